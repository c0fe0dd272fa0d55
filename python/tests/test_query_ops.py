"""Every op of the query protocol through Session.query, each answer checked for sense.

The op list is taken from the dispatcher itself ({"op": "ops"}): an op added to the protocol
without a case here fails test_every_op_has_a_case."""

import numpy as np
import pytest

import robosim

ROBOT = "positioner"
EYE = np.eye(4)


def close(a, b, tol=1e-9):
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=tol)


def tx(x, y, z):
    t = np.eye(4)
    t[:3, 3] = [x, y, z]
    return t


# ---- pure ops: the kinematics, dynamics, collision, library and automation areas ----


def case_fk(s):
    r = s.query({"op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "frames": True})
    T = r["pose"]
    assert T.shape == (4, 4) and close(T[3], [0, 0, 0, 1])
    assert close(T[:3, :3] @ T[:3, :3].T, np.eye(3))
    assert len(r["frames"]) >= 6  # every link frame (and the base)
    assert close(r["frames"][-1][:3, 3], T[:3, 3]) or len(r["frames"]) >= 6


def case_jacobian(s):
    r = s.query({"op": "jacobian", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.3, 0], "frame": "tool"})
    assert r["jacobian"].shape == (6, 6)
    # Numerical check of the linear rows in the base frame against fk differences.
    q = np.array([0, 0.5, -1, 0, 0.3, 0])
    J = s.query({"op": "jacobian", "robot": "puma560", "q": q, "frame": "base"})["jacobian"]
    h = 1e-6
    p0 = s.query({"op": "fk", "robot": "puma560", "q": q})["pose"][:3, 3]
    for j in range(6):
        dq = q.copy()
        dq[j] += h
        p1 = s.query({"op": "fk", "robot": "puma560", "q": dq})["pose"][:3, 3]
        assert close((p1 - p0) / h, J[:3, j], 1e-4)


def case_ik(s):
    q = np.array([0.1, 0.4, -0.9, 0.2, 0.3, 0.1])
    T = s.query({"op": "fk", "robot": "puma560", "q": q})["pose"]
    r = s.query({"op": "ik", "robot": "puma560", "pose": T, "all": True, "method": "analytic"})
    assert len(r["solutions"]) >= 2
    for sol in r["solutions"]:
        T2 = s.query({"op": "fk", "robot": "puma560", "q": sol["q"]})["pose"]
        assert close(T2, T, 1e-7)


def case_encoder_error(s):
    r12 = s.query({"op": "encoder_error", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.3, 0], "bits": 12})
    r16 = s.query({"op": "encoder_error", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.3, 0], "bits": 16})
    assert 0 < r16["position"] < r12["position"]


def case_id(s):
    q = [0, 0.5, -1, 0, 0.3, 0]
    tau = s.query({"op": "id", "robot": "puma560", "q": q, "qd": [0] * 6, "qdd": [0] * 6})["tau"]
    g = s.query({"op": "gravity", "robot": "puma560", "q": q})["tau"]
    assert close(tau, g, 1e-9), "at rest, inverse dynamics is the gravity torque"


def case_mass_matrix(s):
    M = s.query({"op": "mass_matrix", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.3, 0]})["mass_matrix"]
    assert M.shape == (6, 6) and close(M, M.T, 1e-9)
    assert np.all(np.linalg.eigvalsh(M) > 0)


def case_gravity(s):
    g = s.query({"op": "gravity", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.3, 0]})["tau"]
    assert g.shape == (6,) and abs(g[1]) > 1.0  # the shoulder holds the arm up


def case_fd(s):
    q = np.array([0, 0.5, -1, 0, 0.3, 0])
    g = s.query({"op": "gravity", "robot": "puma560", "q": q})["tau"]
    qdd = s.query({"op": "fd", "robot": "puma560", "q": q, "qd": [0] * 6, "tau": g})["qdd"]
    assert close(qdd, np.zeros(6), 1e-7), "the gravity torque holds the arm still"


