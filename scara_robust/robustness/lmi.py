"""A common quadratic Lyapunov function found by semidefinite programming (extra ``lmi``).

Theorem 1 and the vertex test use the P of the design procedure. When they fail, another
P may still prove stability. This module searches for one over the vertices Ā_v of a
polytope (the interval box, or the physical samples) with cvxpy:

    minimize  λ   subject to   P ⪰ I,   P ⪯ λI,   Ā_vᵀP + PĀ_v ⪯ −I   for every v.

A feasible P gives ``V̇ ≤ −‖x‖² ≤ −V/λmax(P)`` on the whole polytope, so V decays at
least as ``exp(−t/λmax(P))`` and the state as ``exp(−αt)``, ``α = 1/(2λmax(P))``. Every
decay rate this package reports is that state decay rate α, with ``V̇ ≤ −2αV``. The
solver's answer is never taken on its word: the returned P is checked with numpy
(symmetric, positive definite, every vertex's ``λmax(Ā_vᵀP + PĀ_v) < 0``), and the reported
margin comes from that check.

The problem has one constraint per vertex, and the SCARA's box has 1024 of them. It is solved
by cutting planes (:mod:`scara_robust.robustness._cutting`): on a few vertices at a time, the
vertices numpy finds violated joining them, until P holds at every vertex; one cvxpy problem
per size (its matrices as parameters) serves every solve of a search, and a search
(:func:`lmi_search`) starts each solve from the vertices that bounded the last one. Near the
end of what a common P certifies, P's condition number grows without bound and the solver
may fail on this form; the equivalent ``maximize t: tI ⪯ P ⪯ I, Ā_vᵀP + PĀ_v ⪯ −tI`` stays
well conditioned there and is tried before an answer is given up (:data:`LMI_FORMS`).

cvxpy is optional (``pip install ".[lmi]"``); without it every function here
returns a result whose status is ``'not installed'``.
"""

from __future__ import annotations

import functools
import hashlib
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_field
from .._validation import check_array, check_choice, check_closed_loops
from ..exceptions import ArgumentValueError
from ..results import AnalysisResult
from ..sdp import LMIProblem, LMIVariable, solve_lmi
from ..sdp._linalg import _factors
from ..sdp.backends import resolve_lmi_solver
from ._cutting import ACTIVE_BATCH, grow_active_set
from ._spectra import _by_parts, largest_eigenvalue

__all__ = ["LMICertificate", "LMI_SOLVERS", "LMI_STOPS", "LMI_VERDICTS", "cvxpy_available", "decay_rate",
           "lmi_certificate", "lmi_search", "verify_lyapunov"]

Array = NDArray[np.float64]

#: The LMI solvers: the package's own interior-point method (:func:`~scara_robust.solve_lmi`),
#: then cvxpy's Clarabel (interior-point, the reference) and SCS (first-order), extra ``lmi``.
LMI_SOLVERS = ("IPM", "CLARABEL", "SCS")
#: Status reported when cvxpy cannot be imported.
NOT_INSTALLED = "not installed"

#: What an LMI answer proves, once numpy has checked it: ``'certified'`` (numpy verified the
#: matrix the solver returned), ``'infeasible'`` (the solver returned a certificate of
#: infeasibility and numpy verified it, where the problem gives one: :func:`lmi_certificate`;
#: a certificate numpy rejects, as on an ill-conditioned problem, is ``'unknown'``),
#: ``'marginal'`` (verified, but with a decay rate below
#: :func:`decay_floor`, within the solver's tolerances of zero), ``'inaccurate'`` (the
#: solver returned an answer, "optimal" or
#: "inaccurate", that numpy rejects, or an inaccurate infeasibility) or ``'unknown'`` (no
#: answer: solver error, iteration limit, cvxpy not installed). Only the first two are
#: facts; a search (bisection) stops at the last two and says so.
LMI_VERDICTS = ("certified", "marginal", "infeasible", "inaccurate", "unknown")


#: The status of a solver's "infeasible" whose certificate of infeasibility numpy rejects.
INFEASIBLE_NOT_VERIFIED = "infeasible, certificate not verified"

#: A verified decay rate below this fraction of the closed loops' largest spectral norm
#: (1/s) is within the solver's tolerances of zero: reported as ``'marginal'``, not certified.
DECAY_FLOOR_RTOL = 1e-8


def decay_floor(closed_loops: ArrayLike) -> float:
    """The smallest decay rate (1/s) reported as certified for these closed loops.

    ``DECAY_FLOOR_RTOL · max_i ‖A_i‖₂``: the LMIs are solved to relative tolerances of
    about 1e-8, so a decay rate smaller than that fraction of the loops' own rates says
    nothing a solver's rounding could not change.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)

    Returns
    -------
    float
        1/s.
    """
    A = check_array("closed_loops", closed_loops, ndim=3)
    return float(DECAY_FLOOR_RTOL * _largest_spectral_norm(A))


