"""An LMI problem described once: variables, blocks as sums of terms, and a linear objective.

Every LMI the package solves has the same shape: a few matrix variables (a common
Lyapunov matrix P, a gain's Y, the two halves P₀, P₁ of a parameter-dependent P), a few
scalars (a rate, a bound), and many blocks of one size, one per sampled plant, each a sum
of terms ``Uᵀ X V + Vᵀ Xᵀ U`` with the plant's own matrices U and V::

    S_b(y) = C_b + Σ_t (U_{t,b}ᵀ X_t V_{t,b} + V_{t,b}ᵀ X_tᵀ U_{t,b}) + Σ_j s_j G_{j,b}  ⪰ 0.

A **family** holds the blocks that share their terms' structure (one per plant), with U, V,
G and C stacked along a first axis; :meth:`LMIProblem.add_lmi` adds one. The vector ``y``
gathers the free entries of every variable (a symmetric X its upper triangle, a patterned X
only the entries its pattern allows), so ``S(y) = C + F(y)`` with F linear.

The structure is what the solver exploits (:mod:`scara_robust.sdp.ipm`): the Schur
complement ``M_pq = Σ_b tr(F_p W_b F_q W_b)`` of an interior-point step is, for two terms of
the same family, a sum over the blocks of Kronecker products of ``n × n`` matrices, formed as
one matrix product of size ``(n², N) × (N, n²)``: ``O(N n⁴)`` operations instead of the
``O(N n⁶)`` of the dense formula (:func:`dense_schur`, kept as its test).

References
----------
Boyd, El Ghaoui, Feron and Balakrishnan, *Linear Matrix Inequalities in System and Control
Theory*, SIAM 1994, §2.2 (the LMI form); Todd, Toh and Tütüncü, "On the Nesterov–Todd
direction in semidefinite programming", SIAM J. Optim. 8 (1998), §3 (the Schur complement).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array
from ..exceptions import ArgumentValueError

__all__ = ["LMIProblem", "LMIVariable", "LMIFamily", "dense_schur"]

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LMIVariable:
    """A matrix or scalar variable of an :class:`LMIProblem`.

    Attributes
    ----------
    name : str
    shape : tuple of int
        ``(r, c)``; ``(1, 1)`` for a scalar.
    symmetric : bool
    offset : int
        Its first free entry in the problem's vector ``y``.
    basis : ndarray, shape (r * c, p)
        ``vec(X) = basis @ y[offset:offset + p]`` (row-major vec); p free entries.
    scalar : bool
    """

    name: str
    shape: tuple[int, int]
    symmetric: bool
    offset: int
    basis: Array = field(repr=False)
    scalar: bool = False

    @functools.cached_property
    def size(self) -> int:
        """Free entries p."""
        return int(self.basis.shape[1])

    @functools.cached_property
    def slice(self) -> slice:
        """Its entries in ``y``."""
        return slice(self.offset, self.offset + self.size)

    @functools.cached_property
    def gather(self) -> tuple[NDArray[np.int64], NDArray[np.int64], Array]:
        """Each free entry's first and second entry of vec(X), and 1.0 where it has a second."""
        rows, cols = np.nonzero(self.basis.T)
        first = np.full(self.size, -1)
        second = np.zeros(self.size, dtype=np.int64)
        twice = np.zeros(self.size)
        for k, e in zip(rows, cols):
            if first[k] < 0:
                first[k] = e
            else:
                second[k], twice[k] = e, 1.0
        return first, second, twice

    def value(self, y: Array) -> Array:
        """The variable at ``y``: shape ``(r, c)`` (a float for a scalar is ``value(y)[0, 0]``)."""
        return (self.basis @ y[self.slice]).reshape(self.shape)


