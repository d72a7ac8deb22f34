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

cvxpy is optional (``pip install ".[lmi]"``); without it every function here
returns a result whose status is ``'not installed'``.
"""

from __future__ import annotations

import hashlib
import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_field
from .._validation import check_array, check_choice, check_closed_loops
from ..results import AnalysisResult

__all__ = ["LMICertificate", "LMI_SOLVERS", "LMI_VERDICTS", "cvxpy_available", "decay_rate", "lmi_certificate",
           "verify_lyapunov"]

Array = NDArray[np.float64]

#: Solvers tried by name through cvxpy (Clarabel is interior-point, SCS first-order).
LMI_SOLVERS = ("CLARABEL", "SCS")
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
    return float(DECAY_FLOOR_RTOL * np.linalg.norm(A, 2, axis=(1, 2)).max())


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
        Verified decay rate α of the state, 1/s (``V̇ <= −2αV``): ``−max_vertex_eig /
        (2 λmax(P))`` when P is positive definite, else NaN. Positive means certified.
    n_vertices : int
    floor : float
        The smallest decay rate reported as certified (:func:`decay_floor`), 1/s.
    """

    status: str
    solver: str
    P: Array | None
    max_vertex_eig: float
    decay_rate: float
    n_vertices: int
    floor: float = 0.0

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
    PA = P @ A_v
    max_vertex_eig = float(np.linalg.eigvalsh(PA + np.swapaxes(PA, -1, -2))[:, -1].max())
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
    PA = P @ A
    M = root_inv @ (PA + np.swapaxes(PA, -1, -2)) @ root_inv
    return float(-np.linalg.eigvalsh(M)[:, -1].max() / 2)


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


def lmi_certificate(closed_loops: ArrayLike, *, solver: str = "CLARABEL") -> LMICertificate:
    """Search a common quadratic Lyapunov matrix for the polytope ``conv{Ā_v}``.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        Frozen closed-loop matrices at the vertices, e.g. from
        ``scara_robust.robustness.polytope.box_closed_loops``.
    solver : {'CLARABEL', 'SCS'}

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
    A_v = check_closed_loops("closed_loops", closed_loops)
    check_choice("solver", solver, LMI_SOLVERS)
    if not cvxpy_available():
        return LMICertificate(NOT_INSTALLED, solver, None, np.nan, np.nan, A_v.shape[0])
    # one command asks the same question twice (its table's LMI row, then the design's decay
    # rate): the answer for the same closed loops is kept, read-only
    key = (hashlib.sha256(np.ascontiguousarray(A_v).tobytes()).hexdigest(), A_v.shape, solver)
    if key not in _SOLVED:
        if len(_SOLVED) >= _SOLVED_SIZE:
            _SOLVED.pop(next(iter(_SOLVED)))
        _SOLVED[key] = _solve_common_p(A_v, solver)
    return _SOLVED[key]


#: Answers of :func:`lmi_certificate` kept for the same closed loops and solver.
_SOLVED: dict[tuple[str, tuple[int, ...], str], LMICertificate] = {}
_SOLVED_SIZE = 16


def _solve_common_p(A_v: NDArray[np.float64], solver: str) -> LMICertificate:
    import cvxpy as cp

    n = A_v.shape[1]

    # Scaling the vertices by a positive constant leaves feasibility unchanged and keeps
    # the -I right-hand side commensurate with the data.
    scale = float(np.abs(A_v).max()) or 1.0
    A_s = A_v / scale
    P = cp.Variable((n, n), symmetric=True)
    lam = cp.Variable()
    eye = np.eye(n)
    constraints = [P >> eye, P << lam * eye]
    for A in A_s:
        lhs = A.T @ P + P @ A
        constraints.append(0.5 * (lhs + lhs.T) << -eye)
    problem = cp.Problem(cp.Minimize(lam), constraints)
    try:
        with warnings.catch_warnings():
            # "Solution may be inaccurate" is reported through the status, not as a warning
            warnings.simplefilter("ignore", UserWarning)
            # cvxpy's C++ canonicalization: on the SCARA's 1024 corners it builds the problem in 4.7 s
            # instead of 6.7 s (the default's choice); the problem and the solver are the same
            problem.solve(solver=solver, canon_backend=cp.CPP_CANON_BACKEND)  # type: ignore[no-untyped-call]
    except cp.SolverError as err:
        return LMICertificate(f"solver error: {err}", solver, None, np.nan, np.nan, A_v.shape[0])
    status = str(problem.status)
    if status == cp.INFEASIBLE and not farkas_certificate_holds(A_v, [c.dual_value for c in constraints[2:]]):
        status = INFEASIBLE_NOT_VERIFIED
    if P.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return LMICertificate(status, solver, None, np.nan, np.nan, A_v.shape[0])
    P_val = np.array(P.value, dtype=float)
    P_val.setflags(write=False)
    max_vertex_eig, margin = verify_lyapunov(A_v, P_val)
    return LMICertificate(status, solver, P_val, max_vertex_eig, float(margin), A_v.shape[0], decay_floor(A_v))
