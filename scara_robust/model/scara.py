"""The SCARA with its payload as an instance of the uncertain plant.

The robot's tracking-error dynamics linearized along its reference (paper Eq. 3) is a
second-order plant ``ë = A_q e + A_v ė + M⁻¹ u`` in two parameters: the reference time
``t_ref`` (s, over one period; it moves the linearization point, and the paper's interval
model lets it vary arbitrarily fast) and the payload mass ``m_p`` (kg). Its PID form is the
paper's Eq. (4): :func:`scara_uncertain_plant` gives it as an :class:`~scara_robust.UncertainPlant`, so
the derived interval model, the physical samples, the payload margin (a parameter margin in
kg) and the payload rate (kg/s) are the plant's general answers. With ``bounds='paper'`` the
interval view is the published Tables 1–2 (:func:`scara_robust.paper_model`) instead of the
hull computed from the robot.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_int, check_real
from ..paper import PAPER_A_STAR, PAPER_B_STAR, PAPER_TABLE1, PAPER_TABLE2
from .perturbation import NEGLIGIBLE_BOUND, IntegralDrift, PerturbedSamples
from .plant import Parameter, Signal, UncertainPlant, hull_of_stacks
from .robot import (
    ConstantPayload,
    PayloadProfile,
    ScaraParams,
    SinusoidalPayload,
    error_dynamics_jacobians,
    forward_dynamics,
    mass_matrix,
    paper_payload,
    payload_range,
)
from .signals import Reference, paper_reference
from .uncertain import UncertainElement, UncertainLTVModel

__all__ = [
    "scara_uncertain_plant",
    "SCARA_BOUNDS",
    "paper_model",
    "derived_model",
    "physical_samples",
    "PhysicalSamples",
    "scara_perturbed_samples",
]

Array = NDArray[np.float64]
#: Interval views of :func:`scara_uncertain_plant`.
SCARA_BOUNDS = ("derived", "paper")


def scara_uncertain_plant(
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    *,
    bounds: str = "derived",
    n_times: int = 721,
    n_masses: int = 21,
    payload_rate: float | None = None,
) -> UncertainPlant:
    """The SCARA's linearized error dynamics along its reference, over the payload range.

    Parameters
    ----------
    params : ScaraParams, optional
        Robot (default: the paper's).
    reference : Reference, optional
        Joint reference (default: the paper's ``sin t, cos t``).
    payload : callable, optional
        ``payload(t) -> m_p`` in kg (default: the paper's); its range over one period
        [0, 2π] s is the range of ``m_p`` (nominal: the lower end).
    bounds : {'derived', 'paper'}
        The interval view: the hull of the robot's samples (as
        :func:`scara_robust.derived_model`), or the published Tables 1–2.
    n_times, n_masses : int
        Grid of the samples: reference times over [0, 2π] s and masses over the range
        (the defaults are those of :func:`scara_robust.derived_model`).
    payload_rate : float, optional
        Bound on ``|ṁ_p|``, kg/s.

    Returns
    -------
    UncertainPlant
        Parameters ``t_ref`` (s) and ``m_p`` (kg), form 'pid', inputs the joint torques
        (N·m), outputs the joint angles (rad); 6 design-form states ``[∫e, e, ė]``.

    See Also
    --------
    paper_model, derived_model : its interval boxes.
    payload_margin : its payload margin in kg.

    Examples
    --------
    >>> import scara_robust as sr
    >>> plant = sr.scara_uncertain_plant()
    >>> plant.interval_model().elements == sr.derived_model().elements
    True
    """
    check_choice("bounds", bounds, SCARA_BOUNDS)
    robot = params or ScaraParams()
    ref = reference or paper_reference()
    load = payload if payload is not None else paper_payload(robot)
    n_times = check_int("n_times", n_times, 1)
    n_masses = check_int("n_masses", n_masses, 1)
    lo, hi = payload_range(load, np.linspace(0.0, 2 * np.pi, n_times))
    parameters = (
        Parameter("t_ref", "s", (0.0, 2 * np.pi), samples=max(n_times, 2), coarse=37,
                  description="reference time over one period (the linearization point)"),
        Parameter("m_p", "kg", (lo, hi), rate=payload_rate if hi > lo else None, samples=max(n_masses, 2), coarse=5,
                  description="payload mass"),
    )
    if n_times == 1:
        parameters = (Parameter("t_ref", "s", (0.0, 0.0)), parameters[1])

    sampled: dict[bytes, tuple[Array, Array]] = {}  # the reference on each grid of times asked (a search asks again)

    def matrices(values: Mapping[str, Array]) -> tuple[Array, Array]:
        t = np.asarray(values["t_ref"], dtype=float)
        m = np.asarray(values["m_p"], dtype=float)
        shape = np.broadcast_shapes(t.shape, m.shape)
        t, m = np.broadcast_to(t, shape), np.broadcast_to(m, shape)
        times = np.ascontiguousarray(t.ravel())
        key = times.tobytes()
        if key not in sampled:
            if len(sampled) >= 8:
                sampled.pop(next(iter(sampled)))
            r, rd, _ = ref.sample(times)
            r.setflags(write=False)
            rd.setflags(write=False)
            sampled[key] = r, rd
        r, rd = sampled[key]
        a_star, g_bar = error_dynamics_jacobians(robot, r, rd, m.ravel())
        A = np.zeros((t.size, 4, 4))
        A[:, :2, 2:] = np.eye(2)
        A[:, 2:, :] = a_star
        B = np.zeros((t.size, 4, 2))
        B[:, 2:, :] = -g_bar  # M⁻¹: the error model's input matrix is ḡ = −M⁻¹
        return A.reshape(shape + (4, 4)), B.reshape(shape + (4, 2))

    def published(theta: float) -> UncertainLTVModel:
        return paper_model().scaled(theta)

    return UncertainPlant(
        parameters, matrices, 4, 2, form="pid", name="derived (model-based)" if bounds == "derived" else
        "paper (Tables 1-2)",
        inputs=(Signal("T1", "N·m"), Signal("T2", "N·m")),
        outputs=(Signal("q1", "rad"), Signal("q2", "rad")),
        hull=published if bounds == "paper" else None,
        prefix="scara_pid",
    )


def pid_state_matrices(a_star: ArrayLike, b_star: ArrayLike) -> tuple[Array, Array]:
    """Assemble Eq. (4)'s A (6x6) and B (6x2) for the PID state ``[∫e, e, ė]``.

    Parameters
    ----------
    a_star : array_like, shape (2, 4)
        Rows 5-6, columns 3-6 of A (the Jacobian of f with respect to ``e, ė``).
    b_star : array_like, shape (2, 2)
        Rows 5-6 of B.

    Returns
    -------
    A : ndarray, shape (6, 6)
    B : ndarray, shape (6, 2)
    """
    a_star = check_array("a_star", a_star, shape=(2, 4))
    b_star = check_array("b_star", b_star, shape=(2, 2))
    A = np.zeros((6, 6))
    A[:4, 2:] = np.eye(4)
    A[4:, 2:] = a_star
    B = np.zeros((6, 2))
    B[4:, :] = b_star
    return A, B




def paper_model() -> UncertainLTVModel:
    """The published model of Section 4: A*, B* and Tables 1-2 exactly.

    Returns
    -------
    UncertainLTVModel
        n = 6, m = 2, N = 10 elements: ΔA(5..6, 4..6) then ΔB(5..6, 1..2), each with
        lower bound 0 (A*, B* are the lower ends of the intervals).

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.paper_model().n_elements
    10
    """
    a_star = np.zeros((2, 4))
    a_star[:, 1:] = PAPER_A_STAR
    A, B = pid_state_matrices(a_star, PAPER_B_STAR)
    elements = [
        UncertainElement("A", 4 + i, 3 + j, 0.0, float(PAPER_TABLE1[i, j])) for i in range(2) for j in range(3)
    ] + [UncertainElement("B", 4 + i, k, 0.0, float(PAPER_TABLE2[i, k])) for i in range(2) for k in range(2)]
    return UncertainLTVModel(A, B, tuple(elements), name="paper (Tables 1-2)", n_joints=2)


@dataclass(frozen=True)
class PhysicalSamples:
    """The robot's own (A, B) pairs, sampled along the reference over the payload range.

    Attributes
    ----------
    A : ndarray, shape (k, 6, 6)
        State matrices of Eq. (4) at each sample.
    B : ndarray, shape (k, 6, 2)
        Input matrices (rows 5-6 hold ``-M⁻¹``).
    times : ndarray, shape (k,)
        Reference time of each sample, s.
    masses : ndarray, shape (k,)
        Payload mass of each sample, kg.
    """

    A: Array
    B: Array
    times: Array
    masses: Array

    @property
    def n_samples(self) -> int:
        """Number of samples k."""
        return int(self.times.size)


def physical_samples(
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    *,
    times: ArrayLike | None = None,
    n_masses: int = 21,
) -> PhysicalSamples:
    """Linearize the robot at ``e = 0`` on the grid ``times × masses``.

    Parameters
    ----------
    params : ScaraParams, optional
        Robot (default: the paper's).
    reference : Reference, optional
        Joint reference (default: the paper's ``sin t, cos t``).
    payload : callable, optional
        ``payload(t) -> m_p`` in kg (default: the paper's); only its range over `times`
        is used.
    times : array_like, shape (n_t,), optional
        Reference sample times, s (default: 721 points over [0, 2π]).
    n_masses : int
        Payload masses sampled evenly across its range (>= 1).

    Returns
    -------
    PhysicalSamples
        ``k = n_t * n_masses`` samples, time-major.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.physical_samples(times=[0.0, 1.0], n_masses=3).A.shape
    (6, 6, 6)
    """
    params = params or ScaraParams()
    reference = reference or paper_reference()
    payload = payload if payload is not None else paper_payload(params)
    t = np.linspace(0.0, 2 * np.pi, 721) if times is None else check_array("times", times, ndim=1)
    if t.size == 0:
        raise ValueError("`times` must hold at least one time, found none")
    n_masses = check_int("n_masses", n_masses, 1)
    lo, hi = payload_range(payload, t)
    masses = np.linspace(lo, hi, int(n_masses))
    r, rd, _ = reference.sample(t)
    a_star, g_bar = error_dynamics_jacobians(params, r[:, None, :], rd[:, None, :], masses[None, :])
    k = t.size * masses.size
    A0, _ = pid_state_matrices(np.zeros((2, 4)), np.zeros((2, 2)))
    A_all = np.repeat(A0[None], k, axis=0)
    A_all[:, 4:, 2:] = a_star.reshape(k, 2, 4)
    B_all = np.zeros((k, 6, 2))
    B_all[:, 4:, :] = g_bar.reshape(k, 2, 2)
    grid_t, grid_m = np.meshgrid(t, masses, indexing="ij")
    return PhysicalSamples(A=A_all, B=B_all, times=grid_t.ravel(), masses=grid_m.ravel())


def derived_model(
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    *,
    times: ArrayLike | None = None,
    n_masses: int = 21,
    rtol: float = 1e-9,
) -> UncertainLTVModel:
    """Interval model obtained by linearizing the robot along the reference.

    The Jacobians of :func:`scara_robust.error_dynamics_jacobians` are evaluated on the
    grid ``times × masses`` (masses spanning the payload's range; see
    :func:`physical_samples`), so the reference and payload are treated as independent.
    An element varies when its range exceeds ``rtol`` times the largest magnitude in its
    matrix; the nominal matrices hold the element-wise minima and each varying element
    gets ``[0, max - min]``, the paper's convention.

    Parameters
    ----------
    params : ScaraParams, optional
        Robot (default: the paper's).
    reference : Reference, optional
        Joint reference (default: the paper's ``sin t, cos t``).
    payload : callable, optional
        ``payload(t) -> m_p`` in kg (default: the paper's).
    times : array_like, shape (k,), optional
        Reference sample times, s (default: 721 points over [0, 2π]).
    n_masses : int
        Payload masses sampled across its range (>= 1).
    rtol : float
        Relative threshold below which an element is constant.

    Returns
    -------
    UncertainLTVModel

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.derived_model().n_elements
    10
    """
    rtol = check_real("rtol", rtol, nonnegative=True)
    samples = physical_samples(params, reference, payload, times=times, n_masses=n_masses)
    return hull_of_stacks(samples.A, samples.B, "derived (model-based)", 2, rtol=rtol)


#: (times over the samples' span, payloads) on which the drift's bound is taken.
DRIFT_GRID = (3601, 21)


def scara_perturbed_samples(
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    *,
    disturbance: float = 5.0,
    times: ArrayLike | None = None,
    n_masses: int = 5,
) -> PerturbedSamples:
    """The robot's sampled plants with the perturbation w of Eq. (4) as four bounded channels.

    Channels ``T_d1, T_d2`` (N·m, ``|T_dj| <= disturbance``) enter through each sample's
    input matrix (rows 5–6: ``ḡ = −M⁻¹(r, m_p)``); channels ``f̄_1, f̄_2`` (rad/s²) enter
    rows 5–6 directly, bounded by the largest ``|f̄_i| = |r̈_i − q̈_i(r, ṙ, T = 0, m_p)|``
    (the error's acceleration at ``e = ė = 0`` with no torque: paper, Eq. (3)) on
    :data:`DRIFT_GRID` (the span of `times`, one period of the reference, times the payload
    range), finer than the samples: on the paper's robot 0.3–0.4 % above the maximum over
    37 × 5 samples. With a sinusoidal or constant payload, :attr:`PerturbedSamples.integral`
    also holds the drift as the torque ``M r̈ + C(r, ṙ)`` a PID's integral absorbs, its rate
    bounded on the same grid (:meth:`PerturbedSamples.integral_form`).

    Parameters
    ----------
    params : ScaraParams, optional
    reference : Reference, optional
    payload : callable, optional
        As for :func:`physical_samples`.
    disturbance : float
        Bound on each joint's disturbance torque, N·m (>= 0; the paper's square waves: 5).
    times : array_like, shape (n_t,), optional
        Reference times, s (default: 37 points over [0, 2π]).
    n_masses : int

    Returns
    -------
    PerturbedSamples
        ``k = n_t * n_masses`` samples, time-major; n = 6, m = 2, q = 4.

    Examples
    --------
    >>> import scara_robust as sr
    >>> s = sr.scara_perturbed_samples(times=[0.0, 1.0], n_masses=2)
    >>> s.disturbance.shape, s.channels
    ((4, 6, 4), ('T_d1', 'T_d2', 'fbar_1', 'fbar_2'))
    """
    params = params or ScaraParams()
    reference = reference or paper_reference()
    payload = payload if payload is not None else paper_payload(params)
    t = np.linspace(0.0, 2 * np.pi, 37) if times is None else check_array("times", times, ndim=1)
    bound = check_real("disturbance", disturbance, nonnegative=True)
    samples = physical_samples(params, reference, payload, times=t, n_masses=n_masses)
    lo, hi = payload_range(payload, t)
    masses = np.linspace(lo, hi, check_int("n_masses", n_masses, 1))
    # the drift's bound on a fine grid of the samples' time span and the payload range, not only the samples
    t_fine = np.linspace(float(t.min()), float(t.max()), DRIFT_GRID[0]) if t.size > 1 else t
    m_fine = np.linspace(lo, hi, DRIFT_GRID[1])
    r, rd, rdd = reference.sample(t_fine)
    drift = rdd[:, None, :] - forward_dynamics(params, r[:, None, :], rd[:, None, :], np.zeros(2), m_fine[None, :])
    f_bound = np.abs(drift).reshape(-1, 2).max(axis=0)
    k = samples.n_samples
    Bw = np.zeros((k, 6, 4))
    Bw[:, :, :2] = samples.B
    Bw[:, 4, 2] = Bw[:, 5, 3] = 1.0
    w_bound = np.maximum(np.r_[bound, bound, f_bound], NEGLIGIBLE_BOUND)
    return PerturbedSamples(samples.A, samples.B, Bw, w_bound, ("T_d1", "T_d2", "fbar_1", "fbar_2"),
                            ("N·m", "N·m", "rad/s²", "rad/s²"),
                            f"{t.size} reference times x {masses.size} payloads, |T_d| <= {bound:g} N·m",
                            _scara_integral(params, reference, payload, t_fine, (lo, hi)))


#: Step of the central difference of the SCARA's drift torque along the reference, s.
_RATE_STEP = 1e-6


def _payload_rate(payload: PayloadProfile) -> float | None:
    """``max |ṁ_p|`` of a profile, kg/s: a sinusoid's amplitude times its frequency, 0 for a constant (else None)."""
    if isinstance(payload, ConstantPayload):
        return 0.0
    if isinstance(payload, SinusoidalPayload):
        return float(payload.amplitude * payload.omega)
    return None


def _scara_integral(params: ScaraParams, reference: Reference, payload: PayloadProfile, times: Array,
                    masses: tuple[float, float]) -> IntegralDrift | None:
    """The drift as the torque ``τ_r = M(r̈ − q̈(r, ṙ, 0)) = M r̈ + C ṙ`` a PID's integral absorbs (no feedforward).

    ``M`` and ``C`` are affine in ``m_p`` (a point mass at the tip), so ``|τ̇_r|`` is bounded by
    the time derivative at the payload's two ends (a central difference) plus the profile's
    largest ``|ṁ_p|`` times the per-kilogram term, on `times`. None for a profile whose rate
    is not known (only sinusoids and constants are).
    """
    rate = _payload_rate(payload)
    if rate is None:
        return None
    lo, hi = masses

    def residual(t: Array, m: float) -> Array:
        r, rd, rdd = reference.sample(t)
        qdd = forward_dynamics(params, r, rd, np.zeros(2), np.full(t.shape, m))
        return np.asarray(np.einsum("kij,kj->ki", mass_matrix(params, r, np.full(t.shape, m)), rdd - qdd), dtype=float)

    ends = {m: (residual(times, m), (residual(times + _RATE_STEP, m) - residual(times - _RATE_STEP, m))
                / (2 * _RATE_STEP)) for m in (lo, hi)}
    per_kg = (ends[hi][0] - ends[lo][0]) / (hi - lo) if hi > lo else np.zeros_like(ends[lo][0])
    rates = np.max(np.maximum(np.abs(ends[lo][1]), np.abs(ends[hi][1])) + rate * np.abs(per_kg), axis=0)
    torque = np.max(np.maximum(np.abs(ends[lo][0]), np.abs(ends[hi][0])), axis=0)
    initial = np.array([residual(np.array([float(times[0])]), m)[0] for m in (lo, hi)])
    return IntegralDrift((2, 3), rates, initial, torque,
                         f"{times.size} reference times x the payload's ends, |ṁ_p| <= {rate:.4g} kg/s")
