//! `robot NAME from_mjcf "FILE" { tip: …, base: … }` (issue 36 item 5): a Library Space robot
//! read from a MuJoCo MJCF file, with the same semantics as `from_urdf` — the chain from the
//! world to the `tip` body (the MJCF reader's `import_mjcf`), or without `tip` the whole tree
//! (`import_mjcf_tree`); a relative file name is read from the folder of the `.rsl` file that
//! declares it. Files: testdata/mjcf/ur5.xml (MuJoCo's own save of the UR5 URDF) and small MJCFs
//! written next to the `.rsl`.

use nalgebra::Matrix4;
use robosim_kinematics::fk::{forward, link_frames};
use robosim_library::{ErrorKind, Evaluated, Library, Params, RobotModel};
use std::path::{Path, PathBuf};

fn ur5_mjcf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mjcf/ur5.xml")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn robot(lib: &Library, name: &str) -> RobotModel {
    match lib.evaluate(name, &Params::new()).expect("evaluates") {
        Evaluated::Robot(r) => r,
        other => panic!("{name} is not a robot: {other:?}"),
    }
}

fn load_err(text: &str, dir: &Path) -> robosim_library::LibError {
    let rsl = write(dir, "bad.rsl", text);
    match Library::load(&rsl) {
        Err(robosim_library::Error::Source(e)) => e,
        Err(other) => panic!("not a located error: {other}"),
        Ok(_) => panic!("loaded"),
    }
}

/// Two hinges and a slide, a box and a sphere that collide, an actuator and a sensor (not
/// read, noted by the reader).
const SMALL: &str = r#"<mujoco model="small">
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper" pos="0 0 0.3">
      <joint name="shoulder" axis="0 0 1" range="-3 3"/>
      <inertial pos="0.2 0 0" mass="2" diaginertia="0.01 0.02 0.03"/>
      <geom type="box" size="0.2 0.05 0.05" pos="0.2 0 0"/>
      <body name="fore" pos="0.4 0 0">
        <joint name="elbow" axis="0 1 0" range="-2 2"/>
        <inertial pos="0.15 0 0" mass="1" diaginertia="0.004 0.005 0.006"/>
        <geom type="sphere" size="0.05" pos="0.3 0 0"/>
        <body name="hand" pos="0.3 0 0">
          <joint name="slide" type="slide" axis="1 0 0" range="0 0.1"/>
          <inertial pos="0 0 0" mass="0.5" diaginertia="0.001 0.001 0.001"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="shoulder"/></actuator>
  <sensor><jointpos joint="elbow"/></sensor>
</mujoco>
"#;

/// The UR5 as MuJoCo saves it, by absolute name, with a tip and a base: the MJCF reader's
/// chain moved by the base, at every link frame.
#[test]
fn the_ur5_chain_with_a_tip_and_a_base_has_the_mjcf_readers_kinematics() {
    let tmp = tempfile::tempdir().expect("tmp");
    let rsl = write(
        tmp.path(),
        "arms.rsl",
        &format!(
            "robot ur5_arm from_mjcf \"{}\" {{\n\
             \x20   tip: \"wrist_3_link\"\n\
             \x20   base: translate(0.1 m, 0, 0.5 m)\n\
             }}\n",
            ur5_mjcf().display()
        ),
    );
    let lib = Library::load(&rsl).expect("loads");
    let m = robot(&lib, "ur5_arm");
    let u = robosim_urdf::import_mjcf(&ur5_mjcf(), Some("wrist_3_link")).expect("imports");
    assert_eq!(m.robot.dof(), 6);
    assert_eq!(m.robot.name, "ur5_arm");
    assert_eq!(
        m.link_names,
        u.joints.iter().map(|j| j.link.clone()).collect::<Vec<_>>()
    );
    assert_eq!(
        m.link_names.last().map(String::as_str),
        Some("wrist_3_link")
    );
    let base = Matrix4::new_translation(&nalgebra::Vector3::new(0.1, 0.0, 0.5));
    for k in 0..20 {
        let q: Vec<f64> = (0..6)
            .map(|j| ((k * 7 + j * 3) as f64 * 0.37).sin() * 2.0)
            .collect();
        let got = link_frames(&m.robot, &q);
        let want = link_frames(&u.robot, &q);
        for (g, w) in got.iter().zip(&want) {
            assert!(
                ((base * w) - g).abs().max() <= 1e-12,
                "q {q:?}: {g} vs {}",
                base * w
            );
        }
        let d = (forward(&m.robot, &q) - base * forward(&u.robot, &q))
            .abs()
            .max();
        assert!(d <= 1e-12, "tool: {d}");
    }
}