def _largest_spectral_norm(A: Array) -> float:
    """``max_i ‖A_i‖₂`` as ``numpy.linalg.norm(A, 2, axis=(1, 2)).max()`` gives it, from a few SVDs.

    ``‖A_i‖₂ <= ‖A_i‖_F``, so a loop whose Frobenius norm is below a 2-norm already computed
    cannot be the largest: the 2-norms are computed in decreasing Frobenius norm, in batches,
    until the next one's Frobenius norm is below the best (the same SVDs of the same matrices).
    """
    if A.shape[0] == 0 or not np.isfinite(A).all():  # what numpy says of these, as before
        return float(np.linalg.norm(A, 2, axis=(1, 2)).max())
    frobenius = np.linalg.norm(A, axis=(1, 2))
    order = np.argsort(-frobenius, kind="stable")
    best, done = -np.inf, 0
    while done < len(order) and frobenius[order[done]] >= best:
        batch = order[done:done + 8]
        best = max(best, float(np.linalg.norm(A[batch], 2, axis=(1, 2)).max()))
        done += len(batch)
    return best


def solver_said(status: str) -> str:
    """A solver's status without an answer, in words (``'infeasible_inaccurate'``, ``'solver error: ...'``).

    Parameters
    ----------
    status : str
        As for :func:`lmi_verdict`.

    Returns
    -------
    str
        What the status means for the question, e.g. ``"the solver stopped on a numerical
        failure: neither an answer nor a proof that none exists"``.

    Examples
    --------
    >>> from scara_robust.robustness.lmi import solver_said
    >>> said = solver_said("solver error: Solver 'CLARABEL' failed. Try another solver, or solve with verbose=True.")
    >>> said.split(": ")[0]
    "the solver stopped on a numerical failure (Solver 'CLARABEL' failed)"
    """
    unproven = "neither an answer nor a proof that none exists"
    if status.startswith("solver error"):
        # the solver's own words, without cvxpy's advice to the programmer
        detail = status.partition(":")[2].split(" Try another solver")[0].strip().rstrip(".")
        return f"the solver stopped on a numerical failure{f' ({detail})' if detail else ''}: {unproven}"
    if status == "infeasible_inaccurate":
        return f"the solver found the LMI infeasible only to a loose tolerance (infeasible_inaccurate): {unproven}"
    if status in ("unbounded", "unbounded_inaccurate"):
        return f"the solver found the LMI unbounded ({status}), which a well-posed LMI is not: {unproven}"
    if status == INFEASIBLE_NOT_VERIFIED:
        return f"the solver said infeasible, but its certificate fails numpy's check: {unproven}"
    return f"the solver said {status}: {unproven}"


def lmi_verdict(status: str, verified: bool) -> str:
    """What an LMI answer proves (one of :data:`LMI_VERDICTS`).

    Parameters
    ----------
    status : str
        The solver's status as cvxpy reports it (``'optimal'``, ``'infeasible'``,
        ``'optimal_inaccurate'``, ...), ``'solver error: ...'`` or ``'not installed'``.
    verified : bool
        numpy's check of the returned matrix passed.

    Returns
    -------
    str

    Examples
    --------
    >>> from scara_robust.robustness.lmi import lmi_verdict
    >>> lmi_verdict("optimal", True), lmi_verdict("optimal", False), lmi_verdict("infeasible", False)
    ('certified', 'inaccurate', 'infeasible')
    """
    if verified:
        return "certified"
    if status == "infeasible":
        return "infeasible"
    if status == INFEASIBLE_NOT_VERIFIED:
        return "unknown"
    if status in ("optimal", "optimal_inaccurate", "infeasible_inaccurate"):
        return "inaccurate"
    return "unknown"


