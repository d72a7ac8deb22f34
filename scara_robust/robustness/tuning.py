"""The smallest gain whose certified tracking-error bound meets a requirement.

For the sampled plants ``(A_i, B_i)`` of a loop, the perturbation ``|w_k| <= w̄_k`` entering
through ``B_w`` and a rate α, the synthesis LMI in ``Q = P⁻¹`` and ``Y = KQ`` (the congruence
of :mod:`~scara_robust.robustness.tracking`'s invariance block by ``diag(Q, I)``)::

    [[A_iQ − B_iY + (·)ᵀ + αQ, B_w diag(w̄)], [diag(w̄) B_wᵀ, −diag(μ)]] ⪯ 0   at every i,
    Σ μ_k / α <= 1,   c_j Q c_jᵀ <= β,   Q ⪰ νI,   [[κ²νI, Y], [Yᵀ, Q]] ⪰ 0

makes ``{xᵀQ⁻¹x <= 1}`` invariant under every perturbation and time variation, decaying at α
outside it, keeps ``|e_j| <= √β`` on it and ``‖K‖₂ <= κ``. ``minimize β`` for each α of a
grid; numpy then proves the bound after the settling time from the initial states with
``P = Q⁻¹`` (:func:`~scara_robust.robustness.tracking.ellipsoid_tracking_bound`). A larger
κ never gives a worse bound, so the smallest κ that meets the requirement is found by
bisection: the gain that meets it with the most room for the torque and the sample time.

Input limits ``|u_i| <= ū_i`` enter the synthesis where the gain without them exceeds them:
``[[ū_i²/γ, y_i], [y_iᵀ, Q]] ⪰ 0`` (``y_i`` the i-th row of Y) keeps ``|k_i x| <= ū_i`` on
``{xᵀQ⁻¹x <= γ}``, and ``[[γ, x₀ᵀ], [x₀, Q]] ⪰ 0`` holds the initial states in it, so with
``V∞ <= 1 <= γ`` every trajectory stays where the inputs are within their limits. γ, the
initial states' level, is the one the synthesis without limits gave them, at least 1 and at
most ``e^{αT}`` (where it has decayed to the ultimate level by T): a choice, not an optimum
(the problem is bilinear in γ), so the answer is conservative and numpy checks it like the
bound. When no gain meets the requirement within the limits, the same LMI with ``β`` capped
at the requirement and ``minimize s²`` on ``[[s²ū_i²/γ, y_i], [y_iᵀ, Q]] ⪰ 0`` gives the
smallest common scale of the limits a gain would need: the value reachable for them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_real
from ..exceptions import ArgumentValueError
from ..results import AnalysisResult
from ..sdp import LMIProblem, solve_lmi
from ..sdp.backends import resolve_lmi_solver
from ._cutting import grow_active_set
from .tracking import verified_ellipsoid

__all__ = ["GainTuning", "TrackingGain", "tune_gain", "tracking_gain", "tracking_synthesis_problem", "ALPHA_SETTLING",
           "CHANNEL_ITERATIONS", "input_peaks"]

Array = NDArray[np.float64]

#: Rates tried per gain bound: log-spaced multiples of 1/T (with a settling time T), 1/s.
ALPHA_SETTLING = np.logspace(0, math.log10(30.0), 7)
#: Plants the cutting planes start from (evenly spread over the samples).
FIRST_ACTIVE = 12
#: Relative width at which the bisection on κ stops.
KAPPA_RTOL = 0.05
#: Syntheses at one κ with gain-dependent channels, each from the last one's gain.
CHANNEL_ITERATIONS = 3
#: The factor (at most) by which the held synthesis's error cap shrinks where the gain's own channels exceed it.
CHANNEL_SHRINK = 0.95
#: The largest αT of the initial states' level ``γ <= e^{αT}`` where the inputs are held.
START_DECAY_CAP = 14.0
#: The room left below the requirement when the smallest input scale is sought (numpy's check inflates μ).
CAP_MARGIN = 1e-3


@dataclass(frozen=True)
class GainTuning(AnalysisResult):
    """The gain :func:`tune_gain` found, with the bound numpy proved for it.

    Attributes
    ----------
    K : ndarray, shape (m, n), or None
    P : ndarray, shape (n, n), or None
        The ellipsoid's matrix (``P = Q⁻¹``).
    bound : ndarray, shape (p,)
        The certified bound on each output after the settling time (output units).
    requirement : float
        The largest bound asked for (output units).
    alpha : float
        1/s.
    kappa : float
        The gain bound at the answer (``‖K‖₂ <= κ``).
    mu : ndarray, shape (q,), or None
        The multipliers of the perturbation channels.
    best_reachable : float
        With every requirement met, the bound; otherwise the smallest bound of a gain that
        meets the others (inf: none does), or the bound at the largest κ tried.
    status : str
        ``'met'`` or ``'requirement not met'``.
    binding : str
        What stops the requirement from being met (``''`` when met).
    search : str
        The bisection's steps, one ``κ: bound`` per step.
    seconds : float
    input_scale : float
        Where the gain the bisection found exceeds the input bound: the smallest common scale
        of the bound within which a synthesized gain (then `K`, with its bound) meets the
        requirement (<= 1: within it; inf: none found; NaN: not sought).
    """

    K: Array | None
    P: Array | None
    mu: Array | None
    bound: Array
    requirement: float
    alpha: float
    kappa: float
    best_reachable: float
    status: str
    binding: str
    search: str
    seconds: float
    input_scale: float = math.nan

    @property
    def certified(self) -> bool:
        """True when a gain meets the requirement with a bound numpy proved."""
        return bool(self.status == "met" and self.K is not None and np.all(np.isfinite(self.bound))
                    and self.bound.max() <= self.requirement)

    @property
    def verdict(self) -> str:
        """``'met'`` or ``'not met'``."""
        return "met" if self.certified else "not met"

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.certified:
            return (f"‖K‖₂ = {float(np.linalg.norm(np.asarray(self.K), 2)):.4g} keeps every output within "
                    f"{self.bound.max():.4g} <= {self.requirement:.4g} (certified, α = {self.alpha:.3g} 1/s)")
        head = f"the error requirement {self.requirement:.4g} is not met: {self.binding} binds"
        if not math.isnan(self.input_scale) and self.input_scale > 1:
            reach = (f"the best certified bound reachable within them is {self.best_reachable:.4g}"
                     if math.isfinite(self.best_reachable) else "no gain tried is certified within them")
            return f"{head}; {reach}; a gain meets it with {self.input_scale:.4g} times the input bounds"
        if math.isinf(self.best_reachable) and np.all(np.isfinite(self.bound)):
            return (f"{head}; no gain tried passes it (the smallest that meets the error bound, "
                    f"{self.bound.max():.4g}, does not)")
        return f"{head}; the best certified bound reachable is {self.best_reachable:.4g}"


def tracking_synthesis_problem(A: Array, B: Array, Bw: Array, w_bound: Array, C: Array, alpha: float,
                               kappa: float, input_bound: Array | None = None, starts: Array | None = None,
                               start_level: float = 1.0, beta_cap: float | None = None,
                               scale_unit: float | None = None) -> tuple[LMIProblem, dict[str, Any]]:
    """The synthesis LMI of the module docstring at one α and κ.

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    B : ndarray, shape (V, n, m)
    Bw : ndarray, shape (V, n, q)
    w_bound : ndarray, shape (q,)
    C : ndarray, shape (p, n)
    alpha, kappa : float
    input_bound : ndarray, shape (m,), optional
        ``ū_i``: with it, ``[[ū_i²/γ, y_i], [y_iᵀ, Q]] ⪰ 0`` for each input with a finite
        bound (``y_i`` the i-th row of Y), so ``|k_i x| <= ū_i`` on ``{xᵀQ⁻¹x <= γ}``.
    starts : ndarray, shape (k, n), optional
        With `input_bound`, the initial states held inside that level set,
        ``[[γ, x₀ᵀ], [x₀, Q]] ⪰ 0``: with ``γ >= 1 >= V∞`` every trajectory stays in it.
    start_level : float
        γ (>= 1).
    beta_cap : float, optional
        With `input_bound`: ``β <= beta_cap`` and ``minimize s²`` with the input blocks
        ``[[s² ū_i²/γ, y_i], [y_iᵀ, Q]] ⪰ 0``: the smallest common scale s of the input
        bounds an ellipsoid this small holds (the variable ``'scale2'``: ``(s / scale_unit)²``).
    scale_unit : float, optional
        The unit of s in ``'scale2'`` (> 0): the scale a known gain needs (the one without the
        bounds), so that the optimum is not far from one (on the Panda's problems 0.02–0.04,
        where the default unit puts it at 1e5 and the interior-point method runs out of its
        100 iterations). Default: ``√(γ / max_i ū_i²)``, the same problem whatever the bounds'
        size and γ.

    Returns
    -------
    problem : LMIProblem
    variables : dict
        ``'Q'``, ``'Y'``, ``'mu'`` (list of q scalars), ``'beta'``.
    """
    n, m, q = A.shape[1], B.shape[2], len(w_bound)
    eye, one = np.eye(n), np.ones((1, 1))
    problem = LMIProblem()
    Q, Y = problem.symmetric("Q", n), problem.matrix("Y", m, n)
    nu, beta = problem.scalar("nu"), problem.scalar("beta")
    mu = [problem.scalar(f"mu{k}") for k in range(q)]
    problem.add_lmi(terms=[(Q, 0.5 * eye, eye)], scalars=[(nu, -eye)], name="Q >= nu I")
    problem.add_lmi(scalars=[(nu, one)], name="nu >= 0")
    top, bottom = np.eye(m, m + n), np.eye(n, m + n, m)
    problem.add_lmi(terms=[(Y, top, bottom), (Q, 0.5 * bottom, bottom)],
                    scalars=[(nu, kappa**2 * np.diag(np.r_[np.ones(m), np.zeros(n)]))], name="gain bound")
    size = n + q
    En = np.eye(n, size)
    const = np.zeros((A.shape[0], size, size))
    const[:, :n, n:] = -Bw * w_bound
    const[:, n:, :n] = np.swapaxes(const[:, :n, n:], 1, 2)
    channels = []
    for k in range(q):
        G = np.zeros((size, size))
        G[n + k, n + k] = 1.0
        channels.append((mu[k], G))
    problem.add_lmi(terms=[(Q, -(np.swapaxes(A, 1, 2) + 0.5 * alpha * eye) @ En, En),
                           (Y, np.swapaxes(B, 1, 2) @ En, En)], scalars=channels, const=const, name="invariance")
    problem.add_lmi(scalars=[(mk, -one / alpha) for mk in mu], const=one, name="V_inf <= 1")
    problem.add_lmi(terms=[(Q, -0.5 * C[:, :, None], C[:, :, None])], scalars=[(beta, one)], name="outputs")
    variables = {"Q": Q, "Y": Y, "mu": mu, "beta": beta}
    if input_bound is not None:
        scale2 = problem.scalar("scale2") if beta_cap is not None else None
        _hold_inputs(problem, Q, Y, np.asarray(input_bound, dtype=float),
                     np.zeros((0, n)) if starts is None else np.atleast_2d(starts), max(start_level, 1.0), scale2,
                     scale_unit)
        if scale2 is not None and beta_cap is not None:
            problem.add_lmi(scalars=[(beta, -one)], const=float(beta_cap) * one, name="beta <= cap")
            problem.minimize({scale2: 1.0})
            return problem, {**variables, "scale2": scale2}
    problem.minimize({beta: 1.0})
    return problem, variables


def _hold_inputs(problem: LMIProblem, Q: Any, Y: Any, input_bound: Array, starts: Array, level: float,
                 scale2: Any = None, scale_unit: float | None = None) -> None:
    """``|k_i x| <= ū_i`` (``s ū_i`` with ``scale2`` = (s / scale_unit)²) on ``{xᵀQ⁻¹x <= level}``, which holds
    every start."""
    m, n = input_bound.shape[0], starts.shape[1]
    size = 1 + n
    lower = np.eye(n, size, 1)  # x -> (0, x)
    rows = np.flatnonzero(np.isfinite(input_bound))
    if len(rows):
        U = np.zeros((len(rows), m, size))
        U[np.arange(len(rows)), rows, 0] = 1.0
        const = np.zeros((len(rows), size, size))
        const[:, 0, 0] = input_bound[rows] ** 2 / level
        if scale2 is None:
            problem.add_lmi(terms=[(Y, U, lower), (Q, 0.5 * lower, lower)], const=const, name="inputs")
        else:
            unit2 = 1.0 / const[:, 0, 0].max() if scale_unit is None else float(scale_unit) ** 2
            problem.add_lmi(terms=[(Y, U, lower), (Q, 0.5 * lower, lower)],
                            scalars=[(scale2, const * unit2)], name="inputs")
    if len(starts):
        const = np.zeros((len(starts), size, size))
        const[:, 0, 0] = level
        const[:, 0, 1:], const[:, 1:, 0] = starts, starts
        problem.add_lmi(terms=[(Q, 0.5 * lower, lower)], const=const, name="starts")


def input_peaks(K: Array, P: Array, level: float) -> Array:
    """Each input's largest ``|k_i x|`` on ``{xᵀPx <= level}``: ``√(level · k_i P⁻¹ k_iᵀ)``, shape (m,).

    Parameters
    ----------
    K : ndarray, shape (m, n)
    P : ndarray, shape (n, n)
        Positive definite.
    level : float
        >= 0.

    Returns
    -------
    ndarray, shape (m,)
        In the input's unit (N·m for a torque).
    """
    return np.asarray(np.sqrt(np.einsum("ij,ij->i", K, np.linalg.solve(P, K.T).T) * level), dtype=float)


def _inputs_hold(K: Array, P: Array, mu: Array, alpha: float, starts: Array, input_bound: Array | None) -> bool:
    """numpy's check of the input bound: every input within ū on the level set that holds every trajectory."""
    if input_bound is None:
        return True
    v0 = float(np.einsum("ki,ij,kj->k", starts, P, starts).max()) if len(starts) else 0.0
    return bool(np.all(input_peaks(K, P, max(v0, float(np.sum(mu)) / alpha)) <= input_bound))


