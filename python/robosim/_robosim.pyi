"""Type stubs of the extension module robosim._robosim (see robosim/__init__.py)."""

import os
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

class RequestError(RobosimError):
    """A malformed argument: wrong shape, non-finite number, bad field (``bad_request``...)."""

class RobotError(RobosimError):
    """No such robot, or a description/file that makes none (``unknown_robot``, ``bad_robot``)."""

class UnreachableError(RobosimError):
    """The pose is outside the workspace (``unreachable``)."""

class NotConvergedError(RobosimError):
    """An iterative solve missed the tolerance (``not_converged``)."""

class NotApplicableError(RobosimError):
    """The method does not apply to this robot (``not_applicable``)."""

class NumericalError(RobosimError):
    """Singular inertia, overflow, divergence or too many steps."""

class ShapeError(RobosimError):
    """The fields make no solid (``bad_shape``)."""

class Model:
    """One robot's algorithms (docs/python.md). Per-configuration methods take q of shape (nq,)
    and v, a, tau of shape (nv,), or batches (N, nq) / (N, nv), and answer with the batch axis
    first. A floating root's 7 q / 6 v and a ball joint's 4 / 3 are in them (docs/query.md);
    with mimic=True they are the reduced coordinates (the followers left out)."""

    def __init__(self, name: str) -> None: ...
    @staticmethod
    def from_urdf(
        path: str,
        tip: Optional[str] = None,
        floating: Union[None, bool, str] = None,
        mimic: bool = False,
    ) -> "Model": ...
    @staticmethod
    def from_mjcf(path: str, tip: Optional[str] = None, mimic: bool = False) -> "Model": ...
    @staticmethod
    def from_json(robot: Dict[str, Json]) -> "Model": ...
    @staticmethod
    def from_session(session: "Session", name: str) -> "Model": ...
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int: ...
    @property
    def nv(self) -> int: ...
    @property
    def njoints(self) -> int:
        """Joints of the full model (root not counted, followers counted)."""
    @property
    def coordinates(self) -> List[int]:
        """The full model's joint index of each reduced joint coordinate."""
    @property
    def root(self) -> Optional[str]:
        """"free_flyer", "planar", or None for a fixed base."""
    def limits(self) -> npt.NDArray[np.float64]:
        """(k, 2): [lo, hi] per joint of `coordinates`."""
    def to_json(self) -> Dict[str, Json]: ...
    def fk(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """Tool pose (4, 4), or (N, 4, 4)."""
    def frames(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """Base, every link, tool: (njoints+2, 4, 4), or (N, njoints+2, 4, 4)."""
    def jacobian(self, q: ArrayLike, frame: str = "base") -> npt.NDArray[np.float64]:
        """(6, nv) rows vx vy vz wx wy wz, frame "base" or "tool"; (N, 6, nv)."""
    def ik(
        self,
        pose: ArrayLike,
        method: Optional[str] = None,
        q0: Optional[ArrayLike] = None,
        tol: Union[None, float, Dict[str, Json]] = None,
        all: bool = False,
        full: bool = False,
        respect_limits: bool = True,
        max_iterations: Optional[int] = None,
        restarts: Optional[int] = None,
        seed: Optional[int] = None,
    ) -> Any:
        """q (nq,); with all (k, nq); a batch (N, nq) or a list; full: the ik op's answer dicts.
        A floating robot needs q0: the root is held there (not with mimic=True)."""
    def rnea(self, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> npt.NDArray[np.float64]: ...
    def crba(self, q: ArrayLike) -> npt.NDArray[np.float64]: ...
    def aba(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike) -> npt.NDArray[np.float64]: ...
    def gravity(self, q: ArrayLike) -> npt.NDArray[np.float64]: ...
    def simulate(
        self,
        q0: ArrayLike,
        t_end: float,
        integrator: str = "rk4",
        dt: Optional[float] = None,
        qd0: Optional[ArrayLike] = None,
        tau: Optional[ArrayLike] = None,
        outputs: Optional[ArrayLike] = None,
        rtol: Optional[float] = None,
        atol: Optional[float] = None,
        limits: bool = False,
        max_steps: Optional[int] = None,
    ) -> Dict[str, Json]:
        """{"t", "q", "qd", "energy", "stats"} at the output times."""
    def check(self, q: ArrayLike, scene: Dict[str, Json], **options: Json) -> Any:
        """The check op's answer dict; a list of them for a batch."""

def query(request: Dict[str, Json]) -> Dict[str, Json]:
    """Any pure op of the query protocol, answered in this process."""

def collide(a: Dict[str, Json], pose_a: ArrayLike, b: Dict[str, Json], pose_b: ArrayLike, **options: Json) -> Dict[str, Json]: ...
def distance(a: Dict[str, Json], pose_a: ArrayLike, b: Dict[str, Json], pose_b: ArrayLike, **options: Json) -> Optional[float]: ...

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

class Dataflow:
    """A dataflow graph file (docs/dataflow.md) run on a session pass by pass (Session.dataflow)."""

    def step(self) -> Dict[str, Json]:
        """One pass: sources read, the graph fired, sinks written; {versions, raised, cleared}."""
    def reload(self) -> Dict[str, List[str]]:
        """The file parsed again, the graph rewired; {kept, replaced, added, removed} actors."""
    def value(self, name: str) -> Optional[float]:
        """The last value of data node `name`."""
    def state(self) -> Dict[str, Json]:
        """Node values, sinks, alarms, actors with firing counts, passes, writes, errors."""

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
    def model(self, name: str) -> Model:
        """Robot `name` as the session ops use it."""
    def dataflow(self, graph: Union[str, "os.PathLike[str]"], tolerance: float = 1e-9) -> Dataflow:
        """The dataflow graph in file `graph` on this session; RequestError (file:line) if wrong."""
    def plant_command(self, command: Dict[str, Json]) -> Dict[str, Json]:
        """A command to the automation plant: {"cmd": "fault", "fault": NAME} or {"cmd": "get"};
        its state (faults, ringing alarms, units). SessionError if no plant runs or it refuses."""
