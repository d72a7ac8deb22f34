"""The nonlinear closed loop of an arm from its URDF: Pinocchio's ABA under the paper's PID.

The loop is ``τ = τ_ff(t) − K [∫e, e, ė] + τ_d(t)`` with ``e = r − q`` on the arm's
forward dynamics ``q̈ = ABA(q, q̇, τ, m_p(t))``; its state is ``[q, q̇, ∫e]`` (3n). It runs
through the same segment loop and engines as the SCARA (:mod:`scara_robust.simulation.engines`:
LSODA by default, fixed-step RK4, RK4 with a sampled and held controller), or whole in
machine code on the SCARA's compiled integrators (``method='compiled'``, the extra
``compiled``: :mod:`scara_robust.simulation.compiled_arm`), and is judged by the same
metrics and statuses (:func:`scara_robust.tracking_metrics`, :data:`scara_robust.STATUSES`).

Angles in rad, rates in rad/s, torques in N·m, masses in kg, times in s.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, cast

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_argument, renamed_field
from .._validation import check_array, check_callable, check_choice, check_instance, check_real
from ..controller.kinds import controller_kind, schedule_of
from ..controller.scheduled import ScheduledGain
from ..exceptions import ArgumentValueError
from ..model.arm import ArmSetup
from ..model.signals import MeasurementNoise, SquareWave
from ..paper import PAPER_TRANSIENT
from .compiled import COMPILED_INTEGRATORS, NUMBA_MISSING, numba_available
from .compiled_arm import compiled_arm_run
from .engines import ENGINES, integrate
from .loop import DIVERGENCE_LIMIT, STATE_LIMIT
from .metrics import TRACKING_TOLERANCE, TrackingMetrics, run_status, tracking_metrics
from .result import peak

__all__ = ["simulate_arm", "ArmRun", "ARM_ENGINES"]

Array = NDArray[np.float64]
#: Engines an arm runs on (names of :data:`scara_robust.ENGINES`).
ARM_ENGINES = ("lsoda", "rk4", "compiled")


class _NoDisturbance:
    """Zero disturbance torque on n joints, with no switching instants."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __call__(self, t: Any) -> Array:
        return np.zeros(self.n) if np.ndim(t) == 0 else np.zeros((self.n, np.size(t)))

    def switching_times(self, t0: float, t1: float) -> Array:
        return np.zeros(0)


def _gain_of_time(K: Array | ScheduledGain, payload: Callable[[float], Any],
                  bias: float) -> Callable[[float], Array]:
    """``t -> K`` (n, 3n): the fixed gain, or a schedule's at the measured payload ``m_p(t) + bias``."""
    schedule = schedule_of(K)
    if schedule is not None:
        return lambda t: schedule.gain(float(payload(t)) + bias)
    fixed = cast(Array, K)
    return lambda t: fixed