@dataclass(frozen=True)
class TrackingGain:
    """The best gain of one gain bound κ: the synthesis at each α of a grid, the smallest proved bound.

    Attributes
    ----------
    kappa : float
    value : float
        The largest output bound numpy proved after T (inf without a gain).
    bound : ndarray, shape (p,)
    K : ndarray, shape (m, n), or None
    P : ndarray, shape (n, n), or None
    mu : ndarray, shape (q,), or None
    alpha : float
        1/s (NaN without a gain).
    """

    kappa: float
    value: float
    bound: Array
    K: Array | None
    P: Array | None
    mu: Array | None
    alpha: float


def _invariance_violation(A: Array, B: Array, Bw: Array, w: Array, alpha: float, Q: Array, Y: Array,
                          mu: Array) -> Array:
    """Each plant's largest eigenvalue of the synthesis's invariance block (> 0: violated), shape (V,)."""
    n, q = Q.shape[0], len(w)
    top = A @ Q - B @ Y
    top = top + np.swapaxes(top, 1, 2) + alpha * Q
    block = np.zeros((len(A), n + q, n + q))
    block[:, :n, :n], block[:, :n, n:] = top, Bw * w
    block[:, n:, :n] = np.swapaxes(block[:, :n, n:], 1, 2)
    block[:, n:, n:] = -np.diag(mu)
    return np.asarray(np.linalg.eigvalsh(block)[:, -1], dtype=float)


