"""Tracking metrics of one closed-loop run (one function, reused everywhere).

Errors in rad, torques in N·m, times in s.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike

from .._validation import check_array, check_real
from ..exceptions import ArgumentValueError
from ..paper import PAPER_TRANSIENT

__all__ = ["TrackingMetrics", "tracking_metrics", "METRIC_NAMES", "STATUSES", "TRACKING_TOLERANCE"]

#: The status of a run, one of:
#: ``tracking`` (the integrator finished and max |e| after the transient is within the
#: tolerance), ``not-tracking`` (finished, error above the tolerance), ``diverged`` (the
#: error or the state left its limits and the run stopped), ``failed`` (the integrator or
#: the controller failed) and ``too-short`` (the run ended before the transient was over,
#: so tracking cannot be judged).
STATUSES = ("tracking", "not-tracking", "diverged", "failed", "too-short")

#: Default tolerance (rad) on max |e| after the transient for a run to count as tracking.
#: 0.05 rad (2.9°) is the small initial error of Figure 6 and 2.5 times the paper's 0.02 rad
#: performance bound: a run that tracks ends up well inside it (the paper's PID: 0.022 rad,
#: both sliding-mode laws: 0.007 rad), one that does not is far outside (metres of tip
#: error, or tens of radians). It tells tracking from not tracking; it is not a
#: performance specification, which the metrics give.
TRACKING_TOLERANCE = 0.05


@dataclass(frozen=True)
class TrackingMetrics:
    """Metrics of a run; "after" means ``t >= t_transient``.

    Attributes
    ----------
    max_abs_error : float
        ``max |e_i(t)|`` after the transient, over all joints, rad.
    rms_error : float
        ``sqrt(∫ mean_i e_i² dt / duration)`` after the transient, rad (for the SCARA
        ``(e1² + e2²)/2``).
    peak_torque : float
        ``max |T_ci(t)|`` over the whole run and both joints, N·m.
    max_abs_torque : float
        ``max |T_ci(t)|`` after the transient, N·m.
    chattering_index : float
        Total variation of ``T_c`` after the transient, summed over joints, per second
        (N·m/s), on the sampled signal.
    control_energy : float
        ``∫ ‖T_c‖² dt`` over the whole run, N²·m²·s.
    t_transient : float
        End of the transient, s; it names the keys of :meth:`to_dict`.
    """

    max_abs_error: float
    rms_error: float
    peak_torque: float
    max_abs_torque: float
    chattering_index: float
    control_energy: float
    t_transient: float = PAPER_TRANSIENT

    def to_dict(self) -> dict[str, float]:
        """The metrics keyed by :func:`metric_names` of this run's transient.

        Returns
        -------
        dict of str to float
            ``max_abs_error_after_6s``, ... for the default 6-s transient.
        """
        names = metric_names(self.t_transient)
        values = [getattr(self, f.name) for f in fields(self) if f.name != "t_transient"]
        return dict(zip(names, values))


def metric_names(t_transient: float = PAPER_TRANSIENT) -> tuple[str, ...]:
    """Column names of the metrics for a transient of `t_transient` seconds.

    Parameters
    ----------
    t_transient : float
        End of the transient, s.

    Returns
    -------
    tuple of str
        ``max_abs_error_after_<t>s, rms_error_after_<t>s, peak_torque,
        max_abs_torque_after_<t>s, chattering_index, control_energy``, with ``<t>`` the
        transient formatted by ``'{:g}'`` (``6`` for 6 s, ``2.5`` for 2.5 s).
    """
    after = f"after_{float(t_transient):g}s"
    return (
        f"max_abs_error_{after}",
        f"rms_error_{after}",
        "peak_torque",
        f"max_abs_torque_{after}",
        "chattering_index",
        "control_energy",
    )


#: Metric names at the paper's 6-s transient: the columns of ``compare`` and campaign tables.
METRIC_NAMES = metric_names(PAPER_TRANSIENT)
#: The unit of each metric, in the order of :func:`metric_names` (keyed by :data:`METRIC_NAMES`).
METRIC_UNITS: dict[str, str] = dict(zip(METRIC_NAMES, ("rad", "rad", "N·m", "N·m", "N·m/s", "N²·m²·s")))


def tracking_metrics(
    t: ArrayLike,
    e: ArrayLike,
    torque: ArrayLike,
    *,
    t_transient: float = PAPER_TRANSIENT,
    peak_torque: float | None = None,
) -> TrackingMetrics:
    """Compute :class:`TrackingMetrics` from sampled signals.

    Parameters
    ----------
    t : array_like, shape (k,)
        Increasing sample times, s.
    e : array_like, shape (n, k)
        Joint errors, rad (n joints: 2 for the SCARA).
    torque : array_like, shape (n, k)
        Control torques, N·m.
    t_transient : float
        End of the transient, s (>= 0); at least two samples must follow it.
    peak_torque : float, optional
        The trajectory's peak ``max |T_ci(t)|`` where it is known beyond the samples, N·m
        (see :class:`~scara_robust.SimulationResult`); the metric is the larger of it and
        the sampled peak. NaN or None: the sampled peak.

    Returns
    -------
    TrackingMetrics


    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> t = np.linspace(0, 10, 11)
    >>> m = sr.tracking_metrics(t, np.ones((2, 11)), np.zeros((2, 11)))
    >>> m.max_abs_error, m.rms_error
    (1.0, 1.0)
    """
    t = check_array("t", t, ndim=1)
    e = check_array("e", e, ndim=2)
    if e.shape[1] != t.size or e.shape[0] == 0:
        raise ArgumentValueError("e", f"must have shape (n, {t.size}) (n joints by the samples of t), found {e.shape}")
    torque = check_array("torque", torque, shape=e.shape)
    t0 = check_real("t_transient", t_transient, nonnegative=True)
    if t.size < 2 or np.any(np.diff(t) <= 0):
        raise ArgumentValueError("t", "must be strictly increasing with at least 2 samples")
    after = t >= t0
    if after.sum() < 2:
        found = int(after.sum())
        raise ArgumentValueError("t", f"must have at least 2 samples at or after t_transient={t0} s, found {found}")
    ta, ea, tqa = t[after], e[:, after], torque[:, after]
    duration = ta[-1] - ta[0]
    rms = np.sqrt(np.trapezoid((ea**2).mean(axis=0), ta) / duration)
    return TrackingMetrics(
        max_abs_error=float(np.abs(ea).max()),
        rms_error=float(rms),
        peak_torque=float(np.abs(torque).max()) if peak_torque is None or np.isnan(peak_torque)
        else max(float(peak_torque), float(np.abs(torque).max())),
        max_abs_torque=float(np.abs(tqa).max()),
        chattering_index=float(np.abs(np.diff(tqa, axis=1)).sum() / duration),
        control_energy=float(np.trapezoid((torque**2).sum(axis=0), t)),
        t_transient=t0,
    )


def run_status(
    metrics: TrackingMetrics | None,
    *,
    success: bool,
    diverged: bool,
    message: str,
    tolerance: float = TRACKING_TOLERANCE,
    t_transient: float = PAPER_TRANSIENT,
) -> tuple[str, str]:
    """The status of a run (one of :data:`STATUSES`) and the reason for it.

    Parameters
    ----------
    metrics : TrackingMetrics or None
        The run's metrics, or None when the run ended before the transient was over.
    success, diverged : bool
        How the integration ended.
    message : str
        The integrator's message.
    tolerance : float
        Largest max |e| after the transient (rad) that counts as tracking.
    t_transient : float
        End of the transient, s.

    Returns
    -------
    status : str
    reason : str
    """
    if diverged:
        return "diverged", message
    if not success:
        return "failed", message
    if metrics is None:
        return "too-short", f"the run ends before the {t_transient:g}-s transient is over; tracking is not judged"
    worst = metrics.max_abs_error
    if worst <= tolerance:
        return "tracking", f"max |e| after {t_transient:g} s = {worst:.3g} rad <= {tolerance:g} rad"
    return "not-tracking", f"max |e| after {t_transient:g} s = {worst:.3g} rad > {tolerance:g} rad"