def cvxpy_available() -> bool:
    """True when cvxpy can be imported (the ``lmi`` extra is installed).

    Returns
    -------
    bool

    Examples
    --------
    >>> import scara_robust as sr
    >>> isinstance(sr.cvxpy_available(), bool)
    True
    """
    try:
        import cvxpy  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class LMICertificate(AnalysisResult):
    """Result of the LMI search, verified independently.

    Attributes
    ----------
    status : str
        The solver's status (``'optimal'``, ``'infeasible'``, ...) or ``'not installed'``.
    solver : str
    P : ndarray, shape (n, n), or None
        The Lyapunov matrix returned (None when the solver found none).
    max_vertex_eig : float
        numpy's ``max_v λmax(Ā_vᵀP + PĀ_v)`` (NaN without P).
    decay_rate : float
        Verified decay rate α of ``V = xᵀPx``, 1/s (``V̇ <= −2αV``): :func:`decay_rate` of P on
        every loop, ``min_v −λmax(P^{-1/2}(Ā_vᵀP + PĀ_v)P^{-1/2}) / 2`` (``-inf`` when P is not
        positive definite, NaN without P). Positive means certified.
    n_vertices : int
    floor : float
        The smallest decay rate reported as certified (:func:`decay_floor`), 1/s.
    active : ndarray of int, shape (V_active,), or None
        The loops the last LMI was solved on (the cutting planes' active set); a search on
        loops indexed alike starts its next solve from them.
    unstable_loop : int or None
        A closed loop numpy finds unstable (an eigenvalue with a positive real part): the
        proof of infeasibility when the solver's own certificate fails numpy's check.
    """

    status: str
    solver: str
    P: Array | None
    max_vertex_eig: float
    decay_rate: float
    n_vertices: int
    floor: float = 0.0
    active: NDArray[np.int64] | None = field(default=None, repr=False, compare=False)
    unstable_loop: int | None = None

    margin = renamed_field("margin", "decay_rate")

    @property
    def certified(self) -> bool:
        """True only when numpy confirms P ≻ 0 and a decay rate above the floor."""
        return bool(self.decay_rate > 0 and self.decay_rate >= self.floor)

    @property
    def verdict(self) -> str:
        """What the answer proves: one of :data:`LMI_VERDICTS`."""
        if not self.certified and self.decay_rate > 0:
            return "marginal"
        return lmi_verdict(self.status, self.certified)

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.status == NOT_INSTALLED:
            return "cvxpy is not installed (pip install '.[lmi]')"
        if self.certified:
            note = f" (the solver said {self.status}; numpy's check passed)" if self.status != "optimal" else ""
            return (f"common quadratic Lyapunov P found and verified; decay rate α >= {self.decay_rate:.4g} 1/s "
                    f"(V̇ <= −2αV){note}")
        if self.verdict == "marginal":
            return (f"marginal, not certified: numpy verifies a decay rate of only {self.decay_rate:.3g} 1/s, "
                    f"below the floor {self.floor:.3g} 1/s ({DECAY_FLOOR_RTOL:g} of the loops' norm)")
        if self.verdict == "infeasible" and self.unstable_loop is not None:
            return (f"no common quadratic Lyapunov P exists: closed loop {self.unstable_loop} is unstable "
                    "(numpy's eigenvalues)")
        if self.verdict == "infeasible":
            return f"no common quadratic Lyapunov P exists ({self.solver} proved the LMI infeasible)"
        if self.status == INFEASIBLE_NOT_VERIFIED:
            return (f"unknown: {self.solver} said infeasible, but its certificate of infeasibility fails numpy's "
                    "check (an ill-conditioned problem): neither feasibility nor infeasibility is proven")
        if self.P is None:
            return f"no answer: {self.solver} said {self.status}; neither feasibility nor infeasibility is proven"
        return (f"{self.solver} returned a P ({self.status}) that fails numpy's check: inaccurate, "
                "neither feasibility nor infeasibility is proven")


def verify_lyapunov(closed_loops: ArrayLike, P: ArrayLike) -> tuple[float, float]:
    """Check a Lyapunov matrix on every vertex with numpy alone.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    P : array_like, shape (n, n)

    Returns
    -------
    max_vertex_eig : float
        ``max_v λmax(Ā_vᵀP + PĀ_v)``.
    margin : float
        The state decay rate α it proves, ``−max_vertex_eig / (2 λmax(P))`` (1/s,
        ``V̇ <= −2αV``), when P is symmetric positive definite (negative when it proves
        nothing); ``-inf`` when P is not positive definite or not symmetric.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> box = sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
    ...                            (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))
    >>> d = sr.design(box, 1.0, 2.0)
    >>> max_eig, rate = sr.verify_lyapunov(np.array([d.A_cl]), d.P)
    >>> bool(max_eig < 0 and rate > 0)
    True
    """
    A_v = check_array("closed_loops", closed_loops, ndim=3)
    P = check_array("P", P, shape=(A_v.shape[1], A_v.shape[1]))
    scale = max(np.abs(P).max(), 1e-300)

    def largest(stack: Array) -> Array:  # max over the loops of λmax(AᵀP + PA)
        PA = P @ stack
        return np.array([largest_eigenvalue(PA + np.swapaxes(PA, -1, -2))])

    max_vertex_eig = float(_by_parts(largest, A_v).max())
    if not np.allclose(P, P.T, rtol=0.0, atol=1e-9 * scale):
        return max_vertex_eig, -np.inf
    eig_P = np.linalg.eigvalsh(0.5 * (P + P.T))
    if eig_P[0] <= 0:
        return max_vertex_eig, -np.inf
    return max_vertex_eig, -max_vertex_eig / (2 * eig_P[-1])