@dataclass(frozen=True)
class ArmLoop:
    """One arm loop for the engines: state ``[q, q̇, ∫e]``, shape (3n,).

    Attributes
    ----------
    setup : ArmSetup
        The arm, its reference and feedforward.
    K : ndarray, shape (n, 3n), or ScheduledGain
        The PID gain on ``[∫e, e, ė]``, or a gain scheduled on the measured payload.
    payload : callable
        ``m_p(t)`` in kg.
    disturbance : SquareWave or None
        Disturbance torque (one sign per joint), or none.
    Ts : float or None
        Period (s) of a sampled PID, held between samples; None if continuous.
    torque_limit : ndarray, shape (n,), or None
        Each joint's torque is clipped to ± its entry, N·m (inf: none); None: no limit.
    noise : MeasurementNoise or None
        Noise on the measured angles (its rate on the measured rates); the PID and its
        integrator see ``q + n(t)``.
    measurement_bias : float
        With a scheduled gain: what its measurement adds to ``m_p(t)``, kg.
    """

    setup: ArmSetup
    K: Array | ScheduledGain
    payload: Callable[[float], Any]
    disturbance: Any
    Ts: float | None = None
    torque_limit: Array | None = None
    noise: MeasurementNoise | None = None
    measurement_bias: float = 0.0

    sample_time = renamed_field("sample_time", "Ts")

    discrete = False

    @property
    def n(self) -> int:
        """Joints n."""
        return self.setup.arm.n_joints

    @property
    def n_states(self) -> int:
        """``3n``: joint angles, rates and the integral of the error."""
        return 3 * self.n

    @cached_property
    def torque(self) -> Callable[[float, Array], Array]:
        """``torque(t, x) -> τ_ff(t) − K [∫e, e, ė]``, shape (n,), N·m."""
        n, ref, setup, noise = self.n, self.setup.reference, self.setup, self.noise
        constant_ff = setup.feedforward == "none"
        zero = np.zeros(n)
        limit = self.torque_limit
        gain_at = _gain_of_time(self.K, self.payload, self.measurement_bias)

        def torque(t: float, x: Array) -> Array:
            r, rd, _ = ref.at(t)
            if noise is not None:
                r, rd = r - noise(t), rd - noise.rate(t)
            err = np.concatenate([x[2 * n:], r - x[:n], rd - x[n:2 * n]])
            out: Array = (zero if constant_ff else setup.tau_ff(t)) - gain_at(t) @ err
            return out if limit is None else np.clip(out, -limit, limit)

        return torque

    @cached_property
    def rhs(self) -> Callable[[float, Array, Array, Array], Array]:
        """``rhs(t, x, tc, td) -> ẋ``: ABA with the payload of time t; a state beyond the limits is frozen."""
        n, arm, ref, payload, noise = self.n, self.setup.arm, self.setup.reference, self.payload, self.noise

        def rhs(t: float, x: Array, tc: Array, td: Array) -> Array:
            if not np.abs(x[:2 * n]).max() <= STATE_LIMIT:
                return np.zeros_like(x)
            dx = np.empty_like(x)
            dx[:n] = x[n:2 * n]
            dx[n:2 * n] = arm.forward_dynamics(x[:n], x[n:2 * n], tc + td, float(payload(t)))
            dx[2 * n:] = ref.at(t)[0] - x[:n] if noise is None else ref.at(t)[0] - noise(t) - x[:n]
            return dx

        return rhs

    def jump(self, t: float, x: Array) -> Array:  # pragma: no cover - the PID here is continuous or held
        raise NotImplementedError

    def divergence(self, t: float, x: Array, limit: float) -> str | None:
        """Why the run counts as diverged at (t, x), or None."""
        n = self.n
        beyond = not np.all(np.isfinite(x[:2 * n])) or np.abs(x[:2 * n]).max() > STATE_LIMIT
        if beyond or np.abs(self.setup.reference.at(t)[0] - x[:n]).max() > limit:
            return f"diverged by t = {t:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
        return None


