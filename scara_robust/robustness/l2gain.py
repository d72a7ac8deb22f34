"""Worst-case L2 gain of an uncertain closed loop: an upper bound by LMI, a lower bound from frozen plants.

For ``ẋ = Ā(t) x + B_w w``, ``z = C x + D w`` with ``Ā(t)`` anywhere in the convex hull of
the closed loops ``Ā_i``, the bounded-real lemma with a common P (Boyd et al. 1994, §6.3.2)::

    [[Ā_iᵀP + PĀ_i + CᵀC, PB_w + CᵀD], [B_wᵀP + DᵀC, DᵀD − γ²I]] ≺ 0   at every i,   P ≻ 0

bounds ``‖z‖₂ <= γ‖w‖₂`` for every time variation (the idea of MATLAB's ``quadperf``). Every
frozen plant is one admissible variation, so ``max_i ‖C(sI − Ā_i)⁻¹B_w‖∞`` (python-control's
``norm(sys, 'inf')``) bounds the worst-case gain from below.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_closed_loops
from ..exceptions import ArgumentValueError
from ..results import AnalysisResult
from ..sdp import LMIProblem, LMIVariable, solve_lmi
from ..sdp.backends import resolve_lmi_solver
from .lmi import NOT_INSTALLED, cvxpy_available

__all__ = ["L2Gain", "l2_gain", "L2_INFLATION", "PeakBound", "peak_gain"]

Array = NDArray[np.float64]


class GainBound:
    """Mixin of a verified upper bound ``upper`` (``inf`` when none) and the solver's ``status``."""

    @property
    def certified(self) -> bool | None:
        """True when numpy verified the finite upper bound, else None (no bound is no disproof)."""
        return True if math.isfinite(self.upper) else None  # type: ignore[attr-defined]

    @property
    def verdict(self) -> str:
        """``'certified'`` (a verified bound), ``'infeasible'``, ``'not installed'`` or ``'unknown'``."""
        if math.isfinite(self.upper):  # type: ignore[attr-defined]
            return "certified"
        status: str = self.status  # type: ignore[attr-defined]
        return status if status in ("infeasible", NOT_INSTALLED) else "unknown"


def check_gain_inputs(closed_loops: ArrayLike, Bw: ArrayLike, C: ArrayLike,
                      D: ArrayLike | None) -> tuple[Array, Array, Array, Array]:
    """The closed loops, B_w (one per loop), C and D of a gain from w to z, or an error naming the argument.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    Bw : array_like, shape (n, q) or (V, n, q)
    C : array_like, shape (r, n)
    D : array_like, shape (r, q), or None
        None is zero.

    Returns
    -------
    A : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    C : ndarray, shape (r, n)
    D : ndarray, shape (r, q)
    """
    A = check_closed_loops("closed_loops", closed_loops)
    n = A.shape[1]
    Bw_ = check_array("Bw", Bw)
    if Bw_.ndim == 2:
        Bw_ = np.broadcast_to(Bw_, (A.shape[0], *Bw_.shape))
    if Bw_.ndim != 3 or Bw_.shape[:2] != (A.shape[0], n):
        raise ArgumentValueError("Bw", f"must have shape ({n}, q) or ({A.shape[0]}, {n}, q), found {Bw_.shape}")
    C_ = check_array("C", C, shape=(None, n))
    q = Bw_.shape[2]
    D_ = np.zeros((C_.shape[0], q)) if D is None else check_array("D", D, shape=(C_.shape[0], q))
    return A, Bw_, C_, D_


def frozen_hinf_norms(A: Array, Bw: Array, C: Array, D: Array) -> list[float]:
    """Each frozen closed loop's H∞ norm from w to z (python-control), ``inf`` for an unstable one.

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    C : ndarray, shape (r, n)
    D : ndarray, shape (r, q)

    Returns
    -------
    list of float
        Units of z per unit of w.
    """
    return [math.inf if np.linalg.eigvals(A_i).real.max() >= 0  # a frozen unstable plant: unbounded gain
            else float(ct.norm(ct.ss(A_i, B_i, C, D), p="inf")) for A_i, B_i in zip(A, Bw)]


