"""Rate-bounded stability: a parameter-dependent Lyapunov function ``V = xᵀ(P₀ + pP₁)x``.

The common-P test (:func:`scara_robust.lmi_certificate`) proves stability for parameters
that may jump arbitrarily fast. Real parameters (a payload mass) change at a bounded rate
``|ṗ| <= ν``; a Lyapunov matrix that follows the parameter, ``P(p) = P₀ + pP₁``, then
proves more. Along a trajectory ``V̇ = xᵀ(Ā(p)ᵀP(p) + P(p)Ā(p) + ṗP₁)x``, affine in ṗ, so
(Gahinet, Apkarian and Chilali, "Affine parameter-dependent Lyapunov functions and real
parametric uncertainty", IEEE TAC 41(3), 1996; the idea of MATLAB's ``pvec`` rates and
``pdlstab``)::

    P(p_i) ≻ 0,   Ā_iᵀP(p_i) + P(p_i)Ā_i ± νP₁ ≺ 0      at every sample (p_i, Ā_i)

are what ``V`` needs to decay along every variation with ``|ṗ| <= ν``, the other sampled
directions (for the robot: the reference phase) varying arbitrarily within the hull of the
samples that share a p. Held at every p of the range they prove it; for samples of a
dependence that is not affine in p they are a gridding condition (like MATLAB's gridded
LPV ``pdlstab``): checked at the samples and re-verified with numpy on a finer,
independent grid. When the dependence is affine, ``Ā(p) = Ā₀ + pĀ₁``, the left-hand side
is quadratic in p with curvature ``2(Ā₁ᵀP₁ + P₁Ā₁)``; the multi-convexity condition::

    Ā₁ᵀP₁ + P₁Ā₁ ⪰ 0

makes it convex along p, so the conditions at the two end points hold on the whole
interval (Gahinet et al. 1996). With ``ν → ∞`` the inequalities force
``P₁ = 0``: the common-P test, requested here by ``rate=inf``. Feasibility is monotone in
ν (the conditions at ±ν imply those at any smaller rate, a convex combination of them),
so the largest certified rate is found by bisection (:func:`max_certified_rate`).
Evidence from the other side, for the robot: :func:`payload_switching_growth` measures the
growth of the linearized loop under a periodic payload ramping at a given rate.

Every answer is re-verified with numpy eigenvalues on the samples and, when given, on an
independent check set; an answer numpy cannot verify, or one the solver calls
``'optimal_inaccurate'``, is reported as such and never as certified. cvxpy + Clarabel
(extra ``lmi``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_field
from .._validation import check_array, check_closed_loops, check_real
from ..exceptions import ArgumentValueError
from ..results import AnalysisResult, VerdictFromCertified, verdict_of
from ..sdp import LMIProblem, LMIVariable, solve_lmi_interior
from ..sdp.backends import resolve_lmi_solver
from .lmi import DECAY_FLOOR_RTOL, NOT_INSTALLED, cvxpy_available, decay_floor
from .search import bisect

__all__ = ["RateCertificate", "RateMargin", "rate_bounded_certificate", "verify_rate_bounded", "max_certified_rate"]

Array = NDArray[np.float64]

#: The LMI maximizes t with ``tI ⪯ P(p_i) ⪯ I`` and ``Ā_iᵀP_i + P_iĀ_i ± νP1 ⪯ −tI`` (in
#: normalized units); an optimal t at or below this counts as infeasible (no strict solution).
FEASIBILITY_TOL = 1e-9


@dataclass(frozen=True)
class RateCertificate(AnalysisResult):
    """Result of the rate-bounded parameter-dependent test, verified independently.

    Attributes
    ----------
    status : str
        ``'certified'`` (numpy verified every condition), ``'infeasible'``, ``'not verified'``
        (the solver's answer fails numpy's check), ``'optimal_inaccurate'`` (never
        certified, whatever numpy says), another solver status, or ``'not installed'``.
    P0, P1 : ndarray, shape (n, n), or None
        ``P(p) = P0 + p·P1``; P1 is in 1/(unit of p) relative to P0 (1/kg for the robot).
        ``P1`` is zero for ``rate=inf`` (the common-P test).
    rate : float
        The rate bound ν tested, in units of p per second (kg/s for the robot); ``inf`` for
        the common-P test.
    decay_rate : float
        numpy's verified decay rate on the samples, 1/s:
        ``min_i −λmax(Ā_iᵀP_i + P_iĀ_i ± νP1) / (2 λmax(P_i))``: the state's decay rate α
        (``V̇ <= −2αV``, the package's one convention); ``-inf``
        when some ``P(p_i)`` is not positive definite, NaN without P. Positive means verified.
        With `slopes` (an affine dependence), the decay rate on the whole interval of p
        instead: the end points' worst λmax, plus ``max(0, −convexity)·((p_max − p_min)/2)²``
        for a curvature deficit, over their largest ``λmax(P)``.
    check_decay_rate : float
        The same on the independent check set (NaN when none was given), 1/s.
    convexity : float
        ``min_i λmin(Ā₁ᵀP1 + P1Ā₁)`` over the given slopes (NaN when the dependence was not
        declared affine); it must be >= 0 up to rounding.
    n_samples, n_checked : int
        Sizes of the sample set and of the check set.
    solver_status : str
        What the solver said.
    seconds : float
    """

    status: str
    P0: Array | None
    P1: Array | None
    rate: float
    decay_rate: float
    check_decay_rate: float
    convexity: float
    n_samples: int
    n_checked: int
    solver_status: str
    seconds: float
    floor: float = 0.0

    margin = renamed_field("margin", "decay_rate")
    check_margin = renamed_field("check_margin", "check_decay_rate")

    @property
    def verdict(self) -> str:
        """``'certified'``, ``'infeasible'``, ``'not installed'`` or ``'unknown'``."""
        if self.certified:
            return "certified"
        return self.status if self.status in ("infeasible", NOT_INSTALLED) else "unknown"

    @property
    def certified(self) -> bool:
        """numpy verified the conditions on the samples and, if given, on the check set."""
        checked = math.isnan(self.check_decay_rate) or self.check_decay_rate > 0
        return bool(self.status == "certified" and self.decay_rate > 0 and self.decay_rate >= self.floor and checked)

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        what = "a common P" if math.isinf(self.rate) else f"P(p) = P0 + p·P1 for |ṗ| <= {self.rate:.6g}"
        if self.status == NOT_INSTALLED:
            return "cvxpy is not installed (pip install '.[lmi]')"
        if self.certified:
            extra = "" if math.isnan(self.check_decay_rate) else (
                f"; on {self.n_checked} independent samples the decay rate α >= {self.check_decay_rate:.4g} 1/s")
            return (f"{what} found; numpy verifies a decay rate α >= {self.decay_rate:.4g} 1/s (V̇ <= −2αV) on the "
                    f"{self.n_samples} samples{extra}")
        if self.status == "infeasible":
            return f"no {what.removeprefix('a ')} exists on the {self.n_samples} samples (infeasible)"
        if self.status == "marginal":
            checked = self.check_decay_rate if not math.isnan(self.check_decay_rate) else math.inf
            return (f"{what}: marginal, not certified: numpy verifies a decay rate of only "
                    f"{min(self.decay_rate, checked):.3g} "
                    f"1/s, below the floor {self.floor:.3g} 1/s ({DECAY_FLOOR_RTOL:g} of the loops' norm)")
        if self.P0 is not None:
            return (f"the solver returned {what} ({self.solver_status}) that is not certified: numpy margin "
                    f"{self.decay_rate:.4g} 1/s on the samples, {self.check_decay_rate:.4g} on the check set")
        return f"no answer for {what}: {self.status}"


def _rate(rate: float) -> float:
    """ν >= 0 or ``inf``, else raise naming `rate`."""
    if isinstance(rate, (float, np.floating)) and rate == math.inf:
        return math.inf
    return check_real("rate", rate, nonnegative=True)


def _samples(name: str, closed_loops: ArrayLike, p: ArrayLike) -> tuple[Array, Array]:
    A = check_closed_loops(name, closed_loops)
    p_name = "p" if name == "closed_loops" else f"{name.split('[')[0]}[1]"
    p_arr = check_array(p_name, p, ndim=1)
    if p_arr.shape[0] != A.shape[0]:
        raise ArgumentValueError(p_name, f"must hold one value per sample ({A.shape[0]}), found {p_arr.shape[0]}")
    return A, p_arr


def verify_rate_bounded(closed_loops: ArrayLike, p: ArrayLike, P0: ArrayLike, P1: ArrayLike, rate: float) -> float:
    """numpy's check of ``P(p) = P0 + p·P1`` on samples, for ``|ṗ| <= rate``.

    Parameters
    ----------
    closed_loops : array_like, shape (N, n, n)
        Frozen closed loops Ā_i.
    p : array_like, shape (N,)
        The scheduling parameter of each sample.
    P0, P1 : array_like, shape (n, n)
        Symmetric matrices.
    rate : float
        ν >= 0, units of p per second; ``inf`` checks ``P0`` alone as a common P (P1 must be 0).

    Returns
    -------
    float
        ``min_i −λmax(Ā_iᵀP_i + P_iĀ_i ± νP1) / (2 λmax(P_i))``, 1/s, with ``P_i = P(p_i)``:
        the state's decay rate α on the samples (``V̇ <= −2αV``). ``-inf`` when some P_i is not
        positive definite, or P0 or P1 is not symmetric.
    """
    A, p_arr = _samples("closed_loops", closed_loops, p)
    n = A.shape[1]
    P0 = check_array("P0", P0, shape=(n, n))
    P1 = check_array("P1", P1, shape=(n, n))
    nu = _rate(rate)
    scale = max(float(np.abs(P0).max()), float(np.abs(P1).max() * np.abs(p_arr).max()), 1e-300)
    for M in (P0, P1):
        if not np.allclose(M, M.T, rtol=0.0, atol=1e-9 * scale):
            return -math.inf
    if math.isinf(nu):
        if np.abs(P1).max() > 0:
            return -math.inf
        nu = 0.0
    P = P0[None] + p_arr[:, None, None] * P1[None]
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    eig_P = np.linalg.eigvalsh(P)
    if eig_P[:, 0].min() <= 0:
        return -math.inf
    L = np.swapaxes(A, -1, -2) @ P + P @ A
    worst = np.full(A.shape[0], -np.inf)
    for sign in (1.0, -1.0):
        M = L + sign * nu * P1[None]
        worst = np.maximum(worst, np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, -1, -2)))[:, -1])
    return float((-worst / (2 * eig_P[:, -1])).min())


def _bent_margin(A: Array, p: Array, P0: Array, P1: Array, nu: float, deficit: float) -> float:
    """The decay rate of V on the whole interval from its end points, for an affine dependence.

    ``xᵀ(Ā(p)ᵀP(p) + P(p)Ā(p) ± νP1)x`` is quadratic in p with second derivative
    ``2xᵀ(Ā₁ᵀP1 + P1Ā₁)x >= −2·deficit·‖x‖²``, so between the end points it exceeds their
    larger value by at most ``deficit·((p_max − p_min)/2)²·‖x‖²`` (nothing when multi-convex).
    """
    P = P0[None] + p[:, None, None] * P1[None]
    eig_P = np.linalg.eigvalsh(0.5 * (P + np.swapaxes(P, -1, -2)))
    if eig_P[:, 0].min() <= 0:
        return -math.inf
    L = np.swapaxes(A, -1, -2) @ P + P @ A
    bend = deficit * (0.5 * (p.max() - p.min())) ** 2
    worst = np.full(A.shape[0], -np.inf)
    for sign in (1.0, -1.0):
        M = L + sign * (0.0 if math.isinf(nu) else nu) * P1[None]
        worst = np.maximum(worst, np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, -1, -2)))[:, -1])
    # between the end points λmax(P(p)) is at most its largest end value (P is affine)
    return float(-(worst.max() + bend) / (2 * eig_P[:, -1].max()))


def _balancing(A: Array) -> Array:
    """``T`` with ``TᵀPT = I`` for the Lyapunov matrix P of a Hurwitz A (identity otherwise)."""
    n = A.shape[0]
    if np.linalg.eigvals(A).real.max() >= 0:
        return np.eye(n)
    P = scipy.linalg.solve_continuous_lyapunov(A.T, -np.eye(n))
    w, V = np.linalg.eigh(0.5 * (P + P.T))
    if w[0] <= 0:
        return np.eye(n)
    return np.asarray(V @ np.diag(w**-0.5) @ V.T, dtype=float)


def _solve(A: Array, p: Array, nu: float, slopes: Array | None, solver: str) -> tuple[str, Array | None, Array | None]:
    """Maximize t: tI ⪯ P(p̂_i) ⪯ I, L_i ± ν̂P̂1 ⪯ −tI, in normalized units (p̂ ∈ [−1, 1], balanced Ā/scale)."""
    centre = 0.5 * (p.max() + p.min())
    half = 0.5 * (p.max() - p.min()) or 1.0
    # A change of state coordinates x = T z leaves feasibility unchanged; T from the
    # Lyapunov matrix of the sample nearest the centre evens out the states' scales.
    T = _balancing(A[int(np.argmin(np.abs(p - centre)))])
    T_inv = np.asarray(np.linalg.inv(T), dtype=float)
    A_t = T_inv @ A @ T
    # time unit: the geometric mean of the fastest and slowest decay of that sample, so that
    # neither the fast nor the slow modes' margins sit near the solver's tolerances
    decays = np.abs(np.linalg.eigvals(A_t[int(np.argmin(np.abs(p - centre)))]).real)
    scale = float(np.sqrt(decays.max() * decays.min())) or float(np.abs(A_t).max()) or 1.0
    A_s = A_t / scale
    q = (p - centre) / half
    nu_s = nu / (half * scale) if math.isfinite(nu) else 0.0
    status, Q0, Q1 = _solve_description(A_s, q, math.inf if math.isinf(nu) else nu_s, None if slopes is None else
                                        np.unique(T_inv @ slopes @ T * half / scale, axis=0), solver)
    if Q0 is None or Q1 is None:
        return status, None, None
    return (status, *_back(Q0, Q1, T_inv, centre, half))


def _back(Q0: Array, Q1: Array, T_inv: Array, centre: float, half: float) -> tuple[Array, Array]:
    """(P0, P1) in the caller's state and p from the normalized solution (Q0, Q1)."""
    # back to x: P = T⁻ᵀ Q T⁻¹; back to the caller's p: P(p) = Q0 + (p − centre)/half · Q1
    P1 = T_inv.T @ Q1 @ T_inv / half
    P0 = T_inv.T @ Q0 @ T_inv - centre * P1
    return 0.5 * (P0 + P0.T), 0.5 * (P1 + P1.T)


def pdl_problem(A_s: Array, q: Array, nu_s: float,
                slopes: Array | None = None) -> tuple[LMIProblem, LMIVariable, LMIVariable | None, LMIVariable]:
    """The rate-bounded LMI of :func:`_solve` for the package's solver (normalized units).

    ``maximize t: tI ⪯ Q0 + q Q1 ⪯ I`` at every distinct q, ``−(A_iᵀP_i + P_iA_i ± ν Q1) ⪰ tI``
    with ``P_i = Q0 + q_i Q1`` at every sample, and ``S̃ᵀQ1 + Q1S̃ ⪰ 0`` for every slope; with
    ``nu_s = 0`` and an infinite rate, Q1 is absent (the common P). Strictly feasible for
    any data (t → −∞); t* > 0 exactly when the strict conditions hold.

    Parameters
    ----------
    A_s : ndarray, shape (V, n, n)
    q : ndarray, shape (V,)
        The samples' parameter in [−1, 1].
    nu_s : float
        The rate in normalized units; ``math.inf`` for the common P (no Q1).
    slopes : ndarray, shape (k, n, n), optional

    Returns
    -------
    problem : LMIProblem
    Q0, Q1, t : LMIVariable
        Q1 is None for an infinite rate.
    """
    n = A_s.shape[1]
    eye = np.eye(n)
    problem = LMIProblem()
    Q0 = problem.symmetric("Q0", n)
    Q1 = None if math.isinf(nu_s) else problem.symmetric("Q1", n)
    t = problem.scalar("t")
    values = np.unique(q)
    level = values[:, None, None] * eye
    def both(sign: float) -> list[tuple[LMIVariable, Array, Array]]:
        return ([(Q0, sign * 0.5 * np.broadcast_to(eye, level.shape), eye)]
                + ([] if Q1 is None else [(Q1, sign * 0.5 * level, eye)]))

    problem.add_lmi(terms=both(1.0), scalars=[(t, -eye)], name="P(q) >= tI")
    problem.add_lmi(terms=both(-1.0), const=eye, name="P(q) <= I")
    signs = (0.0,) if Q1 is None else (1.0, -1.0)
    for sign in signs:
        terms = [(Q0, -np.broadcast_to(eye, A_s.shape), A_s)]
        if Q1 is not None:
            terms += [(Q1, -q[:, None, None] * eye, A_s), (Q1, -0.5 * sign * nu_s * eye, eye)]
        problem.add_lmi(terms=terms, scalars=[(t, -eye)], name=f"decay, rate {sign:+g}")
    if slopes is not None and Q1 is not None:
        problem.add_lmi(terms=[(Q1, np.broadcast_to(eye, slopes.shape), slopes)], name="multi-convexity")
    problem.maximize({t: 1.0})
    return problem, Q0, Q1, t


def _solve_description(A_s: Array, q: Array, nu_s: float, slopes: Array | None,
                       solver: str) -> tuple[str, Array | None, Array | None]:
    """:func:`pdl_problem` by `solver`: (status, Q0, Q1) in normalized units, or None."""
    problem, Q0, Q1, t = pdl_problem(A_s, q, nu_s, slopes)
    result = solve_lmi_interior(problem, t, floor=FEASIBILITY_TOL, solver=solver)
    if result.y is None:
        return result.status, None, None
    if result.value(t) <= FEASIBILITY_TOL:
        return ("infeasible" if result.status == "optimal" else result.status), None, None
    Q0_value = result.value(Q0)
    return result.status, Q0_value, np.zeros_like(Q0_value) if Q1 is None else result.value(Q1)


def rate_bounded_certificate(
    closed_loops: ArrayLike,
    p: ArrayLike,
    rate: float,
    *,
    slopes: ArrayLike | None = None,
    check: tuple[ArrayLike, ArrayLike] | None = None,
    solver: str | None = None,
) -> RateCertificate:
    """Search ``P(p) = P0 + p·P1`` proving stability for ``|ṗ| <= rate``.

    Parameters
    ----------
    closed_loops : array_like, shape (N, n, n)
        Frozen closed loops Ā_i, flat: samples sharing a value of p (for the robot, the
        reference phases at one mass) span the direction that may vary arbitrarily.
    p : array_like, shape (N,)
        The scheduling parameter of each sample (kg for the robot's payload).
    rate : float
        ν >= 0, the bound on ``|ṗ|`` in units of p per second; ``inf`` asks for a common P
        (``P1 = 0``), the test of :func:`scara_robust.lmi_certificate`.
    slopes : array_like, shape (N, n, n), optional
        ``dĀ/dp`` at each sample, declaring the dependence affine in p
        (``Ā(p) = Ā₀ + pĀ₁``, one Ā₁ per arbitrarily varying direction). The
        multi-convexity condition ``Ā₁ᵀP1 + P1Ā₁ ⪰ 0`` is added, so samples at the two end
        points of p prove the whole interval.
    check : tuple (closed_loops, p), optional
        An independent set, shapes (M, n, n) and (M,), on which numpy re-verifies the answer
        (a finer grid of p and of the other directions).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    RateCertificate
        Never raises for an infeasible or inaccurate problem: those are results.

    Raises
    ------
    ArgumentValueError
        For a bad shape, a negative rate, or an unknown solver (naming the argument).

    See Also
    --------
    parameter_rate : the largest certified rate.
    max_certified_rate : the same for an interval model.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> p = np.linspace(1.0, 4.0, 7)
    >>> A = np.array([[[-0.1, 1.0], [-x, -0.1]] for x in p])  # frozen stable for every p
    >>> sr.rate_bounded_certificate(A, p, np.inf).certified  # no common P
    False
    >>> sr.rate_bounded_certificate(A, p, 0.2).certified
    True
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    A, p_arr = _samples("closed_loops", closed_loops, p)
    n = A.shape[1]
    nu = _rate(rate)
    slope_arr = None
    if slopes is not None:
        slope_arr = check_array("slopes", slopes, shape=(A.shape[0], n, n))
    A_chk = p_chk = None
    if check is not None:
        if not isinstance(check, tuple) or len(check) != 2:
            raise ArgumentValueError("check", "must be a tuple (closed_loops, p)")
        A_chk, p_chk = _samples("check[0]", check[0], check[1])
        if A_chk.shape[1:] != A.shape[1:]:
            raise ArgumentValueError("check[0]", f"must hold {n}x{n} matrices like `closed_loops`, found {A_chk.shape}")
    n_chk = 0 if A_chk is None else int(A_chk.shape[0])
    if not cvxpy_available():
        return RateCertificate(NOT_INSTALLED, None, None, nu, math.nan, math.nan, math.nan, A.shape[0], n_chk,
                               NOT_INSTALLED, time.perf_counter() - start)
    solver_status, P0, P1 = _solve(A, p_arr, nu, slope_arr, solver)
    if P0 is None or P1 is None:
        return RateCertificate(solver_status, None, None, nu, math.nan, math.nan, math.nan, A.shape[0], n_chk,
                               solver_status, time.perf_counter() - start)
    margin = verify_rate_bounded(A, p_arr, P0, P1, nu)
    checked = math.nan if A_chk is None or p_chk is None else verify_rate_bounded(A_chk, p_chk, P0, P1, nu)
    convexity = math.nan
    if slope_arr is not None:
        C = np.swapaxes(slope_arr, -1, -2) @ P1 + P1 @ slope_arr
        convexity = float(np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))[:, 0].min())
        margin = _bent_margin(A, p_arr, P0, P1, nu, max(0.0, -convexity))
    floor = decay_floor(A)
    verified = margin > 0 and (math.isnan(checked) or checked > 0)
    above = margin >= floor and (math.isnan(checked) or checked >= floor)
    status = solver_status
    if solver_status == "optimal":
        status = ("certified" if above else "marginal") if verified else "not verified"
    return RateCertificate(status, P0, P1, nu, margin, checked, convexity, A.shape[0], n_chk, solver_status,
                           time.perf_counter() - start, floor)


@dataclass(frozen=True)
class RateMargin(VerdictFromCertified, AnalysisResult):
    """The largest rate ``|ṗ|`` the parameter-dependent test certifies.

    Attributes
    ----------
    rate : float
        Largest ν certified (units of p per second; kg/s for the robot): ``inf`` when a
        common P exists, NaN when not even ν = 0 is certified.
    bracket : tuple of float
        ``(certified, not certified)`` rates of the bisection; ``(inf, inf)`` with a common
        P, ``(nan, 0)`` when ν = 0 fails.
    certificate : RateCertificate or None
        The verified certificate at ``rate`` (None when none was found).
    common : RateCertificate
        The common-P test (``rate=inf``) on the same samples.
    n_solves : int
        LMIs solved.
    seconds : float
    """

    rate: float
    bracket: tuple[float, float]
    certificate: RateCertificate | None
    common: RateCertificate
    n_solves: int
    seconds: float

    @property
    def certified(self) -> bool | None:
        """True when a rate is certified (ν >= 0 or any rate), else None."""
        return None if math.isnan(self.rate) else True

    @property
    def verdict(self) -> str:
        """``'certified'``, ``'not installed'`` or ``'unknown'``."""
        return NOT_INSTALLED if self.common.status == NOT_INSTALLED else verdict_of(self.certified)

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.common.status == NOT_INSTALLED:
            return self.common.message
        if math.isinf(self.rate):
            return "a common P exists: any rate of variation is certified"
        if math.isnan(self.rate):
            return "not certified even for a frozen parameter (ν = 0) with an affine P(p)"
        return (f"common P: {self.common.status}; P(p) = P0 + p·P1 certifies |ṗ| <= {self.rate:.6g} "
                f"(bracket [{self.bracket[0]:.6g}, {self.bracket[1]:.6g}])")


def max_certified_rate(
    closed_loops: ArrayLike,
    p: ArrayLike,
    *,
    slopes: ArrayLike | None = None,
    check: tuple[ArrayLike, ArrayLike] | None = None,
    rate_max: float = 1e6,
    tol: float = 1e-2,
    solver: str | None = None,
) -> RateMargin:
    """Bisect the largest rate bound ν that :func:`rate_bounded_certificate` certifies.

    The common-P test (``rate=inf``) runs first: when it certifies, the answer is ``inf``.
    Otherwise ν = 0 (frozen parameter with an affine P(p)), then doubling from 1 until a rate
    fails or `rate_max` is reached, then bisection. A rate counts as certified only when
    the returned P verifies on the samples and on `check` (feasibility is monotone in ν).

    Parameters
    ----------
    closed_loops, p, slopes, check, solver
        As for :func:`rate_bounded_certificate`.
    rate_max : float
        Largest rate tried, units of p per second (> 0).
    tol : float
        Relative width of the final bracket (> 0).

    Returns
    -------
    RateMargin
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    rate_max = check_real("rate_max", rate_max, positive=True)
    tol = check_real("tol", tol, positive=True)
    solves = 0

    def run(nu: float) -> RateCertificate:
        nonlocal solves
        solves += 1
        return rate_bounded_certificate(closed_loops, p, nu, slopes=slopes, check=check, solver=solver)

    common = run(math.inf)
    if common.status == NOT_INSTALLED:
        return RateMargin(math.nan, (math.nan, math.nan), None, common, solves, time.perf_counter() - start)
    if common.certified:
        return RateMargin(math.inf, (math.inf, math.inf), common, common, solves, time.perf_counter() - start)
    best = run(0.0)
    if not best.certified:
        return RateMargin(math.nan, (math.nan, 0.0), None, common, solves, time.perf_counter() - start)
    lo, hi = 0.0, 1.0
    while True:
        trial = run(hi)
        if not trial.certified:
            break
        lo, best = hi, trial
        if hi >= rate_max:
            return RateMargin(lo, (lo, math.inf), best, common, solves, time.perf_counter() - start)
        hi = min(2 * hi, rate_max)
    def certified(nu: float) -> bool:
        nonlocal best
        trial = run(nu)
        if trial.certified:
            best = trial
        return trial.certified

    lo, hi = bisect(certified, lo, hi, tol, midpoint="eighth", stop=lambda lo, hi, mid: mid < 1e-12 * rate_max,
                    desc="rate")
    return RateMargin(lo, (lo, hi), best, common, solves, time.perf_counter() - start)


