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

and run the algorithms on one robot, Pinocchio-style, on one configuration or a batch::

    m = robosim.Model("puma560")           # or Model.from_urdf(path, tip=...), s.model("arm2")
    T = m.fk(q)                            # 4x4; m.fk(Q) for Q of shape (N, n): (N, 4, 4)
    tau = m.rnea(q, v, a); M = m.crba(q); qdd = m.aba(q, v, tau); g = m.gravity(q)
    q = m.ik(T, method="analytic")         # every method and branch of the protocol's ik

Every refusal raises RobosimError (or its subclass for the error kind: SessionError,
TransactionError, JointLimitError, RequestError, RobotError, UnreachableError,
NotConvergedError, NotApplicableError, NumericalError, ShapeError) with
``.kind`` and ``.message``; a refusal changes nothing.
"""

from ._robosim import (
    Dataflow,
    JointLimitError,
    Model,
    NotApplicableError,
    NotConvergedError,
    NumericalError,
    RequestError,
    RobosimError,
    RobotError,
    Session,
    SessionError,
    ShapeError,
    Sim,
    Snapshot,
    TransactionError,
    UnreachableError,
    collide,
    distance,
    query,
)
from .plot import plot

__all__ = [
    "Session",
    "Dataflow",
    "Snapshot",
    "Sim",
    "RobosimError",
    "SessionError",
    "TransactionError",
    "JointLimitError",
    "RequestError",
    "RobotError",
    "UnreachableError",
    "NotConvergedError",
    "NotApplicableError",
    "NumericalError",
    "ShapeError",
    "Model",
    "query",
    "collide",
    "distance",
    "plot",
]
__version__ = "0.1.0"
