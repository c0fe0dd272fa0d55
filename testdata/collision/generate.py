#!/usr/bin/env python3
"""Reference pairs for robosim's collision tests (testdata/collision/pairs.json).

Two sources, recorded per case in "source":
* "closed-form": pairs whose signed distance has a closed form, computed here in float64:
  sphere-sphere, sphere-box, sphere-cylinder, sphere-cone (signed distance of the convex body at
  the sphere centre minus the radius: exact, also when penetrating) and box-box with a common
  orientation (the Minkowski difference is a box). Nearest points are given when separated.
* "fcl": any pair of box / sphere / cylinder / cone in random poses, answered by FCL through
  python-fcl 0.7.0.11 (true primitives, not meshes): the collide boolean, the penetration depth
  of its deepest contact when colliding, and the distance when separated. FCL's GJK distances
  are accurate to about 1e-6 m here, so the tests use them for the boolean outside a boundary
  band, and for distances with a 1e-5 tolerance.

Conventions (DESIGN.md): box "size" is full side lengths; cylinder and cone are centred on their
bounding box, axis z, cone base at z = -h/2 and apex at +h/2 (FCL's convention too); poses are
4x4 row-major nested lists acting on column vectors.

Run:  pip install python-fcl==0.7.0.11 numpy && python3 testdata/collision/generate.py
"""
import json
import math
import os

import fcl
import numpy as np

rng = np.random.default_rng(20261122)


def rand_rot():
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def pose(R, t):
    m = np.eye(4)
    m[:3, :3] = R
    m[:3, 3] = t
    return m


def rand_shape(kind):
    s = lambda: float(rng.uniform(0.2, 1.5))
    if kind == "box":
        return {"shape": "box", "size": [s(), s(), s()]}
    if kind == "sphere":
        return {"shape": "sphere", "radius": s() / 2}
    return {"shape": kind, "radius": s() / 2, "height": s()}


def fcl_geom(sh):
    k = sh["shape"]
    if k == "box":
        return fcl.Box(*sh["size"])
    if k == "sphere":
        return fcl.Sphere(sh["radius"])
    if k == "cylinder":
        return fcl.Cylinder(sh["radius"], sh["height"])
    return fcl.Cone(sh["radius"], sh["height"])


def sd_box(p, half):
    """Signed distance from local point p to a centred box with half extents `half`."""
    q = np.abs(p) - half
    outside = np.linalg.norm(np.maximum(q, 0.0))
    inside = min(max(q[0], q[1], q[2]), 0.0)
    return outside + inside


def nearest_box(p, half):
    return np.clip(p, -half, half)


def sd_2d_convex(pt, poly):
    """Signed distance from 2D point to a convex CCW polygon, and the nearest boundary point."""
    best, near = math.inf, None
    inside = True
    for i in range(len(poly)):
        a, b = np.array(poly[i]), np.array(poly[(i + 1) % len(poly)])
        e = b - a
        t = np.clip(np.dot(pt - a, e) / np.dot(e, e), 0.0, 1.0)
        c = a + t * e
        d = np.linalg.norm(pt - c)
        if d < best:
            best, near = d, c
        if e[0] * (pt - a)[1] - e[1] * (pt - a)[0] < 0:
            inside = False
    return (-best if inside else best), near


def sd_revolution(p, kind, r, h):
    """Signed distance to a cylinder or cone (axis z, centred), via its meridian section. For a
    point inside, only the real boundary counts (the axis is not a boundary), which the mirrored
    section gives automatically."""
    rho = math.hypot(p[0], p[1])
    if kind == "cylinder":
        poly = [(-r, -h / 2), (r, -h / 2), (r, h / 2), (-r, h / 2)]
    else:
        poly = [(-r, -h / 2), (r, -h / 2), (0.0, h / 2)]
    d, near2 = sd_2d_convex(np.array([rho, p[2]]), poly)
    if rho > 1e-15:
        u = np.array([p[0], p[1], 0.0]) / rho
    else:
        u = np.array([1.0, 0.0, 0.0])
    near = u * near2[0] + np.array([0.0, 0.0, near2[1]])
    return d, near


