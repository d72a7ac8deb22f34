"""The reference backend: an :class:`~scara_robust.sdp.problem.LMIProblem` solved by cvxpy (extra ``lmi``).

The description is written out term by term as cvxpy expressions and solved by Clarabel
(or SCS); the answer comes back as an :class:`~scara_robust.sdp.ipm.LMIResult` with cvxpy's
status and the dual blocks. It is slower than the package's own solver (cvxpy builds the
problem anew, and its solver sees no structure), and it is the one every problem kind is
tested against.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .ipm import LMIResult
from .problem import LMIProblem

__all__ = ["solve_lmi_cvxpy"]


def solve_lmi_cvxpy(problem: LMIProblem, solver: str = "CLARABEL") -> LMIResult:
    """Solve `problem` with cvxpy and `solver`.

    Parameters
    ----------
    problem : LMIProblem
    solver : str
        A cvxpy solver name (``'CLARABEL'``, ``'SCS'``).

    Returns
    -------
    LMIResult
        ``y`` gathered from the variables' values; ``duals`` the blocks' dual matrices.
    """
    import cvxpy as cp

    y = cp.Variable(problem.n_free)
    values = {var: cp.reshape(var.basis @ y[var.slice], var.shape, order="C")  # type: ignore[attr-defined]
              for var in problem.variables}
    constraints = []
    for fam in problem.families:
        for n in range(fam.count):
            expr = fam.const[n]
            for var, U, V in fam.terms:
                T = U[n].T @ values[var] @ V[n]
                expr = expr + T + T.T
            for var, G in fam.scalars:
                expr = expr + values[var][0, 0] * G[n]
            constraints.append(0.5 * (expr + expr.T) >> 0)
    objective = cp.Maximize(problem.b() @ y)
    cvx = cp.Problem(objective, constraints)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            cvx.solve(solver=solver)  # type: ignore[no-untyped-call]
    except cp.SolverError as err:
        return LMIResult(f"solver error: {err}", None, None, math.nan, math.nan, 0, solver=solver)
    status = str(cvx.status)
    duals = None
    if all(c.dual_value is not None for c in constraints):
        blocks = iter(np.asarray(c.dual_value, dtype=float) for c in constraints)
        duals = [np.array([next(blocks) for _ in range(fam.count)]) for fam in problem.families]
    stats = cvx.solver_stats
    iterations = int(stats.num_iters) if stats is not None and stats.num_iters is not None else 0
    if y.value is None or status not in ("optimal", "optimal_inaccurate"):
        return LMIResult(status, None, duals, math.nan, math.nan, iterations, solver=solver)
    y_val = np.array(y.value, dtype=float)
    return LMIResult(status, y_val, duals, float(problem.b() @ y_val), math.nan, iterations, solver=solver)
