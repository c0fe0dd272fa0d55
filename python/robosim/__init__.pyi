from ._robosim import (
    JointLimitError as JointLimitError,
    RobosimError as RobosimError,
    Session as Session,
    SessionError as SessionError,
    Sim as Sim,
    Snapshot as Snapshot,
    TransactionError as TransactionError,
)
from .plot import plot as plot

__version__: str