def closed_form_case(kind):
    R, t = rand_rot(), rng.normal(size=3) * 0.2
    if kind == "box_box_aligned":
        a, b = rand_shape("box"), rand_shape("box")
        ha, hb = np.array(a["size"]) / 2, np.array(b["size"]) / 2
        delta = rng.uniform(-1.0, 1.0, size=3) * (ha + hb) * 1.3
        gap = np.abs(delta) - (ha + hb)
        if np.all(gap < 0):
            sd = float(np.max(gap))
        else:
            sd = float(np.linalg.norm(np.maximum(gap, 0.0)))
        pa, pb = pose(R, t), pose(R, t + R @ delta)
        return a, pa, b, pb, sd, None
    other = kind.split("_")[1]
    a = rand_shape("sphere")
    b = rand_shape(other)
    r = a["radius"]
    Rb, tb = rand_rot(), rng.normal(size=3) * 0.2
    pb = pose(Rb, tb)
    # sphere centre around b, at a distance that spreads the signed distance around 0
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    reach = {"sphere": b.get("radius", 0), "box": np.linalg.norm(np.array(b.get("size", [0, 0, 0]))) / 2}.get(other)
    if reach is None:
        reach = math.hypot(b["radius"], b["height"] / 2)
    c_local = direction * rng.uniform(0.2, 1.4) * (reach + r)
    if other == "sphere":
        sdb, near_local = np.linalg.norm(c_local) - b["radius"], (c_local / max(np.linalg.norm(c_local), 1e-300)) * b["radius"]
    elif other == "box":
        half = np.array(b["size"]) / 2
        sdb, near_local = sd_box(c_local, half), nearest_box(c_local, half)
    else:
        sdb, near_local = sd_revolution(c_local, other, b["radius"], b["height"])
    pa = pose(R, tb + Rb @ c_local)
    sd = float(sdb - r)
    wit = None
    if sd > 1e-6:
        cw = tb + Rb @ c_local
        nb = tb + Rb @ near_local
        n = (nb - cw) / np.linalg.norm(nb - cw)
        wit = [list(cw + n * r), list(nb)]
    return a, pa, b, pb, sd, wit


def fcl_case(ka, kb):
    a, b = rand_shape(ka), rand_shape(kb)
    pa = pose(rand_rot(), rng.normal(size=3) * 0.1)
    pb = pose(rand_rot(), rng.normal(size=3) * 0.1 + rng.normal(size=3) * 0.6)
    oa = fcl.CollisionObject(fcl_geom(a), fcl.Transform(pa[:3, :3], pa[:3, 3]))
    ob = fcl.CollisionObject(fcl_geom(b), fcl.Transform(pb[:3, :3], pb[:3, 3]))
    creq = fcl.CollisionRequest(enable_contact=True, num_max_contacts=4)
    cres = fcl.CollisionResult()
    hit = fcl.collide(oa, ob, creq, cres) > 0
    depth = max((c.penetration_depth for c in cres.contacts), default=None) if hit else None
    dist = None
    if not hit:
        dres = fcl.DistanceResult()
        dist = float(fcl.distance(oa, ob, fcl.DistanceRequest(enable_nearest_points=True), dres))
    return a, pa, b, pb, hit, depth, dist


def m2l(m):
    return [[float(x) for x in row] for row in m]


cases = []
for kind in ["sphere_sphere", "sphere_box", "sphere_cylinder", "sphere_cone", "box_box_aligned"]:
    for i in range(60):
        a, pa, b, pb, sd, wit = closed_form_case(kind)
        cases.append({"name": f"{kind}_{i}", "source": "closed-form", "a": a, "pose_a": m2l(pa), "b": b, "pose_b": m2l(pb),
                      "intersect": sd <= 0.0, "signed_distance": sd, "witness": wit})
kinds = ["box", "sphere", "cylinder", "cone"]
for ka in kinds:
    for kb in kinds:
        for i in range(20):
            a, pa, b, pb, hit, depth, dist = fcl_case(ka, kb)
            cases.append({"name": f"fcl_{ka}_{kb}_{i}", "source": "fcl", "a": a, "pose_a": m2l(pa), "b": b, "pose_b": m2l(pb),
                          "intersect": bool(hit), "penetration_depth": depth, "distance": dist})

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pairs.json")
with open(out, "w") as f:
    json.dump({"generator": "testdata/collision/generate.py", "fcl": "python-fcl 0.7.0.11", "cases": cases}, f, indent=None)
    f.write("\n")
print(len(cases), "cases ->", out)