def decay_rate(closed_loops: ArrayLike, P: ArrayLike) -> float:
    """The decay rate α of ``V = xᵀPx`` guaranteed on the closed loops, checked with numpy alone.

    ``α = min_i −λmax(P^{-1/2}(A_iᵀP + PA_i)P^{-1/2}) / 2``: ``V̇ <= −2αV`` at every A_i
    (hence on their convex hull). Negative means not certified; ``-inf`` if P is not
    symmetric positive definite.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    P : array_like, shape (n, n)

    Returns
    -------
    float
        1/s.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> box = sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
    ...                            (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))
    >>> d = sr.design(box, 1.0, 2.0)
    >>> bool(sr.decay_rate(np.array([d.A_cl]), d.P) > 0)   # V = xᵀPx decays on the nominal loop
    True
    """
    A = check_array("closed_loops", closed_loops, ndim=3)
    P = check_array("P", P, shape=(A.shape[1], A.shape[1]))
    if not np.allclose(P, P.T, rtol=1e-9, atol=1e-12 * float(np.abs(P).max())):
        return -math.inf
    w, V = np.linalg.eigh(0.5 * (P + P.T))
    if w[0] <= 0:
        return -math.inf
    root_inv = V @ np.diag(w**-0.5) @ V.T

    def largest(stack: Array) -> Array:  # max over the loops of λmax(P^{-1/2}(AᵀP + PA)P^{-1/2})
        PA = P @ stack
        return np.array([largest_eigenvalue(root_inv @ (PA + np.swapaxes(PA, -1, -2)) @ root_inv)])

    # the loops split between the cores, each loop the same calls: the same values, and the same largest
    return float(-_by_parts(largest, A).max() / 2)


def farkas_certificate_holds(closed_loops: ArrayLike, duals: list[ArrayLike | None]) -> bool:
    """numpy's check of a solver's proof that no common P exists.

    No ``P ≻ 0`` with ``Ā_vᵀP + PĀ_v ≺ 0`` at every vertex exists when matrices ``Y_v ⪰ 0``
    give ``S = Σ_v (Ā_vY_v + Y_vĀ_vᵀ) ≻ 0``: then ``Σ_v tr((Ā_vᵀP + PĀ_v)Y_v) = tr(PS) > 0``
    for every ``P ≻ 0``, while each term is ``<= 0`` (Boyd et al. 1994, §2.2.3, the theorem of
    alternatives). The solver's dual values of the vertex constraints are such ``Y_v``; they
    are projected on the positive semidefinite cone (their tiny negative eigenvalues set to
    0), and S is checked to be positive definite.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    duals : list of array_like, shape (n, n), or None
        One per vertex, as cvxpy returns them for an infeasible problem.

    Returns
    -------
    bool
        True when the certificate proves infeasibility; False when it is missing or fails.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[[1.0]], [[-1.0]]])       # ẋ = x at one vertex: unstable, no P exists
    >>> farkas_certificate_holds(A, [np.eye(1), np.zeros((1, 1))])
    True
    """
    A_v = check_array("closed_loops", closed_loops, ndim=3)
    if len(duals) != A_v.shape[0] or any(y is None for y in duals):
        return False
    S = np.zeros(A_v.shape[1:])
    for A, y in zip(A_v, duals):
        Y = np.asarray(y, dtype=float)
        w, V = np.linalg.eigh(0.5 * (Y + Y.T))
        Y = (V * np.clip(w, 0.0, None)) @ V.T
        S += A @ Y + Y @ A.T
    eig = np.linalg.eigvalsh(0.5 * (S + S.T))
    return bool(eig[-1] > 0 and eig[0] > VERIFY_FARKAS_RTOL * eig[-1])


#: The smallest eigenvalue of S, relative to its largest, that proves infeasibility.
VERIFY_FARKAS_RTOL = 1e-9


#: How a cutting-plane solve of :func:`lmi_certificate` stops, by name: ``'optimum'`` when the P of
#: the active loops meets every loop's constraint of the whole problem (its optimum, to
#: :data:`OPTIMUM_RTOL`); ``'verified'`` as soon as numpy verifies it on every loop (a bisection needs
#: only the verdict); ``'probe'`` as ``'verified'``, and also, with the package's solver, as soon as its
#: dual bound shows no P with t above :data:`PROBE_MARGIN` (a search's step, not a proof: the answer is
#: then ``'infeasible, certificate not verified'``).
LMI_STOPS = ("optimum", "verified", "probe")

#: A ``'probe'`` stops without a P once the solver's dual bound puts the always-feasible form's t*
#: (:func:`common_p_problem`, on loops scaled to entries of at most one) at or below this: the
#: bound at which a finished solve's t is taken as no strictly feasible P
#: (:data:`MARGIN_FEASIBILITY_TOL`), so a probe reaches the verdict a finished solve would, earlier.
#: Not a larger one: t* is also P's smallest eigenvalue, and a feasible LMI's t* can be 5e-8 (the
#: SO-101's 95 plants). On a probe without a P, t* = 0 is attained at P = 0, a degenerate point the
#: solver approaches slowly (the 6-joint arm's decay probe above its optimum: 54 iterations to the
#: end, 42 to this bound).
PROBE_MARGIN = 1e-9

#: A loop outside the active set whose ``λmax(Āᵀ P + P Ā)`` (in the solver's scaled units, where
#: the constraint is ``⪯ −I``) exceeds ``−1 + OPTIMUM_RTOL`` joins it, with ``stop='optimum'``.
OPTIMUM_RTOL = 1e-6

