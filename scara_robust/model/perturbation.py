"""The perturbation of Eq. (4) as channels with bounds, beside the sampled plants it acts on.

The linearized tracking-error dynamics along a reference is ``ẋ = A(t)x + B(t)u + w(t)``
(paper, Eq. 4), where w holds what the linearization leaves: the drift ``f̄`` (the error's
acceleration at ``e = 0`` without a control torque, or with the model feedforward, what it
leaves unexplained) and the disturbance torque through the input matrix, ``ḡ T_d``. Both are
bounded channel by channel: ``w = Σ_k b_k(t) w_k(t)`` with ``|w_k(t)| <= w̄_k``. Keeping the
torque channels behind the input matrix of each sample (instead of one bound on ``ḡ T_d``)
keeps the coupling the robot's inertia gives them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["PerturbedSamples"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PerturbedSamples:
    """Sampled plants with the perturbation channels that drive them.

    Attributes
    ----------
    A : ndarray, shape (k, n, n)
    B : ndarray, shape (k, n, m)
        The linearized plants (the design state and the control input).
    disturbance : ndarray, shape (k, n, q)
        ``b_k`` of each channel at each sample.
    w_bound : ndarray, shape (q,)
        ``w̄_k`` (> 0; where a channel is identically zero, a tiny positive value).
    channels : tuple of str, length q
        Each channel's name.
    units : tuple of str, length q
        Each channel's unit (``N·m`` for a torque, ``rad/s²`` for a drift).
    description : str
        How a summary names the set.
    """

    A: Array
    B: Array
    disturbance: Array
    w_bound: Array
    channels: tuple[str, ...]
    units: tuple[str, ...]
    description: str

    @property
    def n_samples(self) -> int:
        """k."""
        return int(self.A.shape[0])
