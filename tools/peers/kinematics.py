#!/usr/bin/env python3
"""FK and frame Jacobians: robosim against Pinocchio on the same robots and the same q.

Two jobs (issue 37, item 1):

  fixtures   writes testdata/kinematics/peers/<robot>.json: each robot in robosim's inline
             format, 16 joint vectors (numpy default_rng seed 37, uniform within the limits,
             continuous joints in [-pi, pi]) and Pinocchio's answers at them: every joint frame
             (oMi), the tool frame (oMf) and its Jacobian in the world axes
             (LOCAL_WORLD_ALIGNED = robosim's Frame::Base). robosim's tests check its FK and
             Jacobian against these (core/kinematics/tests/peers.rs).
  time       interleaved rounds: per round, robosim's timing program (the release example
             `peer_timing` of robosim-kinematics, one process per round) and Pinocchio's
             timeit loops on the same robots and q; prints per-op medians and spreads and the
             ratio robosim / Pinocchio per round.

Robots: PUMA 560 (standard DH, testdata/kinematics/puma560.json; Pinocchio's model built joint by
joint as testdata/dynamics/gen_reference.py builds it: JointModelRZ placed at DH frame j-1, the
tool a frame on the last joint), and from example-robot-data's URDFs (read by
pin.buildModelFromUrdf): UR10 (tip tool0), xArm7 (tip link_eef), Panda (fingers locked with
pin.buildReducedModel at 0, tip panda_hand_tcp). The URDF robots are handed to robosim as
general joints with Pinocchio's own joint placements and axes (fixed joints already folded), so
both libraries compute on the same numbers.

What is timed, per call (q cycled through the 16 vectors):
  fk_all      robosim KinematicModel::link_frames_into (base, every link frame, tool) against
              pin.forwardKinematics(model, data, q) (every joint frame oMi; the tool frame is
              not computed by Pinocchio's call, so robosim does one more product here);
  jacobian    robosim KinematicModel::fk_and_jacobian_into (tool pose + 6 x n base-frame
              Jacobian of the tool origin) against pin.computeFrameJacobian(model, data, q,
              tool, LOCAL_WORLD_ALIGNED) (FK along the support, the Jacobian, in the world axes).
Binding overhead: each Pinocchio figure has the same call on an EMPTY model (universe only; a
frame on the universe for the Jacobian; q of size 0) subtracted: dispatch, argument conversion
and, for the Jacobian, the returned numpy array — what the call costs with no joint to compute.
Both raw and subtracted ratios are printed.

Run from the repository root, with Pinocchio 4.1 (pip `pin`):
    /work/peers-venv/bin/python tools/peers/kinematics.py fixtures
    cargo build --release -p robosim-kinematics --example peer_timing
    /work/peers-venv/bin/python tools/peers/kinematics.py time [--rounds 7]
"""
import glob
import json
import os
import statistics
import subprocess
import sys
import timeit

import numpy as np
import pinocchio as pin

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
OUT = os.path.join(ROOT, "testdata", "kinematics", "peers")
SAMPLES = 16


def erd_robots():
    hits = glob.glob(os.path.join(sys.prefix, "lib", "python3*", "site-packages", "cmeel.prefix",
                                  "share", "example-robot-data", "robots"))
    if not hits:
        sys.exit("example-robot-data not found under " + sys.prefix)
    return hits[0]


def se3(m):
    m = np.array(m, dtype=float)
    return pin.SE3(m[:3, :3], m[:3, 3])


def rx(a):
    return pin.SE3(pin.utils.rotate("x", a), np.zeros(3))


def rz(a):
    return pin.SE3(pin.utils.rotate("z", a), np.zeros(3))


def tx(v):
    return pin.SE3(np.eye(3), np.array([v, 0.0, 0.0]))


def tz(v):
    return pin.SE3(np.eye(3), np.array([0.0, 0.0, v]))


