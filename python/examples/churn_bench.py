"""A client leaving the session: what it costs the keeper and the other writers (docs/bench/python.md).

    python3 python/examples/churn_bench.py PATH/TO/robosim [K]

Keepers with the resizable (before: ROBOSIM_BENCH_DYNAMIC_RESPONSES=1) and the fixed (after)
response pool, interleaved, twice; per cycle a child process attaches, commits once and exits,
then this planner's next set_joints is timed; keeper CPU per cycle from /proc.
"""
import os, subprocess, sys, tempfile, time, shutil
import numpy as np
import robosim
R = sys.argv[1]; K = int(sys.argv[2]) if len(sys.argv) > 2 else 10
home = tempfile.mkdtemp(); os.environ["ROBOSIM_HOME"] = home
CHILD = "import sys,robosim;s=robosim.Session(sys.argv[1]);s.set_joints('positioner',s.joints('positioner'))"
def ticks(pid):
    rest = open(f"/proc/{pid}/stat").read().rsplit(") ", 1)[1].split()
    return int(rest[11]) + int(rest[12])
print("| rep | response pool | next set_joints after a departure p50 / max ms | child attach+commit+exit p50 ms | keeper CPU per attach+departure ms |")
print("|---|---|---|---|---|")
for rep in range(2):
    for mode in ("resizable (before)", "fixed (after)"):
        name = f"churn{rep}{mode[0]}{os.getpid()}"
        env = dict(os.environ)
        if mode.startswith("resizable"):
            env["ROBOSIM_BENCH_DYNAMIC_RESPONSES"] = "1"
        k = subprocess.Popen([R, "space", "--scene", "surgical_positioner_cell", "--session", name, "--no-sync"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        t0 = time.monotonic()
        while True:
            try:
                s = robosim.Session(name); break
            except robosim.SessionError:
                if time.monotonic() - t0 > 60: raise
                time.sleep(0.05)
        q = s.joints("positioner")
        for _ in range(50): s.set_joints("positioner", q)
        nxt, child = [], []
        c0 = ticks(k.pid)
        for i in range(K):
            t = time.perf_counter_ns()
            subprocess.run([sys.executable, "-c", CHILD, name], check=True)
            child.append(time.perf_counter_ns() - t)
            t = time.perf_counter_ns()
            s.set_joints("positioner", q)
            nxt.append(time.perf_counter_ns() - t)
        cpu = (ticks(k.pid) - c0) * 10 / K
        nxt = np.array(nxt) / 1e6; child = np.array(child) / 1e6
        print(f"| {rep} | {mode} | {np.median(nxt):.2f} / {nxt.max():.2f} | {np.median(child):.0f} | {cpu:.0f} |", flush=True)
        del s
        k.terminate(); k.wait()
        for f in os.listdir("/dev/shm"):
            if f.startswith(f"rs_{name}_"): os.remove(os.path.join("/dev/shm", f))
shutil.rmtree(home, ignore_errors=True)
