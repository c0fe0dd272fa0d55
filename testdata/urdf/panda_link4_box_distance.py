#!/usr/bin/env python3
"""Reference distance for robosim's URDF collision geometry, computed by coal (hpp-fcl).

The Panda's link4 collision mesh (example-robot-data 6.0.0, vendored beside this script under
example-robot-data/robots/panda_description/meshes/collision/link4.stl; Apache-2.0, see
LICENSE-panda_description) is read as binary STL (float32 vertices widened to float64, no
scale, no <origin>: panda.urdf gives link4's <collision> neither), made convex by coal's
Convex.convexHull (qhull), and its distance to a box is computed by coal.distance with GJK
tolerance 1e-14 — in link4's own frame. robosim's test (file-io/tests/urdf_geometry.rs)
builds the same link from panda.urdf (parry's hull of the same vertices), poses the robot at a
non-zero q, places the box at T_link4(q) * box_pose, and compares its exact-mode distance.

As an independent check the script also gives the smallest distance from a hull vertex to the
box (numpy, closed form): it equals the hull-box distance when the nearest feature of the hull
is a vertex (the box poses below are chosen so), and is an upper bound otherwise.

Usage (from the repository root):
    python3 -m venv /tmp/coal && /tmp/coal/bin/pip install coal
    /tmp/coal/bin/python testdata/urdf/panda_link4_box_distance.py > testdata/urdf/panda_link4_box_distance.json
"""
import json
import os
import struct

import coal
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
STL = os.path.join(
    HERE, "example-robot-data/robots/panda_description/meshes/collision/link4.stl"
)

# Boxes in link4's frame: full side lengths (m), translation (m), rotation as roll-pitch-yaw
# (URDF convention R = Rz(y) Ry(p) Rx(r)).
CASES = [
    {"size": [0.1, 0.2, 0.3], "xyz": [0.25, 0.05, 0.02], "rpy": [0.0, 0.0, 0.0]},
    {"size": [0.05, 0.4, 0.1], "xyz": [-0.08, 0.3, 0.1], "rpy": [0.3, -0.2, 0.5]},
    {"size": [0.2, 0.2, 0.05], "xyz": [0.0, 0.0, -0.2], "rpy": [0.1, 0.2, 0.3]},
]


def read_binary_stl(path):
    data = open(path, "rb").read()
    (n,) = struct.unpack_from("<I", data, 80)
    assert len(data) == 84 + 50 * n, "not a binary STL"
    pts = []
    for t in range(n):
        vals = struct.unpack_from("<12f", data, 84 + 50 * t)
        for k in range(3):
            pts.append(tuple(float(v) for v in vals[3 + 3 * k : 6 + 3 * k]))
    return np.unique(np.array(pts, dtype=np.float64), axis=0)


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def point_box_distance(p, half, rot, t):
    local = rot.T @ (p - t)
    d = np.maximum(np.abs(local) - half, 0.0)
    return float(np.linalg.norm(d))


def main():
    pts = read_binary_stl(STL)
    vec = coal.StdVec_Vec3s()
    for p in pts:
        vec.append(p)
    hull = coal.Convex.convexHull(vec, False, "")
    out = {"mesh": "link4.stl", "distinct_vertices": int(len(pts)), "coal": coal.__version__, "cases": []}
    for c in CASES:
        half = np.array(c["size"]) / 2.0
        rot = rpy_matrix(*c["rpy"])
        t = np.array(c["xyz"])
        box = coal.Box(*c["size"])
        req = coal.DistanceRequest()
        req.gjk_tolerance = 1e-14
        res = coal.DistanceResult()
        d = coal.distance(hull, coal.Transform3s.Identity(), box, coal.Transform3s(rot, t), req, res)
        vmin = min(point_box_distance(p, half, rot, t) for p in pts)
        out["cases"].append({**c, "distance": float(d), "vertex_box_min": vmin})
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
