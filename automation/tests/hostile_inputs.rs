//! Issue 34, item 13: a fault model path that is a FIFO or a device is refused by name, without
//! blocking on the open or reading `/dev/zero` until memory runs out.

use robosim_automation::model::load_model;
use std::sync::mpsc;
use std::time::Duration;

#[test]
fn issue_34_a_fault_model_that_is_a_fifo_or_a_device_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("station.hpm");
    let status = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("run mkfifo");
    assert!(status.success());
    let path = fifo.display().to_string();
    let (tx, rx) = mpsc::channel();
    let p = path.clone();
    std::thread::spawn(move || {
        let _ = tx.send(load_model(&p));
    });
    // A reader blocked in the FIFO's open (the bug) fails here instead of hanging the test.
    let e = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the read of a FIFO blocked")
        .expect_err("a FIFO is refused");
    assert_eq!((e.file.as_str(), e.line), (path.as_str(), 0));
    assert!(
        e.message
            .ends_with("it is a FIFO (named pipe), not a regular file"),
        "{}",
        e.message
    );
    let e = load_model("/dev/zero").expect_err("a device is refused");
    assert!(
        e.message.contains("it is a character device"),
        "{}",
        e.message
    );
}
