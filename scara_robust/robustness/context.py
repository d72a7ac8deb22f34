"""What a registered method is given: one design on one uncertainty set, with the sets it may test.

:class:`CertificateContext` is built once per :func:`~scara_robust.certificate_table` call and
handed to every method of the ``'certificate'`` family. It computes each set of closed loops
the first time a method asks for it and keeps it for the next (the box's corners, the
plant's frozen plants on a grid), so two methods on one set share one computation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..lyapunov.gain import Design
from ..model.base import CAPABILITIES
from ..model.plant import UncertainPlant
from ..model.polytopic import PolytopicModel
from ..model.uncertain import UncertainLTVModel
from .polytope import MAX_BOX_ELEMENTS

__all__ = ["CertificateContext", "PayloadContext"]

Array = NDArray[np.float64]
#: Why a method that needs a capability cannot run without it.
_LACKING = {
    "intervals": "Theorem 1 needs interval elements; a polytope's box hull is model.box_hull()",
    "vertices": "needs a finite vertex set",
    "parameters": "needs a plant with physical parameters (its frozen plants on the parameter grid)",
    "rates": "needs a parameter with a rate bound (`rate` in the plant file)",
}
_Grid = tuple[tuple[str, int], ...]


@dataclass
class CertificateContext:
    """One design on one uncertainty set, and the options of the table that runs the methods.

    Attributes
    ----------
    model : UncertainLTVModel or PolytopicModel
        The uncertainty set (an interval box or a polytope).
    design : Design
        The design K and its P.
    plant : UncertainPlant or None
        The plant whose frozen plants make the sampled sets (None: no parameters).
    grid, fine, coarse : dict of str to int
        Points per parameter of the sampled set, of its refinement (``2k − 1``) and of the
        coarser set an LMI is solved on (empty without a plant).
    lmi_solver : str
    falsifier_tries : int
    seed : int
    """

    model: UncertainLTVModel | PolytopicModel
    design: Design
    plant: UncertainPlant | None
    grid: dict[str, int] = field(default_factory=dict)
    fine: dict[str, int] = field(default_factory=dict)
    coarse: dict[str, int] = field(default_factory=dict)
    lmi_solver: str | None = None
    falsifier_tries: int = 30
    seed: int = 0
    _sampled: dict[_Grid, tuple[Array, Array, tuple[str, ...]]] = field(default_factory=dict, repr=False)
    _box: Array | None = field(default=None, repr=False)

    @property
    def capabilities(self) -> frozenset[str]:
        """What the tested set can do, and the plant's parameters and rates (:data:`~scara_robust.CAPABILITIES`)."""
        extra = self.plant.capabilities & {"parameters", "rates"} if self.plant is not None else frozenset()
        return self.model.capabilities | extra

    @property
    def is_polytope(self) -> bool:
        """True when the set has no interval elements (its ``-box`` rows run over its vertices)."""
        return "intervals" not in self.model.capabilities

    @property
    def n_elements(self) -> int:
        """Interval elements of the box (0 for a polytope)."""
        return 0 if self.is_polytope else len(self.model.elements)  # type: ignore[union-attr]

    def missing(self, needs: frozenset[str]) -> str | None:
        """Why a method with these needs cannot run here, or None when it can.

        Parameters
        ----------
        needs : frozenset of str
            Items of :data:`~scara_robust.METHOD_NEEDS`.

        Returns
        -------
        str or None
        """
        lacking = [c for c in CAPABILITIES if c in needs and c not in self.capabilities]
        if lacking:
            return _LACKING[lacking[0]]
        if "vertices" in needs and self.n_elements > MAX_BOX_ELEMENTS:
            return (f"the box has 2^{self.n_elements} = {2.0 ** self.n_elements:.3g} corners, beyond the exact "
                    f"vertex tests (at most 2^{MAX_BOX_ELEMENTS}); Theorem 1 and the physical rows answer")
        return None

    def vertex_loops(self) -> Array:
        """The closed loops at the set's vertices (the box's corners), shape (V, n, n)."""
        if self._box is None:
            self._box = np.asarray(self.model.vertex_closed_loops(self.design.K))
        return self._box

    def sampled(self, points: Mapping[str, int]) -> tuple[Array, Array, tuple[str, ...]]:
        """The plant's frozen closed loops on a grid, computed once per grid.

        Parameters
        ----------
        points : mapping of str to int
            Points per parameter.

        Returns
        -------
        loops : ndarray, shape (N, n, n)
        values : ndarray, shape (N, n_parameters)
            Each loop's parameter values, in their units.
        names : tuple of str
            The parameters' names, the columns of `values`.
        """
        key = tuple(sorted(points.items()))
        if key not in self._sampled:
            assert self.plant is not None, "sampled() needs a plant"
            s = self.plant.samples(points)
            self._sampled[key] = (s.closed_loops(self.design.K), s.values, s.names)
        return self._sampled[key]


@dataclass(frozen=True)
class PayloadContext:
    """One SCARA design and the payload sets a ``'payload'`` method tests, by peak mass.

    Attributes
    ----------
    design : Design
        A design for the SCARA's 6-state error model.
    closed_loops : callable ``closed_loops(mass, n_times, n_masses) -> ndarray, shape (N, 6, 6)``
        The robot's frozen closed loops along the reference for payloads in [0, mass] (kg),
        on a grid of `n_times` reference times by `n_masses` masses.
    n_times, n_masses : int
        The grid of the tests.
    lmi_times, lmi_masses : int
        The coarser grid an LMI is solved on (then verified on the other).
    """

    design: Design
    closed_loops: Callable[[float, int, int], Array]
    n_times: int
    n_masses: int
    lmi_times: int
    lmi_masses: int
