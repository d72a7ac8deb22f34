"""A certificate for a jittering period: every sample period in ``[Ts − J, Ts + J]``, in any order.

ros2_control's ``pid_controller`` integrates over the measured period, which jitters, while the
sampled-data certificate assumes an exact Ts. With the period ``h_k`` of sample k anywhere in
``[Ts − J, Ts + J]``, the loop is ``ξ_{k+1} = A_d(h_k) ξ_k``: the plant held over ``h_k`` and the
controller run with that period (:meth:`DiscretePID.linear_at`, its integrator scaled by ``h_k``
as control_toolbox's is). One common ``P`` with ``A_d(h)ᵀ P A_d(h) − P ≺ 0`` for every h of the
interval and every plant certifies every sequence of periods. The LMI is solved on a grid of
periods (:data:`JITTER_PERIODS`) and the P verified with numpy on a finer one
(:data:`JITTER_CHECK_PERIODS`, the ends included); between its grid points the certificate rests
on that grid, as between the plant samples it rests on theirs.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import check_int, check_real
from ..controller.kinds import check_controller
from ..exceptions import ArgumentValueError
from ..results import AnalysisResult
from ..sdp.backends import resolve_lmi_solver
from .lmi import cvxpy_available, decay_floor
from .sampled import (
    _plants,
    _restrict,
    _solve_lmi,
    _without_marginal,
    discrete_lyapunov_check,
    sampled_closed_loops,
)

__all__ = ["JitterCertificate", "jitter_certificate", "max_jitter", "JITTER_PERIODS", "JITTER_CHECK_PERIODS"]

Array = NDArray[np.float64]

#: Periods of the LMI over ``[Ts − J, Ts + J]``, ends included.
JITTER_PERIODS = 5
#: Periods on which numpy verifies the P, ends included.
JITTER_CHECK_PERIODS = 41


@dataclass(frozen=True)
class JitterCertificate(AnalysisResult):
    """The sampled-data certificate over an interval of periods (:func:`jitter_certificate`).

    Attributes
    ----------
    Ts, jitter : float
        s: the periods ``[Ts − jitter, Ts + jitter]``.
    status : str
        The solver's status.
    P : ndarray or None
        The common Lyapunov matrix of the sampled loop's state.
    rate : float
        The smallest decay rate α (1/s) numpy verifies over the checked periods and plants;
        ``-inf`` when P does not verify.
    spectral_radius : float
        The largest of the frozen loops at the checked periods.
    n_plants, n_periods : int
        Plants and checked periods.
    floor : float
        The decay rate below which a verified decrease is not told from rounding, 1/s.
    seconds : float
    """

    Ts: float
    jitter: float
    status: str
    P: Array | None
    rate: float
    spectral_radius: float
    n_plants: int
    n_periods: int
    floor: float
    seconds: float

    units = {"Ts": "s", "jitter": "s", "rate": "1/s", "seconds": "s"}

    @property
    def certified(self) -> bool:
        """numpy verified the common P at every checked period, above the rounding floor."""
        return bool(self.P is not None and self.rate > 0 and self.rate >= self.floor)

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not certified'``."""
        return "certified" if self.certified else "not certified"

    @property
    def message(self) -> str:
        """One sentence."""
        span = (f"every period in [{self.Ts - self.jitter:.6g}, {self.Ts + self.jitter:.6g}] s (Ts = {self.Ts:g} s ± "
                f"{self.jitter:.3g} s)")
        if self.certified:
            return (f"{span} certified, in any order: a common P verified with numpy on {self.n_plants} plants at "
                    f"{self.n_periods} periods, decay rate α >= {self.rate:.4g} 1/s")
        if self.spectral_radius >= 1:
            return f"{span} not certified: a frozen loop is unstable (spectral radius {self.spectral_radius:.4g})"
        return f"{span} not certified: no common P verified ({self.status})"

    def record(self) -> dict[str, Any]:
        """JSON-ready: ``certified``, ``Ts``, ``jitter`` (s), ``periods`` [lo, hi] (s), ``decay_rate``, ``message``."""
        return {"certified": self.certified, "Ts": self.Ts, "jitter": self.jitter,
                "periods": [self.Ts - self.jitter, self.Ts + self.jitter],
                "decay_rate": self.rate if math.isfinite(self.rate) else None, "n_plants": self.n_plants,
                "n_periods": self.n_periods, "message": self.message}


def _loops(A: Array, B: Array, controller: Any, periods: Array, keep: Any) -> list[Array]:
    return [_restrict(sampled_closed_loops(A, B, controller.linear_at(float(h))), keep) for h in periods]


