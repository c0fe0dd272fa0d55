"""Type stubs of the extension module robosim._robosim (see robosim/__init__.py)."""

from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

ArrayLike = Union[Sequence[float], npt.NDArray[np.float64]]
Json = Any

class RobosimError(Exception):
    """A refusal: ``kind`` is the query protocol's error kind, ``message`` says what and where."""

    kind: str
    message: str

class SessionError(RobosimError):
    """No such session, no keeper/simulator, or a peer went away (kind ``session``)."""

class TransactionError(RobosimError):
    """The keeper refused a transaction; nothing changed (kind ``transaction``)."""

class JointLimitError(RobosimError):
    """Joint values outside the limits; nothing changed (kind ``joint_limit``)."""

class Snapshot:
    """One consistent version of the model, a view of shared memory."""

    @property
    def version(self) -> int: ...
    @property
    def structure_version(self) -> int: ...
    def robots(self) -> List[str]: ...
    def objects(self) -> List[str]: ...
    def joints(self, robot: str) -> npt.NDArray[np.float64]:
        """Committed joint values (rad / m), chain order."""
    def limits(self, robot: str) -> npt.NDArray[np.float64]:
        """Joint limits, shape (n, 2): [lo, hi] (rad / m)."""
    def pose(self, name: str) -> npt.NDArray[np.float64]:
        """World pose of an object, 4x4 (m), acting on column vectors."""

class Sim:
    """The session's simulator daemon (``robosim simulator``)."""

    def step(self, n: int = 1) -> Dict[str, Json]:
        """Lock-step: advance n steps, return the state after them."""
    def state(self) -> Dict[str, Json]: ...
    def target(self, robot: str, q: ArrayLike) -> str: ...
    def torque(self, robot: str, tau: ArrayLike) -> str: ...
    def pause(self) -> str: ...
    def resume(self) -> str: ...
    def reset(self) -> str: ...

class Session:
    """An attachment to a running session; raises SessionError if there is none."""

    def __init__(self, name: str) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def version(self) -> int: ...
    @property
    def sim(self) -> Sim: ...
    def snapshot(self) -> Snapshot: ...
    def robots(self) -> List[str]: ...
    def joints(self, robot: str) -> npt.NDArray[np.float64]: ...
    def set_joints(self, robot: str, q: ArrayLike) -> int:
        """One transaction; returns the acknowledged version."""
    def transact(self, ops: Sequence[Sequence[Json]]) -> int:
        """One all-or-nothing transaction of [op, object, args...] ops."""
    def wait_change(self, timeout: float = 1.0) -> Optional[int]:
        """Newest version committed after the last one seen, or None on timeout."""
    def wait_changes(self, timeout: float = 1.0) -> Optional[List[Dict[str, Json]]]:
        """The commits after the last one seen: version, aspects, objects, ids, published_ns."""
    def query(self, request: Dict[str, Json]) -> Dict[str, Json]:
        """Any op of the query protocol; the answer dict (number arrays as numpy arrays)."""
    def plant_command(self, command: Dict[str, Json]) -> Dict[str, Json]:
        """A command to the automation plant: {"cmd": "fault", "fault": NAME} or {"cmd": "get"};
        its state (faults, ringing alarms, units). SessionError if no plant runs or it refuses."""
