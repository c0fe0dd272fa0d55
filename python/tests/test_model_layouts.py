"""robosim.Model on robots whose q is not one value per joint (issue 36): a floating root
(Solo-12 with a free-flyer or planar root), ball joints (testdata/ball/ball_tree.xml) and mimic
joints over the reduced coordinates (the corpus robots with <mimic>). Numbers against Pinocchio
4.1's, the same checked-in references the Rust tests read (testdata/floating/reference.json,
testdata/ball/reference.json, testdata/urdf_corpus/mimic_reference.json, each made by the
make_*.py script beside it), and bit for bit against the query protocol's ops on the same robot.
Tolerances as the Rust tests': poses and Jacobians 1e-12, dynamics 1e-10, relative to the
largest reference entry (or 1)."""

import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import robosim

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
SOLO = os.path.join(ROOT, "testdata", "urdf_corpus", "robots", "solo_description", "solo12.urdf")
BALL = os.path.join(ROOT, "testdata", "ball", "ball_tree.xml")
CORPUS = os.path.join(ROOT, "testdata", "urdf_corpus")
POSE_TOL = 1e-12
DYN_TOL = 1e-10


def load(*parts):
    with open(os.path.join(ROOT, *parts)) as f:
        return json.load(f)


def rel_err(got, want):
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, (got.shape, want.shape)
    return np.max(np.abs(got - want)) / max(1.0, np.max(np.abs(want)))


def close(got, want, tol, what):
    e = rel_err(got, want)
    assert e <= tol, f"{what}: {e:e}"


