#!/usr/bin/env python3
"""Reference data for robosim-dynamics, computed with Pinocchio (pip package `pin`).

Writes, next to this script:
  robots/<name>.json   the robot in robosim's inline format (DESIGN.md, "The query protocol")
  reference.json       per robot: many (q, qd, qdd) with tau = RNEA, M = CRBA, g = gravity torque,
                       and (q, qd, tau_fd) with qdd_fd = ABA.
  reference_drive.json the PUMA 560 with motor inertia and friction, from roboticstoolbox's rne/accel.

The PUMA 560, Stanford arm (standard DH) and Panda (modified DH) parameters are taken from
roboticstoolbox-python's `rtb.models.DH.Puma560 / Stanford / Panda` (motor inertia, friction and
gear ratio set to zero on both sides). Two synthetic arms add prismatic joints, offsets and a
tilted base in both conventions.

The DH chain is turned into a Pinocchio model here, independently of robosim's formulation:
  standard  A_j = Rz(theta) Tz(d) Tx(a) Rx(alpha): joint j is a Pinocchio RZ/PZ joint placed at
            frame j-1 (times the constant part of the screw: Rz(offset) or Rz(theta) Tz(offset));
            the link frame j sits at Tz(d) Tx(a) Rx(alpha) (revolute) or Tx(a) Rx(alpha)
            (prismatic) in the joint frame.
  modified  A_j = Rx(alpha) Tx(a) Rz(theta) Tz(d): the joint frame is link frame j itself, placed
            at Rx(alpha) Tx(a) Rz(offset) Tz(d) (revolute) or Rx(alpha) Tx(a) Rz(theta) Tz(offset)
            (prismatic) in frame j-1.
The body inertia (mass, com, inertia about com, in link frame j) is moved into the joint frame.
As a check of this conversion the script compares Pinocchio's RNEA with roboticstoolbox's `rne`
(which works on the DH table directly) and prints the largest difference.

Usage: python3 gen_reference.py     (pin 4.1.0, roboticstoolbox-python 1.5.0, numpy 2.x)
"""
import json
import os

import numpy as np
import pinocchio as pin
import roboticstoolbox as rtb

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = 40
rng = np.random.default_rng(20261122)


def rx(a):
    return pin.SE3(pin.utils.rotate("x", a), np.zeros(3))


def rz(a):
    return pin.SE3(pin.utils.rotate("z", a), np.zeros(3))


def tx(v):
    return pin.SE3(np.eye(3), np.array([v, 0.0, 0.0]))


def tz(v):
    return pin.SE3(np.eye(3), np.array([0.0, 0.0, v]))


def to_pinocchio(robot):
    """robot: dict in robosim's inline format -> pinocchio.Model"""
    model = pin.Model()
    model.gravity.linear = np.array(robot["gravity"])
    base = np.array(robot["base"])
    prev_post = pin.SE3(base[:3, :3], base[:3, 3])
    parent = 0
    for j, jt in enumerate(robot["joints"]):
        a, d, al, th, off = jt["a"], jt["d"], jt["alpha"], jt["theta"], jt["offset"]
        rev = jt["type"] == "revolute"
        if robot["convention"] == "standard":
            pre = rz(off) if rev else rz(th) * tz(off)
            post = (tz(d) * tx(a) * rx(al)) if rev else (tx(a) * rx(al))
        else:
            pre = (rx(al) * tx(a) * rz(off) * tz(d)) if rev else (rx(al) * tx(a) * rz(th) * tz(off))
            post = pin.SE3.Identity()
        jmodel = pin.JointModelRZ() if rev else pin.JointModelPZ()
        jid = model.addJoint(parent, jmodel, prev_post * pre, "j%d" % (j + 1))
        inertia = pin.Inertia(jt["mass"], np.array(jt["com"]), np.array(jt["inertia"]))
        model.appendBodyToJoint(jid, post.act(inertia), pin.SE3.Identity())
        parent = jid
        prev_post = post
    return model


