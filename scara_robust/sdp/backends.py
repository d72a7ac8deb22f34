"""The LMI solvers by name: the package's own interior-point method and cvxpy's (extra ``lmi``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
from numpy.typing import NDArray

from .._validation import check_choice
from .ipm import LMIResult, solve_ipm
from .problem import LMIProblem, LMIVariable
from .reference import solve_lmi_cvxpy

__all__ = ["LMI_BACKENDS", "solve_lmi", "solve_lmi_interior", "default_lmi_solver", "use_lmi_solver",
           "resolve_lmi_solver"]

#: The solvers of :func:`solve_lmi`: the package's own, then cvxpy's (extra ``lmi``).
LMI_BACKENDS = ("IPM", "CLARABEL", "SCS")

_DEFAULT: ContextVar[str] = ContextVar("scara_robust_lmi_solver", default="IPM")


def default_lmi_solver() -> str:
    """The solver an analysis uses when its ``solver`` argument is None (``'IPM'`` unless changed).

    Returns
    -------
    str
        A name of :data:`LMI_BACKENDS`.

    See Also
    --------
    use_lmi_solver : change it for a block of code.
    """
    return _DEFAULT.get()


@contextmanager
def use_lmi_solver(solver: str) -> Iterator[str]:
    """Make `solver` the default of every LMI analysis inside a ``with`` block.

    Every function of the package that solves an LMI takes ``solver=None`` to mean this
    default; inside the block, ``None`` means `solver`. The setting is a context variable:
    it holds in the thread (or task) that entered the block, and ends with it.

    Parameters
    ----------
    solver : {'IPM', 'CLARABEL', 'SCS'}

    Returns
    -------
    contextlib.AbstractContextManager
        Entered by ``with``, it gives the solver's name.

    Examples
    --------
    >>> import scara_robust as sr
    >>> with sr.use_lmi_solver("CLARABEL"):
    ...     sr.default_lmi_solver()
    'CLARABEL'
    >>> sr.default_lmi_solver()
    'IPM'
    """
    check_choice("solver", solver, LMI_BACKENDS)
    token = _DEFAULT.set(solver)
    try:
        yield solver
    finally:
        _DEFAULT.reset(token)


def resolve_lmi_solver(solver: str | None) -> str:
    """The solver an analysis runs: `solver` checked, or the default (:func:`default_lmi_solver`) for None.

    Parameters
    ----------
    solver : {'IPM', 'CLARABEL', 'SCS'} or None

    Returns
    -------
    str
    """
    if solver is None:
        return _DEFAULT.get()
    check_choice("solver", solver, LMI_BACKENDS)
    return solver


def solve_lmi(problem: LMIProblem, solver: str | None = None, *,
          accept: Callable[[NDArray[np.float64]], bool] | None = None,
          reject: Callable[[float], bool] | None = None) -> LMIResult:
    """Solve an LMI problem.

    Parameters
    ----------
    problem : LMIProblem
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        ``'IPM'``: :func:`solve_ipm`; the others through cvxpy (:func:`solve_lmi_cvxpy`).
        None: :func:`default_lmi_solver`.
    accept : callable ``accept(y) -> bool``, optional
        With ``'IPM'``: stop at the first iterate it accepts (a bisection's question answered).
    reject : callable ``reject(bound) -> bool``, optional
        With ``'IPM'``: stop (status ``'rejected'``) once it accepts the dual bound on the
        optimal value (a bisection's step that will find nothing better).

    Returns
    -------
    LMIResult
    """
    solver = resolve_lmi_solver(solver)
    if solver == "IPM":
        return solve_ipm(problem, accept=accept, reject=reject)
    return solve_lmi_cvxpy(problem, solver)


def solve_lmi_interior(problem: LMIProblem, t: LMIVariable, *, floor: float = 0.0,
                       solver: str | None = None) -> LMIResult:
    """Maximize the margin t of an always-feasible LMI; where rounding stops short, ask for t*/2.

    If the solver ends ``'optimal_inaccurate'`` (rounding stopped it short of its
    tolerances) with ``t > floor``, a strictly interior point is asked for instead, which is
    all a certificate needs: the package's solver solves the problem again and stops at the
    first iterate, every block positive semidefinite, with ``t >= t*/2``; cvxpy's solvers
    solve the feasibility problem ``t = t*/2``.

    Parameters
    ----------
    problem : LMIProblem
        Its objective is ``maximize t``.
    t : LMIVariable
        The margin, a scalar.
    floor : float
        A margin at or below this is no interior point.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        None: :func:`default_lmi_solver`.

    Returns
    -------
    LMIResult
    """
    solver = resolve_lmi_solver(solver)
    result = solve_lmi(problem, solver)
    if result.status != "optimal_inaccurate" or result.y is None or result.value(t) <= floor:
        return result
    half = 0.5 * result.value(t)
    if solver == "IPM":
        second = solve_ipm(problem, accept=lambda y: bool(y[t.offset] >= half))
        return second if second.accepted else result
    pinned = problem.copy()
    one = np.ones((1, 1))
    pinned.add_lmi(scalars=[(t, one)], const=-half * one, name="t >= t*/2")
    pinned.add_lmi(scalars=[(t, -one)], const=half * one, name="t <= t*/2")
    pinned.maximize({})
    return solve_lmi_cvxpy(pinned, solver)
