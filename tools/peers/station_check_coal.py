#!/usr/bin/env python3
"""coal's side of the robot-versus-station check (issue 37 item 2).

Reads testdata/collision/station_check.json (written by
report/examples/station_check_export.rs: the space station's servicer, 6 DOF, and the 300-odd
other parts of `space_station`) and checks the servicer against the scene with coal 3.0.3 at
the two configurations, as robosim's criterion bench core/collision/benches/station_check.rs
does: exact primitives (box, cylinder, cone, sphere; other library primitives as triangle
meshes, BVHModelOBBRSS), the scene in a DynamicAABBTreeCollisionManager, the robot's parts in a
second one, one manager-against-manager `collide` per check with coal's default callback (stops
at the first contact: num_max_contacts 1, no depth asked — coal's boolean check).

Timed: the C++ call `scene.collide(robot, callback)` through the Python binding, the robot's
transforms fixed (robosim's bench also times from given link poses). The binding's own cost
per call is measured beside it (`collide` of an empty robot manager) and subtracted; both
figures are printed. Verdicts must match robosim's (contact / clear) or the script refuses to
report.

Run: /work/peers-venv/bin/python tools/peers/station_check_coal.py [rounds]
Versions: coal 3.0.3 (pip, cmeel), Python 3.11.
"""

import json
import os
import statistics
import sys
import time

import coal
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def mat(m):
    return np.array(m, dtype=float)


def geometry(s):
    k = s["shape"]
    if k == "box":
        return coal.Box(*s["size"])
    if k == "cylinder":
        return coal.Cylinder(s["radius"], s["height"])
    if k == "cone":
        return coal.Cone(s["radius"], s["height"])
    if k == "sphere":
        return coal.Sphere(s["radius"])
    if k == "mesh":
        verts = np.array(s["vertices"], dtype=float)
        tris = []
        for p in s["polygons"]:
            for i in range(1, len(p) - 1):  # fan triangulation (faces are convex)
                tris.append([p[0], p[i], p[i + 1]])
        m = coal.BVHModelOBBRSS()
        m.beginModel(len(tris), len(verts))
        m.addVertices(verts)
        m.addTriangles(np.array(tris, dtype=np.int64))
        m.endModel()
        return m
    raise ValueError(f"shape {k}")


def obj(s, pose):
    g = geometry(s)
    t = coal.Transform3s(pose[:3, :3], pose[:3, 3])
    o = coal.CollisionObject(g, t)
    o.computeAABB()
    return o


def load():
    """(doc, scene manager, keep): the station's objects in a DynamicAABBTreeCollisionManager;
    `keep` holds the coal objects, which must outlive the managers."""
    doc = json.load(open(os.path.join(ROOT, "testdata/collision/station_check.json")))
    keep = []
    scene = coal.DynamicAABBTreeCollisionManager()
    for o in doc["objects"]:
        co = obj(o, mat(o["pose"]))
        keep.append(co)
        scene.registerObject(co)
    scene.setup()
    return doc, scene, keep


def robot(doc, name, keep):
    """The robot's parts at configuration `name` ("contact" or "clear") in their own manager."""
    cfg = doc["configurations"][name]
    mgr = coal.DynamicAABBTreeCollisionManager()
    for link, frame in zip(doc["links"], cfg["link_frames"]):
        for part in link:
            co = obj(part, mat(frame) @ mat(part["pose"]))
            keep.append(co)
            mgr.registerObject(co)
    mgr.setup()
    return mgr


def check(scene, mgr):
    """coal's boolean check: one manager-against-manager collide, default callback."""
    cb = coal.CollisionCallBackDefault()
    scene.collide(mgr, cb)
    return cb.data.result.isCollision()


def empty_manager():
    mgr = coal.DynamicAABBTreeCollisionManager()
    mgr.setup()
    return mgr


def time_once(scene, mgr, empty, n=2000):
    """One round: (seconds per check, seconds per check of the empty robot manager)."""
    t0 = time.perf_counter()
    for _ in range(n):
        check(scene, mgr)
    per = (time.perf_counter() - t0) / n
    t0 = time.perf_counter()
    for _ in range(n):
        check(scene, empty)
    return per, (time.perf_counter() - t0) / n


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    doc, scene, keep = load()
    for name, expect in [("contact", True), ("clear", False)]:
        mgr = robot(doc, name, keep)
        empty = empty_manager()
        got = check(scene, mgr)
        if got != expect:
            sys.exit(f"{name}: coal says {'contact' if got else 'clear'}, robosim {'contact' if expect else 'clear'}")
        n = 2000
        per, base = zip(*(time_once(scene, mgr, empty, n) for _ in range(rounds)))
        med, bmed = statistics.median(per), statistics.median(base)
        print(
            f"{name}: coal check {med * 1e6:.2f} us per call (min {min(per) * 1e6:.2f}, max {max(per) * 1e6:.2f}), "
            f"binding + callback alone {bmed * 1e6:.2f} us, net {(med - bmed) * 1e6:.2f} us "
            f"over {rounds} rounds of {n}; robot parts {sum(len(l) for l in doc['links'])}, objects {len(doc['objects'])}"
        )


if __name__ == "__main__":
    main()