def dh_model(robot):
    """A standard/modified DH robot (robosim's inline dict) -> (pinocchio.Model, tool frame id),
    as testdata/dynamics/gen_reference.py builds it (kinematics only)."""
    model = pin.Model()
    prev_post = se3(robot.get("base", np.eye(4)))
    parent = 0
    for j, jt in enumerate(robot["joints"]):
        a, d, al = jt.get("a", 0.0), jt.get("d", 0.0), jt.get("alpha", 0.0)
        th, off = jt.get("theta", 0.0), jt.get("offset", 0.0)
        rev = jt.get("type", "revolute") == "revolute"
        if robot.get("convention", "standard") == "standard":
            pre = rz(off) if rev else rz(th) * tz(off)
            post = (tz(d) * tx(a) * rx(al)) if rev else (tx(a) * rx(al))
        else:
            pre = (rx(al) * tx(a) * rz(off) * tz(d)) if rev else (rx(al) * tx(a) * rz(th) * tz(off))
            post = pin.SE3.Identity()
        jmodel = pin.JointModelRZ() if rev else pin.JointModelPZ()
        lo, hi = jt.get("qlim", [-np.pi, np.pi])
        parent = model.addJoint(parent, jmodel, prev_post * pre, "j%d" % (j + 1),
                                np.array([1e3]), np.array([1e3]), np.array([lo]), np.array([hi]))
        prev_post = post
    tool = prev_post * se3(robot.get("tool", np.eye(4)))
    fid = model.addFrame(pin.Frame("tool", parent, tool, pin.FrameType.OP_FRAME))
    return model, fid


AXES = {"RX": ("revolute", [1.0, 0.0, 0.0]), "RY": ("revolute", [0.0, 1.0, 0.0]),
        "RZ": ("revolute", [0.0, 0.0, 1.0]), "PX": ("prismatic", [1.0, 0.0, 0.0]),
        "PY": ("prismatic", [0.0, 1.0, 0.0]), "PZ": ("prismatic", [0.0, 0.0, 1.0])}


def urdf_model(file, tip, lock_off_tip):
    model = pin.buildModelFromUrdf(file)
    if lock_off_tip:
        tip_joint = model.frames[model.getFrameId(tip)].parentJoint
        keep = set(model.supports[tip_joint])
        lock = [j for j in range(1, model.njoints) if j not in keep]
        model = pin.buildReducedModel(model, lock, pin.neutral(model))
    return model, model.getFrameId(tip)


def as_robosim(name, model, fid):
    """A Pinocchio chain of RX..PZ joints -> robosim's inline robot (general joints)."""
    joints = []
    for j in range(1, model.njoints):
        kind, axis = AXES[model.joints[j].shortname().replace("JointModel", "")]
        assert model.parents[j] == j - 1, "a chain"
        lo, hi = model.lowerPositionLimit[j - 1], model.upperPositionLimit[j - 1]
        joints.append({"type": kind, "qlim": [float(lo), float(hi)],
                       "origin": {"placement": model.jointPlacements[j].homogeneous.tolist(),
                                  "axis": axis}})
    frame = model.frames[fid]
    assert frame.parentJoint == model.njoints - 1, "the tool hangs from the last joint"
    return {"name": name, "joints": joints, "tool": frame.placement.homogeneous.tolist(),
            "source": "Pinocchio %s model of example-robot-data's URDF (tools/peers/kinematics.py)"
                      % pin.__version__}


def models():
    """(name, robosim robot dict, pinocchio model, tool frame id)"""
    erd = erd_robots()
    out = []
    with open(os.path.join(ROOT, "testdata", "kinematics", "puma560.json")) as f:
        puma = json.load(f)
    m, fid = dh_model(puma)
    out.append(("puma560", {"builtin": "puma560"}, m, fid))
    for name, file, tip, lock in [
        ("ur10", "ur_description/urdf/ur10_robot.urdf", "tool0", False),
        ("xarm7", "xarm_description/urdf/xarm7.urdf", "link_eef", False),
        ("panda", "panda_description/urdf/panda.urdf", "panda_hand_tcp", True),
    ]:
        m, fid = urdf_model(os.path.join(erd, file), tip, lock)
        out.append((name, as_robosim(name, m, fid), m, fid))
    return out


def samples(model, rng):
    lo = np.maximum(model.lowerPositionLimit, -np.pi)
    hi = np.minimum(model.upperPositionLimit, np.pi)
    return [rng.uniform(lo, hi) for _ in range(SAMPLES)]


def fixtures():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(37)
    for name, robot, model, fid in models():
        data = model.createData()
        rows = []
        for q in samples(model, rng):
            pin.forwardKinematics(model, data, q)
            pin.updateFramePlacements(model, data)
            J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
            rows.append({"q": q.tolist(),
                         "joint_frames": [data.oMi[j].homogeneous.tolist()
                                          for j in range(1, model.njoints)],
                         "tool": data.oMf[fid].homogeneous.tolist(),
                         "jacobian": J.tolist()})
        doc = {"pinocchio": pin.__version__, "seed": 37, "robot": robot, "samples": rows}
        with open(os.path.join(OUT, name + ".json"), "w") as f:
            json.dump(doc, f, indent=1)
        print("wrote", os.path.join(OUT, name + ".json"))


