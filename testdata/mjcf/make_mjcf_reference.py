#!/usr/bin/env python3
"""MJCF files made by MuJoCo itself from example-robot-data URDFs, and MuJoCo's own FK and mass
matrix on them: the reference robosim's MJCF import (core/urdf/src/mjcf.rs) is tested against
(file-io/tests/mjcf_import.rs).

For each robot below, the URDF of example-robot-data (BSD-3-Clause, see
../urdf/LICENSE-example-robot-data) is read as text, its <visual> and <collision> elements are
removed (MuJoCo's URDF loader would otherwise need the mesh files, which are not vendored; the
MJCF therefore has bodies, joints and inertials only, no geoms), a <mujoco><compiler
discardvisual="false" fusestatic="false"/></mujoco> extension is added so that every URDF link
stays a body (fixed joints become bodies without a joint), then

    m = mujoco.MjModel.from_xml_string(urdf)
    mujoco.mj_saveLastXML("<robot>.xml", m)

writes <robot>.xml beside this script. features.xml is hand-written (defaults, degrees, euler
sequences, joint anchors, inertia from geoms) and sampled the same way. That file is loaded again (MjModel.from_xml_path) and, at
10 random q (numpy default_rng seed 36; q uniform in the joint range when limited, in [-pi, pi]
otherwise), mj_kinematics + mj_crb give per body its xpos and xquat (w x y z, world frame) and
mj_fullM the nv x nv mass matrix (armature is 0 in these files). Written to mujoco_reference.json:
{"mujoco": version, "robots": [{"name", "file", "nq", "bodies": [names], "samples": [{"q",
"xpos": [[x,y,z] per body], "xquat": [[w,x,y,z] per body], "mass_matrix": [[...]]}]}]}.
Body 0 is the world.

Usage (MuJoCo 4.0 in /work/peers-venv):
    /work/peers-venv/bin/python testdata/mjcf/make_mjcf_reference.py
"""
import json
import os
import re

import mujoco
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ERD = os.path.join(
    os.path.dirname(mujoco.__file__), "..", "cmeel.prefix", "share", "example-robot-data", "robots"
)
ROBOTS = [
    ("ur5", "ur_description/urdf/ur5_robot.urdf"),
    ("panda", "panda_description/urdf/panda.urdf"),
    ("xarm7", "xarm_description/urdf/xarm7.urdf"),
    ("z1", "z1_description/urdf/z1.urdf"),
    ("kinova", "kinova_description/robots/kinova.urdf"),
]
HANDWRITTEN = ["features"]


def strip(text):
    text = re.sub(r"<visual\b.*?</visual>", "", text, flags=re.S)
    text = re.sub(r"<collision\b.*?</collision>", "", text, flags=re.S)
    ext = '<mujoco><compiler discardvisual="false" fusestatic="false"/></mujoco>'
    return re.sub(r"(<robot\b[^>]*>)", r"\1" + ext, text, count=1)


def main():
    rng = np.random.default_rng(36)
    out = {"mujoco": mujoco.__version__, "robots": []}
    for name, rel in ROBOTS:
        with open(os.path.join(ERD, rel)) as f:
            urdf = strip(f.read())
        try:
            m = mujoco.MjModel.from_xml_string(urdf)
        except Exception as e:  # noqa: BLE001 - report and go on
            print(f"{name}: MuJoCo refuses the URDF: {e}")
            continue
        path = os.path.join(HERE, f"{name}.xml")
        mujoco.mj_saveLastXML(path, m)
        out["robots"].append(sample(rng, name, path, rel))
    # Hand-written (see its comment): defaults, degrees, euler sequences, inertia from geoms.
    for name in HANDWRITTEN:
        out["robots"].append(sample(rng, name, os.path.join(HERE, f"{name}.xml"), "hand-written"))
    with open(os.path.join(HERE, "mujoco_reference.json"), "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


def sample(rng, name, path, source):
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    bodies = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or "world" for b in range(m.nbody)]
    samples = []
    for _ in range(10):
        q = np.empty(m.nq)
        for j in range(m.njnt):
            a = m.jnt_qposadr[j]
            lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (-np.pi, np.pi)
            q[a] = rng.uniform(lo, hi)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        samples.append({
            "q": q.tolist(),
            "xpos": d.xpos.tolist(),
            "xquat": d.xquat.tolist(),
            "mass_matrix": M.tolist(),
        })
    print(f"{name}: {m.nbody} bodies, nq {m.nq}")
    return {"name": name, "file": f"{name}.xml", "source": source, "nq": int(m.nq),
            "bodies": bodies, "samples": samples}


if __name__ == "__main__":
    main()
