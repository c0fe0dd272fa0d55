#!/usr/bin/env python3
"""Contact-regime reference pairs for robosim's exact mode (testdata/collision/contact_pairs.json).

Issue #20 item 8: primitives resting on each other (touching), 1e-9 m apart, 1e-9 m into each
other, one inside another, thin plates (1e-4 m), the 100 m and 1e-3 m scales, whole
configurations rotated about two axes. Each case records its signed distance (distance when
apart, minus the penetration depth when overlapping), from one of two sources named in "source":

* "closed-form": configurations whose signed distance is known exactly by construction:
  a body resting on a box face (cylinder on its base or on its side, cone on its base or its
  apex, box, convex octahedron on its apex, thin disc) lifted by the gap g, so sd = g; a sphere
  whose centre is put at p + n (r + g) for a boundary point p of a convex body and n in the
  normal cone at p (face, rim edge, apex, box corner), so sd = g; boxes sharing one orientation
  (the Minkowski difference is a box); containment (box in box, sphere in box / cylinder,
  cylinder in box with a common axis) where the depth is the smallest face-wise margin.
  A whole configuration is then rotated about two axes (Rz(alpha) Rx(beta)) and translated,
  which leaves sd unchanged.
* "support-optimiser": pairs with no closed form (cylinder-cylinder, cylinder-cone, cone-cone,
  box-cylinder and box-cone in general orientation, convex-cylinder). The signed distance is
  max over unit u of  l(u) = min_{a in A} u.a - max_{b in B} u.b  (the separating-plane bound;
  for overlapping bodies the maximum is minus the penetration depth), with the support functions
  written here in closed form (independent of parry and of robosim). It is maximised by
  scipy's Nelder-Mead over a tangent-plane parametrisation, restarted until it stops
  improving. A random pose is first measured, then B is moved along the optimal direction to
  the target gap, and the optimiser is run again at the final pose: that value is recorded
  ("signed_distance"), the target is kept in "target" (they agree to ~1e-13 m).

Conventions (DESIGN.md): box "size" is full side lengths; cylinder and cone centred on their
bounding box with the axis along z, cone base at z = -h/2 and apex at +h/2; "convex" is the hull
of "points"; poses are 4x4 row-major nested lists acting on column vectors; metres.

Run:  pip install numpy scipy && python3 testdata/collision/generate_contact.py
"""
import json
import math
import os

import numpy as np
from scipy.optimize import minimize

rng = np.random.default_rng(20261124)

SCALES = [1.0, 100.0, 1e-3]
GAPS = [0.0, 1e-9, -1e-9, "far"]  # "far": 1e-3 x scale


