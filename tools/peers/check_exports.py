#!/usr/bin/env python3
"""Exports that other tools open (issue 36 item 4): every robot of the standard library
(LIBRARY below) and imported robots (example-robot-data's UR5; the Panda's arm to panda_hand,
fingers held; the whole Panda, its finger a <mimic> joint; PR2 with ten <mimic> joints; a chain
of testdata/ball/ball_tree.xml with two ball joints) exported by `robosim export urdf` and
`robosim export mjcf`, loaded with no flags by MuJoCo (MjModel.from_xml_path) and Pinocchio
(buildModelFromUrdf / buildModelFromMJCF), and at 5 random q (numpy default_rng seed 4; q
uniform in the limits, [-pi, pi] when unbounded, a ball a random unit quaternion) the tool pose
and the mass matrix compared with robosim's own (`robosim query`, ops fk and mass_matrix, on the
library robot by name or the file by path).

Mimic robots are compared over the reduced coordinates (robosim's `"mimic": true`): MuJoCo's and
Pinocchio's full models at q = phi(q_r) with M_r = G^T M G (G from the <equality><joint> MuJoCo
read from the MJCF), and Pinocchio's mimic model (buildModelFromUrdf(path, mimic=True)) at q_r;
the script checks that MuJoCo read every equality from both files. A ball joint: robosim's q is
x y z w, MuJoCo's qpos w x y z; URDF has none, so that robot's URDF export must be refused.

URDF has no element for the motor (rotor) inertia that robosim adds to M's diagonal (MuJoCo's
armature, which the MJCF export writes): the URDF rows compare the peer's M plus the exported
armature with robosim's M.

Tool pose: in MuJoCo-from-MJCF and Pinocchio the body / frame `<robot>_tool`; in MuJoCo-from-URDF
(which fuses fixed links away) the last link's pose times the file's `<robot>_tool_joint` origin.
Printed: the largest |difference| of the tool pose (m, and rotation-matrix entries) and of M
relative to max(1, max|M|), per robot, format and peer, as a Markdown table (docs/file-io.md).

Geometry (the exports' <visual>/<collision> and MJCF geoms, meshes as STL files beside the
file): MuJoCo loads the MJCF with its meshes and has one geom per <geom> written; Pinocchio's
buildGeomFromUrdf loads the collision and visual models with one object per <collision> /
<visual>, with no package_dirs (the URDF names its meshes by absolute path, `--mesh-paths
absolute`, the default; a `--mesh-paths relative` export is checked to open in MuJoCo and, with
package_dirs=[folder] only, in Pinocchio 4.1, which resolves a relative name only there). At the same
q, each collision shape's placement in Pinocchio (URDF) is compared with the same shape's geom
in MuJoCo (MJCF): primitives by their pose, meshes by the world box of their vertices (MuJoCo
re-centres a mesh on its centre of mass; STL stores f32). Printed: the largest difference per
robot (second table).

Also writes testdata/mjcf/exports/<robot>.xml (the exported MJCF) and
testdata/mjcf/exports/mujoco_exports.json (MuJoCo's tool pose and M on them at the same q),
which file-io/tests/mjcf_export.rs re-imports and compares.

A floating robot (issue 36): Solo-12 (testdata/urdf_corpus, vendored from example-robot-data)
imported into a session with `robosim import urdf --floating`, exported by `robosim export urdf`
and `robosim export mjcf --robot solo`, loaded by MuJoCo (MJCF: the base body's <freejoint/>)
and Pinocchio (URDF: buildModelFromUrdf(path, JointModelFreeFlyer()), the ROS convention of a
floating base, the base link as the file's root link; MJCF: buildModelFromMJCF), and at 5
random q (seed 5: a random position and unit quaternion, joints in their limits) the tool pose
and M compared with robosim's on `{"urdf": SOLO, "floating": true}`. MuJoCo's free joint has
qpos x y z qw qx qy qz (robosim's and Pinocchio's: x y z qx qy qz qw) and its linear velocity
in the world frame (theirs: in the base frame), so its M is compared as T^T M T, T = diag(R, I).
MuJoCo's URDF loader welds a URDF's root link to the world, so the URDF export of a floating
robot is checked in Pinocchio only. Written: testdata/mjcf/exports/solo_floating.json (the
robosim q, MuJoCo's tool pose and T^T M T at each sample).

Usage (MuJoCo 4.0, pin 4.1 in /work/peers-venv; target/debug/robosim built):
    /work/peers-venv/bin/python tools/peers/check_exports.py
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
ROBOSIM = os.path.join(ROOT, "target", "debug", "robosim")
OUT = os.path.join(ROOT, "testdata", "mjcf", "exports")
UR5 = os.path.join(ROOT, "testdata", "urdf", "ur5_robot.urdf")
PANDA = os.path.join(ROOT, "testdata", "urdf", "panda.urdf")
PR2 = os.path.join(ROOT, "testdata", "urdf_corpus", "robots", "pr2_description", "pr2.urdf")
BALL = os.path.join(ROOT, "testdata", "ball", "ball_tree.xml")
# The robots of the standard library (library-space/stdlib), all with their default parameters.
LIBRARY = ["puma560", "stanford", "weld_positioner", "panda", "weld_arm", "weld_study_positioner",
           "surgical_positioner", "station_servicer", "station_solar_structure",
           "station_outboard_assembly"]
# The robots whose exported MJCF and MuJoCo values are kept in testdata (the Rust tests read them).
REFERENCE = ["puma560", "stanford", "weld_positioner", "ur5", "panda_arm", "panda_mimic",
             "ball_chain"]
# name, query robot, library file text (None: the standard library), kind: None, "mimic" (the
# robot has <mimic> joints: compared over the reduced coordinates) or "ball" (ball joints: MJCF
# only, URDF has none and its export must refuse the robot)
ROBOTS = [(name, name, None, None) for name in LIBRARY] + [
    ("ur5", {"urdf": UR5, "tip": "tool0"}, f'robot ur5 from_urdf "{UR5}" {{ tip: "tool0" }}\n',
     None),
    ("panda_arm", {"urdf": PANDA, "tip": "panda_hand"},
     f'robot panda_arm from_urdf "{PANDA}" {{ tip: "panda_hand" }}\n', None),
    ("panda_mimic", {"urdf": PANDA, "mimic": True}, f'robot panda_mimic from_urdf "{PANDA}"\n',
     "mimic"),
    ("pr2_mimic", {"urdf": PR2, "mimic": True}, f'robot pr2_mimic from_urdf "{PR2}"\n', "mimic"),
    ("ball_chain", {"mjcf": BALL, "tip": "finger"},
     f'robot ball_chain from_mjcf "{BALL}" {{ tip: "finger" }}\n', "ball"),
]


def run(args):
    r = subprocess.run([ROBOSIM] + args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"robosim {' '.join(args)}: {r.stderr}")
    return r.stdout


def query(reqs):
    text = "\n".join(json.dumps(r) for r in reqs) + "\n"
    r = subprocess.run([ROBOSIM, "query"], input=text, capture_output=True, text=True)
    answers = [json.loads(line) for line in r.stdout.splitlines() if line.strip()]
    for a in answers:
        if not a.get("ok"):
            sys.exit(f"robosim query: {a}")
    return answers


def rpy_matrix(r, p, y):
    return pin.rpy.rpyToMatrix(r, p, y)


def urdf_tool_offset(path, name):
    tree = ET.parse(path)
    for j in tree.getroot().iter("joint"):
        if j.get("name") == f"{name}_tool_joint":
            o = j.find("origin")
            xyz = [float(v) for v in o.get("xyz").split()]
            rpy = [float(v) for v in o.get("rpy").split()]
            m = np.eye(4)
            m[:3, :3] = rpy_matrix(*rpy)
            m[:3, 3] = xyz
            return m
    sys.exit(f"{path}: no {name}_tool_joint")


def mj_pose(m, d, body):
    b = m.body(body).id
    x = np.eye(4)
    x[:3, :3] = d.xmat[b].reshape(3, 3)
    x[:3, 3] = d.xpos[b]
    return x


def mj_values(m, q, tool):
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    mujoco.mj_crb(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return tool(m, d), M


def pin_values(model, q, frame):
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    x = data.oMf[model.getFrameId(frame)].homogeneous
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    return x, M


def read_stl(path):
    """Vertices (n, 3) of a binary STL."""
    with open(path, "rb") as f:
        data = f.read()
    n = int.from_bytes(data[80:84], "little")
    rec = np.frombuffer(data[84:84 + 50 * n], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                               ("a", "<u2")]))
    return rec["v"].reshape(-1, 3).astype(float)


def collision_names(urdf):
    """Pinocchio's collision object names (link name + index in the link) -> the <collision>
    name and its mesh file (None for a primitive)."""
    out = {}
    for link in ET.parse(urdf).getroot().iter("link"):
        for k, c in enumerate(link.findall("collision")):
            mesh = c.find("geometry/mesh")
            out[f"{link.get('name')}_{k}"] = (c.get("name"), None if mesh is None else mesh.get("filename"))
    return out


def geometry_check(name, urdf, xml, pin_model, mj_model, q_list):
    """Loads the geometry in both peers, checks the counts, and compares the placements of the
    collision shapes (see the docstring). Returns (collision, visual, geoms, pose diff, box diff).
    Without a URDF (a robot URDF cannot say), MuJoCo's geoms only."""
    n_geom = len(list(ET.parse(xml).getroot().find("worldbody").iter("geom")))
    if urdf is None:
        if mj_model.ngeom != n_geom:
            sys.exit(f"{name}: MuJoCo has {mj_model.ngeom} geoms, the MJCF {n_geom}")
        return None, None, n_geom, None, None
    folder = os.path.dirname(urdf)
    tree = ET.parse(urdf).getroot()
    n_col = len(list(tree.iter("collision")))
    n_vis = len(list(tree.iter("visual")))
    # no package_dirs: the export names its meshes by absolute path (--mesh-paths absolute)
    col = pin.buildGeomFromUrdf(pin_model, urdf, pin.GeometryType.COLLISION)
    vis = pin.buildGeomFromUrdf(pin_model, urdf, pin.GeometryType.VISUAL)
    if col.ngeoms != n_col or vis.ngeoms != n_vis:
        sys.exit(f"{name}: Pinocchio loaded {col.ngeoms} collision / {vis.ngeoms} visual objects, "
                 f"the URDF has {n_col} / {n_vis}")
    if mj_model.ngeom != n_geom:
        sys.exit(f"{name}: MuJoCo has {mj_model.ngeom} geoms, the MJCF {n_geom}")
    names = collision_names(urdf)
    pose_err, box_err = None, None  # None: no such shape
    d = mujoco.MjData(mj_model)
    for q in q_list:
        data = pin_model.createData()
        gdata = col.createData()
        pin.updateGeometryPlacements(pin_model, data, col, gdata,
                                     pin_q(pin_model, q, name, range(len(q))))
        d.qpos[:] = np.asarray(q, dtype=float)
        mujoco.mj_kinematics(mj_model, d)
        for i, obj in enumerate(col.geometryObjects):
            shape, mesh = names[obj.name]
            g = mj_model.geom(f"{shape}_collision").id
            X = gdata.oMg[i].homogeneous
            if mesh is None:
                Y = np.eye(4)
                Y[:3, :3] = d.geom_xmat[g].reshape(3, 3)
                Y[:3, 3] = d.geom_xpos[g]
                pose_err = max(pose_err or 0.0, np.abs(X - Y).max())
            else:
                v = read_stl(os.path.join(folder, mesh))
                ours = v @ X[:3, :3].T + X[:3, 3]
                m = mj_model.geom_dataid[g]
                a, n = mj_model.mesh_vertadr[m], mj_model.mesh_vertnum[m]
                mv = mj_model.mesh_vert[a:a + n]
                theirs = mv @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
                box_err = max(box_err or 0.0, np.abs(ours.min(0) - theirs.min(0)).max(),
                              np.abs(ours.max(0) - theirs.max(0)).max())
    return n_col, n_vis, n_geom, pose_err, box_err


