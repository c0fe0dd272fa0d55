//! The URDF corpus (issue 36, "What must be shown"): every robot description of
//! example-robot-data 6.0 that Pinocchio 4.1 loads as a fixed-base model
//! (testdata/urdf_corpus/robots/, dynamics-only copies; alex_description's three, whose licence
//! allows no derivative, are read from `$EXAMPLE_ROBOT_DATA` when it is set) is imported by robosim — as a tree
//! (`import_urdf_tree`, every movable joint a coordinate) and as the chain to a chosen tip
//! (`import_urdf`) — and its forward kinematics, frame Jacobians, RNEA, CRBA, ABA and gravity
//! at random states agree with Pinocchio's (testdata/urdf_corpus/reference.json, written by
//! make_reference.py beside it): poses and Jacobians to 1e-12, dynamics to 1e-10, relative to
//! the largest reference entry (or 1).
//!
//! Joints are matched by name (Pinocchio orders a link's children by joint name, robosim by
//! file order); a continuous joint is one angle in robosim and (cos, sin) in Pinocchio, the
//! reference stores the angle. Robots robosim refuses on purpose are listed in [`REFUSED`]
//! with the reason (docs/file-io.md, URDF section); any other refusal or disagreement fails.

use crate::common::{floats, matrix, rel_err};
use nalgebra::{DMatrix, Matrix4};
use robosim_dynamics::{Data, Model, aba, crba, gravity, rnea};
use robosim_kinematics::fk::forward;
use robosim_kinematics::jacobian::{Frame, jacobian};
use robosim_urdf::urdf_import::{UrdfRobot, import_urdf_str, import_urdf_tree_str};
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

const POSE_TOL: f64 = 1e-12;
const DYN_TOL: f64 = 1e-10;

/// The robots robosim refuses deliberately, with the start of the refusal's message.
const REFUSED: &[(&str, &str)] = &[(
    // body's principal moments −0.021, 0.05, 0.099 kg·m²: not a rigid body; 0.22 of the
    // robot's largest moment, far beyond NEGATIVE_INERTIA_TOLERANCE
    "romeo_description/romeo_laas_small.urdf",
    "inertia is not positive semi-definite",
)];

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/urdf_corpus")
}

/// What one robot's comparison found: the worst relative error per quantity, and failures.
#[derive(Default)]
struct Findings {
    worst: HashMap<&'static str, f64>,
    failures: Vec<String>,
}

impl Findings {
    fn check(&mut self, robot: &str, what: &'static str, got: &[f64], want: &[f64], tol: f64) {
        let e = rel_err(got, want);
        let w = self.worst.entry(what).or_insert(0.0);
        *w = w.max(e);
        if !(e <= tol) {
            self.failures.push(format!(
                "{robot}: {what} differs by {e:e} (relative; tol {tol:e})"
            ));
        }
    }
}

/// The reference's values (Pinocchio's joint order) in robosim's q order.
fn permuted(values: &[f64], perm: &[usize]) -> Vec<f64> {
    let mut out = vec![0.0; values.len()];
    for (k, &i) in perm.iter().enumerate() {
        out[i] = values[k];
    }
    out
}

fn index_of(robot: &UrdfRobot) -> HashMap<&str, usize> {
    robot
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| (j.name.as_str(), i))
        .collect()
}

fn as_vec(m: &Matrix4<f64>) -> Vec<f64> {
    (0..4)
        .flat_map(|i| (0..4).map(move |j| m[(i, j)]))
        .collect()
}