def case_simulate(s):
    r = s.query({"op": "simulate", "robot": "puma560", "q0": [0, 0.5, -1, 0, 0.3, 0], "t_end": 0.2,
                 "outputs": [0, 0.2], "integrator": "rk4", "dt": 0.001})
    a, b = r["samples"][0], r["samples"][-1]
    assert a["t"] == 0 and abs(b["t"] - 0.2) < 1e-12
    assert not close(a["q"], b["q"]), "an unheld arm falls"
    assert np.isfinite(a["energy"]) and np.isfinite(b["energy"])


def case_collide(s):
    near = s.query({"op": "collide", "a": {"shape": "sphere", "radius": 0.5}, "pose_a": EYE,
                    "b": {"shape": "box", "size": [1, 1, 1]}, "pose_b": tx(1.5, 0, 0), "mode": "exact"})
    assert near["intersect"] is False and abs(near["distance"] - 0.5) < 1e-9
    hit = s.query({"op": "collide", "a": {"shape": "sphere", "radius": 0.5}, "pose_a": EYE,
                   "b": {"shape": "box", "size": [1, 1, 1]}, "pose_b": tx(0.8, 0, 0), "mode": "exact"})
    assert hit["intersect"] is True


def case_check_pure(s):
    crate = {"name": "crate", "shape": "box", "size": [0.2, 0.2, 0.2], "pose": tx(5, 5, 5)}
    r = s.query({"op": "check", "robot": "puma560", "q": [0] * 6, "scene": {"objects": [crate]}})
    assert r.get("status") == "clear" or r.get("clear") is True, r
    inside = {"name": "crate", "shape": "box", "size": [5, 5, 5], "pose": EYE}
    r = s.query({"op": "check", "robot": "puma560", "q": [0] * 6, "scene": {"objects": [inside]}})
    assert r.get("status") == "contact" or r.get("clear") is False, r


def case_lib_list(s):
    r = s.query({"op": "lib_list"})
    names = [d["name"] for d in r["declarations"]] if "declarations" in r else list(r)
    assert "surgical_positioner_cell" in str(r) and len(names) > 5


def case_lib_params(s):
    r = s.query({"op": "lib_params", "name": "station_truss"})
    assert "bays" in str(r) and "size" in str(r)


def case_lib_evaluate(s):
    r = s.query({"op": "lib_evaluate", "name": "aluminium"})
    assert "2700" in str(r) or "2.7" in str(r), r


def case_diag_check(s):
    r = s.query({"op": "diag_check", "model": "eclss"})
    assert r["consistent"] is True and r["alarms"] > 10


def case_diag_simulate(s):
    r = s.query({"op": "diag_simulate", "model": "eclss", "faults": [{"fault": "sorbent_bed_failure"}]})
    names = [a["alarm"] for a in r["alarms"]]
    assert names[0] == "A_co2_bed" and "A_co2_removal" in names
    times = [a["t"] for a in r["alarms"]]
    assert times == sorted(times)


def case_diag_diagnose(s):
    r = s.query({"op": "diag_diagnose", "model": "eclss", "alarms": [{"alarm": "A_shower_leak", "t": 0}]})
    assert r["components"] == ["shower_unit"]


def case_ops(s):
    ops = s.query({"op": "ops"})["ops"]
    assert {"op": "ops", "area": "transport"} in ops


# ---- session ops (the simulation library on the session's Instance Space) ----


def case_get_robot(s):
    r = s.query({"op": "get_robot", "robot": ROBOT})
    assert close(r["q"], s.joints(ROBOT))
    assert len(r["links"]) == len(r["q"]) == 6
    # The inline robot it returns is one every pure op takes: fk of it at q is the tool pose.
    T = s.query({"op": "fk", "robot": r["robot"], "q": r["q"]})["pose"]
    assert T.shape == (4, 4)


