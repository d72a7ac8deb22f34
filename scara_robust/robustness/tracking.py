"""A certified bound on the tracking error after a settling time: an invariant ellipsoid with a decay.

For ``ẋ = Ā(t) x + B_w w(t)`` with ``Ā(t)`` anywhere in the convex hull of the closed loops
``Ā_i`` and every channel of the perturbation bounded, ``|w_k(t)| <= w̄_k`` (Eq. (4) of the
paper: w holds the drift ``f̄`` along the reference and ``ḡ T_d``), a common P, a rate α > 0
and multipliers ``μ_k >= 0`` with, at every i,

    [[Ā_iᵀP + PĀ_i + αP, PB_w diag(w̄)], [diag(w̄) B_wᵀP, −diag(μ)]] ⪯ 0

give ``V̇ <= −αV + Σ μ_k (w_k/w̄_k)² <= −α(V − V∞)`` for ``V = xᵀPx`` and ``V∞ = Σ μ_k / α``
(the S-procedure of Boyd et al. 1994, §6.1.3, one multiplier per channel). So
``V(t) <= V∞ + (V(0) − V∞) e^{−αt}``, and for every ``t >= T``

    |c_j x(t)|² <= c_j P⁻¹ c_jᵀ · max(V∞, V∞ (1 − e^{−αT}) + V(0) e^{−αT}),

whatever the time variation of ``Ā(t)`` inside the hull and of ``w`` inside its bounds. For a
given α the best P is an LMI with a linear objective (P normalized by ``c_j P⁻¹ c_jᵀ <= 1``,
so the bound² is the ``max(...)``, an epigraph); α is searched on a grid and refined. numpy
then checks the LMI at every loop with the solver's P and μ (slightly inflated until it
holds) and computes the bound it reports from them: the figure never comes from the solver.

On ``ẋ = −a x + w``, ``|w| <= w̄`` the bound is
``min over 0 < α < 2a of max(w̄²/(α(2a−α)), w̄²(1 − e^{−αT})/(α(2a−α)) + x₀² e^{−αT})`` (square
root), whose limit for large T is ``w̄/a``, the exact worst case.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_closed_loops, check_real
from ..exceptions import ArgumentValueError
from ..results import AnalysisResult
from ..sdp import LMIProblem, solve_lmi
from ..sdp.backends import resolve_lmi_solver
from ._cutting import grow_active_set

__all__ = ["TrackingBound", "tracking_bound", "tracking_bound_problem", "ellipsoid_tracking_bound"]

Array = NDArray[np.float64]

#: Loops the cutting planes start from (evenly spread).
FIRST_ACTIVE = 12
#: Rates tried before the refinement, per call.
N_ALPHAS = 10
#: Inflations of μ (and deflations of α) tried, in turn, until numpy accepts the solver's answer.
INFLATIONS = (0.0, 1e-7, 1e-5, 1e-3, 1e-2, 3e-2, 0.1)
#: What the refinement of α sees where nothing was verified (a finite number: the scalar search needs one).
_NOT_VERIFIED = 1e300


@dataclass(frozen=True)
class TrackingBound(AnalysisResult):
    """A certified bound on each output's magnitude after a settling time.

    Attributes
    ----------
    bound : ndarray, shape (p,)
        ``sup_{t >= T} |z_j(t)|`` is at most ``bound[j]``, in the output's unit; ``inf`` when
        no ellipsoid was verified.
    ultimate : ndarray, shape (p,)
        The same as ``T → ∞`` with the same P, α and μ (what the perturbation alone leaves).
    settling_time : float
        T, s.
    alpha : float
        The rate of the verified ellipsoid, 1/s (NaN without one).
    P : ndarray, shape (n, n), or None
        ``V = xᵀPx``.
    mu : ndarray, shape (q,), or None
        The multipliers, one per perturbation channel (units of V).
    initial_level : float
        ``max_k x₀,kᵀ P x₀,k`` over the initial states (0 without them).
    status : str
        The LMI solver's status at the best rate (``'unstable'`` when a loop is not Hurwitz).
    n_loops : int
    seconds : float
    """

    bound: Array
    ultimate: Array
    settling_time: float
    alpha: float
    P: Array | None
    mu: Array | None
    initial_level: float
    status: str
    n_loops: int
    seconds: float

    @property
    def certified(self) -> bool:
        """True when numpy verified an ellipsoid (every bound finite)."""
        return bool(self.P is not None and np.all(np.isfinite(self.bound)))

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not verified'``."""
        return "certified" if self.certified else "not verified"

    @property
    def worst(self) -> float:
        """The largest of :attr:`bound` (output units)."""
        return float(np.max(self.bound)) if self.bound.size else math.nan

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if not self.certified:
            return f"no verified bound on the outputs after {self.settling_time:g} s: {self.status}"
        return (f"after {self.settling_time:g} s every output stays within {np.array2string(self.bound, precision=4)} "
                f"(ultimately {np.array2string(self.ultimate, precision=4)}); invariant ellipsoid at "
                f"α = {self.alpha:.4g} 1/s over {self.n_loops} closed loops, verified with numpy")