@dataclass(frozen=True)
class ArmPIDLoop:
    """An arm under a sampled :class:`~scara_robust.DiscretePID` for the engines: state ``[q, q̇, z]``.

    The PID (with its feedforward, limit, anti-windup and deadband, as exported) is sampled
    at ``t_k = k Ts``: ``u_k = pid.control(r, ṙ, r̈, q + n, q̇ + ṅ)`` held over the period, its
    state z jumping once per sample; the arm's effort limits clip what the motors give.

    Attributes
    ----------
    setup : ArmSetup
    pid : DiscretePID
    payload : callable
        ``m_p(t)``, kg.
    disturbance : SquareWave or None
    limit : ndarray, shape (n,), or None
        The motors' limit (N·m), after the PID's own.
    noise : MeasurementNoise or None
    """

    setup: ArmSetup
    pid: Any
    payload: Callable[[float], Any]
    disturbance: Any
    limit: Array | None = None
    noise: MeasurementNoise | None = None

    discrete = True

    @property
    def Ts(self) -> float:
        """The PID's sample time, s."""
        return float(self.pid.Ts)

    @property
    def n(self) -> int:
        """Joints n."""
        return self.setup.arm.n_joints

    @property
    def n_plant(self) -> int:
        """``2n``: the arm's angles and rates, before the PID's state."""
        return 2 * self.n

    @property
    def n_states(self) -> int:
        """``2n + n_z``."""
        return 2 * self.n + int(self.pid.n_state_values)

    def _sample(self, t: float, x: Array) -> tuple[list[float], list[float], list[float], list[float] | None]:
        """``(z, y, u, v)`` of the PID at the sample (t, x): its state, input and torques."""
        n, setup, noise = self.n, self.setup, self.noise
        r, rd, rdd = setup.reference.at(t)
        q, qd = x[:n], x[n:2 * n]
        if noise is not None:
            q, qd = q + noise(t), qd + noise.rate(t)
        y = [float(v) for v in r - q] + [float(v) for v in rd - qd]
        ff = None if self.pid.feedforward is None else self.pid.feedforward.torque(list(r), list(rd), list(rdd))
        z = [float(v) for v in x[2 * n:]]
        u, v = self.pid.output(z, y, ff)
        return z, y, u, v

    @cached_property
    def torque(self) -> Callable[[float, Array], Array]:
        """``torque(t, x)``: the PID's held torque at the sample (t, x), clipped to the motors' limit, N·m."""
        limit = self.limit

        def torque(t: float, x: Array) -> Array:
            out = np.array(self._sample(t, x)[2], dtype=float)
            return out if limit is None else np.clip(out, -limit, limit)

        return torque

    @cached_property
    def rhs(self) -> Callable[[float, Array, Array, Array], Array]:
        """``rhs(t, x, tc, td) -> ẋ``: ABA with the payload of time t; the PID's state is constant between samples."""
        n, arm, payload = self.n, self.setup.arm, self.payload

        def rhs(t: float, x: Array, tc: Array, td: Array) -> Array:
            dx = np.zeros_like(x)
            if not np.abs(x[:2 * n]).max() <= STATE_LIMIT:
                return dx
            dx[:n] = x[n:2 * n]
            dx[n:2 * n] = arm.forward_dynamics(x[:n], x[n:2 * n], tc + td, float(payload(t)))
            return dx

        return rhs

    def jump(self, t: float, x: Array) -> Array:
        """The PID's next state after the sample (t, x)."""
        z, y, u, v = self._sample(t, x)
        return np.array(self.pid.update(z, y, u, v), dtype=float)

    def divergence(self, t: float, x: Array, limit: float) -> str | None:
        """Why the run counts as diverged at (t, x), or None."""
        n = self.n
        beyond = not np.all(np.isfinite(x[:2 * n])) or np.abs(x[:2 * n]).max() > STATE_LIMIT
        if beyond or np.abs(self.setup.reference.at(t)[0] - x[:n]).max() > limit:
            return f"diverged by t = {t:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
        return None


@dataclass(frozen=True)
class ArmRun:
    """One closed-loop run of an arm.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Sample times, s.
    q, e, edot : ndarray, shape (n, k)
        Joint angles, errors ``r − q`` (rad) and their rates (rad/s).
    torque : ndarray, shape (n, k)
        The applied joint torque ``τ_ff − K x`` (without the disturbance), N·m.
    feedforward : ndarray, shape (n, k)
        Its feedforward part, N·m.
    payload : ndarray, shape (k,)
        m_p(t), kg.
    joints : tuple of str
    success, diverged : bool
    message, method, status, status_reason : str
    t_transient, tracking_tolerance : float
        s and rad.
    """

    t: Array
    q: Array
    e: Array
    edot: Array
    torque: Array
    feedforward: Array
    payload: Array
    joints: tuple[str, ...]
    success: bool
    diverged: bool
    message: str
    method: str
    status: str
    status_reason: str
    t_transient: float = PAPER_TRANSIENT
    tracking_tolerance: float = TRACKING_TOLERANCE
    _metrics: TrackingMetrics | None = field(default=None, repr=False, compare=False)

    def metrics(self, t_transient: float | None = None) -> TrackingMetrics:
        """:func:`scara_robust.tracking_metrics` after `t_transient` (s; default the run's)."""
        t0 = self.t_transient if t_transient is None else t_transient
        if self._metrics is not None and t0 == self.t_transient:
            return self._metrics
        return tracking_metrics(self.t, self.e, self.torque, t_transient=t0)

    @property
    def has_metrics(self) -> bool:
        """True if at least two samples follow the transient (so :meth:`metrics` exists)."""
        return int((self.t >= self.t_transient).sum()) >= 2

    @property
    def u(self) -> Array:
        """The controller's torque, shape (n, k), N·m: `torque` under :class:`~scara_robust.Run`'s name."""
        return self.torque

    @property
    def reason(self) -> str:
        """`status_reason` under :class:`~scara_robust.Run`'s name."""
        return self.status_reason

    @property
    def max_abs_error(self) -> float:
        """``max |e|`` after `t_transient` over joints, rad (NaN when the transient fills the run)."""
        return self.metrics().max_abs_error if self.has_metrics else math.nan

    @property
    def peak_input(self) -> float:
        """``max |u|`` over the run and joints, N·m."""
        return peak(self.torque)

    def to_pandas(self) -> pd.DataFrame:
        """One row per sample: ``t [s]``, ``m_p [kg]``, then ``e_<joint> [rad]`` and ``tau_<joint> [N·m]``."""
        cols: dict[str, Any] = {"t [s]": self.t, "m_p [kg]": self.payload}
        for i, j in enumerate(self.joints):
            cols[f"e_{j} [rad]"] = self.e[i]
        for i, j in enumerate(self.joints):
            cols[f"tau_{j} [N·m]"] = self.torque[i]
        return pd.DataFrame(cols)


