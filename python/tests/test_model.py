"""robosim.Model against the query protocol: every method gives the numbers the protocol's op
gives on the same robot and input (bit for bit: both sides run the same code on the same f64s,
and robosim.query moves numbers without text), and every batch gives its single calls' numbers
bit for bit. Errors are typed and name the argument."""

import os

import numpy as np
import pytest

import robosim

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
UR5_URDF = os.path.join(ROOT, "testdata", "urdf_corpus", "robots", "ur_description", "ur5_robot.urdf")
UR5_MJCF = os.path.join(ROOT, "testdata", "mjcf", "ur5.xml")
RNG = np.random.default_rng(7)


def configs(model, k):
    lim = model.limits()
    lo = np.maximum(lim[:, 0], -3.0)
    hi = np.minimum(lim[:, 1], 3.0)
    return lo + (hi - lo) * RNG.random((k, model.nq))


def same(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (a.shape, b.shape)
    assert np.array_equal(a, b), np.max(np.abs(a - b))


@pytest.fixture(scope="module")
def puma():
    return robosim.Model("puma560")


def test_a_name_resolves_as_the_protocol_does(puma):
    assert puma.name == "puma560" and puma.nq == puma.nv == 6
    with pytest.raises(robosim.RobotError) as e:
        robosim.Model("no_such_robot")
    assert e.value.kind == "unknown_robot" and "no_such_robot" in e.value.message


@pytest.mark.parametrize("name", ["puma560", "stanford", "panda"])
def test_kinematics_equal_the_protocols(name):
    m = robosim.Model(name)
    for q in configs(m, 5):
        r = robosim.query({"op": "fk", "robot": name, "q": q})
        same(m.fk(q), r["pose"])
        r = robosim.query({"op": "fk", "robot": name, "q": q, "frames": True})
        same(m.frames(q), np.stack(r["frames"]))
        for frame in ["base", "tool"]:
            r = robosim.query({"op": "jacobian", "robot": name, "q": q, "frame": frame})
            same(m.jacobian(q, frame=frame), r["jacobian"])


@pytest.mark.parametrize("name", ["puma560", "stanford", "panda"])
def test_dynamics_equal_the_protocols(name):
    m = robosim.Model(name)
    n = m.nq
    for q in configs(m, 4):
        v, a = RNG.normal(size=n), RNG.normal(size=n)
        same(m.rnea(q, v, a), robosim.query({"op": "id", "robot": name, "q": q, "qd": v, "qdd": a})["tau"])
        same(m.crba(q), robosim.query({"op": "mass_matrix", "robot": name, "q": q})["mass_matrix"])
        same(m.gravity(q), robosim.query({"op": "gravity", "robot": name, "q": q})["tau"])
        tau = RNG.normal(size=n)
        same(m.aba(q, v, tau), robosim.query({"op": "fd", "robot": name, "q": q, "qd": v, "tau": tau})["qdd"])


def test_rnea_and_aba_are_inverse_and_crba_is_the_mass_matrix(puma):
    # The same numbers as the protocol would be worthless if both were wrong: check the physics.
    q = configs(puma, 1)[0]
    v, a = RNG.normal(size=6), RNG.normal(size=6)
    tau = puma.rnea(q, v, a)
    assert np.allclose(puma.aba(q, v, tau), a, atol=1e-9)
    M = puma.crba(q)
    assert np.allclose(tau - puma.rnea(q, v, np.zeros(6)), M @ a, atol=1e-9)
    assert np.allclose(puma.gravity(q), puma.rnea(q, np.zeros(6), np.zeros(6)), atol=0)


@pytest.mark.parametrize("name", ["puma560", "panda"])
def test_batches_equal_single_calls_bit_for_bit(name):
    m = robosim.Model(name)
    n = m.nq
    Q, V, A = configs(m, 7), RNG.normal(size=(7, n)), RNG.normal(size=(7, n))
    cases = [
        (m.fk, (Q,)),
        (m.frames, (Q,)),
        (lambda q: m.jacobian(q, frame="tool"), (Q,)),
        (m.jacobian, (Q,)),
        (m.rnea, (Q, V, A)),
        (m.aba, (Q, V, A)),
        (m.crba, (Q,)),
        (m.gravity, (Q,)),
    ]
    for f, args in cases:
        batch = f(*args)
        assert batch.shape[0] == 7
        for i in range(7):
            same(batch[i], f(*(x[i] for x in args)))


def test_ik_every_method_equals_the_protocols(puma):
    q = np.array([0.1, 0.4, -0.9, 0.2, 0.3, 0.1])
    T = puma.fk(q)
    for method in ["analytic", "newton", "dls", "hybrid", "auto"]:
        req = {"op": "ik", "robot": "puma560", "pose": T, "method": method, "q0": q + 0.05}
        r = robosim.query(req)
        full = puma.ik(T, method=method, q0=q + 0.05, full=True)
        assert full["method"] == r["method"] and full["family"] == r["family"]
        assert len(full["solutions"]) == len(r["solutions"])
        for a, b in zip(full["solutions"], r["solutions"]):
            same(a["q"], b["q"])
            assert a.get("branch") == b.get("branch") and a["residual"] == b["residual"]
        same(puma.ik(T, method=method, q0=q + 0.05), r["solutions"][0]["q"])
        assert np.allclose(puma.fk(puma.ik(T, method=method, q0=q + 0.05)), T, atol=1e-7)


def test_ik_all_gives_every_analytic_branch(puma):
    T = puma.fk(np.array([0.1, 0.4, -0.9, 0.2, 0.3, 0.1]))
    r = robosim.query({"op": "ik", "robot": "puma560", "pose": T, "all": True, "method": "analytic"})
    sols = puma.ik(T, method="analytic", all=True)
    assert sols.shape == (len(r["solutions"]), 6) and len(sols) >= 4
    same(sols, np.stack([s["q"] for s in r["solutions"]]))
    branches = {s["branch"] for s in puma.ik(T, method="analytic", all=True, full=True)["solutions"]}
    assert len(branches) == len(sols), "each solution its own branch"
    for s in sols:
        assert np.allclose(puma.fk(s), T, atol=1e-7)


def test_ik_batches_and_tolerances(puma):
    Q = configs(puma, 5) * 0.3
    T = puma.fk(Q)
    batch = puma.ik(T, method="dls", q0=Q + 0.01, tol=1e-8)
    assert batch.shape == (5, 6)
    for i in range(5):
        same(batch[i], puma.ik(T[i], method="dls", q0=Q[i] + 0.01, tol=1e-8))
        r = robosim.query({"op": "ik", "robot": "puma560", "pose": T[i], "method": "dls", "q0": Q[i] + 0.01,
                           "tolerances": {"position": 1e-8, "orientation": 1e-8}})
        same(batch[i], r["solutions"][0]["q"])
    alls = puma.ik(T, method="analytic", all=True)
    assert isinstance(alls, list) and len(alls) == 5
    same(alls[2], puma.ik(T[2], method="analytic", all=True))


def test_ik_refusals_are_typed(puma):
    far = np.eye(4)
    far[:3, 3] = [10.0, 0, 0]
    with pytest.raises(robosim.UnreachableError) as e:
        puma.ik(far, method="analytic")
    assert e.value.kind == "unreachable"
    T = np.stack([puma.fk(np.zeros(6)), far])
    with pytest.raises(robosim.RobosimError, match="row 1"):
        puma.ik(T, method="analytic")
    with pytest.raises(robosim.RequestError, match="method"):
        puma.ik(far, method="magic")


def test_wrong_shapes_and_nans_name_the_argument(puma):
    with pytest.raises(robosim.RequestError, match=r"q: expected shape \(6,\) or \(N, 6\).*\(5,\)"):
        puma.fk(np.zeros(5))
    with pytest.raises(robosim.RequestError, match=r"q\[3\]: NaN is not a finite number"):
        puma.fk([0, 0, 0, np.nan, 0, 0])
    with pytest.raises(robosim.RequestError, match=r"v\[1, 2\]: inf is not a finite number"):
        v = np.zeros((2, 6))
        v[1, 2] = np.inf
        puma.rnea(np.zeros((2, 6)), v, np.zeros((2, 6)))
    with pytest.raises(robosim.RequestError, match="a is one configuration but q is a batch of 2"):
        puma.rnea(np.zeros((2, 6)), np.zeros((2, 6)), np.zeros(6))
    with pytest.raises(robosim.RequestError, match="frame"):
        puma.jacobian(np.zeros(6), frame="world")
    with pytest.raises(robosim.RequestError, match="not an array of numbers"):
        puma.gravity("abc")
    assert issubclass(robosim.RequestError, robosim.RobosimError)


def test_simulate_equals_the_protocols(puma):
    q0 = np.array([0, 0.5, -1, 0, 0.3, 0])
    r = robosim.query({"op": "simulate", "robot": "puma560", "q0": q0, "t_end": 0.2,
                       "outputs": [0, 0.1, 0.2], "integrator": "rk4", "dt": 0.001})
    s = puma.simulate(q0, 0.2, integrator="rk4", dt=0.001, outputs=[0, 0.1, 0.2])
    same(s["t"], [x["t"] for x in r["samples"]])
    same(s["q"], np.stack([x["q"] for x in r["samples"]]))
    same(s["qd"], np.stack([x["qd"] for x in r["samples"]]))
    same(s["energy"], [x["energy"] for x in r["samples"]])
    assert s["stats"] == r["stats"]
    assert not np.allclose(s["q"][0], s["q"][-1]), "an unheld arm falls"


def test_check_collide_and_distance_equal_the_protocols(puma):
    crate = {"name": "crate", "shape": "box", "size": [0.2, 0.2, 0.2], "pose": np.eye(4)}
    for q in configs(puma, 3):
        scene = {"objects": [crate]}
        r = robosim.query({"op": "check", "robot": "puma560", "q": q, "scene": scene})
        assert puma.check(q, scene).keys() == r.keys()
        assert puma.check(q, scene)["clear"] == r["clear"]
    Q = configs(puma, 3)
    batch = puma.check(Q, {"objects": [crate]}, self_collision=False)
    assert [b["clear"] for b in batch] == [puma.check(q, {"objects": [crate]}, self_collision=False)["clear"] for q in Q]
    sphere, box = {"shape": "sphere", "radius": 0.5}, {"shape": "box", "size": [1, 1, 1]}
    t = np.eye(4)
    t[0, 3] = 1.5
    r = robosim.query({"op": "collide", "a": sphere, "pose_a": np.eye(4), "b": box, "pose_b": t})
    c = robosim.collide(sphere, np.eye(4), box, t)
    assert c["distance"] == r["distance"] and c["intersect"] is False
    assert abs(robosim.distance(sphere, np.eye(4), box, t) - 0.5) < 1e-9
    t[0, 3] = 0.8
    assert robosim.distance(sphere, np.eye(4), box, t) < 0
    with pytest.raises(robosim.ShapeError):
        robosim.collide({"shape": "sphere", "radius": -1}, np.eye(4), box, t)


@pytest.mark.skipif(not os.path.exists(UR5_URDF), reason="testdata/urdf_corpus not present")
def test_a_urdf_file_is_the_protocols_urdf_robot():
    m = robosim.Model.from_urdf(UR5_URDF, tip="tool0")
    spec = {"urdf": UR5_URDF, "tip": "tool0"}
    q = configs(m, 1)[0]
    same(m.fk(q), robosim.query({"op": "fk", "robot": spec, "q": q})["pose"])
    same(m.crba(q), robosim.query({"op": "mass_matrix", "robot": spec, "q": q})["mass_matrix"])
    with pytest.raises(robosim.RobotError, match="robot.urdf"):
        robosim.Model.from_urdf("/no/such/file.urdf", tip="x")


@pytest.mark.skipif(not os.path.exists(UR5_MJCF), reason="testdata/mjcf not present")
def test_an_mjcf_file_is_the_protocols_mjcf_robot():
    m = robosim.Model.from_mjcf(UR5_MJCF, tip="wrist_3_link")
    spec = {"mjcf": UR5_MJCF, "tip": "wrist_3_link"}
    q = configs(m, 1)[0]
    same(m.frames(q), np.stack(robosim.query({"op": "fk", "robot": spec, "q": q, "frames": True})["frames"]))
    same(m.gravity(q), robosim.query({"op": "gravity", "robot": spec, "q": q})["tau"])
    with pytest.raises(robosim.RobotError, match="robot.mjcf"):
        robosim.Model.from_mjcf(UR5_MJCF, tip="no_such_body")


def test_an_inline_robot_round_trips(puma):
    m = robosim.Model.from_json(puma.to_json())
    q = configs(puma, 1)[0]
    same(m.fk(q), puma.fk(q))
    same(m.rnea(q, q, q), puma.rnea(q, q, q))


def test_a_session_robot_is_the_one_its_session_ops_use(lab):
    s = lab.attach()
    m = s.model("positioner")
    same(robosim.Model.from_session(s, "positioner").fk(s.joints("positioner")), m.fk(s.joints("positioner")))
    q = s.joints("positioner")
    same(m.jacobian(q), s.query({"op": "jacob", "robot": "positioner"})["jacobian"])
    T = m.fk(q)
    kinv = s.query({"op": "kinv", "robot": "positioner", "pose": T})
    same(m.ik(T, q0=q, full=True)["solutions"][0]["q"], kinv["solutions"][0]["q"])
    with pytest.raises(robosim.RobotError):
        s.model("no_such_robot")