def from_rtb(name, r):
    joints = []
    for L in r.links:
        joints.append(
            {
                "type": "prismatic" if L.isprismatic else "revolute",
                "a": float(L.a),
                "d": float(L.d),
                "alpha": float(L.alpha),
                "theta": float(L.theta),
                "offset": float(L.offset),
                "qlim": [float(L.qlim[0]), float(L.qlim[1])],
                "mass": float(L.m),
                "com": [float(x) for x in L.r],
                "inertia": np.array(L.I, dtype=float).tolist(),
            }
        )
    if name.startswith("puma560"):
        # d1 is 26.45 in, exactly 0.67183 m; RTB's float product 26.45 * 0.0254 is one unit in
        # the last place low. The files carry the published value (library-space/tests/
        # builtin_tables.rs); the reference outputs moved by far less than their tolerances.
        joints[0]["d"] = 0.67183
    return {
        "name": name,
        "convention": "modified" if r.mdh else "standard",
        "joints": joints,
        "gravity": [0.0, 0.0, -9.81],
        "base": r.base.A.tolist(),
        "tool": r.tool.A.tolist(),
    }


def random_inertia(m):
    # principal moments of a box of random sides: satisfies the triangle inequality
    s = rng.uniform(0.05, 0.4, 3)
    p = m / 12.0 * np.array([s[1] ** 2 + s[2] ** 2, s[0] ** 2 + s[2] ** 2, s[0] ** 2 + s[1] ** 2])
    R = pin.utils.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
    return (R @ np.diag(p) @ R.T).tolist()


def synthetic(name, convention, types):
    joints = []
    for t in types:
        m = float(rng.uniform(0.5, 8.0))
        joints.append(
            {
                "type": t,
                "a": float(rng.uniform(-0.4, 0.4)),
                "d": float(rng.uniform(-0.3, 0.3)),
                "alpha": float(rng.uniform(-np.pi, np.pi)),
                "theta": float(rng.uniform(-np.pi, np.pi)),
                "offset": float(rng.uniform(-0.5, 0.5)),
                "qlim": [-0.5, 0.5] if t == "prismatic" else [-np.pi, np.pi],
                "mass": m,
                "com": rng.uniform(-0.2, 0.2, 3).tolist(),
                "inertia": random_inertia(m),
            }
        )
    base = np.eye(4)
    base[:3, :3] = pin.utils.rpyToMatrix(0.3, -0.2, 0.7)
    base[:3, 3] = [0.1, -0.2, 0.5]
    return {
        "name": name,
        "convention": convention,
        "joints": joints,
        "gravity": [0.0, 0.0, -9.81],
        "base": base.tolist(),
        "tool": np.eye(4).tolist(),
    }


def rtb_check(r, model, data):
    """largest |tau_pinocchio - tau_rtb| over a few random states (rtb with Jm = B = Tc = 0)"""
    for L in r.links:
        L.Jm = 0.0
        L.B = 0.0
        L.Tc = [0.0, 0.0]
    worst = 0.0
    for _ in range(10):
        q = rng.uniform(-2, 2, r.n)
        qd = rng.uniform(-2, 2, r.n)
        qdd = rng.uniform(-5, 5, r.n)
        a = r.rne(q, qd, qdd)  # rtb uses r.gravity = [0, 0, -9.81]
        b = pin.rnea(model, data, q, qd, qdd)
        worst = max(worst, float(np.max(np.abs(a - b))))
    return worst