#: Up to this many closed loops the LMI is solved on all of them at once (cvxpy's solvers).
DIRECT_LOOPS = 16
#: The same with the package's solver on more than :data:`SMALL_STATES` states, whose iteration
#: costs a matrix product over the loops (the arms' 95 samples of 18 or 21 states: one solve
#: instead of rounds); the check sets still join by cutting planes.
IPM_DIRECT_LOOPS = 2048

#: Loops added per round where the state has at most :data:`SMALL_STATES` entries: a solve is
#: cheap there (7–55 ms for 8–64 loops of 6 states), so fewer loops a round keep the active set,
#: and each later solve, small (the SCARA's margin command: 4.2 s against 5.1 s with 8 a round).
#: An 18-state solve costs 0.7–1.5 s, and :data:`~scara_robust.robustness._cutting.ACTIVE_BATCH`
#: a round needs fewer of them (the 6-joint arm's decay LMI: 6.8 s against 8.8 s with 4).
SMALL_BATCH = 4
#: States up to which a solve is cheap enough for rounds of :data:`SMALL_BATCH` loops, each cut as
#: soon as the package's solver has a strictly feasible P of the active loops that a loop outside
#: rejects (the SCARA's margin command: its LMI solves 0.55 s → 0.31 s, the same table).
SMALL_STATES = 8


def lmi_certificate(closed_loops: ArrayLike, *, check: Sequence[ArrayLike] = (), solver: str | None = None,
                    stop: str = "optimum", start: ArrayLike | None = None) -> LMICertificate:
    """Search a common quadratic Lyapunov matrix for the polytope ``conv{Ā_v}``.

    The LMI is solved by cutting planes: on a small active set of the loops, grown by the
    :data:`ACTIVE_BATCH` loops the last P violates most, until P holds on every loop. The
    answer is checked by numpy on every loop, exactly as a solve on all of them at once; a
    proof of infeasibility on the active set is one for the whole set.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        Frozen closed-loop matrices at the vertices, e.g. from
        ``scara_robust.robustness.polytope.box_closed_loops``.
    check : sequence of array_like, shape (V_k, n, n)
        Further closed loops on which P must also verify (a finer sampling): a check loop
        joins the active set only where numpy finds P's decay rate on it below the floor.
        :attr:`LMICertificate.decay_rate` is the smallest over the loops and the checks.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    stop : {'optimum', 'verified', 'probe'}
        ``'optimum'``: grow the active set until P meets every loop's constraint
        (``Āᵀ P + P Ā ⪯ −I`` to :data:`OPTIMUM_RTOL`), so P is the optimum of the problem on all
        of `closed_loops`; ``'verified'``: stop at the first P numpy verifies on every loop (a
        bisection needs only the verdict; the decay rate may be smaller); with the package's
        solver on at most :data:`SMALL_STATES` states, a round also stops at the first P the
        active loops' LMI holds strictly that a loop outside rejects, and adds the loops it
        violates most (a cut without the active set's optimum); ``'probe'``: as ``'verified'``, and
        with the package's solver it also stops without a P once its dual bound shows the
        always-feasible form's t* at most :data:`PROBE_MARGIN` (a search's step: no P found, not
        proven infeasible). Either way the
        ``'decay'`` form of :data:`LMI_FORMS` is solved; where it fails numerically (not where
        the solver says infeasible), the ``'margin'`` form is tried (its P is returned when it
        certifies).
    start : array_like of int, optional
        Indices of the loops to start from, the checks counted after `closed_loops`
        (:attr:`LMICertificate.active` of the previous solve of a search on loops indexed
        alike); default: the least stable loop of `closed_loops`.

    Returns
    -------
    LMICertificate
        Status ``'not installed'`` when cvxpy is missing.

    See Also
    --------
    verify_lyapunov : numpy's check of the returned P.
    vertex_certificate : the design's own P.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> A = np.array([[[-1.0, 0.0], [0.0, -2.0]], [[-1.0, 0.5], [0.0, -2.0]]])
    >>> sr.lmi_certificate(A).certified
    True
    """
    solver = resolve_lmi_solver(solver)
    A_main = check_closed_loops("closed_loops", closed_loops)
    checks = [check_array(f"check[{k}]", c, shape=(None, *A_main.shape[1:])) for k, c in enumerate(check)]
    A_v = np.concatenate([A_main, *checks]) if checks else A_main
    check_choice("stop", stop, LMI_STOPS)
    given = None if start is None else _start_indices(start, A_v.shape[0])
    if not cvxpy_available():
        return LMICertificate(NOT_INSTALLED, solver, None, np.nan, np.nan, A_v.shape[0])
    # one command asks the same question twice (its table's LMI row, then the design's decay
    # rate): the answer for the same closed loops is kept, read-only
    key = (hashlib.sha256(np.ascontiguousarray(A_v).tobytes()).hexdigest(), A_v.shape, A_main.shape[0], solver, stop)
    if key not in _SOLVED:
        if len(_SOLVED) >= _SOLVED_SIZE:
            _SOLVED.pop(next(iter(_SOLVED)))
        # default start: the least stable loop of `closed_loops`
        first = np.array([int(np.argmax(np.linalg.eigvals(A_main).real.max(axis=1)))]) if given is None else given
        found = _cutting_planes(A_v, A_main.shape[0], solver, stop, first, "decay")
        if (solver != "IPM" and not found.certified and found.verdict != "infeasible"
                and found.status != INFEASIBLE_NOT_VERIFIED):
            # the 'decay' form breaks down where P's condition number grows without bound, near the
            # end of what a common P can certify: where it failed numerically (a solver error, an
            # inaccurate or marginal P), not where the solver said infeasible, the well-conditioned
            # 'margin' form may still find one
            retry = _cutting_planes(A_v, A_main.shape[0], solver, "verified", first, "margin")
            if retry.certified or (found.P is None and retry.P is not None):
                found = retry
        _SOLVED[key] = found
    return _SOLVED[key]


