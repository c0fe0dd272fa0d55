"""Figures of a run from Python: ``robosim.plot(run, out)`` is ``robosim plot RUN --out OUT``.

``run`` is a recording (``robosim simulator --record run.mcap``) or the simulator's CSV signal
log (``$ROBOSIM_HOME/<session>/run/simulator-<robot>.csv``). One PNG per robot (joint positions,
velocities, efforts and the actuator work, a panel each), ``contacts.png``, the run's events as
vertical lines, and ``plot.json``; the call returns that JSON as a dict (figures, panels,
series labels, axis ranges, events).

The drawing is the ``robosim`` binary's (the same figures as the command, and the wheel stays
free of a plotting library): it is found from ``$ROBOSIM_BIN``, else on ``PATH``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess

from ._robosim import RobosimError


def _binary():
    exe = os.environ.get("ROBOSIM_BIN") or shutil.which("robosim")
    if not exe:
        raise FileNotFoundError(
            "robosim.plot runs the robosim binary: put it on PATH "
            "(cargo install --path . in the repository) or set ROBOSIM_BIN"
        )
    return exe


def plot(run: str | os.PathLike[str], out: str | os.PathLike[str] = "robosim-plots") -> dict:
    """Draw the run ``run`` (an MCAP recording or a CSV signal log) into the directory ``out``
    and return what was drawn (``plot.json`` as a dict). A file that cannot be plotted raises
    RobosimError naming it and what is wrong."""
    run, out = os.fspath(run), os.fspath(out)
    r = subprocess.run(
        [_binary(), "-q", "plot", run, "--out", out],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        raise RobosimError(r.stderr.strip() or f"robosim plot {run} failed ({r.returncode})")
    with open(os.path.join(out, "plot.json")) as f:
        return json.load(f)