def jitter_certificate(
    model: Any,
    controller: Any,
    jitter: float,
    *,
    check: Any = None,
    periods: int = JITTER_PERIODS,
    check_periods: int = JITTER_CHECK_PERIODS,
    solver: str | None = None,
) -> JitterCertificate:
    """The sampled-data certificate of `controller` for every period in ``[Ts − jitter, Ts + jitter]``.

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel, PhysicalSamples or tuple (A, B)
        The plants (the PID form for a PID), as :func:`sampled_certificate` takes them.
    controller : DiscretePID or SampledStateFeedback
        At its nominal Ts.
    jitter : float
        s, ``0 <= jitter < Ts``.
    check : optional
        Plants on which P must also verify.
    periods, check_periods : int
        Periods of the LMI and of numpy's check over the interval (>= 2, ends included).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    JitterCertificate
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    check_controller("controller", controller, ("pid", "state feedback"),
                     "a DiscretePID (Design.discretize) or a SampledStateFeedback")
    Ts = float(controller.Ts)
    jitter = check_real("jitter", jitter, nonnegative=True)
    if not jitter < Ts:
        raise ArgumentValueError("jitter", f"must be below Ts = {Ts:g} s (a period stays > 0), found {jitter:g} s")
    periods = check_int("periods", periods, 2)
    check_periods = check_int("check_periods", check_periods, 2)
    A, B = _plants(model)
    nominal, keep = _without_marginal(sampled_closed_loops(A, B, controller.linear_at(Ts)))
    solve_at = np.linspace(Ts - jitter, Ts + jitter, periods) if jitter > 0 else np.array([Ts])
    verify_at = np.linspace(Ts - jitter, Ts + jitter, check_periods) if jitter > 0 else np.array([Ts])
    verify = _loops(A, B, controller, verify_at, keep)
    if check is not None:
        Ac, Bc = _plants(check)
        verify = [np.concatenate([v, w]) for v, w in zip(verify, _loops(Ac, Bc, controller, verify_at, keep))]
    radius = max(float(np.abs(np.linalg.eigvals(v)).max()) for v in verify)
    floor = decay_floor((nominal - np.eye(nominal.shape[1])) / Ts)
    n_plants = int(verify[0].shape[0])
    if radius >= 1.0 or not cvxpy_available():
        status = "skipped" if radius >= 1.0 else "cvxpy not installed"
        return JitterCertificate(Ts, jitter, status, None, -math.inf, radius, n_plants, verify_at.size, floor,
                                 time.perf_counter() - start)
    stack = np.concatenate(_loops(A, B, controller, solve_at, keep))
    status, P = _solve_lmi(stack, Ts, solver)
    rate = -math.inf
    if P is not None:
        rate = min(discrete_lyapunov_check(v, P, float(h))[1] for v, h in zip(verify, verify_at))
    return JitterCertificate(Ts, jitter, status, P, float(rate), radius, n_plants, verify_at.size, floor,
                             time.perf_counter() - start)


def max_jitter(model: Any, controller: Any, *, check: Any = None, rtol: float = 0.02,
               solver: str | None = None) -> tuple[float, float, JitterCertificate | None]:
    """The largest jitter J certified by :func:`jitter_certificate`, by bisection on ``[0, 0.99 Ts]``.

    Parameters
    ----------
    model, controller, check, solver
        As :func:`jitter_certificate`.
    rtol : float
        Relative width of the final bracket.

    Returns
    -------
    certified : float
        The largest J certified (s); -inf when not even J = 0 is.
    not_certified : float
        The smallest J found not certified (s; inf when 0.99 Ts is certified).
    certificate : JitterCertificate or None
        At the certified J.
    """
    solver = resolve_lmi_solver(solver)
    rtol = check_real("rtol", rtol, positive=True)
    Ts = float(controller.Ts)
    best = jitter_certificate(model, controller, 0.0, check=check, solver=solver)
    if not best.certified:
        return -math.inf, 0.0, None
    top = jitter_certificate(model, controller, 0.99 * Ts, check=check, solver=solver)
    if top.certified:
        return 0.99 * Ts, math.inf, top
    lo, hi = 0.0, 0.99 * Ts
    while hi - lo > rtol * max(hi, 1e-12):
        mid = 0.5 * (lo + hi)
        cert = jitter_certificate(model, controller, mid, check=check, solver=solver)
        if cert.certified:
            lo, best = mid, cert
        else:
            hi = mid
    return lo, hi, best
