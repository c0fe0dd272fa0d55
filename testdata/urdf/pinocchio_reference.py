#!/usr/bin/env python3
"""Reference values for robosim's URDF import, computed by Pinocchio (pip package `pin`).

Reads the URDFs vendored beside this script from example-robot-data (ur5_robot.urdf: BSD, see
LICENSE-example-robot-data; panda.urdf: Apache-2.0, see LICENSE-panda_description; meshes are
not vendored: neither Pinocchio's model nor robosim's FK/dynamics needs them) and writes
pinocchio_reference.json.

The chain: robosim imports the serial chain from the URDF's root link to a tip link; every
joint off that chain is held at 0 and rigid with its parent. Pinocchio gets the same by
pin.buildReducedModel, locking every joint that does not support the tip at the neutral q (0
for these robots: the Panda's fingers). Fixed joints are folded by both (frames in Pinocchio,
inertia lumped into the parent body).

Per robot, 20 samples (numpy default_rng seed 14): q uniform within the position limits,
qd and qdd uniform in [-1, 1], tau uniform in [-5, 5]; then
  * tip:         the tip frame's pose in the root link's (= Pinocchio's world) frame, 4x4;
  * jacobian:    6 x n, rows vx vy vz wx wy wz: the tip origin's linear velocity and the
                 angular velocity in the world axes = Pinocchio LOCAL_WORLD_ALIGNED = robosim's
                 Frame::Base;
  * jacobian_tool: the same in the tip frame's axes = Pinocchio LOCAL = robosim's Frame::Tool;
  * rnea:        tau = RNEA(q, qd, qdd) (no joint friction: Pinocchio's RNEA has none);
  * mass_matrix: CRBA, both triangles;
  * aba:         qdd = ABA(q, qd, tau).
Gravity (0, 0, -9.81). Matrices are row-major nested lists.

Trees ("trees" in the JSON): the FULL model of a URDF (every movable joint a coordinate; the
Panda's two finger joints included — pin.buildModelFromUrdf's default treats the <mimic> finger
joint as an independent joint, as robosim's import_urdf_tree does), 10 samples (the same rng,
drawn after the chains), per sample q, qd, qdd, tau and
  * links:     per movable joint, its child link's pose (oMf of the link's body frame, = the
               joint's placement oMi) and its Jacobian (LOCAL_WORLD_ALIGNED and LOCAL);
  * rnea, mass_matrix, aba, gravity (pin.computeGeneralizedGravity) as above.

Usage, from the repository root (pin 3.x or newer):
    python3 -m venv /tmp/pin && /tmp/pin/bin/pip install pin
    /tmp/pin/bin/python testdata/urdf/pinocchio_reference.py
"""
import json
import os

import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
ROBOTS = [("ur5", "ur5_robot.urdf", "tool0"), ("panda", "panda.urdf", "panda_hand_tcp")]

out = {"pinocchio": pin.__version__, "seed": 14, "robots": {}}
rng = np.random.default_rng(14)
for name, file, tip in ROBOTS:
    full = pin.buildModelFromUrdf(os.path.join(HERE, file))
    tip_joint = full.frames[full.getFrameId(tip)].parentJoint
    keep = set(full.supports[tip_joint])
    lock = [j for j in range(1, full.njoints) if j not in keep]
    model = pin.buildReducedModel(full, lock, pin.neutral(full))
    data = model.createData()
    fid = model.getFrameId(tip)
    samples = []
    for _ in range(20):
        lo = np.maximum(model.lowerPositionLimit, -np.pi)
        hi = np.minimum(model.upperPositionLimit, np.pi)
        q = rng.uniform(lo, hi)
        qd = rng.uniform(-1.0, 1.0, model.nv)
        qdd = rng.uniform(-1.0, 1.0, model.nv)
        tau = rng.uniform(-5.0, 5.0, model.nv)
        pin.framesForwardKinematics(model, data, q)
        pose = data.oMf[fid].homogeneous.copy()
        pin.computeJointJacobians(model, data, q)
        jac = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED).copy()
        jac_tool = pin.getFrameJacobian(model, data, fid, pin.LOCAL).copy()
        rnea = pin.rnea(model, data, q, qd, qdd).copy()
        m = pin.crba(model, data, q).copy()
        m = np.triu(m) + np.triu(m, 1).T
        aba = pin.aba(model, data, q, qd, tau).copy()
        samples.append({
            "q": q.tolist(), "qd": qd.tolist(), "qdd": qdd.tolist(), "tau": tau.tolist(),
            "tip": pose.tolist(), "jacobian": jac.tolist(), "jacobian_tool": jac_tool.tolist(),
            "rnea": rnea.tolist(), "mass_matrix": m.tolist(), "aba": aba.tolist(),
        })
    out["robots"][name] = {
        "file": file, "tip": tip,
        "joints": [model.names[j] for j in range(1, model.njoints)],
        "samples": samples,
    }
TREES = [("panda", "panda.urdf")]
out["trees"] = {}
for name, file in TREES:
    model = pin.buildModelFromUrdf(os.path.join(HERE, file))
    data = model.createData()
    joints = [model.names[j] for j in range(1, model.njoints)]
    child_links = []
    for j in range(1, model.njoints):
        body = [f for f in model.frames if f.parentJoint == j and f.type == pin.BODY and f.placement.isIdentity()]
        child_links.append(body[0].name)
    samples = []
    for _ in range(10):
        lo = np.maximum(model.lowerPositionLimit, -np.pi)
        hi = np.minimum(model.upperPositionLimit, np.pi)
        q = rng.uniform(lo, hi)
        qd = rng.uniform(-1.0, 1.0, model.nv)
        qdd = rng.uniform(-1.0, 1.0, model.nv)
        tau = rng.uniform(-5.0, 5.0, model.nv)
        pin.forwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        per_link = []
        for j in range(1, model.njoints):
            per_link.append({
                "pose": data.oMi[j].homogeneous.tolist(),
                "jacobian": pin.getJointJacobian(model, data, j, pin.LOCAL_WORLD_ALIGNED).tolist(),
                "jacobian_tool": pin.getJointJacobian(model, data, j, pin.LOCAL).tolist(),
            })
        rnea = pin.rnea(model, data, q, qd, qdd).copy()
        m = pin.crba(model, data, q).copy()
        m = np.triu(m) + np.triu(m, 1).T
        aba = pin.aba(model, data, q, qd, tau).copy()
        grav = pin.computeGeneralizedGravity(model, data, q).copy()
        samples.append({
            "q": q.tolist(), "qd": qd.tolist(), "qdd": qdd.tolist(), "tau": tau.tolist(),
            "links": per_link, "rnea": rnea.tolist(), "mass_matrix": m.tolist(),
            "aba": aba.tolist(), "gravity": grav.tolist(),
        })
    out["trees"][name] = {
        "file": file, "joints": joints, "links": child_links,
        "parents": [int(model.parents[j]) for j in range(1, model.njoints)],
        "samples": samples,
    }
with open(os.path.join(HERE, "pinocchio_reference.json"), "w") as f:
    json.dump(out, f, indent=1)
    f.write("\n")
print("wrote pinocchio_reference.json with Pinocchio", pin.__version__)
