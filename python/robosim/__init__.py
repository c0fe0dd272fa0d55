"""robosim: a planner's client to a running robosim session (docs/python.md).

Attach to a session's Instance Space over shared memory, read it, wait for its changes, write
transactions, ask any op of the query protocol, and drive the simulator in lock-step::

    import robosim
    s = robosim.Session("lab")
    snap = s.snapshot()
    q = snap.joints("positioner")          # numpy float64 (rad / m)
    v = s.set_joints("positioner", q)      # one transaction; the acknowledged version
    v = s.wait_change(timeout=1.0)         # newest version after the last seen, or None
    r = s.query({"op": "kinv", "robot": "positioner", "pose": T})
    s.sim.step(10)                         # lock-step: 10 simulator steps, then its state
    robosim.plot("run.mcap", "plots/")     # figures of a recorded run (or its CSV log)

Every refusal raises RobosimError (or SessionError, TransactionError, JointLimitError) with
``.kind`` and ``.message``; a refusal changes nothing.
"""

from ._robosim import (
    JointLimitError,
    RobosimError,
    Session,
    SessionError,
    Sim,
    Snapshot,
    TransactionError,
)
from .plot import plot

__all__ = [
    "Session",
    "Snapshot",
    "Sim",
    "RobosimError",
    "SessionError",
    "TransactionError",
    "JointLimitError",
    "plot",
]
__version__ = "0.1.0"
