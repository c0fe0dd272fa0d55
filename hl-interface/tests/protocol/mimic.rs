//! Mimic joints through the query protocol (issue 36): `{"urdf": PATH, "mimic": true}` answers
//! fk, jacobian, id, gravity, mass_matrix and fd over the reduced coordinates with Pinocchio
//! 4.1's mimic model — the same reference the core's dynamics test reads
//! (testdata/urdf_corpus/mimic_reference.json, made by make_mimic_reference.py beside it:
//! Panda, Baxter, PR2, TIAGo Pro with `mimic=True`, Romeo and TALOS through the full model and
//! G in closed form). Poses and Jacobians to 1e-12, dynamics to 1e-10, relative to the largest
//! reference entry (or 1).

use nalgebra::DMatrix;
use serde_json::{Value, json};
use std::path::PathBuf;

const POSE_TOL: f64 = 1e-12;
const DYN_TOL: f64 = 1e-10;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf_corpus")
}

/// The request through the protocol's whole dispatcher (the mimic hook sits in front of the
/// kinematics and dynamics ops): the answer object, or the refusal's message.
fn ask(req: Value) -> Result<Value, String> {
    let line: Value =
        serde_json::from_str(&robosim_hl_interface::handle_request(&req)).expect("a JSON line");
    if line["ok"] == true {
        Ok(line)
    } else {
        Err(line["error"].to_string())
    }
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("array, got {v}"))
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn rows(v: &Value) -> DMatrix<f64> {
    let r: Vec<Vec<f64>> = v.as_array().expect("rows").iter().map(nums).collect();
    let (n, m) = (r.len(), r.first().map_or(0, Vec::len));
    DMatrix::from_fn(n, m, |i, j| r[i][j])
}

