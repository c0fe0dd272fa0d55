"""The Python planner client against real sessions (issue 16): attach, read, write, wait, query,
lock-step determinism, a planner killed with -9, refused transactions, missing sessions."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import robosim
from conftest import Procs

ROBOT = "positioner"
# Child planners import the same package this suite runs with.
PKG_PATH = os.path.dirname(os.path.dirname(os.path.abspath(robosim.__file__)))


def test_attaching_to_a_missing_session_raises_a_clear_error(lab):
    lab.attach()  # its home, where no session "nosuch" exists
    with pytest.raises(robosim.SessionError) as e:
        robosim.Session(f"nosuch{os.getpid()}")
    assert e.value.kind == "session"
    assert f"nosuch{os.getpid()}" in e.value.message
    assert lab.name in e.value.message, "the message lists the running sessions"
    assert isinstance(e.value, robosim.RobosimError)


def test_a_session_without_keeper_or_simulator_says_which_is_missing(procs):
    keeper = procs.start_keeper()
    s = procs.attach()
    with pytest.raises(robosim.SessionError) as e:
        s.sim.step(1)
    assert "no simulator runs" in e.value.message
    procs.stop(keeper)
    with pytest.raises(robosim.SessionError) as e:
        procs.attach()
    assert "no keeper" in e.value.message, e.value.message


def test_read_a_snapshot_as_numpy(lab):
    s = lab.attach()
    snap = s.snapshot()
    assert snap.version >= 1
    assert snap.robots() == [ROBOT]
    q = snap.joints(ROBOT)
    assert isinstance(q, np.ndarray) and q.dtype == np.float64 and q.shape == (6,)
    # The same joints through the query protocol's GET_ROBOT.
    r = s.query({"op": "get_robot", "robot": ROBOT})
    assert np.array_equal(r["q"], q)
    lim = snap.limits(ROBOT)
    assert lim.shape == (6, 2) and np.all(lim[:, 0] <= q) and np.all(q <= lim[:, 1])
    head = snap.pose("head")
    assert head.shape == (4, 4) and np.array_equal(head[3], [0, 0, 0, 1])
    with pytest.raises(robosim.RobosimError) as e:
        snap.joints("nobody")
    assert e.value.kind == "unknown_robot" and ROBOT in e.value.message


def test_write_is_acknowledged_and_another_planner_wakes_on_it(lab):
    writer, watcher = lab.attach(), lab.attach()
    while watcher.wait_change(0.0) is not None:
        pass  # what earlier tests committed
    q = writer.joints(ROBOT) + 0.01
    v = writer.set_joints(ROBOT, q)
    assert v == writer.version
    assert watcher.wait_change(timeout=5.0) == v
    assert np.array_equal(watcher.snapshot().joints(ROBOT), q), "bit for bit"
    # What it touched: the positioner's six links, their poses.
    v2 = writer.set_joints(ROBOT, q + 0.01)
    changes = watcher.wait_changes(timeout=5.0)
    assert [c["version"] for c in changes] == [v2]
    assert changes[0]["aspects"] == ["pose"]
    assert changes[0]["objects"] == [
        "waist", "upper", "elbow", "wrist_roll", "wrist_pitch", "tool_roll"
    ]


def test_wait_change_times_out_with_none(lab):
    s = lab.attach()
    while s.wait_change(0.0) is not None:
        pass
    t = time.monotonic()
    assert s.wait_change(timeout=0.2) is None
    assert time.monotonic() - t >= 0.2
    with pytest.raises(robosim.RobosimError) as e:
        s.wait_change(timeout=float("nan"))
    assert e.value.kind == "bad_request"


def test_refused_writes_raise_and_change_nothing(lab):
    s = lab.attach()
    v, q = s.version, s.joints(ROBOT)
    lim = s.snapshot().limits(ROBOT)
    beyond = q.copy()
    beyond[0] = lim[0, 1] + 0.1
    with pytest.raises(robosim.JointLimitError) as e:
        s.set_joints(ROBOT, beyond)
    assert e.value.kind == "joint_limit" and "joint 0" in e.value.message
    for bad, what in [
        (q[:3], "wrong length"),
        (np.full(6, np.nan), "NaN"),
        (np.zeros((2, 3)), "2-D"),
        ("abc", "text"),
    ]:
        with pytest.raises(robosim.RobosimError) as e:
            s.set_joints(ROBOT, bad)
        assert e.value.kind == "bad_request", what
    # The keeper refuses a transaction that would hang the robot under its own link; the other
    # op of the same transaction does not happen either.
    with pytest.raises(robosim.TransactionError) as e:
        s.transact([["set_joint", "waist", 0.5], ["attach", ROBOT, "waist"]])
    assert e.value.kind == "transaction" and "op 1" in e.value.message
    with pytest.raises(robosim.RobosimError) as e:
        s.transact([["set_joint", "nothing_here", 0.5]])
    assert e.value.kind == "unknown_object"
    assert s.version == v
    assert np.array_equal(s.joints(ROBOT), q)


def test_transactions_commit_all_their_ops(lab):
    s = lab.attach()
    head = s.snapshot().pose("head")
    moved = head.copy()
    moved[2, 3] += 0.001
    v = s.transact([["set_pose", "head", moved]])
    assert np.allclose(s.snapshot().pose("head"), moved, atol=1e-12)
    assert s.transact([["set_pose", "head", head]]) == v + 1


def test_query_answers_pure_and_session_ops(lab):
    s = lab.attach()
    fk = s.query({"op": "fk", "robot": "puma560", "q": np.zeros(6)})
    assert fk["pose"].shape == (4, 4)
    ops = {o["op"] for o in s.query({"op": "ops"})["ops"]}
    assert {"movej", "moveji", "kinv", "check", "fk", "ik", "sim_state"} <= ops
    # KINV of the pose the positioner's tool has now comes back to (one of) its joints.
    q = s.joints(ROBOT)
    inline = s.query({"op": "get_robot", "robot": ROBOT})["robot"]
    tool = s.query({"op": "fk", "robot": inline, "q": q})["pose"]
    if "base" not in inline:
        tool = s.snapshot().pose(ROBOT) @ tool
    kinv = s.query({"op": "kinv", "robot": ROBOT, "pose": tool, "all": True})
    assert any(np.allclose(sol["q"], q, atol=1e-6) for sol in kinv["solutions"])
    check = s.query({"op": "check", "robot": ROBOT})
    assert check["status"] in ("clear", "contact")
    with pytest.raises(robosim.RobosimError) as e:
        s.query({"op": "no_such_op"})
    assert e.value.kind == "unknown_op"
    with pytest.raises(robosim.RobosimError) as e:
        s.query({"op": "movej", "robot": ROBOT, "q": [0, 0]})
    assert e.value.kind == "bad_request"


def run_script(s, q0, target):
    """A lock-step planner script: commit q0, reset the simulator there, drive to target."""
    s.set_joints(ROBOT, q0)
    s.sim.reset()
    s.sim.target(ROBOT, target)
    log = []
    for _ in range(5):
        st = s.sim.step(20)
        r = st["robots"][0]
        log.append((st["steps"], r["q"].tobytes(), r["qd"].tobytes()))
    return log


def test_lock_step_is_deterministic_and_never_runs_ahead(lab):
    s = lab.attach()
    q0 = s.joints(ROBOT)
    target = q0 + np.array([0.2, -0.1, 0.1, 0.3, -0.2, 0.1])
    a = run_script(s, q0, target)
    b = run_script(s, q0, target)
    assert [x[0] for x in a] == [20, 40, 60, 80, 100]
    assert a == b, "same script, bit-identical states"
    assert a[0][1] != a[-1][1], "the robot moved"
    # Nothing runs between steps: the state stands still while the planner thinks.
    before = s.sim.state()
    time.sleep(0.2)
    after = s.sim.state()
    assert (before["steps"], before["run_steps"]) == (after["steps"], after["run_steps"])
    assert after["state"] == "paused" and after["queued_steps"] == 0
    with pytest.raises(robosim.SessionError) as e:
        s.sim.step(0)
    assert "`n` must be an integer" in e.value.message


PLANNER = textwrap.dedent(
    """
    import sys, robosim
    s = robosim.Session(sys.argv[1])
    q = s.joints("positioner")
    print("attached", flush=True)
    k = 0
    while True:
        k += 1
        q[5] = 0.001 * (k % 100)
        s.set_joints("positioner", q)
    """
)


def test_a_planner_killed_with_sigkill_leaves_the_session_intact(lab):
    s = lab.attach()
    child = subprocess.Popen(
        [sys.executable, "-c", PLANNER, lab.name],
        stdout=subprocess.PIPE,
        env=dict(os.environ, ROBOSIM_HOME=lab.home, PYTHONPATH=PKG_PATH),
    )
    try:
        assert child.stdout.readline().strip() == b"attached"
        v = s.version
        while s.wait_change(5.0) is not None and s.version < v + 20:
            pass  # it is writing
        assert s.version >= v + 20
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
    # The session goes on: writes, waits, queries, new attachments, the simulator.
    q = s.joints(ROBOT)
    q[5] = 0.5
    v = s.set_joints(ROBOT, q)
    assert np.array_equal(s.joints(ROBOT), q)
    other = lab.attach()
    assert other.snapshot().version == v
    assert other.sim.step(1)["queued_steps"] == 0
    assert s.query({"op": "check", "robot": ROBOT})["status"] in ("clear", "contact")


def test_the_surgical_planner_example_reaches_targets_on_the_head(lab):
    lab.attach()
    here = os.path.dirname(os.path.abspath(__file__))
    example = os.path.join(here, "..", "examples", "surgical_planner.py")
    out = subprocess.run(
        [sys.executable, example, "--session", lab.name],
        capture_output=True,
        text=True,
        env=dict(os.environ, ROBOSIM_HOME=lab.home, PYTHONPATH=PKG_PATH),
        timeout=300,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    assert "targets reached" in out.stdout
    assert "back home: done" in out.stdout


def run_fresh_session(tag):
    """The lock-step script on a fresh session of its own: returns the states it saw and the
    simulator's CSV log, read after the simulator stopped (it flushes on the way out)."""
    p = Procs(tag)
    try:
        p.start_keeper()
        sim = p.start_simulator()
        s = p.attach()
        q0 = s.joints(ROBOT)
        target = q0 + np.array([0.2, -0.1, 0.1, 0.3, -0.2, 0.1])
        s.set_joints(ROBOT, q0)
        s.sim.target(ROBOT, target)
        states = []
        for _ in range(5):
            st = s.sim.step(20)
            r = st["robots"][0]
            states.append((st["steps"], r["q"].tobytes(), r["qd"].tobytes()))
        log_path = s.sim.state()["robots"][0]["log"]
        del s
        p.stop(sim)
        with open(log_path, "rb") as f:
            log = f.read()
        return states, log
    finally:
        p.close()


def test_lock_step_is_bit_identical_across_fresh_sessions():
    a_states, a_log = run_fresh_session("deta")
    b_states, b_log = run_fresh_session("detb")
    assert a_states == b_states, "same script, two fresh sessions: bit-identical states"
    lines = a_log.splitlines()
    assert len(lines) >= 101, f"a header and a row per step: {len(lines)} lines"
    assert a_log == b_log, "the simulators' CSV logs are byte for byte the same"
    assert lines[1] != lines[-1], "the robot moved"