def invariance_eigenvalues(closed_loops: Array, Bw: Array, w_bound: Array, P: Array, mu: Array,
                           alpha: float) -> Array:
    """Each loop's largest eigenvalue of the invariance block of the module docstring (> 0: violated).

    Parameters
    ----------
    closed_loops : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    w_bound : ndarray, shape (q,)
    P : ndarray, shape (n, n)
    mu : ndarray, shape (q,)
    alpha : float

    Returns
    -------
    ndarray, shape (V,)
    """
    n, q = P.shape[0], len(w_bound)
    side = P @ Bw * w_bound
    top = np.swapaxes(closed_loops, 1, 2) @ P + P @ closed_loops + alpha * P
    block = np.zeros((len(closed_loops), n + q, n + q))
    block[:, :n, :n], block[:, :n, n:] = top, side
    block[:, n:, :n] = np.swapaxes(side, 1, 2)
    block[:, n:, n:] = -np.diag(mu)
    return np.asarray(np.linalg.eigvalsh(0.5 * (block + np.swapaxes(block, 1, 2)))[:, -1], dtype=float)


def ellipsoid_tracking_bound(closed_loops: Array, Bw: Array, w_bound: Array, C: Array, initial_states: Array,
                             settling_time: float, P: Array, mu: Array, alpha: float) -> tuple[Array, Array, float]:
    """numpy's check of ``(P, μ, α)`` and the bounds it proves (module docstring); inf where it fails.

    Parameters
    ----------
    closed_loops : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    w_bound : ndarray, shape (q,)
        ``w̄``, > 0.
    C : ndarray, shape (p, n)
    initial_states : ndarray, shape (k, n)
        k may be 0.
    settling_time : float
        T, s.
    P : ndarray, shape (n, n)
    mu : ndarray, shape (q,)
    alpha : float
        1/s, > 0.

    Returns
    -------
    bound, ultimate : ndarray, shape (p,)
    initial_level : float
        ``max_k x₀,kᵀ P x₀,k``.
    """
    p = C.shape[0]
    inf = np.full(p, math.inf)
    P = 0.5 * (P + P.T)
    if alpha <= 0 or np.any(mu < 0) or np.linalg.eigvalsh(P)[0] <= 0:
        return inf, inf, math.inf
    if invariance_eigenvalues(closed_loops, Bw, w_bound, P, mu, alpha).max() > 0:
        return inf, inf, math.inf
    v_inf = float(np.sum(mu)) / alpha
    v0 = float(np.einsum("ki,ij,kj->k", initial_states, P, initial_states).max()) if len(initial_states) else 0.0
    decay = math.exp(-alpha * settling_time)
    gains = np.einsum("ji,ji->j", C, np.linalg.solve(P, C.T).T)
    level = max(v_inf, v_inf * (1.0 - decay) + v0 * decay)
    return np.sqrt(gains * level), np.sqrt(gains * v_inf), v0