#: Answers of :func:`lmi_certificate` kept for the same closed loops, checks, solver and stop.
_SOLVED: dict[tuple[str, tuple[int, ...], int, str, str], LMICertificate] = {}
_SOLVED_SIZE = 16


def _start_indices(start: ArrayLike, n_loops: int) -> NDArray[np.int64]:
    """`start` as sorted unique indices of the loops and checks, or raise naming it."""
    values = check_array("start", start, ndim=1)
    idx = np.unique(values.astype(np.int64))
    if idx.size == 0 or idx[0] < 0 or idx[-1] >= n_loops or not np.array_equal(values, np.round(values)):
        raise ArgumentValueError("start", f"must hold indices of the loops and checks in [0, {n_loops}), "
                                          f"found {idx.tolist()[:8]}")
    return idx


#: A real part of an eigenvalue above this fraction of the loop's norm is unstable beyond rounding.
UNSTABLE_RTOL = 1e-9


def _unstable_loop(A_v: Array) -> int | None:
    """The most unstable closed loop, if one has an eigenvalue with a real part clearly above 0."""
    abscissa = np.linalg.eigvals(A_v).real.max(axis=1) / np.linalg.norm(A_v, 2, axis=(1, 2))
    worst = int(np.argmax(abscissa))
    return worst if abscissa[worst] > UNSTABLE_RTOL else None


def _cutting_planes(A_v: Array, n_main: int, solver: str, stop: str, first: NDArray[np.int64],
                    form: str) -> LMICertificate:
    n_loops = A_v.shape[0]
    # Scaling the loops by a positive constant leaves feasibility unchanged and keeps
    # the right-hand sides commensurate with the data.
    scale = float(np.abs(A_v).max()) or 1.0
    A_s = A_v / scale
    floor = decay_floor(A_v[:n_main])

    def violation(P: Array) -> Array:
        if stop != "optimum" and holds(P):
            return np.full(n_loops, -np.inf)  # no loop violated: their values are not needed
        def largest(stack: Array) -> Array:
            PA = P @ stack
            return np.asarray(np.linalg.eigvalsh(PA + np.swapaxes(PA, -1, -2))[:, -1])

        worst = _by_parts(largest, A_s)  # on the cores, each loop the same calls
        # numpy's own test: the decay rate of every loop above the floor
        verified = worst + 2 * floor * np.linalg.eigvalsh(P)[-1] / scale
        if stop == "optimum":  # the problem's own constraint on the loops, ⪯ −I; the checks verified
            verified[:n_main] = worst[:n_main] + 1.0 - OPTIMUM_RTOL
        return np.asarray(verified)

    def holds(P: Array, loops: Array | None = None) -> bool:
        """``violation(P) < 0`` on every loop (or on `loops`, some of them), by one stacked Cholesky factorization."""
        shift = 2 * floor * np.linalg.eigvalsh(P)[-1] / scale * np.eye(P.shape[0])

        def factors(stack: Array) -> NDArray[np.bool_]:
            PA = P @ stack
            shifted = -(PA + np.swapaxes(PA, -1, -2)) - shift
            return np.array([bool(np.isfinite(shifted).all()) and _factors(shifted)])

        return bool(_by_parts(factors, A_s if loops is None else loops).all())  # the loops split between the cores

    def solve(idx: NDArray[np.int64]) -> tuple[str, Array | None]:
        if solver == "IPM":
            outside = np.ones(n_loops, dtype=bool)
            outside[idx] = False
            cut_early = A_v.shape[1] <= SMALL_STATES and bool(outside.any())
            A_out, A_in = (A_s[outside], A_s[~outside]) if cut_early else (A_s, A_s)  # taken once a solve

            def accept(P: Array) -> bool:
                # a bisection's question is answered by the first P numpy verifies on every loop; on small
                # states, where a solve is cheap and rounds are many, a P the active loops' LMI holds strictly
                # (t > 0) that a loop outside rejects is a cut to make at once, without going on to the active
                # set's optimum (`violation` then judges it, as every answer)
                if cut_early and not holds(P, A_out):
                    return True
                return holds(P, A_in) if cut_early else holds(P)

            return _solve_common_p_ipm(A_s[idx], accept if stop != "optimum" else None,
                                       reject_below=PROBE_MARGIN if stop == "probe" else None)
        return _solve_common_p(A_s[idx], solver, form)

    batch = ACTIVE_BATCH if A_v.shape[1] > SMALL_STATES else SMALL_BATCH
    # the package's solver costs O(N n⁴) an iteration: on large states every loop at once beats
    # rounds of cutting planes; on small ones a few loops a round stay cheaper
    direct = IPM_DIRECT_LOOPS if solver == "IPM" and A_v.shape[1] > SMALL_STATES else DIRECT_LOOPS
    status, P_val, active = grow_active_set(solve, violation, np.arange(n_main) if n_main <= direct else first,
                                            batch=batch)
    if P_val is None:
        # a verified proof of infeasibility on the active loops is one on all of them; where the
        # solver's proof fails numpy's check, an unstable closed loop is one too
        unstable = _unstable_loop(A_v) if status == INFEASIBLE_NOT_VERIFIED else None
        return LMICertificate("infeasible" if unstable is not None else status, solver, None, np.nan, np.nan,
                              n_loops, active=active, unstable_loop=unstable)
    P_val.setflags(write=False)
    max_vertex_eig, _ = verify_lyapunov(A_v, P_val)
    # the exact rate of V = xᵀPx on the loops, as decay_rate reports it for any P (one question, one number)
    return LMICertificate(status, solver, P_val, max_vertex_eig, decay_rate(A_v, P_val), n_loops, floor, active=active)