fn flat(m: &DMatrix<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

/// The whole tree: dynamics against the full model, the chosen leaves' frames through chains
/// imported to them.
fn check_tree(name: &str, text: &str, path: &Path, rob: &Value, f: &mut Findings) {
    let tree = match import_urdf_tree_str(text, path) {
        Ok(t) => t,
        Err(e) => return f.failures.push(format!("{name}: tree import: {e}")),
    };
    let names: Vec<&str> = rob["joints"]
        .as_array()
        .expect("joints")
        .iter()
        .map(|n| n.as_str().expect("name"))
        .collect();
    let index = index_of(&tree);
    if tree.robot.dof() != names.len() {
        return f.failures.push(format!(
            "{name}: tree has {} joints, Pinocchio {}",
            tree.robot.dof(),
            names.len()
        ));
    }
    let Some(perm) = names
        .iter()
        .map(|n| index.get(n).copied())
        .collect::<Option<Vec<usize>>>()
    else {
        return f.failures.push(format!("{name}: joint names differ"));
    };
    let model = match Model::new(&tree.robot) {
        Ok(m) => m,
        Err(e) => return f.failures.push(format!("{name}: dynamics model: {e}")),
    };
    let mut data = Data::new(&model);
    let mut chains: HashMap<String, Option<UrdfRobot>> = HashMap::new();
    for s in rob["tree"].as_array().expect("samples") {
        let [q, v, a, tau] = ["q", "v", "a", "tau"].map(|k| permuted(&floats(&s[k]), &perm));
        let want = |k: &str| permuted(&floats(&s[k]), &perm);
        match rnea(&model, &mut data, &q, &v, &a) {
            Ok(t) => f.check(name, "tree rnea", t.as_slice(), &want("rnea"), DYN_TOL),
            Err(e) => f.failures.push(format!("{name}: rnea: {e}")),
        }
        match gravity(&model, &mut data, &q) {
            Ok(t) => f.check(
                name,
                "tree gravity",
                t.as_slice(),
                &want("gravity"),
                DYN_TOL,
            ),
            Err(e) => f.failures.push(format!("{name}: gravity: {e}")),
        }
        if s["aba"].is_null() {
            // Pinocchio's ABA is not finite: a joint with no inertia about its axis
            if aba(&model, &mut data, &q, &v, &tau).is_ok() {
                f.failures
                    .push(format!("{name}: aba answers where Pinocchio's is singular"));
            }
        } else {
            match aba(&model, &mut data, &q, &v, &tau) {
                Ok(t) => f.check(name, "tree aba", t.as_slice(), &want("aba"), DYN_TOL),
                Err(e) => f.failures.push(format!("{name}: aba: {e}")),
            }
        }
        if !s["M"].is_null() {
            let m_ref = matrix(&s["M"]);
            let n = perm.len();
            let m_want = DMatrix::from_fn(n, n, |i, j| {
                let (pi, pj) = (
                    perm.iter().position(|&x| x == i).expect("perm"),
                    perm.iter().position(|&x| x == j).expect("perm"),
                );
                m_ref[(pi, pj)]
            });
            match crba(&model, &mut data, &q) {
                Ok(m) => f.check(name, "tree M", &flat(m), &flat(&m_want), DYN_TOL),
                Err(e) => f.failures.push(format!("{name}: crba: {e}")),
            }
        }
        let frames = s["frames"].as_object().expect("frames");
        for (link, fr) in frames {
            let chain = chains.entry(link.clone()).or_insert_with(|| {
                match import_urdf_str(text, path, Some(link)) {
                    Ok(c) => Some(c),
                    Err(e) => {
                        f.failures.push(format!("{name}: chain to {link:?}: {e}"));
                        None
                    }
                }
            });
            let Some(chain) = chain else { continue };
            let qc: Vec<f64> = chain
                .joints
                .iter()
                .map(|j| q[index[j.name.as_str()]])
                .collect();
            let pose = forward(&chain.robot, &qc);
            let want_pose: Vec<f64> = flat(&matrix(&fr["pose"]));
            f.check(name, "frame pose", &as_vec(&pose), &want_pose, POSE_TOL);
            let jac = jacobian(&chain.robot, &qc, Frame::Base);
            let cols = fr["jacobian"].as_object().expect("columns");
            let mut got = Vec::new();
            let mut want = Vec::new();
            for (i, j) in chain.joints.iter().enumerate() {
                let col = cols.get(&j.name).map_or(vec![0.0; 6], floats);
                want.extend(col);
                got.extend((0..6).map(|r| jac[(r, i)]));
            }
            if cols
                .keys()
                .any(|k| !chain.joints.iter().any(|j| &j.name == k))
            {
                f.failures.push(format!(
                    "{name}: frame {link:?}: a supporting joint is off the chain"
                ));
            }
            f.check(name, "frame jacobian", &got, &want, POSE_TOL);
        }
    }
}

/// The chain to the tip: FK, Jacobian and dynamics against Pinocchio's reduced model.
fn check_chain(name: &str, text: &str, path: &Path, rob: &Value, f: &mut Findings) {
    let tip = rob["tip"].as_str().expect("tip");
    let chain = match import_urdf_str(text, path, Some(tip)) {
        Ok(c) => c,
        Err(e) => return f.failures.push(format!("{name}: chain to {tip:?}: {e}")),
    };
    let want_names: Vec<&str> = rob["chain"]["joints"]
        .as_array()
        .expect("joints")
        .iter()
        .map(|n| n.as_str().expect("name"))
        .collect();
    let got_names: Vec<&str> = chain.joints.iter().map(|j| j.name.as_str()).collect();
    if got_names != want_names {
        return f.failures.push(format!(
            "{name}: chain joints {got_names:?}, Pinocchio {want_names:?}"
        ));
    }
    let model = match Model::new(&chain.robot) {
        Ok(m) => m,
        Err(e) => {
            return f
                .failures
                .push(format!("{name}: chain dynamics model: {e}"));
        }
    };
    let mut data = Data::new(&model);
    for s in rob["chain"]["samples"].as_array().expect("samples") {
        let [q, v, a, tau] = ["q", "v", "a", "tau"].map(|k| floats(&s[k]));
        let pose = forward(&chain.robot, &q);
        f.check(
            name,
            "chain tip",
            &as_vec(&pose),
            &flat(&matrix(&s["tip"])),
            POSE_TOL,
        );
        let jac = jacobian(&chain.robot, &q, Frame::Base);
        let jac = DMatrix::from_fn(6, q.len(), |i, j| jac[(i, j)]);
        let want_jac = matrix(&s["jacobian"]);
        if want_jac.ncols() == q.len() {
            f.check(
                name,
                "chain jacobian",
                &flat(&jac),
                &flat(&want_jac),
                POSE_TOL,
            );
        }
        match rnea(&model, &mut data, &q, &v, &a) {
            Ok(t) => f.check(
                name,
                "chain rnea",
                t.as_slice(),
                &floats(&s["rnea"]),
                DYN_TOL,
            ),
            Err(e) => f.failures.push(format!("{name}: chain rnea: {e}")),
        }
        match crba(&model, &mut data, &q) {
            Ok(m) => f.check(name, "chain M", &flat(m), &flat(&matrix(&s["M"])), DYN_TOL),
            Err(e) => f.failures.push(format!("{name}: chain crba: {e}")),
        }
        if !s["aba"].is_null() {
            match aba(&model, &mut data, &q, &v, &tau) {
                Ok(t) => f.check(name, "chain aba", t.as_slice(), &floats(&s["aba"]), DYN_TOL),
                Err(e) => f.failures.push(format!("{name}: chain aba: {e}")),
            }
        }
    }
}

#[test]
fn every_robot_pinocchio_loads_is_imported_with_pinocchios_numbers() {
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("reference.json")).expect("reference.json"),
    )
    .expect("JSON");
    let robots = reference["robots"].as_array().expect("robots");
    assert_eq!(
        robots.len(),
        68,
        "example-robot-data 6.0: 68 URDFs Pinocchio loads"
    );
    let mut f = Findings::default();
    let (mut loaded, mut refused_as_documented, mut compared, mut not_vendored) = (0, 0, 0, 0);
    for rob in robots {
        let name = rob["file"].as_str().expect("file");
        let path = if rob["vendored"].as_bool() == Some(true) {
            dir().join("robots").join(name)
        } else {
            // a licence that allows no derivative (alex_description, CC-BY-NC-ND-4.0): the
            // installed original, when EXAMPLE_ROBOT_DATA names example-robot-data's robots/
            match std::env::var_os("EXAMPLE_ROBOT_DATA") {
                Some(d) => PathBuf::from(d).join(rob["source"].as_str().expect("source")),
                None => {
                    not_vendored += 1;
                    continue;
                }
            }
        };
        let text = std::fs::read_to_string(&path).expect("the URDF");
        let documented = REFUSED.iter().find(|(n, _)| *n == name);
        match (import_urdf_tree_str(&text, &path), documented) {
            (Err(e), Some((_, why))) if e.to_string().contains(why) => {
                refused_as_documented += 1;
                continue;
            }
            (Err(e), _) => {
                f.failures.push(format!("{name}: refused: {e}"));
                continue;
            }
            (Ok(_), Some(_)) => {
                f.failures
                    .push(format!("{name}: imported, but REFUSED says it is refused"));
                continue;
            }
            (Ok(_), None) => loaded += 1,
        }
        if rob.get("tree").is_some() {
            compared += 1;
            check_tree(name, &text, &path, rob, &mut f);
            check_chain(name, &text, &path, rob, &mut f);
        }
    }
    let mut worst: Vec<_> = f.worst.iter().collect();
    worst.sort_by(|a, b| a.0.cmp(b.0));
    eprintln!(
        "URDF corpus: {loaded} of {} imported ({refused_as_documented} refused as documented, {not_vendored} not vendored: licence), {compared} compared with Pinocchio {}; worst relative errors {worst:?}",
        robots.len(),
        reference["pinocchio"]
    );
    assert!(
        f.failures.is_empty(),
        "{} failures:\n{}",
        f.failures.len(),
        f.failures.join("\n")
    );
    assert_eq!(loaded + refused_as_documented + not_vendored, robots.len());
}
