#!/usr/bin/env python3
"""Mimic joints (issue 36 item 1): reference values for the corpus robots with movable <mimic>
joints, one coordinate for leader and follower, for robosim's test
core/dynamics/tests/urdf_mimic.rs (robosim_kinematics::mimic, robosim_dynamics::mimic over
robosim_urdf's UrdfRobot::coupling).

Run with the peer venv (pin 4.1), from the repository root:
    /work/peers-venv/bin/python testdata/urdf_corpus/make_mimic_reference.py

Robots: the vendored copies under robots/ (make_reference.py) that have a movable joint with
<mimic>, one file per package (panda, baxter, pr2, tiago_pro, romeo, talos_full_v2). Two
sources, both recorded per robot in "source":
  * "pinocchio mimic=True": pin.buildModelFromUrdf(file, mimic=True) — Pinocchio's own mimic
    model (JointModelMimic). Its RNEA, CRBA, generalised gravity, frame placements and frame
    Jacobians are used as they are; Pinocchio 4.1's ABA refuses mimic joints ("This algorithm
    does not support Joint Mimic type"), so "aba" is M_r^-1 (tau - b_r), solved by numpy from
    its CRBA and RNEA(q, v, 0).
  * "pinocchio full model, G applied": where Pinocchio 4.1 refuses the mimic model (romeo,
    talos_full_v2: "The parent joint of the mimic joint is not in the kinematic tree" — a
    follower before its leader in Pinocchio's traversal), the full model (mimic=False) with
    the relation imposed in closed form: q = phi(q_r), v = G v_r, tau_r = G^T tau,
    M_r = G^T M G, J_r = J G.
For the robots of the first kind the script also checks that both ways agree (1e-11).

reference: mimic_reference.json — {"pinocchio", "seed", "robots": [...]}, per robot: file,
source, free (the reduced coordinates' joint names, in Pinocchio's order), followers
({name: [leader, multiplier, offset]}), samples: q (one value per free joint: the angle of a
continuous one), v, a, tau, rnea, gravity, M (both triangles), aba, frames ({link: {pose 4x4,
jacobian 6 x n_r, LOCAL_WORLD_ALIGNED}} for up to three links that are the child of a movable
joint, followers' links first). q uniform within limits ([-pi, pi] without), v, a in [-1, 1],
tau in [-5, 5]; numpy default_rng(361). "aba" is null where M_r is singular (condition ≥ 1e12).
"""
import glob
import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
FILES = [
    "panda_description/panda.urdf",
    "baxter_description/baxter.urdf",
    "pr2_description/pr2.urdf",
    "tiago_pro_description/tiago_pro.urdf",
    "romeo_description/romeo.urdf",
    "talos_data/talos_full_v2.urdf",
]
SAMPLES = 2
rng = np.random.default_rng(361)


def vec(v):
    return [float(x) for x in np.asarray(v).ravel()]


def mat(m):
    return [[float(x) for x in row] for row in np.asarray(m)]


def mimic_tags(path):
    """{follower: (leader, multiplier, offset)} of the movable joints with <mimic>, and the
    child link of every movable joint."""
    root = ET.parse(path).getroot()
    tags, child = {}, {}
    for j in root.findall("joint"):
        if j.get("type") == "fixed":
            continue
        child[j.get("name")] = j.find("child").get("link")
        m = j.find("mimic")
        if m is not None:
            tags[j.get("name")] = (m.get("joint"), float(m.get("multiplier", 1.0)),
                                   float(m.get("offset", 0.0)))
    return tags, child


def solve(M, rhs):
    """M^-1 rhs; None where M is singular (a joint with no inertia outboard of it about its
    axis: romeo's fingers), which the test does not compare."""
    return vec(np.linalg.solve(M, rhs)) if np.linalg.cond(M) < 1e12 else None


def is_continuous(j):
    return j.nq == 2 and j.nv == 1


def resolve(name, tags):
    """A follower's free coordinate and its affine map (followers of followers composed)."""
    m, c = 1.0, 0.0
    while name in tags:
        leader, mul, off = tags[name]
        c += m * off
        m *= mul
        name = leader
    return name, m, c


class Full:
    """Pinocchio's full model with the mimic relations in closed form."""

    def __init__(self, path, tags):
        self.model = pin.buildModelFromUrdf(path)
        self.data = self.model.createData()
        md = self.model
        self.names = [md.names[j] for j in range(1, md.njoints)]
        self.free = [n for n in self.names if n not in tags]
        self.tags = tags
        nv, nr = md.nv, len(self.free)
        self.G = np.zeros((nv, nr))
        for jid in range(1, md.njoints):
            n = md.names[jid]
            leader, m, _ = resolve(n, tags)
            if leader in self.free:
                self.G[md.joints[jid].idx_v, self.free.index(leader)] = m

    def q(self, theta):
        md = self.model
        th = dict(zip(self.free, theta))
        q = pin.neutral(md)
        for jid in range(1, md.njoints):
            j = md.joints[jid]
            leader, m, c = resolve(md.names[jid], self.tags)
            x = m * th.get(leader, 0.0) + c
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
        rec["aba"] = solve(Mr, tau - b)
        pin.computeJointJacobians(md, d, q)
        pin.updateFramePlacements(md, d)
        rec["frames"] = {}
        for l in links:
            fid = md.getFrameId(l)
            J = pin.getFrameJacobian(md, d, fid, pin.LOCAL_WORLD_ALIGNED)
            rec["frames"][l] = {"pose": mat(d.oMf[fid].homogeneous), "jacobian": mat(J @ G)}
        return rec


