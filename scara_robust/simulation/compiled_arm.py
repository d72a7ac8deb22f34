"""The compiled engine for a URDF arm: its closed loop in machine code (numba, extra ``compiled``).

:func:`scara_robust.simulate_arm` with ``method='compiled'`` runs here. The arm's rigid
bodies are read once from the Pinocchio model the package builds
(:meth:`~scara_robust.RobotArm.rigid_bodies`: joint placements, axes, inertias with the
locked joints folded in, the payload per kg, the armature, gravity) into arrays, and the
kernels of :mod:`scara_robust.simulation._kernels` run the recursive algorithms on them:
RNEA for the bias forces and the feedforward, CRBA for the mass matrix (with the
armature), and a Cholesky solve for ``q̈ = M⁻¹(τ − b)``. The closed loop is the same as
:class:`~scara_robust.simulation.arm.ArmLoop`'s (the PID on ``[∫e, e, ė]``, the
nominal-payload feedforward on the reference ``r(t)``, the square-wave disturbance, the
payload ``m_p(t)``, the state limits), integrated by the same compiled integrators as the
SCARA (:data:`~scara_robust.simulation.compiled.COMPILED_INTEGRATORS`: scipy's BDF step for
step, or Dormand–Prince 5(4), dense output at the samples, restarted at every switch of the
disturbance; RK4 per sample for a sampled PID).

Pinocchio stays the reference: the first time a robot's compiled model is built, its mass
matrix, RNEA and forward dynamics are compared with Pinocchio's (CRBA, RNEA, ABA) on random
states and payloads (:func:`check_compiled_dynamics`), and a mismatch refuses the robot.

A payload the kernels can evaluate is a :class:`~scara_robust.ConstantPayload`, a
:class:`~scara_robust.SinusoidalPayload`, or any profile of
:func:`~scara_robust.parameter_profile`; a callable of one's own is refused (the Python
engines take it).

Angles in rad, rates in rad/s, torques in N·m, masses in kg, times in s.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_choice
from ..controller.kinds import schedule_of
from ..controller.scheduled import ScheduledGain
from ..exceptions import ArgumentValueError
from ..model.arm import FEEDFORWARDS, ArmSetup, RigidBodies, RobotArm
from ..model.robot import ConstantPayload, SinusoidalPayload
from ..model.signals import MeasurementNoise, SquareWave
from .compiled import COMPILED_INTEGRATORS
from .engines import output_grid
from .loop import STATE_LIMIT
from .plants import ParameterProfile

__all__: list[str] = []

Array = NDArray[np.float64]

#: Largest relative difference from Pinocchio the load check accepts.
DYNAMICS_RTOL = 1e-12
#: Random states of the load check.
CHECK_STATES = 24

# Layout of the model tuple: see _kernels.py ("a URDF arm").
_N_P = 18
_A_GRAVITY, _A_PAYLOAD, _A_DIST, _A_FF, _A_NOMINAL, _A_TS, _A_LIMIT, _A_NOISY = 0, 3, 8, 11, 12, 13, 14, 15
_A_SCHEDULED, _A_BIAS = 16, 17
_COMPLETED, _DIVERGED, _FAILED = 0, 1, 2
_PAYLOAD_KINDS = {"constant": 0, "sine": 1, "sinusoid": 2, "ramp": 3, "table": 4}


@dataclass(frozen=True, eq=False)
class _Bodies:
    """An arm's rigid bodies as the kernels read them (checked against Pinocchio)."""

    ix: NDArray[np.int64]  # n, payload body, parents (n), body of each joint (n)
    tree: Array  # (n, 16)
    body: Array  # (n + 1, 13)
    gravity: Array  # (3,)
    errors: dict[str, float]  # the load check's worst relative differences


_CHECKED: weakref.WeakKeyDictionary[RobotArm, _Bodies] = weakref.WeakKeyDictionary()


def _kernels() -> SimpleNamespace:
    """The kernels the arm uses (numba is imported here, the first time)."""
    from ._kernels import arm_forward_dynamics, arm_inverse_dynamics, arm_mass_matrix, run

    return SimpleNamespace(run=run, arm_mass_matrix=arm_mass_matrix, arm_inverse_dynamics=arm_inverse_dynamics,
                           arm_forward_dynamics=arm_forward_dynamics)


