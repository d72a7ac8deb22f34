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
from scipy.linalg.lapack import dpotrf

__all__ = ["spectral_abscissae", "StabilityScan"]

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


#: A Lyapunov inequality holds when ``λ_min(−(AᵀP + PA))`` exceeds this times ``‖A‖_F ‖P‖_F``
#: (the rounding of the product is about ``2 n u ‖A‖ ‖P‖``, some 1e-14 of it at n = 30).
_LYAPUNOV_MARGIN = 1e-12


def _lyapunov_candidates(stack: NDArray[np.float64]) -> NDArray[np.float64]:
    """For each Hurwitz matrix A of the stack a P ≻ 0 with ``AᵀP + PA = −V⁻ᵀV⁻¹`` (A = VΛV⁻¹).

    In A's eigenvector basis the equation is diagonal: ``P = V⁻ᴴ D V⁻¹`` with
    ``D = diag(−1/(2 Re λ_i))``, so ``AᴴP + PA = V⁻ᴴ(Λ̄D + DΛ)V⁻¹ = −V⁻ᴴV⁻¹``; P is real
    for a real A (its eigenvectors come in conjugate pairs). For a defective or
    ill-conditioned V the P is poor; it is only a candidate, which
    :meth:`StabilityScan.all_stable` checks before it uses it.
    """
    lam, V = np.linalg.eig(stack)
    Vinv = np.linalg.inv(V)
    D = -0.5 / lam.real
    P = (np.swapaxes(Vinv, 1, 2).conj() @ (D[:, :, None] * Vinv)).real
    return np.asarray(0.5 * (P + np.swapaxes(P, 1, 2)), dtype=float)


def _positive_definite(stack: NDArray[np.float64], shift: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Per matrix, ``M − shift I ≻ 0`` by LAPACK's Cholesky factorization (its lower triangle).

    One ``dpotrf`` per matrix: numpy's stacked Cholesky stops at the first failure without saying
    which, and the stacked eigenvalues cost four times this loop.
    """
    eye = np.eye(stack.shape[1])
    finite = np.isfinite(stack).all(axis=(1, 2)) & np.isfinite(shift)
    return np.array([bool(ok) and dpotrf(m - c * eye, lower=1, clean=0)[1] == 0
                     for m, c, ok in zip(stack, shift, finite)], dtype=bool)


def _lyapunov_holds(stack: NDArray[np.float64], P: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Per matrix: ``AᵀP + PA ≺ 0`` with :data:`_LYAPUNOV_MARGIN` (then A is Hurwitz, P ≻ 0 being given)."""
    Q = -(np.swapaxes(stack, 1, 2) @ P + P @ stack)
    shift = _LYAPUNOV_MARGIN * np.linalg.norm(stack, axis=(1, 2)) * np.linalg.norm(P, axis=(1, 2))
    return _positive_definite(Q, shift)


class StabilityScan:
    """Whether every matrix of a stack is Hurwitz, for a sequence of nearby stacks of one shape.

    The answer is ``spectral_abscissae(matrices).max() < 0``; what changes is its cost. A
    matrix for which the Lyapunov matrix P kept from an earlier stack still proves
    ``AᵀP + PA ≺ 0`` (a Cholesky factorization, with a margin of rounding's size) is
    Hurwitz without its eigenvalues; the others' eigenvalues are computed as
    :func:`spectral_abscissae` computes them, and each stable one's P is renewed. On a
    bisection or a fine scan over a parameter, where the stacks move a little from call to
    call, most calls factor instead of computing eigenvalues. The matrix at index i of one
    stack is taken to be near the matrix at index i of the last (a grid of plants, in order).
    """

    def __init__(self) -> None:
        self._P: NDArray[np.float64] | None = None
        #: Matrices decided by their eigenvalues, and by a kept P, since the scan began.
        self.by_eigenvalues = 0
        self.by_lyapunov = 0

    def all_stable(self, matrices: NDArray[np.float64]) -> bool:
        """``max Re λ < 0`` over every matrix of the stack.

        Parameters
        ----------
        matrices : ndarray, shape (N, n, n)
            Real square matrices (closed loops, 1/s).

        Returns
        -------
        bool
            True when every matrix is Hurwitz; the same answer as
            ``spectral_abscissae(matrices).max() < 0``.
        """
        stack = np.asarray(matrices, dtype=float)
        if self._P is not None and self._P.shape == stack.shape:
            unknown = np.flatnonzero(~_lyapunov_holds(stack, self._P))
        else:
            self._P = np.broadcast_to(np.eye(stack.shape[1]), stack.shape).copy()
            unknown = np.arange(stack.shape[0])
        self.by_lyapunov += stack.shape[0] - unknown.size
        self.by_eigenvalues += unknown.size
        if unknown.size == 0:
            return True
        if not spectral_abscissae(stack[unknown]).max() < 0:
            return False
        P = _lyapunov_candidates(stack[unknown])
        kept = _positive_definite(P, _LYAPUNOV_MARGIN * np.linalg.norm(P, axis=(1, 2)))
        self._P[unknown] = np.where(kept[:, None, None], P, np.eye(stack.shape[1]))  # I: a P ≻ 0 all the same
        return True
