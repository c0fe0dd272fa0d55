#!/usr/bin/env python3
"""Floating-base reference values (issue 36 item 2): Solo-12 (example-robot-data's
solo_description/robots/solo12.urdf, the copy vendored in testdata/urdf_corpus/robots/, BSD:
see testdata/urdf_corpus/LICENSES.md) with a free-flyer root joint, computed by Pinocchio, for
core/dynamics/tests/floating.rs. Also a planar-root variant of the same robot.

Run with the peer venv (pin 4.1, example-robot-data 6.0), from the repository root:
    /work/peers-venv/bin/python testdata/floating/make_floating_reference.py

Writes reference.json: {"pinocchio", "seed", "robots": [...]}, per robot:
  file (relative to the repository root), root ("free_flyer" | "planar"), nq, nv,
  joints (Pinocchio's movable joint names after the root joint, in its q order),
  samples: per sample q (Pinocchio's layout: root first — free-flyer x y z qx qy qz qw, planar
  x y cos sin — then one angle per joint), v (root: linear then angular velocity in the base
  link's frame, LOCAL), a, tau, and
    rnea = RNEA(q, v, a), gravity = g(q), aba = ABA(q, v, tau), M = CRBA(q) (both triangles,
    row-major),
    frames: {"root_joint" | joint name: {pose: oMi (4x4, the joint's child link frame),
      jacobian: getJointJacobian in LOCAL_WORLD_ALIGNED (6 x nv, rows vx vy vz wx wy wz,
      row-major)}}.
q: root position uniform in [-1, 1]^3 (planar: x, y), a uniformly random unit quaternion
(planar: angle in [-pi, pi]), joints uniform within their limits; v and a uniform in [-1, 1],
tau uniform in [-5, 5]; numpy default_rng(2). Gravity (0, 0, -9.81).
"""
import json
import os

import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
FILE = "testdata/urdf_corpus/robots/solo_description/solo12.urdf"
SAMPLES = 4


def rows(m):
    return [list(map(float, r)) for r in np.asarray(m)]


def sample(model, rng, root):
    q = np.zeros(model.nq)
    if root == "free_flyer":
        q[:3] = rng.uniform(-1, 1, 3)
        quat = rng.normal(size=4)
        q[3:7] = quat / np.linalg.norm(quat)
        start = 7
    else:
        q[:2] = rng.uniform(-1, 1, 2)
        th = rng.uniform(-np.pi, np.pi)
        q[2:4] = [np.cos(th), np.sin(th)]
        start = 4
    lo = model.lowerPositionLimit[start:]
    hi = model.upperPositionLimit[start:]
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    q[start:] = rng.uniform(lo, hi)
    return q


def robot(rng, root):
    path = os.path.join(ROOT, FILE)
    jm = pin.JointModelFreeFlyer() if root == "free_flyer" else pin.JointModelPlanar()
    model = pin.buildModelFromUrdf(path, jm)
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = model.createData()
    out = {
        "file": FILE,
        "root": root,
        "nq": model.nq,
        "nv": model.nv,
        "joints": [model.names[i] for i in range(2, model.njoints)],
        "samples": [],
    }
    for _ in range(SAMPLES):
        q = sample(model, rng, root)
        v = rng.uniform(-1, 1, model.nv)
        a = rng.uniform(-1, 1, model.nv)
        tau = rng.uniform(-5, 5, model.nv)
        s = {"q": q.tolist(), "v": v.tolist(), "a": a.tolist(), "tau": tau.tolist()}
        s["rnea"] = pin.rnea(model, data, q, v, a).tolist()
        s["gravity"] = pin.computeGeneralizedGravity(model, data, q).tolist()
        s["aba"] = pin.aba(model, data, q, v, tau).tolist()
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        s["M"] = rows(M)
        pin.computeJointJacobians(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        frames = {}
        for jid in range(1, model.njoints):
            J = pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            frames[model.names[jid]] = {
                "pose": rows(data.oMi[jid].homogeneous),
                "jacobian": rows(J),
            }
        s["frames"] = frames
        out["samples"].append(s)
    return out


def main():
    rng = np.random.default_rng(2)
    ref = {
        "pinocchio": pin.__version__,
        "seed": 2,
        "robots": [robot(rng, "free_flyer"), robot(rng, "planar")],
    }
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        json.dump(ref, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print("wrote", os.path.join(HERE, "reference.json"))


if __name__ == "__main__":
    main()
