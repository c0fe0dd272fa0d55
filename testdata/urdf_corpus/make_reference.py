#!/usr/bin/env python3
"""The URDF corpus (issue 36): every robot description of example-robot-data that Pinocchio
loads as a fixed-base model, with reference values computed by Pinocchio, for robosim's corpus
test (core/dynamics/tests/urdf_corpus.rs).

Run with the peer venv (pin 4.1, example-robot-data 6.0; `pip install pin example-robot-data`
elsewhere), from the repository root:
    /work/peers-venv/bin/python testdata/urdf_corpus/make_reference.py

What it writes:
  * robots/<package>/<file>.urdf — a dynamics-only copy of each URDF Pinocchio loads:
    <visual>, <collision>, <gazebo>, <transmission>, <sensor> elements and comments removed
    (neither Pinocchio's Model nor robosim's kinematics and dynamics reads them; the copy is
    ~45 % of the original's size). The script checks that Pinocchio's model of the copy and of
    the original agree (RNEA, CRBA at a random state, to 1e-13).
    Licences per package (package.xml) in LICENSES.md, written by this script; alex_description
    (CC-BY-NC-ND-4.0: no derivatives) is not vendored, its reference values are (the test
    reads the original when EXAMPLE_ROBOT_DATA names the installed robots/ directory).
  * reference.json — {"pinocchio", "example_robot_data", "seed", "refused": {file: reason},
    "robots": [...]}, per robot:
      file, nq, nv, joints (Pinocchio's movable joint names, in Pinocchio's order), continuous
      (per joint: a revolute joint without limits, Pinocchio's RUB joint with q = (cos, sin)),
      tip (the chosen tip link) and
      tree: the FULL model (pin.buildModel(file), no root joint: the root link is the world;
        <mimic> joints independent, Pinocchio's default), samples, per sample q (one angle per
        joint, robosim's layout), v, a, tau, and
          rnea = RNEA(q, v, a), aba = ABA(q, v, tau), gravity = g(q), M = CRBA (first sample
          only, both triangles, row-major; large robots make it large);
          frames: {link: {pose: 4x4 oMf, jacobian: {joint name: 6-column}}} for up to three
            leaf links (the tip first): oMf of the link's body frame and its frame Jacobian in
            LOCAL_WORLD_ALIGNED (rows vx vy vz wx wy wz; robosim's Frame::Base), only the
            non-zero columns (the joints supporting the link), keyed by joint name.
      chain: the serial chain root -> tip as robosim's import_urdf(tip) makes it: every joint
        not supporting the tip locked at q = 0 (Pinocchio's reduced model; see chain_samples),
        joints (names, root to tip), per sample q, v, a, tau, tip pose, tip Jacobian
        (LOCAL_WORLD_ALIGNED, 6 x n), rnea, M, aba (M^-1 (tau - h), solved by numpy).
q: uniform within the position limits (a continuous joint or one without limits: [-pi, pi]),
v and a uniform in [-1, 1], tau uniform in [-5, 5]; numpy default_rng(36). Gravity
(0, 0, -9.81).

The tip: the leaf link with the most movable joints on its path from the root whose path has
no <mimic> joint (robosim refuses a mimic joint on an imported chain), ties broken by file
order.
"""
import glob
import json
import os
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
SHARE = os.environ.get("EXAMPLE_ROBOT_DATA") or os.path.join(
    sys.prefix, "lib", f"python{sys.version_info[0]}.{sys.version_info[1]}", "site-packages",
    "cmeel.prefix", "share", "example-robot-data", "robots")
# example-robot-data's package.xml: the licence of each robot package. CC-BY-NC-ND (alex) allows
# no derivative: not vendored (its reference values are written; the test reads the original
# when EXAMPLE_ROBOT_DATA names the installed robots/ directory).
LICENCE = {}
for spdx, pkgs in {
    "Apache-2.0": "alexander centauro hyq panda so_arm tiago tiago_pro",
    "BSD-2-Clause": "borinot hextilt human simple_humanoid",
    "BSD-3-Clause": "anymal_b_simple anymal_c_simple bolt finger_edu g1 solo xarm",
    "BSD": "allegro_hand asr_twodof baxter double_pendulum hector kinova pr2 romeo ur",
    "CC-BY-NC-ND-4.0": "alex",
    "CC-BY-SA-4.0": "icub",
    "ISC": "cassie",
    "MPL-2.0": "z1",
}.items():
    for p in pkgs.split():
        LICENCE[p + "_description"] = spdx
LICENCE["talos_data"] = "BSD-3-Clause"
for p in ("a1", "b1", "go1", "go2", "laikago", "quadruped", "iris"):
    LICENCE.setdefault(p + "_description", "BSD-2-Clause (no licence of its own in package.xml: the project's)")
NOT_VENDORED = {"CC-BY-NC-ND-4.0"}
DROP = {"visual", "collision", "gazebo", "transmission", "sensor"}
SAMPLES = 2
rng = np.random.default_rng(36)