@dataclass(frozen=True)
class L2Gain(GainBound, AnalysisResult):
    """Bounds on the worst-case L2 gain from w to z over the closed loops' hull.

    Attributes
    ----------
    upper : float
        A bound numpy verified: ``γ* (1 + inflation)``, where γ* is the LMI's optimum (a
        point on the boundary of the feasible set, where a strict inequality cannot be
        checked) and the LMI is solved again at the inflated bound for the most interior P,
        which numpy checks (``inf`` when the LMI is infeasible or its answer fails the
        check; NaN without cvxpy). Units of z per unit of w (rad per N·m for the robot's
        tracking error and disturbance torque).
    lower : float
        ``max_i`` of the frozen plants' H∞ norms.
    worst_index : int
        The frozen plant attaining `lower`.
    status : str
        The solver's status, ``'not verified'``, ``'infeasible'`` or ``'not installed'``.
    P : ndarray, shape (n, n), or None
    seconds : float
    inflation : float
        The relative margin of `upper` over the LMI's optimum (:data:`L2_INFLATION`).
    """

    upper: float
    lower: float
    worst_index: int
    status: str
    P: Array | None
    seconds: float
    inflation: float = 0.0

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if math.isfinite(self.upper):
            return (f"worst-case L2 gain in [{self.lower:.4g}, {self.upper:.4g}] (frozen plant {self.worst_index}; "
                    f"common-P bounded-real LMI, {self.status})")
        return f"worst-case L2 gain >= {self.lower:.4g} (frozen plant {self.worst_index}); upper bound: {self.status}"


#: The relative margin of a verified upper bound of :func:`l2_gain` over the LMI's optimum.
L2_INFLATION = 1e-3


def bounded_real_ok(A: Array, Bw: Array, C: Array, P: Array, gamma: float, D: Array | None = None) -> bool:
    """numpy's check of the bounded-real inequality at every closed loop (feedthrough D, default 0)."""
    q = Bw.shape[-1]
    D = np.zeros((C.shape[0], q)) if D is None else D
    top = np.swapaxes(A, -1, -2) @ P + P @ A + C.T @ C
    side = P @ Bw + C.T @ D  # (V, n, q)
    corner = np.broadcast_to(D.T @ D - gamma**2 * np.eye(q), (A.shape[0], q, q))
    block = np.block([[top, side], [np.swapaxes(side, -1, -2), corner]])
    return bool(np.linalg.eigvalsh(0.5 * (block + np.swapaxes(block, -1, -2)))[:, -1].max() < 0
                and np.linalg.eigvalsh(P)[0] > 0)


def _sym(a: Array) -> Array:
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def bounded_real_problem(A: Array, Bw: Array, C: Array, D: Array, *,
                         gamma: float | None = None) -> tuple[LMIProblem, LMIVariable, LMIVariable]:
    """The bounded-real LMI of :func:`l2_gain` as an :class:`~scara_robust.LMIProblem`.

    With ``E = [I 0]`` and ``N_i = [Ā_i B_w,i]`` (n × (n+q)), each loop's block is
    ``−(EᵀPN_i + N_iᵀPE) − [C D]ᵀ[C D] + γ² diag(0, I) ⪰ 0``, the bounded-real inequality.
    Without `gamma`: ``minimize γ²`` over P ⪰ 1e-9 I with every block ⪰ 1e-9 I (the
    optimum). With `gamma`: ``maximize t ≤ 1`` with ``P ⪰ tI`` and every block ⪰ tI at
    that γ (the most interior P, which numpy can check strictly).

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    C : ndarray, shape (r, n)
    D : ndarray, shape (r, q)
    gamma : float, optional

    Returns
    -------
    problem : LMIProblem
    P : LMIVariable
    s : LMIVariable
        γ² (without `gamma`) or t (with it).
    """
    n, q = A.shape[1], Bw.shape[2]
    eye = np.eye(n)
    E = np.hstack([eye, np.zeros((n, q))])
    N = np.concatenate([A, Bw], axis=2)
    CD = np.hstack([C, D])
    lower = np.zeros((n + q, n + q))
    lower[n:, n:] = np.eye(q)
    problem = LMIProblem()
    P, s = problem.symmetric("P", n), problem.scalar("g2" if gamma is None else "t")
    if gamma is None:
        problem.add_lmi(terms=[(P, 0.5 * eye, eye)], const=-1e-9 * eye, name="P >= 1e-9 I")
        problem.add_lmi(terms=[(P, -E, N)], scalars=[(s, lower)], const=-CD.T @ CD - 1e-9 * np.eye(n + q),
                        name="bounded real")
        problem.minimize({s: 1.0})
    else:
        problem.add_lmi(terms=[(P, 0.5 * eye, eye)], scalars=[(s, -eye)], name="P >= tI")
        problem.add_lmi(scalars=[(s, -np.ones((1, 1)))], const=np.ones((1, 1)), name="t <= 1")
        problem.add_lmi(terms=[(P, -E, N)], scalars=[(s, -np.eye(n + q))], const=-CD.T @ CD + gamma**2 * lower,
                        name="bounded real")
        problem.maximize({s: 1.0})
    return problem, P, s