/// A relative name is read from the `.rsl` file's folder; without `tip` the whole tree; the
/// geoms that collide are the bodies' solids.
#[test]
fn a_relative_mjcf_without_tip_is_the_whole_tree_with_its_geoms_as_solids() {
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::create_dir(tmp.path().join("mjcf")).expect("mkdir");
    write(&tmp.path().join("mjcf"), "small.xml", SMALL);
    let lib_dir = tmp.path().join("lib");
    std::fs::create_dir(&lib_dir).expect("mkdir");
    let rsl = write(
        &lib_dir,
        "small.rsl",
        "robot small from_mjcf \"../mjcf/small.xml\" { facets: 16 }\n",
    );
    let lib = Library::load(&rsl).expect("loads");
    let m = robot(&lib, "small");
    let u = robosim_urdf::import_mjcf_tree(&tmp.path().join("mjcf/small.xml")).expect("imports");
    assert_eq!(m.robot.dof(), 3);
    assert_eq!(m.link_names, ["upper", "fore", "hand"]);
    assert_eq!(m.robot.joints, u.robot.joints);
    // base (0), upper (1): the box, fore (2): the sphere, hand (3): none
    let counts: Vec<usize> = m.frames.iter().map(Vec::len).collect();
    assert_eq!(counts, [0, 1, 1, 0]);
    // the reader lists what it did not read
    assert!(
        u.notes.iter().any(|n| n.contains("actuator"))
            && u.notes.iter().any(|n| n.contains("sensor")),
        "{:?}",
        u.notes
    );
}

#[test]
fn a_tip_that_is_not_a_body_names_the_tip_and_the_mjcf() {
    let tmp = tempfile::tempdir().expect("tmp");
    write(tmp.path(), "small.xml", SMALL);
    let e = load_err(
        "robot small from_mjcf \"small.xml\" {\n    tip: \"elbow\"\n}\n",
        tmp.path(),
    );
    assert_eq!(e.kind, ErrorKind::Include);
    assert_eq!((e.location.line, e.location.column), (2, 10), "{e}");
    let text = e.to_string();
    assert!(text.contains("cannot import MJCF"), "{text}");
    assert!(text.contains("tip \"elbow\" is not a <body>"), "{text}");
    assert!(
        text.contains(&format!("{}:", tmp.path().join("small.xml").display())),
        "{text}"
    );
}

#[test]
fn a_malformed_or_missing_mjcf_is_located_and_from_mjcf_is_only_for_robots() {
    let tmp = tempfile::tempdir().expect("tmp");
    let broken = SMALL.replace("range=\"-2 2\"", "range=\"-2 big\"");
    write(tmp.path(), "broken.xml", &broken);
    let e = load_err("robot small from_mjcf \"broken.xml\"\n", tmp.path());
    assert_eq!((e.location.line, e.location.column), (1, 23), "{e}");
    let line = broken
        .lines()
        .position(|l| l.contains("big"))
        .expect("the line")
        + 1;
    let text = e.to_string();
    assert!(text.contains(&format!("broken.xml:{line}:")), "{text}");

    let e = load_err("robot ghost from_mjcf \"nowhere.xml\"\n", tmp.path());
    assert_eq!(e.kind, ErrorKind::Include);
    assert!(e.to_string().contains("cannot read the file"), "{e}");

    write(tmp.path(), "small.xml", SMALL);
    let e = load_err("solid thing from_mjcf \"small.xml\" {}\n", tmp.path());
    assert_eq!(e.kind, ErrorKind::Syntax);
    assert!(
        e.message.contains("a solid cannot be read `from_mjcf`"),
        "{e}"
    );
    let e = load_err("robot small from_mjcf 42\n", tmp.path());
    assert!(
        e.to_string()
            .contains("the MJCF file name in quotes after `from_mjcf`"),
        "{e}"
    );
}
