"""The rigid two-link SCARA of the paper (Eq. 1) carrying a time-varying payload.

Joint angles ``q = (q1, q2)`` in rad, joint rates in rad/s, torques in N·m, masses in
kg, lengths in m, polar moments of inertia in kg·m². The payload of mass ``m_p(t)`` sits
at the tip of link 2 (distance ``L2`` from joint 2) with polar inertia ``I_p = c_p m_p``.

Every dynamics function broadcasts over leading batch dimensions: ``q`` of shape
``(..., 2)`` with ``m_p`` of shape ``(...)`` gives ``M`` of shape ``(..., 2, 2)``.

References
----------
Paper, Section 2, Eq. (1) and the elements of M and C below it; Section 4 for the data.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_callable, check_real
from ..exceptions import ArgumentValueError
from ..paper import PAPER_PAYLOAD_FRACTION

__all__ = [
    "ScaraParams",
    "PARAM_UNITS",
    "PARAM_LIMITS",
    "SinusoidalPayload",
    "ConstantPayload",
    "paper_params",
    "paper_payload",
    "payload_range",
    "mass_matrix",
    "coriolis",
    "forward_dynamics",
    "kinetic_energy",
    "error_dynamics_jacobians",
    "scara_plant",
]

Array = NDArray[np.float64]
PayloadProfile = Callable[[Any], Any]


#: Unit of every field of :class:`ScaraParams` (the one list of them).
PARAM_UNITS: dict[str, str] = {
    "m1": "kg",
    "m2": "kg",
    "L1": "m",
    "L2": "m",
    "Lc1": "m",
    "Lc2": "m",
    "I1": "kg·m²",
    "I2": "kg·m²",
    "cp": "m²",
}


#: Plausible range of every field of :class:`ScaraParams`: (lower, upper, lower is strict).
#: Wide enough for any SCARA from a desktop arm to a heavy industrial one; beyond it a
#: number is a typo or a unit mistake (grams for kilograms), and the dynamics would
#: overflow double precision long before they meant anything.
PARAM_LIMITS: dict[str, tuple[float, float, bool]] = {
    "m1": (0.0, 1e3, True),
    "m2": (0.0, 1e3, True),
    "L1": (0.0, 10.0, True),
    "L2": (0.0, 10.0, True),
    "Lc1": (0.0, 10.0, True),
    "Lc2": (0.0, 10.0, True),
    "I1": (0.0, 1e3, False),
    "I2": (0.0, 1e3, False),
    "cp": (0.0, 10.0, False),
}


@dataclass(frozen=True)
class ScaraParams:
    """Rigid SCARA parameters (SI units).

    Parameters
    ----------
    m1, m2 : float
        Link masses, kg (> 0).
    L1 : float
        Length of link 1, m (> 0).
    L2 : float
        Length of link 2, m (> 0): the distance from joint 2 to the payload. The paper
        does not give it; the default 0.4 m is ``2 * Lc2``, the length of a uniform link
        whose centre of mass is at the published ``Lc2 = 0.2`` m.
    Lc1, Lc2 : float
        Distance from each joint to the centre of mass of its link, m (> 0).
    I1, I2 : float
        Polar moments of inertia of the links, kg·m² (>= 0).
    cp : float
        Payload shape factor ``c_p = I_p / m_p``, m² (>= 0); 0.005 m² is a homogeneous
        cylinder of radius 0.1 m.

    References
    ----------
    Paper, Section 4: m1 = 2.61, m2 = 3.45, L1 = 0.3, Lc1 = 0.178, Lc2 = 0.2, I1 = 0.198,
    I2 = 0.184, c_p = 0.005.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.ScaraParams().m2
    3.45
    """

    m1: float = 2.61
    m2: float = 3.45
    L1: float = 0.3
    L2: float = 0.4
    Lc1: float = 0.178
    Lc2: float = 0.2
    I1: float = 0.198
    I2: float = 0.184
    cp: float = 0.005

    def __post_init__(self) -> None:
        for f in fields(self):
            unit = PARAM_UNITS[f.name]
            low, high, strict = PARAM_LIMITS[f.name]
            checked = check_real(f"{f.name} [{unit}]", getattr(self, f.name), positive=strict, nonnegative=not strict)
            if checked > high:
                raise ArgumentValueError(
                    f"{f.name} [{unit}]", f"must be <= {high:g} {unit} for a SCARA, found {checked:g}"
                )
            object.__setattr__(self, f.name, checked)
        for centre, length in (("Lc1", "L1"), ("Lc2", "L2")):
            if getattr(self, centre) > getattr(self, length):
                raise ArgumentValueError(
                    f"{centre} [m]",
                    f"must be <= {length} = {getattr(self, length):g} m (the centre of mass lies on the link), "
                    f"found {getattr(self, centre):g}",
                )


def paper_params(**overrides: float) -> ScaraParams:
    """Return the paper's SCARA, optionally with some fields replaced.

    Parameters
    ----------
    **overrides : float
        Any field of `ScaraParams`, e.g. ``L2=0.35``.

    Returns
    -------
    ScaraParams

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.paper_params(L2=0.35).L2
    0.35
    """
    names = {f.name for f in fields(ScaraParams)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise TypeError(f"`{unknown[0]}` is not a SCARA parameter; expected one of {sorted(names)}")
    return ScaraParams(**overrides)


@dataclass(frozen=True)
class SinusoidalPayload:
    """Payload mass ``m_p(t) = offset + amplitude * sin(omega * t + phase)`` in kg.

    Parameters
    ----------
    offset : float
        Mean mass, kg.
    amplitude : float
        Amplitude, kg (>= 0, <= offset so the mass never goes negative).
    omega : float
        Angular frequency, rad/s (> 0).
    phase : float
        Phase, rad.

    Examples
    --------
    >>> import scara_robust as sr
    >>> round(float(sr.paper_payload()(0.0)), 3)
    1.035
    """

    offset: float
    amplitude: float
    omega: float = 1.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        check_real("offset [kg]", self.offset, nonnegative=True)
        check_real("amplitude [kg]", self.amplitude, nonnegative=True)
        check_real("omega [rad/s]", self.omega, positive=True)
        check_real("phase [rad]", self.phase)
        if self.amplitude > self.offset:
            raise ValueError(
                f"`amplitude [kg]` must be <= `offset` so the mass stays >= 0, found {self.amplitude} > {self.offset}"
            )

    def __call__(self, t: ArrayLike) -> Any:
        return self.offset + self.amplitude * np.sin(self.omega * np.asarray(t, dtype=float) + self.phase)

    @property
    def bounds(self) -> tuple[float, float]:
        """Smallest and largest mass, kg."""
        return (self.offset - self.amplitude, self.offset + self.amplitude)


@dataclass(frozen=True)
class ConstantPayload:
    """A payload of constant mass, kg (0 is the empty gripper of Figures 4-5)."""

    mass: float = 0.0

    def __post_init__(self) -> None:
        check_real("mass [kg]", self.mass, nonnegative=True)

    def __call__(self, t: ArrayLike) -> Any:
        return np.full(np.shape(t), self.mass) if np.ndim(t) else self.mass

    @property
    def bounds(self) -> tuple[float, float]:
        """Smallest and largest mass, kg."""
        return (self.mass, self.mass)


def paper_payload(params: ScaraParams | None = None) -> SinusoidalPayload:
    """The paper's payload ``m_p(t) = 0.3 m2 (sin t + 1)``, in kg.

    Parameters
    ----------
    params : ScaraParams, optional
        Supplies m2 (default: the paper's robot).

    Returns
    -------
    SinusoidalPayload


    References
    ----------
    Paper, Section 4.
    """
    m2 = (params or ScaraParams()).m2
    return SinusoidalPayload(offset=PAPER_PAYLOAD_FRACTION * m2, amplitude=PAPER_PAYLOAD_FRACTION * m2, omega=1.0)


def payload_range(payload: PayloadProfile, times: ArrayLike | None = None) -> tuple[float, float]:
    """Smallest and largest payload mass in kg.

    Uses ``payload.bounds`` where the profile has it, else samples ``payload(t)`` at
    `times` (default: 2001 points over [0, 2π] s).

    Parameters
    ----------
    payload : callable
        ``payload(t) -> m_p`` in kg.
    times : array_like, shape (k,), optional
        Sample times, s.

    Returns
    -------
    tuple of float
        ``(min, max)``, kg.


    Raises
    ------
    ValueError
        If a sampled mass is negative or not finite.
    """
    bounds = getattr(payload, "bounds", None)
    if bounds is not None:
        return (float(bounds[0]), float(bounds[1]))
    check_callable("payload", payload)
    t = np.linspace(0.0, 2 * np.pi, 2001) if times is None else check_array("times", times, ndim=1)
    masses = check_array("payload(t)", [payload(float(ti)) for ti in t])
    if np.any(masses < 0):
        raise ValueError(f"`payload(t)` must be >= 0 kg, found {masses.min()}")
    return (float(masses.min()), float(masses.max()))


def inertia_coefficients(params: ScaraParams, m_p: ArrayLike) -> tuple[Any, Any, Any]:
    """The paper's lumped coefficients ``a1, a2, a3`` (kg·m²), each shaped like `m_p`.

    ``a1 = m1 Lc1² + (m2 + m_p) L1² + I1``, ``a2 = m2 Lc2² + m_p L2² + I2 + c_p m_p``,
    ``a3 = L1 (m2 Lc2 + m_p L2)``, so ``M = [[a1 + a2 + 2 a3 cos q2, a2 + a3 cos q2],
    [a2 + a3 cos q2, a2]]``.

    Parameters
    ----------
    params : ScaraParams
    m_p : array_like
        Payload mass, kg.

    Returns
    -------
    tuple of ndarray
        ``a1, a2, a3`` in kg·m².
    """
    p = params
    mp = np.asarray(m_p, dtype=float)
    a1 = p.m1 * p.Lc1**2 + (p.m2 + mp) * p.L1**2 + p.I1
    a2 = p.m2 * p.Lc2**2 + mp * p.L2**2 + p.I2 + p.cp * mp
    a3 = p.L1 * (p.m2 * p.Lc2 + mp * p.L2)
    return a1, a2, a3


def _stack22(m11: Any, m12: Any, m21: Any, m22: Any) -> Array:
    m11, m12, m21, m22 = np.broadcast_arrays(m11, m12, m21, m22)
    return np.stack([np.stack([m11, m12], axis=-1), np.stack([m21, m22], axis=-1)], axis=-2)


def _joint_array(name: str, value: ArrayLike) -> Array:
    """`value` as a float array whose last axis holds the two joints."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise ValueError(f"`{name}` must have shape (..., 2) (one value per joint), found shape {arr.shape}")
    return arr


def mass_matrix(params: ScaraParams, q: ArrayLike, m_p: ArrayLike) -> Array:
    """Mass matrix ``M(q, m_p)``, kg·m².

    Parameters
    ----------
    params : ScaraParams
    q : array_like, shape (..., 2)
        Joint angles, rad (only ``q2`` matters).
    m_p : array_like, shape (...)
        Payload mass, kg.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        Symmetric positive definite.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.mass_matrix(sr.ScaraParams(), [0.0, 0.0], 0.0).shape
    (2, 2)
    """
    q = _joint_array("q", q)
    a1, a2, a3 = inertia_coefficients(params, m_p)
    c2 = np.cos(q[..., 1])
    off = a2 + a3 * c2
    return _stack22(a1 + a2 + 2 * a3 * c2, off, off, a2 + 0 * c2)


def coriolis(params: ScaraParams, q: ArrayLike, qd: ArrayLike, m_p: ArrayLike) -> Array:
    """Coriolis and centrifugal torques ``C(q, q̇, m_p)``, N·m, shape (..., 2).

    Parameters
    ----------
    params : ScaraParams
    q, qd : array_like, shape (..., 2)
        Joint angles (rad) and rates (rad/s).
    m_p : array_like, shape (...)
        Payload mass, kg.

    Returns
    -------
    ndarray, shape (..., 2)
        N·m.
    """
    q = _joint_array("q", q)
    qd = _joint_array("qd", qd)
    _, _, a3 = inertia_coefficients(params, m_p)
    s2 = np.sin(q[..., 1])
    w1, w2 = qd[..., 0], qd[..., 1]
    return np.stack([-a3 * (2 * w1 * w2 + w2**2) * s2, a3 * w1**2 * s2], axis=-1)


def _solve22(M: Array, b: Array) -> Array:
    """Closed-form solve of a batch of 2x2 systems ``M x = b``."""
    det = M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
    x0 = (M[..., 1, 1] * b[..., 0] - M[..., 0, 1] * b[..., 1]) / det
    x1 = (M[..., 0, 0] * b[..., 1] - M[..., 1, 0] * b[..., 0]) / det
    return np.stack([x0, x1], axis=-1)


def _inv22(M: Array) -> Array:
    det = M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
    return _stack22(M[..., 1, 1] / det, -M[..., 0, 1] / det, -M[..., 1, 0] / det, M[..., 0, 0] / det)


def forward_dynamics(params: ScaraParams, q: ArrayLike, qd: ArrayLike, torque: ArrayLike, m_p: ArrayLike) -> Array:
    """Joint accelerations ``q̈ = M⁻¹ (T - C)``, rad/s², shape (..., 2).

    Parameters
    ----------
    params : ScaraParams
    q, qd : array_like, shape (..., 2)
        Joint angles (rad) and rates (rad/s).
    torque : array_like, shape (..., 2)
        Total joint torque ``T_c + T_d``, N·m.
    m_p : array_like, shape (...)
        Payload mass, kg.

    Returns
    -------
    ndarray, shape (..., 2)
        rad/s².
    """
    M = mass_matrix(params, q, m_p)
    rhs = np.asarray(torque, dtype=float) - coriolis(params, q, qd, m_p)
    return _solve22(M, rhs)


def dynamics_terms(
    params: ScaraParams, q2: float, w1: float, w2: float, m_p: float
) -> tuple[float, float, float, float, float]:
    """Scalar ``M11, M12, M22, C1, C2`` for one state: the lean path of the simulators.

    Parameters
    ----------
    params : ScaraParams
    q2 : float
        Angle of joint 2, rad.
    w1, w2 : float
        Joint rates, rad/s.
    m_p : float
        Payload mass, kg.

    Returns
    -------
    tuple of float
        ``M11, M12, M22`` (kg·m²) and ``C1, C2`` (N·m).
    """
    p = params
    a1 = p.m1 * p.Lc1**2 + (p.m2 + m_p) * p.L1**2 + p.I1
    a2 = p.m2 * p.Lc2**2 + m_p * p.L2**2 + p.I2 + p.cp * m_p
    a3 = p.L1 * (p.m2 * p.Lc2 + m_p * p.L2)
    c2, s2 = math.cos(q2), math.sin(q2)
    return a1 + a2 + 2 * a3 * c2, a2 + a3 * c2, a2, -a3 * (2 * w1 * w2 + w2 * w2) * s2, a3 * w1 * w1 * s2


def forward_dynamics_scalar(params: ScaraParams, x: Array, t1: float, t2: float, m_p: float) -> tuple[float, float]:
    """``q̈`` for one state ``x = [q1, q2, q̇1, q̇2]`` and total torques, by a closed-form 2x2 solve.

    Parameters
    ----------
    params : ScaraParams
    x : ndarray, shape (>= 4,)
        ``[q1, q2, q̇1, q̇2, ...]`` in rad and rad/s.
    t1, t2 : float
        Total joint torques, N·m.
    m_p : float
        Payload mass, kg.

    Returns
    -------
    tuple of float
        ``(q̈1, q̈2)``, rad/s².
    """
    m11, m12, m22, c1, c2 = dynamics_terms(params, float(x[1]), float(x[2]), float(x[3]), m_p)
    b1, b2 = t1 - c1, t2 - c2
    det = m11 * m22 - m12 * m12
    return (m22 * b1 - m12 * b2) / det, (m11 * b2 - m12 * b1) / det


def kinetic_energy(params: ScaraParams, q: ArrayLike, qd: ArrayLike, m_p: ArrayLike) -> Any:
    """Kinetic energy ``q̇ᵀ M q̇ / 2``, J, shape (...).

    Parameters
    ----------
    params : ScaraParams
    q, qd : array_like, shape (..., 2)
        Joint angles (rad) and rates (rad/s).
    m_p : array_like, shape (...)
        Payload mass, kg.

    Returns
    -------
    ndarray, shape (...)
        J.
    """
    qd = np.asarray(qd, dtype=float)
    M = mass_matrix(params, q, m_p)
    return 0.5 * np.einsum("...i,...ij,...j->...", qd, M, qd)


def error_dynamics_jacobians(params: ScaraParams, r: ArrayLike, rd: ArrayLike, m_p: ArrayLike) -> tuple[Array, Array]:
    """Linearize the tracking-error dynamics (Eq. 2) at ``e = ė = 0`` (Eq. 3).

    With ``e = r - q``, ``ë = f + g (T_c + T_d)`` where ``f = r̈ + M⁻¹ C`` and
    ``g = -M⁻¹``, both evaluated at ``q = r - e``, ``q̇ = ṙ - ė``. The Jacobians are
    analytic: ``∂(M⁻¹C)/∂q2 = M⁻¹ (∂C/∂q2 - ∂M/∂q2 M⁻¹ C)`` and ``∂(M⁻¹C)/∂q̇ = M⁻¹ ∂C/∂q̇``.

    Parameters
    ----------
    params : ScaraParams
    r, rd : array_like, shape (..., 2)
        Reference angles (rad) and rates (rad/s).
    m_p : array_like, shape (...)
        Payload mass, kg.

    Returns
    -------
    a_star : ndarray, shape (..., 2, 4)
        ``[∂f/∂e1, ∂f/∂e2, ∂f/∂ė1, ∂f/∂ė2]``: rows 5-6, columns 3-6 of the state matrix
        of Eq. (4) (1/s², 1/s² and 1/s), for the state ``[∫e1, ∫e2, e1, e2, ė1, ė2]``.
    g_bar : ndarray, shape (..., 2, 2)
        ``ḡ = -M⁻¹(r, m_p)``, 1/(kg·m²): rows 5-6 of the input matrix.
    """
    q = np.asarray(r, dtype=float)
    qd = np.asarray(rd, dtype=float)
    batch = np.broadcast_shapes(q.shape[:-1], qd.shape[:-1], np.shape(m_p))
    q = np.broadcast_to(q, batch + (2,))
    qd = np.broadcast_to(qd, batch + (2,))
    m_p = np.broadcast_to(np.asarray(m_p, dtype=float), batch)
    _, _, a3 = inertia_coefficients(params, m_p)
    M = mass_matrix(params, q, m_p)
    Minv = _inv22(M)
    C = coriolis(params, q, qd, m_p)
    h = np.einsum("...ij,...j->...i", Minv, C)
    s2, c2 = np.sin(q[..., 1]), np.cos(q[..., 1])
    w1, w2 = qd[..., 0], qd[..., 1]
    zero = 0 * s2
    dM_dq2 = _stack22(-2 * a3 * s2, -a3 * s2, -a3 * s2, zero)
    dC_dq2 = np.stack([-a3 * c2 * (2 * w1 * w2 + w2**2), a3 * c2 * w1**2], axis=-1)
    dC_dw1 = np.stack([-2 * a3 * s2 * w2, 2 * a3 * s2 * w1], axis=-1)
    dC_dw2 = np.stack([-2 * a3 * s2 * (w1 + w2), zero], axis=-1)

    def minv_times(v: Array) -> Array:
        return np.asarray(np.einsum("...ij,...j->...i", Minv, v), dtype=float)

    dh_dq2 = minv_times(dC_dq2 - np.einsum("...ij,...j->...i", dM_dq2, h))
    # f depends on e through q = r - e, so every derivative changes sign.
    columns = [zero[..., None] * np.ones(2), -dh_dq2, -minv_times(dC_dw1), -minv_times(dC_dw2)]
    a_star = np.stack(columns, axis=-1)
    return a_star, -Minv


def scara_plant(
    params: ScaraParams | None = None,
    payload: PayloadProfile | None = None,
    *,
    name: str = "scara",
    state_limit: float = 1e3,
) -> ct.NonlinearIOSystem:
    """The SCARA as a python-control nonlinear input/output system.

    Parameters
    ----------
    params : ScaraParams, optional
        Robot data (default: the paper's).
    payload : callable, optional
        ``payload(t) -> m_p`` in kg (default: the paper's sinusoid).
    name : str
        System name.
    state_limit : float
        Once any state exceeds this magnitude (rad or rad/s) the state stops evolving,
        so a diverging simulation ends quickly instead of crawling through a blow-up;
        simulators flag such runs as diverged.

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``Tc1, Tc2, Td1, Td2`` (N·m); states and outputs ``q1, q2`` (rad) and
        ``q1_dot, q2_dot`` (rad/s). Its update function is ``updfcn(t, x, u, params)``
        returning ``[q̇1, q̇2, q̈1, q̈2]`` with ``q̈ = M⁻¹(T_c + T_d - C)``.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sys = sr.scara_plant()
    >>> sys.ninputs, sys.nstates
    (4, 4)
    """
    params = params or ScaraParams()
    payload = check_callable("payload", payload if payload is not None else paper_payload(params))

    limit = check_real("state_limit", state_limit, positive=True)

    def updfcn(t: float, x: Array, u: Array, _params: Any) -> Array:
        if np.abs(x).max() > limit:
            return np.zeros(4)
        a1, a2 = forward_dynamics_scalar(params, x, u[0] + u[2], u[1] + u[3], float(payload(t)))
        return np.array([x[2], x[3], a1, a2])

    return ct.NonlinearIOSystem(
        updfcn,
        None,
        inputs=["Tc1", "Tc2", "Td1", "Td2"],
        outputs=["q1", "q2", "q1_dot", "q2_dot"],
        states=["q1", "q2", "q1_dot", "q2_dot"],
        name=name,
    )
