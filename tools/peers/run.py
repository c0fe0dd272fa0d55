#!/usr/bin/env python3
"""robosim beside its peers on the same inputs, in interleaved rounds; writes docs/bench/peers.md.

    tools/peers/setup.sh /path/to/venv                # once: the peers (requirements.txt)
    /path/to/venv/bin/python tools/peers/run.py [--rounds 5] [--no-build] [--only kin,dyn,...]
        [--out docs/bench/peers.md]

Run from anywhere; it builds what it times (release: the examples `peer_timing` of
robosim-kinematics, `peer_distance` of robosim-collision, `collide_rate` and `query` of
robosim-hl-interface, the criterion bench `station_check` of robosim-collision, and the Python
package's extension
`robosim-python`, copied with python/robosim/*.py into a temporary site directory) unless
--no-build. CI does not run it.

Every measure is one section below; each round runs every section once, and each section runs
robosim and then the peer back to back on the same inputs, so the two see the same machine
load; the table gives the median over the rounds of the per-round ratio robosim / peer (lower:
robosim faster) with its min–max, and the agreement of the two results. The scripts beside this
one hold each peer's side (kinematics.py, station_check_coal.py, collision_tolerance_coal.py,
collide_rate_coal.py); testdata/dynamics/gen_reference.py builds the DH robots' Pinocchio models.

Binding overhead (what a Python call costs with nothing to compute) is measured in the same round
and subtracted from the peer's time where the peer is called per item from Python:
  Pinocchio   the same function on an EMPTY model (universe only, q of size 0);
  coal        distance: coal.distance of two spheres (its closed form); station check: collide
              against an empty manager;
  Robotics Toolbox  ik_LM on a target its start already solves (one iteration);
robosim's own side is native wherever a native timing program exists (kinematics, collision,
query protocol) and otherwise one Python call over a batch of N items (dynamics, simulate, IK),
which spreads its binding over N; the per-row array copies stay in robosim's figure. MuJoCo's
mj_step takes nstep, so both RK4 sides are one call of many steps. The query-protocol rows are
whole request streams on both sides (robosim: the `query` example reading a file, its start-up
measured on a one-line file and subtracted; peer: a Python loop parsing, computing, answering).
"""

import argparse
import glob
import importlib.util
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import timeit

import numpy as np

sys.dont_write_bytecode = True  # nothing written beside the scripts
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
REL = os.path.join(TARGET, "release")


def load_module(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ---------------------------------------------------------------------------------------------
# building and robosim's native timing programs

def build(site):
    env = dict(os.environ, CARGO_INCREMENTAL="0")
    cmds = [
        ["cargo", "build", "--release", "-p", "robosim-kinematics", "--example", "peer_timing"],
        ["cargo", "build", "--release", "-p", "robosim-collision", "--example", "peer_distance"],
        ["cargo", "build", "--release", "-p", "robosim-hl-interface", "--example", "collide_rate",
         "--example", "query"],
        ["cargo", "bench", "--no-run", "-p", "robosim-collision", "--bench", "station_check"],
        ["cargo", "build", "--release", "-p", "robosim-python"],
    ]
    for c in cmds:
        print("+", " ".join(c), file=sys.stderr)
        if subprocess.run(c, cwd=ROOT, env=env).returncode != 0:
            # a shared tree: someone's half-done edit elsewhere; the last good build is used
            # if there is one, and the doc says when each binary was built
            NOTES.append(f"`{' '.join(c)}` failed at this run; the binaries it makes are from "
                         "an earlier build (times below).")
    install_module(site)


NOTES = []


def built_at(path):
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(os.path.getmtime(path))) if os.path.exists(path) else "missing"


def install_module(site):
    pkg = os.path.join(site, "robosim")
    os.makedirs(pkg, exist_ok=True)
    for f in glob.glob(os.path.join(ROOT, "python", "robosim", "*")):
        shutil.copy(f, pkg)
    shutil.copy(os.path.join(REL, "lib_robosim.so"), os.path.join(pkg, "_robosim.abi3.so"))


def bench_binary(name):
    hits = [p for p in glob.glob(os.path.join(REL, "deps", name + "-*")) if os.access(p, os.X_OK)
            and not p.endswith(".d")]
    if not hits:
        sys.exit(f"no bench binary {name}: run without --no-build")
    return max(hits, key=os.path.getmtime)


def criterion(binary, bench_id, home):
    """One short criterion run of one benchmark id: its median estimate, seconds."""
    subprocess.run([binary, "--bench", "--warm-up-time", "0.5", "--measurement-time", "1.5",
                    "--noplot", "--exact", bench_id], check=True, capture_output=True,
                   env=dict(os.environ, CRITERION_HOME=home))
    group, function = bench_id.split("/", 1)  # criterion's directory: group/function with _ for /
    with open(os.path.join(home, group, function.replace("/", "_"), "new", "estimates.json")) as f:
        return json.load(f)["median"]["point_estimate"] * 1e-9


