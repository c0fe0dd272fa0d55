"""Latency of the Python client against the same work through `robosim query --session` pipes.

    python3 python/examples/bench.py --session lab [--n 2000]

Measures, on one session, p50 and p99 of:
* Python `set_joints` → acknowledged (one transaction, keeper journaled and published);
* Python `query(movej)` with collision checks off → acknowledged;
* the same movej request through a `robosim query --session` child's pipes (JSON lines);
* a change → Python `wait_changes` wake-up: a writer process commits every 2 ms, the waiter
  compares CLOCK_MONOTONIC at wake-up with the keeper's publish stamp.
Prints a markdown table (µs).
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

import robosim

ROBOT = "positioner"


def pct(xs):
    xs = np.asarray(xs) / 1e3
    return f"{np.percentile(xs, 50):.1f} | {np.percentile(xs, 99):.1f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--session", default="lab")
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--robosim", default=os.environ.get("ROBOSIM_BIN", "robosim"))
    a = ap.parse_args()
    s = robosim.Session(a.session)
    q0 = s.joints(ROBOT)
    qs = [q0 + 1e-4 * (k % 2) for k in range(a.n)]
    ack = []
    for q in qs:
        t = time.perf_counter_ns()
        s.set_joints(ROBOT, q)
        ack.append(time.perf_counter_ns() - t)
    s.query({"op": "c_switch", "on": False})
    mv = []
    for q in qs:
        req = {"op": "movej", "robot": ROBOT, "q": q}
        t = time.perf_counter_ns()
        s.query(req)
        mv.append(time.perf_counter_ns() - t)
    child = subprocess.Popen(
        [a.robosim, "query", "--session", a.session],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        bufsize=1,
    )
    child.stdin.write(json.dumps({"op": "c_switch", "on": False}) + "\n")
    child.stdin.flush()
    child.stdout.readline()
    pipe = []
    for q in qs:
        line = json.dumps({"op": "movej", "robot": ROBOT, "q": q.tolist()}) + "\n"
        t = time.perf_counter_ns()
        child.stdin.write(line)
        child.stdin.flush()
        child.stdout.readline()
        pipe.append(time.perf_counter_ns() - t)
    child.stdin.close()
    child.wait()
    writer = subprocess.Popen(
        [sys.executable, "-c", WRITER, a.session, str(a.n // 4)],
        env=os.environ,
    )
    while s.wait_change(0) is not None:
        pass
    wake = []
    while writer.poll() is None or len(wake) == 0:
        cs = s.wait_changes(1.0)
        now = time.monotonic_ns()
        if cs and len(cs) == 1:  # one commit per wake-up: its own latency
            wake.append(now - cs[0]["published_ns"])
        if writer.poll() is not None:
            break
    print("| path | p50 µs | p99 µs |")
    print("|---|---|---|")
    print(f"| Python `set_joints` → acknowledged | {pct(ack)} |")
    print(f"| Python `query(movej)` → acknowledged | {pct(mv)} |")
    print(f"| `robosim query --session` pipes, movej → answer line | {pct(pipe)} |")
    print(f"| commit published → Python `wait_changes` awake ({len(wake)} samples) | {pct(wake)} |")


WRITER = """
import sys, time, robosim
s = robosim.Session(sys.argv[1])
q = s.joints("positioner")
for k in range(int(sys.argv[2])):
    q[5] = 1e-4 * (k % 2)
    s.set_joints("positioner", q)
    time.sleep(0.002)
"""

if __name__ == "__main__":
    main()
