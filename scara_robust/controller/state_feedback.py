"""Static state feedback ``u_k = −K x(t_k)``, held between samples (zero-order hold).

The second controller form next to the PID: a gain designed elsewhere (LQR, pole placement,
a textbook's) on the plant's own state, analysed by the sampled-data certificate and
:func:`scara_robust.max_sample_time` without rewriting it in the PID form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_real

__all__ = ["SampledStateFeedback"]

Array = NDArray[np.float64]


@dataclass(frozen=True, init=False)
class SampledStateFeedback:
    """``u_k = −K x(t_k)`` at sample time Ts, held constant until the next sample.

    Parameters
    ----------
    K : array_like, shape (m, n)
        The gain, input units per state unit (e.g. N·m/rad for a torque from an angle).
    Ts : float
        Sample time, s (> 0).

    Attributes
    ----------
    K : ndarray, shape (m, n)
    Ts : float

    See Also
    --------
    DiscretePID : the PID form.
    max_sample_time : the largest certified Ts of either form.

    Examples
    --------
    >>> import scara_robust as sr
    >>> ctrl = sr.SampledStateFeedback([[3.75, 11.5]], 0.5)   # u = −[3.75, 11.5] x, held 0.5 s
    >>> ctrl.step([1.0, 0.0]).tolist()
    [-3.75]
    """

    K: Array
    Ts: float

    def __init__(self, K: ArrayLike, Ts: float) -> None:
        object.__setattr__(self, "K", check_array("K", K, ndim=2))
        object.__setattr__(self, "Ts", check_real("Ts", Ts, positive=True))

    @property
    def n_inputs(self) -> int:
        """m, the number of plant inputs."""
        return int(self.K.shape[0])

    @property
    def n_states(self) -> int:
        """n, the number of plant states fed back."""
        return int(self.K.shape[1])

    def at(self, Ts: float) -> SampledStateFeedback:
        """The same gain at another sample time.

        Parameters
        ----------
        Ts : float
            Sample time, s (> 0).

        Returns
        -------
        SampledStateFeedback
        """
        return SampledStateFeedback(self.K, Ts)

    def step(self, x: ArrayLike) -> Array:
        """The input held over the next sample period.

        Parameters
        ----------
        x : array_like, shape (n,)
            The sampled state.

        Returns
        -------
        ndarray, shape (m,)
            ``−K x``.
        """
        x = check_array("x", x, shape=(self.n_states,))
        return np.asarray(-self.K @ x, dtype=float)

    def step_single(self, x: ArrayLike) -> NDArray[np.float32]:
        """:meth:`step` in float32, as the single-precision C computes it.

        ``u_j = −Σ_i K_ji x_i``, each product and sum rounded to float32 in the order of the
        C's loop (no contraction).

        Parameters
        ----------
        x : array_like, shape (n,)
            The sampled state (rounded to float32).

        Returns
        -------
        ndarray of float32, shape (m,)
        """
        xs = check_array("x", x, shape=(self.n_states,)).astype(np.float32)
        K = self.K.astype(np.float32)
        u = np.zeros(K.shape[0], dtype=np.float32)
        for j in range(K.shape[0]):
            acc = np.float32(0.0)
            for i in range(K.shape[1]):
                acc = np.float32(acc + np.float32(K[j, i] * xs[i]))
            u[j] = -acc
        return u
