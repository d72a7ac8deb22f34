"""Linear time-varying models with interval-bounded elements (paper Eqs. 4-5).

``ẋ = (A + ΔA(t)) x + (B + ΔB(t)) u`` where each uncertain element ``h_j(t)`` of ΔA or
ΔB stays in ``[lower_j, upper_j]``.

Indexing, once for the whole package: rows and columns are **0-based**, as in numpy,
in constructors, labels (``ΔA[4, 3]``) and tables alike. The paper numbers them from 1:
its ΔA(5, 4) is ``ΔA[4, 3]`` here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._resources import check_memory, corners_bytes
from .._validation import check_array, check_choice, check_int, check_real
from ..exceptions import ArgumentTypeError, ArgumentValueError

__all__ = ["UncertainElement", "UncertainLTVModel", "ELEMENT_SETS", "ANCHORS"]

Array = NDArray[np.float64]
#: Which uncertain elements vary: all of them, those of A only, or those of B only.
ELEMENT_SETS = ("all", "A", "B")
#: Points a box or polytope is scaled about (:meth:`UncertainLTVModel.scaled`): the design
#: plant at the lower corner (the paper's convention, the default) or the set's centre.
ANCHORS = ("lower", "center")


def state_space(sys: Any, name: str = "sys") -> ct.StateSpace:
    """A continuous-time ``control.StateSpace`` from `sys` (a StateSpace, a TransferFunction, ...).

    Parameters
    ----------
    sys : control.StateSpace, control.TransferFunction or anything ``control.ss`` takes
    name : str
        The argument's name, for errors.

    Returns
    -------
    control.StateSpace

    Raises
    ------
    ArgumentTypeError
        If ``control.ss`` cannot convert `sys`.
    ArgumentValueError
        If `sys` is discrete-time.
    """
    if isinstance(sys, ct.StateSpace):
        ss = sys
    else:
        try:
            ss = ct.ss(sys)
        except (TypeError, ValueError, ct.ControlArgument) as err:
            raise ArgumentTypeError(
                name, f"must be a control.StateSpace or what control.ss converts, found {type(sys).__name__}"
            ) from err
    if not ct.isctime(ss, strict=False) or (ss.dt not in (0, None)):
        raise ArgumentValueError(name, f"must be continuous-time (dt = 0), found dt = {ss.dt}: discretize after design")
    return ss


@dataclass(frozen=True)
class UncertainElement:
    """One time-varying element ``h(t) ∈ [lower, upper]`` of ΔA or ΔB.

    Parameters
    ----------
    matrix : {'A', 'B'}
        Which matrix the element perturbs.
    row, col : int
        0-based position in that matrix (the paper's ΔA(5, 4) is ``row=4, col=3``).
    lower, upper : float
        Bounds of ``h(t)``, in the units of the matrix element; ``lower <= upper``.
    """

    matrix: Literal["A", "B"]
    row: int
    col: int
    lower: float
    upper: float

    def __post_init__(self) -> None:
        check_choice("matrix", self.matrix, ("A", "B"))
        for name in ("row", "col"):
            value = getattr(self, name)
            object.__setattr__(self, name, check_int(name, value, 0))
        lo = check_real("lower", self.lower)
        hi = check_real("upper", self.upper)
        if lo > hi:
            raise ValueError(f"`lower` must be <= `upper` for element {self.label}, found {lo} > {hi}")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @property
    def label(self) -> str:
        """0-based label in numpy's notation, e.g. ``ΔA[4, 3]`` (the paper's ΔA(5, 4))."""
        return f"Δ{self.matrix}[{self.row}, {self.col}]"

    @property
    def width(self) -> float:
        """``upper - lower``."""
        return self.upper - self.lower


#: An element, or its fields ``(matrix, row, col, lower, upper)``.
ElementLike = UncertainElement | tuple[str, int, int, float, float]


def as_element(value: Any, name: str = "element") -> UncertainElement:
    """`value` as an :class:`UncertainElement` (it may be one, or its five fields).

    Parameters
    ----------
    value : UncertainElement or tuple (matrix, row, col, lower, upper)
    name : str
        The argument's name, for errors.

    Returns
    -------
    UncertainElement
    """
    if isinstance(value, UncertainElement):
        return value
    if not isinstance(value, (tuple, list)) or len(value) != 5:
        raise ArgumentTypeError(
            name, f"must be an UncertainElement or (matrix, row, col, lower, upper), found {value!r}"
        )
    matrix, row, col, lower, upper = value
    kind = cast(Literal["A", "B"], check_choice(f"{name}.matrix", matrix, ("A", "B")))
    return UncertainElement(kind, row, col, lower, upper)


@dataclass(frozen=True)
class UncertainLTVModel:
    """``ẋ = (A + ΔA(t)) x + (B + ΔB(t)) u`` with interval-bounded elements.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Known part of the state matrix.
    B : array_like, shape (n, m)
        Known part of the input matrix.
    elements : sequence of UncertainElement
        The time-varying elements, each in its own position (no duplicates).
    name : str
        Label used in tables and plots.
    n_joints : int, optional
        For a model in the paper's PID form ``x = [∫e, e, ė]`` (Eq. 4), the number of
        joints p (n = 3p): the design's gain then splits into PID matrices. None otherwise.

    Notes
    -----
    Nothing here is SCARA-specific: any ``(A, B, elements)`` is accepted.

    Examples
    --------
    >>> import scara_robust as sr
    >>> el = sr.UncertainElement("A", 1, 0, -0.5, 0.5)
    >>> model = sr.UncertainLTVModel([[0, 1], [0, 0]], [[0], [1]], [el])
    >>> model.n_states, model.n_inputs, model.n_elements
    (2, 1, 1)
    """

    A: Array
    B: Array
    elements: tuple[UncertainElement, ...] = ()
    name: str = "model"
    n_joints: int | None = None

    def __post_init__(self) -> None:
        A = check_array("A", self.A, ndim=2)
        if A.shape[0] != A.shape[1] or A.shape[0] == 0:
            raise ValueError(f"`A` must be square and non-empty, found shape {A.shape}")
        B = check_array("B", self.B, ndim=2)
        if B.shape[0] != A.shape[0] or B.shape[1] == 0:
            raise ValueError(f"`B` must have shape ({A.shape[0]}, m) with m >= 1, found shape {B.shape}")
        elements = tuple(self.elements)
        seen: set[tuple[str, int, int]] = set()
        for k, el in enumerate(elements):
            if not isinstance(el, UncertainElement):
                raise TypeError(f"`elements[{k}]` must be an UncertainElement, found {type(el).__name__}")
            shape = A.shape if el.matrix == "A" else B.shape
            if el.row >= shape[0] or el.col >= shape[1]:
                raise ValueError(f"`elements[{k}]` {el.label} lies outside {el.matrix} of shape {shape}")
            key = (el.matrix, el.row, el.col)
            if key in seen:
                raise ValueError(f"`elements[{k}]` {el.label} appears twice")
            seen.add(key)
        for name, value in (("A", A), ("B", B)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "elements", elements)
        if self.n_joints is not None:
            joints = check_int("n_joints", self.n_joints, 1)
            if A.shape[0] != 3 * joints or B.shape[1] < 1:
                raise ValueError(f"`n_joints` = {joints} needs n = 3 n_joints states, found n = {A.shape[0]}")

    @classmethod
    def from_system(
        cls,
        sys: Any,
        elements: Sequence[ElementLike] = (),
        *,
        name: str | None = None,
    ) -> UncertainLTVModel:
        """The model of a continuous-time python-control system with uncertain elements.

        Parameters
        ----------
        sys : control.StateSpace, control.TransferFunction or anything ``control.ss`` takes
            The nominal plant, continuous time. Only its A and B enter (C and D do not:
            the state is fed back).
        elements : sequence of UncertainElement or (matrix, row, col, lower, upper)
            The time-varying elements, 0-based positions in the system's A or B.
        name : str, optional
            Default: the system's name.

        Returns
        -------
        UncertainLTVModel

        Raises
        ------
        ArgumentTypeError
            If `sys` is not something ``control.ss`` converts.
        ArgumentValueError
            If `sys` is discrete-time.

        Examples
        --------
        >>> import control as ct, scara_robust as sr
        >>> G = ct.tf([1], [1, 2, 1])
        >>> sr.UncertainLTVModel.from_system(G, [("A", 0, 0, -0.1, 0.1)]).n_states
        2
        """
        ss = state_space(sys, "sys")
        els = tuple(as_element(el, f"elements[{k}]") for k, el in enumerate(elements))
        return cls(ss.A, ss.B, els, name=name if name is not None else str(ss.name))

    @property
    def n_states(self) -> int:
        """Number of states n."""
        return int(self.A.shape[0])

    @property
    def n_inputs(self) -> int:
        """Number of inputs m."""
        return int(self.B.shape[1])

    @property
    def n_elements(self) -> int:
        """Number of uncertain elements N."""
        return len(self.elements)

    def subset(self, elements: str = "all") -> UncertainLTVModel:
        """The same model with only the ΔA (``'A'``) or ΔB (``'B'``) elements varying, or all.

        The elements left out stay at their lower bounds: each one's lower bound is added
        to its entry of the nominal A or B, so the subset describes the same matrices
        with fewer of them varying.

        Parameters
        ----------
        elements : {'all', 'A', 'B'}

        Returns
        -------
        UncertainLTVModel
        """
        check_choice("elements", elements, ELEMENT_SETS)
        if elements == "all":
            return self
        nominal = {"A": self.A.copy(), "B": self.B.copy()}
        for el in self.elements:
            if el.matrix != elements:
                nominal[el.matrix][el.row, el.col] += el.lower
        kept = tuple(el for el in self.elements if el.matrix == elements)
        return UncertainLTVModel(
            nominal["A"], nominal["B"], kept, name=f"{self.name} [{elements} only]", n_joints=self.n_joints,
        )

    def scaled(self, theta: float, anchor: str = "lower") -> UncertainLTVModel:
        """The same model with every element range scaled by θ about an anchor.

        ``anchor='lower'`` (the paper's convention: the design plant is the box's lower
        corner) gives ``[θ·lower, θ·upper]``, so θ = 0 is the nominal; ``anchor='center'``
        gives ``[c − θw/2, c + θw/2]`` with ``c`` the range's centre and ``w`` its width,
        so θ = 0 is the box's centre. Both give the model itself at θ = 1.

        Parameters
        ----------
        theta : float
            θ >= 0.
        anchor : {'lower', 'center'}

        Returns
        -------
        UncertainLTVModel
        """
        theta = check_real("theta", theta, nonnegative=True)
        check_choice("anchor", anchor, ANCHORS)
        if anchor == "lower":
            ranges = [(theta * el.lower, theta * el.upper) for el in self.elements]
        else:
            ranges = [(0.5 * (el.lower + el.upper) - 0.5 * theta * (el.upper - el.lower),
                       0.5 * (el.lower + el.upper) + 0.5 * theta * (el.upper - el.lower)) for el in self.elements]
        els = tuple(UncertainElement(el.matrix, el.row, el.col, lo, hi) for el, (lo, hi) in zip(self.elements, ranges))
        return UncertainLTVModel(self.A, self.B, els, name=f"{self.name} x {theta:g} ({anchor})",
                                 n_joints=self.n_joints)

    def centered(self) -> UncertainLTVModel:
        """The same box with the nominal at its centre: elements ``[−w/2, w/2]`` about ``A + ΔA(c)``.

        The set of matrices is unchanged; the design plant (``design`` uses the nominal)
        moves from the lower corner (the paper's convention) to the centre of the box.

        Returns
        -------
        UncertainLTVModel

        Examples
        --------
        >>> import scara_robust as sr
        >>> m = sr.paper_model().centered()
        >>> m.elements[0].lower == -m.elements[0].upper
        True
        """
        A, B = self.A.copy(), self.B.copy()
        els = []
        for el in self.elements:
            c, half = 0.5 * (el.lower + el.upper), 0.5 * (el.upper - el.lower)
            (A if el.matrix == "A" else B)[el.row, el.col] += c
            els.append(UncertainElement(el.matrix, el.row, el.col, -half, half))
        return UncertainLTVModel(A, B, tuple(els), name=self.name, n_joints=self.n_joints)

    # --- the interface every uncertainty set shares with PolytopicModel -------------------

    @property
    def kind(self) -> str:
        """``'box'``: an interval box (a :class:`PolytopicModel` says ``'polytope'``)."""
        return "box"

    @property
    def capabilities(self) -> frozenset[str]:
        """``{'intervals', 'vertices'}`` (see :data:`~scara_robust.CAPABILITIES`)."""
        return frozenset({"intervals", "vertices"})

    @property
    def is_fixed(self) -> bool:
        """True when nothing varies (no elements)."""
        return self.n_elements == 0

    def interval_hull(self) -> UncertainLTVModel:
        """The interval box holding the set: the model itself."""
        return self

    def vertex_matrices(self) -> tuple[Array, Array]:
        """``(A_v, B_v)`` at the 2^N corners of the box, shapes (2^N, n, n) and (2^N, n, m)."""
        A, B = self.matrices_at(self.box_vertices())
        return np.asarray(A, dtype=float), np.asarray(B, dtype=float)

    def vertex_points(self) -> Array:
        """What identifies each vertex: the element values, shape (2^N, N)."""
        return self.box_vertices()

    def vertex_closed_loops(self, K: ArrayLike) -> Array:
        """``A + ΔA_v − (B + ΔB_v)K`` at every corner, shape (2^N, n, n)."""
        H = self.box_vertices()
        K = check_array("K", K, shape=(self.n_inputs, self.n_states))
        E = self.perturbation_matrices(K)
        base = self.A - self.B @ K
        return np.asarray(base[None] + np.einsum("vj,jik->vik", H, E), dtype=float)

    def affine_vertex_loops(self, K: ArrayLike, elements: str = "all", anchor: str = "lower") -> tuple[Array, Array]:
        """``(C, D)`` with the scaled set's vertex closed loops ``(A − BK) + C + θ·D_v``.

        Parameters
        ----------
        K : array_like, shape (m, n)
        elements : {'all', 'A', 'B'}
            The elements that scale (the others held at their lower bounds).
        anchor : {'lower', 'center'}

        Returns
        -------
        C : ndarray, shape (n, n)
        D : ndarray, shape (2^N', n, n)
        """
        check_choice("elements", elements, ELEMENT_SETS)
        check_choice("anchor", anchor, ANCHORS)
        sub = self.subset(elements)
        held = np.array([elements not in ("all", el.matrix) for el in self.elements], dtype=bool)
        E_all = self.perturbation_matrices(K)
        E_sub = sub.perturbation_matrices(K)
        shift = np.einsum("j,jik->ik", self.lower_bounds() * held, E_all)
        D = shift + np.einsum("vj,jik->vik", sub.box_vertices(), E_sub)
        C = np.zeros((self.n_states, self.n_states))
        if anchor == "center":  # vertex v at θ: c + θ(h_v − c), with h_v its corner and c the centre
            centre = 0.5 * (sub.lower_bounds() + sub.upper_bounds())
            C = np.einsum("j,jik->ik", centre, E_sub)
            D = D - C
        return C, np.asarray(D, dtype=float)

    def box_vertices(self) -> Array:
        """All 2^N corners of the interval box: row v holds the element values of vertex v.

        Bit j of v selects the upper bound of element j.

        Returns
        -------
        ndarray, shape (2**N, N)
        """
        n = self.n_elements
        check_memory("model", corners_bytes(n, self.n_states),
                     f"the 2^{n} = {2.0**n:.3g} corners of its box (exact vertex tests); use Theorem 1, "
                     "the LMI on samples or the falsifier instead")
        bits = (np.arange(2**n)[:, None] >> np.arange(n)[None, :]) & 1
        lower, upper = self.lower_bounds(), self.upper_bounds()
        return np.asarray(lower + bits * (upper - lower), dtype=float)

    def lower_bounds(self) -> Array:
        """Lower bounds, shape (N,)."""
        return np.array([el.lower for el in self.elements], dtype=float)

    def upper_bounds(self) -> Array:
        """Upper bounds, shape (N,)."""
        return np.array([el.upper for el in self.elements], dtype=float)

    def perturbation_factors(self, K: ArrayLike) -> tuple[Array, Array]:
        """Rank-one factors ``E_j = a_j b_jᵀ`` of the matrices of :meth:`perturbation_matrices`.

        ``a_j = e_i`` for an element in row i; ``b_j = e_k`` for ΔA(i, k) and
        ``b_j = -K[k, :]`` for ΔB(i, k).

        Parameters
        ----------
        K : array_like, shape (..., m, n)
            State-feedback gain, or a stack of gains.

        Returns
        -------
        a : ndarray, shape (N, n)
        b : ndarray, shape (..., N, n)
        """
        K = check_array("K", K)
        if K.ndim < 2 or K.shape[-2:] != (self.n_inputs, self.n_states):
            raise ValueError(f"`K` must have shape (..., {self.n_inputs}, {self.n_states}), found {K.shape}")
        a = np.zeros((self.n_elements, self.n_states))
        b = np.zeros((*K.shape[:-2], self.n_elements, self.n_states))
        for j, el in enumerate(self.elements):
            a[j, el.row] = 1.0
            if el.matrix == "A":
                b[..., j, el.col] = 1.0
            else:
                b[..., j, :] = -K[..., el.col, :]
        return a, b

    def perturbation_matrices(self, K: ArrayLike) -> Array:
        """The matrices ``E_j`` of Eq. (5) for the closed loop ``u = -K x``.

        ``E_j = e_i e_jᵀ`` for ΔA(i, j); for ΔB(i, k), ``ΔB u = -ΔB K x``, so ``E_j`` is
        zero but for row i, which holds ``-K[k, :]``.

        Parameters
        ----------
        K : array_like, shape (m, n)
            State-feedback gain.

        Returns
        -------
        ndarray, shape (N, n, n)
        """
        K = check_array("K", K, shape=(self.n_inputs, self.n_states))
        a, b = self.perturbation_factors(K)
        return a[:, :, None] * b[:, None, :]

    def matrices_at(self, h: ArrayLike) -> tuple[Array, Array]:
        """``(A + ΔA, B + ΔB)`` for element values `h` of shape (N,) (or (k, N) → batched)."""
        h = check_array("h", h)
        if h.shape[-1:] != (self.n_elements,):
            raise ValueError(f"`h` must have last dimension {self.n_elements}, found shape {h.shape}")
        A = np.broadcast_to(self.A, h.shape[:-1] + self.A.shape).copy()
        B = np.broadcast_to(self.B, h.shape[:-1] + self.B.shape).copy()
        for j, el in enumerate(self.elements):
            target = A if el.matrix == "A" else B
            target[..., el.row, el.col] += h[..., j]
        return A, B

    def to_pandas(self) -> pd.DataFrame:
        """One row per element: label, matrix, 0-based row and column, nominal, lower, upper."""
        rows = []
        for el in self.elements:
            nominal = (self.A if el.matrix == "A" else self.B)[el.row, el.col]
            rows.append(
                {
                    "label": el.label,
                    "matrix": el.matrix,
                    "row": el.row,
                    "col": el.col,
                    "nominal": nominal,
                    "lower": el.lower,
                    "upper": el.upper,
                }
            )
        return pd.DataFrame(rows, columns=["label", "matrix", "row", "col", "nominal", "lower", "upper"])

    def bounds_table(self, matrix: Literal["A", "B"], offset: tuple[int, int] = (0, 0)) -> pd.DataFrame:
        """Bounds laid out like the paper's Tables 1-2: columns ``(i, j)``, rows h_l, h_u.

        Parameters
        ----------
        matrix : {'A', 'B'}
        offset : tuple of int
            Subtracted from the 0-based positions, e.g. ``(4, 3)`` numbers ΔA's elements
            as ΔA*'s, like Table 1 (whose ΔA*(1, 1) is ``[0, 0]`` here).
        """
        check_choice("matrix", matrix, ("A", "B"))
        els = [el for el in self.elements if el.matrix == matrix]
        cols = [f"[{el.row - offset[0]}, {el.col - offset[1]}]" for el in els]
        data = [[el.lower for el in els], [el.upper for el in els]]
        return pd.DataFrame(data, index=pd.Index(["h_l", "h_u"], name="(i, j)"), columns=cols)
