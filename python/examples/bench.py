"""Latency of the Python client against the Rust planner client and `robosim query --session` pipes.

    python3 python/examples/bench.py --session lab [--n 2000]
    python3 python/examples/bench.py --fresh [--n 2000] [--planner-bench PATH]
    python3 python/examples/bench.py --spin-compare 200 [--reps 5] [--n 2000] [--planner-bench PATH]

With --session: one running session. With --fresh: two fresh sessions of the
surgical_positioner_cell, one whose keeper syncs its journal before every acknowledgement (the
default) and one started with `robosim space --no-sync`, every row measured on both in this run;
the Rust rows come from the planner_bench example (`--planner-bench`, default
target/release/examples/planner_bench).

Measures p50 and p99 of:
* Python `set_joints` → acknowledged (one transaction, keeper journaled and published);
* Python `query(movej)` with collision checks off → acknowledged;
* the same movej request through a `robosim query --session` child's pipes (JSON lines);
* a change → Python `wait_changes` wake-up: a writer process commits every 2 ms, the waiter
  compares CLOCK_MONOTONIC at wake-up with the keeper's publish stamp;
* the same two through the Rust planner client (the planner_bench example), when given.
Prints a markdown table (µs).

With --spin-compare S: two fresh --no-sync sessions, one keeper started with ROBOSIM_SPIN_US=0
and one with ROBOSIM_SPIN_US=S (the clients of each with the same setting), and `set_joints` →
acknowledged from Rust and Python measured on each in turn, --reps times, with the keepers' CPU
time over each block (in % of one core).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

import robosim

ROBOT = "positioner"


def pct(xs):
    xs = np.asarray(xs) / 1e3
    return f"{np.percentile(xs, 50):.1f} | {np.percentile(xs, 99):.1f}"


def measure(session, n, robosim_bin, planner_bench):
    """Every row on one running session: [(row, p50 | p99 text)]."""
    rows = []
    if planner_bench:
        out = subprocess.run(
            [planner_bench, "--session", session, "--n", str(n)],
            check=True, capture_output=True, text=True,
        ).stdout
        for line in out.splitlines():
            r = json.loads(line)
            rows.append((r["row"], f"{r['p50_us']:.1f} | {r['p99_us']:.1f}"))
    s = robosim.Session(session)
    q0 = s.joints(ROBOT)
    qs = [q0 + 1e-4 * (k % 2) for k in range(n)]
    ack = []
    for q in qs:
        t = time.perf_counter_ns()
        s.set_joints(ROBOT, q)
        ack.append(time.perf_counter_ns() - t)
    rows.append(("Python `set_joints` → acknowledged", pct(ack)))
    s.query({"op": "c_switch", "on": False})
    mv = []
    for q in qs:
        req = {"op": "movej", "robot": ROBOT, "q": q}
        t = time.perf_counter_ns()
        s.query(req)
        mv.append(time.perf_counter_ns() - t)
    rows.append(("Python `query(movej)` (collision off) → acknowledged", pct(mv)))
    child = subprocess.Popen(
        [robosim_bin, "query", "--session", session],
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
    rows.append(("`robosim query --session` pipes, the same movej (= set_joints' transaction) → answer line", pct(pipe)))
    writer = subprocess.Popen(
        [sys.executable, "-c", WRITER, session, str(n // 4)],
        env=os.environ,
    )
    while s.wait_change(0) is not None:
        pass
    wake = []
    while True:
        cs = s.wait_changes(1.0)
        now = time.monotonic_ns()
        if cs and len(cs) == 1:  # one commit per wake-up: its own latency
            wake.append(now - cs[0]["published_ns"])
        if writer.poll() is not None:
            break
    rows.append((f"commit published → Python `wait_changes` returned ({len(wake)} samples)", pct(wake)))
    return rows


def fresh_session(robosim_bin, name, no_sync):
    """A keeper of its own in a temp home; returns (process, home)."""
    home = tempfile.mkdtemp(prefix="robosim-bench-")
    os.environ["ROBOSIM_HOME"] = home
    args = [robosim_bin, "space", "--scene", "surgical_positioner_cell", "--session", name]
    if no_sync:
        args.append("--no-sync")
    p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    start = time.monotonic()
    while True:
        try:
            robosim.Session(name)
            return p, home
        except robosim.SessionError:
            if time.monotonic() - start > 30:
                p.kill()
                raise
            time.sleep(0.05)


def keeper_ticks(pid):
    with open(f"/proc/{pid}/stat") as f:
        rest = f.read().rsplit(") ", 1)[1].split()
    return int(rest[11]) + int(rest[12])


def spin_compare(a, bench):
    """set_joints round trips against keepers with and without a spin window, interleaved."""
    home = tempfile.mkdtemp(prefix="robosim-bench-")
    os.environ["ROBOSIM_HOME"] = home
    spins = (0, a.spin_compare)
    keepers = {}
    try:
        for spin in spins:
            name = f"bs{spin}x{os.getpid()}"  # short: session names are bounded
            env = dict(os.environ, ROBOSIM_SPIN_US=str(spin))
            keepers[spin] = (name, subprocess.Popen(
                [a.robosim, "space", "--scene", "surgical_positioner_cell", "--session", name,
                 "--no-sync"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        for spin in spins:  # wait for both keepers
            start = time.monotonic()
            while subprocess.run([sys.executable, "-c", PY_ACK, keepers[spin][0], "1"],
                                 capture_output=True).returncode != 0:
                if time.monotonic() - start > 60:
                    raise RuntimeError(f"keeper of {keepers[spin][0]} did not come up")
                time.sleep(0.1)
        print("| rep | spin µs | Rust p50 µs | Rust p99 µs | Python p50 µs | Python p99 µs | keeper CPU % of a core |")
        print("|---|---|---|---|---|---|---|")
        for rep in range(a.reps):
            for spin in spins:
                name, proc = keepers[spin]
                env = dict(os.environ, ROBOSIM_SPIN_US=str(spin))
                t0, c0 = time.monotonic(), keeper_ticks(proc.pid)
                r = {"p50_us": float("nan"), "p99_us": float("nan")}
                if os.path.exists(bench):
                    out = subprocess.run([bench, "--session", name, "--n", str(a.n), "--ack-only"],
                                         check=True, capture_output=True, text=True, env=env).stdout
                    r = json.loads(out.splitlines()[0])
                # Python in a process of its own per block (one attachment per process).
                ack = json.loads(subprocess.run([sys.executable, "-c", PY_ACK, name, str(a.n)],
                                                check=True, capture_output=True, text=True,
                                                env=env).stdout)
                cpu = (keeper_ticks(proc.pid) - c0) / 100 / (time.monotonic() - t0) * 100
                print(f"| {rep} | {spin} | {r['p50_us']:.1f} | {r['p99_us']:.1f} | {pct(ack)} | {cpu:.0f} |",
                      flush=True)
    finally:
        for name, proc in keepers.values():
            proc.terminate()
            proc.wait()
            for f in os.listdir("/dev/shm"):
                if f.startswith(f"rs_{name}_"):
                    os.remove(os.path.join("/dev/shm", f))
        shutil.rmtree(home, ignore_errors=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--session", default="lab")
    ap.add_argument("--fresh", action="store_true")
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--robosim", default=os.environ.get("ROBOSIM_BIN", "robosim"))
    ap.add_argument("--planner-bench", default=None)
    ap.add_argument("--spin-compare", type=int, default=None, metavar="S")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    if a.spin_compare is not None:
        spin_compare(a, a.planner_bench or os.path.join("target", "release", "examples", "planner_bench"))
        return
    if not a.fresh:
        rows = measure(a.session, a.n, a.robosim, a.planner_bench)
        print("| path | p50 µs | p99 µs |")
        print("|---|---|---|")
        for r, v in rows:
            print(f"| {r} | {v} |")
        return
    bench = a.planner_bench or os.path.join("target", "release", "examples", "planner_bench")
    table = {}
    for no_sync in (False, True):
        name = f"bench{'nosync' if no_sync else 'sync'}{os.getpid()}"
        keeper, home = fresh_session(a.robosim, name, no_sync)
        try:
            for r, v in measure(name, a.n, a.robosim, bench):
                table.setdefault(r.split(" (")[0] if "samples" in r else r, {})[no_sync] = v
        finally:
            keeper.terminate()
            keeper.wait()
            for f in os.listdir("/dev/shm"):
                if f.startswith(f"rs_{name}_"):
                    os.remove(os.path.join("/dev/shm", f))
            shutil.rmtree(home, ignore_errors=True)
    print("| path | journal synced: p50 µs | p99 µs | --no-sync: p50 µs | p99 µs |")
    print("|---|---|---|---|---|")
    for r, v in table.items():
        print(f"| {r} | {v.get(False, '– | –')} | {v.get(True, '– | –')} |")


PY_ACK = """
import json, sys, time, robosim
s = robosim.Session(sys.argv[1])
q0 = s.joints("positioner")
ack = []
for k in range(int(sys.argv[2])):
    q = q0 + 1e-4 * (k % 2)
    t = time.perf_counter_ns()
    s.set_joints("positioner", q)
    ack.append(time.perf_counter_ns() - t)
print(json.dumps(ack))
"""

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