def _candidate(A: Array, B: Array, Bw: Array, w: Array, C: Array, X0: Array, T: float, alpha: float, kappa: float,
               solver: str, hint: list[NDArray[np.int64]] | None = None, input_bound: Array | None = None,
               requirement: float | None = None) -> tuple[float, Array | None, Array | None, Array | None, Array,
                                                           float]:
    """One synthesis at (α, κ) on an active set of the plants grown by cutting planes.

    Returns the bound numpy proves for its gain on every plant, the gain, P and μ
    (inf, None, None, None where there is none). `hint` (a one-element list) holds the plants
    the last synthesis ended on: this one starts from them and leaves its own.

    With `input_bound` and `requirement`, where the first found a gain, a second synthesis
    (s in the unit of the first gain's scale, :func:`tracking_synthesis_problem`) keeps the bound within the
    requirement and minimizes a common scale s of the input bounds on the level γ of the
    initial states in the first (between 1 and ``e^{αT}``, where they have decayed to the
    ultimate level by T; :func:`tracking_synthesis_problem`): the first value returned is
    then the s numpy finds (``max_i peak_i / ū_i`` on the level set that holds every
    trajectory), inf where the bound it proves exceeds `requirement`.
    """
    p = C.shape[0]
    nothing: tuple[float, Array | None, Array | None, Array | None, Array, float] = (
        math.inf, None, None, None, np.full(p, math.inf), math.nan)

    def synthesize(level: float | None, cap: float | None = None,
                   unit: float | None = None) -> tuple[float, Array | None, Array | None, Array | None, Array, float]:
        def solve(active: NDArray[np.int64]) -> tuple[str, tuple[Array, Array, Array] | None]:
            problem, var = tracking_synthesis_problem(A[active], B[active], Bw[active], w, C, alpha, kappa,
                                                      None if level is None else input_bound, X0, level or 1.0, cap,
                                                      unit)
            result = solve_lmi(problem, solver)
            if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
                return result.status, None
            Q = np.array(result.value(var["Q"]), dtype=np.float64)
            Y = np.array(result.value(var["Y"]), dtype=np.float64)
            mu = np.array([float(result.value(mk)) for mk in var["mu"]], dtype=np.float64)
            return result.status, (0.5 * (Q + Q.T), Y, mu)

        first = np.unique(np.linspace(0, len(A) - 1, min(len(A), FIRST_ACTIVE)).round().astype(np.int64))
        if hint:
            first = np.union1d(first, hint[0][hint[0] < len(A)])
        _, answer, active = grow_active_set(solve, lambda a: _invariance_violation(A, B, Bw, w, alpha, *a), first)
        if answer is None:
            return nothing
        if hint is not None:
            hint[:] = [active]
        Q, Y, mu = answer
        try:
            P = np.linalg.inv(Q)
        except np.linalg.LinAlgError:
            return nothing
        K = Y @ P
        bound, _, _, mu_v, alpha_v = verified_ellipsoid(A - B @ K, Bw, w, C, X0, T, P, mu, alpha)
        if not np.all(np.isfinite(bound)):
            return nothing
        return float(bound.max()), K, P, mu_v, bound, alpha_v

    free = synthesize(None)
    if input_bound is None or requirement is None:
        return free
    _, K, P, mu, _, alpha_v = free
    if K is None or P is None or mu is None:
        return nothing  # the held synthesis only adds constraints to the one that found no gain
    level = math.exp(min(alpha * T, START_DECAY_CAP))
    if len(X0):
        level = min(level, max(1.0, float(np.einsum("ki,ij,kj->k", X0, P, X0).max())))
    decay = math.exp(-alpha * T)
    cap = (1.0 - CAP_MARGIN) * requirement**2 / max(1.0, decay * level + 1.0 - decay)
    finite = np.isfinite(input_bound)
    unit = float(np.max(input_peaks(K, P, level)[finite] / input_bound[finite]))  # the held optimum's order
    value, K, P, mu, bound, alpha_v = synthesize(level, cap, unit if math.isfinite(unit) and unit > 0 else None)
    if K is None or P is None or mu is None or not value <= requirement:
        return nothing
    v0 = float(np.einsum("ki,ij,kj->k", X0, P, X0).max()) if len(X0) else 0.0
    peaks = input_peaks(K, P, max(v0, float(np.sum(mu)) / alpha_v))
    return float(np.max(peaks[finite] / input_bound[finite])), K, P, mu, bound, alpha_v


