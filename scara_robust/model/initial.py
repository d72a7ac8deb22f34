"""Initial conditions of a closed-loop run, given as the tracking error at t = 0.

Angles in rad, rates in rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..paper import PAPER_INITIAL_ERRORS
from .signals import Reference

__all__ = ["Scenario", "SCENARIOS"]


@dataclass(frozen=True)
class Scenario:
    """Initial condition of a run, given as the tracking error at t = 0.

    Attributes
    ----------
    name : str
    e0 : tuple of float, shape (2,)
        ``e(0) = r(0) - q(0)``, rad.
    edot0 : tuple of float, shape (2,)
        ``ė(0)``, rad/s.
    """

    name: str
    e0: tuple[float, float]
    edot0: tuple[float, float]

    def initial_state(self, reference: Reference) -> NDArray[np.float64]:
        """Plant state ``[q1, q2, q̇1, q̇2]`` at t = 0, shape (4,)."""
        r0 = np.asarray(reference.position(0.0), dtype=float)
        rd0 = np.asarray(reference.velocity(0.0), dtype=float)
        return np.concatenate([r0 - np.asarray(self.e0), rd0 - np.asarray(self.edot0)])


#: The paper's two initial conditions: ``large`` (Figure 3: q(0) = (1.5, -1.5) rad,
#: q̇(0) = 0, i.e. e(0) = (-1.5, 2.5), ė(0) = (1, 0) for the paper's reference) and
#: ``small`` (Figure 6: e(0) = (0.05, 0.05) rad, ė(0) = 0).
SCENARIOS: dict[str, Scenario] = {
    name: Scenario(name, e0, edot0) for name, (e0, edot0) in PAPER_INITIAL_ERRORS.items()
}
