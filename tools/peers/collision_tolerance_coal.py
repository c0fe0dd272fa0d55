#!/usr/bin/env python3
"""Distance accuracy against time at each GJK tolerance, coal's side (issue 37 item 3).

Writes, for `robosim report collision` (report/src/collision_tolerance.rs reads them):

* testdata/collision/tolerance_pairs.csv — the pairs: 4 classes (cylinder-cone, cylinder-box,
  cone-box, box-box) x 40 pairs, separated by 1 mm to 0.3 m, sizes 0.1-0.6 m; each row
  `class,index,kind_a,p0_a,p1_a,p2_a,<12 numbers: R row-major then t>,kind_b,...` where a
  cylinder or cone is `radius,height,0` (axis z, centred; a cone's apex at +h/2) and a box is its
  three full side lengths — the same convention in robosim and coal;
* testdata/collision/tolerance_coal.csv — `class,index,tolerance,distance`: coal.distance with
  DistanceRequest.gjk_tolerance = tolerance (coal's default GJK convergence criterion);
* testdata/collision/tolerance_coal_time.csv — `class,tolerance,ns_per_pair,binding_ns`: the
  best of 15 interleaved rounds (the least disturbed: the machine is shared, as robosim's
  report takes the best of its repetitions) of coal.distance over the class's pairs, and the
  binding's cost per call (coal.distance on two spheres, coal's closed form) measured in the
  same rounds; robosim's report subtracts it.

Errors are not computed here: the report takes them against robosim's certified distances
(brackets of width <= 1e-11 m), so both libraries are judged by the same reference.

Convex meshes (`hulls`): testdata/collision/tolerance_hull_pairs.csv, 40 pairs of convex hulls
(class hull-hull) in the same row format with kind `hull,n,radius,seed`: the hull of the n
points `hull_points(n, radius, seed)` (a golden-angle spiral on an ellipsoid of semi-axes
radius x (1, 0.8, 0.6), each point's distance jittered by 15 %; Python's math and Rust's f64
sin/cos/sqrt are both glibc's, so both sides build the hull of the same points: robosim in
`robosim_collision::exact::pair_file`, coal with Convex.convexHull). Only the pairs file is
written (`run.py`'s dist section times coal on it); the report's files are left as they are.

Run: /work/peers-venv/bin/python tools/peers/collision_tolerance_coal.py [hulls]
Versions: coal 3.0.3 (pip, cmeel), numpy, Python 3.11. Seeded: the same pairs every run.
"""

import csv
import math
import os
import sys
import statistics
import time

import coal
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "testdata", "collision")
TOLERANCES = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]
CLASSES = [("cylinder", "cone"), ("cylinder", "box"), ("cone", "box"), ("box", "box")]
PER_CLASS = 40


def rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def dims(rng, kind):
    if kind == "box":
        return list(rng.uniform(0.1, 0.6, 3))
    return [rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6), 0.0]


def hull_points(n, radius, seed):
    """The points of a `hull` row (the same formula as robosim's pair_file::hull_points)."""
    out = []
    for k in range(int(n)):
        z = 1.0 - (2.0 * k + 1.0) / n
        r = math.sqrt(1.0 - z * z)
        phi = 2.399963229728653 * k + seed
        rho = radius * (1.0 + 0.15 * math.sin(1.7 * k + 3.1 * seed))
        out.append([rho * r * math.cos(phi), rho * 0.8 * r * math.sin(phi), rho * 0.6 * z])
    return out


def geometry(kind, p):
    if kind == "hull":
        pts = coal.StdVec_Vec3s()
        for q in hull_points(int(p[0]), p[1], p[2]):
            pts.append(np.array(q))
        return coal.Convex.convexHull(pts, False, "")
    if kind == "box":
        return coal.Box(p[0], p[1], p[2])
    if kind == "cylinder":
        return coal.Cylinder(p[0], p[1])
    return coal.Cone(p[0], p[1])


def tf(r, t):
    return coal.Transform3s(r, t)


def distance(ga, ta, gb, tb, tol):
    req = coal.DistanceRequest()
    req.gjk_tolerance = tol
    res = coal.DistanceResult()
    return coal.distance(ga, ta, gb, tb, req, res)


def read_pairs(path=os.path.join(OUT, "tolerance_pairs.csv")):
    """The pairs file back as [(class, index, geometry a, pose a, geometry b, pose b)]."""
    out = []
    with open(path) as f:
        for row in csv.reader(f):
            bodies = []
            for c in (row[2:18], row[18:34]):
                v = [float(x) for x in c[1:16]]
                bodies.append((geometry(c[0], v[:3]), tf(np.array(v[3:12]).reshape(3, 3), np.array(v[12:15]))))
            out.append((row[0], int(row[1]), bodies[0][0], bodies[0][1], bodies[1][0], bodies[1][1]))
    return out


def binding_pair():
    """Two spheres apart: coal's closed form, the floor of a Python call of coal.distance."""
    return (coal.Sphere(0.1), tf(np.eye(3), np.zeros(3)), coal.Sphere(0.2), tf(np.eye(3), np.array([1.0, 0.0, 0.0])))