def verified_ellipsoid(closed_loops: Array, Bw: Array, w_bound: Array, C: Array, initial_states: Array,
                       settling_time: float, P: Array, mu: Array, alpha: float
                       ) -> tuple[Array, Array, float, Array, float]:
    """A solver's ``(P, μ, α)`` made to pass numpy's check: μ inflated and α deflated by :data:`INFLATIONS` in turn.

    The optimum of an LMI sits on its boundary, and the loops between the samples it saw
    may lie just outside; the first ``(μ(1 + ε) + 10⁻¹² , α(1 − ε))`` that numpy accepts
    on every loop of `closed_loops` is kept (the bound grows with ε).

    Parameters
    ----------
    closed_loops, Bw, w_bound, C, initial_states, settling_time, P, mu, alpha
        As for :func:`ellipsoid_tracking_bound`.

    Returns
    -------
    bound, ultimate : ndarray, shape (p,)
        inf when no ε passes.
    initial_level : float
    mu, alpha
        The multipliers and rate that passed (the solver's when none did).
    """
    for eps in INFLATIONS:
        mu_v, alpha_v = np.maximum(mu, 0.0) * (1 + eps) + 1e-12, alpha * (1 - eps)
        bound, ultimate, v0 = ellipsoid_tracking_bound(closed_loops, Bw, w_bound, C, initial_states, settling_time,
                                                       P, mu_v, alpha_v)
        if np.all(np.isfinite(bound)):
            return bound, ultimate, v0, mu_v, alpha_v
    inf = np.full(C.shape[0], math.inf)
    return inf, inf, math.inf, mu, alpha


def tracking_bound_problem(closed_loops: Array, Bw: Array, w_bound: Array, C: Array, initial_states: Array,
                           settling_time: float, alpha: float) -> tuple[LMIProblem, dict[str, Any]]:
    """The LMI of :func:`tracking_bound` at one rate α, as an :class:`~scara_robust.LMIProblem`.

    ``minimize τ`` over symmetric P, ``μ >= 0``, s and τ with, at every loop, the invariance
    block of the module docstring ⪯ 0; ``[[1, c_j], [c_jᵀ, P]] ⪰ 0`` per output (so
    ``c_j P⁻¹ c_jᵀ <= 1``); ``x₀ᵀPx₀ <= s`` per initial state; ``τ >= Σμ/α`` and
    ``τ >= (1 − e^{−αT}) Σμ/α + e^{−αT} s``. The bound² on every output is then at most τ.

    Parameters
    ----------
    closed_loops : ndarray, shape (V, n, n)
    Bw : ndarray, shape (V, n, q)
    w_bound : ndarray, shape (q,)
    C : ndarray, shape (p, n)
    initial_states : ndarray, shape (k, n)
    settling_time : float
        s.
    alpha : float
        1/s.

    Returns
    -------
    problem : LMIProblem
    variables : dict
        ``'P'``, ``'mu'`` (a list of q scalars), ``'tau'``.
    """
    V, n = closed_loops.shape[:2]
    q = len(w_bound)
    eye = np.eye(n)
    one = np.ones((1, 1))
    problem = LMIProblem()
    P = problem.symmetric("P", n)
    mu = [problem.scalar(f"mu{k}") for k in range(q)]
    tau = problem.scalar("tau")
    E = np.hstack([eye, np.zeros((n, q))])
    N = np.concatenate([closed_loops + 0.5 * alpha * eye, Bw * w_bound], axis=2)
    channels = []
    for k in range(q):
        G = np.zeros((n + q, n + q))
        G[n + k, n + k] = 1.0
        channels.append((mu[k], G))
    problem.add_lmi(terms=[(P, -E, N)], scalars=channels, name="invariance")
    F = np.eye(n, n + 1, 1)
    const = np.zeros((C.shape[0], n + 1, n + 1))
    const[:, 0, 0] = 1.0
    const[:, 0, 1:], const[:, 1:, 0] = C, C
    problem.add_lmi(terms=[(P, 0.5 * F, F)], const=const, name="outputs")
    decay = math.exp(-alpha * settling_time)
    ultimate = [(tau, one)] + [(m, -one / alpha) for m in mu]
    problem.add_lmi(scalars=ultimate, name="tau >= V_inf")
    if len(initial_states) and decay > 0:
        s = problem.scalar("s")
        problem.add_lmi(terms=[(P, -0.5 * initial_states[:, :, None], initial_states[:, :, None])],
                        scalars=[(s, one)], name="initial states inside")
        problem.add_lmi(scalars=[(tau, one), (s, -decay * one)] + [(m, -(1.0 - decay) * one / alpha) for m in mu],
                        name="tau >= V(T)")
    problem.minimize({tau: 1.0})
    return problem, {"P": P, "mu": mu, "tau": tau}


