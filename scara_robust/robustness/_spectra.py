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
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import cache

import numpy as np
from numpy.typing import NDArray

from ..sdp._linalg import positive_definite

__all__ = ["lyapunov_decreases", "spectral_abscissae", "StabilityScan"]

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
    return _by_parts(_abscissae, np.asarray(matrices, dtype=float))


def _by_parts(fn: Callable[[NDArray[np.float64]], NDArray[np.float64]],
              stack: NDArray[np.float64]) -> NDArray[np.float64]:
    """``fn(stack)``, matrix by matrix, with the stack split between the cores (each matrix the same calls)."""
    workers = _workers()
    if workers == 1 or stack.shape[0] < _PARALLEL_FROM:
        return fn(stack)
    return np.concatenate(list(_pool(workers).map(fn, np.array_split(stack, workers))))


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
    return _by_parts(_candidates, stack)


def _candidates(stack: NDArray[np.float64]) -> NDArray[np.float64]:
    lam, V = np.linalg.eig(stack)
    Vinv = np.linalg.inv(V)
    D = -0.5 / lam.real
    P = (np.swapaxes(Vinv, 1, 2).conj() @ (D[:, :, None] * Vinv)).real
    return np.asarray(0.5 * (P + np.swapaxes(P, 1, 2)), dtype=float)


def _lyapunov_holds(stack: NDArray[np.float64], P: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Per matrix: ``AᵀP + PA ≺ 0`` with :data:`_LYAPUNOV_MARGIN` (then A is Hurwitz, P ≻ 0 being given)."""
    Q = -(np.swapaxes(stack, 1, 2) @ P + P @ stack)
    shift = _LYAPUNOV_MARGIN * np.linalg.norm(stack, axis=(1, 2)) * np.linalg.norm(P, axis=(1, 2))
    return positive_definite(Q, shift)


def lyapunov_decreases(stack: NDArray[np.float64], P: NDArray[np.float64]) -> bool:
    """``max λmax(PA + AᵀP) < 0`` over the stack, as numpy's eigenvalues answer it, with a Cholesky first.

    Where every ``−(PA + AᵀP)`` factors with a shift of :data:`_LYAPUNOV_MARGIN` times its
    norm, each ``λmax(PA + AᵀP)`` is negative beyond the eigenvalues' rounding, so the
    answer is True without them; otherwise the eigenvalues decide. It is the verdict of
    :func:`~scara_robust.robustness.polytope.polytope_certificate` (``certified``).

    Parameters
    ----------
    stack : ndarray, shape (N, n, n)
        Closed loops A, 1/s.
    P : ndarray, shape (n, n)
        Symmetric positive definite.

    Returns
    -------
    bool
    """
    PA = P @ stack
    S = PA + np.swapaxes(PA, -1, -2)
    if positive_definite(-S, _LYAPUNOV_MARGIN * np.linalg.norm(S, axis=(1, 2))).all():
        return True
    return bool(np.linalg.eigvalsh(S)[:, -1].max() < 0)


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

    Parameters
    ----------
    strict : bool
        True (default): stable means ``max Re λ < 0`` (Hurwitz). False: ``max Re λ <= 0``, the
        complement of "some eigenvalue has a positive real part", which a search for an
        unstable matrix asks (a kept P proves the strict inequality, so it answers both).
    """

    def __init__(self, strict: bool = True) -> None:
        self.strict = bool(strict)
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
            ``spectral_abscissae(matrices).max() < 0`` (``<= 0`` when not `strict`).
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
        abscissae = spectral_abscissae(stack[unknown])
        worst = abscissae.max()
        if not (worst < 0 if self.strict else worst <= 0):
            return False
        self._P[unknown] = np.eye(stack.shape[1])  # a P ≻ 0 all the same, for a matrix with no candidate
        hurwitz = unknown[abscissae < 0]  # a zero real part (not strict) has no Lyapunov matrix
        if hurwitz.size:
            P = _lyapunov_candidates(stack[hurwitz])
            kept = positive_definite(P, _LYAPUNOV_MARGIN * np.linalg.norm(P, axis=(1, 2)))
            self._P[hurwitz[kept]] = P[kept]
        return True
