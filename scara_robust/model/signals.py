"""Reference trajectories and disturbance torques.

Angles in rad, rates in rad/s, accelerations in rad/s², torques in N·m, times in s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_callable, check_real
from ..paper import PAPER_DISTURBANCE_AMPLITUDE, PAPER_DISTURBANCE_PERIOD

__all__ = ["Reference", "paper_reference", "sinusoidal_reference", "SquareWave", "paper_disturbance",
           "MeasurementNoise"]

Array = NDArray[np.float64]
Signal = Callable[[Any], Any]


@dataclass(frozen=True)
class Reference:
    """A joint reference ``r(t)`` with its first two time derivatives.

    Parameters
    ----------
    position, velocity, acceleration : callable
        ``f(t) -> array_like, shape (2,)`` for scalar ``t`` (s); also vectorized where
        the callable allows: ``t`` of shape ``(k,)`` gives shape ``(2, k)``.
        Units rad, rad/s and rad/s².

    Examples
    --------
    >>> import scara_robust as sr
    >>> ref = sr.paper_reference()
    >>> ref.position(0.0).tolist()
    [0.0, 1.0]
    """

    position: Signal
    velocity: Signal
    acceleration: Signal
    #: ``(a, ω)`` when the reference is ``a (sin ωt, cos ωt)`` (rad, rad/s): what a compiled
    #: engine needs to evaluate it without calling back into Python; None otherwise.
    sinusoid: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in ("position", "velocity", "acceleration"):
            check_callable(name, getattr(self, name))

    @classmethod
    def from_function(cls, position: Signal, *, step: float = 1e-3) -> Reference:
        """Build a reference from a smooth ``r(t)`` alone.

        The derivatives are central differences of step `step` (s), accurate to
        ``O(step²)``; pass exact derivatives to the constructor when you have them.
        """
        check_callable("position", position)
        h = check_real("step", step, positive=True)

        def velocity(t: Any) -> Any:
            return (np.asarray(position(t + h)) - np.asarray(position(t - h))) / (2 * h)

        def acceleration(t: Any) -> Any:
            r0 = np.asarray(position(t))
            return (np.asarray(position(t + h)) - 2 * r0 + np.asarray(position(t - h))) / h**2

        return cls(position, velocity, acceleration)

    def sample(self, times: ArrayLike) -> tuple[Array, Array, Array]:
        """Evaluate r, ṙ, r̈ at `times`, each of shape ``(k, 2)`` for `times` of shape (k,).

        Each distinct time is evaluated once (a grid over time and a second parameter repeats
        every time), by the same scalar calls, so the values do not depend on the repeats.
        """
        t = check_array("times", times, ndim=1)
        distinct, where = np.unique(t, return_inverse=True)
        out = []
        for fn in (self.position, self.velocity, self.acceleration):
            values = np.array([np.asarray(fn(float(ti)), dtype=float) for ti in distinct])
            out.append(check_array("reference value", values, shape=(len(distinct), 2))[where.reshape(-1)])
        return out[0], out[1], out[2]


def _sin_cos(t: Any) -> Array:
    return np.array([np.sin(t), np.cos(t)])


def _cos_minus_sin(t: Any) -> Array:
    return np.array([np.cos(t), -np.sin(t)])


def _minus_sin_cos(t: Any) -> Array:
    return np.array([-np.sin(t), -np.cos(t)])


def paper_reference() -> Reference:
    """The paper's reference ``r1 = sin t``, ``r2 = cos t`` (rad) with exact derivatives.

    Returns
    -------
    Reference


    References
    ----------
    Paper, Section 4.
    """
    return Reference(_sin_cos, _cos_minus_sin, _minus_sin_cos, sinusoid=(1.0, 1.0))


def sinusoidal_reference(amplitude: float = 1.0, omega: float = 1.0) -> Reference:
    """``r1 = a sin(ωt)``, ``r2 = a cos(ωt)`` with exact derivatives; a = ω = 1 is the paper's.

    Parameters
    ----------
    amplitude : float
        a, rad (>= 0).
    omega : float
        ω, rad/s (> 0).

    Returns
    -------
    Reference

    Examples
    --------
    >>> import scara_robust as sr
    >>> ref = sr.sinusoidal_reference(2.0, 0.5)   # q_d = (2 sin 0.5t, 2 cos 0.5t) rad
    >>> ref.position(0.0).tolist(), [float(v) + 0.0 for v in ref.velocity(0.0)]   # + 0.0 drops -0.0
    ([0.0, 2.0], [1.0, 0.0])
    """
    a = check_real("amplitude [rad]", amplitude, nonnegative=True)
    w = check_real("omega [rad/s]", omega, positive=True)

    def position(t: Any) -> Array:
        return a * np.array([np.sin(w * np.asarray(t)), np.cos(w * np.asarray(t))])

    def velocity(t: Any) -> Array:
        return a * w * np.array([np.cos(w * np.asarray(t)), -np.sin(w * np.asarray(t))])

    def acceleration(t: Any) -> Array:
        return -(w**2) * position(t)

    return Reference(position, velocity, acceleration, sinusoid=(a, w))


@dataclass(frozen=True)
class SquareWave:
    """Square-wave disturbance torque on both joints, N·m.

    ``T_d(t) = amplitude * s(t) * signs`` with ``s(t) = +1`` on the first half of each
    period (counted from ``-phase * period / (2π)``) and ``-1`` on the second.

    Parameters
    ----------
    amplitude : float
        Magnitude, N·m (>= 0). Paper: 5.
    period : float
        Period, s (> 0). Paper: π/5.
    phase : float
        Phase, rad; 0 means ``+amplitude`` right after t = 0. The paper does not state
        phase or sign at t = 0; 0 is this package's choice.
    signs : tuple of float, shape (n,)
        Sign (or scale) per joint; default ``(+1, +1)``: the SCARA's two joints in phase.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.paper_disturbance()(0.1).tolist()
    [5.0, 5.0]
    """

    amplitude: float = PAPER_DISTURBANCE_AMPLITUDE
    period: float = PAPER_DISTURBANCE_PERIOD
    phase: float = 0.0
    signs: tuple[float, ...] = (1.0, 1.0)

    def __post_init__(self) -> None:
        check_real("amplitude [N·m]", self.amplitude, nonnegative=True)
        check_real("period [s]", self.period, positive=True)
        check_real("phase [rad]", self.phase)
        signs = check_array("signs", self.signs, ndim=1)
        if signs.size == 0:
            raise ValueError("`signs` must hold one sign per joint, found none")
        object.__setattr__(self, "signs", tuple(float(v) for v in signs))

    def level(self, t: ArrayLike) -> Any:
        """The wave's sign ``s(t)`` in {-1, +1}."""
        frac = np.mod(np.asarray(t, dtype=float) / self.period + self.phase / (2 * np.pi), 1.0)
        return np.where(frac < 0.5, 1.0, -1.0)

    def __call__(self, t: ArrayLike) -> Array:
        """Torque at `t`: shape (n,) for scalar t, (n, k) for t of shape (k,)."""
        s = self.level(t)
        return np.asarray(self.amplitude * np.multiply.outer(np.asarray(self.signs, dtype=float), s), dtype=float)

    def switching_times(self, t0: float, t1: float) -> Array:
        """Instants in the open interval ``(t0, t1)`` where the wave switches, s."""
        half = self.period / 2
        offset = -self.phase / (2 * np.pi) * self.period
        k0 = np.floor((t0 - offset) / half) + 1
        k1 = np.ceil((t1 - offset) / half) - 1
        times = offset + half * np.arange(k0, k1 + 1)
        return times[(times > t0) & (times < t1)]