def rot_x(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


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


# ---- support functions (world frame), closed form --------------------------------------------

def h_local(sh, v):
    k = sh["shape"]
    if k == "box":
        return sum(0.5 * s * abs(c) for s, c in zip(sh["size"], v))
    if k == "sphere":
        return sh["radius"] * math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    if k == "convex":
        return max(p[0] * v[0] + p[1] * v[1] + p[2] * v[2] for p in sh["points"])
    rho = math.hypot(v[0], v[1])
    r, hh = sh["radius"], sh["height"] / 2
    if k == "cylinder":
        return r * rho + hh * abs(v[2])
    if k == "cone":
        return max(hh * v[2], -hh * v[2] + r * rho)
    raise ValueError(k)


def h_world(sh, m, u):
    R, t = m[:3, :3], m[:3, 3]
    return float(t @ u) + h_local(sh, R.T @ u)


def lower_bound(a, ma, b, mb, u):
    u = u / np.linalg.norm(u)
    return -h_world(a, ma, -u) - h_world(b, mb, u)


def tangent_basis(u):
    e = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(u, e)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(u, e1)


def nm_climb(a, ma, b, mb, u):
    """Nelder-Mead restarts in the tangent plane at the best direction so far, until three
    restarts in a row gain nothing."""
    best = lower_bound(a, ma, b, mb, u)
    step, idle = 0.3, 0
    while idle < 3 and step > 1e-14:
        e1, e2 = tangent_basis(u)
        f = lambda x: -lower_bound(a, ma, b, mb, u + x[0] * e1 + x[1] * e2)
        simplex = np.array([[0, 0], [step, 0], [0, step]])
        r = minimize(f, np.zeros(2), method="Nelder-Mead",
                     options={"xatol": 1e-17, "fatol": 1e-19, "maxiter": 4000,
                              "initial_simplex": simplex})
        if -r.fun > best:
            best = -r.fun
            un = u + r.x[0] * e1 + r.x[1] * e2
            u = un / np.linalg.norm(un)
            step = max(np.linalg.norm(r.x), 1e-12)
            idle = 0
        else:
            step *= 0.1
            idle += 1
    return best, u


def optimise(a, ma, b, mb, u0):
    """max over unit u of the separating-plane bound, from the start direction u0 (B -> A), and
    again from four perturbed starts; returns (best, its u, spread of the five results)."""
    best, u = nm_climb(a, ma, b, mb, u0 / np.linalg.norm(u0))
    vals = [best]
    for _ in range(4):
        p = u + rng.normal(size=3) * 1e-3
        v, w = nm_climb(a, ma, b, mb, p / np.linalg.norm(p))
        vals.append(v)
        if v > best:
            best, u = v, w
    return best, u, max(vals) - min(vals)


# ---- shapes -------------------------------------------------------------------------------------

def box(sx, sy, sz):
    return {"shape": "box", "size": [sx, sy, sz]}


def cyl(r, h):
    return {"shape": "cylinder", "radius": r, "height": h}


def cone(r, h):
    return {"shape": "cone", "radius": r, "height": h}


def sphere(r):
    return {"shape": "sphere", "radius": r}


def octahedron(r):
    pts = [[r, 0, 0], [-r, 0, 0], [0, r, 0], [0, -r, 0], [0, 0, r], [0, 0, -r]]
    return {"shape": "convex", "points": pts}


def box_points(sx, sy, sz):
    return {"shape": "convex", "points": [[x * sx / 2, y * sy / 2, z * sz / 2]
                                          for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]}


def scaled(sh, s):
    sh = json.loads(json.dumps(sh))
    for k in ("radius", "height"):
        if k in sh:
            sh[k] *= s
    if "size" in sh:
        sh["size"] = [x * s for x in sh["size"]]
    if "points" in sh:
        sh["points"] = [[x * s for x in p] for p in sh["points"]]
    return sh


# ---- closed-form configurations (base frame: z up, unit scale) ---------------------------------
# Each returns (a, Ra, ta, b, Rb, tb) for scale s and gap g with sd = g exactly.

def resting(top_shape, R_top, bottom_z_offset):
    """`top_shape` rests on the top face (z = 0.5) of a 2 x 2 x 1 box, its lowest point
    `bottom_z_offset` below its centre, centre off-centre in x, y."""
    def make(s, g):
        base = scaled(box(2, 2, 1), s)
        top = scaled(top_shape, s)
        tb = np.array([0.2 * s, -0.1 * s, 0.5 * s + bottom_z_offset * s + g])
        return base, np.eye(3), np.zeros(3), top, R_top, tb
    return make


def plate_resting(top_shape, R_top, bottom_z_offset):
    """On a 1 x 1 x 1e-4 m plate (thin plates are absolute, not scaled)."""
    def make(s, g):
        base = box(1, 1, 1e-4)
        top = scaled(top_shape, s)
        tb = np.array([0.1, 0.05, 0.5e-4 + bottom_z_offset * s + g])
        return base, np.eye(3), np.zeros(3), top, R_top, tb
    return make


def sphere_at(body, p, n, r):
    """A sphere of radius r whose centre is at p + n (r + g): sd = g (n a unit outward normal
    in the normal cone of the convex body at its boundary point p)."""
    n = np.array(n, float)
    n /= np.linalg.norm(n)

    def make(s, g):
        c = np.array(p, float) * s + n * (r * s + g)
        return scaled(body, s), np.eye(3), np.zeros(3), sphere(r * s), np.eye(3), c
    return make


def aligned_boxes(sa, sb, delta):
    def make(s, g):
        # delta is the contact direction's sign pattern; shift along x by the gap
        ha, hb = np.array(sa) / 2, np.array(sb) / 2
        d = np.array(delta, float) * s
        d[0] = ha[0] * s + hb[0] * s + g
        return scaled(box(*sa), s), np.eye(3), np.zeros(3), scaled(box(*sb), s), np.eye(3), d
    return make


def convex_box_on_box(s, g):
    base = scaled(box(2, 2, 1), s)
    top = scaled(box_points(0.6, 0.4, 0.3), s)
    return base, np.eye(3), np.zeros(3), top, rot_z(0.5), np.array([0.1 * s, 0.2 * s, 0.5 * s + 0.15 * s + g])


CLOSED = {
    "cylinder_on_box": resting(cyl(0.3, 0.4), np.eye(3), 0.2),
    "cylinder_side_on_box": resting(cyl(0.3, 0.4), rot_y(math.pi / 2), 0.3),
    "cone_base_on_box": resting(cone(0.3, 0.5), np.eye(3), 0.25),
    "cone_apex_on_box": resting(cone(0.3, 0.5), rot_x(math.pi), 0.25),
    "box_on_box_twisted": resting(box(0.5, 0.3, 0.2), rot_z(0.7), 0.1),
    "octahedron_apex_on_box": resting(octahedron(0.3), rot_z(0.3), 0.3),
    "convex_box_on_box": convex_box_on_box,
    "disc_on_plate": plate_resting(cyl(0.2, 1e-4), np.eye(3), 0.5e-4),
    "cylinder_on_plate": plate_resting(cyl(0.2, 0.3), np.eye(3), 0.15),
    "cone_apex_on_plate": plate_resting(cone(0.2, 0.3), rot_x(math.pi), 0.15),
    "plate_on_plate": plate_resting(box(0.3, 0.2, 1e-4), rot_z(0.4), 0.5e-4),
    "sphere_on_cylinder_axis": sphere_at(cyl(0.3, 0.4), [0, 0, 0.2], [0, 0, 1], 0.25),
    "sphere_beside_cylinder": sphere_at(cyl(0.3, 0.4), [0.3, 0, 0.05], [1, 0, 0], 0.25),
    "sphere_on_cylinder_rim": sphere_at(cyl(0.3, 0.4), [0, 0.3, 0.2], [0, 0.6, 0.8], 0.25),
    "sphere_on_cone_apex": sphere_at(cone(0.3, 0.5), [0, 0, 0.25], [0.1, 0.2, 1.0], 0.2),
    "sphere_on_cone_side": sphere_at(cone(0.3, 0.5), [0.15, 0, 0.0], [0.5 / math.hypot(0.5, 0.3), 0, 0.3 / math.hypot(0.5, 0.3)], 0.2),
    "sphere_on_box_corner": sphere_at(box(1, 0.6, 0.4), [0.5, 0.3, 0.2], [1, 2, 3], 0.2),
    "sphere_on_box_face": sphere_at(box(1, 0.6, 0.4), [0.1, -0.1, 0.2], [0, 0, 1], 0.2),
    "boxes_aligned": aligned_boxes([1, 0.6, 0.4], [0.5, 0.5, 0.5], [0, 0.2, -0.1]),
}

ROTATIONS = {"upright": np.eye(3), "tilted": rot_z(0.7) @ rot_x(0.45)}


def containment_cases():
    """(name, a, ma, b, mb, sd) with sd = minus the depth, exact."""
    out = []
    for s in SCALES:
        # small box in a big box, aligned: Minkowski difference is a box
        hb, hs, c = np.array([1.0, 0.8, 0.6]) * s, np.array([0.1, 0.2, 0.15]) * s, np.array([0.3, -0.2, 0.1]) * s
        sd = float(np.max(np.abs(c) - (hb + hs)))
        out.append(("box_in_box", box(*(2 * hb)), pose(np.eye(3), np.zeros(3)), box(*(2 * hs)), pose(np.eye(3), c), sd))
        # sphere in a box: sd_box(centre) - r
        r = 0.2 * s
        q = np.abs(c) - hb
        out.append(("sphere_in_box", box(*(2 * hb)), pose(np.eye(3), np.zeros(3)), sphere(r), pose(np.eye(3), c), float(max(q) - r)))
        # sphere in a cylinder: the meridian section
        rc, hc = 0.5 * s, 0.4 * s
        cc = np.array([0.1, 0.05, -0.1]) * s
        d = max(math.hypot(cc[0], cc[1]) - rc, abs(cc[2]) - hc)
        out.append(("sphere_in_cylinder", cyl(rc, 2 * hc), pose(np.eye(3), np.zeros(3)), sphere(r), pose(np.eye(3), cc), float(d - r)))
        # cylinder in a box, common axis: depth = smallest face-wise margin (the box's sides are
        # flat, so the rounded part of the Minkowski sum is never nearest)
        rr, hh = 0.2 * s, 0.15 * s
        depth = min(hb[0] + rr - abs(c[0]), hb[1] + rr - abs(c[1]), hb[2] + hh - abs(c[2]))
        out.append(("cylinder_in_box", box(*(2 * hb)), pose(np.eye(3), np.zeros(3)), cyl(rr, 2 * hh), pose(np.eye(3), c), float(-depth)))
    return out


OPTIMISED = [
    ("cylinder_cylinder", cyl(0.3, 0.5), cyl(0.2, 0.6)),
    ("cylinder_cone", cyl(0.3, 0.5), cone(0.25, 0.6)),
    ("cone_cone", cone(0.3, 0.5), cone(0.25, 0.4)),
    ("box_cylinder", box(0.8, 0.5, 0.4), cyl(0.2, 0.6)),
    ("box_cone", box(0.8, 0.5, 0.4), cone(0.25, 0.5)),
    ("convex_cylinder", octahedron(0.4), cyl(0.2, 0.5)),
]


def m2l(m):
    return [[float(x) for x in row] for row in m]


def common(R, T, Ra, ta):
    return pose(R @ Ra, R @ ta + T)


def main():
    cases = []
    for name, make in CLOSED.items():
        for rname, R in ROTATIONS.items():
            for s in SCALES:
                if name in ("disc_on_plate", "cylinder_on_plate", "cone_apex_on_plate", "plate_on_plate") and s != 1.0:
                    continue  # the plate is 1e-4 m thick in absolute terms
                for g in GAPS:
                    gap = 1e-3 * s if g == "far" else g
                    a, Ra, ta, b, Rb, tb = make(s, gap)
                    T = np.array([0.3, -0.7, 0.2]) * s
                    cases.append({"name": f"{name}_{rname}_s{s:g}_g{gap:g}", "source": "closed-form",
                                  "scale": s, "a": a, "pose_a": m2l(common(R, T, Ra, ta)),
                                  "b": b, "pose_b": m2l(common(R, T, Rb, tb)), "signed_distance": float(gap)})
    for rname, R in ROTATIONS.items():
        for name, a, pa, b, pb, sd in containment_cases():
            s = a.get("size", [0])[0] / 2.0 if a["shape"] == "box" else a["radius"] / 0.5
            T = np.array([0.3, -0.7, 0.2])
            cases.append({"name": f"{name}_{rname}_s{s:g}", "source": "closed-form", "scale": s,
                          "a": a, "pose_a": m2l(pose(R, T) @ pa), "b": b, "pose_b": m2l(pose(R, T) @ pb),
                          "signed_distance": sd})
    worst, worst_spread = 0.0, 0.0
    for name, a0, b0 in OPTIMISED:
        for s in SCALES:
            for k in range(2):
                a, b = scaled(a0, s), scaled(b0, s)
                ma = pose(rand_rot(), np.zeros(3))
                dirn = rng.normal(size=3)
                dirn /= np.linalg.norm(dirn)
                mb = pose(rand_rot(), dirn * 1.2 * s)
                d0, u, _ = optimise(a, ma, b, mb, -dirn)
                d0, u, _ = optimise(a, ma, b, mb, u)
                for g in GAPS:
                    gap = 1e-3 * s if g == "far" else g
                    m = mb.copy()
                    m[:3, 3] = mb[:3, 3] - (gap - d0) * u
                    sd, _, spread = optimise(a, ma, b, m, u)
                    worst = max(worst, abs(sd - gap))
                    worst_spread = max(worst_spread, spread)
                    cases.append({"name": f"{name}_{k}_s{s:g}_g{gap:g}", "source": "support-optimiser",
                                  "scale": s, "a": a, "pose_a": m2l(ma), "b": b, "pose_b": m2l(m),
                                  "signed_distance": float(sd), "target": float(gap),
                                  "optimiser_spread": float(spread)})
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "contact_pairs.json")
    with open(out, "w") as f:
        json.dump({"generator": "testdata/collision/generate_contact.py", "cases": cases}, f, indent=None)
        f.write("\n")
    print(len(cases), "cases ->", out, f"(optimiser vs target: worst {worst:.2e} m; "
          f"spread over five starts: worst {worst_spread:.2e} m)")


if __name__ == "__main__":
    main()