class Mimic:
    """Pinocchio's own mimic model (buildModel(..., mimic=True))."""

    def __init__(self, path):
        self.model = pin.buildModelFromUrdf(path, mimic=True)
        self.data = self.model.createData()
        md = self.model
        self.joints = [(md.names[j], md.joints[j]) for j in range(1, md.njoints)
                       if md.joints[j].nv > 0]
        self.free = [n for n, _ in self.joints]

    def q(self, theta):
        q = pin.neutral(self.model)
        for (n, j), x in zip(self.joints, theta):
            if is_continuous(j):
                q[j.idx_q], q[j.idx_q + 1] = np.cos(x), np.sin(x)
            else:
                q[j.idx_q] = x
        return q

    def sample(self, theta, v, a, tau, links):
        md, d = self.model, self.data
        # Pinocchio's v order is its joints' idx_v order, which is self.free's
        assert [j.idx_v for _, j in self.joints] == list(range(md.nv))
        q = self.q(theta)
        rec = {"rnea": vec(pin.rnea(md, d, q, v, a)),
               "gravity": vec(pin.computeGeneralizedGravity(md, d, q))}
        M = pin.crba(md, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        b = pin.rnea(md, d, q, v, np.zeros(md.nv))
        rec["M"] = mat(M)
        rec["aba"] = solve(M, tau - b)
        pin.computeJointJacobians(md, d, q)
        pin.updateFramePlacements(md, d)
        rec["frames"] = {}
        for l in links:
            fid = md.getFrameId(l)
            J = pin.getFrameJacobian(md, d, fid, pin.LOCAL_WORLD_ALIGNED)
            rec["frames"][l] = {"pose": mat(d.oMf[fid].homogeneous), "jacobian": mat(J)}
        return rec


def limits(full, name):
    md = full.model
    j = md.joints[md.getJointId(name)]
    if is_continuous(j):
        return -np.pi, np.pi
    lo, hi = md.lowerPositionLimit[j.idx_q], md.upperPositionLimit[j.idx_q]
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi - lo > 1e6:
        return -np.pi, np.pi
    return lo, hi


def close(a, b, what, rel):
    a, b = np.asarray(a), np.asarray(b)
    err = np.abs(a - b).max() / max(1.0, np.abs(b).max())
    if err > 1e-11:
        raise SystemExit(f"{rel}: {what}: Pinocchio's mimic model and the closed form differ by {err:e}")


def main():
    out = {"pinocchio": pin.__version__, "example_robot_data": "6.0.0", "seed": 361,
           "robots": []}
    for rel in FILES:
        path = os.path.join(HERE, "robots", rel)
        tags, child = mimic_tags(path)
        full = Full(path, tags)
        try:
            mim = Mimic(path)
            source = "pinocchio mimic=True"
        except Exception as e:  # Pinocchio 4.1 refuses this mimic model
            mim, source = None, "pinocchio full model, G applied"
            refusal = " ".join(str(e).split())
        order = mim.free if mim else full.free
        followers = [n for n in full.names if n in tags]
        links = [child[n] for n in followers[:2]] + [child[order[-1]]]
        rob = {"file": rel, "source": source, "free": order,
               "followers": {n: list(tags[n]) for n in followers}}
        if mim is None:
            rob["pinocchio_refusal"] = refusal
        samples = []
        for _ in range(SAMPLES):
            theta = np.array([rng.uniform(*limits(full, n)) for n in order])
            nr = len(order)
            v, a, tau = rng.uniform(-1, 1, nr), rng.uniform(-1, 1, nr), rng.uniform(-5, 5, nr)
            rec = {"q": vec(theta), "v": vec(v), "a": vec(a), "tau": vec(tau)}
            if mim:
                rec.update(mim.sample(theta, v, a, tau, links))
                # the closed form over Pinocchio's full model, in the mimic model's order
                perm = [full.free.index(n) for n in order]
                inv = np.argsort(perm)
                th_f, v_f, a_f, t_f = (np.asarray(x)[inv] for x in (theta, v, a, tau))
                chk = full.sample(th_f, v_f, a_f, t_f, links)
                close(np.asarray(chk["rnea"])[perm], rec["rnea"], "rnea", rel)
                close(np.asarray(chk["M"])[np.ix_(perm, perm)], rec["M"], "M", rel)
                if rec["aba"] is not None:
                    close(np.asarray(chk["aba"])[perm], rec["aba"], "aba", rel)
                for l in links:
                    close(np.asarray(chk["frames"][l]["jacobian"])[:, perm],
                          rec["frames"][l]["jacobian"], f"jacobian {l}", rel)
                    close(chk["frames"][l]["pose"], rec["frames"][l]["pose"], f"pose {l}", rel)
            else:
                rec.update(full.sample(theta, v, a, tau, links))
            samples.append(rec)
        rob["samples"] = samples
        out["robots"].append(rob)
        print(f"{rel}: {source}, {len(order)} free of {len(full.names)}, frames {links}")
    with open(os.path.join(HERE, "mimic_reference.json"), "w") as f:
        json.dump(out, f, separators=(",", ":"))


if __name__ == "__main__":
    main()
