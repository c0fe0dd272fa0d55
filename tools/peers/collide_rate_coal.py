#!/usr/bin/env python3
"""A Python + coal loop doing the work of robosim's `collide` op on the same request lines
(issue 37 item 4): parse the JSON line, build the two coal shapes (cylinder, cone: coal's
cylinder and cone are centred on z like robosim's), collide (boolean), then distance with the
nearest points (coal's default GJK tolerance, 1e-6 — robosim answers certified distances), and
serialise an answer object like robosim's. The shapes are built every request, as a simple
client would; the line with a shape cache keyed by the shape's JSON text is printed too.

Lines: written by `cargo run --release -p robosim-hl-interface --example collide_rate --
--write /tmp/collide_lines.jsonl`.

Run: /work/peers-venv/bin/python tools/peers/collide_rate_coal.py /tmp/collide_lines.jsonl [rounds]
Versions: coal 3.0.3, Python 3.11.
"""

import json
import statistics
import sys
import time

import coal
import numpy as np


def shape(s):
    if s["shape"] == "cylinder":
        return coal.Cylinder(s["radius"], s["height"])
    if s["shape"] == "cone":
        return coal.Cone(s["radius"], s["height"])
    raise ValueError(s["shape"])


def tf(m):
    m = np.array(m, dtype=float)
    return coal.Transform3s(m[:3, :3], m[:3, 3])


def answer(line, cache):
    req = json.loads(line)
    if cache is None:
        a, b = shape(req["a"]), shape(req["b"])
    else:
        ka, kb = json.dumps(req["a"], sort_keys=True), json.dumps(req["b"], sort_keys=True)
        a = cache.get(ka) or cache.setdefault(ka, shape(req["a"]))
        b = cache.get(kb) or cache.setdefault(kb, shape(req["b"]))
    ta, tb = tf(req["pose_a"]), tf(req["pose_b"])
    cres = coal.CollisionResult()
    coal.collide(a, ta, b, tb, coal.CollisionRequest(), cres)
    hit = cres.isCollision()
    dres = coal.DistanceResult()
    d = coal.distance(a, ta, b, tb, coal.DistanceRequest(), dres)
    out = {
        "id": req["id"],
        "ok": True,
        "verdict": "contact" if hit else "clear",
        "intersect": hit,
        "distance": 0.0 if hit else d,
        "signed_distance": d,
        "witness_a": list(dres.getNearestPoint1()),
        "witness_b": list(dres.getNearestPoint2()),
    }
    return json.dumps(out)


def time_lines(lines, cached):
    """One pass over the lines: µs per request (a fresh cache when `cached`)."""
    cache = {} if cached else None
    t0 = time.perf_counter()
    for l in lines:
        answer(l, cache)
    return (time.perf_counter() - t0) / len(lines) * 1e6


def main():
    lines = open(sys.argv[1]).read().splitlines()
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    for name, cached in [("coal, shapes built per request", False), ("coal, shapes cached by JSON text", True)]:
        per = [time_lines(lines, cached) for _ in range(rounds)]
        m = statistics.median(per)
        print(f"{name}: {m:.2f} us per request ({1e6 / m:.0f} requests/s), spread {min(per):.2f}..{max(per):.2f} us over {rounds} rounds of {len(lines)}")


if __name__ == "__main__":
    main()
