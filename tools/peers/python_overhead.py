"""Per-call cost of robosim.Model against Pinocchio's Python bindings on the same robot (a bench,
not a test; docs/python.md has the figures).

The UR5 of example-robot-data (testdata/urdf_corpus/robots/ur_description/ur5_robot.urdf, the
copy the reference data comes from) loaded by both: robosim.Model.from_urdf(path, tip="tool0"),
pin.buildModelFromUrdf(path). For each algorithm: one call from Python on one configuration
(what the Python caller pays per call), and a batch of N configurations — robosim's one call on
an (N, n) array against Pinocchio in a Python loop (Pinocchio's bindings have no batch form).
timeit, ROUNDS interleaved rounds (robosim, pin, robosim, ...), median and spread (min..max) of
the per-call time in µs, and the ratio of medians.

Run with the peer venv (pin 4.1) and robosim's built module on the path, as the pytest suite
puts it (python/tests/pytest.rs):

    cargo build -p robosim-python            # or --release (say which in the docs)
    mkdir -p /tmp/rs_site/robosim && cp python/robosim/* /tmp/rs_site/robosim/ \
        && cp target/debug/lib_robosim.so /tmp/rs_site/robosim/_robosim.abi3.so
    PYTHONPATH=/tmp/rs_site /work/peers-venv/bin/python tools/peers/python_overhead.py
"""

import os
import statistics
import sys
import timeit

import numpy as np
import pinocchio as pin

import robosim

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
URDF = os.path.join(ROOT, "testdata", "urdf_corpus", "robots", "ur_description", "ur5_robot.urdf")
ROUNDS = int(os.environ.get("ROUNDS", "7"))
N = int(os.environ.get("BATCH", "1000"))


def measure(stmt, number):
    return timeit.timeit(stmt, number=number) / number * 1e6  # µs per call


def main():
    m = robosim.Model.from_urdf(URDF, tip="tool0")
    pm = pin.buildModelFromUrdf(URDF)
    pd = pm.createData()
    n = m.nq
    assert pm.nq == n, (pm.nq, n)
    rng = np.random.default_rng(1)
    Q = rng.uniform(-3, 3, (N, n))
    V = rng.normal(size=(N, n))
    A = rng.normal(size=(N, n))
    q, v, a = Q[0], V[0], A[0]
    # The two agree (else the comparison means nothing): RNEA and CRBA of the same state.
    assert np.allclose(m.rnea(q, v, a), pin.rnea(pm, pd, q, v, a), atol=1e-8)
    M = pin.crba(pm, pd, q)
    M = np.triu(M) + np.triu(M, 1).T
    assert np.allclose(m.crba(q), M, atol=1e-8)
    tool = pm.njoints - 1

    def pin_fk(q):
        pin.forwardKinematics(pm, pd, q)
        return pd.oMi[tool].homogeneous

    def pin_frames(q):
        pin.forwardKinematics(pm, pd, q)
        return [x.homogeneous for x in pd.oMi]

    def pin_jac(q):
        return pin.computeJointJacobian(pm, pd, q, tool)

    cases = [
        ("fk", lambda: m.fk(q), lambda: pin_fk(q), lambda: m.fk(Q), lambda: [pin_fk(x) for x in Q]),
        ("frames", lambda: m.frames(q), lambda: pin_frames(q), lambda: m.frames(Q), lambda: [pin_frames(x) for x in Q]),
        ("jacobian", lambda: m.jacobian(q, frame="tool"), lambda: pin_jac(q),
         lambda: m.jacobian(Q, frame="tool"), lambda: [pin_jac(x) for x in Q]),
        ("rnea", lambda: m.rnea(q, v, a), lambda: pin.rnea(pm, pd, q, v, a),
         lambda: m.rnea(Q, V, A), lambda: [pin.rnea(pm, pd, x, y, z) for x, y, z in zip(Q, V, A)]),
        ("crba", lambda: m.crba(q), lambda: pin.crba(pm, pd, q), lambda: m.crba(Q), lambda: [pin.crba(pm, pd, x) for x in Q]),
        ("aba", lambda: m.aba(q, v, a), lambda: pin.aba(pm, pd, q, v, a),
         lambda: m.aba(Q, V, A), lambda: [pin.aba(pm, pd, x, y, z) for x, y, z in zip(Q, V, A)]),
        ("gravity", lambda: m.gravity(q), lambda: pin.computeGeneralizedGravity(pm, pd, q),
         lambda: m.gravity(Q), lambda: [pin.computeGeneralizedGravity(pm, pd, x) for x in Q]),
    ]
    print(f"UR5 (n = {n}), robosim {robosim.__version__} ({os.environ.get('ROBOSIM_BUILD', 'build not stated')}), "
          f"pinocchio {pin.__version__}, numpy {np.__version__}, python {sys.version.split()[0]}; "
          f"{ROUNDS} interleaved rounds, µs per call: median (min..max)")
    print(f"| op | robosim 1 call | pin 1 call | ratio | robosim batch of {N}, per row | pin loop of {N}, per row | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, rs1, pn1, rsb, pnb in cases:
        t = {k: [] for k in ("rs1", "pn1", "rsb", "pnb")}
        for _ in range(ROUNDS):
            t["rs1"].append(measure(rs1, 2000))
            t["pn1"].append(measure(pn1, 2000))
            t["rsb"].append(measure(rsb, 5) / N)
            t["pnb"].append(measure(pnb, 5) / N)

        def cell(x):
            return f"{statistics.median(x):.2f} ({min(x):.2f}..{max(x):.2f})"

        r1 = statistics.median(t["rs1"]) / statistics.median(t["pn1"])
        rb = statistics.median(t["rsb"]) / statistics.median(t["pnb"])
        print(f"| {name} | {cell(t['rs1'])} | {cell(t['pn1'])} | {r1:.2f} | {cell(t['rsb'])} | {cell(t['pnb'])} | {rb:.2f} |")


if __name__ == "__main__":
    main()