def case_movej(s):
    q0 = s.joints(ROBOT)
    q1 = q0.copy()
    q1[5] += 0.1
    r = s.query({"op": "movej", "robot": ROBOT, "q": q1})
    assert r["completed"] is True and r["steps_done"] == 1
    assert close(r["q"], q1) and close(s.joints(ROBOT), q1)
    assert r["version"] == s.snapshot().version
    with pytest.raises(robosim.JointLimitError):
        s.query({"op": "movej", "robot": ROBOT, "q": q1 + 100})
    assert close(s.joints(ROBOT), q1), "a refused move moves nothing"
    s.query({"op": "movej", "robot": ROBOT, "q": q0})


def case_moveji(s):
    q0 = s.joints(ROBOT)
    q1 = q0.copy()
    q1[5] += 0.2
    v0 = s.snapshot().version
    r = s.query({"op": "moveji", "robot": ROBOT, "q": q1, "steps": 4})
    assert r["completed"] is True and r["steps_done"] == 4
    assert r["version"] == v0 + 4, "one transaction per step"
    assert close(s.joints(ROBOT), q1)
    s.query({"op": "movej", "robot": ROBOT, "q": q0})


def _pose(s, name):
    return s.snapshot().pose(name)


def case_pretranslate(s):
    before = _pose(s, "head")
    r = s.query({"op": "pretranslate", "object": "head", "by": [0.01, 0, 0]})
    assert close(r["pose"][:3, 3] - before[:3, 3], [0.01, 0, 0], 1e-12)
    s.query({"op": "pretranslate", "object": "head", "by": [-0.01, 0, 0]})
    assert close(_pose(s, "head"), before, 1e-12)


def case_posttranslate(s):
    before = _pose(s, "head")
    r = s.query({"op": "posttranslate", "object": "head", "by": [0, 0, 0.01]})
    # Along the object's own z axis.
    assert close(r["pose"][:3, 3] - before[:3, 3], before[:3, 2] * 0.01, 1e-12)
    s.query({"op": "posttranslate", "object": "head", "by": [0, 0, -0.01]})
    assert close(_pose(s, "head"), before, 1e-12)


def case_prerotate(s):
    before = _pose(s, "head")
    r = s.query({"op": "prerotate", "object": "head", "axis": [0, 0, 1], "angle": 0.25})
    c, sn = np.cos(0.25), np.sin(0.25)
    R = np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1]])
    assert close(r["pose"][:3, :3], R @ before[:3, :3], 1e-12)
    s.query({"op": "prerotate", "object": "head", "axis": [0, 0, 1], "angle": -0.25})
    assert close(_pose(s, "head"), before, 1e-12)


def case_postrotate(s):
    before = _pose(s, "head")
    r = s.query({"op": "postrotate", "object": "head", "axis": [1, 0, 0], "angle": 0.5})
    c, sn = np.cos(0.5), np.sin(0.5)
    R = np.array([[1, 0, 0], [0, c, -sn], [0, sn, c]])
    assert close(r["pose"][:3, :3], before[:3, :3] @ R, 1e-12)
    assert close(r["pose"][:3, 3], before[:3, 3], 1e-12), "about its own origin"
    s.query({"op": "postrotate", "object": "head", "axis": [1, 0, 0], "angle": -0.5})
    assert close(_pose(s, "head"), before, 1e-12)


def case_kinv(s):
    robot = s.query({"op": "get_robot", "robot": ROBOT})
    q = robot["q"]
    T = s.query({"op": "fk", "robot": robot["robot"], "q": q})["pose"]
    r = s.query({"op": "kinv", "robot": ROBOT, "pose": T, "all": True})
    assert r["solutions"], "the pose it stands at is reachable"
    assert any(close(sol["q"], q, 1e-6) for sol in r["solutions"]), "its own q is a solution"


