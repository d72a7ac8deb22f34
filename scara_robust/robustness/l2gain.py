"""Worst-case L2 gain of an uncertain closed loop: an upper bound by LMI, a lower bound from frozen plants.

For ``ẋ = Ā(t) x + B_w w``, ``z = C x`` with ``Ā(t)`` anywhere in the convex hull of the
closed loops ``Ā_i``, the bounded-real lemma with a common P (Boyd et al. 1994, §6.3.2)::

    [[Ā_iᵀP + PĀ_i + CᵀC, PB_w], [B_wᵀP, −γ²I]] ≺ 0   at every i,   P ≻ 0

bounds ``‖z‖₂ <= γ‖w‖₂`` for every time variation (the idea of MATLAB's ``quadperf``). Every
frozen plant is one admissible variation, so ``max_i ‖C(sI − Ā_i)⁻¹B_w‖∞`` (python-control's
``norm(sys, 'inf')``) bounds the worst-case gain from below.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice
from ..exceptions import ArgumentValueError
from .lmi import LMI_SOLVERS, NOT_INSTALLED, cvxpy_available

__all__ = ["L2Gain", "l2_gain"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class L2Gain:
    """Bounds on the worst-case L2 gain from w to z over the closed loops' hull.

    Attributes
    ----------
    upper : float
        γ of the bounded-real LMI with a common P, verified with numpy (``inf`` when the LMI
        is infeasible or its answer fails the check; NaN without cvxpy). Units of z per
        unit of w (rad per N·m for the robot's tracking error and disturbance torque).
    lower : float
        ``max_i`` of the frozen plants' H∞ norms.
    worst_index : int
        The frozen plant attaining `lower`.
    status : str
        The solver's status, ``'not verified'``, ``'infeasible'`` or ``'not installed'``.
    P : ndarray, shape (n, n), or None
    seconds : float
    """

    upper: float
    lower: float
    worst_index: int
    status: str
    P: Array | None
    seconds: float

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if math.isfinite(self.upper):
            return (f"worst-case L2 gain in [{self.lower:.4g}, {self.upper:.4g}] (frozen plant {self.worst_index}; "
                    f"common-P bounded-real LMI, {self.status})")
        return f"worst-case L2 gain >= {self.lower:.4g} (frozen plant {self.worst_index}); upper bound: {self.status}"


def _bounded_real_ok(A: Array, Bw: Array, C: Array, P: Array, gamma: float) -> bool:
    """numpy's check of the bounded-real inequality at every closed loop."""
    top = np.swapaxes(A, -1, -2) @ P + P @ A + C.T @ C
    side = P @ Bw  # (V, n, q)
    q = Bw.shape[-1]
    corner = np.broadcast_to(-gamma**2 * np.eye(q), (A.shape[0], q, q))
    block = np.block([[top, side], [np.swapaxes(side, -1, -2), corner]])
    return bool(np.linalg.eigvalsh(0.5 * (block + np.swapaxes(block, -1, -2)))[:, -1].max() < 0
                and np.linalg.eigvalsh(P)[0] > 0)


def l2_gain(closed_loops: ArrayLike, Bw: ArrayLike, C: ArrayLike, *, solver: str = "CLARABEL") -> L2Gain:
    """Upper and lower bounds on the worst-case L2 gain from w to z over ``conv{Ā_i}``.

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
    solver : {'CLARABEL', 'SCS'}

    Returns
    -------
    L2Gain
    """
    start = time.perf_counter()
    A = check_array("closed_loops", closed_loops, ndim=3)
    n = A.shape[1]
    if A.shape[2] != n or A.shape[0] == 0:
        raise ArgumentValueError("closed_loops", f"must have shape (V >= 1, n, n), found {A.shape}")
    Bw = check_array("Bw", Bw)
    if Bw.ndim == 2:
        Bw = np.broadcast_to(Bw, (A.shape[0], *Bw.shape))
    if Bw.ndim != 3 or Bw.shape[:2] != (A.shape[0], n):
        raise ArgumentValueError("Bw", f"must have shape ({n}, q) or ({A.shape[0]}, {n}, q), found {Bw.shape}")
    C = check_array("C", C, shape=(None, n))
    check_choice("solver", solver, LMI_SOLVERS)
    norms = []
    for A_i, B_i in zip(A, Bw):
        if np.linalg.eigvals(A_i).real.max() >= 0:
            norms.append(math.inf)  # a frozen unstable plant: unbounded gain
        else:
            norms.append(float(ct.norm(ct.ss(A_i, B_i, C, 0), p="inf")))
    worst = int(np.argmax(norms))
    lower = norms[worst]
    if not cvxpy_available():
        return L2Gain(math.nan, lower, worst, NOT_INSTALLED, None, time.perf_counter() - start)
    import cvxpy as cp

    q = Bw.shape[2]
    P = cp.Variable((n, n), symmetric=True)
    g2 = cp.Variable(nonneg=True)
    constraints = [P >> 1e-9 * np.eye(n)]
    for A_i, B_i in zip(A, Bw):
        lhs = cp.bmat([[A_i.T @ P + P @ A_i + C.T @ C, P @ B_i], [B_i.T @ P, -g2 * np.eye(q)]])  # type: ignore[attr-defined]
        constraints.append(0.5 * (lhs + lhs.T) << -1e-9 * np.eye(n + q))
    problem = cp.Problem(cp.Minimize(g2), constraints)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=solver)  # type: ignore[no-untyped-call]
    except cp.SolverError as err:
        return L2Gain(math.inf, lower, worst, f"solver error: {err}", None, time.perf_counter() - start)
    if P.value is None or problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return L2Gain(math.inf, lower, worst, str(problem.status), None, time.perf_counter() - start)
    gamma = math.sqrt(max(float(np.asarray(g2.value)), 0.0))
    # The optimum sits on the boundary, where numpy cannot confirm a strict inequality:
    # re-solve at γ(1 + 1e-3) for the most interior P, and check that one.
    bound = gamma * (1 + 1e-3)
    t = cp.Variable()
    interior = [P >> t * np.eye(n), t <= 1]
    for A_i, B_i in zip(A, Bw):
        lhs = cp.bmat([[A_i.T @ P + P @ A_i + C.T @ C, P @ B_i], [B_i.T @ P, -bound**2 * np.eye(q)]])  # type: ignore[attr-defined]
        interior.append(0.5 * (lhs + lhs.T) << -t * np.eye(n + q))
    second = cp.Problem(cp.Maximize(t), interior)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            second.solve(solver=solver)  # type: ignore[no-untyped-call]
    except cp.SolverError:
        pass
    if P.value is not None and second.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        P_val = 0.5 * (np.array(P.value) + np.array(P.value).T)
        if _bounded_real_ok(A, Bw, C, P_val, bound):
            return L2Gain(bound, lower, worst, str(problem.status), P_val, time.perf_counter() - start)
    return L2Gain(math.inf, lower, worst, "not verified", None, time.perf_counter() - start)
