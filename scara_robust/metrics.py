"""Tracking metrics of one closed-loop run (one function, reused everywhere).

Errors in rad, torques in N·m, times in s.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._validation import check_array, check_real

__all__ = ["TrackingMetrics", "tracking_metrics", "METRIC_NAMES"]


@dataclass(frozen=True)
class TrackingMetrics:
    """Metrics of a run; "after" means ``t >= t_transient``.

    Attributes
    ----------
    max_abs_error_after_6s : float
        ``max |e_i(t)|`` over both joints, rad.
    rms_error_after_6s : float
        ``sqrt(∫ (e1² + e2²)/2 dt / duration)``, rad.
    peak_torque : float
        ``max |T_ci(t)|`` over the whole run and both joints, N·m.
    max_abs_torque_after_6s : float
        Same, after the transient, N·m.
    chattering_index : float
        Total variation of ``T_c`` after the transient, summed over joints, per second
        (N·m/s), on the sampled signal.
    control_energy : float
        ``∫ ‖T_c‖² dt`` over the whole run, N²·m²·s.
    """

    max_abs_error_after_6s: float
    rms_error_after_6s: float
    peak_torque: float
    max_abs_torque_after_6s: float
    chattering_index: float
    control_energy: float

    def to_dict(self) -> dict[str, float]:
        """The metrics as a plain dict."""
        return asdict(self)


METRIC_NAMES = tuple(TrackingMetrics.__dataclass_fields__)


def tracking_metrics(t: ArrayLike, e: ArrayLike, torque: ArrayLike, *, t_transient: float = 6.0) -> TrackingMetrics:
    """Compute :class:`TrackingMetrics` from sampled signals.

    Parameters
    ----------
    t : array_like, shape (k,)
        Increasing sample times, s.
    e : array_like, shape (2, k)
        Joint errors, rad.
    torque : array_like, shape (2, k)
        Control torques, N·m.
    t_transient : float
        End of the transient, s (>= 0); at least two samples must follow it.

    Returns
    -------
    TrackingMetrics


    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> t = np.linspace(0, 10, 11)
    >>> m = sr.tracking_metrics(t, np.ones((2, 11)), np.zeros((2, 11)))
    >>> m.max_abs_error_after_6s, m.rms_error_after_6s
    (1.0, 1.0)
    """
    t = check_array("t", t, ndim=1)
    e = check_array("e", e, shape=(2, t.size))
    torque = check_array("torque", torque, shape=(2, t.size))
    t0 = check_real("t_transient", t_transient, nonnegative=True)
    if t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("`t` must be strictly increasing with at least 2 samples")
    after = t >= t0
    if after.sum() < 2:
        raise ValueError(f"`t` must have at least 2 samples at or after t_transient={t0} s, found {int(after.sum())}")
    ta, ea, tqa = t[after], e[:, after], torque[:, after]
    duration = ta[-1] - ta[0]
    rms = np.sqrt(np.trapezoid(0.5 * (ea**2).sum(axis=0), ta) / duration)
    return TrackingMetrics(
        max_abs_error_after_6s=float(np.abs(ea).max()),
        rms_error_after_6s=float(rms),
        peak_torque=float(np.abs(torque).max()),
        max_abs_torque_after_6s=float(np.abs(tqa).max()),
        chattering_index=float(np.abs(np.diff(tqa, axis=1)).sum() / duration),
        control_energy=float(np.trapezoid((torque**2).sum(axis=0), t)),
    )