def tracking_gain(A: Array, B: Array, Bw: Array, w: Array, C: Array, X0: Array, T: float, kappa: float,
                  alphas: Array, solver: str, hint: list[NDArray[np.int64]] | None = None) -> TrackingGain:
    """:class:`TrackingGain` at κ over the rates `alphas` (1/s): the smallest bound numpy proved.

    Parameters
    ----------
    A, B, Bw : ndarray, shapes (V, n, n), (V, n, m), (V, n, q)
    w : ndarray, shape (q,)
    C : ndarray, shape (p, n)
    X0 : ndarray, shape (k, n)
    T, kappa : float
    alphas : ndarray, shape (r,)
    solver : str
    hint : list, optional
        A one-element list of plant indices the cutting planes start from (with the evenly
        spread ones), updated to where each synthesis ends: the plants that bind at one
        rate or gain bound mostly bind at the next. Any start gives a verified answer.

    Returns
    -------
    TrackingGain
    """
    best = TrackingGain(kappa, math.inf, np.full(C.shape[0], math.inf), None, None, None, math.nan)
    for alpha in alphas:
        value, K, P, mu, bound, alpha_v = _candidate(A, B, Bw, w, C, X0, T, float(alpha), kappa, solver, hint)
        if value < best.value:
            best = TrackingGain(kappa, value, bound, K, P, mu, alpha_v)
    return best


