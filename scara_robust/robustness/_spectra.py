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
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..sdp._linalg import positive_definite

__all__ = ["lyapunov_decreases", "spectral_abscissae", "StabilityScan"]

#: Below this much work, matrices times n³, one thread does it all (the threads' start costs more):
#: 256 matrices of 6 × 6, or 10 of 18 × 18 (a frozen scan's few loops that need their eigenvalues).
_PARALLEL_FROM = 256 * 6**3


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


def _by_parts(fn: Callable[..., NDArray[Any]], stack: NDArray[np.float64], *more: NDArray[np.float64]) -> NDArray[Any]:
    """``fn(stack, *more)``, matrix by matrix, with the stacks split alike between the cores.

    Each matrix goes through the same calls whichever part it is in (numpy's stacked linear
    algebra and products release the GIL), so the values are those of one call, bit for bit.
    """
    workers = min(_workers(), stack.shape[0])
    if workers <= 1 or stack.shape[0] * stack.shape[-1] ** 3 < _PARALLEL_FROM:
        return fn(stack, *more)
    parts = np.array_split(np.arange(stack.shape[0]), workers)
    return np.concatenate(list(_pool(workers).map(lambda ix: fn(stack[ix], *(m[ix] for m in more)), parts)))


#: A Lyapunov inequality holds when ``λ_min(−(AᵀP + PA))`` exceeds this times ``‖A‖_F ‖P‖_F``
#: (the rounding of the product is about ``2 n u ‖A‖ ‖P‖``, some 1e-14 of it at n = 30).
_LYAPUNOV_MARGIN = 1e-12


#: States from which :class:`StabilityScan` checks its kept Lyapunov matrices on the threads.
_CHECKS_ON_THREADS = 12


def _lyapunov_candidates(stack: NDArray[np.float64]) -> NDArray[np.float64]:
    """For each Hurwitz matrix A of the stack a P ≻ 0 with ``AᵀP + PA = V⁻ᴴ diag(2 Re λ) V⁻¹`` (A = VΛV⁻¹).

    ``P = V⁻ᴴV⁻¹``, the squared norm of the state in A's eigenvector coordinates, decays on A
    since ``AᴴP + PA = V⁻ᴴ(Λ̄ + Λ)V⁻¹`` is negative definite when every ``Re λ_i < 0``; P is
    real for a real A (its eigenvectors come in conjugate pairs). It is kept for the next
    stacks of a scan: on the 6-joint arm's payload search it still proves 2.7 times as many
    moved loops as the P of ``AᵀP + PA = −V⁻ᴴV⁻¹`` (weights ``1/(2|Re λ_i|)``, which load the
    slow modes) did (3 905 against 10 616 loops sent to their eigenvalues over 141 scales).
    For a defective or ill-conditioned V the P is poor; it is only a candidate, which
    :meth:`StabilityScan.all_stable` checks before it uses it.
    """
    return _by_parts(_candidates, stack)


def _candidates(stack: NDArray[np.float64]) -> NDArray[np.float64]:
    V = np.linalg.eig(stack)[1]
    Vinv = np.linalg.inv(V)
    P = (np.swapaxes(Vinv, 1, 2).conj() @ Vinv).real
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
            # on the threads from _CHECKS_ON_THREADS states: on the 6-joint arm's scan (1 267 loops of 18)
            # 2.1x faster than on one, mostly by the temporaries each thread's allocator keeps instead of
            # asking the system again; on the SCARA's 1 024 corners of 6 states 8 % slower
            check = _by_parts if stack.shape[-1] >= _CHECKS_ON_THREADS else (lambda fn, *args: fn(*args))
            unknown = np.flatnonzero(~check(_lyapunov_holds, stack, self._P))
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
