"""The perturbation of Eq. (4) as channels with bounds, beside the sampled plants it acts on.

The linearized tracking-error dynamics along a reference is ``ẋ = A(t)x + B(t)u + w(t)``
(paper, Eq. 4), where w holds what the linearization leaves: the drift ``f̄`` (the error's
acceleration at ``e = 0`` without a control torque, or with the model feedforward, what it
leaves unexplained) and the disturbance torque through the input matrix, ``ḡ T_d``. Both are
bounded channel by channel: ``w = Σ_k b_k(t) w_k(t)`` with ``|w_k(t)| <= w̄_k``. Keeping the
torque channels behind the input matrix of each sample (instead of one bound on ``ḡ T_d``)
keeps the coupling the robot's inertia gives them.

Where the drift is the input matrix times a torque, ``f̄ = −B(t) τ_r(t)`` (the torque the
model feedforward leaves: ``τ_r = M r̈ + C ṙ + G − τ_ff``), and that torque varies slowly
(the reference is smooth and ``|ṁ_p|`` is bounded), a PID's integral absorbs it exactly:
with ``K_I`` the gain's block on ``∫e`` (invertible) and ``x_s = (K_I⁻¹ τ_r, 0, 0)``,
``K x_s = τ_r`` and, where ``A``'s columns of ``∫e`` are zero, ``z = x + x_s`` obeys

    ż = (A − BK) z + B T_d + (K_I⁻¹ τ̇_r, 0, 0),    e(z) = e(x),

so the drift enters through its rate ``|τ̇_r| <= τ̄'`` and the initial state moves by
``x_s(0)`` (:meth:`PerturbedSamples.integral_form`): a bound on a slow drift's size is no
longer treated as the worst disturbance of that size. The feedback torque is then
``u = −Kz + τ_r`` and the whole torque ``τ_ff + u = τ_id − Kz`` with ``τ_id = M r̈ + C ṙ + G``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["PerturbedSamples", "IntegralDrift"]

Array = NDArray[np.float64]

#: The bound a channel with none (a zero disturbance) is given, so that every bound is > 0 as the LMIs
#: take them; a channel at or below it perturbs nothing.
NEGLIGIBLE_BOUND = 1e-12


@dataclass(frozen=True)
class IntegralDrift:
    """The drift as a torque a PID's integral absorbs (see the module docstring).

    Attributes
    ----------
    columns : tuple of int, length n
        The drift's channels in :attr:`PerturbedSamples.disturbance` (one per joint).
    rate : ndarray, shape (n,)
        Bound on ``|τ̇_r,j|`` along the reference, with ``|ṁ_p|`` at its bound, N·m/s (> 0).
    initial : ndarray, shape (k, n)
        ``τ_r(0)`` at the payload's ends (``τ_r`` is affine in ``m_p``), N·m.
    torque : ndarray, shape (n,)
        Bound on ``|τ_id,j|``, the torque the reference needs with the payload, N·m.
    description : str
        The grid the bounds come from.
    """

    columns: tuple[int, ...]
    rate: Array
    initial: Array
    torque: Array
    description: str


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
    integral : IntegralDrift or None
        The drift as a torque a PID's integral absorbs (None: only as a bounded channel).
    """

    A: Array
    B: Array
    disturbance: Array
    w_bound: Array
    channels: tuple[str, ...]
    units: tuple[str, ...]
    description: str
    integral: IntegralDrift | None = None

    @property
    def n_samples(self) -> int:
        """k."""
        return int(self.A.shape[0])

    def integral_form(self, K: Array | None, initial_states: Array) -> tuple[Array, Array, Array] | None:
        """The channels and initial states with the drift absorbed by `K`'s integral.

        Parameters
        ----------
        K : ndarray, shape (m, n_x), or None
            The gain (columns in the design state ``[∫e, e, ė]``); None: the channels
            without the drift (a first synthesis, before a gain exists).
        initial_states : ndarray, shape (k, n_x)
            Initial design states ``x(0)``.

        Returns
        -------
        (disturbance (V, n_x, q), w_bound (q,), initial_states (k', n_x)) or None
            The drift's channels replaced by ``(K_I⁻¹, 0, 0)`` with bounds :attr:`IntegralDrift.rate`
            and the initial states by ``x(0) + x_s(0)`` at each payload end (``K = None``: the
            other channels alone, or, where every other bound is at most 1e-12, the floor a zero
            bound is given (no disturbance), all the channels with the drift bounded by its size: a synthesis
            with no perturbation at all shrinks its ellipsoid to a point and gives no gain to
            start from); None without
            :attr:`integral`, when ``A``'s columns of ``∫e`` are not zero or when ``K_I`` is
            singular.
        """
        drift = self.integral
        if drift is None:
            return None
        m = len(drift.columns)
        if np.any(self.A[:, :, :m] != 0.0):
            return None
        keep = [k for k in range(self.disturbance.shape[2]) if k not in drift.columns]
        Bw, w = self.disturbance[:, :, keep], self.w_bound[keep]
        X0 = np.atleast_2d(np.asarray(initial_states, dtype=float))
        if K is None:
            if not np.any(w > NEGLIGIBLE_BOUND):  # nothing left without the drift: the drift by its size
                return np.ascontiguousarray(self.disturbance), self.w_bound, X0
            return np.ascontiguousarray(Bw), w, X0
        KI = np.asarray(K, dtype=float)[:, :m]
        if np.linalg.cond(KI) > 1e12:
            return None
        KI_inv = np.linalg.inv(KI)
        column = np.zeros((self.A.shape[1], m))
        column[:m] = KI_inv
        Bw = np.concatenate([Bw, np.broadcast_to(column, (len(self.A), *column.shape))], axis=2)
        shifts = np.zeros((len(drift.initial), self.A.shape[1]))
        shifts[:, :m] = drift.initial @ KI_inv.T
        starts = (X0[:, None, :] + shifts[None, :, :]).reshape(-1, X0.shape[1])
        return np.ascontiguousarray(Bw), np.r_[w, np.maximum(drift.rate, 1e-12)], starts
