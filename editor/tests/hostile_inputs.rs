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
        .expect_err("a FIFO is refused")
        .to_string();
    assert_eq!(
        e,
        format!(
            "cannot read a ROBOSIM program `{}`: it is a FIFO (named pipe), not a regular file",
            fifo.display()
        )
    );
    let e = robosim_editor::cli::lang_run(std::path::Path::new("/dev/zero"), dir.path())
        .expect_err("a device is refused")
        .to_string();
    assert!(e.contains("it is a character device"), "{e}");
}

#[test]
fn issue_34_lang_run_refuses_to_write_a_link_file_through_a_symlink() {
    let dir = tempfile::tempdir().expect("tempdir");
    let prg = dir.path().join("box.rsim");
    std::fs::write(
        &prg,
        "UNITS M\nBOX X=0.1, Y=0.1, Z=0.4\nSTORE-LINK C.L1\nEND\n",
    )
    .expect("write");
    let out = dir.path().join("out");
    std::fs::create_dir(&out).expect("mkdir");
    let precious = dir.path().join("precious");
    std::fs::write(&precious, "keep me").expect("write");
    std::os::unix::fs::symlink(&precious, out.join("C.L1")).expect("symlink");
    let e = robosim_editor::cli::lang_run(&prg, &out)
        .expect_err("a link is refused")
        .to_string();
    assert!(
        e.starts_with(&format!(
            "cannot write `{}`: it is a symbolic link",
            out.join("C.L1").display()
        )),
        "{e}"
    );
    assert_eq!(std::fs::read_to_string(&precious).expect("read"), "keep me");
    assert!(
        std::fs::symlink_metadata(out.join("C.L1"))
            .expect("link")
            .file_type()
            .is_symlink()
    );
    assert_eq!(
        std::fs::read_dir(&out).expect("dir").count(),
        1,
        "nothing written"
    );
}