def same(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (a.shape, b.shape)
    assert np.array_equal(a, b), np.max(np.abs(a - b))


def movable_joints_depth_first(path):
    """The file's movable joints (name, child link) depth first from the root link, children in
    file order: the order robosim's whole-tree import gives q (and Pinocchio's, for these
    files) — worked out here from the file, independently of the importer."""
    root = ET.parse(path).getroot()
    joints = root.findall("joint")
    children = {}
    child_links = set()
    for j in joints:
        parent = j.find("parent").get("link")
        child = j.find("child").get("link")
        children.setdefault(parent, []).append(j)
        child_links.add(child)
    (base,) = [l.get("name") for l in root.findall("link") if l.get("name") not in child_links]
    out = []

    def visit(link):
        for j in children.get(link, []):
            if j.get("type") not in ("fixed",):
                out.append((j.get("name"), j.find("child").get("link")))
            visit(j.find("child").get("link"))

    visit(base)
    return out


# --- a floating root -------------------------------------------------------------------------


def floating_arg(kind):
    return True if kind == "free_flyer" else kind


@pytest.mark.parametrize("kind", ["free_flyer", "planar"])
def test_solo_on_a_floating_root_answers_pinocchios_values(kind):
    ref = load("testdata", "floating", "reference.json")
    (rob,) = [r for r in ref["robots"] if r["root"] == kind]
    m = robosim.Model.from_urdf(SOLO, floating=floating_arg(kind))
    assert (m.nq, m.nv, m.root) == (rob["nq"], rob["nv"], kind)
    names = [n for n, _ in movable_joints_depth_first(SOLO)]
    # Pinocchio's joint order is robosim's for this file: the vectors compare as they are
    assert names == rob["joints"]
    assert m.njoints == len(names) and m.coordinates == list(range(len(names)))
    assert m.limits().shape == (len(names), 2)
    qs = []
    for s in rob["samples"]:
        q, v, a, tau = (np.array(s[k]) for k in ("q", "v", "a", "tau"))
        qs.append(q)
        frames = m.frames(q)
        assert frames.shape == (len(names) + 2, 4, 4)
        for name, fr in s["frames"].items():
            link = 0 if name == "root_joint" else names.index(name) + 1
            close(frames[link], fr["pose"], POSE_TOL, f"{kind} frame {name}")
        tool = s["frames"][names[-1]]
        close(m.fk(q), tool["pose"], POSE_TOL, f"{kind} fk")
        j = m.jacobian(q)
        assert j.shape == (6, m.nv)
        close(j, tool["jacobian"], POSE_TOL, f"{kind} jacobian")
        close(m.rnea(q, v, a), s["rnea"], DYN_TOL, f"{kind} rnea")
        close(m.gravity(q), s["gravity"], DYN_TOL, f"{kind} gravity")
        close(m.aba(q, v, tau), s["aba"], DYN_TOL, f"{kind} aba")
        close(m.crba(q), s["M"], DYN_TOL, f"{kind} crba")
    # the protocol's ops on the same robot, bit for bit; a batch gives its rows
    robot = {"urdf": SOLO, "floating": floating_arg(kind)}
    qs = np.stack(qs)
    s = rob["samples"][0]
    q, v, a = (np.array(s[k]) for k in ("q", "v", "a"))
    same(m.fk(q), robosim.query({"op": "fk", "robot": robot, "q": q})["pose"])
    same(m.jacobian(q, frame="tool"),
         robosim.query({"op": "jacobian", "robot": robot, "q": q, "frame": "tool"})["jacobian"])
    same(m.rnea(q, v, a), robosim.query({"op": "id", "robot": robot, "q": q, "qd": v, "qdd": a})["tau"])
    same(m.crba(q), robosim.query({"op": "mass_matrix", "robot": robot, "q": q})["mass_matrix"])
    batch = m.fk(qs)
    assert batch.shape == (len(qs), 4, 4)
    for k, qk in enumerate(qs):
        same(batch[k], m.fk(qk))


def test_a_floating_q_is_sized_by_nq_and_its_quaternion_checked():
    m = robosim.Model.from_urdf(SOLO, floating=True)
    with pytest.raises(robosim.RequestError) as e:
        m.fk(np.zeros(12))
    assert "nq = 19" in e.value.message and "free_flyer" in e.value.message, e.value.message
    q = np.zeros(19)
    with pytest.raises(robosim.RequestError) as e:
        m.fk(q)  # a zero quaternion
    assert "not unit" in e.value.message, e.value.message
    q[6] = 1.0
    with pytest.raises(robosim.RequestError) as e:
        m.rnea(q, np.zeros(19), np.zeros(18))
    assert "nv = 18" in e.value.message, e.value.message
    # at rest in free fall: the base accelerates at g (in the base frame: identity here), the
    # joints not at all
    qdd = m.aba(q, np.zeros(18), np.zeros(18))
    close(qdd[:3], [0.0, 0.0, -9.81], DYN_TOL, "free fall")
    close(qdd[3:], np.zeros(15), DYN_TOL, "free fall")


def test_ik_on_a_floating_robot_holds_the_root_and_moves_one_leg():
    m = robosim.Model.from_urdf(SOLO, floating=True)
    s = load("testdata", "floating", "reference.json")["robots"][0]["samples"][0]
    q0 = np.array(s["q"])
    goal = q0.copy()
    goal[-3:] += [0.1, -0.2, 0.15]  # the last leg's three joints (the tool is its foot)
    pose = m.fk(goal)
    q = m.ik(pose, q0=q0, method="newton")
    assert q.shape == (19,)
    same(q[:7], q0[:7])  # the root is held where q0 puts it
    same(q[7:-3], q0[7:-3])  # the other legs as in q0
    close(m.fk(q), pose, 1e-6, "ik")
    with pytest.raises(robosim.RequestError) as e:
        m.ik(pose)
    assert "q0" in e.value.message, e.value.message


def test_simulate_a_floating_robot_integrates_on_the_manifold():
    m = robosim.Model.from_urdf(SOLO, floating=True)
    q0 = np.zeros(19)
    q0[2], q0[6] = 1.0, 1.0
    out = m.simulate(q0, 0.2, dt=1e-3, outputs=[0.1, 0.2])
    assert out["q"].shape == (2, 19) and out["qd"].shape == (2, 18)
    close(out["q"][-1, 2], 1.0 - 0.5 * 9.81 * 0.2**2, 1e-9, "fall")
    close(np.linalg.norm(out["q"][-1, 3:7]), 1.0, 1e-12, "unit quaternion")


# --- ball joints -----------------------------------------------------------------------------


def test_ball_joints_are_sized_by_nq_and_nv_and_match_pinocchio():
    ref = load("testdata", "ball", "reference.json")
    # the chain to the finger: shoulder (ball), elbow, wrist (ball), slide — the hip's branch
    # is held; q 4 + 1 + 4 + 1, v 3 + 1 + 3 + 1
    m = robosim.Model.from_mjcf(BALL, tip="finger")
    assert (m.nq, m.nv, m.njoints) == (10, 8, 4)
    chain = ["shoulder", "elbow", "wrist", "slide"]
    assert ref["joints"][:4] == chain
    robot = {"mjcf": BALL, "tip": "finger"}
    for s in ref["samples"]:
        q = np.array(s["q"][:10])
        v = np.array(s["v"][:8])
        frames = m.frames(q)
        for k, name in enumerate(chain):
            pose = np.array(s["frames"][name]["pose"]).reshape(4, 4)
            close(frames[k + 1], pose, POSE_TOL, f"ball frame {name}")
        close(m.fk(q), np.array(s["frames"]["slide"]["pose"]).reshape(4, 4), POSE_TOL, "ball fk")
        # the tree's Jacobian of the finger: its hip columns (the last 3) are zero
        jt = np.array(s["frames"]["slide"]["jacobian"]).reshape(6, ref["nv"])
        assert not jt[:, 8:].any()
        close(m.jacobian(q), jt[:, :8], POSE_TOL, "ball jacobian")
        tau = m.rnea(q, v, v)
        close(m.aba(q, v, tau), v, 1e-9, "aba undoes rnea")
        same(tau, robosim.query({"op": "id", "robot": robot, "q": q, "qd": v, "qdd": v})["tau"])
        same(m.crba(q), robosim.query({"op": "mass_matrix", "robot": robot, "q": q})["mass_matrix"])
    with pytest.raises(robosim.RequestError) as e:
        m.fk(np.zeros(4))
    assert "nq = 10" in e.value.message and "ball" in e.value.message, e.value.message


# --- mimic joints ----------------------------------------------------------------------------


def mimic_robots():
    return load("testdata", "urdf_corpus", "mimic_reference.json")["robots"]


@pytest.mark.parametrize("rob", mimic_robots(), ids=lambda r: r["file"].split("/")[0])
def test_mimic_true_answers_pinocchios_mimic_model(rob):
    path = os.path.join(CORPUS, "robots", rob["file"])
    m = robosim.Model.from_urdf(path, mimic=True)
    joints = movable_joints_depth_first(path)
    names = [n for n, _ in joints]
    free = [names[c] for c in m.coordinates]
    assert m.njoints == len(names)
    assert sorted(free) == sorted(rob["free"]), rob["file"]
    assert m.nq == m.nv == len(free) < len(names)
    assert not set(free) & set(rob["followers"])
    # Pinocchio's order → robosim's
    perm = [free.index(n) for n in rob["free"]]

    def ours(x):
        out = np.zeros(len(x))
        out[perm] = x
        return out

    tool_link = joints[-1][1]
    for s in rob["samples"]:
        q, v, a, tau = (ours(s[k]) for k in ("q", "v", "a", "tau"))
        close(m.rnea(q, v, a), ours(s["rnea"]), DYN_TOL, "rnea")
        close(m.gravity(q), ours(s["gravity"]), DYN_TOL, "gravity")
        mr = np.array(s["M"])
        close(m.crba(q), mr[np.ix_(np.argsort(perm), np.argsort(perm))], DYN_TOL, "crba")
        if s["aba"] is not None:
            close(m.aba(q, v, tau), ours(s["aba"]), DYN_TOL, "aba")
        frames = m.frames(q)
        assert frames.shape == (len(names) + 2, 4, 4)
        for link, fr in s["frames"].items():
            k = [c for _, c in joints].index(link)
            close(frames[k + 1], fr["pose"], POSE_TOL, f"frame {link}")
            if link == tool_link:
                close(m.fk(q), fr["pose"], POSE_TOL, "fk")
                jr = np.array(fr["jacobian"])
                close(m.jacobian(q), jr[:, np.argsort(perm)], POSE_TOL, "jacobian")


def test_mimic_true_equals_the_protocols_mimic_ops_and_refuses_the_others():
    path = os.path.join(CORPUS, "robots", "panda_description", "panda.urdf")
    m = robosim.Model.from_urdf(path, mimic=True)
    assert robosim.Model.from_json({"urdf": path, "mimic": True}).nq == m.nq == 8
    full = robosim.Model.from_urdf(path, tip="panda_leftfinger")
    assert full.nq == 8  # the chain: the other finger held, not a coordinate
    off = robosim.Model.from_json({"urdf": path, "tip": "panda_leftfinger", "mimic": False})
    assert off.nq == full.nq and off.coordinates == full.coordinates
    robot = {"urdf": path, "mimic": True}
    rng = np.random.default_rng(36)
    q, v, a = rng.uniform(-0.5, 0.5, (3, 8))
    q[7] = 0.02
    same(m.fk(q), robosim.query({"op": "fk", "robot": robot, "q": q})["pose"])
    same(m.jacobian(q), robosim.query({"op": "jacobian", "robot": robot, "q": q})["jacobian"])
    same(m.rnea(q, v, a), robosim.query({"op": "id", "robot": robot, "q": q, "qd": v, "qdd": a})["tau"])
    same(m.crba(q), robosim.query({"op": "mass_matrix", "robot": robot, "q": q})["mass_matrix"])
    same(m.gravity(q), robosim.query({"op": "gravity", "robot": robot, "q": q})["tau"])
    same(m.aba(q, v, a), robosim.query({"op": "fd", "robot": robot, "q": q, "qd": v, "tau": a})["qdd"])
    # the follower's link moves with its leader: finger 2 mirrors finger 1 about the hand
    frames = m.frames(q)
    assert frames.shape == (11, 4, 4)
    q2 = q.copy()
    q2[7] = 0.03
    moved = m.frames(q2)
    for k in (8, 9):
        assert np.linalg.norm(moved[k][:3, 3] - frames[k][:3, 3]) == pytest.approx(0.01, abs=1e-12)
    with pytest.raises(robosim.RequestError) as e:
        m.fk(np.zeros(9))
    assert "mimic" in e.value.message and "nq = 8" in e.value.message, e.value.message
    for call in (lambda: m.ik(m.fk(q)), lambda: m.simulate(q, 0.1), lambda: m.check(q, {"objects": []})):
        with pytest.raises(robosim.RequestError) as e:
            call()
        assert "mimic=True" in e.value.message, e.value.message


def test_mimic_true_on_a_chain_moves_the_followers_off_it():
    """A chain to a gripper finger with mimic=True: the followers of its joints that hang off
    the chain (the other fingers) move with their leaders — Pinocchio 4.1's values from
    testdata/urdf_corpus/mimic_chain_reference.json (make_mimic_chain_reference.py); the
    reduced coordinates are the chain's free joints, in chain order."""
    ref = load("testdata", "urdf_corpus", "mimic_chain_reference.json")
    for rob in ref["robots"]:
        path = os.path.join(CORPUS, "robots", rob["file"])
        m = robosim.Model.from_urdf(path, tip=rob["tip"], mimic=True)
        plain = robosim.Model.from_urdf(path, tip=rob["tip"])
        assert m.nq == m.nv == len(rob["free"]), rob["file"]
        assert m.njoints > plain.njoints  # the moving followers are joints of the model
        for s in rob["samples"]:
            q, v, a, tau = (np.array(s[k]) for k in ("q", "v", "a", "tau"))
            close(m.rnea(q, v, a), s["rnea"], DYN_TOL, f"{rob['file']} rnea")
            close(m.gravity(q), s["gravity"], DYN_TOL, f"{rob['file']} gravity")
            close(m.crba(q), s["M"], DYN_TOL, f"{rob['file']} crba")
            close(m.aba(q, v, tau), s["aba"], DYN_TOL, f"{rob['file']} aba")
            tip = s["frames"][rob["tip"]]
            close(m.fk(q), tip["pose"], POSE_TOL, f"{rob['file']} fk")
            close(m.jacobian(q), tip["jacobian"], POSE_TOL, f"{rob['file']} jacobian")
            frames = m.frames(q)
            poses = [f for f in frames]
            for link, fr in s["frames"].items():
                if link == rob["tip"]:
                    continue
                # a follower's link frame is one of the model's frames
                err = min(rel_err(p, fr["pose"]) for p in poses)
                assert err <= POSE_TOL, f"{rob['file']} {link}: {err:e}"
