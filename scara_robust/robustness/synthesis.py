"""Robust synthesis: a state-feedback (PID) gain designed together with its Lyapunov certificate.

For an uncertainty set given by its vertices or samples ``(A_i, B_i)``, find ``Q ≻ 0`` and
``Y`` with (Boyd et al., *Linear Matrix Inequalities in System and Control Theory*, 1994,
§7.2.1)::

    A_i Q + Q A_iᵀ − B_i Y − Yᵀ B_iᵀ + 2α Q ≺ 0      at every i,

then ``K = Y Q⁻¹`` (``u = −Kx``) and ``P = Q⁻¹``: ``V = xᵀPx`` decays at least as fast as
``e^{−2αt}`` for any time variation inside the convex hull. The decay rate α is maximized
by bisection (each step an LMI, cvxpy + Clarabel: extra ``lmi``). ``‖K‖₂ <= κ`` is kept by
``Q ⪰ I`` and ``[[κ²I, Y], [Yᵀ, I]] ⪰ 0`` (then ``‖K‖ <= ‖Y‖‖Q⁻¹‖ <= κ``). The answer is
re-verified with numpy on the same set and, when given, on an independent one; a gain
numpy cannot verify is reported as not certified.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_instance, check_real
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import Design
from ..model.polytopic import PolytopicModel
from ..model.uncertain import UncertainLTVModel
from .lmi import LMI_SOLVERS, NOT_INSTALLED, cvxpy_available

__all__ = ["Synthesis", "synthesize", "decay_rate", "GAIN_BOUND", "vertices_of"]

Array = NDArray[np.float64]

#: Default bound on ‖K‖₂. The paper's gain at (3, 90) has ‖K‖₂ = 386 (N·m per rad, rad·s,
#: rad/s mixed); 1000 leaves the synthesis room (2.6 times that) while keeping the closed
#: loop's fastest poles within what a 1-kHz controller and the default engines follow.
GAIN_BOUND = 1e3


def vertices_of(model: UncertainLTVModel | PolytopicModel) -> tuple[Array, Array]:
    """The ``(A_i, B_i)`` whose convex hull is the model's uncertainty set.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
        An interval box (its 2^N corners) or a polytope (its vertices).

    Returns
    -------
    A : ndarray, shape (V, n, n)
    B : ndarray, shape (V, n, m)
    """
    check_instance("model", model, (UncertainLTVModel, PolytopicModel), "an UncertainLTVModel or a PolytopicModel")
    if isinstance(model, PolytopicModel):
        return np.asarray(model.vertices_A), np.asarray(model.vertices_B)
    A, B = model.matrices_at(model.box_vertices())
    return np.asarray(A, dtype=float), np.asarray(B, dtype=float)


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


@dataclass(frozen=True)
class Synthesis:
    """A synthesized gain and its certificate.

    Attributes
    ----------
    status : str
        ``'certified'``, ``'infeasible'`` (no gain within the bound makes every vertex
        decay), ``'not verified'`` (the solver's answer fails numpy's check), a solver
        status (``'optimal_inaccurate'``, ...) or ``'not installed'``.
    K : ndarray, shape (m, n), or None
        Gain of ``u = −Kx``.
    P : ndarray, shape (n, n), or None
        Lyapunov matrix ``Q⁻¹``.
    decay : float
        The decay rate the LMI reached, 1/s (NaN without a gain).
    verified_decay : float
        numpy's decay rate (:func:`decay_rate`) on the synthesis set, 1/s.
    check_decay : float
        numpy's decay rate on the independent check set (NaN when none was given), 1/s.
    gain_norm : float
        ``‖K‖₂``.
    gain_bound : float
        κ used.
    n_vertices, n_checked : int
        Sizes of the synthesis and check sets.
    solver_status : str
        What the solver said of the last feasible LMI (``'optimal'``, ``'optimal_inaccurate'``, ...).
    seconds : float
    design : Design or None
        The gain as a :class:`~scara_robust.Design` on the model's nominal (ρ and η NaN),
        so every certificate, margin and simulation takes it.
    """

    status: str
    K: Array | None
    P: Array | None
    decay: float
    verified_decay: float
    check_decay: float
    gain_norm: float
    gain_bound: float
    n_vertices: int
    n_checked: int
    seconds: float
    design: Design | None
    solver_status: str = ""

    @property
    def certified(self) -> bool:
        """numpy verified a positive decay on the synthesis set and, if given, on the check set."""
        checked = math.isnan(self.check_decay) or self.check_decay > 0
        return bool(self.status == "certified" and self.verified_decay > 0 and checked)

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.certified:
            said = "" if self.solver_status == "optimal" else f" (the solver said {self.solver_status})"
            extra = said + ("" if math.isnan(self.check_decay) else (
                f"; on {self.n_checked} independent samples V decays at >= {self.check_decay:.4g} 1/s"))
            return (f"gain found with ‖K‖ = {self.gain_norm:.4g} <= {self.gain_bound:g}; numpy verifies that V "
                    f"decays at >= {self.verified_decay:.4g} 1/s on the {self.n_vertices} synthesis points{extra}")
        if self.status == "infeasible":
            return f"no gain with ‖K‖ <= {self.gain_bound:g} and a common quadratic Lyapunov function exists"
        if self.K is not None:
            return (f"the solver returned a gain ({self.status}) that numpy does not certify: decay "
                    f"{self.verified_decay:.4g} 1/s on the synthesis set, {self.check_decay:.4g} on the check set")
        return f"no gain: {self.status}"


def _solve(A: Array, B: Array, alpha: float, kappa: float, solver: str) -> tuple[str, Array | None, Array | None]:
    import cvxpy as cp

    n, m = A.shape[1], B.shape[2]
    Q = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((m, n))
    eye = np.eye(n)
    constraints = [Q >> eye, cp.bmat([[kappa**2 * np.eye(m), Y], [Y.T, eye]]) >> 0]  # type: ignore[attr-defined]
    for A_i, B_i in zip(A, B):
        lhs = A_i @ Q + Q @ A_i.T - B_i @ Y - Y.T @ B_i.T + 2 * alpha * Q
        constraints.append(0.5 * (lhs + lhs.T) << -1e-6 * eye)
    problem = cp.Problem(cp.Minimize(cp.trace(Q)), constraints)  # type: ignore[attr-defined]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "inaccurate" is reported through the status
            problem.solve(solver=solver)  # type: ignore[no-untyped-call]
    except cp.SolverError as err:
        return f"solver error: {err}", None, None
    if Q.value is None or problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return str(problem.status), None, None
    return str(problem.status), np.array(Q.value, dtype=float), np.array(Y.value, dtype=float)


def synthesize(
    model: UncertainLTVModel | PolytopicModel | tuple[ArrayLike, ArrayLike],
    *,
    decay: float | None = None,
    gain_bound: float = GAIN_BOUND,
    check: tuple[ArrayLike, ArrayLike] | None = None,
    nominal: UncertainLTVModel | PolytopicModel | None = None,
    tol: float = 1e-2,
    solver: str = "CLARABEL",
) -> Synthesis:
    """Synthesize ``u = −Kx`` and its common Lyapunov matrix over an uncertainty set.

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel or tuple (A, B)
        The set: an interval box (its corners), a polytope (its vertices), or sampled
        pairs ``(A (k, n, n), B (k, n, m))`` (the robot's :func:`scara_robust.physical_samples`).
    decay : float, optional
        Required decay rate α of V, 1/s (>= 0); default: the largest found by bisection.
    gain_bound : float
        κ > 0 with ``‖K‖₂ <= κ``.
    check : tuple (A, B), optional
        An independent set on which numpy re-verifies the answer (for the robot: a finer
        sampling of times and payloads).
    nominal : UncertainLTVModel or PolytopicModel, optional
        Supplies the nominal (A, B) and PID structure of the returned design (default:
        `model` itself; for sampled pairs, their average).
    tol : float
        Relative tolerance of the bisection on α.
    solver : {'CLARABEL', 'SCS'}

    Returns
    -------
    Synthesis
        Never raises for an infeasible or inaccurate problem: those are results.
    """
    start = time.perf_counter()
    if isinstance(model, (UncertainLTVModel, PolytopicModel)):
        A, B = vertices_of(model)
    else:
        if not isinstance(model, tuple) or len(model) != 2:
            raise ArgumentValueError("model", "must be a model or a tuple (A, B) of sampled matrices")
        A = check_array("model[0]", model[0], ndim=3)
        B = check_array("model[1]", model[1], ndim=3)
        if A.shape[1] != A.shape[2] or B.shape[:2] != A.shape[:2]:
            raise ArgumentValueError("model", f"must hold A (k, n, n) and B (k, n, m), found {A.shape}, {B.shape}")
    kappa = check_real("gain_bound", gain_bound, positive=True)
    tol = check_real("tol", tol, positive=True)
    check_choice("solver", solver, LMI_SOLVERS)
    A_chk = B_chk = None
    if check is not None:
        A_chk = check_array("check[0]", check[0], ndim=3)
        B_chk = check_array("check[1]", check[1], ndim=3)
        if A_chk.shape[1:] != A.shape[1:] or B_chk.shape[1:] != B.shape[1:]:
            raise ArgumentValueError("check", f"must hold matrices of the sizes of `model`, found {A_chk.shape}")
    n_chk = 0 if A_chk is None else int(A_chk.shape[0])
    if not cvxpy_available():
        return Synthesis(NOT_INSTALLED, None, None, math.nan, math.nan, math.nan, math.nan, kappa, len(A), n_chk,
                         time.perf_counter() - start, None)
    if decay is not None:
        alpha = check_real("decay", decay, nonnegative=True)
        status, Q, Y = _solve(A, B, alpha, kappa, solver)
    else:
        status, Q, Y = _solve(A, B, 0.0, kappa, solver)
        alpha = 0.0
        if Q is not None:
            lo, hi = 0.0, 1.0
            while hi < 1e4:  # grow until infeasible
                s_hi, Q_hi, Y_hi = _solve(A, B, hi, kappa, solver)
                if Q_hi is None:
                    break
                lo, hi, status, Q, Y = hi, 2 * hi, s_hi, Q_hi, Y_hi
            while hi - lo > tol * max(hi, 1e-9):
                mid = 0.5 * (lo + hi)
                s_mid, Q_mid, Y_mid = _solve(A, B, mid, kappa, solver)
                if Q_mid is None:
                    hi = mid
                else:
                    lo, status, Q, Y = mid, s_mid, Q_mid, Y_mid
            alpha = lo
    if Q is None or Y is None:
        return Synthesis("infeasible" if status == "infeasible" else status, None, None, math.nan, math.nan, math.nan,
                         math.nan, kappa, len(A), n_chk, time.perf_counter() - start, None)
    K = Y @ np.linalg.inv(Q)
    P = np.linalg.inv(Q)
    P = 0.5 * (P + P.T)
    verified = decay_rate(A - B @ K, P)
    checked = math.nan if A_chk is None or B_chk is None else decay_rate(A_chk - B_chk @ K, P)
    ok = verified > 0 and (math.isnan(checked) or checked > 0)
    design = _as_design(K, P, nominal if nominal is not None else model, A, B)
    return Synthesis("certified" if ok else "not verified", K, P, alpha, verified, checked,
                     float(np.linalg.norm(K, 2)), kappa, len(A), n_chk, time.perf_counter() - start, design, status)


def _as_design(K: Array, P: Array, model: object, A: Array, B: Array) -> Design:
    if isinstance(model, (UncertainLTVModel, PolytopicModel)):
        A0, B0 = model.A, model.B
        joints = getattr(model, "n_joints", None)
    else:
        A0, B0 = A.mean(axis=0), B.mean(axis=0)
        joints = A.shape[1] // 3 if A.shape[1] % 3 == 0 and A.shape[1] // 3 == B.shape[2] else None
    A_cl = A0 - B0 @ K
    Q = -0.5 * (P @ A_cl + A_cl.T @ P)
    poles = np.linalg.eigvals(A_cl).astype(complex)
    return Design(rho=math.nan, eta=math.nan, K=K, P=P, A_cl=A_cl, Q=0.5 * (Q + Q.T), poles=poles,
                  hurwitz=bool(np.all(poles.real < 0)), care_residual=math.nan, n_joints=joints)
