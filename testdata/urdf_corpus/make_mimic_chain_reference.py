#!/usr/bin/env python3
"""Mimic followers off a chain (issue 36 item 1): reference values for robosim's chain import
with its off-chain followers moving (robosim_urdf::urdf_import::import_urdf_with_followers, the
query protocol's {"urdf", "tip", "mimic": true}), for core/dynamics/tests/urdf_mimic.rs.

Run with the peer venv (pin 4.1), from the repository root:
    /work/peers-venv/bin/python testdata/urdf_corpus/make_mimic_chain_reference.py

The robot of a chain import with followers is: the movable joints on the chain root -> tip, plus
every movable joint off the chain that <mimic>s a movable chain joint (through other followers)
and hangs from the chain through fixed joints or other such followers; every other joint is held
at 0. This script works that set out from the file (independently of robosim) and builds it in
Pinocchio as pin.buildReducedModel(full model, every other movable joint locked, neutral q)
— the full model (mimic=False) so that the mimic relations are imposed in closed form as in
make_mimic_reference.py: q = phi(q_r), v = G v_r, tau_r = G^T tau, M_r = G^T M G, J_r = J G,
aba = M_r^-1 (tau_r - b_r). Where Pinocchio 4.1 builds the same reduced model from its own
mimic model (buildModelFromUrdf(mimic=True), the same joints locked), the script checks that both
agree (1e-11) and records "pinocchio_mimic_check": true.

reference: mimic_chain_reference.json — {"pinocchio", "seed", "robots": [...]}, per robot: file,
tip, free (the reduced coordinates' joint names: the chain's movable joints that follow nothing,
in chain order), moving_followers (the off-chain followers that move), followers ({name:
[leader, multiplier, offset]} of every follower in the model), samples: q, v, a, tau (free order),
rnea, gravity, M, aba, frames ({link: {pose 4x4, jacobian 6 x n_r LOCAL_WORLD_ALIGNED}} for the
tip and the child links of up to three moving followers). q uniform within limits ([-pi, pi]
without), v, a in [-1, 1], tau in [-5, 5]; numpy default_rng(362).
"""
import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = [
    ("pr2_description/pr2.urdf", "r_gripper_l_finger_tip_link"),
    ("tiago_pro_description/tiago_pro.urdf", "gripper_left_outer_finger_left_link"),
    ("baxter_description/baxter.urdf", "l_gripper_l_finger_tip"),
]
SAMPLES = 2
MOVABLE = ("revolute", "continuous", "prismatic")
rng = np.random.default_rng(362)


def vec(v):
    return [float(x) for x in np.asarray(v).ravel()]


def mat(m):
    return [[float(x) for x in row] for row in np.asarray(m)]


def read(path):
    root = ET.parse(path).getroot()
    joints = {}
    children = {}
    parent_joint = {}
    for j in root.findall("joint"):
        name = j.get("name")
        parent, child = j.find("parent").get("link"), j.find("child").get("link")
        m = j.find("mimic")
        joints[name] = {
            "type": j.get("type"), "parent": parent, "child": child,
            "mimic": None if m is None else (m.get("joint"), float(m.get("multiplier", 1.0)),
                                             float(m.get("offset", 0.0))),
        }
        children.setdefault(parent, []).append(name)
        parent_joint[child] = name
    return joints, children, parent_joint


def kept_joints(joints, children, parent_joint, tip):
    """The chain's movable joints and the off-chain followers that move (see the docstring)."""
    chain = []
    link = tip
    while link in parent_joint:
        chain.append(parent_joint[link])
        link = joints[parent_joint[link]]["parent"]
    chain.reverse()
    chain_set = set(chain)
    movable_chain = [j for j in chain if joints[j]["type"] in MOVABLE]
    last = max(i for i, j in enumerate(chain) if joints[j]["type"] in MOVABLE)

    def follows_chain(name):
        at = name
        for _ in range(len(joints) + 1):
            m = joints[at]["mimic"]
            if m is None:
                return at != name and at in chain_set and joints[at]["type"] in MOVABLE
            at = m[0]
        return False

    def collect(link):
        out = []
        for k in children.get(link, []):
            if k in chain_set:
                continue
            j = joints[k]
            if j["type"] == "fixed":
                sub = collect(j["child"])
                if sub:
                    out += [k] + sub
            elif j["type"] in MOVABLE and follows_chain(k):
                out += [k] + collect(j["child"])
        return out

    moving = []
    for i, k in enumerate(chain):
        if i < last:
            moving += [b for b in collect(joints[k]["child"]) if joints[b]["type"] in MOVABLE]
    return movable_chain, moving


def resolve(name, joints):
    m, c = 1.0, 0.0
    while joints[name]["mimic"] is not None:
        leader, mul, off = joints[name]["mimic"]
        c += m * off
        m *= mul
        name = leader
    return name, m, c


def is_continuous(j):
    return j.nq == 2 and j.nv == 1


def limits(model, name):
    j = model.joints[model.getJointId(name)]
    if is_continuous(j):
        return -np.pi, np.pi
    lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi - lo > 1e6:
        return -np.pi, np.pi
    return lo, hi


