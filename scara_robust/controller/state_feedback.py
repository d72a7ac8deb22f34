"""Static state feedback ``u_k = −K x(t_k)``, held between samples (zero-order hold).

The second controller form next to the PID: a gain designed elsewhere (LQR, pole placement,
a textbook's) on the plant's own state, analysed by the sampled-data certificate and
:func:`scara_robust.max_sample_time` without rewriting it in the PID form.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_real
from ..exceptions import ArgumentValueError
from ._hold import expm_stack

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

    # -- the controller protocol (what certificates, the board and the export ask) --------

    #: The controller's kind, as export targets and the board name it.
    kind: ClassVar[str] = "state feedback"

    def linear_at(self, Ts: float) -> SampledStateFeedback:
        """The same law at another sample time (:meth:`at`: the law is linear)."""
        return self.at(Ts)

    def closed_loops(self, A: Array, B: Array) -> Array:
        """The sampled loops ``A_d,i = Φ_i − Γ_i K`` of each plant ``(A_i, B_i)`` held by a zero-order hold.

        Parameters
        ----------
        A : ndarray, shape (V, n, n)
        B : ndarray, shape (V, n, m)
            Continuous-time plants of any form, whose whole state is fed back.

        Returns
        -------
        ndarray, shape (V, n, n)

        Raises
        ------
        ArgumentValueError
            Naming ``model``, for plants of other shapes.
        """
        n, m = self.n_states, self.n_inputs
        if A.shape[1:] != (n, n) or B.shape[1:] != (n, m) or A.shape[0] != B.shape[0]:
            raise ArgumentValueError(
                "model", f"must hold plants of shapes ({n}, {n}) and ({n}, {m}) for this gain, "
                f"found {A.shape[1:]} and {B.shape[1:]}")
        held = np.zeros((A.shape[0], n + m, n + m))
        held[:, :n, :n], held[:, :n, n:] = A * self.Ts, B * self.Ts
        E = expm_stack(held)
        return np.asarray(E[:, :n, :n] - E[:, :n, n:] @ self.K, dtype=float)

    def sampled_coordinates(self, P: ArrayLike, n: int) -> Array | None:
        """A continuous-time P on the same state: itself where it is (n, n), else None."""
        return np.asarray(P, dtype=float) if np.shape(P) == (n, n) else None

    @property
    def step_sizes(self) -> tuple[int, int]:
        """(inputs, outputs) of one step: x (n) in, u (m) out."""
        return self.n_states, self.n_inputs

    @property
    def n_state_values(self) -> int:
        """Numbers kept between steps: none."""
        return 0

    def random_inputs(self, rng: np.random.Generator, n_steps: int) -> Array:
        """Random step inputs: standard normal states, shape (n, n_steps)."""
        return rng.standard_normal((self.n_states, n_steps))

    def run_steps(self, inputs: Array, precision: str) -> Array:
        """:meth:`step` (double) or :meth:`step_single` on every column of `inputs`, shape (m, n_steps)."""
        fixed = self.step_single if precision == "single" else self.step
        rows: list[Any] = [fixed(inputs[:, k]) for k in range(inputs.shape[1])]
        return np.asarray(np.array(rows, dtype=float).T, dtype=float)

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
