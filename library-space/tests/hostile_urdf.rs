//! Issue 34, items 13 and 14, through `robot NAME from_urdf "FILE"`: a URDF nested 20,000 deep
//! is a located error instead of a stack overflow, and a URDF that is a FIFO is refused without
//! blocking the load.

use robosim_library::{Error, Library};
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

fn load_message(dir: &Path, rsl_text: &str) -> String {
    let rsl = dir.join("bad.rsl");
    std::fs::write(&rsl, rsl_text).expect("write");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(Library::load(&rsl).map(|_| ()));
    });
    // A load blocked on a FIFO's open (the bug) fails here instead of hanging the test.
    match rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the load blocked")
    {
        Err(Error::Source(e)) => e.to_string(),
        other => panic!("{other:?}"),
    }
}

#[test]
fn issue_34_from_urdf_of_a_urdf_nested_20000_deep_is_a_located_error() {
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::write(
        tmp.path().join("deep.urdf"),
        format!(
            "<robot name=\"deep\">\n<link name=\"base\"/>\n{}{}</robot>\n",
            "<a>".repeat(20_000),
            "</a>".repeat(20_000)
        ),
    )
    .expect("write");
    let text = load_message(tmp.path(), "robot deep from_urdf \"deep.urdf\"\n");
    assert!(
        text.contains("deep.urdf:3: XML: elements nested more than 512 deep"),
        "{text}"
    );
    assert!(text.contains("bad.rsl:1:"), "{text}");
}

#[test]
fn issue_34_from_urdf_of_a_fifo_is_refused_without_blocking() {
    let tmp = tempfile::tempdir().expect("tmp");
    let status = std::process::Command::new("mkfifo")
        .arg(tmp.path().join("pipe.urdf"))
        .status()
        .expect("run mkfifo");
    assert!(status.success());
    let text = load_message(tmp.path(), "robot p from_urdf \"pipe.urdf\"\n");
    assert!(
        text.contains("it is a FIFO (named pipe), not a regular file"),
        "{text}"
    );
}
