"""Polytopic models: ``(A(t), B(t))`` anywhere in the convex hull of given vertices ``(A_i, B_i)``.

A polytope is the natural description when the plant is known at a few operating points
(three identified models, the extremes of a parameter). Theorem 1 needs interval elements
and does not apply; the exact vertex test, the common-P LMI and the falsifier do. A
polytope can be turned into the interval box around it (:meth:`PolytopicModel.box_hull`),
which always contains it and may contain much more (unstable corners included).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_real
from ..exceptions import ArgumentValueError
from .uncertain import ANCHORS, UncertainElement, UncertainLTVModel, state_space

__all__ = ["PolytopicModel"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PolytopicModel:
    """``ẋ = A(t) x + B(t) u`` with ``(A(t), B(t))`` in the convex hull of the vertices.

    Parameters
    ----------
    vertices_A : array_like, shape (V, n, n)
        State matrices at the vertices.
    vertices_B : array_like, shape (V, n, m)
        Input matrices at the vertices (zeros for an autonomous polytope).
    nominal : tuple of array_like, optional
        ``(A, B)`` at which a Riccati gain is designed; default the vertex average.
    name : str

    Attributes
    ----------
    A, B : ndarray
        The nominal matrices, shapes (n, n) and (n, m) (what :func:`scara_robust.design` uses).

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> A = [[[-1, 2], [1, -3]], [[-0.8, 1.5], [1.3, -2.7]], [[-1.4, 0.9], [0.7, -2.0]]]
    >>> sr.PolytopicModel(A, np.zeros((3, 2, 1))).n_vertices
    3
    """

    vertices_A: Array
    vertices_B: Array
    nominal: tuple[Any, Any] | None = None
    name: str = "polytope"

    def __post_init__(self) -> None:
        A_v = check_array("vertices_A", self.vertices_A, ndim=3)
        if A_v.shape[0] < 1 or A_v.shape[1] != A_v.shape[2] or A_v.shape[1] == 0:
            raise ArgumentValueError("vertices_A", f"must have shape (V >= 1, n, n), found {A_v.shape}")
        B_v = check_array("vertices_B", self.vertices_B, ndim=3)
        if B_v.shape[:2] != A_v.shape[:2] or B_v.shape[2] == 0:
            raise ArgumentValueError(
                "vertices_B", f"must have shape ({A_v.shape[0]}, {A_v.shape[1]}, m >= 1), found {B_v.shape}"
            )
        if self.nominal is None:
            A0, B0 = A_v.mean(axis=0), B_v.mean(axis=0)
        else:
            A0 = check_array("nominal[0]", self.nominal[0], shape=A_v.shape[1:])
            B0 = check_array("nominal[1]", self.nominal[1], shape=B_v.shape[1:])
        for value in (A_v, B_v, A0, B0):
            value.setflags(write=False)
        object.__setattr__(self, "vertices_A", A_v)
        object.__setattr__(self, "vertices_B", B_v)
        object.__setattr__(self, "nominal", (A0, B0))

    @classmethod
    def from_systems(cls, systems: Sequence[Any], *, name: str = "polytope", **kwargs: Any) -> PolytopicModel:
        """The polytope whose vertices are the (A, B) of continuous-time python-control systems.

        Parameters
        ----------
        systems : sequence of control.StateSpace, control.TransferFunction, ...
            One system per vertex, all with the same state and input sizes (the same
            realization: convert transfer functions consistently).
        name : str
        **kwargs
            ``nominal``, passed on.

        Returns
        -------
        PolytopicModel
        """
        if not len(systems):
            raise ArgumentValueError("systems", "must hold at least one system, found none")
        ss = [state_space(s, f"systems[{i}]") for i, s in enumerate(systems)]
        shapes = {(s.A.shape, s.B.shape) for s in ss}
        if len(shapes) != 1:
            raise ArgumentValueError("systems", f"must share one state and input size, found {sorted(shapes)}")
        return cls(np.array([s.A for s in ss]), np.array([s.B for s in ss]), name=name, **kwargs)

    @property
    def A(self) -> Array:
        """Nominal state matrix, shape (n, n)."""
        assert self.nominal is not None
        return np.asarray(self.nominal[0])

    @property
    def B(self) -> Array:
        """Nominal input matrix, shape (n, m)."""
        assert self.nominal is not None
        return np.asarray(self.nominal[1])

    @property
    def n_states(self) -> int:
        """n."""
        return int(self.vertices_A.shape[1])

    @property
    def n_inputs(self) -> int:
        """m."""
        return int(self.vertices_B.shape[2])

    @property
    def n_vertices(self) -> int:
        """V."""
        return int(self.vertices_A.shape[0])

    # --- the interface every uncertainty set shares with UncertainLTVModel ----------------

    @property
    def kind(self) -> str:
        """``'polytope'`` (an :class:`UncertainLTVModel` says ``'box'``)."""
        return "polytope"

    @property
    def capabilities(self) -> frozenset[str]:
        """``{'vertices'}`` (see :data:`~scara_robust.CAPABILITIES`)."""
        return frozenset({"vertices"})

    @property
    def is_fixed(self) -> bool:
        """True when every vertex is the same plant."""
        return bool(np.ptp(self.vertices_A, axis=0).max() == 0 and np.ptp(self.vertices_B, axis=0).max() == 0)

    def interval_hull(self) -> UncertainLTVModel:
        """The interval box holding the polytope (:meth:`box_hull`), for Theorem 1."""
        return self.box_hull()

    def subset(self, elements: str = "all") -> PolytopicModel:
        """The polytope itself: it has no elements to choose (`elements` must be ``'all'``)."""
        if elements != "all":
            raise ArgumentValueError("elements", f"must be 'all' for a PolytopicModel, found {elements!r}")
        return self

    def vertex_matrices(self) -> tuple[Array, Array]:
        """``(A_i, B_i)`` at the vertices, shapes (V, n, n) and (V, n, m)."""
        return np.asarray(self.vertices_A), np.asarray(self.vertices_B)

    def vertex_points(self) -> None:
        """Vertices are identified by their index alone."""
        return None

    def vertex_closed_loops(self, K: ArrayLike) -> Array:
        """``A_i − B_i K`` at every vertex, shape (V, n, n) (as :meth:`closed_loops`)."""
        return self.closed_loops(K)

    def affine_vertex_loops(self, K: ArrayLike, elements: str = "all", anchor: str = "lower") -> tuple[Array, Array]:
        """``(C, D)`` with the scaled polytope's vertex closed loops ``(A₀ − B₀K) + C + θ·D_i``."""
        self.subset(elements)
        check_choice("anchor", anchor, ANCHORS)
        loops = self.closed_loops(K)
        nominal = self.A - self.B @ np.asarray(K, dtype=float)
        centre = loops.mean(axis=0) if anchor == "center" else nominal
        return centre - nominal, np.asarray(loops - centre, dtype=float)

    def closed_loops(self, K: ArrayLike) -> Array:
        """``A_i − B_i K`` at every vertex, shape (V, n, n).

        Parameters
        ----------
        K : array_like, shape (m, n)
            Gain of ``u = −Kx``.

        Returns
        -------
        ndarray, shape (V, n, n)
        """
        K = check_array("K", K, shape=(self.n_inputs, self.n_states))
        return np.asarray(self.vertices_A - self.vertices_B @ K, dtype=float)

    def scaled(self, theta: float, anchor: str = "lower") -> PolytopicModel:
        """The polytope scaled by θ about an anchor.

        ``anchor='lower'`` scales about the nominal ``(A₀, B₀)`` (the design plant):
        vertices ``A₀ + θ(A_i − A₀)``; ``anchor='center'`` about the vertices' mean ``Ā``:
        ``Ā + θ(A_i − Ā)``. The nominal stays ``(A₀, B₀)``.

        Parameters
        ----------
        theta : float
            θ >= 0; 1 is the polytope itself.
        anchor : {'lower', 'center'}

        Returns
        -------
        PolytopicModel
        """
        theta = check_real("theta", theta, nonnegative=True)
        check_choice("anchor", anchor, ANCHORS)
        A0, B0 = self.A, self.B
        cA, cB = (A0, B0) if anchor == "lower" else (self.vertices_A.mean(axis=0), self.vertices_B.mean(axis=0))
        return PolytopicModel(
            cA + theta * (self.vertices_A - cA), cB + theta * (self.vertices_B - cB), nominal=(A0, B0),
            name=f"{self.name} x {theta:g} ({anchor})",
        )

    def box_hull(self, rtol: float = 1e-12) -> UncertainLTVModel:
        """The interval box around the polytope: each entry from its smallest to its largest vertex value.

        Parameters
        ----------
        rtol : float
            An entry varies when its range exceeds `rtol` times the largest magnitude of
            its matrix.

        Returns
        -------
        UncertainLTVModel
            Nominal matrices at the element-wise minima, each varying entry ``[0, max − min]``
            (the paper's convention). It contains the polytope, and its corners need not be
            in it.
        """
        rtol = check_real("rtol", rtol, nonnegative=True)
        elements: list[UncertainElement] = []
        nominal = {}
        for label, stack in (("A", self.vertices_A), ("B", self.vertices_B)):
            low, high = stack.min(axis=0), stack.max(axis=0)
            nominal[label] = low
            scale = max(float(np.abs(stack).max()), 1e-300)
            for i, j in zip(*np.nonzero(high - low > rtol * scale)):
                matrix: Literal["A", "B"] = "A" if label == "A" else "B"
                elements.append(UncertainElement(matrix, int(i), int(j), 0.0, float(high[i, j] - low[i, j])))
        return UncertainLTVModel(nominal["A"], nominal["B"], tuple(elements), name=f"box hull of {self.name}")