def time_once(pairs, tol, reps=20):
    """One round over `pairs` at `tol`: (seconds per pair, seconds per binding-floor call), each
    the median over `reps` passes, a pass over the pairs and a pass of as many floor calls
    alternating so that both see the same load (the median, as criterion's on robosim's side,
    shrugs off a pass another process interrupted). The request and result objects are made
    once (their construction is Python work, not coal's)."""
    s1, t1, s2, t2 = binding_pair()
    req = coal.DistanceRequest()
    req.gjk_tolerance = tol
    res = coal.DistanceResult()
    dist = coal.distance
    per, base = [], []
    for _ in range(reps):
        t0 = time.perf_counter()
        for _, _, ga, ta, gb, tb in pairs:
            dist(ga, ta, gb, tb, req, res)
        t1_ = time.perf_counter()
        for _ in range(len(pairs)):
            dist(s1, t1, s2, t2, req, res)
        per.append((t1_ - t0) / len(pairs))
        base.append((time.perf_counter() - t1_) / len(pairs))
    return statistics.median(per), statistics.median(base)


HULL_POINTS = 64


def hulls():
    """testdata/collision/tolerance_hull_pairs.csv: 40 separated pairs of convex hulls of 64
    points (radius 0.1-0.3 m, gaps 1 mm - 0.3 m), placed as main() places its pairs."""
    rng = np.random.default_rng(38)
    rows = []
    i = 0
    while i < PER_CLASS:
        pa = [float(HULL_POINTS), rng.uniform(0.1, 0.3), float(rng.integers(0, 1000))]
        pb = [float(HULL_POINTS), rng.uniform(0.1, 0.3), float(rng.integers(0, 1000))]
        ra, rb = rotation(rng), rotation(rng)
        ta = np.zeros(3)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        ga, gb = geometry("hull", pa), geometry("hull", pb)
        gap = rng.uniform(1e-3, 0.3)
        lo, hi = 0.0, 3.0
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            if distance(ga, tf(ra, ta), gb, tf(rb, u * mid), 1e-12) > gap:
                hi = mid
            else:
                lo = mid
        tb = u * hi
        d = distance(ga, tf(ra, ta), gb, tf(rb, tb), 1e-12)
        if not (5e-4 < d < 0.31):
            continue
        row = ["hull-hull", i, "hull"] + [repr(float(x)) for x in pa] + [repr(float(x)) for x in ra.flatten()]
        row += [repr(float(x)) for x in ta] + ["hull"] + [repr(float(x)) for x in pb]
        row += [repr(float(x)) for x in rb.flatten()] + [repr(float(x)) for x in tb]
        rows.append(row)
        i += 1
    path = os.path.join(OUT, "tolerance_hull_pairs.csv")
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows(rows)
    print(f"{len(rows)} hull pairs written to {path}")


def main():
    if sys.argv[1:] == ["hulls"]:
        return hulls()
    rng = np.random.default_rng(37)
    pairs = []
    for ka, kb in CLASSES:
        cls = f"{ka}-{kb}"
        i = 0
        while i < PER_CLASS:
            pa, pb = dims(rng, ka), dims(rng, kb)
            ra, rb = rotation(rng), rotation(rng)
            ta = np.zeros(3)
            # b along a random direction, then pulled in until the gap is in [1 mm, 0.3 m]
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            ga, gb = geometry(ka, pa), geometry(kb, pb)
            gap = rng.uniform(1e-3, 0.3)
            lo, hi = 0.0, 3.0
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                d = distance(ga, tf(ra, ta), gb, tf(rb, u * mid), 1e-12)
                if d > gap:
                    hi = mid
                else:
                    lo = mid
            tb = u * hi
            d = distance(ga, tf(ra, ta), gb, tf(rb, tb), 1e-12)
            if not (5e-4 < d < 0.31):
                continue
            pairs.append((cls, i, ka, pa, ra, ta, kb, pb, rb, tb))
            i += 1
    with open(os.path.join(OUT, "tolerance_pairs.csv"), "w", newline="") as f:
        w = csv.writer(f)
        for cls, i, ka, pa, ra, ta, kb, pb, rb, tb in pairs:
            row = [cls, i, ka] + [repr(float(x)) for x in pa] + [repr(float(x)) for x in ra.flatten()] + [repr(float(x)) for x in ta]
            row += [kb] + [repr(float(x)) for x in pb] + [repr(float(x)) for x in rb.flatten()] + [repr(float(x)) for x in tb]
            w.writerow(row)
    built = [
        (cls, i, geometry(ka, pa), tf(ra, ta), geometry(kb, pb), tf(rb, tb))
        for cls, i, ka, pa, ra, ta, kb, pb, rb, tb in pairs
    ]
    with open(os.path.join(OUT, "tolerance_coal.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["class", "index", "tolerance", "distance"])
        for tol in TOLERANCES:
            for cls, i, ga, ta, gb, tb in built:
                w.writerow([cls, i, repr(tol), repr(distance(ga, ta, gb, tb, tol))])
    with open(os.path.join(OUT, "tolerance_coal_time.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["class", "tolerance", "ns_per_pair", "binding_ns"])
        for ka, kb in CLASSES:
            cls = f"{ka}-{kb}"
            mine = [b for b in built if b[0] == cls]
            for tol in TOLERANCES:
                # interleaved: pairs, then the binding floor, each round
                per, base = zip(*(time_once(mine, tol) for _ in range(15)))
                w.writerow([cls, repr(tol), f"{min(per) * 1e9:.0f}", f"{min(base) * 1e9:.0f}"])
    print(f"{len(pairs)} pairs, {len(TOLERANCES)} tolerances written to {OUT}")


if __name__ == "__main__":
    main()