SOLO = os.path.join(ROOT, "testdata", "urdf_corpus", "robots", "solo_description", "solo12.urdf")


def pin_permuted(model, q, frame, name="solo", root_nq=7, root_nv=6):
    """pin_values with robosim's joint order: Pinocchio numbers a URDF tree's joints in its own
    traversal order (a link's child joints by name: solo_joint10 before solo_joint4), so q and
    M are mapped joint by joint through the names robosim wrote (`<name>_joint<k>`)."""
    n = len(q) - root_nq
    iq = list(range(root_nq)) + [model.joints[model.getJointId(f"{name}_joint{k + 1}")].idx_q
                                 for k in range(n)]
    iv = list(range(root_nv)) + [model.joints[model.getJointId(f"{name}_joint{k + 1}")].idx_v
                                 for k in range(n)]
    qp = np.zeros(model.nq)
    qp[iq] = q
    x, M = pin_values(model, qp, frame)
    return x, M[np.ix_(iv, iv)]


def floating_check(rows):
    """Solo-12 floating through a session's export (see the module docstring)."""
    home = tempfile.mkdtemp()
    env = dict(os.environ, ROBOSIM_HOME=home)
    session = f"peersfloat{os.getpid()}"

    def rs(args):
        r = subprocess.run([ROBOSIM] + args + ["--session", session], env=env,
                           capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"robosim {' '.join(args)}: {r.stderr}")
        return r.stdout

    urdf, xml = os.path.join(home, "solo.urdf"), os.path.join(home, "solo.xml")
    rs(["up", "demo"])
    try:
        rs(["import", "urdf", SOLO, "--floating", "--as", "solo"])
        notes = rs(["export", "urdf", urdf, "--robot", "solo"])
        notes += rs(["export", "mjcf", xml, "--robot", "solo"])
    finally:
        rs(["down"])
    if "base placement is not written" in notes:
        sys.exit(f"solo: the session placed the robot off the identity: {notes}")
    for line in notes.splitlines():
        if "note:" in line:
            print(f"solo (floating): {line.strip()}")
    mj = mujoco.MjModel.from_xml_path(xml)
    pin_urdf = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    pin_mjcf = pin.buildModelFromMJCF(xml)
    assert (mj.nq, mj.nv, pin_urdf.nq, pin_urdf.nv, pin_mjcf.nq) == (19, 18, 19, 18, 19)
    rng = np.random.default_rng(5)
    lo, hi = mj.jnt_range[1:, 0], mj.jnt_range[1:, 1]
    limited = mj.jnt_limited[1:].astype(bool)
    robot = {"urdf": SOLO, "floating": True}
    err, samples = {}, []
    for _ in range(5):
        quat = rng.normal(size=4)
        quat /= np.linalg.norm(quat)  # x y z w
        joints = np.where(limited, rng.uniform(lo, hi), rng.uniform(-np.pi, np.pi, 12))
        q = np.concatenate([rng.uniform(-1, 1, 3), quat, joints])
        fk, mm = query([
            {"id": 1, "op": "fk", "robot": robot, "q": q.tolist()},
            {"id": 2, "op": "mass_matrix", "robot": robot, "q": q.tolist()},
        ])
        ours_x, ours_m = np.array(fk["pose"]), np.array(mm["mass_matrix"])
        qpos = np.concatenate([q[:3], [quat[3]], quat[:3], joints])
        x_mj, m_mj = mj_values(mj, qpos, lambda m, d: mj_pose(m, d, "solo_tool"))
        t = np.eye(18)
        t[:3, :3] = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
        m_mj = t.T @ m_mj @ t
        got = {
            ("MJCF", "MuJoCo"): (x_mj, m_mj),
            ("URDF", "Pinocchio"): pin_permuted(pin_urdf, q, "solo_tool"),
            ("MJCF", "Pinocchio"): pin_permuted(pin_mjcf, q, "solo_tool"),
        }
        for k, (x, M) in got.items():
            ex = np.abs(x - ours_x).max()
            em = np.abs(M - ours_m).max() / max(1.0, np.abs(ours_m).max())
            a, b = err.get(k, (0.0, 0.0))
            err[k] = (max(a, ex), max(b, em))
        samples.append({"q": q.tolist(), "tool": x_mj.tolist(), "mass_matrix": m_mj.tolist()})
    with open(os.path.join(OUT, "solo_floating.json"), "w") as f:
        json.dump({"mujoco": mujoco.__version__, "pinocchio": pin.__version__,
                   "robot": "testdata/urdf_corpus/robots/solo_description/solo12.urdf, floating",
                   "layout": "q: robosim/Pinocchio (x y z qx qy qz qw, joints); mass_matrix: "
                             "MuJoCo's, as T^T M T in robosim's velocity layout",
                   "samples": samples}, f, indent=1)
        f.write("\n")
    shutil.rmtree(home)
    for (fmt, peer), (ex, em) in sorted(err.items()):
        rows.append(f"| solo (floating) | {fmt} | {peer} | {ex:.1e} | {em:.1e} |")


