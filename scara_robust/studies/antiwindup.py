"""Anti-windup evidence: the sampled PID under a torque limit, with and without back-calculation.

Runs the :class:`~scara_robust.DiscretePID` of a design on the nonlinear robot (zero-order
hold, :func:`~scara_robust.sampled_pid_controller`) for each torque limit, with and without
anti-windup, and tabulates the transient. Errors in rad, torques in N·m, times in s.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._deprecation import renamed_argument, renamed_field
from .._validation import check_array, check_instance, check_real
from ..controller.discrete import DiscretePID
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import Design, design
from ..model.scara import paper_model
from ..paper import PAPER_DESIGN_POINT, PAPER_T_FINAL
from ..simulation.controllers import sampled_pid_controller
from ..simulation.metrics import TRACKING_TOLERANCE
from ..simulation.run import SimulationResult, simulate

__all__ = ["AntiWindupStudy", "anti_windup_study"]

#: Columns of :attr:`AntiWindupStudy.table`.
ANTI_WINDUP_COLUMNS = (
    "torque_limit", "anti_windup", "status", "overshoot_e1", "overshoot_e2", "settling_time",
    "max_abs_error_after_transient", "saturated_fraction", "peak_unsaturated_torque",
)


def overshoot(e: np.ndarray) -> np.ndarray:
    """Per joint, the largest error of the sign opposite to the initial error, rad (0 if none).

    Parameters
    ----------
    e : ndarray, shape (p, k)
        Tracking error over time, rad.

    Returns
    -------
    ndarray, shape (p,)
    """
    e = check_array("e", e, ndim=2)
    sign = np.sign(e[:, :1])
    return np.asarray(np.maximum(0.0, (-sign * e).max(axis=1)), dtype=float)


def settling_time(t: np.ndarray, e: np.ndarray, band: float) -> float:
    """The time after which ``max_i |e_i| <= band`` for good, s (NaN if never; 0 if always).

    Parameters
    ----------
    t : ndarray, shape (k,)
        Times, s.
    e : ndarray, shape (p, k)
        Errors, rad.
    band : float
        rad (> 0).

    Returns
    -------
    float
    """
    band = check_real("band", band, positive=True)
    outside = np.flatnonzero(np.abs(e).max(axis=0) > band)
    if outside.size == 0:
        return 0.0
    if outside[-1] + 1 >= t.size:
        return float("nan")
    return float(t[outside[-1] + 1])


@dataclass(frozen=True)
class AntiWindupStudy:
    """Result of :func:`anti_windup_study`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (limit, anti-windup on/off) plus one without limit, columns
        :data:`ANTI_WINDUP_COLUMNS`: overshoots (rad), settling time into the band (s),
        max |e| after the transient (rad), fraction of samples with a joint at its limit,
        the largest torque the PID asked for (N·m).
    runs : dict of str to SimulationResult
        The runs, keyed like ``'limit 50 N·m, anti-windup'``, ``'no limit'``.
    band : float
        Settling band, rad.
    Ts : float
        s.
    """

    table: pd.DataFrame
    runs: dict[str, SimulationResult]
    band: float
    Ts: float

    sample_time = renamed_field("sample_time", "Ts")


def anti_windup_study(
    torque_limits: Sequence[float] = (50.0, 8.0),
    *,
    scenario: str = "large",
    Ts: float = 1e-3,
    pid_design: Design | None = None,
    band: float = TRACKING_TOLERANCE,
    t_final: float = PAPER_T_FINAL,
    sample_time: float | None = None,
) -> AntiWindupStudy:
    """Overshoot, settling time and max |e| after 6 s with and without anti-windup.

    Parameters
    ----------
    torque_limits : sequence of float
        Per-joint limits to try, N·m (> 0).
    scenario : {'large', 'small'}
    Ts : float
        s (> 0).
    pid_design : Design, optional
        Default: (ρ, η) = (3, 90) on the published model.
    band : float
        Settling band on max |e|, rad (default 0.05, the tracking tolerance).
    t_final : float
        Horizon, s.
    sample_time : float, optional
        Deprecated name of `Ts`.

    Returns
    -------
    AntiWindupStudy

    Examples
    --------
    >>> import scara_robust as sr
    >>> study = sr.anti_windup_study([20.0], t_final=7.0)
    >>> list(study.table["anti_windup"])
    [None, False, True]
    """
    Ts = renamed_argument("anti_windup_study", "sample_time", "Ts", sample_time, Ts, 1e-3)
    limits = check_array("torque_limits", torque_limits, ndim=1)
    if limits.size == 0 or np.any(limits <= 0):
        raise ArgumentValueError("torque_limits", f"must be one or more limits > 0 N·m, found {limits.tolist()}")
    d = pid_design if pid_design is not None else design(paper_model(), *PAPER_DESIGN_POINT)
    check_instance("pid_design", d, Design, "a Design")
    band = check_real("band", band, positive=True)
    cases: list[tuple[str, float | None, bool | None]] = [("no limit", None, None)]
    for lim in limits:
        cases += [(f"limit {lim:g} N·m, no anti-windup", float(lim), False),
                  (f"limit {lim:g} N·m, anti-windup", float(lim), True)]
    runs: dict[str, SimulationResult] = {}
    rows = []
    for key, lim, aw in cases:
        pid = d.discretize(Ts, torque_limit=lim, anti_windup=bool(aw) if aw is not None else True)
        res = simulate(sampled_pid_controller(pid), scenario, t_final=t_final)
        runs[key] = res
        # the unsaturated torque the PID asked for, replayed from the recorded errors
        asked = np.array([pid.output(z, y)[1] for z, y in _replay(pid, res)])
        over = overshoot(res.e)
        saturated = 0.0 if lim is None else float((np.abs(res.torque) >= lim * (1 - 1e-12)).any(axis=0).mean())
        rows.append({
            "torque_limit": lim, "anti_windup": aw, "status": res.status,
            "overshoot_e1": over[0], "overshoot_e2": over[1],
            "settling_time": settling_time(res.t, res.e, band),
            "max_abs_error_after_transient": res.metrics().max_abs_error if res.has_metrics else float("nan"),
            "saturated_fraction": saturated,
            "peak_unsaturated_torque": float(np.abs(asked).max()),
        })
    return AntiWindupStudy(pd.DataFrame(rows, columns=list(ANTI_WINDUP_COLUMNS)), runs, band, Ts)


def _replay(pid: DiscretePID, res: SimulationResult) -> Iterator[tuple[list[float], list[float]]]:
    """(state, input) at each sample of a recorded run, stepping `pid` along it."""
    start = pid.initial_state()
    z = [float(v) for v in start]
    for k in range(res.t.size):
        y = [float(v) for v in np.concatenate([res.e[:, k], res.edot[:, k]])]
        yield z, y
        u, v = pid.output(z, y)
        z = pid.update(z, y, u, v)