class Reduced:
    """The kept joints of a Pinocchio model (others locked at neutral), the relations imposed."""

    def __init__(self, model, keep, joints, free):
        lock = [model.getJointId(model.names[i]) for i in range(1, model.njoints)
                if model.names[i] not in keep]
        self.model = pin.buildReducedModel(model, lock, pin.neutral(model))
        self.data = self.model.createData()
        md = self.model
        self.joints, self.free = joints, free
        self.G = np.zeros((md.nv, len(free)))
        for jid in range(1, md.njoints):
            leader, m, _ = resolve(md.names[jid], joints)
            if md.joints[jid].nv:
                self.G[md.joints[jid].idx_v, free.index(leader)] = m

    def q(self, theta):
        md = self.model
        th = dict(zip(self.free, theta))
        q = pin.neutral(md)
        for jid in range(1, md.njoints):
            j = md.joints[jid]
            leader, m, c = resolve(md.names[jid], self.joints)
            x = m * th[leader] + c
            if is_continuous(j):
                q[j.idx_q], q[j.idx_q + 1] = np.cos(x), np.sin(x)
            else:
                q[j.idx_q] = x
        return q

    def sample(self, theta, v, a, tau, links):
        md, d, G = self.model, self.data, self.G
        q = self.q(theta)
        rec = {"rnea": vec(G.T @ pin.rnea(md, d, q, G @ v, G @ a)),
               "gravity": vec(G.T @ pin.computeGeneralizedGravity(md, d, q))}
        M = pin.crba(md, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        Mr = G.T @ M @ G
        b = G.T @ pin.rnea(md, d, q, G @ v, np.zeros(md.nv))
        rec["M"] = mat(Mr)
        rec["aba"] = vec(np.linalg.solve(Mr, tau - b))
        pin.computeJointJacobians(md, d, q)
        pin.updateFramePlacements(md, d)
        rec["frames"] = {}
        for l in links:
            fid = md.getFrameId(l)
            J = pin.getFrameJacobian(md, d, fid, pin.LOCAL_WORLD_ALIGNED)
            rec["frames"][l] = {"pose": mat(d.oMf[fid].homogeneous), "jacobian": mat(J @ G)}
        return rec


class MimicReduced:
    """Pinocchio's own mimic model, the same joints locked (a cross-check where it builds)."""

    def __init__(self, path, keep):
        model = pin.buildModelFromUrdf(path, mimic=True)
        lock = [i for i in range(1, model.njoints) if model.names[i] not in keep]
        self.model = pin.buildReducedModel(model, lock, pin.neutral(model))
        self.data = self.model.createData()
        md = self.model
        self.free = [md.names[j] for j in range(1, md.njoints) if md.joints[j].nv > 0]

    def sample(self, theta, v, a, links):
        md, d = self.model, self.data
        q = pin.neutral(md)
        for n, x in zip(self.free, theta):
            j = md.joints[md.getJointId(n)]
            if is_continuous(j):
                q[j.idx_q], q[j.idx_q + 1] = np.cos(x), np.sin(x)
            else:
                q[j.idx_q] = x
        out = {"rnea": pin.rnea(md, d, q, v, a)}
        M = pin.crba(md, d, q)
        out["M"] = np.triu(M) + np.triu(M, 1).T
        pin.framesForwardKinematics(md, d, q)
        out["poses"] = {l: d.oMf[md.getFrameId(l)].homogeneous for l in links}
        return out


def close(a, b, what, rel):
    a, b = np.asarray(a), np.asarray(b)
    err = np.abs(a - b).max() / max(1.0, np.abs(b).max())
    if err > 1e-11:
        raise SystemExit(f"{rel}: {what}: Pinocchio's mimic model and the closed form differ by {err:e}")


def main():
    out = {"pinocchio": pin.__version__, "example_robot_data": "6.0.0", "seed": 362, "robots": []}
    for rel, tip in CASES:
        path = os.path.join(HERE, "robots", rel)
        joints, children, parent_joint = read(path)
        movable_chain, moving = kept_joints(joints, children, parent_joint, tip)
        keep = set(movable_chain) | set(moving)
        free = [j for j in movable_chain if joints[j]["mimic"] is None]
        full = pin.buildModelFromUrdf(path)
        red = Reduced(full, keep, joints, free)
        links = [tip] + [joints[k]["child"] for k in moving[:3]]
        try:
            mim = MimicReduced(path, keep)
            assert sorted(mim.free) == sorted(free)
        except Exception as e:  # Pinocchio 4.1 refuses or reorders this mimic model
            mim, why = None, " ".join(str(e).split())
        rob = {"file": rel, "tip": tip, "free": free, "moving_followers": moving,
               "followers": {n: list(joints[n]["mimic"]) for n in sorted(keep)
                             if joints[n]["mimic"] is not None},
               "pinocchio_mimic_check": mim is not None}
        if mim is None:
            rob["pinocchio_mimic_refusal"] = why
        samples = []
        for _ in range(SAMPLES):
            theta = np.array([rng.uniform(*limits(full, n)) for n in free])
            n = len(free)
            v, a, tau = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-5, 5, n)
            rec = {"q": vec(theta), "v": vec(v), "a": vec(a), "tau": vec(tau)}
            rec.update(red.sample(theta, v, a, tau, links))
            if mim is not None:
                perm = [free.index(x) for x in mim.free]
                chk = mim.sample(theta[perm], v[perm], a[perm], links)
                close(chk["rnea"], np.asarray(rec["rnea"])[perm], "rnea", rel)
                close(chk["M"], np.asarray(rec["M"])[np.ix_(perm, perm)], "M", rel)
                for l in links:
                    close(chk["poses"][l], rec["frames"][l]["pose"], f"pose {l}", rel)
            samples.append(rec)
        rob["samples"] = samples
        out["robots"].append(rob)
        print(f"{rel} to {tip}: {len(free)} free, moving followers {moving}, "
              f"pinocchio mimic check {mim is not None}")
    with open(os.path.join(HERE, "mimic_chain_reference.json"), "w") as f:
        json.dump(out, f, separators=(",", ":"))


if __name__ == "__main__":
    main()
