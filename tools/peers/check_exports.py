#!/usr/bin/env python3
"""Exports that other tools open (issue 36 item 4): every library robot (puma560, stanford,
weld_positioner) and two URDF-imported robots (example-robot-data's UR5, and the Panda's arm
to panda_hand, fingers held) exported by `robosim export urdf` and `robosim export mjcf`, loaded
with no flags by MuJoCo (MjModel.from_xml_path) and Pinocchio (buildModelFromUrdf /
buildModelFromMJCF), and at 5 random q (numpy default_rng seed 4; q uniform in the limits,
[-pi, pi] when unbounded) the tool pose and the mass matrix compared with robosim's own
(`robosim query`, ops fk and mass_matrix, on the library robot by name or the URDF by path).

URDF has no element for the motor (rotor) inertia that robosim adds to M's diagonal (MuJoCo's
armature, which the MJCF export writes): the URDF rows compare the peer's M plus the exported
armature with robosim's M.

Tool pose: in MuJoCo-from-MJCF and Pinocchio the body / frame `<robot>_tool`; in MuJoCo-from-URDF
(which fuses fixed links away) the last link's pose times the file's `<robot>_tool_joint` origin.
Printed: the largest |difference| of the tool pose (m, and rotation-matrix entries) and of M
relative to max(1, max|M|), per robot, format and peer, as a Markdown table (docs/file-io.md).

Also writes testdata/mjcf/exports/<robot>.xml (the exported MJCF) and
testdata/mjcf/exports/mujoco_exports.json (MuJoCo's tool pose and M on them at the same q),
which file-io/tests/mjcf_export.rs re-imports and compares.

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
# name, query robot, library file text (None: the standard library)
ROBOTS = [
    ("puma560", "puma560", None),
    ("stanford", "stanford", None),
    ("weld_positioner", "weld_positioner", None),
    ("ur5", {"urdf": UR5, "tip": "tool0"}, f'robot ur5 from_urdf "{UR5}" {{ tip: "tool0" }}\n'),
    ("panda_arm", {"urdf": PANDA, "tip": "panda_hand"},
     f'robot panda_arm from_urdf "{PANDA}" {{ tip: "panda_hand" }}\n'),
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


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(4)
    tmp = tempfile.mkdtemp()
    rows = []
    reference = {"mujoco": mujoco.__version__, "pinocchio": pin.__version__, "robots": []}
    for name, qrobot, lib in ROBOTS:
        extra = []
        if lib is not None:
            f = os.path.join(tmp, f"{name}.rsl")
            with open(f, "w") as fh:
                fh.write(lib)
            extra = ["--library", f]
        urdf = os.path.join(tmp, f"{name}.urdf")
        xml = os.path.join(OUT, f"{name}.xml")
        notes = run(["export", "urdf", urdf, "--scene", name] + extra)
        notes += run(["export", "mjcf", xml, "--scene", name] + extra)
        for line in notes.splitlines():
            if "note:" in line:
                print(f"{name}: {line.strip()}")
        mj_mjcf = mujoco.MjModel.from_xml_path(xml)
        mj_urdf = mujoco.MjModel.from_xml_path(urdf)
        pin_urdf = pin.buildModelFromUrdf(urdf)
        pin_mjcf = pin.buildModelFromMJCF(xml)
        n = mj_mjcf.nq
        lo, hi = mj_mjcf.jnt_range[:, 0], mj_mjcf.jnt_range[:, 1]
        limited = mj_mjcf.jnt_limited.astype(bool)
        offset = urdf_tool_offset(urdf, name)
        last = f"{name}_link{n}"
        samples, err = [], {}
        for _ in range(5):
            q = np.where(limited, rng.uniform(lo, hi), rng.uniform(-np.pi, np.pi, n))
            fk, mm = query([
                {"id": 1, "op": "fk", "robot": qrobot, "q": q.tolist()},
                {"id": 2, "op": "mass_matrix", "robot": qrobot, "q": q.tolist()},
            ])
            ours_x, ours_m = np.array(fk["pose"]), np.array(mm["mass_matrix"])
            got = {
                ("MJCF", "MuJoCo"): mj_values(mj_mjcf, q, lambda m, d: mj_pose(m, d, f"{name}_tool")),
                ("URDF", "MuJoCo"): mj_values(mj_urdf, q, lambda m, d: mj_pose(m, d, last) @ offset),
                ("URDF", "Pinocchio"): pin_values(pin_urdf, q, f"{name}_tool"),
                ("MJCF", "Pinocchio"): pin_values(pin_mjcf, q, f"{name}_tool"),
            }
            armature = np.diag(mj_mjcf.dof_armature)
            for k, (x, M) in got.items():
                if k[0] == "URDF":
                    # URDF has no motor inertia: compared with it added back (see the docstring).
                    M = M + armature
                ex = np.abs(x - ours_x).max()
                em = np.abs(M - ours_m).max() / max(1.0, np.abs(ours_m).max())
                a, b = err.get(k, (0.0, 0.0))
                err[k] = (max(a, ex), max(b, em))
            x, M = got[("MJCF", "MuJoCo")]
            samples.append({"q": q.tolist(), "tool": x.tolist(), "mass_matrix": M.tolist()})
        reference["robots"].append({"name": name, "file": f"{name}.xml", "nq": int(n),
                                    "samples": samples})
        for (fmt, peer), (ex, em) in sorted(err.items()):
            rows.append(f"| {name} | {fmt} | {peer} | {ex:.1e} | {em:.1e} |")
    with open(os.path.join(OUT, "mujoco_exports.json"), "w") as f:
        json.dump(reference, f, indent=1)
        f.write("\n")
    shutil.rmtree(tmp)
    print(f"MuJoCo {mujoco.__version__}, Pinocchio {pin.__version__}")
    print("| robot | exported as | loaded by | tool pose max abs diff | M max diff / max(1, max abs M) |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