def _inputs(closed_loops: ArrayLike, disturbance: ArrayLike, w_bound: ArrayLike, output: ArrayLike,
            initial_states: ArrayLike | None) -> tuple[Array, Array, Array, Array, Array]:
    A = check_closed_loops("closed_loops", closed_loops)
    V, n = A.shape[:2]
    Bw = check_array("disturbance", disturbance)
    if Bw.ndim == 2:
        Bw = np.broadcast_to(Bw, (V, *Bw.shape))
    if Bw.ndim != 3 or Bw.shape[:2] != (V, n):
        raise ArgumentValueError("disturbance", f"must have shape ({n}, q) or ({V}, {n}, q), found {Bw.shape}")
    w = check_array("w_bound", w_bound, ndim=1)
    if w.shape != (Bw.shape[2],) or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ArgumentValueError("w_bound", f"must hold {Bw.shape[2]} finite bounds > 0 (one per column of "
                                            f"`disturbance`, in its unit), found {w.tolist()}")
    C = check_array("output", output, shape=(None, n))
    X0 = np.zeros((0, n)) if initial_states is None else check_array("initial_states", initial_states)
    if X0.ndim == 1:
        X0 = X0[None, :]
    if X0.ndim != 2 or X0.shape[1] != n:
        raise ArgumentValueError("initial_states", f"must have shape (k, {n}) (state units), found {X0.shape}")
    return A, np.asarray(Bw, dtype=float), w, C, X0