def cases(robot, model):
    data = model.createData()
    n = model.nq
    lo = np.array([j["qlim"][0] for j in robot["joints"]])
    hi = np.array([j["qlim"][1] for j in robot["joints"]])
    out = []
    for _ in range(CASES):
        q = rng.uniform(lo, hi)
        qd = rng.uniform(-2, 2, n)
        qdd = rng.uniform(-5, 5, n)
        tau_fd = rng.uniform(-20, 20, n)
        tau = pin.rnea(model, data, q, qd, qdd).copy()
        M = pin.crba(model, data, q).copy()
        M = np.triu(M) + np.triu(M, 1).T  # pinocchio fills the upper triangle
        g = pin.computeGeneralizedGravity(model, data, q).copy()
        qdd_fd = pin.aba(model, data, q, qd, tau_fd).copy()
        out.append(
            {
                "q": q.tolist(),
                "qd": qd.tolist(),
                "qdd": qdd.tolist(),
                "tau": tau.tolist(),
                "mass_matrix": M.tolist(),
                "gravity": g.tolist(),
                "tau_fd": tau_fd.tolist(),
                "qdd_fd": qdd_fd.tolist(),
            }
        )
    return out


def drive_reference():
    """The PUMA 560 with its drive terms, reflected to the joints, against roboticstoolbox's rne and
    accel (which model them on the DH links directly): motor inertia G² Jm, viscous friction G² B,
    Coulomb friction |G| Tc (Tc made symmetric, Tc⁻ = −Tc⁺: robosim has one Coulomb magnitude)."""
    r = rtb.models.DH.Puma560()
    robot = from_rtb("puma560_drive", r)
    for L, jt in zip(r.links, robot["joints"]):
        L.Tc = [float(L.Tc[0]), -float(L.Tc[0])]
        g = abs(float(L.G))
        jt["motor_inertia"] = float(L.Jm) * g * g
        jt["viscous"] = float(L.B) * g * g
        jt["coulomb"] = float(L.Tc[0]) * g
    out = []
    for _ in range(CASES):
        q = rng.uniform([j["qlim"][0] for j in robot["joints"]], [j["qlim"][1] for j in robot["joints"]])
        qd = rng.uniform(-2, 2, 6)
        qdd = rng.uniform(-5, 5, 6)
        tau_fd = rng.uniform(-20, 20, 6)
        out.append(
            {
                "q": q.tolist(),
                "qd": qd.tolist(),
                "qdd": qdd.tolist(),
                "tau": np.asarray(r.rne(q, qd, qdd)).tolist(),
                "tau_fd": tau_fd.tolist(),
                "qdd_fd": np.asarray(r.accel(q, qd, tau_fd)).ravel().tolist(),
            }
        )
    return robot, out


def main():
    robots = []
    for name, cls in [("puma560", "Puma560"), ("stanford", "Stanford"), ("panda", "Panda")]:
        r = getattr(rtb.models.DH, cls)()
        robot = from_rtb(name, r)
        model = to_pinocchio(robot)
        print("%-10s pinocchio vs roboticstoolbox rne: max |dtau| = %.3e N·m" % (name, rtb_check(r, model, model.createData())))
        robots.append(robot)
    robots.append(synthetic("synthetic_standard", "standard", ["revolute", "prismatic", "revolute", "revolute", "prismatic"]))
    robots.append(synthetic("synthetic_modified", "modified", ["prismatic", "revolute", "revolute", "prismatic", "revolute"]))

    os.makedirs(os.path.join(HERE, "robots"), exist_ok=True)
    reference = {"source": "pinocchio %s (pin on PyPI), gen_reference.py" % pin.__version__, "robots": {}}
    for robot in robots:
        with open(os.path.join(HERE, "robots", robot["name"] + ".json"), "w") as f:
            json.dump(robot, f, indent=1)
            f.write("\n")
        reference["robots"][robot["name"]] = cases(robot, to_pinocchio(robot))
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        json.dump(reference, f)
        f.write("\n")

    robot, out = drive_reference()
    with open(os.path.join(HERE, "robots", robot["name"] + ".json"), "w") as f:
        json.dump(robot, f, indent=1)
        f.write("\n")
    with open(os.path.join(HERE, "reference_drive.json"), "w") as f:
        json.dump({"source": "roboticstoolbox-python 1.5.0 rne / accel, gen_reference.py", "robots": {"puma560_drive": out}}, f)
        f.write("\n")


if __name__ == "__main__":
    main()