def l2_gain(
    closed_loops: ArrayLike, Bw: ArrayLike, C: ArrayLike, D: ArrayLike | None = None, *, solver: str | None = None
) -> L2Gain:
    """Upper and lower bounds on the worst-case L2 gain from w to z over ``conv{Ā_i}``.

    The upper bound is ``γ* (1 + L2_INFLATION)``: the LMI's optimum γ* lies on the boundary
    of its feasible set, where numpy cannot confirm a strict inequality, so the LMI is
    solved again at the inflated γ for the most interior P, and that P is what numpy checks.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        The closed loops ``Ā_i`` (vertices or samples).
    Bw : array_like, shape (n, q) or (V, n, q)
        How the disturbance w enters, the same at every closed loop or one each (for the
        robot's error model: its B at each sample, since the disturbance torque enters
        like the control torque).
    C : array_like, shape (p, n)
        The output z (for the robot: ``[0, I, 0]``, the tracking error e).
    D : array_like, shape (p, q), optional
        Feedthrough from w to z (default 0). The gain is at least ``σ_max(D)``.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    L2Gain

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> A = np.array([[[-1.0]], [[-2.0]]])      # ẋ = a x + w, a in [-2, -1]; z = x + 0.5 w
    >>> g = sr.l2_gain(A, [[1.0]], [[1.0]], [[0.5]])
    >>> round(g.lower, 6), g.upper <= 1.5 * (1 + 1e-3) + 1e-6   # the H∞ norm at a = -1: 1 + 0.5
    (1.5, True)

    See Also
    --------
    peak_gain : the peak-to-peak bound.
    synthesize : with the ``l2`` objective.
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    A, Bw, C, D = check_gain_inputs(closed_loops, Bw, C, D)
    norms = frozen_hinf_norms(A, Bw, C, D)
    worst = int(np.argmax(norms))
    lower = norms[worst]
    if not cvxpy_available():
        return L2Gain(math.nan, lower, worst, NOT_INSTALLED, None, time.perf_counter() - start)
    problem, P, g2 = bounded_real_problem(A, Bw, C, D)
    result = solve_lmi(problem, solver)
    if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
        return L2Gain(math.inf, lower, worst, result.status, None, time.perf_counter() - start)
    gamma = math.sqrt(max(float(result.value(g2)), 0.0))
    # The optimum sits on the boundary, where numpy cannot confirm a strict inequality:
    # re-solve at γ(1 + 1e-3) for the most interior P, and check that one.
    bound = gamma * (1 + L2_INFLATION)
    interior, P2, _ = bounded_real_problem(A, Bw, C, D, gamma=bound)
    second = solve_lmi(interior, solver)
    if second.y is not None and second.status in ("optimal", "optimal_inaccurate"):
        P_val = _sym(np.asarray(second.value(P2), dtype=float))
        if bounded_real_ok(A, Bw, C, P_val, bound, D):
            return L2Gain(bound, lower, worst, result.status, P_val, time.perf_counter() - start, L2_INFLATION)
    return L2Gain(math.inf, lower, worst, "not verified", None, time.perf_counter() - start)


@dataclass(frozen=True)
class PeakBound(GainBound, AnalysisResult):
    """A bound on the peak of the output for bounded disturbances: an invariant ellipsoid.

    If ``‖w(t)‖₂ <= 1`` at all times and ``x(0) = 0`` (or, from any x(0), ultimately),
    then ``‖z(t)‖₂ <= upper`` for every time variation inside the closed loops' hull.
    Multiply by the disturbance's bound (for the robot's ±5 N·m on both joints, 5√2 N·m).

    Attributes
    ----------
    upper : float
        Units of z per unit of w (rad per N·m for the robot); ``inf`` when no ellipsoid
        was found or numpy rejects it, NaN without cvxpy.
    alpha : float
        The rate (1/s) of the S-procedure at the best ellipsoid.
    P : ndarray, shape (n, n), or None
        The ellipsoid ``{x : xᵀPx <= 1}``.
    status : str
    seconds : float
    """

    upper: float
    alpha: float
    P: Array | None
    status: str
    seconds: float
    lower: float = math.nan
    worst_index: int = -1

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if math.isfinite(self.upper):
            return (f"worst-case peak of z in [{self.lower:.4g}, {self.upper:.4g}] per unit of ‖w‖ (invariant "
                    f"ellipsoid at α = {self.alpha:.3g} 1/s, verified with numpy; sinusoid on frozen plant "
                    f"{self.worst_index})")
        return f"worst-case peak of z >= {self.lower:.4g} per unit of ‖w‖; no upper bound: {self.status}"


def _sinusoid_peak(A: Array, Bw: Array, C: Array, D: Array) -> float:
    """Steady peak of ‖z‖ for the worst sinusoid ``w = Re(v e^{jωt})``, ``|v| = 1``, on one frozen plant.

    ``‖w(t)‖ <= |v| = 1`` at every t, so this is an admissible disturbance and its peak a
    lower bound on the worst case. ω is where ``σmax(G(jω))`` peaks (python-control's
    ``linfnorm``, with the feedthrough D) and v its top right singular vector.
    """
    _, omega = ct.linfnorm(ct.ss(A, Bw, C, D))
    G = C @ np.linalg.solve(1j * float(omega) * np.eye(A.shape[0]) - A, Bw) + D
    v = np.linalg.svd(G)[2][0].conj()
    phases = np.exp(1j * np.linspace(0.0, 2 * np.pi, 721))
    return float(np.linalg.norm(np.real(np.outer(phases, G @ v)), axis=1).max())


def _ellipsoid_bound(A: Array, Bw: Array, C: Array, P: Array, alpha: float) -> float:
    """numpy's check that ``{xᵀPx <= 1}`` is invariant at every closed loop; the bound on ‖Cx‖ on it (inf if not)."""
    q = Bw.shape[-1]
    top = np.swapaxes(A, -1, -2) @ P + P @ A + alpha * P
    side = P @ Bw
    block = np.block([[top, side], [np.swapaxes(side, -1, -2), np.broadcast_to(-alpha * np.eye(q), (len(A), q, q))]])
    if np.linalg.eigvalsh(0.5 * (block + np.swapaxes(block, -1, -2)))[:, -1].max() > 0:
        return math.inf
    if np.linalg.eigvalsh(0.5 * (P + P.T))[0] <= 0:
        return math.inf
    return math.sqrt(float(np.linalg.eigvalsh(C @ np.linalg.inv(P) @ C.T).max()))