#: The two forms of the common-P LMI, by the question they answer: ``'decay'`` minimizes λ with
#: ``I ⪯ P ⪯ λI, Āᵀ P + P Ā ⪯ −I`` (its P gives the reported decay rate); ``'margin'`` maximizes t
#: with ``tI ⪯ P ⪯ I, Āᵀ P + P Ā ⪯ −tI`` (strictly feasible exactly when t* > 0), which stays well
#: conditioned where P's condition number grows without bound, at the end of a margin's bisection.
LMI_FORMS = ("decay", "margin")

#: An optimal t* of the ``'margin'`` form at or below this is no strictly feasible P.
MARGIN_FEASIBILITY_TOL = 1e-9


def _solve_common_p(A_s: Array, solver: str, form: str = "decay") -> tuple[str, Array | None]:
    """One LMI form on the scaled loops `A_s`: (status, P or None); an infeasibility numpy cannot verify is named so."""
    import cvxpy as cp

    n_loops, n = A_s.shape[0], A_s.shape[1]
    problem, P, t, slots = _problem(n, _slot_count(n_loops), form)
    for k, slot in enumerate(slots):
        # a slot left over holds -I: the constraint −2P ⪯ −I (or −tI), strictly implied by P ⪰ I (or tI)
        slot.value = A_s[k] if k < n_loops else -np.eye(n)
    try:
        with warnings.catch_warnings():
            # "Solution may be inaccurate" is reported through the status, not as a warning
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=solver)
    except cp.SolverError as err:
        return f"solver error: {err}", None
    status = str(problem.status)
    if form == "margin" and status == cp.OPTIMAL and t.value is not None and t.value <= MARGIN_FEASIBILITY_TOL:
        status = cp.INFEASIBLE  # P = 0, t = 0 is always feasible: no strictly feasible P
    if status == cp.INFEASIBLE and not farkas_certificate_holds(
            np.array([s.value for s in slots]), [c.dual_value for c in problem.constraints[2:]]):
        status = INFEASIBLE_NOT_VERIFIED
    if P.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return status, None
    return status, np.array(P.value, dtype=float)


def common_p_problem(A_s: Array, *, quadratic: float = 0.0) -> tuple[LMIProblem, LMIVariable, LMIVariable]:
    """The common-P LMI in its always-feasible form, for the package's solver.

    ``maximize t: tI ⪯ P ⪯ I, −(A_iᵀP + PA_i + c A_iᵀPA_i) − tI ⪰ 0`` at every loop, with
    ``c = quadratic`` (0 for continuous time; the sampled-data form's ``Ts``). It is the
    ``'decay'`` form of :data:`LMI_FORMS` with P divided by λ and t = 1/λ, and is strictly
    feasible for every data (t → −∞): t* > 0 exactly when a common P exists.

    Parameters
    ----------
    A_s : ndarray, shape (V, n, n)
    quadratic : float

    Returns
    -------
    problem : LMIProblem
    P, t : LMIVariable
    """
    n = A_s.shape[1]
    eye = np.eye(n)
    problem = LMIProblem()
    P, t = problem.symmetric("P", n), problem.scalar("t")
    problem.add_lmi(terms=[(P, -0.5 * eye, eye)], const=eye, name="P <= I")
    problem.add_lmi(terms=[(P, 0.5 * eye, eye)], scalars=[(t, -eye)], name="P >= tI")
    terms = [(P, -eye, A_s)]  # −(PA + AᵀP): U = −I, V = A
    if quadratic:
        terms.append((P, -0.5 * quadratic * A_s, A_s))  # −c AᵀPA
    problem.add_lmi(terms=terms, scalars=[(t, -eye)], name="loops")
    problem.maximize({t: 1.0})
    return problem, P, t


