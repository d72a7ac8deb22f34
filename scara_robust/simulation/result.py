"""What every closed-loop run has, under one set of names whatever the system ran.

:class:`Run` is the interface of the three runs (:class:`~scara_robust.SimulationResult` of the
SCARA, :class:`~scara_robust.ArmRun` of an arm, :class:`~scara_robust.PlantRun` of a plant),
as python-control's ``TimeResponseData`` is of every response: code that reads a run reads
``t``, ``e``, ``u``, ``status``, ``reason``, ``max_abs_error``, ``peak_input`` and
``to_pandas()`` on any of them. The kinds keep their own fields beside these (the SCARA's
``torque`` and ``status_reason`` are its ``u`` and ``reason``).
"""

from __future__ import annotations

import math
from typing import Any, Protocol, runtime_checkable

import numpy as np
import pandas as pd
from numpy.typing import NDArray

__all__ = ["Run"]

Array = NDArray[np.float64]


@runtime_checkable
class Run(Protocol):
    """The interface every closed-loop run shares (``isinstance(run, Run)`` holds for each).

    Attributes
    ----------
    t : ndarray, shape (k,)
        Sample times, s.
    e : ndarray, shape (q, k)
        Tracking error ``r − y`` per controlled output, in the outputs' units (rad for a joint).
    u : ndarray, shape (m, k)
        The controller's output applied to the plant, in the inputs' units (N·m for a joint).
    status : str
        One of :data:`scara_robust.STATUSES`.
    reason : str
        Why, in words and numbers.
    max_abs_error : float
        ``max |e|`` after the run's transient over every output; NaN when fewer than two
        samples follow it.
    peak_input : float
        ``max |u|`` over the run and every input.
    """

    @property
    def t(self) -> Array: ...

    @property
    def e(self) -> Array: ...

    @property
    def u(self) -> Array: ...

    @property
    def status(self) -> str: ...

    @property
    def reason(self) -> str: ...

    @property
    def max_abs_error(self) -> float: ...

    @property
    def peak_input(self) -> float: ...

    def to_pandas(self) -> pd.DataFrame:
        """The time series, one column per signal with its unit."""
        ...


def peak(values: Any) -> float:
    """``max |values|`` (NaN for no values)."""
    v = np.asarray(values, dtype=float)
    return float(np.abs(v).max()) if v.size else math.nan