fn flat(m: &DMatrix<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

fn rel_err(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    got.iter()
        .zip(want)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn mimic_requests_answer_pinocchios_mimic_model() {
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("mimic_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let robots = reference["robots"].as_array().expect("robots");
    assert_eq!(robots.len(), 6);
    let mut failures = Vec::new();
    let (mut samples, mut frames_checked, mut tool_jacobians) = (0, 0, 0);
    for rob in robots {
        let name = rob["file"].as_str().expect("file");
        let path = dir().join("robots").join(name);
        let robot = json!({"urdf": path.to_str().expect("UTF-8 path"), "mimic": true});
        // The reduced coordinates' names, robosim's order, from the answer's `coordinates` and
        // the file's joints; Pinocchio's order → robosim's.
        let tree = robosim_file_io::urdf_import::import_urdf_tree(&path).expect("imports");
        let s0 = &rob["samples"][0];
        let probe = ask(json!({"op": "gravity", "robot": robot, "q": s0["q"]}))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let coordinates: Vec<usize> = probe["coordinates"]
            .as_array()
            .expect("coordinates")
            .iter()
            .map(|c| c.as_u64().expect("index") as usize)
            .collect();
        let free: Vec<&str> = coordinates
            .iter()
            .map(|&i| tree.joints[i].name.as_str())
            .collect();
        let perm: Vec<usize> = rob["free"]
            .as_array()
            .expect("free")
            .iter()
            .map(|n| {
                let n = n.as_str().expect("name");
                free.iter()
                    .position(|f| *f == n)
                    .unwrap_or_else(|| panic!("{name}: {n} is not a free coordinate"))
            })
            .collect();
        assert_eq!(perm.len(), free.len(), "{name}: reduced coordinates");
        assert!(
            free.len() < tree.robot.dof(),
            "{name}: the followers are not coordinates"
        );
        let ours = |x: &[f64]| {
            let mut out = vec![0.0; x.len()];
            for (k, &i) in perm.iter().enumerate() {
                out[i] = x[k];
            }
            out
        };
        let back = |i: usize| perm.iter().position(|&x| x == i).expect("perm");
        let mut check = |what: &str, got: &[f64], want: &[f64], tol: f64| {
            let e = rel_err(got, want);
            if e.is_nan() || e > tol {
                failures.push(format!("{name}: {what} differs by {e:e}"));
            }
        };
        for s in rob["samples"].as_array().expect("samples") {
            samples += 1;
            let [q, v, a, tau] = ["q", "v", "a", "tau"].map(|k| ours(&nums(&s[k])));
            let want = |k: &str| ours(&nums(&s[k]));
            let id =
                ask(json!({"op": "id", "robot": robot, "q": q, "qd": v, "qdd": a})).expect("id");
            check("id", &nums(&id["tau"]), &want("rnea"), DYN_TOL);
            let g = ask(json!({"op": "gravity", "robot": robot, "q": q})).expect("gravity");
            check("gravity", &nums(&g["tau"]), &want("gravity"), DYN_TOL);
            let m = ask(json!({"op": "mass_matrix", "robot": robot, "q": q})).expect("M");
            let mr = rows(&s["M"]);
            let m_want = DMatrix::from_fn(mr.nrows(), mr.ncols(), |i, j| mr[(back(i), back(j))]);
            check(
                "mass_matrix",
                &flat(&rows(&m["mass_matrix"])),
                &flat(&m_want),
                DYN_TOL,
            );
            if !s["aba"].is_null() {
                let fd = ask(json!({"op": "fd", "robot": robot, "q": q, "qd": v, "tau": tau}))
                    .expect("fd");
                check("fd", &nums(&fd["qdd"]), &want("aba"), DYN_TOL);
            }
            let fk = ask(json!({"op": "fk", "robot": robot, "q": q, "frames": true})).expect("fk");
            let frames = fk["frames"].as_array().expect("frames");
            let jac = ask(json!({"op": "jacobian", "robot": robot, "q": q})).expect("jacobian");
            let last = tree.joints.last().expect("joints").link.as_str();
            for (link, fr) in s["frames"].as_object().expect("frames") {
                let k = tree
                    .joints
                    .iter()
                    .position(|j| &j.link == link)
                    .expect("a movable joint's child link");
                check(
                    &format!("pose of {link}"),
                    &flat(&rows(&frames[k + 1])),
                    &flat(&rows(&fr["pose"])),
                    POSE_TOL,
                );
                frames_checked += 1;
                if link == last {
                    // the protocol's jacobian is the tool's: the last joint's child link
                    let jr = rows(&fr["jacobian"]);
                    let j_want = DMatrix::from_fn(6, jr.ncols(), |r, c| jr[(r, back(c))]);
                    check(
                        "jacobian",
                        &flat(&rows(&jac["jacobian"])),
                        &flat(&j_want),
                        POSE_TOL,
                    );
                    tool_jacobians += 1;
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(
        samples >= 6 && frames_checked >= 6,
        "{samples} {frames_checked}"
    );
    eprintln!(
        "mimic through the protocol: {samples} samples, {frames_checked} link poses, {tool_jacobians} tool Jacobians against Pinocchio"
    );
}

/// The same Panda without `mimic`: the whole tree is not what `{"urdf": PATH}` reads (the chain
/// to one tip), and a full-length q is refused under `mimic` naming the reduced count; the
/// option is refused on ops that do not take it, and on `passive`.
#[test]
fn mimic_requests_are_refused_where_they_do_not_apply() {
    let path = dir().join("robots/panda_description/panda.urdf");
    let robot = json!({"urdf": path.to_str().expect("UTF-8 path"), "mimic": true});
    let full_q = vec![0.1; 9];
    let e = ask(json!({"op": "gravity", "robot": robot, "q": full_q})).expect_err("9 values");
    assert!(e.to_string().contains("8 reduced"), "{e}");
    let e = ask(
        json!({"op": "ik", "robot": robot, "pose": [[1,0,0,0],[0,1,0,0],[0,0,1,0.5],[0,0,0,1]]}),
    )
    .expect_err("ik");
    assert!(e.to_string().contains("`mimic` is for"), "{e}");
    let q = vec![0.1; 8];
    let e = ask(json!({"op": "id", "robot": robot, "q": q, "qd": q, "qdd": q, "passive": true}))
        .expect_err("passive");
    assert!(e.to_string().contains("passive"), "{e}");
    // A leader's torque carries its follower's: τ_r = Gᵀ τ — gravity on the finger pair.
    let reduced = ask(json!({"op": "id", "robot": robot, "q": q, "qd": q, "qdd": q})).expect("id");
    let coordinates = reduced["coordinates"]
        .as_array()
        .expect("coordinates")
        .len();
    assert_eq!(coordinates, 8);
}