def _origin_inertia(mass: float, com: Array, inertia: Array) -> Array:
    """(m, m c, I about the frame's origin) of a body with its inertia about its centre of mass, shape (13,)."""
    c = np.asarray(com, dtype=float)
    about_origin = np.asarray(inertia, dtype=float) + mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return np.concatenate([[mass], mass * c, about_origin.ravel()])


def pack_bodies(bodies: RigidBodies) -> tuple[NDArray[np.int64], Array, Array, Array]:
    """The kernels' arrays of a tree of rigid bodies.

    Parameters
    ----------
    bodies : RigidBodies

    Returns
    -------
    ix : ndarray of int, shape (2 + 2n,)
        n, the payload's body, each body's parent (−1: the base), each joint's body.
    tree : ndarray, shape (n, 16)
        Joint placement rotation (row-major) and translation (m), axis, armature (kg·m²).
    body : ndarray, shape (n + 1, 13)
        Mass (kg), first moment (kg·m), inertia about the joint frame's origin (kg·m²); the
        last row the payload per kg.
    gravity : ndarray, shape (3,)
        m/s².

    Raises
    ------
    ArgumentValueError
        Naming ``method``, for a tree whose bodies do not list parents first.
    """
    n = bodies.parents.size
    if np.any(bodies.parents >= np.arange(n)):
        raise ArgumentValueError("method", "'compiled' needs the arm's bodies listed parents first; use 'lsoda'")
    ix = np.concatenate([[n, bodies.payload_body], bodies.parents, bodies.joint_index]).astype(np.int64)
    tree = np.zeros((n, 16))
    tree[:, 0:9] = bodies.rotations.reshape(n, 9)
    tree[:, 9:12] = bodies.translations
    tree[:, 12:15] = bodies.axes
    tree[:, 15] = bodies.armature
    body = np.zeros((n + 1, 13))
    for i in range(n):
        body[i] = _origin_inertia(float(bodies.masses[i]), bodies.coms[i], bodies.inertias[i])
    body[n] = _origin_inertia(1.0, bodies.payload_com, bodies.payload_inertia)
    return ix, np.ascontiguousarray(tree), body, np.asarray(bodies.gravity, dtype=float).copy()


def _model(ix: NDArray[np.int64], tree: Array, body: Array, gravity: Array, *, reference: Array | None = None,
           gain: Array | None = None, payload: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0),
           table: Array | None = None, disturbance: tuple[float, float, float] = (0.0, 1.0, 0.0),
           feedforward: int = 0, nominal: float = 0.0, Ts: float = 0.0, limit: float = math.inf,
           noise: Array | None = None, schedule: ScheduledGain | None = None, bias: float = 0.0) -> tuple[Any, ...]:
    """The model tuple the kernels take (see _kernels.py), with its own scratch arrays."""
    n = int(ix[0])
    P = np.zeros(_N_P)
    P[_A_GRAVITY:_A_GRAVITY + 3] = gravity
    P[_A_PAYLOAD:_A_PAYLOAD + 5] = payload
    P[_A_DIST:_A_DIST + 3] = disturbance
    P[_A_FF], P[_A_NOMINAL], P[_A_TS] = feedforward, nominal, Ts
    P[_A_LIMIT], P[_A_NOISY] = limit, 0.0 if noise is None else 1.0
    P[_A_SCHEDULED], P[_A_BIAS] = (0.0, 0.0) if schedule is None else (1.0, bias)
    refs = np.vstack([np.zeros((5, n)), np.full((1, n), math.inf)]) if reference is None else \
        np.ascontiguousarray(reference, dtype=float)
    # the kernels write a scheduled K(m̂_p(t)) into this array: always the tuple's own
    K = np.zeros((n, 3 * n)) if gain is None else np.array(gain, dtype=float, order="C")
    sched = np.zeros((1, 1 + 9 * n * n)) if schedule is None else np.hstack(
        [schedule.breakpoints[:, None], schedule.gains.reshape(schedule.breakpoints.size, -1)])
    tab = np.zeros((2, 2)) if table is None else np.ascontiguousarray(table, dtype=float)
    noise_table = np.zeros((n, 3)) if noise is None else np.ascontiguousarray(noise, dtype=float)
    return (P, ix, tree, body, refs, K, tab, np.zeros((n, 40)), np.zeros((n, n)), np.zeros((11, n)),
            np.full(2, np.nan), noise_table, np.ascontiguousarray(sched, dtype=float))