def ns(f, number, repeat=7):
    """ns per call of f: the median over `repeat` passes of `number` calls (a pass another
    process interrupted does not move the median; a mean would carry it)."""
    return statistics.median(timeit.repeat(f, number=number, repeat=repeat)) / number * 1e9


# ---------------------------------------------------------------------------------------------
# sections: setup(); run() -> {key: value} for one round; rows(rounds) -> table rows

class Kinematics:
    """FK (all frames) and the tool frame's world-axes Jacobian: robosim's peer_timing (native)
    against Pinocchio's forwardKinematics / computeFrameJacobian(LOCAL_WORLD_ALIGNED)."""
    name = "kin"

    def setup(self):
        import pinocchio as pin
        import robosim
        self.k = load_module("peer_kinematics", os.path.join(HERE, "kinematics.py"))
        self.exe = os.path.join(REL, "examples", "peer_timing")
        self.models = self.k.models()
        rng = np.random.default_rng(37)
        self.qs = {n: self.k.samples(m, rng) for n, _, m, _ in self.models}
        self.files = [os.path.join(self.k.OUT, n + ".json") for n, *_ in self.models]
        self.agree = {}
        for name, robot, model, fid in self.models:
            rs = robosim.Model(robot["builtin"]) if "builtin" in robot else robosim.Model.from_json(robot)
            data = model.createData()
            dfk = djac = 0.0
            for q in self.qs[name]:
                pin.forwardKinematics(model, data, q)
                pin.updateFramePlacements(model, data)
                J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
                dfk = max(dfk, np.abs(rs.fk(q) - data.oMf[fid].homogeneous).max())
                djac = max(djac, np.abs(rs.jacobian(q, frame="base") - J).max())
            self.agree[(name, "fk_all")] = dfk
            self.agree[(name, "jacobian")] = djac

    def run(self):
        rs = self.k.robosim_times(self.exe, self.files, 300_000)
        out = {}
        for name, _, model, fid in self.models:
            p = self.k.pinocchio_times(model, fid, self.qs[name], 3000)
            for op in ["fk_all", "jacobian"]:
                net = p[op] - p[op + "_empty"]
                out[(name, op)] = (rs[(name, op)], net, p[op + "_empty"])
        return out

    def rows(self, rounds):
        import pinocchio as pin
        label = {"fk_all": "FK, all frames", "jacobian": "frame Jacobian (tool, world axes)"}
        for name, *_ in self.models:
            for op in ["fk_all", "jacobian"]:
                v = [r[(name, op)] for r in rounds]
                was = {"fk_all": "1.50× (PUMA), 1.93–1.95× (URDF)", "jacobian": "1.37–1.42×"}[op]
                yield row(f"{label[op]}, {name}", f"Pinocchio {pin.__version__}", v,
                          f"{self.agree[(name, op)]:.1e} (tool pose)" if op == "fk_all"
                          else f"{self.agree[(name, op)]:.1e}", "ns", goal=1.0, was=was)


class Dynamics:
    """RNEA and ABA: robosim's batch call (1000 rows, one Python call) against Pinocchio's
    rnea/aba called per row minus the empty-model call; each the median of repeated passes; the
    DH robots of testdata/dynamics/robots (Pinocchio models from gen_reference.py)."""
    name = "dyn"
    ROBOTS = ["puma560", "panda", "stanford"]
    N = 1000

    def setup(self):
        import pinocchio as pin
        import robosim
        g = load_module("gen_reference", os.path.join(ROOT, "testdata", "dynamics", "gen_reference.py"))
        self.pin = pin
        self.cases = []
        rng = np.random.default_rng(37)
        empty = pin.Model()
        self.empty = (empty, empty.createData(), np.zeros(0))
        for name in self.ROBOTS:
            with open(os.path.join(ROOT, "testdata", "dynamics", "robots", name + ".json")) as f:
                robot = json.load(f)
            pm = g.to_pinocchio(robot)
            pd = pm.createData()
            rs = robosim.Model.from_json(robot)
            n = rs.nq
            lo = np.array([j["qlim"][0] for j in robot["joints"]])
            hi = np.array([j["qlim"][1] for j in robot["joints"]])
            Q = rng.uniform(lo, hi, (self.N, n))
            V = rng.normal(size=(self.N, n))
            A = rng.normal(size=(self.N, n))
            T = np.array([pin.rnea(pm, pd, q, v, a) for q, v, a in zip(Q, V, A)])
            d_rnea = np.abs(rs.rnea(Q, V, A) - T).max()
            d_aba = np.abs(rs.aba(Q, V, T) - np.array([pin.aba(pm, pd, q, v, t) for q, v, t in zip(Q, V, T)])).max()
            self.cases.append((name, rs, pm, pd, Q, V, A, T, {"rnea": d_rnea, "aba": d_aba}))

    def run(self):
        pin = self.pin
        em, ed, z = self.empty
        out = {}
        idx = range(200)
        floor = {"rnea": ns(lambda: [pin.rnea(em, ed, z, z, z) for _ in idx], 1, 15) / 200,
                 "aba": ns(lambda: [pin.aba(em, ed, z, z, z) for _ in idx], 1, 15) / 200}
        for name, rs, pm, pd, Q, V, A, T, _ in self.cases:
            ours = ns(lambda: rs.rnea(Q, V, A), 1) / self.N
            peer = ns(lambda: [pin.rnea(pm, pd, q, v, a) for q, v, a in zip(Q, V, A)], 1) / self.N
            out[(name, "rnea")] = (ours, peer - floor["rnea"], floor["rnea"])
            ours = ns(lambda: rs.aba(Q, V, T), 1) / self.N
            peer = ns(lambda: [pin.aba(pm, pd, q, v, t) for q, v, t in zip(Q, V, T)], 1) / self.N
            out[(name, "aba")] = (ours, peer - floor["aba"], floor["aba"])
        return out

    def rows(self, rounds):
        for name, *_, agree in self.cases:
            for op in ["rnea", "aba"]:
                yield row(f"{op.upper()}, {name}", f"Pinocchio {self.pin.__version__}",
                          [r[(name, op)] for r in rounds], f"{agree[op]:.1e} N·m" if op == "rnea"
                          else f"{agree[op]:.1e} rad/s²", "ns",
                          was={"rnea": "0.44–0.51×", "aba": "0.56–0.60×"}[op])