def _gain_with_channels(A: Array, B: Array, C: Array, T: float, kappa: float, alphas: Array, solver: str,
                        channels: Callable[[Array | None], tuple[Array, Array, Array] | None],
                        reference: list[Array | None], hint: list[NDArray[np.int64]]) -> TrackingGain:
    """:func:`tracking_gain` with channels taken from the last gain, kept when its own channels verify it."""
    nothing = TrackingGain(kappa, math.inf, np.full(C.shape[0], math.inf), None, None, None, math.nan)
    K_ref = reference[0]
    for _ in range(CHANNEL_ITERATIONS):
        given = channels(K_ref)
        if given is None:
            return nothing
        Bw, w, X0 = given
        found = tracking_gain(A, B, Bw, w, C, X0, T, kappa, alphas, solver, hint)
        if found.K is None or found.P is None or found.mu is None:
            return nothing
        own = channels(found.K)
        if own is not None and own[1].size == found.mu.size:
            bound, _, _, mu, alpha = verified_ellipsoid(A - B @ found.K, own[0], own[1], C, own[2], T, found.P,
                                                        found.mu, found.alpha)
            if np.all(np.isfinite(bound)):
                return TrackingGain(kappa, float(bound.max()), bound, found.K, found.P, mu, alpha)
        K_ref = found.K
    return nothing