def case_jacob(s):
    r = s.query({"op": "jacob", "robot": ROBOT})
    J = r["jacobian"]
    assert J.shape == (6, 6)
    robot = s.query({"op": "get_robot", "robot": ROBOT})
    J2 = s.query({"op": "jacobian", "robot": robot["robot"], "q": robot["q"], "frame": "base"})["jacobian"]
    assert close(J, J2, 1e-9), "JACOB is the pure jacobian at the robot's own q and base"


def case_encoder(s):
    r = s.query({"op": "encoder", "robot": ROBOT, "bits": 12})
    assert r["position"] > 0 and r["orientation"] > 0
    assert len(r["resolution"]) == 6 and close(r["resolution"][0], 2 * np.pi / 4096, 1e-12)


def case_check_session(s):
    assert s.query({"op": "check", "robot": ROBOT})["status"] == "clear"


def case_use_dontuse(s):
    assert s.query({"op": "dontuse", "object": "head"}) == {"object": "head", "in_use": False}
    assert s.query({"op": "use", "object": "head"}) == {"object": "head", "in_use": True}
    with pytest.raises(robosim.RobosimError) as e:
        s.query({"op": "use", "object": "no_such_object"})
    assert e.value.kind == "unknown_object"


def case_c_switch(s):
    r = s.query({"op": "c_switch", "on": False})
    assert r["collision"] is False
    r = s.query({"op": "c_switch", "on": True, "mode": "polygon", "self_collision": False})
    assert (r["collision"], r["mode"], r["self_collision"]) == (True, "polygon", False)


def case_sim_state(s):
    st = s.query({"op": "sim_state"})
    assert st["mode"] == "lockstep" and st["robots"][0]["name"] == ROBOT
    assert close(st["robots"][0]["q"], s.sim.state()["robots"][0]["q"])


CASES = {
    ("fk", "kinematics"): case_fk,
    ("jacobian", "kinematics"): case_jacobian,
    ("ik", "kinematics"): case_ik,
    ("encoder_error", "kinematics"): case_encoder_error,
    ("id", "dynamics"): case_id,
    ("mass_matrix", "dynamics"): case_mass_matrix,
    ("gravity", "dynamics"): case_gravity,
    ("fd", "dynamics"): case_fd,
    ("simulate", "dynamics"): case_simulate,
    ("collide", "collision"): case_collide,
    ("check", "collision"): case_check_pure,
    ("lib_list", "library"): case_lib_list,
    ("lib_params", "library"): case_lib_params,
    ("lib_evaluate", "library"): case_lib_evaluate,
    ("diag_check", "automation"): case_diag_check,
    ("diag_simulate", "automation"): case_diag_simulate,
    ("diag_diagnose", "automation"): case_diag_diagnose,
    ("ops", "transport"): case_ops,
    ("get_robot", "session"): case_get_robot,
    ("movej", "session"): case_movej,
    ("moveji", "session"): case_moveji,
    ("pretranslate", "session"): case_pretranslate,
    ("posttranslate", "session"): case_posttranslate,
    ("prerotate", "session"): case_prerotate,
    ("postrotate", "session"): case_postrotate,
    ("kinv", "session"): case_kinv,
    ("jacob", "session"): case_jacob,
    ("encoder", "session"): case_encoder,
    ("check", "session"): case_check_session,
    ("use", "session"): case_use_dontuse,
    ("dontuse", "session"): case_use_dontuse,
    ("c_switch", "session"): case_c_switch,
    ("sim_state", "session"): case_sim_state,
}


def dispatcher_ops(s):
    return [(o["op"], o["area"]) for o in s.query({"op": "ops"})["ops"]]


def test_every_op_has_a_case(lab):
    missing = [o for o in dispatcher_ops(lab.attach()) if o not in CASES]
    assert not missing, f"ops of the protocol without a test case here: {missing}"


@pytest.mark.parametrize("op", sorted(CASES), ids=lambda o: f"{o[0]}-{o[1]}")
def test_op_answers_sanely(lab, op):
    s = lab.attach()
    assert op in dispatcher_ops(s), f"{op} is no longer an op of the protocol"
    CASES[op](s)