def simulate_arm(
    setup: ArmSetup,
    K: ArrayLike | ScheduledGain,
    payload: Callable[[float], Any] | None = None,
    *,
    e0: ArrayLike | None = None,
    edot0: ArrayLike | None = None,
    disturbance: SquareWave | None = None,
    t_final: float = 20.0,
    dt: float = 1e-3,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    method: str = "lsoda",
    integrator: str = "bdf",
    Ts: float | None = None,
    sample_time: float | None = None,
    divergence_limit: float = DIVERGENCE_LIMIT,
    t_transient: float = PAPER_TRANSIENT,
    tracking_tolerance: float = TRACKING_TOLERANCE,
    torque_limit: float | ArrayLike | None = None,
    noise: MeasurementNoise | None = None,
    measurement_bias: float = 0.0,
) -> ArmRun:
    """Simulate the arm under the PID ``τ = τ_ff − K [∫e, e, ė]`` with a varying payload.

    Parameters
    ----------
    setup : ArmSetup
        The arm, reference and feedforward (:func:`scara_robust.load_arm`).
    K : array_like, shape (n, 3n), ScheduledGain or DiscretePID
        PID gain (a :class:`~scara_robust.Design`'s ``K``), the sampled PID as it is
        exported (:meth:`~scara_robust.Design.discretize`, with the arm's feedforward:
        :func:`~scara_robust.arm_feedforward`; run at its Ts on ``rk4``, its limit on the
        total torque, the arm's effort limits after it), or a gain scheduled on the
        measured payload (:func:`scara_robust.synthesize_schedule`, a schedule file of
        ``synthesize --schedule m_p``): ``K(m̂_p(t))`` with ``m̂_p = m_p(t) +
        measurement_bias``, the edge gain outside its breakpoints.
    payload : callable, optional
        ``m_p(t)`` in kg (default: constant at the setup's nominal payload).
    e0, edot0 : array_like, shape (n,), optional
        Initial errors ``e(0) = r(0) − q(0)`` (rad) and error rates (rad/s); default the
        setup's (its robot file's ``[initial]``), else 0. ``∫e`` starts at 0.
    disturbance : SquareWave, optional
        Disturbance torque with one sign (or scale) per joint; default the setup's (its
        robot file's ``[disturbance]``), else none.
    t_final : float
        Horizon, s (> 0).
    dt : float
        Output spacing, s (and the RK4 step of a continuous PID).
    rtol, atol : float
        Tolerances of LSODA (and of the compiled engine's adaptive steps).
    method : {'lsoda', 'rk4', 'compiled'}
        The engine. ``'compiled'`` (the extra ``compiled``, numba) runs the same loop in
        machine code: the arm's dynamics by RNEA and CRBA on its rigid bodies, checked
        against Pinocchio once per arm, on the SCARA's compiled integrators; it takes a
        :class:`~scara_robust.ConstantPayload`, a :class:`~scara_robust.SinusoidalPayload`
        or a profile of :func:`~scara_robust.parameter_profile` as `payload`.
    integrator : {'bdf', 'dopri5'}
        The compiled engine's integrator of a continuous PID: scipy's BDF step for step
        (stiff loops) or Dormand–Prince 5(4); other engines ignore it.
    Ts : float, optional
        Run the PID sampled with this period and held (zero-order hold), integrated by
        RK4 with that step (on the ``rk4`` engine, or compiled with ``method='compiled'``).
    divergence_limit : float
        ``max |e|`` (rad) beyond which the run stops as diverged.
    t_transient, tracking_tolerance : float
        The status looks at ``t >= t_transient`` (s): tracking when ``max |e|`` is at most
        `tracking_tolerance` (rad) there.
    sample_time : float, optional
        Deprecated name of `Ts`.
    torque_limit : float or array_like, shape (n,), optional
        Actuator limit: each joint's total torque (feedforward and PID) is clipped to ± this,
        N·m (> 0; one number for every joint, or one per joint; ``inf``: none). Default: the
        arm's effort limits (its URDF's, or its robot file's ``effort_limits``), none on a
        joint without one.
    noise : MeasurementNoise, optional
        Noise on the measured joint angles (one row per joint); the PID, its integrator
        and the derivative term see ``q + n(t)`` and ``q̇ + ṅ(t)``, the metrics the true
        error ``r − q``.
    measurement_bias : float
        With a scheduled `K`: what the payload's measurement adds to the true ``m_p(t)``, kg.

    Returns
    -------
    ArmRun

    See Also
    --------
    ArmSetup : the arm, its reference and payload.
    plot_arm_run : draws the run.
    """
    n = setup.arm.n_joints
    bias = check_real("measurement_bias [kg]", measurement_bias)
    if controller_kind(K) == "pid":  # the exported controller itself, sampled at its Ts
        return _simulate_arm_pid(setup, K, payload, e0=e0, edot0=edot0, disturbance=disturbance, t_final=t_final,
                                 divergence_limit=divergence_limit, t_transient=t_transient,
                                 tracking_tolerance=tracking_tolerance, torque_limit=torque_limit, noise=noise,
                                 method=method, Ts=Ts)
    gain = _arm_gain(K, n, bias)
    load = check_callable("payload", payload) if payload is not None else (lambda t: setup.payload_nominal)
    t_final = check_real("t_final", t_final, positive=True)
    dt = check_real("dt", dt, positive=True)
    check_choice("method", method, ARM_ENGINES)
    check_choice("integrator", integrator, COMPILED_INTEGRATORS)
    if method == "compiled" and not numba_available():
        raise ArgumentValueError("method", NUMBA_MISSING)
    Ts = renamed_argument("simulate_arm", "sample_time", "Ts", sample_time, Ts, None)
    if Ts is not None:
        Ts = check_real("Ts", Ts, positive=True)
        if method != "compiled":
            method = "rk4"
    disturbance = setup.disturbance if disturbance is None else disturbance
    if disturbance is not None and len(disturbance.signs) != n:
        raise ArgumentValueError("disturbance", f"must have one sign per joint ({n}), found {len(disturbance.signs)}")
    x0 = _initial_state(setup, e0, edot0)
    torque_limit = _torque_limit(setup, torque_limit)
    if noise is not None:
        check_instance("noise", noise, MeasurementNoise, "a MeasurementNoise")
        if noise.n != n:
            raise ArgumentValueError("noise", f"must have one row per joint ({n}), found {noise.n}")
    if method == "compiled":
        fast = compiled_arm_run(setup, gain, payload, x0, t_final, disturbance=disturbance, dt=dt, rtol=rtol,
                                atol=atol, divergence_limit=divergence_limit, Ts=Ts, integrator=integrator,
                                torque_limit=torque_limit, noise=noise, measurement_bias=bias)
        t, X, ff, masses = fast.t, fast.x, fast.feedforward, fast.payload
        success, diverged, message = fast.success, fast.diverged, fast.message
        # the kernel's own errors and torque at the samples (the reference it evaluated)
        e, edot, tau = fast.e, fast.edot, fast.torque
    else:
        loop = ArmLoop(setup, gain, load, disturbance if disturbance is not None else _NoDisturbance(n), Ts,
                       torque_limit, noise, bias)
        traj = integrate(ENGINES[method], loop, x0, t_final, dt=dt, rtol=rtol, atol=atol,  # type: ignore[arg-type]
                         divergence_limit=divergence_limit)
        t, X = traj.t, traj.x
        success, diverged, message = traj.success, traj.diverged, traj.message
        e, edot, tau, ff, masses = _samples(setup, gain, load, t, X, torque_limit, noise, bias)
    q = X[:n]
    metrics = None
    if int((t >= t_transient).sum()) >= 2 and not diverged:
        metrics = tracking_metrics(t, e, tau, t_transient=t_transient)
    status, reason = run_status(metrics, success=success, diverged=diverged, message=message,
                                tolerance=tracking_tolerance, t_transient=t_transient)
    return ArmRun(t=t, q=q, e=e, edot=edot, torque=tau, feedforward=ff, payload=masses,
                  joints=setup.arm.joints, success=success and not diverged, diverged=diverged,
                  message=message, method=method, status=status, status_reason=reason,
                  t_transient=t_transient, tracking_tolerance=tracking_tolerance, _metrics=metrics)