def mimic_map(mj, name):
    """The coupling MuJoCo read from the MJCF export's <equality><joint>: (free joint indices,
    a function reduced q -> full q, G). Joint k of MuJoCo is robosim's joint k (hinges and
    slides only: a mimic robot has no ball joint)."""
    n = mj.njnt
    rel = {}
    for e in range(mj.neq):
        assert mj.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT
        a0, a1 = mj.eq_data[e][0], mj.eq_data[e][1]
        rel[int(mj.eq_obj1id[e])] = (int(mj.eq_obj2id[e]), a1, a0)  # leader (-1: none), m, c
    free = [k for k in range(n) if k not in rel]
    G = np.zeros((n, len(free)))
    for i, k in enumerate(free):
        G[k, i] = 1.0
    for f, (l, m, c) in rel.items():
        if l >= 0:
            G[f, free.index(l)] = m

    def expand(qr):
        q = np.zeros(n)
        q[free] = qr
        for f, (l, m, c) in rel.items():
            q[f] = m * (q[l] if l >= 0 else 0.0) + c
        return q
    return free, expand, G


def pin_q(model, q, name, joints):
    """Pinocchio's q of robosim's q over `joints` (see pin_by_name)."""
    qp = pin.neutral(model)
    for k, v in zip(joints, q):
        j = model.joints[model.getJointId(f"{name}_joint{k + 1}")]
        if j.nq == 2:
            qp[j.idx_q:j.idx_q + 2] = [np.cos(v), np.sin(v)]
        else:
            qp[j.idx_q] = v
    return qp


