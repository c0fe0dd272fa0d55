from ._robosim import (
    Dataflow as Dataflow,
    JointLimitError as JointLimitError,
    Model as Model,
    NotApplicableError as NotApplicableError,
    NotConvergedError as NotConvergedError,
    NumericalError as NumericalError,
    RequestError as RequestError,
    RobotError as RobotError,
    ShapeError as ShapeError,
    UnreachableError as UnreachableError,
    collide as collide,
    distance as distance,
    query as query,
    RobosimError as RobosimError,
    Session as Session,
    SessionError as SessionError,
    Sim as Sim,
    Snapshot as Snapshot,
    TransactionError as TransactionError,
)
from .plot import plot as plot

__version__: str
