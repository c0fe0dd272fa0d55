#!/usr/bin/env python3
"""Spherical (ball) joint reference values (issue 36 item 5): the small tree of ball_tree.xml
(three ball joints, a hinge and a slide, one branch) loaded by Pinocchio
(pin.buildModelFromMJCF: JointModelSpherical for `type="ball"`) and by MuJoCo, for
core/dynamics/tests/ball.rs.

Run with the peer venv (pin 4.1, mujoco 4.0), from the repository root:
    /work/peers-venv/bin/python testdata/ball/make_ball_reference.py

Layouts. Pinocchio's and robosim's q of a ball joint is a unit quaternion x y z w; MuJoCo's qpos
holds w x y z (converted here). v is the angular velocity in the child (body) frame in all three.
Joint order (q and v): shoulder (ball), elbow (hinge), wrist (ball), slide, hip (ball) — the
document's depth-first body order in all three. nq = 14, nv = 11.

Writes reference.json: {"pinocchio", "mujoco", "seed", "file", "nq", "nv", "joints",
"mujoco_vs_pinocchio" (the largest relative difference over every quantity below, the check that
the two peers agree), "samples": [...]}, per sample:
  q (Pinocchio's layout), v, a, tau,
  rnea = RNEA(q, v, a), gravity = g(q), aba = ABA(q, v, tau), M = CRBA(q) (both triangles,
  row-major), frames: {joint name: {pose: oMi (4x4, the joint's body frame: joints sit at their
  body's origin), jacobian: getJointJacobian in LOCAL_WORLD_ALIGNED (6 x nv, rows vx vy vz wx wy
  wz, row-major)}},
  and the same from MuJoCo under "mujoco": {rnea (mj_rne with qacc = a), aba (qacc of mj_forward
  with qfrc_applied = tau, constraints disabled: the ball range is a cone limit MuJoCo would
  enforce), M (mj_fullM), poses (xpos/xmat), jacobians (mj_jacBody, world-aligned)}.
Random q: each ball a uniformly random unit quaternion, hinge and slide uniform in their range;
v, a uniform in [-1, 1], tau uniform in [-2, 2]; numpy default_rng(5).
"""
import json
import os

import mujoco
import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
FILE = "testdata/ball/ball_tree.xml"
SAMPLES = 5


def rows(m):
    return [list(map(float, r)) for r in np.asarray(m)]


def flat(m):
    return [float(x) for x in np.asarray(m).reshape(-1)]


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def main():
    path = os.path.join(ROOT, FILE)
    model = pin.buildModelFromMJCF(path)
    data = model.createData()
    mj = mujoco.MjModel.from_xml_path(path)
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    md = mujoco.MjData(mj)
    assert (model.nq, model.nv) == (mj.nq, mj.nv) == (14, 11)
    names = [model.names[i] for i in range(1, model.njoints)]
    assert names == [mj.joint(i).name for i in range(mj.njnt)], names
    rng = np.random.default_rng(5)
    samples = []
    worst = 0.0
    for _ in range(SAMPLES):
        q = np.zeros(model.nq)
        qm = np.zeros(mj.nq)
        for i in range(1, model.njoints):
            j = model.joints[i]
            iq = j.idx_q
            if j.nq == 4:
                quat = rng.normal(size=4)
                quat /= np.linalg.norm(quat)
                q[iq : iq + 4] = quat  # x y z w
                qm[iq : iq + 4] = [quat[3], quat[0], quat[1], quat[2]]  # w x y z
            else:
                lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
                q[iq] = qm[iq] = rng.uniform(lo, hi)
        v = rng.uniform(-1, 1, model.nv)
        a = rng.uniform(-1, 1, model.nv)
        tau = rng.uniform(-2, 2, model.nv)

        rnea = pin.rnea(model, data, q, v, a).copy()
        grav = pin.computeGeneralizedGravity(model, data, q).copy()
        aba = pin.aba(model, data, q, v, tau).copy()
        M = pin.crba(model, data, q).copy()
        M = np.triu(M) + np.triu(M, 1).T
        pin.forwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        frames = {}
        for i in range(1, model.njoints):
            J = pin.getJointJacobian(model, data, i, pin.LOCAL_WORLD_ALIGNED)
            frames[model.names[i]] = {
                "pose": rows(data.oMi[i].homogeneous),
                "jacobian": flat(J),
            }

        md.qpos[:] = qm
        md.qvel[:] = v
        md.qfrc_applied[:] = 0
        md.qacc[:] = a
        mujoco.mj_forward(mj, md)
        md.qacc[:] = a
        mj_rnea = np.zeros(mj.nv)
        mujoco.mj_rne(mj, md, 1, mj_rnea)
        mj_M = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, md, mj_M)
        poses, jacs = {}, {}
        for i in range(mj.njnt):
            b = mj.jnt_bodyid[i]
            pose = np.eye(4)
            pose[:3, :3] = md.xmat[b].reshape(3, 3)
            pose[:3, 3] = md.xpos[b]
            jp = np.zeros((3, mj.nv))
            jr = np.zeros((3, mj.nv))
            mujoco.mj_jacBody(mj, md, jp, jr, b)
            name = mj.joint(i).name
            poses[name] = rows(pose)
            jacs[name] = flat(np.vstack([jp, jr]))
        md.qfrc_applied[:] = tau
        mujoco.mj_forward(mj, md)
        mj_aba = md.qacc.copy()

        for got, want in [(mj_rnea, rnea), (mj_aba, aba), (mj_M, M)]:
            worst = max(worst, rel(got, want))
        for n in names:
            worst = max(worst, rel(poses[n], frames[n]["pose"]))
            worst = max(worst, rel(jacs[n], frames[n]["jacobian"]))
        samples.append(
            {
                "q": flat(q),
                "v": flat(v),
                "a": flat(a),
                "tau": flat(tau),
                "rnea": flat(rnea),
                "gravity": flat(grav),
                "aba": flat(aba),
                "M": flat(M),
                "frames": frames,
                "mujoco": {
                    "qpos": flat(qm),
                    "rnea": flat(mj_rnea),
                    "aba": flat(mj_aba),
                    "M": flat(mj_M),
                    "poses": poses,
                    "jacobians": jacs,
                },
            }
        )
    assert worst < 1e-9, f"MuJoCo and Pinocchio disagree: {worst:e}"
    out = {
        "pinocchio": pin.__version__,
        "mujoco": mujoco.__version__,
        "seed": 5,
        "file": FILE,
        "nq": model.nq,
        "nv": model.nv,
        "joints": names,
        "mujoco_vs_pinocchio": worst,
        "samples": samples,
    }
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        json.dump(out, f, indent=1)
    print(f"{SAMPLES} samples; MuJoCo vs Pinocchio: {worst:.2e}")


if __name__ == "__main__":
    main()
