#!/usr/bin/env python3
"""Distance accuracy against time, FCL's side (issue 37 item 3), beside coal's
(collision_tolerance_coal.py) on the same pairs, measured the same way.

Writes, for `robosim report collision` (report/src/collision/tolerance.rs reads them):

* testdata/collision/tolerance_fcl.csv — `class,index,tolerance,distance`: fcl.distance of the
  pairs of testdata/collision/tolerance_pairs.csv (the same file coal's script wrote; a cylinder
  or cone is `radius,height` with axis z, centred, a cone's apex at +h/2, a box its full sides:
  FCL's convention too);
* testdata/collision/tolerance_fcl_time.csv — `class,tolerance,ns_per_pair,binding_ns`: the best
  of 15 interleaved rounds of the median over 20 passes of fcl.distance over the class's pairs,
  and the binding's cost per call (fcl.distance of two spheres, FCL's closed form) measured in
  the same rounds; the report subtracts it.

The tolerance: python-fcl 0.7.0.11 builds FCL's DistanceRequest from three arguments
(enable_nearest_points, enable_signed_distance, gjk_solver_type) and exposes no tolerance, so
FCL runs at its default `distance_tolerance` 1e-6 with its default solver (libccd's GJK);
setting `gjk_solver_type` to GST_INDEP gives the same distances on every pair here (the third
argument lands in FCL's `rel_err`, a BVH setting, not in the solver choice). Every row's
tolerance is therefore 1e-6 — FCL's, not a choice.

Errors are not computed here: the report takes them against robosim's certified distances
(brackets of width <= 1e-11 m), as it does coal's.

Run: /work/peers-venv/bin/python tools/peers/collision_tolerance_fcl.py
Versions: python-fcl 0.7.0.11 (pip wheel, FCL 0.7, libccd), numpy, Python 3.11.
"""

import csv
import os
import statistics
import time

import fcl
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "testdata", "collision")
CLASSES = ["cylinder-cone", "cylinder-box", "cone-box", "box-box"]
# FCL's DistanceRequest default (python-fcl cannot change it).
TOLERANCE = 1e-6


def geometry(kind, p):
    if kind == "box":
        return fcl.Box(p[0], p[1], p[2])
    if kind == "cylinder":
        return fcl.Cylinder(p[0], p[1])
    return fcl.Cone(p[0], p[1])


def read_pairs(path=os.path.join(OUT, "tolerance_pairs.csv")):
    """The pairs file as [(class, index, object a, object b)] (fcl.CollisionObject, posed)."""
    out = []
    with open(path) as f:
        for row in csv.reader(f):
            objs = []
            for c in (row[2:18], row[18:34]):
                v = [float(x) for x in c[1:16]]
                tf = fcl.Transform(np.array(v[3:12]).reshape(3, 3), np.array(v[12:15]))
                objs.append(fcl.CollisionObject(geometry(c[0], v[:3]), tf))
            out.append((row[0], int(row[1]), objs[0], objs[1]))
    return out


def binding_pair():
    """Two spheres apart: FCL's closed form, the floor of a Python call of fcl.distance."""
    a = fcl.CollisionObject(fcl.Sphere(0.1), fcl.Transform(np.eye(3), np.zeros(3)))
    b = fcl.CollisionObject(fcl.Sphere(0.2), fcl.Transform(np.eye(3), np.array([1.0, 0.0, 0.0])))
    return a, b


def distance(a, b, req):
    # A fresh result per call: python-fcl copies the nearest points out only when the result
    # improves, so a reused one would make the Python work depend on the order of the pairs.
    return fcl.distance(a, b, req, fcl.DistanceResult())


def time_once(pairs, reps=20):
    """One round over `pairs`: (seconds per pair, seconds per binding-floor call), each the
    median over `reps` passes, a pass over the pairs and a pass of as many floor calls
    alternating (as collision_tolerance_coal.time_once). The request is made once."""
    s1, s2 = binding_pair()
    req = fcl.DistanceRequest()
    per, base = [], []
    for _ in range(reps):
        t0 = time.perf_counter()
        for _, _, a, b in pairs:
            distance(a, b, req)
        t1 = time.perf_counter()
        for _ in range(len(pairs)):
            distance(s1, s2, req)
        per.append((t1 - t0) / len(pairs))
        base.append((time.perf_counter() - t1) / len(pairs))
    return statistics.median(per), statistics.median(base)


def main():
    pairs = read_pairs()
    req = fcl.DistanceRequest()
    with open(os.path.join(OUT, "tolerance_fcl.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["class", "index", "tolerance", "distance"])
        for cls, i, a, b in pairs:
            w.writerow([cls, i, repr(TOLERANCE), repr(distance(a, b, req))])
    with open(os.path.join(OUT, "tolerance_fcl_time.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["class", "tolerance", "ns_per_pair", "binding_ns"])
        for cls in CLASSES:
            mine = [p for p in pairs if p[0] == cls]
            per, base = zip(*(time_once(mine) for _ in range(15)))
            w.writerow([cls, repr(TOLERANCE), f"{min(per) * 1e9:.0f}", f"{min(base) * 1e9:.0f}"])
    print(f"{len(pairs)} pairs at FCL's tolerance {TOLERANCE} written to {OUT}")


if __name__ == "__main__":
    main()
