//! Issue 34, item 13: ROBOSIM programs read by the one bounded reader (a FIFO is refused
//! without blocking, a device is not read).

use std::sync::mpsc;
use std::time::Duration;

fn mkfifo(path: &std::path::Path) {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("run mkfifo");
    assert!(status.success());
}

/// `f` on another thread: blocking on a FIFO's open (the bug) fails instead of hanging.
fn without_blocking<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(60))
        .expect("the read of a FIFO blocked")
}

#[test]
fn issue_34_lang_run_of_a_fifo_or_a_device_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("arm.prg");
    mkfifo(&fifo);
    let (p, out) = (fifo.clone(), dir.path().join("out"));
    let e = without_blocking(move || robosim_editor::cli::lang_run(&p, &out))
        .expect_err("a FIFO is refused");
    assert_eq!(
        e,
        format!(
            "cannot read a ROBOSIM program `{}`: it is a FIFO (named pipe), not a regular file",
            fifo.display()
        )
    );
    let e = robosim_editor::cli::lang_run(std::path::Path::new("/dev/zero"), dir.path())
        .expect_err("a device is refused");
    assert!(e.contains("it is a character device"), "{e}");
}
