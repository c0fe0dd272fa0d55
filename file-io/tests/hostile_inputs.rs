//! Issue 34, items 6, 13 and 14, through file-io's entry points: every reader refuses a FIFO
//! (without blocking) and a device, XML nested 20,000 deep is a typed error instead of a stack
//! overflow, and saving never replaces a FIFO, a device or a link's target.

use nalgebra::Matrix4;
use robosim_file_io::dae::read_dae;
use robosim_file_io::linkfile::{DhRow, LinkFile, LinkFileError};
use robosim_file_io::urdf_import::{UrdfErrorKind, import_urdf, import_urdf_str, import_urdf_tree};
use robosim_file_io::{Encoding, FileError, SavedModel, format, import, trajectory};
use robosim_input::{FileKind, InputProblem, MAX_XML_DEPTH, OutputProblem};
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("run mkfifo");
    assert!(status.success(), "mkfifo {}", path.display());
}

/// Runs `read` on another thread: a reader that blocks on the FIFO's open (the bug) fails the
/// test after a minute instead of hanging it.
fn without_blocking<T: Send + 'static>(what: &str, read: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(read());
    });
    rx.recv_timeout(Duration::from_secs(60))
        .unwrap_or_else(|_| panic!("{what}: the read of a FIFO blocked"))
}

fn is_fifo_refusal(e: &robosim_input::InputError, path: &Path) {
    assert!(
        matches!(e.problem, InputProblem::NotRegular(FileKind::Fifo)),
        "{e:?}"
    );
    assert_eq!(e.path, path);
}

fn deep_urdf(depth: usize) -> String {
    format!(
        "<robot name=\"deep\">\n  <link name=\"base\"/>\n{}{}</robot>\n",
        "<a>".repeat(depth),
        "</a>".repeat(depth)
    )
}

#[test]
fn issue_34_urdf_nested_20000_deep_is_a_typed_error_not_a_stack_overflow() {
    let file = Path::new("deep.urdf");
    let e = import_urdf_str(&deep_urdf(20_000), file, None).expect_err("too deep");
    assert!(
        matches!(&e.kind, UrdfErrorKind::TooDeep(d) if d.limit == MAX_XML_DEPTH),
        "{e:?}"
    );
    assert_eq!((e.file.as_path(), e.line), (file, 3));
    assert_eq!(
        e.to_string(),
        format!("deep.urdf:3: XML: elements nested more than {MAX_XML_DEPTH} deep")
    );
    // From a file, through both importers (the query's {"urdf": …} robot is `import_urdf`).
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("deep.urdf");
    std::fs::write(&path, deep_urdf(20_000)).expect("write");
    for e in [
        import_urdf(&path, None).expect_err("chain"),
        import_urdf_tree(&path).expect_err("tree"),
    ] {
        assert!(matches!(e.kind, UrdfErrorKind::TooDeep(_)), "{e:?}");
        assert_eq!(e.file, path);
    }
}

#[test]
fn issue_34_urdf_at_the_depth_limit_parses_on_a_small_stack() {
    // The robot element is level 1: MAX_XML_DEPTH - 1 more levels are the deepest accepted.
    let text = deep_urdf(MAX_XML_DEPTH - 1);
    let parsed = std::thread::Builder::new()
        .stack_size(512 << 10)
        .spawn(move || import_urdf_str(&text, Path::new("d.urdf"), None).map(|r| r.root))
        .expect("spawn")
        .join()
        .expect("no stack overflow at the limit on a 512 KiB stack");
    assert_eq!(parsed.expect("imports"), "base");
    let e = import_urdf_str(&deep_urdf(MAX_XML_DEPTH), Path::new("d.urdf"), None)
        .expect_err("one level more");
    assert!(matches!(e.kind, UrdfErrorKind::TooDeep(_)), "{e:?}");
}

#[test]
fn issue_34_collada_nested_20000_deep_is_a_typed_error_not_a_stack_overflow() {
    let text = format!(
        "<?xml version=\"1.0\"?>\n<COLLADA>\n<library_visual_scenes>{}{}</library_visual_scenes></COLLADA>",
        "<node>".repeat(20_000),
        "</node>".repeat(20_000)
    );
    let e = read_dae(text.as_bytes(), Path::new("deep.dae")).expect_err("too deep");
    assert_eq!((e.line, e.element.as_str()), (3, "XML"), "{e}");
    assert_eq!(
        e.to_string(),
        format!("deep.dae:3: XML: elements nested more than {MAX_XML_DEPTH} deep")
    );
}

#[test]
fn issue_34_a_fifo_is_refused_by_every_file_io_reader_without_blocking() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = |name: &str| {
        let p = dir.path().join(name);
        mkfifo(&p);
        p
    };
    let urdf = fifo("robot.urdf");
    let model = fifo("model.rsm");
    let link = fifo("arm.lnk");
    let mesh = fifo("part.stl");
    let log = fifo("simulator-arm.csv");

    let p = urdf.clone();
    let e = without_blocking("URDF", move || import_urdf_tree(&p)).expect_err("URDF");
    assert!(
        matches!(&e.kind, UrdfErrorKind::Io(m) if m == "it is a FIFO (named pipe), not a regular file"),
        "{e:?}"
    );
    let p = model.clone();
    match without_blocking("model", move || format::read(&p)) {
        Err(FileError::Input(e)) => is_fifo_refusal(&e, &model),
        other => panic!("{other:?}"),
    }
    let p = link.clone();
    match without_blocking("link file", move || LinkFile::read(&p)) {
        Err(LinkFileError::Input(e)) => is_fifo_refusal(&e, &link),
        other => panic!("{other:?}"),
    }
    let p = mesh.clone();
    match without_blocking("mesh", move || import::read_mesh(&p, 1.0)) {
        Err(FileError::Input(e)) => is_fifo_refusal(&e, &mesh),
        other => panic!("{other:?}"),
    }
    let (p, out) = (log.clone(), dir.path().join("t.csv"));
    match without_blocking("log", move || trajectory::export(&p, &[], None, &out)) {
        Err(FileError::Input(e)) => is_fifo_refusal(&e, &log),
        other => panic!("{other:?}"),
    }
}