@dataclass(frozen=True, eq=False)
class LMIFamily:
    """N blocks of size s sharing their terms' structure.

    Attributes
    ----------
    terms : tuple of (LMIVariable, ndarray (N, r, s), ndarray (N, c, s))
        ``Uᵀ X V + Vᵀ Xᵀ U`` per block; terms of one variable that share V (or U) are one term,
        their U's (V's) added.
    scalars : tuple of (LMIVariable, ndarray (N, s, s))
        ``s_j G_j`` per block, G symmetric.
    const : ndarray, shape (N, s, s)
        C, symmetric.
    name : str
    """

    terms: tuple[tuple[LMIVariable, Array, Array], ...]
    scalars: tuple[tuple[LMIVariable, Array], ...]
    const: Array
    name: str = ""

    @property
    def count(self) -> int:
        """Blocks N."""
        return int(self.const.shape[0])

    @functools.cached_property
    def transposed(self) -> tuple[tuple[Array, Array], ...]:
        """``(Uᵀ, Vᵀ)`` of each term, shape (N, s, r) and (N, s, c), made once."""
        return tuple((np.ascontiguousarray(np.swapaxes(U, 1, 2)), np.ascontiguousarray(np.swapaxes(V, 1, 2)))
                     for _, U, V in self.terms)

    @property
    def size(self) -> int:
        """Block size s."""
        return int(self.const.shape[1])


def _basis(rows: int, cols: int, symmetric: bool, pattern: Array | None) -> Array:
    """``vec(X) = basis @ y`` for the free entries (upper triangle of a symmetric X), row-major."""
    allowed = np.ones((rows, cols), bool) if pattern is None else pattern != 0
    columns = []
    for i in range(rows):
        for j in range(i if symmetric else 0, cols):
            if allowed[i, j]:
                e = np.zeros((rows, cols))
                e[i, j] = 1.0
                if symmetric:
                    e[j, i] = 1.0
                columns.append(e.reshape(-1))
    return np.array(columns, dtype=float).T.reshape(rows * cols, len(columns))