def _arm_gain(K: Any, n: int, bias: float) -> Array | ScheduledGain:
    """simulate_arm's gain: a schedule on m_p of (n, 3n) gains, or a fixed (n, 3n) K (which measures nothing)."""
    schedule = schedule_of(K)
    if schedule is not None:
        if schedule.shape != (n, 3 * n) or schedule.parameter != "m_p":
            raise ArgumentValueError("K", f"must schedule gains of shape ({n}, {3 * n}) on this arm's [∫e, e, ė] on "
                                          f"its payload m_p, found {schedule.shape} on {schedule.parameter!r}")
        return schedule
    if bias != 0.0:
        raise ArgumentValueError("measurement_bias", "goes with a scheduled gain; a fixed K measures nothing")
    return check_array("K", K, shape=(n, 3 * n))


def _simulate_arm_pid(setup: ArmSetup, pid: Any, payload: Callable[[float], Any] | None, *, e0: ArrayLike | None,
                      edot0: ArrayLike | None, disturbance: SquareWave | None, t_final: float, divergence_limit: float,
                      t_transient: float, tracking_tolerance: float, torque_limit: Any, noise: MeasurementNoise | None,
                      method: str, Ts: float | None) -> ArmRun:
    """simulate_arm with a DiscretePID: :class:`ArmPIDLoop` on the ``rk4`` engine, one step per sample."""
    n = setup.arm.n_joints
    if pid.n_joints != n or pid.n_torques != n:
        raise ArgumentValueError("K", f"must be a PID of this arm's {n} joints, found {pid.n_torques} torques for "
                                      f"{pid.n_joints} joints")
    if Ts is not None and float(Ts) != float(pid.Ts):
        raise ArgumentValueError("Ts", f"must be the PID's Ts = {pid.Ts:g} s or none, found {Ts!r}")
    if method not in ("lsoda", "rk4"):
        raise ArgumentValueError("method", f"a DiscretePID runs on 'rk4' (one step per sample), found {method!r}")
    load = check_callable("payload", payload) if payload is not None else (lambda t: setup.payload_nominal)
    t_final = check_real("t_final", t_final, positive=True)
    disturbance = setup.disturbance if disturbance is None else disturbance
    if noise is not None:
        check_instance("noise", noise, MeasurementNoise, "a MeasurementNoise")
    pid = copy.deepcopy(pid)
    pid.reset()
    x0 = np.concatenate([_initial_state(setup, e0, edot0)[:2 * n], pid.state])
    loop = ArmPIDLoop(setup, pid, load, disturbance if disturbance is not None else _NoDisturbance(n),
                      _torque_limit(setup, torque_limit), noise)
    traj = integrate(ENGINES["rk4"], loop, x0, t_final, dt=pid.Ts, rtol=1e-8, atol=1e-10,  # type: ignore[arg-type]
                     divergence_limit=divergence_limit)
    t, X = traj.t, traj.x
    r, rd, rdd = setup.reference.sample(t)
    e, edot = r.T - X[:n], rd.T - X[n:2 * n]
    tau = np.array([loop.torque(float(tk), X[:, k]) for k, tk in enumerate(t)]).reshape(t.size, n).T
    ff = np.zeros((n, t.size)) if pid.feedforward is None else np.array(
        [pid.feedforward.torque(list(r[k]), list(rd[k]), list(rdd[k])) for k in range(t.size)]).reshape(t.size, n).T
    masses = np.array([float(load(float(tk))) for tk in t])
    metrics = None
    if int((t >= t_transient).sum()) >= 2 and not traj.diverged:
        metrics = tracking_metrics(t, e, tau, t_transient=t_transient)
    status, reason = run_status(metrics, success=traj.success, diverged=traj.diverged, message=traj.message,
                                tolerance=tracking_tolerance, t_transient=t_transient)
    return ArmRun(t=t, q=X[:n], e=e, edot=edot, torque=tau, feedforward=ff, payload=masses, joints=setup.arm.joints,
                  success=traj.success and not traj.diverged, diverged=traj.diverged, message=traj.message,
                  method="rk4", status=status, status_reason=reason, t_transient=t_transient,
                  tracking_tolerance=tracking_tolerance, _metrics=metrics)