def pin_by_name(model, q, frame, name, joints):
    """pin_values with robosim's joint order: q[k] is joint `joints[k]` (robosim's index), mapped
    into Pinocchio's q by the joint names robosim wrote (`<name>_joint<k+1>`): Pinocchio numbers a
    URDF tree's joints in its own traversal order; a continuous joint (URDF `continuous`,
    Pinocchio's nq = 2) gets cos, sin of the angle. Returns the frame's pose and M over `joints`."""
    ids = [model.getJointId(f"{name}_joint{k + 1}") for k in joints]
    iv = [model.joints[i].idx_v for i in ids]
    x, M = pin_values(model, pin_q(model, q, name, joints), frame)
    return x, M[np.ix_(iv, iv)]


def sample_q(mj, rng, free=None):
    """A random q at MuJoCo's joints (or only at `free`): hinge and slide uniform in their range
    ([-pi, pi] when unbounded), a ball a uniformly random unit quaternion. Returns (robosim q,
    MuJoCo qpos): a ball is x y z w in robosim's q, w x y z in qpos."""
    ours, qpos = [], []
    for k in (range(mj.njnt) if free is None else free):
        if mj.jnt_type[k] == mujoco.mjtJoint.mjJNT_BALL:
            quat = rng.normal(size=4)
            quat /= np.linalg.norm(quat)  # x y z w
            ours += list(quat)
            qpos += [quat[3], quat[0], quat[1], quat[2]]
        else:
            lo, hi = mj.jnt_range[k]
            v = rng.uniform(lo, hi) if mj.jnt_limited[k] else rng.uniform(-np.pi, np.pi)
            ours.append(v)
            qpos.append(v)
    return np.array(ours), np.array(qpos)