def committed(rel):
    """The file as committed at HEAD (a temporary copy): the tree is shared, and a half-written
    export in the working tree must not change what is timed. The working file without git."""
    try:
        text = subprocess.run(["git", "show", f"HEAD:{rel}"], cwd=ROOT, check=True,
                              capture_output=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return os.path.join(ROOT, rel)
    path = os.path.join(tempfile.mkdtemp(prefix="peers_"), os.path.basename(rel))
    with open(path, "wb") as f:
        f.write(text)
    return path


class Rk4:
    """One RK4 step: robosim's simulate (rk4, fixed step, 1000 steps in one call) against
    MuJoCo's mj_step(nstep=1000) with the RK4 integrator, on the MJCF robosim exports
    (testdata/mjcf/exports, read by both; armature kept on both sides); contacts, limits,
    equality constraints, joint damping and friction loss off in MuJoCo (robosim's simulate
    is the rigid-body model: limits=False, no joint friction effect)."""
    name = "rk4"
    FILES = ["ur5", "panda_arm", "puma560"]
    STEPS, DT = 1000, 1e-3

    def setup(self):
        import mujoco
        import robosim
        self.mj = mujoco
        self.cases = []
        for f in self.FILES:
            path = committed(os.path.join("testdata", "mjcf", "exports", f + ".xml"))
            rs = robosim.Model.from_mjcf(path)
            mm = mujoco.MjModel.from_xml_path(path)
            mm.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
            mm.opt.timestep = self.DT
            D = mujoco.mjtDisableBit
            mm.opt.disableflags |= int(D.mjDSBL_CONTACT) | int(D.mjDSBL_LIMIT) | int(D.mjDSBL_EQUALITY)
            # robosim's simulate is the rigid-body model (joint friction only when the effect
            # is declared): the exports' joint damping and friction loss off on MuJoCo's side
            mm.dof_damping[:] = 0.0
            mm.dof_frictionloss[:] = 0.0
            md = mujoco.MjData(mm)
            n = rs.nq
            assert mm.nq == n, (f, mm.nq, n)
            q0 = np.linspace(0.1, 0.6, n) * np.where(np.arange(n) % 2, -1.0, 1.0)
            got = rs.simulate(q0, self.STEPS * self.DT, integrator="rk4", dt=self.DT)["q"][-1]
            self.reset(mm, md, q0)
            mujoco.mj_step(mm, md, nstep=self.STEPS)
            self.cases.append((f, rs, mm, md, q0, np.abs(got - md.qpos).max()))

    def reset(self, mm, md, q0):
        self.mj.mj_resetData(mm, md)
        md.qpos[:] = q0

    def run(self):
        out = {}
        for f, rs, mm, md, q0, _ in self.cases:
            t_end = self.STEPS * self.DT
            ours = ns(lambda: rs.simulate(q0, t_end, integrator="rk4", dt=self.DT), 1, 5) / self.STEPS

            def peer():
                self.reset(mm, md, q0)
                self.mj.mj_step(mm, md, nstep=self.STEPS)
            out[f] = (ours, ns(peer, 1, 5) / self.STEPS, 0.0)
        return out

    def rows(self, rounds):
        for f, *_, agree in self.cases:
            yield row(f"RK4 step (1 ms), {f} (MJCF)", f"MuJoCo {self.mj.__version__}",
                      [r[f] for r in rounds], f"{agree:.1e} rad (q after 1 s)", "ns", was="0.48×")


class Ik:
    """Numeric IK, Panda (modified DH, 7 joints): robosim's ik (auto: dls) over a batch of
    targets against Robotics Toolbox's C++ ik_LM (ETS.ik_LM, the robot's ETS built once) per
    target, each with its default tolerance and restarts, both from the same start q0 (the
    toolbox's qr) with joint limits respected; targets are the FK of random q within limits.
    Robotics Toolbox's floor (a call whose start already solves its target: one iteration) is
    subtracted."""
    name = "ik"
    N = 40
    # the toolbox's default (E = ½ eᵀWe < 1e-6, |e| up to ~1e-3) and one as tight as robosim's
    TOLS = {"default": {}, "tol 1e-18": {"tol": 1e-18}}

    def setup(self):
        import roboticstoolbox as rtb
        import robosim
        self.rtb = rtb
        self.r = rtb.models.DH.Panda()
        self.ets = self.r.ets()
        self.rs = robosim.Model("panda")
        rng = np.random.default_rng(37)
        qs = [rng.uniform(self.r.qlim[0], self.r.qlim[1]) for _ in range(self.N)]
        self.T = np.array([self.r.fkine(q).A for q in qs])
        self.q0 = np.array(self.r.qr, dtype=float)
        self.Q0 = np.tile(self.q0, (self.N, 1))
        self.T0 = self.r.fkine(self.q0).A
        self.fk_agree = max(np.abs(self.rs.fk(q) - self.r.fkine(q).A).max() for q in qs)
        ours = self.robosim_solve()
        pos = lambda q, T: np.linalg.norm(self.r.fkine(q).A[:3, 3] - T[:3, 3])
        ok = [a["solutions"][0] for a in ours]
        self.agree = {}
        for key, tol in self.TOLS.items():
            peer = [self.ets.ik_LM(T, q0=self.q0, **tol) for T in self.T]
            self.agree[key] = (
                f"success {sum(s['converged'] for s in ok)}/{self.N} vs {sum(bool(s.success) for s in peer)}/{self.N}; "
                f"position error ≤ {max(pos(s['q'], T) for s, T in zip(ok, self.T) if s['converged']):.0e} vs "
                f"{max((pos(s.q, T) for s, T in zip(peer, self.T) if s.success), default=float('nan')):.0e} m; "
                f"FK {self.fk_agree:.0e}")

    def robosim_solve(self):
        return self.rs.ik(self.T, q0=self.Q0, full=True)

    def run(self):
        ours = ns(self.robosim_solve, 1, 5) / self.N
        out = {}
        for key, tol in self.TOLS.items():
            peer = ns(lambda: [self.ets.ik_LM(T, q0=self.q0, **tol) for T in self.T], 1, 5) / self.N
            floor = ns(lambda: self.ets.ik_LM(self.T0, q0=self.q0, **tol), 20, 10)
            out[key] = (ours, peer - floor, floor)
        return out

    def rows(self, rounds):
        for key in self.TOLS:
            yield row(f"numeric IK, Panda (40 targets from qr), toolbox at {key} tolerance",
                      f"Robotics Toolbox {self.rtb.__version__} ik_LM (C++)",
                      [r[key] for r in rounds], self.agree[key], "µs", scale=1e-3, was="0.37–0.60×")


class Station:
    """Robot against the space station (servicer, 6 DOF, vs ~300 parts), exact mode, boolean:
    robosim's criterion bench station_check/<cfg>/boolean against coal's manager-against-manager
    collide (station_check_coal.py) minus its empty-manager call. robosim's figure is criterion's
    median of ~15 ms samples, which a loaded machine stretches (every sample is shared with
    other processes), coal's the mean of 1000 calls: under load this side leans against
    robosim, not for it."""
    name = "station"

    def setup(self):
        self.c = load_module("station_check_coal", os.path.join(HERE, "station_check_coal.py"))
        import coal  # noqa: F401
        self.bin = bench_binary("station_check")
        self.home = tempfile.mkdtemp(prefix="peers_criterion_")
        self.doc, self.scene, self.keep = self.c.load()
        self.mgr = {n: self.c.robot(self.doc, n, self.keep) for n in ["contact", "clear"]}
        self.empty = self.c.empty_manager()
        self.verdict = {n: self.c.check(self.scene, self.mgr[n]) for n in self.mgr}
        if self.verdict != {"contact": True, "clear": False}:
            sys.exit(f"coal's verdicts differ from robosim's: {self.verdict}")

    def run(self):
        out = {}
        for n in ["contact", "clear"]:
            ours = criterion(self.bin, f"station_check/{n}/boolean", self.home) * 1e9
            per, floor = self.c.time_once(self.scene, self.mgr[n], self.empty, 1000)
            out[n] = (ours, (per - floor) * 1e9, floor * 1e9)
        return out

    def rows(self, rounds):
        for n in ["contact", "clear"]:
            yield row(f"robot vs station check, {n} (boolean)", "coal 3.0.3",
                      [r[n] for r in rounds], f"same verdict ({n})", "µs", scale=1e-3, goal=0.5,
                      was={"contact": "15×", "clear": "0.72×"}[n])


class Distance:
    """Exact distance of separated pairs (40 per class of tolerance_pairs.csv, gaps 1 mm –
    0.3 m, and of convex meshes in tolerance_hull_pairs.csv: hulls of 64 points, the same points
    on both sides) at matched GJK tolerances 1e-6 and 1e-9 m (and robosim's certified distance
    against coal at 1e-9):
    robosim's example peer_distance (exact::collide with distance and witnesses) against
    coal.distance with gjk_tolerance (collision_tolerance_coal.py, request objects made once)
    minus coal's sphere–sphere call, both the median over 60 passes over the 40 pairs (a pass,
    ~40 µs, is shorter than a scheduler slice: the median is the unloaded speed on both sides;
    the criterion bench `tolerance` has the same kernel); agreement against robosim's Python
    `distance` at the same tolerance. FCL 0.7 (python-fcl 0.7.0.11) beside coal at 1e-6 m,
    timed the same way (collision_tolerance_fcl.py: fcl.distance minus its sphere–sphere call,
    a fresh DistanceResult per call on both): python-fcl cannot set FCL's distance_tolerance,
    whose default is 1e-6, so FCL has only the 1e-6 rows."""
    name = "dist"
    # (class, robosim's tolerance, coal's gjk_tolerance)
    CASES = [("cylinder-cone", "1e-6", 1e-6), ("cylinder-cone", "1e-9", 1e-9),
             ("cylinder-cone", "certified", 1e-9), ("cylinder-box", "1e-6", 1e-6),
             ("cylinder-box", "1e-9", 1e-9), ("cone-box", "1e-6", 1e-6), ("cone-box", "1e-9", 1e-9),
             ("box-box", "1e-6", 1e-6), ("box-box", "1e-9", 1e-9), ("hull-hull", "1e-6", 1e-6),
             ("hull-hull", "1e-9", 1e-9)]
    FCL_LABEL = "1e-6"  # FCL's fixed distance_tolerance (python-fcl cannot set it)
    FCL_CLASSES = ["cylinder-cone", "cylinder-box", "cone-box", "box-box"]  # primitives only

    def setup(self):
        import robosim
        self.c = load_module("collision_tolerance_coal", os.path.join(HERE, "collision_tolerance_coal.py"))
        self.exe = os.path.join(REL, "examples", "peer_distance")
        self.f = load_module("collision_tolerance_fcl", os.path.join(HERE, "collision_tolerance_fcl.py"))
        fcl_pairs = self.f.read_pairs()
        self.fcl_pairs = {}
        pairs = self.c.read_pairs()
        pairs += self.c.read_pairs(os.path.join(self.c.OUT, "tolerance_hull_pairs.csv"))
        lines = open(os.path.join(self.c.OUT, "tolerance_pairs.csv")).read().splitlines()
        lines += open(os.path.join(self.c.OUT, "tolerance_hull_pairs.csv")).read().splitlines()
        self.pairs = {}
        self.agree = {}
        for cls, label, tol in self.CASES:
            self.pairs[cls] = [p for p in pairs if p[0] == cls]
            d = 0.0
            for line, (_, _, ga, ta, gb, tb) in zip([l for l in lines if l.startswith(cls + ",")], self.pairs[cls]):
                c = line.split(",")
                a, pa = shape_json(c[2:18])
                b, pb = shape_json(c[18:34])
                opts = {} if label == "certified" else {"tolerance": float(label)}
                ours = robosim.distance(a, pa, b, pb, **opts)
                d = max(d, abs(ours - self.c.distance(ga, ta, gb, tb, tol)))
            self.agree[(cls, label)] = d
            if label == self.FCL_LABEL and cls in self.FCL_CLASSES:
                self.fcl_pairs[cls] = [p for p in fcl_pairs if p[0] == cls]
                req = self.f.fcl.DistanceRequest()
                d = 0.0
                for line, (_, _, fa, fb) in zip([l for l in lines if l.startswith(cls + ",")], self.fcl_pairs[cls]):
                    c = line.split(",")
                    a, pa = shape_json(c[2:18])
                    b, pb = shape_json(c[18:34])
                    d = max(d, abs(robosim.distance(a, pa, b, pb, tolerance=float(label)) - self.f.distance(fa, fb, req)))
                self.agree[(cls, label, "fcl")] = d

    def run(self):
        out = {}
        for cls, label, tol in self.CASES:
            mine = self.pairs[cls]
            got = subprocess.run([self.exe, "--passes", "60", f"{cls}:{label}"], check=True,
                                 capture_output=True, text=True).stdout
            ours = json.loads(got)["ns_per_pair"]
            per, floor = self.c.time_once(mine, tol, reps=60)
            out[(cls, label)] = (ours, (per - floor) * 1e9, floor * 1e9)
            if label == self.FCL_LABEL and cls in self.FCL_CLASSES:
                per, floor = self.f.time_once(self.fcl_pairs[cls], reps=60)
                out[(cls, label, "fcl")] = (ours, (per - floor) * 1e9, floor * 1e9)
        return out

    def rows(self, rounds):
        for cls, label, tol in self.CASES:
            matched = label != "certified"
            yield row(f"exact distance, {cls.replace('-', '–')}, robosim "
                      + (f"at {label} m" if matched else "certified (≤ 1e-11 m)"),
                      f"coal 3.0.3 at gjk_tolerance {tol:g} m", [r[(cls, label)] for r in rounds],
                      f"{self.agree[(cls, label)]:.1e} m", "ns", goal=1.0 if matched else None,
                      was="2.7× (certified vs 1e-9)" if not matched else
                      ({"box-box": "0.7–1.1×", "hull-hull": "not measured"}.get(cls, "1.4–2.2× (curved pairs)")))
        for cls, label, tol in self.CASES:
            if label == self.FCL_LABEL and cls in self.FCL_CLASSES:
                yield row(f"exact distance, {cls.replace('-', '–')}, robosim at {label} m",
                          "FCL 0.7 (python-fcl 0.7.0.11) at its fixed distance_tolerance 1e-6 m",
                          [r[(cls, label, "fcl")] for r in rounds],
                          f"{self.agree[(cls, label, 'fcl')]:.1e} m", "ns", goal=1.0, was="not measured")


def COAL_SIDE():
    return load_module("collision_tolerance_coal", os.path.join(HERE, "collision_tolerance_coal.py"))


def shape_json(c):
    v = [float(x) for x in c[1:16]]
    if c[0] == "hull":
        s = {"shape": "convex", "points": COAL_SIDE().hull_points(int(v[0]), v[1], v[2])}
    elif c[0] == "box":
        s = {"shape": "box", "size": v[:3]}
    else:
        s = {"shape": c[0], "radius": v[0], "height": v[1]}
    pose = np.eye(4)
    pose[:3, :3] = np.array(v[3:12]).reshape(3, 3)
    pose[:3, 3] = v[12:15]
    return s, pose


class Collide:
    """The query protocol's `collide` (cylinder/cone, new poses every request, the shapes
    repeated): robosim's collide_rate example (in-process handle_line, certified and 1e-6 m)
    against a Python + coal loop doing the same work (collide_rate_coal.py: parse, build the
    shapes, collide, distance with nearest points at coal's default 1e-6, answer as JSON)."""
    name = "collide"
    N = 4000

    def setup(self):
        self.c = load_module("collide_rate_coal", os.path.join(HERE, "collide_rate_coal.py"))
        self.exe = os.path.join(REL, "examples", "collide_rate")
        self.lines_file = os.path.join(tempfile.mkdtemp(prefix="peers_"), "collide.jsonl")
        subprocess.run([self.exe, "--n", str(self.N), "--rounds", "1", "--write", self.lines_file],
                       check=True, capture_output=True)
        self.lines = open(self.lines_file).read().splitlines()
        answers = run_query(self.lines_file)
        d = 0.0
        for a, l in zip(answers, self.lines):
            p = json.loads(self.c.answer(l, None))
            d = max(d, abs(a["signed_distance"] - p["signed_distance"]))
        self.agree = d

    def run(self):
        out = subprocess.run([self.exe, "--n", str(self.N), "--rounds", "1"], check=True,
                             capture_output=True, text=True).stdout
        us = {}
        for line in out.splitlines():
            for key, prefix in [("certified", "repeated shapes (cached):"),
                                ("1e-6", "repeated shapes, tolerance 1e-6 m:")]:
                if line.startswith(prefix):
                    us[key] = float(line[len(prefix):].split("us")[0])
        built = self.c.time_lines(self.lines, False)
        cached = self.c.time_lines(self.lines, True)
        return {("certified", "built"): (us["certified"] * 1e3, built * 1e3, 0.0),
                ("certified", "cached"): (us["certified"] * 1e3, cached * 1e3, 0.0),
                ("1e-6", "built"): (us["1e-6"] * 1e3, built * 1e3, 0.0),
                ("1e-6", "cached"): (us["1e-6"] * 1e3, cached * 1e3, 0.0)}

    def rows(self, rounds):
        # goal: ≥ 2× the loop's throughput (ratio ≤ 0.5), at the certified distance too
        for (tol, peer), what in [(("1e-6", "built"), "robosim 1e-6 m vs coal shapes built per request"),
                                  (("1e-6", "cached"), "robosim 1e-6 m vs coal shapes cached by JSON"),
                                  (("certified", "built"), "robosim certified vs coal built per request"),
                                  (("certified", "cached"), "robosim certified vs coal shapes cached by JSON")]:
            yield row(f"query protocol `collide` per request: {what}", "Python + coal 3.0.3 loop",
                      [r[(tol, peer)] for r in rounds], f"{self.agree:.1e} m (certified vs coal)", "µs",
                      scale=1e-3, goal=0.5,
                      was="1.56× (certified, shapes built per request)")


def run_query(path):
    out = subprocess.run([os.path.join(REL, "examples", "query"), "--input", path], check=True,
                         capture_output=True, text=True).stdout
    return [json.loads(l) for l in out.splitlines() if l.strip()]


class Query:
    """The query protocol's fk and id on the PUMA 560: the `query` example serving a file of
    60000 requests (its start-up, the best of three one-line files, subtracted) against a
    Python + Pinocchio loop doing the same work per line (parse, compute, answer as JSON), the
    Pinocchio models built from robosim's own PUMA (kinematics.py's DH model; for id
    gen_reference.py's from Model("puma560").to_json(), rotor inertia as armature)."""
    name = "query"
    N = 60000

    def setup(self):
        import pinocchio as pin
        self.pin = pin
        k = load_module("peer_kinematics", os.path.join(HERE, "kinematics.py"))
        g = load_module("gen_reference", os.path.join(ROOT, "testdata", "dynamics", "gen_reference.py"))
        with open(os.path.join(ROOT, "testdata", "kinematics", "puma560.json")) as f:
            self.km, self.fid = k.dh_model(json.load(f))
        self.kd = self.km.createData()
        # robosim's built-in PUMA as its own JSON says it: the DH rows and rigid bodies (as
        # testdata/dynamics/gen_reference.py reads them) and the rotor inertia as armature
        import robosim
        puma = robosim.Model("puma560").to_json()
        self.dm = g.to_pinocchio(puma)
        self.dm.armature[:] = [j.get("motor_inertia", 0.0) for j in puma["joints"]]
        self.dd = self.dm.createData()
        rng = np.random.default_rng(37)
        d = tempfile.mkdtemp(prefix="peers_")
        self.files = {}
        self.lines = {}
        for op in ["fk", "id"]:
            lines = []
            for i in range(self.N):
                q = rng.uniform(-2.5, 2.5, 6).tolist()
                r = {"id": i, "op": op, "robot": "puma560", "q": q}
                if op == "id":
                    r["qd"] = rng.normal(size=6).tolist()
                    r["qdd"] = rng.normal(size=6).tolist()
                lines.append(json.dumps(r))
            self.lines[op] = lines
            self.files[op] = os.path.join(d, op + ".jsonl")
            with open(self.files[op], "w") as f:
                f.write("\n".join(lines) + "\n")
        self.one = os.path.join(d, "one.jsonl")
        with open(self.one, "w") as f:
            f.write(self.lines["fk"][0] + "\n")
        self.agree = {}
        for op in ["fk", "id"]:
            ours = run_query(self.files[op])
            key = "pose" if op == "fk" else "tau"
            self.agree[op] = max(np.abs(np.array(a[key]) - np.array(json.loads(self.answer(l))[key])).max()
                                 for a, l in zip(ours[:500], self.lines[op][:500]))

    def answer(self, line):
        pin = self.pin
        r = json.loads(line)
        q = np.array(r["q"])
        if r["op"] == "fk":
            pin.forwardKinematics(self.km, self.kd, q)
            pose = pin.updateFramePlacement(self.km, self.kd, self.fid).homogeneous
            return json.dumps({"id": r["id"], "ok": True, "pose": pose.tolist()})
        tau = pin.rnea(self.dm, self.dd, q, np.array(r["qd"]), np.array(r["qdd"]))
        return json.dumps({"id": r["id"], "ok": True, "tau": tau.tolist()})

    def wall(self, path):
        t0 = time.perf_counter()
        subprocess.run([os.path.join(REL, "examples", "query"), "--input", path], check=True,
                       stdout=subprocess.DEVNULL)
        return time.perf_counter() - t0

    def run(self):
        out = {}
        start = min(self.wall(self.one) for _ in range(3))
        for op in ["fk", "id"]:
            ours = (self.wall(self.files[op]) - start) / self.N * 1e9
            t0 = time.perf_counter()
            for l in self.lines[op]:
                self.answer(l)
            peer = (time.perf_counter() - t0) / self.N * 1e9
            out[op] = (ours, peer, 0.0)  # robosim's start-up is subtracted, not shown
        return out

    def rows(self, rounds):
        for op in ["fk", "id"]:
            yield row(f"query protocol `{op}` per request, PUMA 560", f"Python + Pinocchio {self.pin.__version__} loop",
                      [r[op] for r in rounds], f"{self.agree[op]:.1e}", "µs", scale=1e-3,
                      goal={"fk": 1 / 3, "id": 1 / 2.5}[op],
                      was={"fk": "3× the throughput (0.33)", "id": "2.5× (0.40)"}[op])


SECTIONS = [Kinematics, Dynamics, Rk4, Ik, Station, Distance, Collide, Query]


# ---------------------------------------------------------------------------------------------
# the table

def row(measure, peer, per_round, agreement, unit, scale=1.0, goal=None, was=""):
    """per_round: [(robosim, peer net, peer binding floor)] in ns; `goal`: issue 37's largest
    ratio for the row (None: kept, no goal); `was`: the issue's figure before this wave."""
    ours = [x[0] for x in per_round]
    theirs = [x[1] for x in per_round]
    floor = [x[2] for x in per_round]
    ratios = [a / b if b > 0 else float("inf") for a, b, _ in per_round]
    med = lambda v: statistics.median(v)
    fmt = (lambda v: f"{v * scale:.2f}") if scale != 1.0 else (lambda v: f"{v:.0f}")
    return {
        "measure": measure, "peer": peer,
        "ratio": f"**{med(ratios):.2f}** ({min(ratios):.2f}–{max(ratios):.2f})".replace("inf", "∞"),
        "robosim": f"{fmt(med(ours))} {unit}", "peer_t": f"{fmt(med(theirs))} {unit}",
        "floor": f"{fmt(med(floor))} {unit}" if med(floor) > 0 else "—",
        "agreement": agreement,
        "goal": "—" if goal is None else f"≤ {goal:.2f}: " + ("**met**" if med(ratios) <= goal else "not met"),
        "was": was or "—",
    }


def machine():
    load = open("/proc/loadavg").read().split()[:3] if os.path.exists("/proc/loadavg") else ["?"] * 3
    cpu = "?"
    try:
        for l in open("/proc/cpuinfo"):
            if l.startswith("model name"):
                cpu = l.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return cpu, os.cpu_count(), load


def write(path, rows, rounds, loads, started, elapsed, sections):
    import pinocchio as pin
    cpu, ncpu, _ = machine()
    with open(path, "w") as f:
        f.write(f"""# robosim beside its peers

Written by `tools/peers/run.py` (do not edit by hand; run it again). {started} UTC, {rounds}
interleaved rounds, {elapsed / 60:.1f} min; {cpu}, {ncpu} cores, Linux, Python
{platform.python_version()}, numpy {np.__version__}; robosim release builds of this checkout
(`git describe`: {git_describe()}{"; -dirty: the checkout is shared, and binaries are built from the working tree with whatever is not committed yet — their build times are under Method" if git_describe().endswith("-dirty") else ""}). **Load**: the machine is shared with other engineers'
builds: the 1-minute load average at the start of each round was {", ".join(loads)} (on {ncpu}
cores), so absolute times move between rounds; the ratios are per round (both sides measured
back to back on the same inputs) and their spread says how much the load moved them.

**Ratio** = robosim's time / the peer's time (net of its binding), median over the rounds, with
the (min–max) over rounds: below 1.00 robosim is faster. **Agreement**: the largest absolute
difference of the two libraries' results over the inputs of the row (units of the result).
A spread ending in ∞: in some round the peer's time did not exceed its binding floor (load noise
on a call that costs little more than the binding itself).

| measure | peer | ratio | goal (issue 37) | issue 37 said | robosim | peer (net) | peer binding floor | agreement |
|---|---|---|---|---|---|---|---|---|
""")
        for r in rows:
            f.write(f"| {r['measure']} | {r['peer']} | {r['ratio']} | {r['goal']} | {r['was']} | "
                    f"{r['robosim']} | {r['peer_t']} | "
                    f"{r['floor']} | {r['agreement']} |\n")
        f.write("\n## Method\n\n")
        f.write(__doc__.split("\n\n", 2)[2].strip() + "\n\n")
        for s in sections:
            f.write(f"* **{s.name}** — {' '.join(s.__doc__.split())}\n")
        f.write("\nBinaries timed (release, built at): " + "; ".join(
            f"`{os.path.relpath(p, ROOT)}` {built_at(p)}" for p in [
                os.path.join(REL, "examples", "peer_timing"), os.path.join(REL, "examples", "collide_rate"),
                os.path.join(REL, "examples", "query"), os.path.join(REL, "examples", "peer_distance"),
                bench_binary("station_check"),
                os.path.join(REL, "lib_robosim.so")]) + ".\n")
        for n in NOTES:
            f.write(f"\n{n}\n")
        f.write(f"""
Versions: Pinocchio {pin.__version__}, coal 3.0.3, MuJoCo {sections_version('mujoco')},
Robotics Toolbox {sections_version('roboticstoolbox')} (tools/peers/requirements.txt pins them;
tools/peers/setup.sh makes the venv); python-fcl 0.7.0.11 (FCL 0.7) in the exact-distance
rows only, at FCL's fixed 1e-6 m.
""")


def sections_version(mod):
    try:
        return __import__(mod).__version__
    except Exception:  # noqa: BLE001 - a report line, not a failure
        return "not installed"


def git_describe():
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True,
                              text=True).stdout.strip()
    except OSError:
        return "?"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--only", default="", help="comma-separated sections: " + ",".join(s.name for s in SECTIONS))
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "bench", "peers.md"))
    ap.add_argument("--site", default=os.path.join(tempfile.gettempdir(), "robosim_peers_site"))
    ap.add_argument("--note", action="append", default=[], help="a line for the doc's Method (e.g. why a build is older)")
    a = ap.parse_args()
    if a.no_build:
        if not os.path.exists(os.path.join(a.site, "robosim")):
            install_module(a.site)
    else:
        build(a.site)
    sys.path.insert(0, a.site)
    NOTES.extend(a.note)
    only = set(a.only.split(",")) - {""}
    sections = [S() for S in SECTIONS if not only or S.name in only]
    started = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    t0 = time.time()
    for s in sections:
        print(f"setup {s.name}", file=sys.stderr)
        s.setup()
    per = {s.name: [] for s in sections}
    loads = []
    for r in range(a.rounds):
        loads.append(machine()[2][0])
        for s in sections:
            per[s.name].append(s.run())
        print(f"round {r + 1}/{a.rounds} done (load {loads[-1]})", file=sys.stderr)
    rows = [x for s in sections for x in s.rows(per[s.name])]
    write(a.out, rows, a.rounds, loads, started, time.time() - t0, sections)
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