def paper_disturbance() -> SquareWave:
    """±5 N·m square waves of period π/5 s on both joints (paper, Section 4).

    Returns
    -------
    SquareWave
    """
    return SquareWave()


@dataclass(frozen=True, eq=False)
class MeasurementNoise:
    """Band-limited noise on the measured joint angles: a sum of sinusoids per joint, rad.

    ``n_k(t) = Σ_m a_km cos(ω_km t + φ_km)``; the controller sees ``q̂ = q + n(t)`` and
    ``q̇̂ = q̇ + ṅ(t)`` (a differentiated encoder). A smooth signal, so the adaptive
    integrators meet no jumps, and the same function of time on every engine.
    :meth:`draw` picks random frequencies and phases with a given RMS and band.

    Parameters
    ----------
    amplitude : array_like, shape (n, M)
        Each component's amplitude, rad (>= 0).
    omega : array_like, shape (n, M)
        Each component's angular frequency, rad/s (>= 0).
    phase : array_like, shape (n, M)
        Each component's phase, rad.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> noise = sr.MeasurementNoise.draw(1e-3, 5.0, 2, np.random.default_rng(0))
    >>> noise(0.0).shape
    (2,)
    """

    amplitude: Array
    omega: Array
    phase: Array

    def __post_init__(self) -> None:
        amplitude = check_array("amplitude [rad]", self.amplitude, ndim=2)
        shape = amplitude.shape
        omega = check_array("omega [rad/s]", self.omega, shape=shape)
        phase = check_array("phase [rad]", self.phase, shape=shape)
        if np.any(amplitude < 0) or np.any(omega < 0):
            raise ValueError("`amplitude` [rad] and `omega` [rad/s] of MeasurementNoise must be >= 0, found a "
                             "negative entry")
        for name, value in (("amplitude", amplitude), ("omega", omega), ("phase", phase)):
            object.__setattr__(self, name, np.ascontiguousarray(value, dtype=float))

    @classmethod
    def draw(cls, rms: float, bandwidth: float, n: int, rng: np.random.Generator,
             components: int = 8) -> MeasurementNoise:
        """Noise of RMS `rms` on each of `n` joints, frequencies uniform on (0, `bandwidth`].

        Each joint gets `components` sinusoids of equal amplitude ``rms √(2/M)`` (so the
        RMS over a long time is `rms`), frequencies drawn uniformly on ``(0, bandwidth]``
        Hz and phases on ``[0, 2π)``.

        Parameters
        ----------
        rms : float
            RMS of each joint's noise, rad (>= 0).
        bandwidth : float
            Highest frequency, Hz (> 0).
        n : int
            Joints.
        rng : numpy.random.Generator
        components : int
            Sinusoids per joint M (>= 1).

        Returns
        -------
        MeasurementNoise
        """
        rms = check_real("rms [rad]", rms, nonnegative=True)
        bandwidth = check_real("bandwidth [Hz]", bandwidth, positive=True)
        shape = (int(n), int(components))
        omega = 2 * np.pi * bandwidth * (1.0 - rng.random(shape))
        phase = 2 * np.pi * rng.random(shape)
        return cls(np.full(shape, rms * np.sqrt(2.0 / components)), omega, phase)

    @property
    def n(self) -> int:
        """Joints n."""
        return int(self.amplitude.shape[0])

    def __call__(self, t: ArrayLike) -> Array:
        """``n(t)``, rad: shape (n,) for scalar t, (n, k) for t of shape (k,)."""
        angle = np.multiply.outer(self.omega, np.asarray(t, dtype=float)) + self.phase.reshape(*self.phase.shape,
                                                                                               *(1,) * np.ndim(t))
        amp = self.amplitude.reshape(*self.amplitude.shape, *(1,) * np.ndim(t))
        return np.asarray((amp * np.cos(angle)).sum(axis=1), dtype=float)

    def rate(self, t: ArrayLike) -> Array:
        """``ṅ(t)``, rad/s: shape (n,) for scalar t, (n, k) for t of shape (k,)."""
        angle = np.multiply.outer(self.omega, np.asarray(t, dtype=float)) + self.phase.reshape(*self.phase.shape,
                                                                                               *(1,) * np.ndim(t))
        amp = (self.amplitude * self.omega).reshape(*self.amplitude.shape, *(1,) * np.ndim(t))
        return np.asarray((-amp * np.sin(angle)).sum(axis=1), dtype=float)