def check_compiled_dynamics(arm: RobotArm, bodies: tuple[NDArray[np.int64], Array, Array, Array] | None = None, *,
                            n_states: int = CHECK_STATES, seed: int = 0,
                            rtol: float = DYNAMICS_RTOL) -> dict[str, float]:
    """Compare the compiled dynamics with Pinocchio's on random states and payloads.

    At each state (angles uniform in ``[−π, π]`` rad, rates in ``[−3, 3]`` rad/s,
    accelerations in ``[−10, 10]`` rad/s², torques in ``[−50, 50]`` N·m, payload in
    ``[0, 5]`` kg, the first state with no payload), each quantity's difference, in the
    largest entry, is measured relative to the size of what it is made of: the mass matrix
    to ``max |M|``; RNEA's torque to ``max|M| max|q̈| + max|b|`` (``b`` RNEA's at ``q̈ = 0``);
    the forward dynamics to ``max|M⁻¹| (max|τ| + max|b|)``.

    Parameters
    ----------
    arm : RobotArm
    bodies : tuple of ndarray, optional
        The kernels' arrays (:func:`pack_bodies`); default the arm's own.
    n_states, seed : int
        How many random states, and their seed.
    rtol : float
        Largest relative difference accepted.

    Returns
    -------
    dict
        ``{'mass_matrix': ..., 'rnea': ..., 'aba': ...}``: the worst relative difference
        of each over the states.

    Raises
    ------
    ArgumentValueError
        Naming ``method``, when a difference exceeds `rtol`: the compiled model does not
        reproduce Pinocchio's and the compiled engine refuses the arm.
    """
    kernels = _kernels()
    ix, tree, body, gravity = pack_bodies(arm.rigid_bodies()) if bodies is None else bodies
    model = _model(ix, tree, body, gravity)
    n = arm.n_joints
    rng = np.random.default_rng(seed)
    worst = {"mass_matrix": 0.0, "rnea": 0.0, "aba": 0.0}
    M_c, tau_c, acc_c = np.zeros((n, n)), np.zeros(n), np.zeros(n)
    for k in range(n_states):
        q, v = rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n)
        a, tau = rng.uniform(-10, 10, n), rng.uniform(-50, 50, n)
        mass = 0.0 if k == 0 else float(rng.uniform(0, 5))
        M = arm.mass_matrix(q, mass)
        bias = arm.inverse_dynamics(q, v, np.zeros(n), mass)
        kernels.arm_mass_matrix(model, q, mass, M_c)
        kernels.arm_inverse_dynamics(model, q, v, a, mass, tau_c)
        kernels.arm_forward_dynamics(model, q, v, tau, mass, acc_c)
        size_M = float(np.abs(M).max())
        scales = {"mass_matrix": size_M,
                  "rnea": size_M * float(np.abs(a).max()) + float(np.abs(bias).max()),
                  "aba": float(np.abs(np.linalg.inv(M)).max()) * (float(np.abs(tau).max()) + float(np.abs(bias).max()))}
        diffs = {"mass_matrix": M_c - M, "rnea": tau_c - arm.inverse_dynamics(q, v, a, mass),
                 "aba": acc_c - arm.forward_dynamics(q, v, tau, mass)}
        for name, diff in diffs.items():
            err = float(np.abs(diff).max()) / scales[name] if np.all(np.isfinite(diff)) else math.inf
            worst[name] = max(worst[name], err)
    bad = {name: err for name, err in worst.items() if not err <= rtol}
    if bad:
        what = ", ".join(f"{name} by {err:.3g}" for name, err in bad.items())
        raise ArgumentValueError("method", f"'compiled' refuses arm {arm.name!r}: its compiled dynamics do not "
                                           f"reproduce Pinocchio's on random states (relative difference {what}, "
                                           f"above {rtol:g}); use 'lsoda' or 'rk4'")
    return worst


def compiled_bodies(arm: RobotArm) -> _Bodies:
    """The arm's bodies for the kernels, read and checked against Pinocchio once per arm.

    Parameters
    ----------
    arm : RobotArm

    Returns
    -------
    _Bodies
    """
    found = _CHECKED.get(arm)
    if found is None:
        ix, tree, body, gravity = pack_bodies(arm.rigid_bodies())
        errors = check_compiled_dynamics(arm, (ix, tree, body, gravity))
        found = _Bodies(ix, tree, body, gravity, errors)
        _CHECKED[arm] = found
    return found


