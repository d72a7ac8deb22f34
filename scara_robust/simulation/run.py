"""Closed-loop runs of a controller on the nonlinear SCARA (paper Section 4).

:func:`simulate` integrates one loop with an engine chosen by name
(:data:`~scara_robust.simulation.engines.ENGINES`); :func:`run_scenario` builds a named
controller for the paper's signals (or yours) and simulates it. Campaigns, the
comparison and the command line all run through :func:`run_scenario`.

Times in s, angles in rad, torques in N·m, masses in kg.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_argument
from .._resources import check_memory, simulation_bytes
from .._validation import check_array, check_choice, check_instance, check_real
from ..exceptions import ArgumentValueError
from ..model.initial import SCENARIOS, Scenario
from ..model.robot import ConstantPayload, PayloadProfile, ScaraParams, paper_payload
from ..model.signals import Reference, SquareWave, paper_disturbance, paper_reference
from ..paper import PAPER_T_FINAL, PAPER_TRANSIENT
from .compiled import NUMBA_MISSING, CompiledEngine, CompiledRun, compiled_batch, compiled_run, numba_available
from .controllers import CONTROLLERS, make_controller
from .engines import DEFAULT_ENGINE, ENGINES, SAMPLED_ENGINE, Engine, Trajectory, integrate
from .loop import DIVERGENCE_LIMIT, OUTPUT_LABELS, ClosedLoop
from .metrics import TRACKING_TOLERANCE, TrackingMetrics, run_status, tracking_metrics
from .result import peak

__all__ = ["SimulationResult", "simulate", "run_scenario", "run_scenarios"]

Array = NDArray[np.float64]

# Output spacing (s) and tolerances of a run: simulate's defaults, and run_scenario's.
_DT, _RTOL, _ATOL = 1e-3, 1e-8, 1e-10


@dataclass(frozen=True)
class SimulationResult:
    """One closed-loop run.

    Attributes
    ----------
    response : control.TimeResponseData
        python-control's response (``.to_pandas()`` gives a table); outputs ``q1, q2,
        q1_dot, q2_dot, Tc1, Tc2, Td1, Td2``.
    t : ndarray, shape (k,)
        Sample times, s.
    e : ndarray, shape (2, k)
        ``r - q``, rad.
    edot : ndarray, shape (2, k)
        ``ṙ - q̇``, rad/s.
    torque : ndarray, shape (2, k)
        Control torque T_c, N·m.
    disturbance : ndarray, shape (2, k)
        T_d, N·m.
    payload : ndarray, shape (k,)
        m_p(t), kg.
    success : bool
        False when the integrator failed or the run diverged (see `status` for whether it tracks).
    diverged : bool
        The error exceeded ``divergence_limit``; the run stopped there.
    message : str
    controller, scenario : str
    method : str
        The engine that integrated the run (a key of :data:`scara_robust.ENGINES`).
    status : str
        One of :data:`scara_robust.STATUSES`: ``tracking`` means the run finished and
        max |e| after `t_transient` is within `tracking_tolerance`.
    status_reason : str
        Why, in words and numbers.
    t_transient : float
        End of the transient for `status` and :meth:`metrics`, s.
    tracking_tolerance : float
        Tolerance of `status`, rad.
    peak_torque : float
        ``max |T_ci(t)|`` of the trajectory, N·m: the largest sample, refined between the
        samples around the largest local maxima where the engine is dense (a continuous
        controller's torque can peak between two 1-ms samples); NaN when not computed.
    """

    response: ct.TimeResponseData
    t: Array
    e: Array
    edot: Array
    torque: Array
    disturbance: Array
    payload: Array
    success: bool
    diverged: bool
    message: str
    controller: str
    scenario: str
    method: str = DEFAULT_ENGINE
    status: str = "failed"
    status_reason: str = ""
    t_transient: float = PAPER_TRANSIENT
    tracking_tolerance: float = TRACKING_TOLERANCE
    peak_torque: float = float("nan")
    #: The metrics at `t_transient`, computed once when the run is made.
    _metrics: TrackingMetrics | None = field(default=None, repr=False, compare=False)

    def metrics(self, t_transient: float | None = None) -> TrackingMetrics:
        """:func:`scara_robust.tracking_metrics` of this run after `t_transient` (s; default the run's)."""
        t0 = self.t_transient if t_transient is None else t_transient
        if self._metrics is not None and t0 == self.t_transient:
            return self._metrics
        return tracking_metrics(self.t, self.e, self.torque, t_transient=t0, peak_torque=self.peak_torque)

    @property
    def has_metrics(self) -> bool:
        """True if at least two samples follow the transient (so :meth:`metrics` exists)."""
        return int((self.t >= self.t_transient).sum()) >= 2

    @property
    def u(self) -> Array:
        """The controller's torque, shape (2, k), N·m: `torque` under :class:`~scara_robust.Run`'s name."""
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
        """``max |u|`` over the run and joints, N·m (`peak_torque` where computed)."""
        return self.peak_torque if math.isfinite(self.peak_torque) else peak(self.torque)

    def to_pandas(self) -> pd.DataFrame:
        """Time series: t, e1, e2, e1_dot, e2_dot, Tc1, Tc2, Td1, Td2, m_p."""
        return pd.DataFrame(
            {
                "t": self.t,
                "e1": self.e[0],
                "e2": self.e[1],
                "e1_dot": self.edot[0],
                "e2_dot": self.edot[1],
                "Tc1": self.torque[0],
                "Tc2": self.torque[1],
                "Td1": self.disturbance[0],
                "Td2": self.disturbance[1],
                "m_p": self.payload,
            }
        )


#: Local maxima of |T_c| on the output grid whose neighbourhood is searched for the true peak.
PEAK_CANDIDATES = 5
#: Points of the fine grid over the two sample intervals around a candidate.
PEAK_POINTS = 41


def _peak_torque(
    engine: Engine, loop: ClosedLoop, t: Array, X: Array, torque: Array, rtol: float, atol: float
) -> float:
    """``max |T_c(t)|`` of the trajectory: the sampled peak, refined around the largest local maxima.

    Each candidate sample i is re-integrated from sample i - 1 to i + 1 on a fine grid with
    the same engine; a sampled controller holds its torque, so its samples are exact.
    """
    mag = np.abs(torque).max(axis=0)
    peak = float(mag.max()) if mag.size else float("nan")
    if not engine.dense or loop.Ts is not None or mag.size < 2:
        return peak
    padded = np.concatenate([[-np.inf], mag, [-np.inf]])
    local = np.flatnonzero((padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:]))
    for i in local[np.argsort(mag[local])[-PEAK_CANDIDATES:]]:
        a, b = max(int(i) - 1, 0), min(int(i) + 1, mag.size - 1)
        fine = np.linspace(t[a], t[b], PEAK_POINTS)[1:]
        traj = integrate(
            engine, loop, X[:, a], float(t[b]), dt=float(fine[1] - fine[0]), rtol=rtol, atol=atol,
            divergence_limit=np.inf, t0=float(t[a]), t_out=fine,
        )
        if traj.success:
            peak = max(peak, float(np.abs(loop.outputs(traj.t, traj.x)[4:6]).max()))
    return peak


def _result(
    loop: ClosedLoop,
    traj: Trajectory,
    scenario: str,
    engine: Engine,
    t_transient: float,
    tolerance: float,
    rtol: float,
    atol: float,
    known: tuple[Array, float, Array] | None = None,
) -> SimulationResult:
    """The result of a trajectory.

    `known` = (torque (2, k), peak torque, errors (4, k)) when the engine computed them.
    """
    t, X = traj.t, traj.x
    if known is None:
        Y = loop.outputs(t, X)
    else:
        Y = np.vstack([X[:4], known[0], np.asarray(loop.disturbance(t), dtype=float).reshape(2, len(t))])
    response = ct.TimeResponseData(
        t,
        Y,
        X,
        None,
        output_labels=list(OUTPUT_LABELS),
        state_labels=loop.state_labels,
        title=f"{loop.controller.name}, scenario {scenario}",
        issiso=False,
    )
    if known is not None:  # (r - q, ṙ - q̇) from the engine
        e, edot = known[2][0:2], known[2][2:4]
    else:
        if loop.reference.sinusoid is not None:  # the package's own references are vectorized
            r = np.asarray(loop.reference.position(t), dtype=float).reshape(2, len(t))
            rd = np.asarray(loop.reference.velocity(t), dtype=float).reshape(2, len(t))
        else:  # element by element: a user's reference need not be vectorized
            r = np.array([np.asarray(loop.reference.position(ti), dtype=float) for ti in t]).reshape(len(t), 2).T
            rd = np.array([np.asarray(loop.reference.velocity(ti), dtype=float) for ti in t]).reshape(len(t), 2).T
        e, edot = r - Y[0:2], rd - Y[2:4]
    peak = _peak_torque(engine, loop, t, X, Y[4:6], rtol, atol) if known is None else known[1]
    after = t >= t_transient
    metrics = tracking_metrics(t, e, Y[4:6], t_transient=t_transient, peak_torque=peak) if after.sum() >= 2 else None
    status, reason = run_status(
        metrics,
        success=traj.success,
        diverged=traj.diverged,
        message=traj.message,
        tolerance=tolerance,
        t_transient=t_transient,
    )
    return SimulationResult(
        response=response,
        t=t,
        e=e,
        edot=edot,
        torque=Y[4:6],
        disturbance=Y[6:8],
        payload=np.broadcast_to(np.asarray(loop.payload(t), dtype=float), t.shape).copy(),
        success=traj.success,
        diverged=traj.diverged,
        message=traj.message,
        controller=loop.controller.name,
        scenario=scenario,
        method=engine.name,
        status=status,
        status_reason=reason,
        t_transient=t_transient,
        tracking_tolerance=tolerance,
        peak_torque=peak,
        _metrics=metrics,
    )


def _engine_name(method: str | None, Ts: float | None) -> str:
    if method == "fast":  # the name of 0.1, kept for old scripts
        warnings.warn(
            "simulate(method='fast') is deprecated: it names a speed, not an algorithm; use method='lsoda' "
            "(continuous controllers) or 'rk4' (sampled), or leave method unset",
            DeprecationWarning,
            stacklevel=3,
        )
        method = None
    if method is None:
        return SAMPLED_ENGINE if Ts is not None else DEFAULT_ENGINE
    name = check_choice("method", method, tuple(ENGINES))
    if Ts is not None and not ENGINES[name].sampled:
        sampled = ", ".join(repr(n) for n, e in ENGINES.items() if e.sampled)
        raise ArgumentValueError("method", f"must be {sampled} for a sampled controller, found {name!r}")
    if name == CompiledEngine.name and not numba_available():
        raise ArgumentValueError("method", NUMBA_MISSING)
    return name


def simulate(
    controller: ct.NonlinearIOSystem | str,
    scenario: Scenario | str = "large",
    *,
    params: ScaraParams | None = None,
    payload: PayloadProfile | None = None,
    reference: Reference | None = None,
    disturbance: SquareWave | None = None,
    t_final: float = PAPER_T_FINAL,
    dt: float = _DT,
    x0: ArrayLike | None = None,
    rtol: float = _RTOL,
    atol: float = _ATOL,
    divergence_limit: float = DIVERGENCE_LIMIT,
    method: str | None = None,
    Ts: float | None = None,
    t_transient: float = PAPER_TRANSIENT,
    tracking_tolerance: float = TRACKING_TOLERANCE,
    sample_time: float | None = None,
) -> SimulationResult:
    """Simulate one controller on the nonlinear SCARA.

    Parameters
    ----------
    controller : control.NonlinearIOSystem or str
        A controller system (inputs ``q1, q2, q1_dot, q2_dot``, outputs ``Tc1, Tc2``)
        or a name from :data:`scara_robust.CONTROLLERS` (which brings its sample time).
    scenario : Scenario or {'large', 'small'}
        Initial tracking error.
    params : ScaraParams, optional
    payload : callable, optional
        ``m_p(t)`` in kg (default: the paper's sinusoid).
    reference : Reference, optional
        Must be the reference the controller tracks (default: the paper's).
    disturbance : SquareWave, optional
        Default: ±5 N·m, period π/5 s.
    t_final : float
        Horizon, s (> 0).
    dt : float
        Output sample spacing, s (> 0), for the continuous engines.
    x0 : array_like, shape (4 + n_c,), optional
        Full initial state (plant then controller), overriding `scenario`.
    rtol, atol : float
        Tolerances of the adaptive engines.
    divergence_limit : float
        A run whose ``max |e|`` exceeds this (rad) stops and is flagged diverged.
    method : {'lsoda', 'interconnect', 'rk4'}, optional
        The engine, from :data:`scara_robust.ENGINES`. Default ``'lsoda'`` for a
        continuous controller and ``'rk4'`` for a sampled one. ``'interconnect'`` is the
        reference path (python-control's ``interconnect`` and ``input_output_response``,
        RK45). ``'fast'``, the name of version 0.1, is a deprecated alias of the default.
    Ts : float, optional
        Run the controller sampled with this period (s, > 0) and a zero-order hold,
        integrated by ``'rk4'`` with that step (the output grid is then the sample
        grid). Default: the registry's sample time for a named controller, the `dt` of
        a discrete-time system (e.g. :func:`scara_robust.sampled_pid_controller`), none
        for a continuous one.
    t_transient : float
        End of the transient, s (>= 0): metrics and status look at ``t >= t_transient``.
    tracking_tolerance : float
        A finished run is ``tracking`` when max |e| after the transient is at most this,
        rad (> 0; default :data:`scara_robust.TRACKING_TOLERANCE`, 0.05 rad).
    sample_time : float, optional
        Deprecated name of `Ts`.

    Returns
    -------
    SimulationResult

    See Also
    --------
    run_scenario : a named scenario of the paper.
    simulate_plant : any plant with varying parameters.
    simulate_arm : any arm from its URDF.

    Examples
    --------
    >>> import scara_robust as sr
    >>> res = sr.simulate("pid", "small", t_final=0.5)
    >>> res.e.shape[0], res.success, res.method
    (2, True, 'lsoda')
    """
    Ts = renamed_argument("simulate", "sample_time", "Ts", sample_time, Ts, None)
    return _execute(
        _prepare(controller, scenario, params, payload, reference, disturbance, t_final, dt, x0, rtol, atol,
                 divergence_limit, method, Ts, t_transient, tracking_tolerance)
    )


@dataclass(frozen=True)
class _Prepared:
    """A checked run, ready for its engine."""

    loop: ClosedLoop
    x0: Array
    engine: str
    scenario: str
    t_final: float
    dt: float
    rtol: float
    atol: float
    limit: float
    t_transient: float
    tolerance: float

    def batch_key(self) -> tuple[Any, ...]:
        """Runs with equal keys can share one compiled call."""
        return (self.x0.size, self.loop.Ts, self.t_final, self.dt, self.rtol, self.atol, self.limit)


def _prepare(
    controller: ct.NonlinearIOSystem | str,
    scenario: Scenario | str,
    params: ScaraParams | None,
    payload: PayloadProfile | None,
    reference: Reference | None,
    disturbance: SquareWave | None,
    t_final: float,
    dt: float,
    x0: ArrayLike | None,
    rtol: float,
    atol: float,
    divergence_limit: float,
    method: str | None,
    Ts: float | None,
    t_transient: float,
    tracking_tolerance: float,
) -> _Prepared:
    params = params or ScaraParams()
    reference = reference or paper_reference()
    if disturbance is not None and len(disturbance.signs) != 2:
        raise ArgumentValueError("disturbance", f"must have one sign per joint of the SCARA (2), found "
                                                f"{len(disturbance.signs)}")
    if isinstance(controller, str):
        name = check_choice("controller", controller, tuple(CONTROLLERS))
        if Ts is None:
            Ts = CONTROLLERS[name].Ts
        options: dict[str, Any] = {"params": params, "reference": reference}
        if name == "pid-sampled":
            options["Ts"] = Ts
        controller = make_controller(name, **options)
    check_instance("controller", controller, ct.NonlinearIOSystem, "a name or a control.NonlinearIOSystem")
    if controller.isdtime(strict=True):
        dt_c = float(controller.dt) if controller.dt is not True else None
        if dt_c is None:
            raise ArgumentValueError("controller", "is discrete-time with an unspecified sample time (dt=True)")
        if Ts is not None and not np.isclose(check_real("Ts", Ts, positive=True), dt_c):
            raise ArgumentValueError(
                "Ts", f"must be the discrete-time controller's dt = {dt_c:g} s, found {Ts}"
            )
        Ts = dt_c
    if isinstance(scenario, str):
        scenario = SCENARIOS[check_choice("scenario", scenario, tuple(SCENARIOS))]
    check_instance("scenario", scenario, Scenario, "a name or a Scenario")
    t_final = check_real("t_final", t_final, positive=True)
    dt = check_real("dt", dt, positive=True)
    check_memory("t_final", simulation_bytes(t_final, dt, 6 + controller.nstates),
                 f"{t_final / dt + 1:.3g} output samples ({t_final:g} s every {dt:g} s)")
    rtol = check_real("rtol", rtol, positive=True)
    atol = check_real("atol", atol, positive=True)
    limit = check_real("divergence_limit", divergence_limit, positive=True)
    t_transient = check_real("t_transient", t_transient, nonnegative=True)
    tolerance = check_real("tracking_tolerance", tracking_tolerance, positive=True)
    if Ts is not None:
        Ts = check_real("Ts", Ts, positive=True)
    engine = _engine_name(method, Ts)
    loop = ClosedLoop(
        controller,
        params,
        payload if payload is not None else paper_payload(params),
        reference,
        disturbance or paper_disturbance(),
        Ts,
    )
    if x0 is None:
        plant0 = scenario.initial_state(reference)
        start = getattr(controller, "initial_state", None)
        if callable(start):  # a sampled PID starts bumpless at the initial error
            x_c0 = np.asarray(start(np.asarray(scenario.e0, dtype=float), np.asarray(scenario.edot0, dtype=float)))
        else:
            x_c0 = np.zeros(int(controller.nstates))
        x_init = np.concatenate([plant0, x_c0])
    else:
        x_init = check_array("x0", x0, shape=(loop.n_states,))
    return _Prepared(loop, x_init, engine, scenario.name, t_final, dt, rtol, atol, limit, t_transient, tolerance)


def _from_compiled(prep: _Prepared, run: CompiledRun) -> SimulationResult:
    traj = Trajectory(run.t, run.x, run.success, run.diverged, run.message)
    return _result(prep.loop, traj, prep.scenario, ENGINES[prep.engine], prep.t_transient, prep.tolerance,
                   prep.rtol, prep.atol, known=(run.torque, run.peak_torque, run.error))


def _execute(prep: _Prepared) -> SimulationResult:
    if prep.engine == CompiledEngine.name:
        run = compiled_run(prep.loop, prep.x0, prep.t_final, dt=prep.dt, rtol=prep.rtol, atol=prep.atol,
                           divergence_limit=prep.limit, peak_candidates=PEAK_CANDIDATES, peak_points=PEAK_POINTS)
        return _from_compiled(prep, run)
    traj = integrate(ENGINES[prep.engine], prep.loop, prep.x0, prep.t_final, dt=prep.dt, rtol=prep.rtol,
                     atol=prep.atol, divergence_limit=prep.limit)
    return _result(prep.loop, traj, prep.scenario, ENGINES[prep.engine], prep.t_transient, prep.tolerance,
                   prep.rtol, prep.atol)


def run_scenario(
    controller: str,
    scenario: Scenario | str,
    *,
    payload_on: bool = True,
    t_final: float = PAPER_T_FINAL,
    torque_limit: Any = None,
    params: ScaraParams | None = None,
    method: str | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    disturbance: SquareWave | None = None,
    K: ArrayLike | None = None,
    t_transient: float = PAPER_TRANSIENT,
    tracking_tolerance: float = TRACKING_TOLERANCE,
) -> SimulationResult:
    """Run a named controller on a scenario (the paper's signals unless given).

    Parameters
    ----------
    controller : {'pid', 'pid-lmi', 'smc', 'smc-sign', 'pid-sampled'}
        A name from :data:`scara_robust.CONTROLLERS`; a sampled one (``smc-sign``,
        ``pid-sampled``, 1 ms) runs with its sample time.
    scenario : Scenario or {'large', 'small'}
    payload_on : bool
        False sets ``m_p = 0`` (the setting of Figures 4-5).
    t_final : float
        Horizon, s.
    torque_limit : float or array_like of shape (2,), optional
        Per-joint saturation, N·m.
    params : ScaraParams, optional
        The robot (default: the paper's); the sliding-mode law uses it without payload.
    method : {'lsoda', 'interconnect', 'rk4'}, optional
        The engine (see :func:`simulate`).
    reference, payload, disturbance : optional
        Default: the paper's ``sin t, cos t``, ``0.3 m2 (sin t + 1)`` and ±5 N·m square waves.
    K : array_like, shape (2, 6), optional
        PID gain (default: designed at (3, 90) on the published model).
    t_transient, tracking_tolerance : float
        See :func:`simulate`.

    Returns
    -------
    SimulationResult

    See Also
    --------
    simulate : the same run from explicit arguments.
    compare_controllers : PID and sliding mode side by side.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.run_scenario("pid", "small", t_final=6.5).status
    'tracking'
    """
    return _execute(
        _prepare_scenario(controller, scenario, payload_on, t_final, torque_limit, params, method, reference, payload,
                          disturbance, K, t_transient, tracking_tolerance)
    )


def _prepare_scenario(
    controller: str,
    scenario: Scenario | str,
    payload_on: bool,
    t_final: float,
    torque_limit: Any,
    params: ScaraParams | None,
    method: str | None,
    reference: Reference | None,
    payload: PayloadProfile | None,
    disturbance: SquareWave | None,
    K: ArrayLike | None,
    t_transient: float,
    tracking_tolerance: float,
) -> _Prepared:
    """:func:`run_scenario` up to its engine (the defaults are run_scenario's)."""
    name = check_choice("controller", controller, tuple(CONTROLLERS))
    params = params or ScaraParams()
    reference = reference or paper_reference()
    options: dict[str, Any] = {"params": params, "reference": reference, "torque_limit": torque_limit}
    if K is not None and name in ("pid", "pid-sampled"):
        options["K"] = K
    ctrl = make_controller(name, **options)
    if payload_on:
        profile = payload if payload is not None else paper_payload(params)
    else:
        profile = ConstantPayload(0.0)
    return _prepare(ctrl, scenario, params, profile, reference, disturbance, t_final, _DT, None, _RTOL, _ATOL,
                    DIVERGENCE_LIMIT, method, CONTROLLERS[name].Ts, t_transient, tracking_tolerance)


_RUN_SCENARIO = inspect.signature(run_scenario)

#: What :func:`run_scenarios` does with a request that raises.
ERROR_POLICIES = ("raise", "return")


def run_scenarios(
    requests: Sequence[Mapping[str, Any]], *, errors: str = "raise"
) -> list[SimulationResult | Exception]:
    """Run many named scenarios; the compiled runs among them in as few compiled calls as possible.

    Each request gives the arguments of :func:`run_scenario`. Runs on the compiled engine
    that share their state size, sample time, horizon and tolerances are integrated in one
    call of :func:`scara_robust.compiled_batch` (a campaign's chunk, say); the others run
    one by one. Every result equals ``run_scenario(**request)``.

    Parameters
    ----------
    requests : sequence of mapping
        Keyword arguments of :func:`run_scenario`, with ``controller`` and ``scenario``.
    errors : {'raise', 'return'}
        Raise the first error of a request, or put the exception in its place.

    Returns
    -------
    list of SimulationResult (or Exception, with ``errors='return'``)
        In the order of `requests`.
    """
    policy = check_choice("errors", errors, ERROR_POLICIES)
    out: list[SimulationResult | Exception | None] = [None] * len(requests)
    prepared: dict[int, _Prepared] = {}
    for i, request in enumerate(requests):
        try:
            bound = _RUN_SCENARIO.bind(**request)  # run_scenario's defaults, and its errors
            bound.apply_defaults()
            prepared[i] = _prepare_scenario(**bound.arguments)
        except Exception as err:
            if policy == "raise":
                raise
            out[i] = err
    groups: dict[tuple[Any, ...], list[int]] = {}
    for i, prep in prepared.items():
        if prep.engine == CompiledEngine.name:
            groups.setdefault(prep.batch_key(), []).append(i)
        else:
            out[i] = _guarded(prep, policy)
    for members in groups.values():
        first = prepared[members[0]]
        try:
            runs = compiled_batch([prepared[i].loop for i in members], [prepared[i].x0 for i in members],
                                  first.t_final, dt=first.dt, rtol=first.rtol, atol=first.atol,
                                  divergence_limit=first.limit, peak_candidates=PEAK_CANDIDATES,
                                  peak_points=PEAK_POINTS)
        except Exception:  # find which request fails, one by one
            for i in members:
                out[i] = _guarded(prepared[i], policy)
            continue
        for i, run in zip(members, runs):
            out[i] = _from_compiled(prepared[i], run)
    done = [r for r in out if r is not None]
    assert len(done) == len(requests)
    return done


def _guarded(prep: _Prepared, policy: str) -> SimulationResult | Exception:
    try:
        return _execute(prep)
    except Exception as err:
        if policy == "raise":
            raise
        return err