def pinocchio_times(model, fid, qs, number):
    """ns per call: fk_all, jacobian and the same calls on an empty model (*_empty)"""
    data = model.createData()
    empty = pin.Model()
    efid = empty.addFrame(pin.Frame("tool", 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    edata = empty.createData()
    eq = [np.zeros(0) for _ in qs]
    lwa = pin.LOCAL_WORLD_ALIGNED
    fk, jac = pin.forwardKinematics, pin.computeFrameJacobian
    g = dict(fk=fk, jac=jac, model=model, data=data, fid=fid, qs=qs, lwa=lwa,
             empty=empty, edata=edata, efid=efid, eq=eq)
    calls = number * len(qs)
    t = {}
    for key, stmt in [
        ("fk_all", "for q in qs: fk(model, data, q)"),
        ("fk_all_empty", "for q in eq: fk(empty, edata, q)"),
        ("jacobian", "for q in qs: jac(model, data, q, fid, lwa)"),
        ("jacobian_empty", "for q in eq: jac(empty, edata, q, efid, lwa)"),
    ]:
        t[key] = timeit.timeit(stmt, globals=g, number=number) / calls * 1e9
    return t


def robosim_times(exe, files, calls):
    out = subprocess.run([exe, "--calls", str(calls)] + files, check=True,
                         capture_output=True, text=True).stdout
    t = {}
    for line in out.splitlines():
        r = json.loads(line)
        t[(r["robot"], r["op"])] = r["ns_per_call"]
    return t


def time(rounds, number, calls):
    exe = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")),
                       "release", "examples", "peer_timing")
    if not os.path.exists(exe):
        sys.exit("build it first: cargo build --release -p robosim-kinematics --example peer_timing")
    rng = np.random.default_rng(37)
    ms = models()
    files = [os.path.join(OUT, name + ".json") for name, *_ in ms]
    qs = {name: samples(model, rng) for name, _, model, _ in ms}
    per = {}  # (robot, what) -> list over rounds
    for r in range(rounds):
        rs = robosim_times(exe, files, calls)
        for name, _, model, fid in ms:
            p = pinocchio_times(model, fid, qs[name], number)
            for op in ["fk_all", "jacobian"]:
                raw = p[op]
                net = p[op] - p[op + "_empty"]
                ours = rs[(name, op)]
                for key, val in [("pin_raw", raw), ("pin_net", net), ("pin_empty", p[op + "_empty"]),
                                 ("robosim", ours), ("robosim_legacy", rs[(name, op + "_legacy")]),
                                 ("robosim_robot", rs[(name, op + "_robot")]),
                                 ("ratio_net", ours / net), ("ratio_raw", ours / raw),
                                 ("ratio_robot_net", rs[(name, op + "_robot")] / net),
                                 ("ratio_legacy_net", rs[(name, op + "_legacy")] / net)]:
                    per.setdefault((name, op, key), []).append(val)
        print("round %d done" % (r + 1), file=sys.stderr)
    print("| robot | op | robosim (model) ns | robosim (&Robot) ns | robosim before (4x4) ns "
          "| Pinocchio net ns | Pinocchio empty call ns | ratio model/Pin net | "
          "ratio &Robot/Pin net | ratio before/Pin net | ratio model/Pin raw |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, *_ in ms:
        for op in ["fk_all", "jacobian"]:
            def m(key):
                v = per[(name, op, key)]
                return statistics.median(v), min(v), max(v)

            def cell(key, fmt="%.0f"):
                med, lo, hi = m(key)
                return (fmt + " (" + fmt + "–" + fmt + ")") % (med, lo, hi)

            print("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                name, op, cell("robosim"), cell("robosim_robot"), cell("robosim_legacy"),
                cell("pin_net"), cell("pin_empty"), cell("ratio_net", "%.2f"),
                cell("ratio_robot_net", "%.2f"), cell("ratio_legacy_net", "%.2f"),
                cell("ratio_raw", "%.2f")))
    print("(median over %d interleaved rounds, (min–max) across rounds; Pinocchio %s; "
          "%d Python calls and %d robosim calls per op per round)"
          % (rounds, pin.__version__, number * SAMPLES, calls))


if __name__ == "__main__":
    args = sys.argv[1:]
    if args[:1] == ["fixtures"]:
        fixtures()
    elif args[:1] == ["time"]:
        rounds = int(args[args.index("--rounds") + 1]) if "--rounds" in args else 7
        time(rounds, number=10000, calls=500_000)
    else:
        sys.exit(__doc__)