def invariant_ellipsoid_problem(A: Array, Bw: Array, C: Array,
                                alpha: float) -> tuple[LMIProblem, LMIVariable, LMIVariable]:
    """The invariant-ellipsoid LMI of :func:`peak_gain` at one rate α, as an :class:`~scara_robust.LMIProblem`.

    ``minimize γ²`` over P ⪰ 1e-9 I with ``[[P, Cᵀ], [C, γ²I]] ⪰ 0`` and, at every loop,
    ``−(EᵀPN_i + N_iᵀPE) + α diag(0, I) ⪰ 0`` with ``E = [I 0]`` and
    ``N_i = [Ā_i + (α/2)I, B_w,i]``: the block ``−[[Ā_iᵀP + PĀ_i + αP, PB_w], [B_wᵀP, −αI]]``.

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    C : ndarray, shape (p, n)
    alpha : float
        1/s.

    Returns
    -------
    problem : LMIProblem
    P, g2 : LMIVariable
    """
    n, q, p = A.shape[1], Bw.shape[2], C.shape[0]
    eye = np.eye(n)
    E = np.hstack([eye, np.zeros((n, q))])
    N = np.concatenate([A + 0.5 * alpha * eye, Bw], axis=2)
    rate = np.zeros((n + q, n + q))
    rate[n:, n:] = alpha * np.eye(q)
    Ep = np.hstack([eye, np.zeros((n, p))])
    output = np.zeros((n + p, n + p))
    output[n:, :n], output[:n, n:] = C, C.T
    lower = np.zeros((n + p, n + p))
    lower[n:, n:] = np.eye(p)
    problem = LMIProblem()
    P, g2 = problem.symmetric("P", n), problem.scalar("g2")
    problem.add_lmi(terms=[(P, 0.5 * eye, eye)], const=-1e-9 * eye, name="P >= 1e-9 I")
    problem.add_lmi(terms=[(P, 0.5 * Ep, Ep)], scalars=[(g2, lower)], const=output, name="[[P, C'], [C, g2 I]]")
    problem.add_lmi(terms=[(P, -E, N)], const=rate, name="invariance")
    problem.minimize({g2: 1.0})
    return problem, P, g2


