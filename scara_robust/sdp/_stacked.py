"""A small LMI problem as dense matrices: its blocks grouped by size, its linear map one matrix per group.

On a small problem (a 6-state loop with tens of plants) an interior-point iteration of
:mod:`scara_robust.sdp.ipm` spends its time in Python-level calls, not in arithmetic: a
call per term and per family in every :meth:`~scara_robust.sdp.problem.LMIProblem.blocks`
and :meth:`~scara_robust.sdp.problem.LMIProblem.adjoint` (seven of each an iteration with
the iterative refinement) and factorizations per family. :class:`StackedProblem` forms the
linear map once as a dense matrix per block size, ``vec(F_g(y)) = 𝔽_g y`` (the families of
one size stacked along their first axis), so that the map and its adjoint are one matrix
product per size, and the scaling, step lengths and factorizations are batched per size. The
Schur complement stays the Kronecker-structured one of the families. The dense map costs
``O(N s² p)`` memory and time a product (N blocks of size s, p free entries): the
interior-point method stacks a problem where that is at most :data:`DENSE_ENTRIES`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .problem import LMIFamily, LMIProblem

__all__ = ["StackedProblem", "DENSE_ENTRIES"]

Array = NDArray[np.float64]

#: The largest ``Σ_f N_f s_f² p`` (the dense linear maps' entries, at most) for which the
#: interior-point method stacks a problem (4 MB of float64; above it the map of a family
#: term by term is faster: 0.30 against 0.34 ms on 60 blocks of a 9-state loop, 680 000 entries).
DENSE_ENTRIES = 500_000


@dataclass(frozen=True)
class _Group:
    """The blocks of one size: C (N, s, s), the map's columns that are not zero and their matrix."""

    const: Array
    columns: NDArray[np.int64]
    F: Array                      # (N s², len(columns)): vec(F_b(y)) = F @ y[columns]
    members: tuple[tuple[int, int, int], ...]  # (family index, first block, last block + 1)

    @property
    def count(self) -> int:
        return int(self.const.shape[0])

    @property
    def size(self) -> int:
        return int(self.const.shape[1])


def _family_map(problem: LMIProblem, fam: LMIFamily) -> Array:
    """The family's linear map as ``(N, s, s, p)``: the blocks ``F_b(e_k)`` of every unit vector."""
    N, s, p = fam.count, fam.size, problem.n_free
    out = np.zeros((N, s, s, p))
    for var, U, V in fam.terms:
        X = var.basis.T.reshape(var.size, *var.shape)                   # each free entry's X: (k, r, c)
        T = np.einsum("nrs,krc,nct->nstk", U, X, V, optimize=True)  # Uᵀ X_k V: (N, s, s, k)
        out[..., var.slice] += T + np.swapaxes(T, 1, 2)
    for var, G in fam.scalars:
        out[..., var.offset] += G
    return out


class StackedProblem:
    """An :class:`~scara_robust.sdp.problem.LMIProblem`'s blocks grouped by size, its map as dense matrices.

    It answers what the interior-point method asks of a problem (:attr:`families` with
    ``const``, ``count`` and ``size``; :meth:`b`, :attr:`n_free`, :meth:`blocks`,
    :meth:`adjoint`, :meth:`schur`), on the groups instead of the families, and
    :meth:`split` gives a group's dual blocks back per family.

    Parameters
    ----------
    problem : LMIProblem
    """

    def __init__(self, problem: LMIProblem) -> None:
        self.problem = problem
        sizes: dict[int, list[int]] = {}
        for i, fam in enumerate(problem.families):
            sizes.setdefault(fam.size, []).append(i)
        groups = []
        for members in sizes.values():
            maps = [_family_map(problem, problem.families[i]) for i in members]
            full = np.concatenate(maps)                                   # (N, s, s, p)
            columns = np.flatnonzero(np.any(full != 0, axis=(0, 1, 2)))
            bounds, start = [], 0
            for i in members:
                bounds.append((i, start, start + problem.families[i].count))
                start += problem.families[i].count
            groups.append(_Group(np.concatenate([problem.families[i].const for i in members]), columns,
                                 np.ascontiguousarray(full[..., columns].reshape(-1, len(columns))), tuple(bounds)))
        self.families: list[_Group] = groups
        self.n_free = problem.n_free

    @staticmethod
    def entries(problem: LMIProblem) -> int:
        """``Σ N s² p`` over the families (p the problem's free entries): the dense maps' size bound."""
        return sum(f.count * f.size**2 for f in problem.families) * problem.n_free

    def b(self) -> Array:
        """The objective's vector (the problem's)."""
        return self.problem.b()

    def blocks(self, y: Array, *, constant: bool = True) -> list[Array]:
        """``S(y)`` (or ``F(y)``) per group: shape (N, s, s) each."""
        out = []
        for g in self.families:
            lin = (g.F @ y[g.columns]).reshape(g.const.shape)
            out.append(g.const + lin if constant else lin)
        return out

    def adjoint(self, Z: Sequence[Array]) -> Array:
        """``F*(Z)`` for Z per group."""
        out = np.zeros(self.n_free)
        for g, Zg in zip(self.families, Z):
            out[g.columns] += Zg.reshape(-1) @ g.F
        return out

    def schur(self, W: Sequence[Array]) -> Array:
        """``M_pq = Σ_b tr(F_p W_b F_q W_b)`` for W per group, shape (n_free, n_free).

        The problem's own Kronecker-structured :meth:`~scara_robust.sdp.problem.LMIProblem.schur`
        on W split per family: ``O(N n⁴)``, where the dense map's ``Σ 𝔽ᵀ(W ⊗ W)𝔽`` costs
        ``O(N s² p²)`` (already 4 times more at 120 blocks of 8 rows).
        """
        return self.problem.schur(self.split(W))

    def split(self, Z: Sequence[Array]) -> list[Array]:
        """Dual blocks per group → per family of the problem (its order)."""
        out: list[Array] = [np.zeros((0, 0, 0))] * len(self.problem.families)
        for g, Zg in zip(self.families, Z):
            for i, start, stop in g.members:
                out[i] = Zg[start:stop]
        return out