def relative_mesh_check(name, lib):
    """A URDF exported with --mesh-paths relative (the folder can be moved): MuJoCo opens it with
    no flags; Pinocchio 4.1 finds the meshes only with package_dirs=[the folder]."""
    tmp = tempfile.mkdtemp()
    f = os.path.join(tmp, f"{name}.rsl")
    with open(f, "w") as fh:
        fh.write(lib)
    urdf = os.path.join(tmp, f"{name}.urdf")
    run(["export", "urdf", urdf, "--scene", name, "--library", f, "--mesh-paths", "relative"])
    mj = mujoco.MjModel.from_xml_path(urdf)
    model = pin.buildModelFromUrdf(urdf)
    try:
        pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.COLLISION)
        without = "opens"
    except ValueError as e:
        without = f"refuses ({str(e).strip()})"
    col = pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.COLLISION, package_dirs=[tmp])
    shutil.rmtree(tmp)
    return (f"{name}, --mesh-paths relative: MuJoCo opens it ({mj.nmesh} meshes); Pinocchio "
            f"without package_dirs {without}; with package_dirs=[folder] {col.ngeoms} objects")


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(4)
    tmp = tempfile.mkdtemp()
    rows = []
    geo_rows = []
    reference = {"mujoco": mujoco.__version__, "pinocchio": pin.__version__, "robots": []}
    for name, qrobot, lib, kind in ROBOTS:
        extra = []
        if lib is not None:
            f = os.path.join(tmp, f"{name}.rsl")
            with open(f, "w") as fh:
                fh.write(lib)
            extra = ["--library", f]
        urdf = os.path.join(tmp, f"{name}.urdf")
        # beside its meshes; copied into testdata (text only) for the REFERENCE robots
        xml = os.path.join(tmp, f"{name}.xml")
        notes = run(["export", "mjcf", xml, "--scene", name] + extra)
        if kind == "ball":
            r = subprocess.run([ROBOSIM, "export", "urdf", urdf, "--scene", name] + extra,
                               capture_output=True, text=True)
            if r.returncode == 0 or "ball (spherical) joint" not in r.stderr:
                sys.exit(f"{name}: the URDF export of a ball joint was not refused: {r.stderr}")
            print(f"{name}: URDF export refused as it must be: {r.stderr.strip()}")
            urdf = None
        else:
            notes += run(["export", "urdf", urdf, "--scene", name] + extra)
        for line in notes.splitlines():
            if "note:" in line:
                print(f"{name}: {line.strip()}")
        mj_mjcf = mujoco.MjModel.from_xml_path(xml)
        pin_mjcf = pin.buildModelFromMJCF(xml)
        if urdf is not None:
            mj_urdf = mujoco.MjModel.from_xml_path(urdf)
            pin_urdf = pin.buildModelFromUrdf(urdf)
            offset = urdf_tool_offset(urdf, name)
        n = mj_mjcf.njnt
        last = f"{name}_link{n}"
        joints = list(range(n))
        if kind == "mimic":
            free, expand, G = mimic_map(mj_mjcf, name)
            followers = n - len(free)
            pin_mimic = pin.buildModelFromUrdf(urdf, mimic=True)
            # every peer read the coupling: MuJoCo's equalities from both files, Pinocchio's
            # mimic model has one coordinate per free joint
            assert mj_mjcf.neq == followers and mj_urdf.neq == followers, (mj_mjcf.neq, mj_urdf.neq)
            assert pin_mimic.nv == len(free) and pin_urdf.nv == n, (pin_mimic.nv, pin_urdf.nv)
            print(f"{name}: {followers} mimic joints; MuJoCo reads {mj_mjcf.neq} equalities from "
                  f"the MJCF and {mj_urdf.neq} from the URDF, Pinocchio mimic=True nv = "
                  f"{pin_mimic.nv} of {pin_urdf.nv}")
        samples, err = [], {}
        for _ in range(5):
            if kind == "mimic":
                qr, _ = sample_q(mj_mjcf, rng, free)
                q = qpos = expand(qr)
                ask = qr
            else:
                q, qpos = sample_q(mj_mjcf, rng)
                ask = q
            fk, mm = query([
                {"id": 1, "op": "fk", "robot": qrobot, "q": ask.tolist()},
                {"id": 2, "op": "mass_matrix", "robot": qrobot, "q": ask.tolist()},
            ])
            ours_x, ours_m = np.array(fk["pose"]), np.array(mm["mass_matrix"])
            got = {("MJCF", "MuJoCo"): mj_values(mj_mjcf, qpos,
                                                 lambda m, d: mj_pose(m, d, f"{name}_tool"))}
            if kind == "mimic":
                # the full models at q = phi(q_r), M reduced as G^T M G; Pinocchio's mimic model
                # at q_r itself
                got[("URDF", "MuJoCo")] = mj_values(mj_urdf, q,
                                                    lambda m, d: mj_pose(m, d, last) @ offset)
                got[("URDF", "Pinocchio")] = pin_by_name(pin_urdf, q, f"{name}_tool", name, joints)
                got[("MJCF", "Pinocchio")] = pin_by_name(pin_mjcf, q, f"{name}_tool", name, joints)
                full = dict(got)
                got = {k: (x, G.T @ M @ G) for k, (x, M) in full.items()}
                got[("URDF", "Pinocchio mimic=True")] = pin_by_name(pin_mimic, qr, f"{name}_tool",
                                                                    name, free)
            elif kind == "ball":
                got[("MJCF", "Pinocchio")] = pin_values(pin_mjcf, q, f"{name}_tool")
            else:
                got[("URDF", "MuJoCo")] = mj_values(mj_urdf, q,
                                                    lambda m, d: mj_pose(m, d, last) @ offset)
                got[("URDF", "Pinocchio")] = pin_values(pin_urdf, q, f"{name}_tool")
                got[("MJCF", "Pinocchio")] = pin_values(pin_mjcf, q, f"{name}_tool")
            armature = np.diag(mj_mjcf.dof_armature)
            if kind == "mimic":
                armature = G.T @ armature @ G
            for k, (x, M) in got.items():
                if k[0] == "URDF":
                    # URDF has no motor inertia: compared with it added back (see the docstring).
                    M = M + armature
                ex = np.abs(x - ours_x).max()
                em = np.abs(M - ours_m).max() / max(1.0, np.abs(ours_m).max())
                a, b = err.get(k, (0.0, 0.0))
                err[k] = (max(a, ex), max(b, em))
            # the reference: robosim's full q (a ball x y z w) and MuJoCo's full tool pose and M
            x, M = (full if kind == "mimic" else got)[("MJCF", "MuJoCo")]
            samples.append({"q": q.tolist(), "tool": x.tolist(), "mass_matrix": M.tolist()})
        geo_rows.append((name,) + geometry_check(name, urdf, xml, pin_urdf if urdf else None,
                                                  mj_mjcf, [s["q"] for s in samples]))
        if name in REFERENCE:
            shutil.copy(xml, os.path.join(OUT, f"{name}.xml"))
            reference["robots"].append({"name": name, "file": f"{name}.xml", "nq": int(mj_mjcf.nq),
                                        "samples": samples})
        for (fmt, peer), (ex, em) in sorted(err.items()):
            rows.append(f"| {name} | {fmt} | {peer} | {ex:.1e} | {em:.1e} |")
    floating_check(rows)
    relative = relative_mesh_check("panda_arm", {r[0]: r[2] for r in ROBOTS}["panda_arm"])
    with open(os.path.join(OUT, "mujoco_exports.json"), "w") as f:
        json.dump(reference, f, indent=1)
        f.write("\n")
    shutil.rmtree(tmp)
    print(f"MuJoCo {mujoco.__version__}, Pinocchio {pin.__version__}")
    print("| robot | exported as | loaded by | tool pose max abs diff | M max diff / max(1, max abs M) |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))
    print()
    print("| robot | URDF <collision> / <visual> (Pinocchio loads all, no package_dirs) | MJCF geoms "
          "(MuJoCo loads all) | primitive pose max abs diff, Pinocchio vs MuJoCo | mesh world box "
          "max abs diff (m) |")
    print("|---|---|---|---|---|")
    for name, nc, nv, ng, pe, be in geo_rows:
        fmt = lambda e: "-" if e is None else f"{e:.1e}"
        urdf_shapes = "no URDF" if nc is None else f"{nc} / {nv}"
        print(f"| {name} | {urdf_shapes} | {ng} | {fmt(pe)} | {fmt(be)} |")
    print()
    print(relative)


if __name__ == "__main__":
    main()