def peak_gain(
    closed_loops: ArrayLike,
    Bw: ArrayLike,
    C: ArrayLike,
    D: ArrayLike | None = None,
    *,
    alphas: ArrayLike | None = None,
    solver: str | None = None,
) -> PeakBound:
    """The smallest invariant-ellipsoid bound on ``‖z(t)‖`` for ``‖w(t)‖ <= 1`` over ``conv{Ā_i}``.

    For a rate α > 0, ``[[Ā_iᵀP + PĀ_i + αP, PB_w], [B_wᵀP, −αI]] ⪯ 0`` at every i makes
    ``{xᵀPx <= 1}`` invariant (``V̇ <= α(‖w‖² − V)``: Boyd et al. 1994, §6.1.3), and
    ``[[P, Cᵀ], [C, γ²I]] ⪰ 0`` keeps ``‖Cx‖ <= γ`` on it. γ² is minimized by LMI for each α
    of a grid, and the best answer is checked with numpy. It is the quadratic form of
    Corollary 1's ultimate bound, with P chosen for the bound instead of given.

    With a feedthrough, ``z = Cx + Dw``, the upper bound is ``γ + σmax(D)`` (``‖z‖ <=
    ‖Cx‖ + ‖D‖‖w‖``): valid, and conservative by at most σmax(D), since the ellipsoid is
    chosen for ``Cx`` alone. The lower bound's sinusoid includes D.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    Bw : array_like, shape (n, q) or (V, n, q)
    C : array_like, shape (p, n)
    D : array_like, shape (p, q), optional
        Feedthrough from w to z (default zero).
    alphas : array_like, optional
        Rates tried, 1/s (> 0; default 16 points log-spaced over [10⁻², 10²]·(smallest
        decay of the closed loops' eigenvalues)).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    PeakBound
        With ``lower``: the largest steady peak of a worst sinusoid on a frozen plant
        (every frozen plant is an admissible variation).
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    A, Bw, C, D = check_gain_inputs(closed_loops, Bw, C, D)
    feedthrough = float(np.linalg.norm(D, 2)) if D.size else 0.0
    grid = None if alphas is None else check_array("alphas", alphas, ndim=1)
    if grid is not None and np.any(grid <= 0):
        raise ArgumentValueError("alphas", "must all be > 0 (1/s)")
    spectral = float(np.linalg.eigvals(A).real.max())
    if spectral >= 0:
        return PeakBound(math.inf, math.nan, None, "a frozen closed loop is not stable", time.perf_counter() - start,
                         math.inf, int(np.argmax(np.linalg.eigvals(A).real.max(axis=1))))
    if grid is None:
        grid = -spectral * np.logspace(-2, np.log10(2.0), 16)
    if not cvxpy_available():
        return PeakBound(math.nan, math.nan, None, NOT_INSTALLED, time.perf_counter() - start)
    peaks = [_sinusoid_peak(A_i, B_i, C, D) for A_i, B_i in zip(A, Bw)]
    worst = int(np.argmax(peaks))
    best: tuple[float, float, Array | None, str] = (math.inf, math.nan, None, "infeasible")
    for alpha in grid:
        problem, P, _ = invariant_ellipsoid_problem(A, Bw, C, float(alpha))
        result = solve_lmi(problem, solver)
        if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
            continue
        status = result.status
        P_val = _sym(np.asarray(result.value(P), dtype=float))
        # the optimum sits on the boundary; shrink P slightly (a larger ellipsoid) until numpy
        # accepts it as invariant, and report the bound numpy computes on that ellipsoid
        for factor in (1 + 1e-6, 1 + 1e-4, 1 + 1e-2):
            bound = _ellipsoid_bound(A, Bw, C, P_val / factor, float(alpha))
            if math.isfinite(bound):
                if bound < best[0]:
                    best = (bound, float(alpha), P_val / factor, status)
                break
        else:
            if not math.isfinite(best[0]):
                best = (math.inf, math.nan, None, "not verified")
    return PeakBound(best[0] + feedthrough, best[1], best[2], best[3], time.perf_counter() - start, peaks[worst],
                     worst)