def _solve_common_p_ipm(A_s: Array, accept: Callable[[Array], bool] | None,
                        quadratic: float = 0.0, reject_below: float | None = None) -> tuple[str, Array | None]:
    """The common-P LMI by the package's solver: (status, P in the 'decay' form's units, or None).

    The 'decay' form's P is the always-feasible form's divided by t (its constraint
    ``AᵀP + PA ⪯ −I``, which the cutting planes' optimum test reads); with `accept`, the
    solver stops at the first P it accepts; with `reject_below`, as soon as its dual bound puts t* at
    or below it (no P found, not proven infeasible).
    """
    problem, P, t = common_p_problem(A_s, quadratic=quadratic)

    def take(y: Array) -> bool:
        t_y = float(y[t.offset])
        return t_y > 0 and accept is not None and accept(P.value(y) / t_y)

    reject = None if reject_below is None else (lambda bound: bound <= reject_below)
    result = solve_lmi(problem, "IPM", accept=take if accept is not None else None, reject=reject)
    if result.status == "rejected":
        return INFEASIBLE_NOT_VERIFIED, None
    if result.y is None:
        return result.status, None
    t_val = result.value(t)
    if t_val <= MARGIN_FEASIBILITY_TOL:
        # P = 0, t = 0 is feasible: no strictly feasible P; the loops' dual blocks are the proof
        duals = None if result.duals is None else list(result.duals[2])
        proven = duals is not None and farkas_certificate_holds(A_s, duals)
        return ("infeasible" if proven else INFEASIBLE_NOT_VERIFIED), None
    return result.status, np.array(result.value(P), dtype=float) / t_val


def _slot_count(n_loops: int) -> int:
    """Constraint slots of the problem for `n_loops` loops: a power of two, so a search reuses a few problems."""
    return max(8, 1 << (n_loops - 1).bit_length())


@functools.lru_cache(maxsize=8)
def _problem(n: int, n_slots: int, form: str) -> tuple[Any, Any, Any, list[Any]]:
    """One of :data:`LMI_FORMS` for `n_slots` parameters A_k, built once (cvxpy DPP): problem, P, λ or t, slots."""
    import cvxpy as cp

    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    eye = np.eye(n)
    slots = [cp.Parameter((n, n)) for _ in range(n_slots)]
    if form == "decay":
        constraints, bound, objective = [P >> eye, P << t * eye], -eye, cp.Minimize(t)
    else:
        constraints, bound, objective = [P << eye, P >> t * eye], -t * eye, cp.Maximize(t)
    for A in slots:
        lhs = A.T @ P + P @ A
        constraints.append(0.5 * (lhs + lhs.T) << bound)
    return cp.Problem(objective, constraints), P, t, slots

def lmi_search(*, solver: str | None = None, stop: str = "verified") -> Callable[..., LMICertificate]:
    """The common-P test for a search over loops indexed alike (a bisection on a scale, a mass, a rate).

    Each solve of :func:`lmi_certificate` starts from the active loops of the previous one:
    the loops that bounded P at one scale are the ones that bound it at the next.

    Parameters
    ----------
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    stop : {'verified', 'optimum', 'probe'}
        As for :func:`lmi_certificate`; a bisection needs only the verdict ('probe': a search
        step that may end without a P before a proof of infeasibility).

    Returns
    -------
    callable ``test(closed_loops, check=()) -> LMICertificate``
        :func:`lmi_certificate` with this solver and stop, starting from the last active set.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> test = sr.lmi_search()
    >>> A = np.array([[[-1.0, 0.0], [0.0, -2.0]], [[-1.0, 0.5], [0.0, -2.0]]])
    >>> [test(s * A).certified for s in (1.0, 2.0)]
    [True, True]
    """
    solver = resolve_lmi_solver(solver)
    check_choice("stop", stop, LMI_STOPS)
    active: NDArray[np.int64] | None = None

    def test(closed_loops: ArrayLike, check: Sequence[ArrayLike] = ()) -> LMICertificate:
        nonlocal active
        n_loops = np.shape(closed_loops)[0] + sum(np.shape(c)[0] for c in check)
        start = active if active is not None and active.size and active[-1] < n_loops else None
        result = lmi_certificate(closed_loops, check=check, solver=solver, stop=stop, start=start)
        if result.active is not None:
            active = result.active
        return result

    return test