#[test]
fn issue_34_a_mesh_linked_to_dev_zero_is_refused_not_read_until_memory_runs_out() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mesh = dir.path().join("zero.stl");
    std::os::unix::fs::symlink("/dev/zero", &mesh).expect("symlink");
    match import::read_mesh(&mesh, 1.0) {
        Err(FileError::Input(e)) => {
            assert!(
                matches!(e.problem, InputProblem::NotRegular(FileKind::CharDevice)),
                "{e:?}"
            );
            assert!(e.to_string().contains("it is a character device"), "{e}");
        }
        other => panic!("{other:?}"),
    }
    // The same mesh named by a URDF: refused when the geometry is loaded.
    let urdf = dir.path().join("r.urdf");
    std::fs::write(
        &urdf,
        format!(
            "<robot name=\"r\"><link name=\"base\"><visual><geometry><mesh filename=\"{}\"/></geometry></visual></link></robot>",
            mesh.display()
        ),
    )
    .expect("write");
    let robot = import_urdf_tree(&urdf).expect("the URDF itself imports");
    let visual = robot
        .geometry
        .links
        .get("base")
        .and_then(|l| l.visual.first())
        .expect("one visual");
    let robosim_file_io::urdf_geometry::Geometry::Mesh(m) = &visual.geometry else {
        panic!("{visual:?}")
    };
    let e = m.load_coloured().expect_err("a device is not a mesh");
    assert!(e.to_string().contains("it is a character device"), "{e}");
}

/// What `robosim save` writes with ([`format::write`]): an empty model is enough.
fn save(path: &Path) -> Result<u64, FileError> {
    format::write(&SavedModel::default(), path, Encoding::Binary)
}

fn refused_output(r: Result<u64, FileError>, path: &Path) -> OutputProblem {
    match r {
        Err(FileError::Output(e)) => {
            assert_eq!(e.path, path);
            assert!(
                e.to_string()
                    .starts_with(&format!("cannot write `{}`: it is ", path.display())),
                "{e}"
            );
            e.problem
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn issue_34_save_onto_a_fifo_a_device_or_a_symlink_is_refused_and_leaves_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("model.rsm");
    mkfifo(&fifo);
    assert!(matches!(
        refused_output(save(&fifo), &fifo),
        OutputProblem::NotRegular(FileKind::Fifo)
    ));
    assert!(
        std::fs::symlink_metadata(&fifo)
            .expect("fifo")
            .file_type()
            .is_fifo()
    );

    let null = Path::new("/dev/null");
    assert!(matches!(
        refused_output(save(null), null),
        OutputProblem::NotRegular(FileKind::CharDevice)
    ));
    assert!(
        std::fs::symlink_metadata(null)
            .expect("null")
            .file_type()
            .is_char_device()
    );

    let target = dir.path().join("precious.txt");
    std::fs::write(&target, "keep me").expect("write");
    let link = dir.path().join("model2.rsm");
    std::os::unix::fs::symlink(&target, &link).expect("symlink");
    match refused_output(save(&link), &link) {
        OutputProblem::Symlink { target: t } => assert_eq!(t, target),
        other => panic!("{other:?}"),
    }
    assert!(
        std::fs::symlink_metadata(&link)
            .expect("link")
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read_to_string(&target).expect("target"), "keep me");

    // A link file is written by the same writer.
    let lf = LinkFile {
        dh: DhRow {
            theta: 0.0,
            dz: 0.1,
            da: 0.2,
            alpha: 0.0,
        },
        joint_i: None,
        joint_i1: None,
        ainert: Matrix4::identity(),
        ajnt_i: Matrix4::identity(),
        ajnt_i1: Matrix4::identity(),
        amat: Matrix4::identity(),
        vectors: vec![([0.0; 3], false), ([0.1, 0.0, 0.0], true)],
    };
    match lf.write(&link) {
        Err(LinkFileError::Output(e)) => {
            assert!(matches!(e.problem, OutputProblem::Symlink { .. }))
        }
        other => panic!("{other:?}"),
    }
    let lnk = dir.path().join("arm.lnk");
    lf.write(&lnk).expect("a regular path is written");
    assert_eq!(
        LinkFile::read(&lnk).expect("reads back").vectors,
        lf.vectors
    );
    // And a model at a regular path is written and reads back.
    let ok = dir.path().join("m.rsm");
    save(&ok).expect("a regular path saves");
    assert_eq!(
        format::read(&ok).expect("reads back"),
        SavedModel::default()
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).expect("dir").count(),
        5,
        "no temporary file left behind"
    );
}
