"""What every uncertain system of the package is: the protocol the analyses take, and its capabilities.

An interval box (:class:`~scara_robust.UncertainLTVModel`), a polytope
(:class:`~scara_robust.PolytopicModel`) and a plant over physical parameters
(:class:`~scara_robust.UncertainPlant`: a plant file, the SCARA of
:func:`~scara_robust.scara_uncertain_plant`, an arm of :func:`~scara_robust.arm_uncertain_plant`)
all are an :class:`UncertainSystem`. Code above the model layer asks what a system can do
(:data:`CAPABILITIES`), never which class it is: ``"intervals" in system.capabilities``
(Theorem 1 applies), ``"vertices"`` (the exact vertex tests), ``"parameters"`` (frozen
plants on a parameter grid, margins in the parameters' units), ``"rates"`` (a parameter
with a rate bound).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from .uncertain import UncertainLTVModel

__all__ = ["CAPABILITIES", "UncertainSystem"]

#: What an uncertain system can do, by name.
CAPABILITIES: dict[str, str] = {
    "intervals": "interval-bounded elements: Theorem 1, its exact margin, the interval hull is the set",
    "vertices": "a finite vertex set: the exact vertex tests, common-P LMIs and the falsifier on it",
    "parameters": "named physical parameters (units, ranges): frozen plants on a grid, margins in units",
    "rates": "a parameter with a rate bound: rate-bounded certificates",
}


@runtime_checkable
class UncertainSystem(Protocol):
    """An uncertain linear system ``ẋ = A(t)x + B(t)u`` that every analysis of the package takes.

    Attributes
    ----------
    name : str
    capabilities : frozenset of str
        Keys of :data:`CAPABILITIES`.
    """

    @property
    def name(self) -> str:
        """Its name, for titles and messages."""

    @property
    def capabilities(self) -> frozenset[str]:
        """What it can do (keys of :data:`CAPABILITIES`)."""

    def interval_hull(self) -> UncertainLTVModel:
        """The interval box that holds it (Theorem 1's set)."""
