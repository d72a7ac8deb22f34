"""Joint-torque controllers as python-control systems.

Every controller reads the plant outputs ``q1, q2, q1_dot, q2_dot`` (rad, rad/s),
knows the reference ``r(t)`` and its derivatives, and outputs ``Tc1, Tc2`` (N·m). An
optional per-joint torque limit (N·m, off by default) saturates the output.

Controllers are chosen by name through :data:`CONTROLLERS`, whose entries carry what
belongs to each controller: how to build it and, for a sampled law, its sample time.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_argument, renamed_field
from .._validation import check_array, check_choice, check_per_item, check_real
from ..controller.discrete import DiscretePID
from ..controller.kinds import controller_kind, schedule_of
from ..controller.scheduled import ScheduledGain
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import design
from ..model.robot import ScaraParams, dynamics_terms
from ..model.scara import paper_model
from ..model.signals import Reference, paper_reference
from ..paper import PAPER_DESIGN_POINT

__all__ = [
    "pid_controller",
    "SlidingModeGains",
    "sliding_mode_controller",
    "ControllerKind",
    "CONTROLLERS",
    "SAMPLE_TIMES",
    "make_controller",
    "pid_lmi_gain",
    "SampledPID",
    "sampled_pid_controller",
    "scheduled_pid_controller",
]

Array = NDArray[np.float64]
_MEASURED = ["q1", "q2", "q1_dot", "q2_dot"]
#: Package file holding the ``pid-lmi`` gain (a design file, see :func:`pid_lmi_gain`).
PID_LMI_FILE = "data/pid_lmi.json"
_TORQUES = ["Tc1", "Tc2"]


@dataclass(frozen=True)
class ControlLaw:
    """What a controller built here computes, for engines that evaluate it without Python.

    The builders attach it as the system's ``law`` attribute.

    Attributes
    ----------
    kind : {'pid', 'smc-boundary', 'smc-sign'}
    reference : Reference
    torque_limit : ndarray, shape (2,), or None
        N·m.
    K : ndarray, shape (2, 6), or None
        The PID gain.
    gains : SlidingModeGains or None
    params : ScaraParams or None
        The robot the sliding-mode law knows (used without payload).
    """

    kind: str
    reference: Reference
    torque_limit: Array | None
    K: Array | None = None
    gains: SlidingModeGains | None = None
    params: ScaraParams | None = None


def check_torque_limit(torque_limit: Any) -> Array | None:
    """Validate a torque limit: None (off), a number or a pair, each > 0 (N·m).

    Parameters
    ----------
    torque_limit : None, float or array_like of shape (2,)

    Returns
    -------
    ndarray, shape (2,), or None

    Raises
    ------
    ValueError
        If a limit is not a finite number > 0 or the shape is wrong.
    """
    if torque_limit is None:
        return None
    limit = check_per_item("torque_limit", torque_limit, 2)
    if np.any(limit <= 0):
        raise ArgumentValueError("torque_limit", f"must be > 0 N·m, found {limit.tolist()}")
    return limit


def _saturate(u: Array, limit: Array | None) -> Array:
    return u if limit is None else np.clip(u, -limit, limit)


def pid_controller(
    K: ArrayLike,
    reference: Reference | None = None,
    *,
    torque_limit: Any = None,
    name: str = "pid",
) -> ct.NonlinearIOSystem:
    """The PID law ``T_c = -K x``, ``x = [∫e1, ∫e2, e1, e2, ė1, ė2]``, ``e = r - q``.

    Parameters
    ----------
    K : array_like, shape (2, 6)
        Gain, from :func:`scara_robust.design` (N·m·s⁻¹/rad, N·m/rad, N·m·s/rad).
    reference : Reference, optional
        Default: the paper's ``sin t, cos t``.
    torque_limit : float or array_like of shape (2,), optional
        Per-joint saturation, N·m (> 0); None (default) for none.
    name : str

    Returns
    -------
    control.NonlinearIOSystem
        States ``int_e1, int_e2`` (rad·s, start at 0); inputs ``q1, q2, q1_dot,
        q2_dot``; outputs ``Tc1, Tc2``. ``updfcn(t, x, u, params) = r(t) - q`` and
        ``outfcn(t, x, u, params) = sat(-K [x, r(t) - q, ṙ(t) - q̇])``.

    Examples
    --------
    >>> import scara_robust as sr
    >>> d = sr.design(sr.paper_model(), 3, 90)
    >>> sr.pid_controller(d.K).nstates
    2
    """
    K = check_array("K", K, shape=(2, 6))
    ref = reference or paper_reference()
    limit = check_torque_limit(torque_limit)

    def updfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        return np.asarray(ref.position(t), dtype=float) - u[:2]

    def outfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        e = np.asarray(ref.position(t), dtype=float) - u[:2]
        ed = np.asarray(ref.velocity(t), dtype=float) - u[2:]
        return _saturate(-K @ np.concatenate([x, e, ed]), limit)

    sys = ct.NonlinearIOSystem(
        updfcn, outfcn, inputs=_MEASURED, outputs=_TORQUES, states=["int_e1", "int_e2"], name=name
    )
    sys.law = ControlLaw("pid", ref, limit, K=K)
    return sys


def scheduled_pid_controller(
    gain: ScheduledGain,
    payload: Callable[[float], float],
    reference: Reference | None = None,
    *,
    measurement_bias: float = 0.0,
    torque_limit: Any = None,
    name: str = "pid-scheduled",
) -> ct.NonlinearIOSystem:
    """The PID law of :func:`pid_controller` with the gain scheduled on the measured payload.

    ``T_c = −K(m̂_p(t)) x`` with ``m̂_p = m_p(t) + measurement_bias``, ``K`` the
    :class:`~scara_robust.ScheduledGain` (clamped to its breakpoints).

    Parameters
    ----------
    gain : ScheduledGain
        Gains of shape (2, 6) on ``x = [∫e1, ∫e2, e1, e2, ė1, ė2]``, scheduled on the payload (kg).
    payload : callable
        ``m_p(t)``, kg: the payload the run carries (the same profile the run is given).
    reference : Reference, optional
        Default: the paper's.
    measurement_bias : float
        What the measurement adds to the true payload, kg.
    torque_limit : float or array_like of shape (2,), optional
        N·m.
    name : str

    Returns
    -------
    control.NonlinearIOSystem
        As :func:`pid_controller`'s.
    """
    if schedule_of(gain) is None or gain.shape != (2, 6):
        raise ArgumentValueError("gain", "must be a ScheduledGain of (2, 6) gains on the SCARA's [∫e, e, ė]")
    ref = reference or paper_reference()
    limit = check_torque_limit(torque_limit)
    bias = check_real("measurement_bias", measurement_bias)

    def updfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        return np.asarray(ref.position(t), dtype=float) - u[:2]

    def outfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        e = np.asarray(ref.position(t), dtype=float) - u[:2]
        ed = np.asarray(ref.velocity(t), dtype=float) - u[2:]
        K = gain.gain(float(payload(t)) + bias)
        return _saturate(-K @ np.concatenate([x, e, ed]), limit)

    return ct.NonlinearIOSystem(updfcn, outfcn, inputs=_MEASURED, outputs=_TORQUES, states=["int_e1", "int_e2"],
                                name=name)


@dataclass(frozen=True)
class SlidingModeGains:
    """Gains of the sliding-mode law (see :func:`sliding_mode_controller`).

    Parameters
    ----------
    lam : float
        Sliding-surface slope λ, 1/s: ``s = ė + λe``. Default 5 1/s (error time
        constant 0.2 s once on the surface).
    k_d : float
        Linear damping on s, N·m·s/rad. Default 20.
    k_s : float
        Switching gain, N·m. Must exceed the disturbance (5 N·m) plus the torque error
        of the payload-free model; default 10 N·m.
    boundary : float
        Boundary-layer width φ on s, rad/s (> 0) for the continuous variant. Default 0.1.
    """

    lam: float = 5.0
    k_d: float = 20.0
    k_s: float = 10.0
    boundary: float = 0.1

    def __post_init__(self) -> None:
        check_real("lam [1/s]", self.lam, positive=True)
        check_real("k_d [N·m·s/rad]", self.k_d, nonnegative=True)
        check_real("k_s [N·m]", self.k_s, nonnegative=True)
        check_real("boundary [rad/s]", self.boundary, positive=True)


def sliding_mode_controller(
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    *,
    gains: SlidingModeGains | None = None,
    variant: str = "boundary",
    torque_limit: Any = None,
    name: str = "smc",
) -> ct.NonlinearIOSystem:
    """Sliding-mode tracking law in the style of Slotine and Li (1991, Sect. 9.3 / 9.4).

    With ``e = r - q`` and ``s = ė + λ e`` (rad/s)::

        T_c = M̂(q) (r̈ + λ ė) + Ĉ(q, q̇) + k_d s + k_s σ(s)

    where ``M̂, Ĉ`` are the robot's mass matrix and Coriolis vector **without payload**
    (the controller does not know ``m_p``), and ``σ(s) = sign(s)`` (variant ``'sign'``)
    or ``sat(s/φ)`` (variant ``'boundary'``), element-wise. With the true ``M``,
    ``ṡ = -M⁻¹(k_d s + k_s σ(s) + T_d + ΔT)`` where ``ΔT`` is the torque error of the
    payload-free model, so ``k_s > |T_d + ΔT|`` drives each ``s_i`` to 0 (or into the
    boundary layer) in finite time.

    Parameters
    ----------
    params : ScaraParams, optional
        The robot data the controller knows (default: the paper's).
    reference : Reference, optional
        Default: the paper's.
    gains : SlidingModeGains, optional
    variant : {'boundary', 'sign'}
    torque_limit : float or array_like of shape (2,), optional
        Per-joint saturation, N·m.
    name : str

    Returns
    -------
    control.NonlinearIOSystem
        No states; inputs ``q1, q2, q1_dot, q2_dot``; outputs ``Tc1, Tc2``.
    """
    params = params or ScaraParams()
    ref = reference or paper_reference()
    g = gains or SlidingModeGains()
    check_choice("variant", variant, ("boundary", "sign"))
    limit = check_torque_limit(torque_limit)
    sigma: Callable[[Array], Array] = np.sign if variant == "sign" else (lambda s: np.clip(s / g.boundary, -1.0, 1.0))

    def outfcn(t: float, x: Array, u: Array, _params: Any) -> Array:
        q, qd = u[:2], u[2:]
        e = np.asarray(ref.position(t), dtype=float) - q
        ed = np.asarray(ref.velocity(t), dtype=float) - qd
        s = ed + g.lam * e
        v = np.asarray(ref.acceleration(t), dtype=float) + g.lam * ed
        m11, m12, m22, c1, c2 = dynamics_terms(params, float(q[1]), float(qd[0]), float(qd[1]), 0.0)
        tau = np.array([m11 * v[0] + m12 * v[1] + c1, m12 * v[0] + m22 * v[1] + c2])
        return _saturate(tau + g.k_d * s + g.k_s * sigma(s), limit)

    sys = ct.NonlinearIOSystem(None, outfcn, inputs=_MEASURED, outputs=_TORQUES, name=name)
    sys.law = ControlLaw(f"smc-{variant}", ref, limit, gains=g, params=params)
    return sys


class SampledPID(ct.NonlinearIOSystem):  # type: ignore[misc]
    """A :class:`~scara_robust.DiscretePID` as a discrete-time python-control system (``dt = Ts``).

    Built by :func:`sampled_pid_controller`; ``initial_state(e0, edot0)`` gives its state
    for a bumpless start at the initial error (the engines call it).
    """

    pid: DiscretePID

    def initial_state(self, e0: ArrayLike, edot0: ArrayLike) -> Array:
        """State ``z`` for a bumpless start at ``e0`` (rad), ``ė0`` (rad/s); shape (n_z,)."""
        return self.pid.initial_state(e0, edot0 if self.pid.derivative == "filtered" else None)


def sampled_pid_controller(
    pid: DiscretePID,
    reference: Reference | None = None,
    *,
    name: str = "pid-sampled",
) -> SampledPID:
    """The sampled PID on the robot: ``e_k = r(t_k) − q(t_k)``, ``u_k`` held for one period.

    Parameters
    ----------
    pid : DiscretePID
        From :meth:`scara_robust.Design.discretize` (2 joints); its limit and anti-windup
        apply.
    reference : Reference, optional
        Default: the paper's ``sin t, cos t``.
    name : str

    Returns
    -------
    SampledPID
        Discrete-time (``dt = pid.Ts``); states ``z`` of the PID (N·m); inputs ``q1, q2,
        q1_dot, q2_dot``; outputs ``Tc1, Tc2``. ``updfcn(t, z, u, params)`` returns
        ``z_{k+1}``, ``outfcn(t, z, u, params)`` the saturated torque ``u_k``, both calling
        the PID's own :meth:`~scara_robust.DiscretePID.output` and ``update``, so a
        simulation runs exactly what :meth:`~scara_robust.DiscretePID.step` runs.

    Examples
    --------
    >>> import scara_robust as sr
    >>> pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3)
    >>> sr.sampled_pid_controller(pid).dt
    0.001
    """
    if controller_kind(pid) != "pid" or pid.n_joints != 2 or pid.n_torques != 2:
        raise ArgumentValueError("pid", "must be a DiscretePID of a 2-joint design (Design.discretize)")
    ref = reference or paper_reference()

    def measured(t: float, u: Array) -> list[float]:
        e = np.asarray(ref.position(t), dtype=float) - u[:2]
        ed = np.asarray(ref.velocity(t), dtype=float) - u[2:4]
        return [float(e[0]), float(e[1]), float(ed[0]), float(ed[1])]

    def updfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        z, y = [float(v) for v in x], measured(t, u)
        out, v = pid.output(z, y)
        return np.array(pid.update(z, y, out, v), dtype=float)

    def outfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        return np.array(pid.output([float(v) for v in x], measured(t, u))[0], dtype=float)

    n_z = len(pid.state)
    sys = SampledPID(
        updfcn, outfcn, inputs=_MEASURED, outputs=_TORQUES, dt=pid.Ts,
        states=[f"z{i + 1}" for i in range(n_z)], name=name,
    )
    sys.pid = pid
    return sys


def _sampled_pid_factory(**kw: Any) -> ct.NonlinearIOSystem:
    K = kw.get("K")
    Ts = kw.get("Ts", SAMPLED_PID_TS)
    if K is None:
        rho, eta = kw.get("rho", PAPER_DESIGN_POINT[0]), kw.get("eta", PAPER_DESIGN_POINT[1])
        K = design(paper_model(), rho, eta).K
    K = check_array("K", K, shape=(2, 6))
    pid = DiscretePID(
        Ts, -K[:, :2], -K[:, 2:4], -K[:, 4:], torque_limit=kw.get("torque_limit"),
        anti_windup=kw.get("anti_windup", True),
    )
    return sampled_pid_controller(pid, kw.get("reference"))


#: Sample time of the registry's ``pid-sampled`` (s): 1 kHz, a common servo rate, below the
#: certified limit of the paper's design (``scara_robust.max_sample_time``).
SAMPLED_PID_TS = 1e-3


@lru_cache(maxsize=64)
def _paper_gain(rho: float, eta: float) -> Array:
    """K(ρ, η) on the published model, solved once per (ρ, η) and process (read-only)."""
    K = design(paper_model(), rho, eta).K
    K.setflags(write=False)
    return K


def _pid_factory(**kw: Any) -> ct.NonlinearIOSystem:
    K = kw.get("K")
    if K is None:
        K = _paper_gain(float(kw.get("rho", PAPER_DESIGN_POINT[0])), float(kw.get("eta", PAPER_DESIGN_POINT[1])))
    return pid_controller(K, kw.get("reference"), torque_limit=kw.get("torque_limit"))


def pid_lmi_gain() -> Array:
    """The gain of the ``pid-lmi`` controller, shape (2, 6).

    It is the design file ``scara_robust/data/pid_lmi.json`` that ``python -m scara_robust
    synthesize --output`` writes with its defaults: the L2 objective on the paper robot's
    physical set (37 reference times × 5 payloads, 0 to 2.07 kg), decay >= 0.5 1/s,
    ‖K‖₂ <= 1000, verified by numpy on 361 × 9 samples it never saw.

    Returns
    -------
    ndarray, shape (2, 6)
    """
    text = resources.files("scara_robust").joinpath(PID_LMI_FILE).read_text(encoding="utf-8")
    return np.array(json.loads(text)["K"], dtype=float)


def _pid_lmi_factory(**kw: Any) -> ct.NonlinearIOSystem:
    return pid_controller(pid_lmi_gain(), kw.get("reference"), torque_limit=kw.get("torque_limit"), name="pid-lmi")


def _smc_factory(variant: str) -> Callable[..., ct.NonlinearIOSystem]:
    def factory(**kw: Any) -> ct.NonlinearIOSystem:
        return sliding_mode_controller(
            kw.get("params"),
            kw.get("reference"),
            gains=kw.get("gains"),
            variant=variant,
            torque_limit=kw.get("torque_limit"),
            name=f"smc-{variant}",
        )

    return factory


@dataclass(frozen=True)
class ControllerKind:
    """One entry of :data:`CONTROLLERS`: a controller by name and what belongs to it.

    Attributes
    ----------
    name : str
    build : callable
        ``build(**options) -> control.NonlinearIOSystem``; see :func:`make_controller`.
    Ts : float or None
        Period, s, at which the law runs sampled with a zero-order hold; None for a
        continuous-time law.
    description : str

    Calling the entry builds the controller: ``CONTROLLERS['pid'](K=K)``.
    """

    name: str
    build: Callable[..., ct.NonlinearIOSystem]
    Ts: float | None

    sample_time = renamed_field("sample_time", "Ts")
    description: str

    def __call__(self, **options: Any) -> ct.NonlinearIOSystem:
        return self.build(**options)


#: Controllers by name: ``pid`` (designed at (ρ, η) = (3, 90) on the published model
#: unless ``K`` or ``rho``/``eta`` are given), ``pid-lmi`` (the gain synthesized with its
#: certificate, :func:`pid_lmi_gain`), ``smc`` (boundary layer, continuous) and
#: ``smc-sign`` (discontinuous, sampled at 1 kHz: an adaptive integrator would crawl on
#: its switching surface, and a real controller is sampled anyway) and ``pid-sampled``
#: (the PID's :class:`~scara_robust.DiscretePID` at 1 kHz, with back-calculation
#: anti-windup when a torque limit is given).
CONTROLLERS: dict[str, ControllerKind] = {
    kind.name: kind
    for kind in (
        ControllerKind("pid", _pid_factory, None, "PID u = -K x of the paper"),
        ControllerKind("pid-lmi", _pid_lmi_factory, None, "PID with a gain synthesized with its certificate (LMI)"),
        ControllerKind("smc", _smc_factory("boundary"), None, "sliding mode, boundary layer"),
        ControllerKind("smc-sign", _smc_factory("sign"), 1e-3, "sliding mode, sign switching, sampled at 1 kHz"),
        ControllerKind(
            "pid-sampled", _sampled_pid_factory, SAMPLED_PID_TS,
            "PID of the paper, discrete (Tustin), sampled at 1 kHz, anti-windup when limited",
        ),
    )
}

#: Sample time (s) of each sampled controller in :data:`CONTROLLERS` (read from the registry).
SAMPLE_TIMES: dict[str, float] = {k.name: k.Ts for k in CONTROLLERS.values() if k.Ts is not None}


def make_controller(name: str, **options: Any) -> ct.NonlinearIOSystem:
    """Build a controller from :data:`CONTROLLERS` by name.

    Parameters
    ----------
    name : {'pid', 'pid-lmi', 'smc', 'smc-sign', 'pid-sampled'}
    **options
        ``K`` or ``rho``/``eta`` (pid, pid-sampled), ``params`` and ``gains`` (smc),
        ``reference``, ``torque_limit``; ``Ts`` and ``anti_windup`` (pid-sampled).

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``q1, q2, q1_dot, q2_dot``, outputs ``Tc1, Tc2`` (N·m).
    """
    check_choice("controller", name, tuple(CONTROLLERS))
    if "sample_time" in options:
        options["Ts"] = renamed_argument("make_controller", "sample_time", "Ts", options.pop("sample_time"),
                                         options.get("Ts"), None)
    return CONTROLLERS[name](**options)
