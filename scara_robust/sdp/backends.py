"""The LMI solvers by name: the package's own interior-point method and cvxpy's (extra ``lmi``)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .._validation import check_choice
from .ipm import LMIResult, solve_ipm
from .problem import LMIProblem
from .reference import solve_lmi_cvxpy

__all__ = ["LMI_BACKENDS", "solve_lmi"]

#: The solvers of :func:`solve_lmi`: the package's own, then cvxpy's (extra ``lmi``).
LMI_BACKENDS = ("IPM", "CLARABEL", "SCS")


def solve_lmi(problem: LMIProblem, solver: str = "IPM", *,
          accept: Callable[[NDArray[np.float64]], bool] | None = None) -> LMIResult:
    """Solve an LMI problem.

    Parameters
    ----------
    problem : LMIProblem
    solver : {'IPM', 'CLARABEL', 'SCS'}
        ``'IPM'``: :func:`solve_ipm`; the others through cvxpy (:func:`solve_lmi_cvxpy`).
    accept : callable ``accept(y) -> bool``, optional
        With ``'IPM'``: stop at the first iterate it accepts (a bisection's question answered).

    Returns
    -------
    LMIResult
    """
    check_choice("solver", solver, LMI_BACKENDS)
    if solver == "IPM":
        return solve_ipm(problem, accept=accept)
    return solve_lmi_cvxpy(problem, solver)