class LMIProblem:
    """Maximize a linear objective subject to linear matrix inequalities ``S_b(y) ⪰ 0``.

    Build it with :meth:`symmetric`, :meth:`matrix`, :meth:`scalar`, :meth:`add_lmi` and
    :meth:`maximize`; solve it with :func:`~scara_robust.solve_lmi` (the package's
    interior-point method or cvxpy + Clarabel).

    Examples
    --------
    The largest t with ``tI ⪯ P ⪯ I`` and ``AᵀP + PA ⪯ −tI`` for ``A = −I`` is 1, at P = I:

    >>> import numpy as np
    >>> from scara_robust.sdp import LMIProblem, solve_lmi
    >>> pb = LMIProblem()
    >>> P, t = pb.symmetric("P", 2), pb.scalar("t")
    >>> half = 0.5 * np.eye(2)
    >>> _ = pb.add_lmi(terms=[(P, -half, np.eye(2))], const=np.eye(2))             # I − P ⪰ 0
    >>> _ = pb.add_lmi(terms=[(P, half, np.eye(2))], scalars=[(t, -np.eye(2))])    # P − tI ⪰ 0
    >>> A = -np.eye(2)
    >>> _ = pb.add_lmi(terms=[(P, -A, np.eye(2))], scalars=[(t, -np.eye(2))])      # −(AᵀP + PA) − tI ⪰ 0
    >>> pb.maximize({t: 1.0})
    >>> round(solve_lmi(pb).value(t), 6)
    1.0
    """

    def __init__(self) -> None:
        self.variables: list[LMIVariable] = []
        self.families: list[LMIFamily] = []
        self.objective: dict[LMIVariable, Array] = {}
        self._size = 0

    @property
    def n_free(self) -> int:
        """Entries of y."""
        return self._size

    def _add(self, name: str, rows: int, cols: int, symmetric: bool, pattern: ArrayLike | None,
             scalar: bool = False) -> LMIVariable:
        if any(v.name == name for v in self.variables):
            raise ArgumentValueError("name", f"must be new in the problem, found a second variable {name!r}")
        mask = None if pattern is None else check_array("pattern", pattern, shape=(rows, cols))
        if mask is not None and symmetric and not np.array_equal(mask != 0, (mask != 0).T):
            raise ArgumentValueError("pattern", f"of the symmetric variable {name!r} must be symmetric")
        var = LMIVariable(name, (rows, cols), symmetric, self._size, _basis(rows, cols, symmetric, mask), scalar)
        self._size += var.size
        self.variables.append(var)
        return var

    def copy(self) -> LMIProblem:
        """A problem with the same variables, blocks and objective, to which blocks can be added apart."""
        other = LMIProblem()
        other.variables, other.families, other._size = list(self.variables), list(self.families), self._size
        other.objective = dict(self.objective)
        return other

    def symmetric(self, name: str, n: int, *, pattern: ArrayLike | None = None) -> LMIVariable:
        """A symmetric ``n × n`` variable (entries where `pattern` is 0 held at 0)."""
        return self._add(name, n, n, True, pattern)

    def matrix(self, name: str, rows: int, cols: int, *, pattern: ArrayLike | None = None) -> LMIVariable:
        """A full ``rows × cols`` variable (entries where `pattern` is 0 held at 0)."""
        return self._add(name, rows, cols, False, pattern)

    def scalar(self, name: str) -> LMIVariable:
        """A real scalar variable."""
        return self._add(name, 1, 1, False, None, scalar=True)

    def add_lmi(self, *, terms: Sequence[tuple[LMIVariable, ArrayLike, ArrayLike]] = (),
                scalars: Sequence[tuple[LMIVariable, ArrayLike]] = (), const: ArrayLike | None = None,
                name: str = "") -> LMIFamily:
        """Add the blocks ``C + Σ (UᵀXV + VᵀXᵀU) + Σ s G ⪰ 0``.

        Parameters
        ----------
        terms : sequence of (LMIVariable, array_like (N, r, s) or (r, s), array_like (N, c, s) or (c, s))
            X with U and V; a 2-D U or V is the same for every block.
        scalars : sequence of (LMIVariable, array_like (N, s, s) or (s, s))
            A scalar variable and its symmetric G.
        const : array_like, shape (N, s, s) or (s, s), optional
            C (symmetric); zero by default.
        name : str

        Returns
        -------
        LMIFamily
        """
        shapes = [np.shape(a)[-1] for _, u, v in terms for a in (u, v)] + [np.shape(g)[-1] for _, g in scalars]
        if const is not None:
            shapes.append(np.shape(const)[-1])
        counts = [np.shape(a)[0] for _, u, v in terms for a in (u, v) if np.ndim(a) == 3]
        counts += [np.shape(g)[0] for _, g in scalars if np.ndim(g) == 3]
        if const is not None and np.ndim(const) == 3:
            counts.append(np.shape(const)[0])
        if not shapes or len(set(shapes)) != 1 or len(set(counts)) > 1:
            raise ArgumentValueError("terms", f"of one LMI must share the block size and count, found sizes "
                                              f"{shapes} and counts {counts}")
        s, N = shapes[0], (counts[0] if counts else 1)

        def stack(a: ArrayLike, rows: int, label: str) -> Array:
            arr = np.asarray(a, dtype=float)
            if arr.shape[-2:] != (rows, s):
                raise ArgumentValueError(label, f"must have shape (N, {rows}, {s}), found {arr.shape}")
            return np.ascontiguousarray(np.broadcast_to(arr, (N, rows, s)))

        term_list = []
        for var, U, V in terms:
            if var.scalar:
                raise ArgumentValueError("terms", f"take matrix variables; the scalar {var.name!r} goes in `scalars`")
            term_list.append((var, stack(U, var.shape[0], "U"), stack(V, var.shape[1], "V")))
        term_list = _merged(term_list)
        scalar_list = []
        for var, G in scalars:
            if not var.scalar:
                raise ArgumentValueError("scalars", f"take scalar variables, found the matrix {var.name!r}")
            Gs = stack(G, s, "G")
            scalar_list.append((var, 0.5 * (Gs + np.swapaxes(Gs, 1, 2))))
        C = np.zeros((N, s, s)) if const is None else stack(const, s, "const")
        family = LMIFamily(tuple(term_list), tuple(scalar_list), 0.5 * (C + np.swapaxes(C, 1, 2)), name)
        self.families.append(family)
        return family

    def maximize(self, objective: Mapping[LMIVariable, ArrayLike | float]) -> None:
        """Maximize ``Σ c_j s_j + Σ ⟨C_X, X⟩`` (a scalar's coefficient a float, a matrix's a matrix)."""
        self.objective = {var: np.broadcast_to(np.asarray(c, dtype=float), var.shape).copy()
                          for var, c in objective.items()}

    def minimize(self, objective: Mapping[LMIVariable, ArrayLike | float]) -> None:
        """Minimize: :meth:`maximize` of the opposite."""
        self.maximize({var: -np.asarray(c, dtype=float) for var, c in objective.items()})

    # --- the linear map and its adjoint -------------------------------------------------------

    def b(self) -> Array:
        """The objective's vector: maximize ``b @ y``."""
        out = np.zeros(self._size)
        for var, c in self.objective.items():
            out[var.slice] += var.basis.T @ c.reshape(-1)
        return out

    def blocks(self, y: Array, *, constant: bool = True) -> list[Array]:
        """``S_b(y)`` of every family (or only its linear part ``F(y)``): shape (N, s, s) each."""
        out = []
        for fam in self.families:
            S = fam.const.copy() if constant else np.zeros_like(fam.const)
            for (var, _, V), (Ut, _) in zip(fam.terms, fam.transposed):
                T = Ut @ (var.value(y) @ V)  # Uᵀ X V: (N, s, s)
                S += T + np.swapaxes(T, 1, 2)
            for var, G in fam.scalars:
                S += y[var.offset] * G
            out.append(S)
        return out

    def adjoint(self, Z: Sequence[Array]) -> Array:
        """``F*(Z)``: ``y ↦ Σ_b ⟨Z_b, F_b(y)⟩`` as a vector (Z symmetric, one (N, s, s) per family)."""
        out = np.zeros(self._size)
        for fam, Zf in zip(self.families, Z):
            for (var, U, _), (_, Vt) in zip(fam.terms, fam.transposed):
                grad = 2.0 * (U @ Zf @ Vt).sum(axis=0)
                out[var.slice] += var.basis.T @ grad.reshape(-1)
            for var, G in fam.scalars:
                out[var.offset] += float(np.vdot(G, Zf))
        return out

    def schur(self, W: Sequence[Array]) -> Array:
        """The Schur complement ``M_pq = Σ_b tr(F_p W_b F_q W_b)`` from the terms' Kronecker structure.

        Parameters
        ----------
        W : sequence of ndarray, shape (N, s, s)
            One symmetric matrix per block, per family.

        Returns
        -------
        ndarray, shape (n_free, n_free)
        """
        M = np.zeros((self._size, self._size))
        # Σ over the blocks and term pairs of the Hessian in the full entries of (X, X2): the
        # Kronecker factors of every family and term pair of one pair of variables are stacked
        # along the blocks' axis, so each pair of variables costs two matrix products, one
        # transposition and one projection on the free entries, however many families hold it
        factors: dict[tuple[int, int], list[list[Array]]] = {}
        for fam, Wf in zip(self.families, W):
            UW = [U @ Wf for _, U, _ in fam.terms]   # U W: (N, r, s)
            VW = [V @ Wf for _, _, V in fam.terms]   # V W: (N, c, s)
            tr = fam.transposed
            for a, (X, _, _) in enumerate(fam.terms):
                for b, (X2, _, _) in enumerate(fam.terms):
                    if X.offset > X2.offset:
                        continue
                    # (a, b) with X first; for one variable every ordered pair, (b, a) as well
                    lists = factors.setdefault((X.offset, X2.offset), [[], [], [], []])
                    lists[0].append(VW[a] @ tr[b][0])   # V W U2ᵀ: (N, c, r2)
                    lists[1].append(VW[b] @ tr[a][0])   # V2 W Uᵀ: (N, c2, r)
                    lists[2].append(VW[a] @ tr[b][1])   # V W V2ᵀ: (N, c, c2)
                    lists[3].append(UW[b] @ tr[a][0])   # U2 W Uᵀ: (N, r2, r)
            GW = [G @ Wf for _, G in fam.scalars]
            for j, (s_var, _) in enumerate(fam.scalars):
                for k in range(j, len(fam.scalars)):
                    value = float(np.vdot(GW[j], np.swapaxes(GW[k], 1, 2)))
                    M[s_var.offset, fam.scalars[k][0].offset] += value
                    if k != j:
                        M[fam.scalars[k][0].offset, s_var.offset] += value
                WGW = Wf @ GW[j]  # W G W
                for (X, U, _), (_, Vt) in zip(fam.terms, tr):
                    cross = 2.0 * (U @ WGW @ Vt).sum(axis=0)
                    vec = X.basis.T @ cross.reshape(-1)
                    M[s_var.offset, X.slice] += vec
                    M[X.slice, s_var.offset] += vec
        by_offset = {v.offset: v for v in self.variables}
        for (o1, o2), lists in factors.items():
            X, X2 = by_offset[o1], by_offset[o2]
            (r, c), (r2, c2) = X.shape, X2.shape
            t1, t2, t3, t4 = (np.concatenate(t) if len(t) > 1 else t[0] for t in lists)
            n = t1.shape[0]
            H1 = (t1.reshape(n, c * r2).T @ t2.reshape(n, c2 * r)).reshape(c, r2, c2, r)
            H2 = (t3.reshape(n, c * c2).T @ t4.reshape(n, r2 * r)).reshape(c, c2, r2, r)
            H = 2.0 * (H1.transpose(3, 0, 1, 2) + H2.transpose(3, 0, 2, 1)).reshape(r * c, r2 * c2)
            block = _project(X, _project(X2, H.T).T)
            M[X.slice, X2.slice] += block
            if o1 != o2:
                M[X2.slice, X.slice] += block.T
        return M