def _payload_spec(payload: Any, nominal: float) -> tuple[tuple[float, ...], Array | None]:
    """The kernels' payload kind and numbers (and table) of a payload profile."""
    if payload is None:
        return (_PAYLOAD_KINDS["constant"], nominal, 0.0, 0.0, 0.0), None
    if isinstance(payload, ConstantPayload):
        return (_PAYLOAD_KINDS["constant"], float(payload.mass), 0.0, 0.0, 0.0), None
    if isinstance(payload, SinusoidalPayload):
        return (_PAYLOAD_KINDS["sine"], float(payload.offset), float(payload.amplitude), float(payload.omega),
                float(payload.phase)), None
    if isinstance(payload, ParameterProfile):
        if payload.times is not None and payload.values is not None:
            table = np.vstack([np.asarray(payload.times, dtype=float), np.asarray(payload.values, dtype=float)])
            return (_PAYLOAD_KINDS["table"], 0.0, 0.0, 0.0, 0.0), table
        if payload.kind in ("constant", "sinusoid", "ramp"):
            numbers = tuple(float(v) for v in payload.numbers) + (0.0,) * (4 - len(payload.numbers))
            return (_PAYLOAD_KINDS[payload.kind], *numbers), None
    raise ArgumentValueError("payload", "'compiled' evaluates a ConstantPayload, a SinusoidalPayload or a profile of "
                                        f"parameter_profile, found {type(payload).__name__}: a callable of one's own "
                                        "runs on method='lsoda' or 'rk4'")


def pack_arm_loop(setup: ArmSetup, K: Array | ScheduledGain, payload: Any, disturbance: SquareWave | None,
                  Ts: float | None, torque_limit: float | ArrayLike | None = None,
                  noise: MeasurementNoise | None = None, measurement_bias: float = 0.0) -> tuple[Any, ...]:
    """The model tuple of one arm loop (checking the arm's compiled dynamics the first time).

    Parameters
    ----------
    setup : ArmSetup
    K : ndarray, shape (n, 3n), or ScheduledGain
        The PID gain, or one scheduled on the measured payload ``m_p(t) + measurement_bias``.
    payload : ConstantPayload, SinusoidalPayload, ParameterProfile or None
        ``m_p(t)`` in kg; None: the setup's nominal payload.
    disturbance : SquareWave or None
    Ts : float or None
        Sample time of a sampled PID, s.
    torque_limit : float or array_like, shape (n,), optional
        Each joint's torque is clipped to ± this, N·m (one for all or one per joint; inf or
        None: no limit).
    noise : MeasurementNoise, optional
        Noise on the measured angles (and its rate on the measured rates).
    measurement_bias : float
        With a scheduled `K`: what the payload's measurement adds to ``m_p(t)``, kg.

    Returns
    -------
    tuple of ndarray

    Raises
    ------
    ArgumentValueError
        Naming ``payload`` for a payload callable the kernels cannot evaluate, or
        ``method`` for an arm whose compiled dynamics do not reproduce Pinocchio's.
    """
    spec, table = _payload_spec(payload, float(setup.payload_nominal))
    bodies = compiled_bodies(setup.arm)
    ref = setup.reference
    n = setup.arm.n_joints
    signs = np.zeros(n) if disturbance is None else np.asarray(disturbance.signs, dtype=float)
    wave = (0.0, 1.0, 0.0) if disturbance is None else (float(disturbance.amplitude), float(disturbance.period),
                                                         float(disturbance.phase))
    limits = np.broadcast_to(np.inf if torque_limit is None else np.asarray(torque_limit, dtype=float), (n,))
    reference = np.vstack([ref.center, ref.amplitude, ref.omega, ref.phase, signs, limits])
    scheduled = schedule_of(K)
    return _model(bodies.ix, bodies.tree, bodies.body, bodies.gravity, reference=reference,
                  gain=cast(Array, K) if scheduled is None else scheduled.gains[0], payload=spec,
                  table=table, disturbance=wave, feedforward=FEEDFORWARDS.index(setup.feedforward),
                  nominal=float(setup.payload_nominal), Ts=0.0 if Ts is None else float(Ts),
                  limit=math.inf,
                  noise=None if noise is None else np.hstack([noise.amplitude, noise.omega, noise.phase]),
                  schedule=scheduled, bias=float(measurement_bias))