def _torque_limit(setup: ArmSetup, torque_limit: float | ArrayLike | None) -> Array | None:
    """Each joint's torque limit (n,), N·m: the one given (a number for all joints), else the arm's effort
    limits; None when no joint has one."""
    n = setup.arm.n_joints
    if torque_limit is None:
        return setup.torque_limit
    limits = check_array("torque_limit [N·m]", np.broadcast_to(np.asarray(torque_limit, dtype=float), (n,))
                         if np.ndim(torque_limit) == 0 else torque_limit, shape=(n,), finite=False)
    if not np.all(limits > 0):
        raise ArgumentValueError("torque_limit [N·m]", f"must be > 0 per joint (inf: none), found {limits.tolist()}")
    return None if np.all(np.isinf(limits)) else limits.copy()


def _initial_state(setup: ArmSetup, e0: ArrayLike | None, edot0: ArrayLike | None) -> Array:
    """The loop's state ``[q, q̇, ∫e]`` at t = 0 from the initial errors (default the setup's, else 0)."""
    n = setup.arm.n_joints
    e0 = setup.e0 if e0 is None else e0
    edot0 = setup.edot0 if edot0 is None else edot0
    r0, rd0, _ = setup.reference.at(0.0)
    e_init = np.zeros(n) if e0 is None else check_array("e0", e0, shape=(n,))
    ed_init = np.zeros(n) if edot0 is None else check_array("edot0", edot0, shape=(n,))
    return np.concatenate([r0 - e_init, rd0 - ed_init, np.zeros(n)])


