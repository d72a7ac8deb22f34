"""Eigenvalues of many small matrices at once, on every core the process may use.

The frozen-plant scans (:func:`~scara_robust.parameter_margin`'s upper bound, the payload
search) ask for the spectral abscissa of thousands of closed loops of 10–30 states per
step. numpy's stacked ``eigvals`` runs LAPACK's ``geev`` matrix by matrix on one core and
releases the GIL, so splitting the stack between threads gives each core its share; every
matrix still goes through the same LAPACK call, so the values are those of one
``numpy.linalg.eigvals`` on the whole stack, bit for bit.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["spectral_abscissae"]

#: Below this many matrices one thread does it all (the threads' start costs more).
_PARALLEL_FROM = 256


@cache
def _pool(workers: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(max_workers=workers, thread_name_prefix="scara_robust-eigvals")


def _workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - platforms without affinity
        return max(1, os.cpu_count() or 1)


def _abscissae(stack: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(np.linalg.eigvals(stack).real.max(axis=-1), dtype=float)


def spectral_abscissae(matrices: NDArray[np.float64]) -> NDArray[np.float64]:
    """``max Re λ`` of each matrix of a stack.

    Parameters
    ----------
    matrices : ndarray, shape (N, n, n)
        Real square matrices (closed loops, 1/s).

    Returns
    -------
    ndarray, shape (N,)
        Each matrix's spectral abscissa, 1/s, equal to
        ``numpy.linalg.eigvals(matrices).real.max(axis=-1)``.
    """
    stack = np.asarray(matrices, dtype=float)
    workers = _workers()
    if workers == 1 or stack.shape[0] < _PARALLEL_FROM:
        return _abscissae(stack)
    parts = np.array_split(stack, workers)
    return np.concatenate(list(_pool(workers).map(_abscissae, parts)))