def _input_scale(A: Array, B: Array, Bw: Array, w: Array, C: Array, X0: Array, T: float, kappa: float,
                 alphas: Array, solver: str, input_bound: Array, requirement: float,
                 channels: Callable[[Array | None], tuple[Array, Array, Array] | None] | None,
                 K_ref: Array | None) -> tuple[float, TrackingGain | None]:
    """The smallest common scale s of `input_bound` within which a gain meets `requirement`, and that gain.

    One synthesis per α of `alphas`, in turn, until s <= 1 (:func:`_candidate` with the
    requirement), with channels from the last gain where they depend on it; numpy verifies
    the bound and the inputs with the gain's own channels and initial states. The error is
    capped at the requirement; where the gain's own channels then exceed it (the cap leaves
    no room for their change), the next synthesis's cap is smaller by the ratio they
    exceeded it (by :data:`CHANNEL_SHRINK` where they prove no bound).
    """
    best: tuple[float, TrackingGain | None] = (math.inf, None)
    hint: list[NDArray[np.int64]] = []
    for alpha in alphas:
        reference, target = K_ref, requirement
        for _ in range(CHANNEL_ITERATIONS if channels is not None else 1):
            given = (Bw, w, X0) if channels is None else channels(reference)
            if given is None:
                break
            scale, K, P, mu, bound, alpha_v = _candidate(A, B, given[0], given[1], C, given[2], T, float(alpha),
                                                         kappa, solver, hint, input_bound, target)
            if K is None or P is None or mu is None:
                break
            own = given if channels is None else channels(K)
            if own is not None and own[1].size == mu.size:
                bound, _, v0, mu, alpha_v = verified_ellipsoid(A - B @ K, own[0], own[1], C, own[2], T, P, mu,
                                                               alpha_v)
                if np.all(np.isfinite(bound)) and bound.max() <= requirement:
                    finite = np.isfinite(input_bound)
                    peaks = input_peaks(K, P, max(v0, float(np.sum(mu)) / alpha_v))
                    scale = float(np.max(peaks[finite] / input_bound[finite]))
                    if scale < best[0]:
                        best = (scale, TrackingGain(kappa, float(bound.max()), bound, K, P, mu, alpha_v))
                    break
                proved = np.all(np.isfinite(bound))
                target *= min(requirement / float(bound.max()), CHANNEL_SHRINK) if proved else CHANNEL_SHRINK
            reference = K
        if best[0] <= 1.0:
            break
    return best


def _scale_of(found: TrackingGain, bounds: Array | None, X0: Array,
              channels: Callable[[Array | None], tuple[Array, Array, Array] | None] | None) -> float:
    """numpy's ``max_i peak_i / ū_i`` of a gain with its own initial states (0 without bounds, inf without a gain)."""
    if bounds is None:
        return 0.0
    if found.K is None or found.P is None or found.mu is None:
        return math.inf
    own = X0 if channels is None else (channels(found.K) or (None, None, X0))[2]
    v0 = float(np.einsum("ki,ij,kj->k", own, found.P, own).max()) if len(own) else 0.0
    finite = np.isfinite(bounds)
    peaks = input_peaks(found.K, found.P, max(v0, float(np.sum(found.mu)) / found.alpha))
    return float(np.max(peaks[finite] / bounds[finite]))


def _check_problem(plants: tuple[ArrayLike, ArrayLike], disturbance: ArrayLike, w_bound: ArrayLike,
                   output: ArrayLike, initial_states: ArrayLike | None) -> tuple[Array, Array, Array, Array, Array,
                                                                                  Array]:
    A = check_array("plants[0]", plants[0], ndim=3)
    B = check_array("plants[1]", plants[1], ndim=3)
    if A.shape[1] != A.shape[2] or B.shape[:2] != A.shape[:2]:
        raise ArgumentValueError("plants", f"must hold A (V, n, n) and B (V, n, m), found {A.shape}, {B.shape}")
    V, n = A.shape[:2]
    Bw = check_array("disturbance", disturbance)
    Bw = np.broadcast_to(Bw, (V, *Bw.shape)) if Bw.ndim == 2 else Bw
    if Bw.ndim != 3 or Bw.shape[:2] != (V, n):
        raise ArgumentValueError("disturbance", f"must have shape ({n}, q) or ({V}, {n}, q), found {Bw.shape}")
    w = check_array("w_bound", w_bound, shape=(Bw.shape[2],))
    if np.any(w <= 0) or not np.all(np.isfinite(w)):
        raise ArgumentValueError("w_bound", f"must hold finite bounds > 0, found {w.tolist()}")
    C = check_array("output", output, shape=(None, n))
    X0 = np.zeros((0, n)) if initial_states is None else np.atleast_2d(check_array("initial_states", initial_states))
    if X0.ndim != 2 or X0.shape[1] != n:
        raise ArgumentValueError("initial_states", f"must have shape (k, {n}) (state units), found {X0.shape}")
    return A, B, np.ascontiguousarray(Bw, dtype=float), w, C, X0


