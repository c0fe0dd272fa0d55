#!/usr/bin/env python3
"""Reference data for robosim-automation, computed with established libraries.

1. fault_graph_reference.json — random flat fault models in robosim's model language, with
   an alarm state (which alarms have rung), and for every ringing alarm the sources that can
   explain it with their propagation-time bounds, computed with networkx:
     * admissible nodes: failure modes with no allocated alarm that has not rung;
     * dmin: Dijkstra (networkx.multi_source_dijkstra) on tmin over the reversed graph induced
       by the admissible nodes, from the failure modes the alarm detects;
     * dmax: the same on tmax over the edges of probability 1 only (null when unreachable);
     * sources: admissible, non-derived failure modes reached.
   Also the members of zero-time cycles (networkx.strongly_connected_components on the tmin = 0
   subgraph, components of size > 1).
2. pendulum_reference.json — the one-link arm of automation::reconfig under the P controller,
   m l^2 q'' = Kp (q_ref - q) - m g l sin q - b q', q(0) = q'(0) = 0, integrated with
   scipy.integrate.solve_ivp (DOP853, rtol 1e-11, atol 1e-12), sampled every 0.25 s.

Run from the repository root:  python3 testdata/automation/gen_reference.py
(networkx 3.6.1, scipy 1.17.1 were used for the checked-in files.)
"""
import json
import random

import networkx as nx
from scipy.integrate import solve_ivp
import numpy as np

OUT = "testdata/automation/"


def random_case(seed, n, n_edges, zero_share):
    rng = random.Random(seed)
    derived = {i: (i >= n // 3 and rng.random() < 0.6) for i in range(n)}
    edges = []
    seen = set()
    while len(edges) < n_edges:
        a, b = rng.randrange(n), rng.randrange(n)
        if a == b or (a, b) in seen:
            continue
        seen.add((a, b))
        p = 1.0 if rng.random() < 0.5 else round(rng.uniform(0.3, 0.95), 3)
        tmin = 0.0 if rng.random() < zero_share else round(rng.uniform(0.5, 10.0), 3)
        tmax = round(tmin + rng.uniform(0.0, 15.0), 3)
        edges.append((a, b, p, tmin, tmax))
    alarms = {}  # alarm name -> list of fm indices
    for i in range(n):
        if rng.random() < 0.5:
            alarms[f"A{i}"] = [i]
    # a few alarms detecting two failure modes
    for k in range(2):
        a, b = rng.randrange(n), rng.randrange(n)
        if a != b:
            alarms[f"M{k}"] = [a, b]
    rung = sorted(x for x in alarms if rng.random() < 0.4)
    lines = ["process R {"]
    for i in range(n):
        lines.append(f"  failure f{i}" + (" derived" if derived[i] else ""))
    for (a, b, p, tmin, tmax) in edges:
        lines.append(f"  propagate f{a} -> f{b} prob {p} time {tmin}..{tmax}")
    for name, fms in alarms.items():
        lines.append(f"  alarm {name} detects " + ", ".join(f"f{i}" for i in fms))
    lines.append("}")
    text = "\n".join(lines) + "\n"

    pending = {i: 0 for i in range(n)}
    for name, fms in alarms.items():
        if name not in rung:
            for i in fms:
                pending[i] += 1
    admissible = [i for i in range(n) if pending[i] == 0]
    g = nx.DiGraph()
    g.add_nodes_from(range(n))
    for (a, b, p, tmin, tmax) in edges:
        g.add_edge(a, b, tmin=tmin, tmax=tmax, p=p)
    rev = g.subgraph(admissible).reverse(copy=True)
    rev_certain = nx.DiGraph()
    rev_certain.add_nodes_from(rev.nodes)
    rev_certain.add_edges_from((u, v, d) for u, v, d in rev.edges(data=True) if d["p"] >= 1.0)
    explain = {}
    for name in rung:
        targets = [i for i in alarms[name] if pending[i] == 0]
        out = {}
        if targets:
            dmin = nx.multi_source_dijkstra_path_length(rev, targets, weight="tmin")
            dmax = nx.multi_source_dijkstra_path_length(rev_certain, targets, weight="tmax")
            for v, d in dmin.items():
                if not derived[v]:
                    out[f"f{v}"] = [d, dmax.get(v)]
        explain[name] = out
    zero = nx.DiGraph()
    zero.add_nodes_from(range(n))
    zero.add_edges_from((a, b) for (a, b, p, tmin, tmax) in edges if tmin == 0.0)
    cycles = sorted(sorted(f"f{v}" for v in c) for c in nx.strongly_connected_components(zero) if len(c) > 1)
    return {"seed": seed, "model": text, "rung": rung, "explain": explain, "zero_time_cycles": cycles}


def pendulum():
    m, l, b, g, kp, q_ref = 1.0, 0.5, 0.1, 9.81, 20.0, 1.0
    inertia = m * l * l

    def f(t, y):
        q, qd = y
        tau = kp * (q_ref - q)
        return [qd, (tau - m * g * l * np.sin(q) - b * qd) / inertia]

    ts = [0.25 * k for k in range(1, 13)]
    sol = solve_ivp(f, (0.0, ts[-1]), [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-12, t_eval=ts)
    return {
        "params": {"mass": m, "length": l, "damping": b, "gravity": g, "kp": kp, "setpoint": q_ref},
        "samples": [{"t": t, "q": float(q)} for t, q in zip(sol.t, sol.y[0])],
    }


if __name__ == "__main__":
    cases = [random_case(1, 30, 60, 0.0), random_case(2, 60, 150, 0.05), random_case(3, 120, 260, 0.4)]
    with open(OUT + "fault_graph_reference.json", "w") as fh:
        json.dump({"generator": "testdata/automation/gen_reference.py (networkx " + nx.__version__ + ")", "cases": cases}, fh, indent=1)
    with open(OUT + "pendulum_reference.json", "w") as fh:
        json.dump(pendulum(), fh, indent=1)