def strip(text, rel, licence):
    root = ET.fromstring(text)
    for parent in root.iter():
        for c in list(parent):
            if c.tag in DROP or (isinstance(c.tag, str) and c.tag.split("}")[-1] in DROP):
                parent.remove(c)
    ET.indent(root, "  ")
    note = (f"<!-- Dynamics-only copy of example-robot-data 6.0 robots/{rel} (licence: {licence}; "
            "see LICENSES.md): its visual, collision, gazebo, transmission and sensor elements "
            "and its comments removed by testdata/urdf_corpus/make_reference.py. -->\n")
    return '<?xml version="1.0"?>\n' + note + ET.tostring(root, encoding="unicode") + "\n"


def mat(m):
    return [[float(x) for x in row] for row in np.asarray(m)]


def vec(v):
    return [float(x) for x in np.asarray(v).ravel()]


def finite_or_none(x):
    """ABA of a model whose mass matrix is singular (a joint with no inertia outboard of it
    about its axis) is not finite: None (robosim refuses it, DynamicsError::SingularInertia)."""
    x = np.asarray(x)
    return vec(x) if np.all(np.isfinite(x)) and np.abs(x).max() < 1e12 else None


def is_continuous(model, jid):
    return model.joints[jid].nq == 2 and model.joints[jid].nv == 1


def to_q(model, theta):
    """Pinocchio's q from one value per movable joint (robosim's layout)."""
    q = pin.neutral(model)
    for k, jid in enumerate(range(1, model.njoints)):
        j = model.joints[jid]
        if is_continuous(model, jid):
            q[j.idx_q] = np.cos(theta[k])
            q[j.idx_q + 1] = np.sin(theta[k])
        else:
            q[j.idx_q] = theta[k]
    return q


def sample_theta(model):
    th = []
    for jid in range(1, model.njoints):
        j = model.joints[jid]
        if is_continuous(model, jid):
            th.append(rng.uniform(-np.pi, np.pi))
            continue
        lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi - lo > 1e6:
            lo, hi = -np.pi, np.pi
        th.append(rng.uniform(lo, hi))
    return np.array(th)


def urdf_tree(text):
    """links in file order, joint records (name, type, parent, child, mimic)."""
    root = ET.fromstring(text)
    links = [l.get("name") for l in root.findall("link")]
    joints = []
    for j in root.findall("joint"):
        joints.append({
            "name": j.get("name"), "type": j.get("type"),
            "parent": j.find("parent").get("link"), "child": j.find("child").get("link"),
            "mimic": j.find("mimic") is not None})
    return links, joints


def choose_tip(text):
    links, joints = urdf_tree(text)
    parent_joint = {j["child"]: j for j in joints}
    has_child = {j["parent"] for j in joints}
    leaves = [l for l in links if l not in has_child]
    best, free = None, []
    for l in leaves:
        n, mimic, x = 0, False, l
        while x in parent_joint:
            j = parent_joint[x]
            if j["type"] != "fixed":
                n += 1
                mimic |= j["mimic"]
            x = j["parent"]
        if mimic:
            continue
        free.append(l)
        if best is None or n > best[0]:
            best = (n, l)
    return best[1] if best else links[0], free


def frame_data(model, data, link, names):
    fid = model.getFrameId(link)
    pose = data.oMf[fid].homogeneous
    jac = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    cols = {}
    for jid in range(1, model.njoints):
        c = jac[:, model.joints[jid].idx_v]
        if np.any(c != 0.0):
            cols[names[jid - 1]] = vec(c)
    return {"pose": mat(pose), "jacobian": cols}


def tree_samples(model, tip, leaves):
    data = model.createData()
    names = [model.names[j] for j in range(1, model.njoints)]
    frame_links = [tip] + [l for l in leaves if l != tip][:2]
    out = []
    for s in range(SAMPLES):
        th = sample_theta(model)
        q = to_q(model, th)
        v = rng.uniform(-1, 1, model.nv)
        a = rng.uniform(-1, 1, model.nv)
        tau = rng.uniform(-5, 5, model.nv)
        rec = {"q": vec(th), "v": vec(v), "a": vec(a), "tau": vec(tau)}
        rec["rnea"] = vec(pin.rnea(model, data, q, v, a))
        rec["aba"] = finite_or_none(pin.aba(model, data, q, v, tau))
        rec["gravity"] = vec(pin.computeGeneralizedGravity(model, data, q))
        if s == 0:
            M = pin.crba(model, data, q)
            rec["M"] = mat(np.triu(M) + np.triu(M, 1).T)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        rec["frames"] = {l: frame_data(model, data, l, names) for l in frame_links
                         if model.existFrame(l)}
        out.append(rec)
    return out