def _check_input_bound(input_bound: ArrayLike, m: int) -> Array:
    bound = check_array("input_bound", input_bound, ndim=1, finite=False)
    if bound.shape not in ((1,), (m,)) or np.any(np.isnan(bound)) or np.any(bound <= 0):
        raise ArgumentValueError("input_bound", f"must hold {m} bounds > 0 (or one for every input; inf: none), "
                                                f"input units, found {bound.tolist()}")
    return np.asarray(np.broadcast_to(bound, (m,)), dtype=float)


def tune_gain(
    plants: tuple[ArrayLike, ArrayLike],
    disturbance: ArrayLike,
    w_bound: ArrayLike,
    output: ArrayLike,
    requirement: float,
    *,
    initial_states: ArrayLike | None = None,
    settling_time: float = 0.0,
    kappa_range: tuple[float, float] = (1.0, 1e4),
    accept: Callable[[TrackingGain], str] | None = None,
    channels: Callable[[Array | None], tuple[Array, Array, Array] | None] | None = None,
    input_bound: ArrayLike | None = None,
    solver: str | None = None,
) -> GainTuning:
    """The smallest gain bound κ whose synthesized gain keeps every output within `requirement` after T.

    At each κ of a bisection on ``log κ``, :func:`tracking_gain` (its rates: :data:`ALPHA_SETTLING`
    over T, the first time; then the best rate so far and its two neighbours). When the
    answer fails `accept` (the requirements the synthesis does not hold: a sample time, a
    torque limit, margins), a second bisection finds the largest κ below it that passes, and
    its bound is the best reachable.

    Parameters
    ----------
    plants : tuple (A (V, n, n), B (V, n, m))
        Sampled plants (the linearized loop along the reference, over the payload range).
    disturbance : array_like, shape (n, q) or (V, n, q)
    w_bound : array_like, shape (q,)
        ``|w_k| <= w̄_k`` (> 0).
    output : array_like, shape (p, n)
    requirement : float
        The largest output magnitude allowed after T (> 0, output units).
    initial_states : array_like, shape (k, n), optional
    settling_time : float
        T, s.
    kappa_range : (float, float)
        The gain bounds searched (0 < low < high).
    accept : callable ``accept(TrackingGain) -> str``, optional
        ``''`` when the gain meets every other requirement, else what it fails (one phrase).
    channels : callable ``channels(K) -> (disturbance, w_bound, initial_states)``, optional
        Channels that depend on the gain (a drift its integral absorbs,
        :meth:`~scara_robust.PerturbedSamples.integral_form`; ``K = None``: those without
        it). Each synthesis then takes them from the last gain found, and its answer counts
        only when numpy verifies it with its own gain's channels (up to
        :data:`CHANNEL_ITERATIONS` syntheses at a κ).
    input_bound : array_like, shape (m,) or (1,), optional
        ``ū``: each input's ``|k_i x|`` on the level set that holds every trajectory (numpy's
        check; > 0, inf where an input has none, input units). Where the bisection's gain
        exceeds it, the synthesis that holds it (:func:`tracking_synthesis_problem` with
        ``beta_cap``) at the largest κ gives the gain that meets the requirement within the
        smallest common scale of it (:attr:`GainTuning.input_scale`); above 1,
        ``'input_bound'`` binds.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional

    Returns
    -------
    GainTuning
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    A, B, Bw, w, C, X0 = _check_problem(plants, disturbance, w_bound, output, initial_states)
    req = check_real("requirement", requirement, positive=True)
    T = check_real("settling_time", settling_time, nonnegative=True)
    if len(kappa_range) != 2:
        raise ArgumentValueError("kappa_range", f"must be (low, high), found {kappa_range}")
    lo, hi = (check_real("kappa_range", k, positive=True) for k in kappa_range)
    if not lo < hi:
        raise ArgumentValueError("kappa_range", f"must be (low, high) with 0 < low < high, found {kappa_range}")
    bounds = None if input_bound is None else _check_input_bound(input_bound, B.shape[2])
    grid = ALPHA_SETTLING / T if T > 0 else float(np.linalg.norm(A, 2, axis=(1, 2)).max()) * np.logspace(-2, 0, 7)
    steps: list[str] = []
    last = {"alpha": math.nan}
    reference: list[Array | None] = [None]
    hint: list[NDArray[np.int64]] = []

    def at(kappa: float) -> TrackingGain:
        if math.isnan(last["alpha"]):
            alphas = grid
        else:
            i = int(np.argmin(np.abs(np.log(grid / last["alpha"]))))
            alphas = grid[max(i - 1, 0):i + 2]
        found = (tracking_gain(A, B, Bw, w, C, X0, T, kappa, alphas, solver, hint) if channels is None
                 else _gain_with_channels(A, B, C, T, kappa, alphas, solver, channels, reference, hint))
        if found.K is not None:
            last["alpha"] = found.alpha
            reference[0] = found.K
        steps.append(f"κ = {kappa:.4g}: {found.value:.4g}")
        return found

    def result(answer: TrackingGain, best: float, status: str, binding: str) -> GainTuning:
        return GainTuning(answer.K, answer.P, answer.mu, answer.bound, req, answer.alpha, answer.kappa, best, status,
                          binding, "; ".join(steps), time.perf_counter() - start, scaled[0])

    def holds(found: TrackingGain) -> bool:
        return _scale_of(found, bounds, X0, channels) <= 1.0

    def within(answer: TrackingGain, failed: str) -> GainTuning:
        return _largest_within(answer, failed, at, lambda g: holds(g) and not (accept(g) if accept else ""),
                               kappa_range[0], req, result)

    def held_at(kappa: float, near: TrackingGain, rates: int = len(grid)) -> tuple[float, TrackingGain | None]:
        """The input bounds held at κ (:func:`_input_scale`), on the `rates` rates nearest `near`'s."""
        assert bounds is not None
        order = grid[np.argsort(np.abs(np.log(grid / near.alpha)), kind="stable")][:rates]
        scale, held = _input_scale(A, B, Bw, w, C, X0, T, kappa, order, solver, bounds, req, channels, near.K)
        steps.append(f"κ = {kappa:.4g}, the input bounds held: x{scale:.4g} of them needed")
        return scale, held

    scaled = [math.nan]
    top = at(hi)
    if not top.value <= req:
        return result(top, top.value, "requirement not met", f"the error bound: {top.value:.4g} at κ = {hi:.4g}")
    answer = top
    while hi / lo > 1 + KAPPA_RTOL:
        mid = math.sqrt(lo * hi)
        found = at(mid)
        if found.value <= req:
            hi, answer = mid, found
        else:
            lo = mid
    if bounds is not None and answer.K is not None:
        if not holds(answer):
            # the smallest gain that meets the bound exceeds the input bounds: the synthesis that holds them,
            # at the largest gain bound, its rates from the answer's outwards
            scale, held = held_at(kappa_range[1], answer)
            own = _scale_of(answer, bounds, X0, channels)
            if held is None or scale > own:  # the bisection's gain needs less: it stays the answer
                scale, held = own, answer
            scaled[0] = scale
            if scale > 1.0:  # the largest gain within them (below), with the scale a gain would need
                return within(answer, "input_bound")
            # the smallest gain bound at which the synthesis holds them (the most room for the sample time)
            low, high = answer.kappa, kappa_range[1]
            while high / low > 1 + KAPPA_RTOL:
                mid = math.sqrt(low * high)
                s_mid, g_mid = held_at(mid, held, 3)
                if g_mid is not None and s_mid <= 1.0:
                    high, scale, held = mid, s_mid, g_mid
                else:
                    low = mid
            scaled[0] = scale
            failed = accept(held) if accept is not None else ""
            return result(held, held.value if not failed else math.inf, "met" if not failed else
                          "requirement not met", failed)
    failed = accept(answer) if accept is not None else ""
    if not failed:
        return result(answer, answer.value, "met", "")
    return within(answer, failed)


def _largest_within(answer: TrackingGain, failed: str, at: Callable[[float], TrackingGain],
                    passes: Callable[[TrackingGain], bool], low: float, requirement: float,
                    result: Callable[[TrackingGain, float, str, str], GainTuning]) -> GainTuning:
    """The others fail at the smallest gain that meets the bound: the largest gain below it they allow.

    A gain bound at which no gain is found at all is below every one that passes (a larger κ
    never does worse), so the search moves up from it as from one that passes.
    """
    high, best = answer.kappa, None
    while high / low > 1 + KAPPA_RTOL:
        mid = math.sqrt(low * high)
        found = at(mid)
        if found.K is None or passes(found):
            low, best = mid, (found if found.K is not None else best)
        else:
            high = mid
    if best is None:
        return result(answer, math.inf, "requirement not met", failed)
    if best.value <= requirement:  # the bound is not monotone in κ: a smaller gain that passes may meet it too
        return result(best, best.value, "met", "")
    return result(best, best.value, "requirement not met", failed)
