"""Search for an unstable trajectory of a linear system with time-varying parameters.

A failed certificate says nothing by itself: the system may be stable and the test too
weak. The falsifier looks for the opposite evidence. The parameter h(t) switches among
the vertices Ā_v of the uncertainty set, holding each for a dwell time τ, so every step
is exact: ``x_{k+1} = exp(Ā_v τ) x_k``. At each step one of three rules picks the vertex:

* ``'norm'``: the vertex whose step gives the largest ‖x_{k+1}‖ (greedy growth);
* ``'lyapunov'``: the largest ``V(x_{k+1}) = x_{k+1}ᵀPx_{k+1}`` for the given P;
* ``'random'``: a vertex drawn at random.

Each try starts from a random unit x₀. The state is renormalized every step (only the
logarithm of its norm is accumulated), so unstable sets do not overflow. The result is
either "unstable trajectory found" (growth by at least `threshold` and still growing over
the second half of the horizon) or "no counterexample found in N tries"; the latter is
not a proof.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_closed_loops, check_int, check_real, check_symmetric
from ..results import AnalysisResult, VerdictFromCertified

__all__ = ["FalsifierResult", "FALSIFIER_RULES", "falsify"]

Array = NDArray[np.float64]
NDArrayInt = NDArray[np.integer[Any]]

#: Size of a one-dwell transition matrix beyond which the trajectory is not followed in double precision.
FALSIFIER_OVERFLOW = 1e300

#: Vertex-selection rules, tried in turn over the tries.
FALSIFIER_RULES = ("norm", "lyapunov", "random")


@dataclass(frozen=True)
class FalsifierResult(VerdictFromCertified, AnalysisResult):
    """Worst trajectory found.

    Attributes
    ----------
    found : bool
        True when a trajectory grew by at least `threshold` and kept growing.
    growth_factor : float
        Largest ``‖x(T)‖ / ‖x(0)‖`` over the tries (may be ``inf`` for huge growth).
    growth_rate : float
        ``log(growth_factor) / T`` of that trajectory, 1/s (positive means growth).
    late_rate : float
        Its growth rate over the second half of the horizon, 1/s.
    rule : str
        Rule that produced it.
    sequence : ndarray of int, shape (n_steps,)
        Vertex index held at each step.
    x0 : ndarray, shape (n,)
        Its unit initial state.
    n_tries : int
    horizon : float
        T, s.
    dwell : float
        τ, s.
    overflow : bool
        True when some vertex's transition matrix over one dwell exceeds 1e300 (double
        precision cannot follow the trajectory): held there, ‖x‖ grows beyond 1e300
        within one dwell. `sequence` then holds that vertex, `growth_rate` its frozen
        growth rate (largest real part of its eigenvalues) and `growth_factor` is inf.
    """

    found: bool
    growth_factor: float
    growth_rate: float
    late_rate: float
    rule: str
    sequence: NDArrayInt
    x0: Array
    n_tries: int
    horizon: float
    dwell: float
    overflow: bool = False

    @property
    def certified(self) -> bool | None:
        """False when a destabilizing signal was found, else None (a search proves nothing)."""
        return False if self.found else None

    @property
    def verdict(self) -> str:
        """``'unstable trajectory found'``, ``'growth below the detection threshold'`` (‖x‖ grew, by less
        than the threshold) or ``'no counterexample found'``."""
        if self.found:
            return "unstable trajectory found"
        return "growth below the detection threshold" if self.growth_rate > 0 else "no counterexample found"

    def _factor(self) -> str:
        # beyond double precision the factor is still known through its logarithm
        if math.isfinite(self.growth_factor):
            return f"{self.growth_factor:.3g}"
        return f"a factor of 10^{self.growth_rate * self.horizon / math.log(10):.0f}"

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.overflow:
            return (
                f"unstable trajectory found: ‖x‖ grows beyond {FALSIFIER_OVERFLOW:.0e} within one dwell of "
                f"{self.dwell:g} s at vertex {int(self.sequence[0])} "
                f"(its frozen growth rate {self.growth_rate:.4g} 1/s)"
            )
        if self.found:
            return (
                f"unstable trajectory found: ‖x‖ grew by {self._factor()} in {self.horizon:g} s "
                f"(rate {self.growth_rate:.4g} 1/s, rule '{self.rule}')"
            )
        return (
            f"no counterexample found in {self.n_tries} tries (worst growth factor {self.growth_factor:.3g} "
            f"over {self.horizon:g} s)"
        )


def _overflow(A_v: Array, vertices: NDArrayInt, n_tries: int, horizon: float, dwell: float) -> FalsifierResult:
    rates = np.linalg.eigvals(A_v[vertices]).real.max(axis=1)
    worst = int(np.argmax(rates))
    return FalsifierResult(
        found=True,
        growth_factor=math.inf,
        growth_rate=float(rates[worst]),
        late_rate=float(rates[worst]),
        rule="overflow",
        sequence=np.full(1, vertices[worst], dtype=np.int64),
        x0=np.zeros(A_v.shape[1]),
        n_tries=n_tries,
        horizon=horizon,
        dwell=dwell,
        overflow=True,
    )


def falsify(
    closed_loops: ArrayLike,
    P: ArrayLike | None = None,
    *,
    dwell: float = 0.01,
    horizon: float = 5.0,
    n_tries: int = 30,
    threshold: float = 10.0,
    seed: int = 0,
) -> FalsifierResult:
    """Look for a switching signal among vertices that makes ‖x‖ grow.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        Vertices Ā_v of the uncertainty set (e.g. ``scara_robust.robustness.polytope.box_closed_loops``).
    P : array_like, shape (n, n), optional
        Lyapunov matrix for the ``'lyapunov'`` rule (skipped without it).
    dwell : float
        Time each vertex is held, s (> 0).
    horizon : float
        Length of each trajectory, s (>= 2·dwell).
    n_tries : int
        Trajectories to try (>= 1), spread over the rules.
    threshold : float
        Growth factor of ‖x‖ that counts as unstable (> 1).
    seed : int
        Seed of the random initial states and random switching.

    Returns
    -------
    FalsifierResult

    See Also
    --------
    lmi_certificate : the certificate the falsifier tries to contradict.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> A1 = np.array([[-0.1, 1.0], [-10.0, -0.1]]); A2 = np.array([[-0.1, 10.0], [-1.0, -0.1]])
    >>> sr.falsify(np.array([A1, A2]), horizon=20.0).found
    True
    """
    A_v = check_closed_loops("closed_loops", closed_loops)
    n_v, n = A_v.shape[0], A_v.shape[1]
    dwell = check_real("dwell", dwell, positive=True)
    horizon = check_real("horizon", horizon, positive=True)
    threshold = check_real("threshold", threshold, minimum=1.0)
    if horizon < 2 * dwell:
        raise ValueError(f"`horizon` must be at least 2 * dwell = {2 * dwell:g} s, found {horizon:g}")
    n_tries = check_int("n_tries", n_tries, 1)
    rules = list(FALSIFIER_RULES)
    P_sym = np.eye(n)
    if P is not None:
        P_sym = check_symmetric("P", check_array("P", P, shape=(n, n)))
    else:
        rules.remove("lyapunov")
    steps = int(round(horizon / dwell))
    half = steps // 2
    with np.errstate(over="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an overflow is a result here, reported below
        Phi = scipy.linalg.expm(A_v * dwell)  # (V, n, n), exact over one dwell
    huge = ~(np.abs(Phi).max(axis=(1, 2)) <= FALSIFIER_OVERFLOW)
    if huge.any():
        return _overflow(A_v, np.flatnonzero(huge), int(n_tries), steps * dwell, dwell)
    # each rule's value of vertex v is a quadratic form of x, xᵀ G_v x with G_v = Φ_vᵀ W Φ_v (W = I for
    # 'norm', P for 'lyapunov'): on the products x_i x_j (i <= j) one matrix product gives every vertex's
    pairs = np.triu_indices(n)
    twice = np.where(pairs[0] == pairs[1], 1.0, 2.0)

    def forms(W: Array) -> Array:
        G = np.swapaxes(Phi, 1, 2) @ W @ Phi  # (V, n, n)
        return np.ascontiguousarray((G[:, pairs[0], pairs[1]] * twice).T)  # (n(n+1)/2, V)

    products = {"norm": forms(np.eye(n)), "lyapunov": forms(P_sym), "random": None}
    # the draws in the order of one try after the other (a start, then a random try's vertices), so the
    # tries are those of a loop over them; they then run side by side, grouped by rule
    rng = np.random.default_rng(seed)
    rule_of = [rules[trial % len(rules)] for trial in range(int(n_tries))]
    order = np.array([trial for rule in rules for trial, r in enumerate(rule_of) if r == rule], dtype=np.int64)
    place = np.argsort(order)  # trial -> its row in the side-by-side arrays
    starts = np.empty((int(n_tries), n))
    sequences = np.zeros((int(n_tries), steps), dtype=np.int64)
    for trial, rule in enumerate(rule_of):
        draw: Array = rng.normal(size=(n,))
        starts[place[trial]] = draw / np.linalg.norm(draw)
        if rule == "random":
            sequences[place[trial]] = rng.integers(n_v, size=steps)
    groups, first = [], 0
    for rule in rules:
        count = rule_of.count(rule)
        groups.append((slice(first, first + count), products[rule]))
        first += count
    log_norm, log_half = _follow(groups, pairs, Phi, starts, sequences, half)
    log_norm, log_half, sequences, starts = log_norm[place], log_half[place], sequences[place], starts[place]
    best: tuple[float, float, str, NDArrayInt, Array] | None = None
    for trial in range(int(n_tries)):
        if best is None or log_norm[trial] > best[0]:
            best = (float(log_norm[trial]), float(log_norm[trial] - log_half[trial]), rule_of[trial],
                    sequences[trial], starts[trial])
    assert best is not None
    worst, late, rule, worst_sequence, x0 = best
    late_rate = late / ((steps - half) * dwell)
    return FalsifierResult(
        found=bool(worst >= np.log(threshold) and late_rate > 0),
        growth_factor=float(np.exp(worst)) if worst < 700 else float("inf"),
        growth_rate=float(worst / (steps * dwell)),
        late_rate=float(late_rate),
        rule=rule,
        sequence=worst_sequence,
        x0=x0,
        n_tries=int(n_tries),
        horizon=steps * dwell,
        dwell=dwell,
    )


def _follow(groups: list[tuple[slice, Array | None]], pairs: tuple[NDArrayInt, NDArrayInt], Phi: Array,
            starts: Array, sequences: NDArrayInt, half: int) -> tuple[Array, Array]:
    """Run every try side by side: their log-norms at the end and half-way; the vertices are written in place.

    Each step, every try's vertex is chosen as that try alone would choose it (the largest
    ``xᵀ G_v x`` over the vertices, or the drawn one) and its state advanced by ``Φ_v``; a try
    whose state reaches 0 or overflows stops there, with a log-norm of −inf or +inf.

    Parameters
    ----------
    groups : list of (slice, ndarray or None)
        Per rule, its tries (a slice of the rows of `starts`) and its quadratic forms as the
        coefficients of the products ``x_i x_j`` (i <= j), shape (n(n+1)/2, V); None for
        ``'random'``, whose vertices are drawn already.
    pairs : tuple of ndarray of int
        The (i, j) of those products, ``numpy.triu_indices(n)``.
    Phi : ndarray, shape (V, n, n)
        One dwell's transition matrices.
    starts : ndarray, shape (T, n)
    sequences : ndarray of int, shape (T, n_steps)
        The random tries' drawn vertices; the others' are written.
    half : int
        The step after which the half-way log-norm is taken.

    Returns
    -------
    log_norm, log_half : ndarray, shape (T,)
    """
    n_tries, steps = sequences.shape
    X = starts.copy()  # (T, n): the tries' states, rows
    logs = np.zeros(n_tries)
    halves = np.zeros(n_tries)
    alive = np.ones(n_tries, dtype=bool)
    first, second = pairs
    chosen = [(tries, forms) for tries, forms in groups if forms is not None]
    with np.errstate(divide="ignore", invalid="ignore"):  # a state at 0 or beyond double precision: handled below
        for k in range(steps):
            v = sequences[:, k]
            if chosen:
                products = X[:, first] * X[:, second]  # every try's x_i x_j, i <= j
                for tries, forms in chosen:
                    v[tries] = (products[tries] @ forms).argmax(axis=1)
            X = (Phi[v] @ X[:, :, None])[:, :, 0]
            size = np.sqrt(np.einsum("ij,ij->i", X, X))
            step = np.log(size)
            if math.isfinite(step.sum()):  # every try's state finite and nonzero (a sum of logs of norms: no overflow)
                logs += step
            else:  # a try has stopped (or stops here)
                ended = alive & ((size == 0.0) | ~np.isfinite(size))
                logs[ended] = np.where(size[ended] == 0.0, -math.inf, math.inf)
                alive &= ~ended
                if not alive.any():
                    break
                size[~alive] = 1.0
                X[~alive] = 0.0
                logs[alive] += np.log(size[alive])
            X /= size[:, None]
            if k + 1 == half:  # a try that has stopped keeps 0, as it would alone
                halves[alive] = logs[alive]
    return logs, halves
