"""Cutting planes: an LMI over many closed loops solved on a few of them at a time.

An LMI with one constraint per closed loop (a common Lyapunov matrix over a polytope's
vertices or a plant's samples) is solved on a small **active set** of the loops; numpy then
checks the answer on every loop, and the loops it violates most join the active set, until
none is violated. Infeasibility on the active set is infeasibility on the whole set, and the
answer is verified on every loop, exactly as a solve on all of them at once would be; only
the solver's work shrinks (Kelley 1960; Boyd and Vandenberghe, *Convex Optimization*, §6 of
the localization-methods notes, on constraint generation).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["ACTIVE_BATCH", "grow_active_set"]

#: Loops added to the active set per round: the most violated ones.
ACTIVE_BATCH = 8


def grow_active_set(
    solve: Callable[[NDArray[np.int64]], tuple[str, Any]],
    violation: Callable[[Any], NDArray[np.float64]],
    first: NDArray[np.int64],
    *,
    batch: int = ACTIVE_BATCH,
) -> tuple[str, Any, NDArray[np.int64]]:
    """Solve on the active loops, add the most violated of all, until no loop is violated.

    Parameters
    ----------
    solve : callable ``solve(active) -> (status, answer or None)``
        The LMI on the loops of indices `active`, shape (V_active,).
    violation : callable ``violation(answer) -> ndarray, shape (V,)``
        Each loop's violation of the answer (> 0: violated), computed with numpy.
    first : ndarray of int, shape (V_first,)
        The loops to start from (sorted, unique).
    batch : int
        Loops added per round.

    Returns
    -------
    status : str
        The last solve's status.
    answer : object or None
        The last answer: none of the loops violates it; None when the last solve found none
        (its status says why: an infeasible active set is an infeasible whole).
    active : ndarray of int
        The active set of the last solve, sorted.
    """
    active = first
    while True:
        status, answer = solve(active)
        if answer is None:
            return status, None, active
        worst = np.array(violation(answer), dtype=float)
        worst[active] = -np.inf  # a loop already active is the solver's to satisfy, not added twice
        new = np.flatnonzero(worst > 0)
        if not new.size:
            return status, answer, active
        new = new[np.argsort(-worst[new], kind="stable")[:batch]]
        active = np.sort(np.concatenate([active, new]))
