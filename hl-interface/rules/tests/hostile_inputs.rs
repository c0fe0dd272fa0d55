//! Issue 34, item 13: a rule file that is a FIFO or a device is refused by name before CLIPS
//! opens it (its open of a FIFO blocks; it reads `/dev/zero` until memory runs out).

#[cfg(clips)]
use robosim_rules::clips::{Clips, ClipsError};
#[cfg(clips)]
use std::path::Path;

#[test]
fn issue_34_a_rule_file_that_is_a_fifo_or_a_device_is_refused_before_clips_opens_it() {
    if robosim_rules::skipped_without_clips("issue_34_a_rule_file_that_is_a_fifo…") {
        return;
    }
    #[cfg(clips)]
    fifo_and_device_refused();
}

#[cfg(clips)]
fn fifo_and_device_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("rules.clp");
    let status = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("run mkfifo");
    assert!(status.success());
    let mut clips = Clips::new(Box::new(|_| Ok(0))).expect("environment");
    // Without the check CLIPS's fopen of the FIFO blocks here for ever.
    match clips.load(&fifo) {
        Err(ClipsError::Input(e)) => assert!(
            e.to_string()
                .ends_with("it is a FIFO (named pipe), not a regular file"),
            "{e}"
        ),
        other => panic!("{other:?}"),
    }
    match clips.load(Path::new("/dev/zero")) {
        Err(ClipsError::Input(e)) => {
            assert!(e.to_string().contains("it is a character device"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    // A regular rule file still loads.
    let ok = dir.path().join("ok.clp");
    std::fs::write(&ok, "(deffacts start (ready))\n").expect("write");
    clips.load(&ok).expect("a regular rule file loads");
}