def _samples(setup: ArmSetup, gain: Array | ScheduledGain, load: Callable[[float], Any], t: Array, X: Array,
             torque_limit: Array | None, noise: MeasurementNoise | None,
             bias: float) -> tuple[Array, Array, Array, Array, Array]:
    """``(e, ė, τ, τ_ff, m_p)`` at the samples of a run: the law of :meth:`ArmLoop.torque` at every sample at once.

    A held law's samples are its sample instants, so the same formula holds for it.
    """
    n = setup.arm.n_joints
    ff = np.zeros((n, t.size)) if setup.feedforward == "none" else \
        np.array([setup.tau_ff(float(tk)) for tk in t]).reshape(t.size, n).T
    masses = np.array([float(load(float(tk))) for tk in t])
    r, rd, _ = setup.reference.sample(t)
    e, edot = r.T - X[:n], rd.T - X[n:2 * n]
    measured = (e, edot) if noise is None else (e - noise(t), edot - noise.rate(t))
    states = np.vstack([X[2 * n:], *measured])
    schedule = schedule_of(gain)
    if schedule is not None:
        gains = schedule.gain(masses + bias)  # (k, n, 3n) at the measured payloads
        tau = ff - np.einsum("kij,jk->ik", gains, states)
    else:
        tau = ff - gain @ states
    if torque_limit is not None:
        tau = np.clip(tau, -torque_limit[:, None], torque_limit[:, None])
    return e, edot, tau, ff, masses