def chain_samples(model, tip):
    """The chain root -> tip with every other joint locked at 0: Pinocchio's reduced model
    (pin.buildReducedModel), computed on the full model instead (buildReducedModel refuses
    models where a joint and a link share a name): q, v, a of the off-chain joints 0, so
    RNEA's chain entries, M's chain block, the tip frame and its Jacobian's chain columns are
    the reduced model's, and ABA is M_cc^-1 (tau - h_c)."""
    data = model.createData()
    fid = model.getFrameId(tip)
    chain = [j for j in model.supports[model.frames[fid].parentJoint] if j > 0]
    idx = [model.joints[j].idx_v for j in chain]
    names = [model.names[j] for j in chain]
    out = []
    for _ in range(SAMPLES):
        th_full = np.zeros(model.nv)
        sub = sample_theta(model)
        pos = {jid: k for k, jid in enumerate(range(1, model.njoints))}
        for j in chain:
            th_full[pos[j]] = sub[pos[j]]
        th = np.array([th_full[pos[j]] for j in chain])
        q = to_q(model, th_full)
        n = len(chain)
        v, a, tau = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-5, 5, n)
        vf, af = np.zeros(model.nv), np.zeros(model.nv)
        vf[idx], af[idx] = v, a
        rec = {"q": vec(th), "v": vec(v), "a": vec(a), "tau": vec(tau)}
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        rec["tip"] = mat(data.oMf[fid].homogeneous)
        rec["jacobian"] = mat(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:, idx])
        rec["rnea"] = vec(pin.rnea(model, data, q, vf, af)[idx])
        M = pin.crba(model, data, q)
        M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(idx, idx)]
        rec["M"] = mat(M)
        h = pin.rnea(model, data, q, vf, np.zeros(model.nv))[idx]
        rec["aba"] = finite_or_none(np.linalg.solve(M, tau - h)
                                    if np.linalg.cond(M) < 1e12 else np.full(n, np.nan))
        out.append(rec)
    return {"joints": names, "samples": out}


def same_model(a, b):
    if (a.nq, a.nv) != (b.nq, b.nv):
        return False
    da, db = a.createData(), b.createData()
    q = pin.randomConfiguration(a, -np.ones(a.nq), np.ones(a.nq)) if a.nq else pin.neutral(a)
    v = np.linspace(-1, 1, a.nv)
    ok = np.allclose(pin.rnea(a, da, q, v, v), pin.rnea(b, db, q, v, v), rtol=0, atol=1e-13)
    return ok and np.allclose(pin.crba(a, da, q), pin.crba(b, db, q), rtol=0, atol=1e-13)


def main():
    files = sorted(glob.glob(os.path.join(SHARE, "*", "*", "*.urdf")))
    out = {"pinocchio": pin.__version__, "example_robot_data": "6.0.0", "seed": 36,
           "samples": SAMPLES, "refused": {}, "robots": []}
    total_in, total_out = 0, 0
    for path in files:
        rel = os.path.relpath(path, SHARE)
        key = rel.replace("/urdf/", "/").replace("/robots/", "/")
        try:
            model = pin.buildModelFromUrdf(path)
        except Exception as e:  # Pinocchio refuses it: not part of the corpus
            out["refused"][rel] = re.sub(r"\s+", " ", str(e)).strip()
            continue
        text = open(path).read()
        pkg = rel.split("/")[0]
        licence = LICENCE.get(pkg, "BSD-2-Clause (no licence of its own in package.xml: the project's)")
        small = strip(text, rel, licence)
        vendored = licence not in NOT_VENDORED
        if vendored:
            dest = os.path.join(HERE, "robots", key)
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            with open(dest, "w") as f:
                f.write(small)
            lic = os.path.join(os.path.dirname(path), "..", "LICENSE")
            if os.path.exists(lic):
                with open(lic) as src, open(os.path.join(os.path.dirname(dest), "LICENSE"), "w") as f:
                    f.write(src.read())
        if not same_model(model, pin.buildModelFromXML(small)):
            raise SystemExit(f"{rel}: the dynamics-only copy is not the same model")
        total_in += len(text)
        total_out += len(small)
        tip, leaves = choose_tip(text)
        rob = {"file": key, "source": rel, "licence": licence, "vendored": vendored,
               "nq": model.nq, "nv": model.nv,
               "joints": [model.names[j] for j in range(1, model.njoints)],
               "continuous": [is_continuous(model, j) for j in range(1, model.njoints)],
               "tip": tip}
        if model.nv > 0:
            rob["tree"] = tree_samples(model, tip, leaves)
            rob["chain"] = chain_samples(model, tip)
        out["robots"].append(rob)
    out["bytes"] = {"original": total_in, "dynamics_only": total_out}
    with open(os.path.join(HERE, "LICENSES.md"), "w") as f:
        f.write("# Licences of the vendored robot descriptions\n\n"
                "From example-robot-data 6.0 (https://github.com/gepetto/example-robot-data, "
                "package.xml; the project itself: BSD-2-Clause, LICENSE-example-robot-data). "
                "Each file under robots/ is a dynamics-only copy (see its first comment and "
                "make_reference.py). Packages with their own LICENSE file have it beside the "
                "copy.\n\n| file | licence | vendored |\n|---|---|---|\n")
        for rob in out["robots"]:
            f.write(f"| {rob['source']} | {rob['licence']} | "
                    f"{'yes' if rob['vendored'] else 'no: the licence allows no derivative'} |\n")
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        json.dump(out, f, separators=(",", ":"))
    print(f"{len(out['robots'])} robots, {len(out['refused'])} refused by Pinocchio; "
          f"URDF {total_in} -> {total_out} bytes")


if __name__ == "__main__":
    main()
