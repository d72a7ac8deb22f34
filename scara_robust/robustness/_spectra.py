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

from ..sdp._linalg import _factors, positive_definite

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
    The matrices found unstable by the last call are tried first: where one of them is still
    unstable (its eigenvalues, as :func:`spectral_abscissae` computes them) the answer is
    False without the others, the half of a bisection's steps that end unstable.

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
        self._unstable = np.zeros(0, dtype=np.int64)  # the matrices the last unstable answer found unstable
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
        if self._unstable.size and self._P is not None and self._P.shape == stack.shape:
            self.by_eigenvalues += self._unstable.size
            still = ~(lambda a: a < 0 if self.strict else a <= 0)(spectral_abscissae(stack[self._unstable]))
            if still.any():  # one of them still unstable: so is the stack
                self._unstable = self._unstable[still]
                return False
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
            self._unstable = unknown[~(abscissae < 0 if self.strict else abscissae <= 0)]
            return False
        self._P[unknown] = np.eye(stack.shape[1])  # a P ≻ 0 all the same, for a matrix with no candidate
        hurwitz = unknown[abscissae < 0]  # a zero real part (not strict) has no Lyapunov matrix
        if hurwitz.size:
            P = _lyapunov_candidates(stack[hurwitz])
            kept = positive_definite(P, _LYAPUNOV_MARGIN * np.linalg.norm(P, axis=(1, 2)))
            self._P[hurwitz[kept]] = P[kept]
        return True


#: Stacks up to this size take every matrix's eigenvalues (the screening below costs more than it saves).
_SCREEN_FROM = 64
#: Matrices whose eigenvalues are taken first: those with the largest Rayleigh quotient.
_SCREEN_FIRST = 8
#: Matrices per factorization once the screen has failed on the whole stack.
_SCREEN_CHUNK = 64
#: A matrix is screened out when ``(m − δ) I − M ≻ 0`` factors, ``δ`` this times ``|m| + ‖M‖_F``: far
#: beyond the rounding of the factorization and of ``eigvalsh`` (both about ``n u`` of that size).
_SCREEN_MARGIN = 1e-12


def largest_eigenvalue(stack: NDArray[np.float64]) -> float:
    """``max_i λmax(M_i)`` over a stack of symmetric matrices, equal to ``eigvalsh(stack)[:, -1].max()`` bit for bit.

    The eigenvalues are taken first of the :data:`_SCREEN_FIRST` matrices with the largest
    Rayleigh quotient ``vᵀM_iv`` (a lower bound of their λmax; v the top eigenvector of the
    stack's mean), giving a candidate m; every other matrix with ``(m − δ) I − M ≻ 0`` (one
    stacked Cholesky factorization, δ of :data:`_SCREEN_MARGIN`) has a computed λmax below m
    whatever the rounding, so it cannot be the largest; the eigenvalues of those that do not
    factor are taken too. Each matrix goes through the same ``eigvalsh`` as in one call on the
    whole stack, so the largest is the same number.

    Parameters
    ----------
    stack : ndarray, shape (N, n, n)
        Symmetric matrices (their lower triangle is read, as by ``numpy.linalg.eigvalsh``).

    Returns
    -------
    float
    """
    if stack.shape[0] <= _SCREEN_FROM or not np.isfinite(stack).all():
        return float(np.linalg.eigvalsh(stack)[:, -1].max())
    # which matrices to start from only guides the search (a symmetric matrix's upper triangle is its lower
    # one's but for rounding, which the margin covers)
    v = np.linalg.eigh(stack.mean(axis=0))[1][:, -1]
    order = np.argpartition(-((stack @ v) @ v), _SCREEN_FIRST)
    first, rest = order[:_SCREEN_FIRST], np.sort(order[_SCREEN_FIRST:])
    best = float(np.linalg.eigvalsh(stack[first])[:, -1].max())
    # (best − δ) I − M on the lower triangle: where it factors, M's computed λmax is below best
    shifted = -stack[rest]
    shifted += (best - _SCREEN_MARGIN * (abs(best) + np.linalg.norm(shifted, axis=(1, 2))))[:, None, None] \
        * np.eye(stack.shape[1])
    if _factors(shifted):
        return best
    for start in range(0, len(rest), _SCREEN_CHUNK):  # the chunks that do not factor: their eigenvalues
        part = slice(start, start + _SCREEN_CHUNK)
        if not _factors(shifted[part]):
            best = max(best, float(np.linalg.eigvalsh(stack[rest[part]])[:, -1].max()))
    return best