def tracking_bound(
    closed_loops: ArrayLike,
    disturbance: ArrayLike,
    w_bound: ArrayLike,
    output: ArrayLike,
    *,
    initial_states: ArrayLike | None = None,
    settling_time: float = 0.0,
    check: tuple[ArrayLike, ArrayLike] | None = None,
    alphas: ArrayLike | None = None,
    solver: str | None = None,
) -> TrackingBound:
    """The smallest certified bound on ``|c_j x(t)|`` for ``t >= T`` by an invariant ellipsoid with decay.

    See the module docstring for the inequality. The state is balanced
    (``scipy.linalg.matrix_balance`` of the average loop) before the LMI is solved, the
    rate α is searched on :data:`N_ALPHAS` log-spaced points below twice the slowest decay
    of the loops and refined by a bounded scalar search around the best, and the reported
    bound is the one numpy proves from the best verified ``(P, μ, α)``.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        ``Ā_i``: the time-varying closed loop stays in their convex hull.
    disturbance : array_like, shape (n, q) or (V, n, q)
        ``B_w``: how the perturbation enters ẋ.
    w_bound : array_like, shape (q,)
        ``|w_k(t)| <= w̄_k`` at all times (> 0, the unit of w).
    output : array_like, shape (p, n)
        C: the outputs bounded (the tracking errors ``e_j``).
    initial_states : array_like, shape (k, n) or (n,), optional
        The states the loop may start from (default: the origin).
    settling_time : float
        T >= 0, s: the bound holds for every ``t >= T``.
    check : tuple (closed loops (V2, n, n), disturbance (n, q) or (V2, n, q)), optional
        More closed loops, with their disturbance matrices, on which numpy re-verifies the
        answer (a finer, independent sampling).
    alphas : array_like, optional
        Rates to try, 1/s (> 0), instead of the default grid.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        None: :func:`~scara_robust.default_lmi_solver`.

    Returns
    -------
    TrackingBound

    References
    ----------
    Boyd, El Ghaoui, Feron, Balakrishnan, *Linear Matrix Inequalities in System and Control
    Theory*, SIAM 1994, §6.1.3 (invariant ellipsoids, peak of the output) and §5.1 (decay).

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> b = sr.tracking_bound([[[-2.0]]], [[1.0]], [1.0], [[1.0]])
    >>> round(float(b.bound[0]), 3)   # |w| <= 1 through 1/(s + 2): at most 1/2
    0.5
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    A, Bw, w, C, X0 = _inputs(closed_loops, disturbance, w_bound, output, initial_states)
    T = check_real("settling_time", settling_time, nonnegative=True)
    loops_all, Bw_all = A, Bw
    if check is not None:
        if not isinstance(check, tuple) or len(check) != 2:
            raise ArgumentValueError("check", "must be a tuple (closed loops, disturbance)")
        A_chk, Bw_chk, _, _, _ = _inputs(check[0], check[1], w, C, None)
        if A_chk.shape[1:] != A.shape[1:] or Bw_chk.shape[1:] != Bw.shape[1:]:
            raise ArgumentValueError("check", f"must hold loops ({A.shape[1]}, {A.shape[1]}) and disturbance "
                                              f"({A.shape[1]}, {Bw.shape[2]}), found {A_chk.shape}, {Bw_chk.shape}")
        loops_all, Bw_all = np.concatenate([A, A_chk]), np.concatenate([Bw, Bw_chk])
    p = C.shape[0]
    spectral = float(np.linalg.eigvals(loops_all).real.max())
    if spectral >= 0:
        inf = np.full(p, math.inf)
        return TrackingBound(inf, inf, T, math.nan, None, None, math.nan, "unstable", len(loops_all),
                             time.perf_counter() - start)
    # balance the state: x = D x̃ (the LMI in x̃, the check in x)
    _, (scale, _) = scipy.linalg.matrix_balance(A.mean(axis=0), permute=False, separate=True)
    D = np.asarray(scale, dtype=float)
    A_s, Bw_s = loops_all * D[None, None, :] / D[None, :, None], Bw_all / D[None, :, None]
    C_s, X0_s = C * D, X0 / D
    # cutting planes over every loop (the check's too): the LMI sees an active set, numpy all of them
    first = np.unique(np.linspace(0, len(A_s) - 1, min(len(A_s), FIRST_ACTIVE)).round().astype(np.int64))
    best: dict[str, object] = {"value": math.inf, "status": "infeasible"}

    def evaluate(alpha: float) -> float:
        def solve(active: NDArray[np.int64]) -> tuple[str, tuple[Array, Array] | None]:
            problem, var = tracking_bound_problem(A_s[active], Bw_s[active], w, C_s, X0_s, T, alpha)
            result = solve_lmi(problem, solver)
            if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
                return result.status, None
            P_s = np.array(result.value(var["P"]), dtype=np.float64)
            mu = np.array([float(result.value(m)) for m in var["mu"]], dtype=np.float64)
            return result.status, (P_s, mu)

        status, answer, _ = grow_active_set(
            solve, lambda a: invariance_eigenvalues(A_s, Bw_s, w, a[0], a[1], alpha), first)
        if answer is None:
            if not math.isfinite(float(best["value"])):  # type: ignore[arg-type]
                best["status"] = status
            return _NOT_VERIFIED
        P_s, mu = answer
        P = P_s / D[:, None] / D[None, :]
        bound, ultimate, v0, mu_v, alpha_v = verified_ellipsoid(loops_all, Bw_all, w, C, X0, T, P, mu, alpha)
        if not np.all(np.isfinite(bound)):
            return _NOT_VERIFIED
        value = float(bound.max())
        if value < float(best["value"]):  # type: ignore[arg-type]
            best.update(value=value, bound=bound, ultimate=ultimate, alpha=alpha_v, P=P, mu=mu_v, v0=v0,
                        status=status)
        return value

    grid = (np.asarray(check_array("alphas", alphas, ndim=1), dtype=float) if alphas is not None
            else -2.0 * spectral * np.logspace(-2.5, math.log10(0.999), N_ALPHAS))
    if np.any(grid <= 0):
        raise ArgumentValueError("alphas", "must all be > 0 (1/s)")
    values = [evaluate(float(a)) for a in grid]
    if alphas is None and min(values) < _NOT_VERIFIED:
        i = int(np.argmin(values))
        lo, hi = math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, len(grid) - 1)])
        if hi > lo:
            scipy.optimize.minimize_scalar(lambda la: evaluate(math.exp(la)), bounds=(lo, hi), method="bounded",
                                           options={"xatol": 1e-3, "maxiter": 16})
    seconds = time.perf_counter() - start
    if not math.isfinite(float(best["value"])):  # type: ignore[arg-type]
        inf = np.full(p, math.inf)
        return TrackingBound(inf, inf, T, math.nan, None, None, math.nan, str(best["status"]), len(loops_all), seconds)
    return TrackingBound(best["bound"], best["ultimate"], T, float(best["alpha"]), best["P"],  # type: ignore[arg-type]
                         best["mu"], float(best["v0"]), str(best["status"]), len(loops_all), seconds)  # type: ignore[arg-type]