@dataclass(frozen=True)
class CompiledArmRun:
    """What the compiled arm engine returns: the state and the feedforward on the output grid.

    Attributes
    ----------
    t : ndarray, shape (k,)
        s.
    x : ndarray, shape (3n, k)
        ``[q, q̇, ∫e]``.
    feedforward : ndarray, shape (n, k)
        ``τ_ff(t)``, N·m.
    payload : ndarray, shape (k,)
        ``m_p(t)``, kg.
    torque : ndarray, shape (n, k)
        The PID's torque ``τ_ff − K [∫e, e, ė]`` (N·m), as the kernel applied it.
    e, edot : ndarray, shape (n, k)
        ``r − q`` (rad) and ``ṙ − q̇`` (rad/s), from the reference the kernel evaluated.
    success, diverged : bool
    message : str
    rhs_calls : int
    """

    t: Array
    x: Array
    feedforward: Array
    payload: Array
    torque: Array
    e: Array
    edot: Array
    success: bool
    diverged: bool
    message: str
    rhs_calls: int


def compiled_arm_run(setup: ArmSetup, K: Array | ScheduledGain, payload: Any, x0: ArrayLike, t_final: float, *,
                     disturbance: SquareWave | None = None, dt: float = 1e-3, rtol: float = 1e-8,
                     atol: float = 1e-10, divergence_limit: float = 50.0, Ts: float | None = None,
                     integrator: str = "bdf", torque_limit: float | ArrayLike | None = None,
                     noise: MeasurementNoise | None = None, measurement_bias: float = 0.0) -> CompiledArmRun:
    """Integrate one arm loop with the compiled engine.

    Parameters
    ----------
    setup : ArmSetup
    K : ndarray, shape (n, 3n), or ScheduledGain
        The PID gain, or one scheduled on the measured payload.
    payload : ConstantPayload, SinusoidalPayload, ParameterProfile or None
        ``m_p(t)``, kg (None: the nominal).
    x0 : array_like, shape (3n,)
        ``[q, q̇, ∫e]`` at t = 0.
    t_final, dt : float
        Horizon and output spacing, s (a sampled PID outputs at its samples).
    disturbance : SquareWave, optional
    rtol, atol : float
        Tolerances of the adaptive steps.
    divergence_limit : float
        rad.
    Ts : float, optional
        Sample time of a sampled PID, s: one RK4 step per sample with the torque held.
    integrator : {'bdf', 'dopri5'}
        For a continuous PID (:data:`~scara_robust.simulation.compiled.COMPILED_INTEGRATORS`).
    torque_limit : float or array_like, shape (n,), optional
        N·m, one for every joint or one per joint (None: no limit).
    noise : MeasurementNoise, optional
        Noise on the measured angles.
    measurement_bias : float
        With a scheduled `K`: what the payload's measurement adds to ``m_p(t)``, kg.

    Returns
    -------
    CompiledArmRun
    """
    stiff = check_choice("integrator", integrator, COMPILED_INTEGRATORS) == "bdf"
    gain = K if schedule_of(K) is not None else np.asarray(K, dtype=float)
    model = pack_arm_loop(setup, gain, payload, disturbance, Ts, torque_limit, noise, measurement_bias)
    n = setup.arm.n_joints
    if Ts is not None:
        steps = int(np.floor(t_final / Ts + 1e-9))
        t_out = np.asarray(Ts * np.arange(steps + 1), dtype=float)
        edges = t_out
    else:
        t_out = output_grid(t_final, dt)
        switches = np.zeros(0) if disturbance is None else disturbance.switching_times(0.0, t_final)
        edges = np.concatenate([[0.0], switches, [t_final]])
    X = np.zeros((3 * n, t_out.size))
    TC, FF = np.zeros((n, t_out.size)), np.zeros((3 * n + 1, t_out.size))
    x_start = np.ascontiguousarray(x0, dtype=float)
    k, code, t_stop, calls = _kernels().run(model, x_start, t_out, edges, rtol, atol, divergence_limit, X, TC, FF,
                                            stiff)
    if code == _DIVERGED:
        message = f"diverged by t = {t_stop:.3f} s (|e| > {divergence_limit} rad or a state beyond {STATE_LIMIT:g})"
    elif code == _FAILED:
        message = f"integrator failed at t = {t_stop:.3f} s: step size too small"
    else:
        message = "completed"
    return CompiledArmRun(t=t_out[:k], x=X[:, :k], feedforward=FF[:n, :k], payload=FF[n, :k], torque=TC[:, :k],
                          e=FF[n + 1:2 * n + 1, :k], edot=FF[2 * n + 1:, :k],
                          success=code == _COMPLETED, diverged=code == _DIVERGED, message=message,
                          rhs_calls=int(calls))
