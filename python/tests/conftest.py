"""Fixtures: real robosim sessions (a keeper and a lock-step simulator) in a temp home.

The robosim binary comes from $ROBOSIM_BIN (python/tests/pytest.rs sets it), else from PATH.
Each session has its own name; every process started here is stopped by its pid, and the
session's shared-memory files are removed afterwards.
"""

import gc
import os
import shutil
import signal
import subprocess
import tempfile
import time

import pytest

import robosim

# Before the extension first logs: iceoryx2 reads its log level once.
os.environ.setdefault("IOX2_LOG_LEVEL", "Error")

BIN = os.environ.get("ROBOSIM_BIN") or shutil.which("robosim") or "robosim"
SCENE = "surgical_positioner_cell"


class Procs:
    """Processes of one session, started with its name and home, stopped by pid."""

    def __init__(self, tag):
        self.name = f"py{tag}{os.getpid()}"
        self.home = tempfile.mkdtemp(prefix="robosim-py-")
        os.environ["ROBOSIM_HOME"] = self.home
        os.environ.setdefault("IOX2_LOG_LEVEL", "Error")
        self.procs = []

    def attach(self):
        """A planner's attachment to this session (its home made the current one)."""
        os.environ["ROBOSIM_HOME"] = self.home
        return robosim.Session(self.name)

    def spawn(self, *args):
        log = open(os.path.join(self.home, f"{args[0]}-{len(self.procs)}.log"), "wb")
        p = subprocess.Popen(
            [BIN, *args, "--session", self.name],
            stdout=log,
            stderr=subprocess.STDOUT,
            env=dict(os.environ, ROBOSIM_HOME=self.home),
        )
        self.procs.append(p)
        return p

    def start_keeper(self):
        p = self.spawn("space", "--scene", SCENE)
        self.wait_for(self.attach, "the keeper")
        return p

    def start_simulator(self):
        p = self.spawn("simulator", "--mode", "lockstep")
        s = self.attach()
        self.wait_for(lambda: s.sim.state(), "the simulator")
        return p

    def start_plant(self, *args):
        """The automation plant (``robosim automation``, the ECLSS model); returns once it
        answers commands (its units are then committed)."""
        p = self.spawn("automation", *args)
        s = self.attach()
        self.wait_for(lambda: s.plant_command({"cmd": "get"}), "the automation plant")
        return p

    def wait_for(self, f, what, timeout=30.0):
        start = time.monotonic()
        while True:
            try:
                return f()
            except robosim.SessionError as e:
                if time.monotonic() - start > timeout:
                    raise AssertionError(f"{what} did not come up: {e}\n{self.logs()}") from e
                time.sleep(0.05)

    def logs(self):
        """The output of every process started here so far."""
        out = []
        for f in sorted(os.listdir(self.home)):
            if f.endswith(".log"):
                with open(os.path.join(self.home, f), "rb") as fh:
                    out.append(f"--- {f}\n" + fh.read()[-2000:].decode(errors="replace"))
        return "\n".join(out)

    def stop(self, p, sig=signal.SIGTERM):
        if p.poll() is None:
            p.send_signal(sig)
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()

    def close(self):
        gc.collect()  # attachments the test dropped let go of the session before it goes
        for p in reversed(self.procs):
            self.stop(p)
        prefix = f"rs_{self.name}_"
        for f in os.listdir("/dev/shm"):
            if f.startswith(prefix):
                try:
                    os.remove(os.path.join("/dev/shm", f))
                except OSError:
                    pass
        shutil.rmtree(self.home, ignore_errors=True)


@pytest.fixture(scope="module")
def lab():
    """A session with a keeper (the §2.7 surgical-positioner cell) and a lock-step simulator."""
    p = Procs("lab")
    try:
        p.start_keeper()
        p.start_simulator()
        yield p
    finally:
        p.close()


@pytest.fixture
def procs():
    p = Procs("own")
    try:
        yield p
    finally:
        p.close()