def _merged(terms: list[tuple[LMIVariable, Array, Array]]) -> list[tuple[LMIVariable, Array, Array]]:
    """The terms with those of one variable that share V (or U) as one: ``U₁ᵀXV + U₂ᵀXV = (U₁ + U₂)ᵀXV``.

    The blocks are the same sums; the Schur complement stacks a Kronecker factor for each
    ordered pair of terms, so k terms of one variable cost k² where one term costs one.
    """
    out: list[tuple[LMIVariable, Array, Array]] = []
    for var, U, V in terms:
        for k, (other, U2, V2) in enumerate(out):
            if other is not var:
                continue
            if np.array_equal(V, V2):
                out[k] = (var, U2 + U, V2)
                break
            if np.array_equal(U, U2):
                out[k] = (var, U2, V2 + V)
                break
        else:
            out.append((var, U, V))
    return out


def _project(X: LMIVariable, H: Array) -> Array:
    """``X.basisᵀ @ H`` by gathering rows: each free entry is one or two (symmetric) entries of vec(X)."""
    first, second, twice = X.gather
    out = H[first]
    if twice.any():
        out = out + twice[:, None] * H[second]
    return out


def dense_schur(problem: LMIProblem, W: Sequence[Array]) -> Array:
    """The Schur complement by its definition, ``tr(F_p W F_q W)`` for every pair: ``O(N s² p²)``.

    The reference :meth:`LMIProblem.schur` is tested against.

    Parameters
    ----------
    problem : LMIProblem
    W : sequence of ndarray, shape (N, s, s)

    Returns
    -------
    ndarray, shape (n_free, n_free)
    """
    p = problem.n_free
    M = np.zeros((p, p))
    for f, Wf in enumerate(W):
        F = []
        for k in range(p):
            e = np.zeros(p)
            e[k] = 1.0
            F.append(problem.blocks(e, constant=False)[f])
        FW = [Fk @ Wf for Fk in F]
        for i in range(p):
            for j in range(i, p):
                M[i, j] += float(np.einsum("nst,nts->", FW[i], FW[j]))
                M[j, i] = M[i, j]
    return M
