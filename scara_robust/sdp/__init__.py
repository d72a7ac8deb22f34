"""LMIs described once and solved by a structure-exploiting interior-point method.

:class:`LMIProblem` describes an LMI problem (matrix and scalar variables, blocks as sums of
terms ``UᵀXV + VᵀXᵀU``, a linear objective); :func:`solve` solves it with the package's
own primal–dual interior-point method (``solver='IPM'``, the default,
:mod:`scara_robust.sdp.ipm`) or with cvxpy + Clarabel (``solver='CLARABEL'``, the
reference, extra ``lmi``) or SCS. Whichever solver answers, the analyses verify the answer
with numpy.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .._validation import check_choice
from .ipm import MAX_ITERATIONS, TOLERANCE, SDPResult, solve_ipm
from .problem import Family, LMIProblem, Variable, dense_schur
from .reference import solve_cvxpy

__all__ = ["LMIProblem", "Variable", "Family", "SDPResult", "solve", "SDP_SOLVERS", "dense_schur", "solve_ipm",
           "solve_cvxpy", "TOLERANCE", "MAX_ITERATIONS"]

#: The solvers of :func:`solve`: the package's own, then cvxpy's (extra ``lmi``).
SDP_SOLVERS = ("IPM", "CLARABEL", "SCS")


def solve(problem: LMIProblem, solver: str = "IPM", *,
          accept: Callable[[NDArray[np.float64]], bool] | None = None) -> SDPResult:
    """Solve an LMI problem.

    Parameters
    ----------
    problem : LMIProblem
    solver : {'IPM', 'CLARABEL', 'SCS'}
        ``'IPM'``: :func:`solve_ipm`; the others through cvxpy (:func:`solve_cvxpy`).
    accept : callable ``accept(y) -> bool``, optional
        With ``'IPM'``: stop at the first iterate it accepts (a bisection's question answered).

    Returns
    -------
    SDPResult
    """
    check_choice("solver", solver, SDP_SOLVERS)
    if solver == "IPM":
        return solve_ipm(problem, accept=accept)
    return solve_cvxpy(problem, solver)
