//! Issue 34, items 6 and 13: the one reader refuses what is not a regular file or is too big,
//! the one writer never replaces a special file.

use robosim_input::{
    FileKind, InputProblem, Limit, OutputProblem, read_file, read_to_string, write_file_atomic,
};
use std::os::unix::fs::FileTypeExt;
use std::path::Path;

fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("run mkfifo");
    assert!(status.success(), "mkfifo {}", path.display());
}

#[test]
fn issue_34_reading_a_fifo_is_refused_without_blocking_on_the_open() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("robot.urdf");
    mkfifo(&fifo);
    // Without the check before the open, this open blocks forever (no writer ever comes).
    let e = read_file(&fifo, "a URDF file", Limit::TEXT).expect_err("a FIFO is refused");
    assert!(
        matches!(e.problem, InputProblem::NotRegular(FileKind::Fifo)),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        format!(
            "cannot read a URDF file `{}`: it is a FIFO (named pipe), not a regular file",
            fifo.display()
        )
    );
}

#[test]
fn issue_34_reading_dev_zero_a_directory_or_a_missing_file_is_refused() {
    let e = read_file(Path::new("/dev/zero"), "a mesh file", Limit::MESH).expect_err("device");
    assert!(
        matches!(e.problem, InputProblem::NotRegular(FileKind::CharDevice)),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .contains("`/dev/zero`: it is a character device"),
        "{e}"
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let e = read_file(dir.path(), "a model file", Limit::MODEL).expect_err("directory");
    assert!(
        matches!(e.problem, InputProblem::NotRegular(FileKind::Directory)),
        "{e:?}"
    );
    let e = read_file(&dir.path().join("nope"), "a model file", Limit::MODEL).expect_err("none");
    assert!(
        matches!(&e.problem, InputProblem::Io(io) if io.kind() == std::io::ErrorKind::NotFound)
    );
}

#[test]
fn issue_34_a_file_one_byte_over_the_limit_is_refused_with_its_size_and_the_limit() {
    let dir = tempfile::tempdir().expect("tempdir");
    let big = dir.path().join("big.stl");
    let f = std::fs::File::create(&big).expect("create");
    f.set_len(4097).expect("set_len");
    drop(f);
    let e = read_file(&big, "a mesh file", Limit::fixed(4096)).expect_err("too large");
    assert_eq!(
        e.problem.to_string(),
        "it is larger than 4 KiB, the limit for a mesh file (it has 4097 bytes)"
    );
    assert_eq!(
        read_file(&big, "a mesh file", Limit::fixed(4097))
            .expect("at the limit")
            .len(),
        4097
    );
    // The default limits name the variable that raises them.
    let text = dir.path().join("t.txt");
    std::fs::write(&text, "é").expect("write");
    assert_eq!(
        read_to_string(&text, "a script", Limit::TEXT).expect("text"),
        "é"
    );
    std::fs::write(&text, [b'a', 0xff]).expect("write");
    let e = read_to_string(&text, "a script", Limit::TEXT).expect_err("not UTF-8");
    assert!(matches!(e.problem, InputProblem::NotUtf8(1)), "{e:?}");
    let limit = Limit {
        default: 1,
        env: Some("ROBOSIM_TEST_LIMIT_NEVER_SET"),
    };
    let e = read_file(&big, "a mesh file", limit).expect_err("too large");
    assert!(
        e.to_string()
            .ends_with("(it has 4097 bytes; set ROBOSIM_TEST_LIMIT_NEVER_SET to raise the limit)"),
        "{e}"
    );
}

#[test]
fn issue_34_a_symlink_to_a_regular_file_is_read() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("a.txt");
    std::fs::write(&file, "hello").expect("write");
    let link = dir.path().join("b.txt");
    std::os::unix::fs::symlink(&file, &link).expect("symlink");
    assert_eq!(
        read_to_string(&link, "a script", Limit::TEXT).expect("read"),
        "hello"
    );
    let to_dev = dir.path().join("zero");
    std::os::unix::fs::symlink("/dev/zero", &to_dev).expect("symlink");
    let e = read_file(&to_dev, "a script", Limit::TEXT).expect_err("a link to a device");
    assert!(
        matches!(e.problem, InputProblem::NotRegular(FileKind::CharDevice)),
        "{e:?}"
    );
}

#[test]
fn issue_34_save_onto_a_fifo_is_refused_and_the_fifo_stays() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("model.rsm");
    mkfifo(&fifo);
    let e = write_file_atomic(&fifo, b"data").expect_err("a FIFO is refused");
    assert!(
        matches!(e.problem, OutputProblem::NotRegular(FileKind::Fifo)),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .starts_with(&format!("cannot write `{}`: it is a FIFO", fifo.display()))
    );
    let t = std::fs::symlink_metadata(&fifo)
        .expect("still there")
        .file_type();
    assert!(t.is_fifo(), "{t:?}");
    // No temporary file is left behind.
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 1);
}

#[test]
fn issue_34_save_onto_a_character_device_is_refused_and_the_device_stays() {
    let dev = Path::new("/dev/null");
    let e = write_file_atomic(dev, b"data").expect_err("a device is refused");
    assert!(
        matches!(e.problem, OutputProblem::NotRegular(FileKind::CharDevice)),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .contains("`/dev/null`: it is a character device"),
        "{e}"
    );
    let t = std::fs::symlink_metadata(dev)
        .expect("still there")
        .file_type();
    assert!(
        t.is_char_device(),
        "/dev/null is no longer a character device: {t:?}"
    );
}

#[test]
fn issue_34_save_through_a_symlink_is_refused_and_neither_link_nor_target_changes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let target = dir.path().join("real.json");
    std::fs::write(&target, "old").expect("write");
    let link = dir.path().join("model.json");
    std::os::unix::fs::symlink(&target, &link).expect("symlink");
    let e = write_file_atomic(&link, b"new").expect_err("a link is refused");
    match &e.problem {
        OutputProblem::Symlink { target: t } => assert_eq!(t, &target),
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("it is a symbolic link (to `"), "{e}");
    assert!(
        std::fs::symlink_metadata(&link)
            .expect("link")
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read_to_string(&target).expect("target"), "old");
}

#[test]
fn issue_34_save_replaces_a_regular_file_whole_and_keeps_its_mode() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("out.csv");
    write_file_atomic(&path, b"first").expect("new file");
    assert_eq!(std::fs::read(&path).expect("read"), b"first");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).expect("chmod");
    write_file_atomic(&path, b"second").expect("replace");
    assert_eq!(std::fs::read(&path).expect("read"), b"second");
    let mode = std::fs::metadata(&path).expect("meta").permissions().mode() & 0o7777;
    assert_eq!(mode, 0o640);
    assert_eq!(
        std::fs::read_dir(dir.path()).expect("dir").count(),
        1,
        "no temporary left"
    );
    // A directory is never replaced.
    let e = write_file_atomic(Path::new("/"), b"x").expect_err("no file name");
    assert!(
        matches!(
            e.problem,
            OutputProblem::NotRegular(FileKind::Directory) | OutputProblem::NoFileName
        ),
        "{e:?}"
    );
}
