"""Closed-loop simulation of a controller on the nonlinear SCARA (paper Section 4).

The loop is assembled with ``control.interconnect`` from the plant, the controller and
a disturbance source, and integrated with ``control.input_output_response``. The horizon
is split at the square wave's switching instants so the integrator never steps across
a jump: within a segment the disturbance is constant.

Times in s, angles in rad, torques in N·m, masses in kg.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from ._validation import check_array, check_choice, check_real
from .controllers import CONTROLLERS, make_controller
from .metrics import TrackingMetrics, tracking_metrics
from .robot import ConstantPayload, PayloadProfile, ScaraParams, paper_payload, scara_plant
from .signals import Reference, SquareWave, paper_disturbance, paper_reference

__all__ = [
    "Scenario",
    "SCENARIOS",
    "SimulationResult",
    "closed_loop",
    "simulate",
    "run_scenario",
    "SAMPLE_TIMES",
]

Array = NDArray[np.float64]

#: Sampling period (s) of controllers simulated as sampled-data systems.
SAMPLE_TIMES: dict[str, float] = {"smc-sign": 1e-3}


@dataclass(frozen=True)
class Scenario:
    """Initial condition of a run, given as the tracking error at t = 0.

    Attributes
    ----------
    name : str
    e0 : tuple of float, shape (2,)
        ``e(0) = r(0) - q(0)``, rad.
    edot0 : tuple of float, shape (2,)
        ``ė(0)``, rad/s.
    """

    name: str
    e0: tuple[float, float]
    edot0: tuple[float, float]

    def initial_state(self, reference: Reference) -> Array:
        """Plant state ``[q1, q2, q̇1, q̇2]`` at t = 0, shape (4,)."""
        r0 = np.asarray(reference.position(0.0), dtype=float)
        rd0 = np.asarray(reference.velocity(0.0), dtype=float)
        return np.concatenate([r0 - np.asarray(self.e0), rd0 - np.asarray(self.edot0)])


#: The paper's two initial conditions: ``large`` (Figure 3: q(0) = (1.5, -1.5) rad,
#: q̇(0) = 0, i.e. e(0) = (-1.5, 2.5), ė(0) = (1, 0) for the paper's reference) and
#: ``small`` (Figure 6: e(0) = (0.05, 0.05) rad, ė(0) = 0).
SCENARIOS: dict[str, Scenario] = {
    "large": Scenario("large", (-1.5, 2.5), (1.0, 0.0)),
    "small": Scenario("small", (0.05, 0.05), (0.0, 0.0)),
}


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
        False when the integrator failed or the run diverged.
    diverged : bool
        The error exceeded ``divergence_limit``; the run stopped there.
    message : str
    controller, scenario : str
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

    def metrics(self, t_transient: float = 6.0) -> TrackingMetrics:
        """:func:`scara_robust.tracking_metrics` of this run."""
        return tracking_metrics(self.t, self.e, self.torque, t_transient=t_transient)

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


#: Integrator of the ``'fast'`` path. The PID closed loop is stiff (poles near −1500 1/s
#: at (ρ, η) = (3, 90)), so explicit RK45 is held to ~1 ms steps by stability, not
#: accuracy; LSODA switches to BDF there and takes the steps accuracy allows.
FAST_SOLVER = "LSODA"

#: Plant states (rad, rad/s) beyond which a run counts as diverged and is frozen.
STATE_LIMIT = 1e3


def _diverged(reference: Reference, t: float, x: Array, limit: float) -> bool:
    if not np.all(np.isfinite(x[:4])) or np.abs(x[:4]).max() > STATE_LIMIT:
        return True
    return bool(np.abs(np.asarray(reference.position(t), dtype=float) - x[:2]).max() > limit)


def _output_grid(t_final: float, dt: float) -> Array:
    """Output times 0, dt, 2 dt, ... up to `t_final`, which is always included (s)."""
    n_samples = int(np.floor(t_final / dt + 1e-9)) + 1
    t_out = np.linspace(0.0, dt * (n_samples - 1), n_samples)
    return t_out if t_out[-1] >= t_final - 1e-12 else np.append(t_out, t_final)


def _disturbance_source(wave: SquareWave) -> ct.NonlinearIOSystem:
    def outfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        # The level is held per integration segment so an RK stage at a segment's end
        # never sees the next segment's value.
        return np.asarray(wave(params.get("segment_midpoint", t)), dtype=float)

    return ct.NonlinearIOSystem(None, outfcn, inputs=0, outputs=["Td1", "Td2"], name="disturbance")


def closed_loop(
    controller: ct.NonlinearIOSystem,
    params: ScaraParams | None = None,
    payload: PayloadProfile | None = None,
    disturbance: SquareWave | None = None,
) -> ct.InterconnectedSystem:
    """Plant, controller and disturbance joined with ``control.interconnect``.

    Parameters
    ----------
    controller : control.NonlinearIOSystem
        Inputs ``q1, q2, q1_dot, q2_dot``, outputs ``Tc1, Tc2``.
    params : ScaraParams, optional
    payload : callable, optional
        ``m_p(t)`` in kg (default: the paper's).
    disturbance : SquareWave, optional


    Returns
    -------
    control.InterconnectedSystem
        No inputs; outputs ``q1, q2, q1_dot, q2_dot, Tc1, Tc2, Td1, Td2``; states the
        plant's four followed by the controller's.
    """
    params = params or ScaraParams()
    plant = scara_plant(params, payload if payload is not None else paper_payload(params), state_limit=STATE_LIMIT)
    source = _disturbance_source(disturbance or paper_disturbance())
    return ct.interconnect(
        [plant, controller, source],
        inplist=[],
        outlist=["q1", "q2", "q1_dot", "q2_dot", "Tc1", "Tc2", "Td1", "Td2"],
        outputs=["q1", "q2", "q1_dot", "q2_dot", "Tc1", "Tc2", "Td1", "Td2"],
        name="closed_loop",
    )


def simulate(
    controller: ct.NonlinearIOSystem | str,
    scenario: Scenario | str = "large",
    *,
    params: ScaraParams | None = None,
    payload: PayloadProfile | None = None,
    reference: Reference | None = None,
    disturbance: SquareWave | None = None,
    t_final: float = 20.0,
    dt: float = 1e-3,
    x0: ArrayLike | None = None,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    divergence_limit: float = 50.0,
    method: str = "interconnect",
    sample_time: float | None = None,
) -> SimulationResult:
    """Simulate one controller on the nonlinear SCARA.

    Parameters
    ----------
    controller : control.NonlinearIOSystem or str
        A controller system (inputs ``q1, q2, q1_dot, q2_dot``, outputs ``Tc1, Tc2``)
        or a name from :data:`scara_robust.CONTROLLERS`.
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
        Output sample spacing, s (> 0).
    x0 : array_like, shape (4 + n_c,), optional
        Full initial state (plant then controller), overriding `scenario`.
    rtol, atol : float
        Tolerances of ``scipy.integrate.solve_ivp`` (RK45).
    divergence_limit : float
        A run whose ``max |e|`` exceeds this (rad) stops and is flagged diverged.
    method : {'interconnect', 'fast'}
        ``'interconnect'`` integrates the ``control.interconnect`` system with
        ``control.input_output_response`` (the reference path). ``'fast'`` integrates
        the same equations with ``scipy.integrate.solve_ivp`` on a lean right-hand side
        that calls the plant dynamics and the controller's own ``updfcn``/``outfcn``
        directly, skipping the interconnection machinery.
    sample_time : float, optional
        If given (s, > 0), the controller runs sampled: its output is computed at
        multiples of `sample_time` and held in between (zero-order hold), and the loop
        is integrated by classical RK4 with that step (``method='fast'`` only; the
        output grid is then the sample grid). This is how the discontinuous
        sliding-mode law is simulated: an adaptive integrator would crawl on its
        switching surface, and a real controller is sampled anyway.

    Returns
    -------
    SimulationResult

    Examples
    --------
    >>> import scara_robust as sr
    >>> res = sr.simulate("pid", "small", t_final=0.5)
    >>> res.e.shape[0], res.success
    (2, True)
    """
    params = params or ScaraParams()
    reference = reference or paper_reference()
    if isinstance(controller, str):
        name = check_choice("controller", controller, tuple(CONTROLLERS))
        controller = make_controller(name, params=params, reference=reference)
    elif not isinstance(controller, ct.NonlinearIOSystem):
        raise TypeError(
            f"`controller` must be a name or a control.NonlinearIOSystem, found {type(controller).__name__}"
        )
    if isinstance(scenario, str):
        scenario = SCENARIOS[check_choice("scenario", scenario, tuple(SCENARIOS))]
    elif not isinstance(scenario, Scenario):
        raise TypeError(f"`scenario` must be a name or a Scenario, found {type(scenario).__name__}")
    t_final = check_real("t_final", t_final, positive=True)
    dt = check_real("dt", dt, positive=True)
    rtol = check_real("rtol", rtol, positive=True)
    atol = check_real("atol", atol, positive=True)
    limit = check_real("divergence_limit", divergence_limit, positive=True)
    check_choice("method", method, ("interconnect", "fast"))
    if sample_time is not None:
        sample_time = check_real("sample_time", sample_time, positive=True)
        if method != "fast":
            raise ValueError("`sample_time` needs method='fast', found method='interconnect'")
    payload = payload if payload is not None else paper_payload(params)
    wave = disturbance or paper_disturbance()
    n_c = controller.nstates
    if x0 is None:
        x_init = np.concatenate([scenario.initial_state(reference), np.zeros(n_c)])
    else:
        x_init = check_array("x0", x0, shape=(4 + n_c,))
    labels = ["q1", "q2", "q1_dot", "q2_dot", "Tc1", "Tc2", "Td1", "Td2"]
    state_labels = [f"scara_{n}" for n in ("q1", "q2", "q1_dot", "q2_dot")] + [
        f"{controller.name}_{n}" for n in controller.state_labels
    ]
    if method == "fast":
        t, X, Y, success, diverged, message = _fast_run(
            controller, params, payload, reference, wave, x_init, t_final, dt, rtol, atol, limit, sample_time
        )
        return _result(
            t,
            X,
            Y,
            labels,
            state_labels,
            reference,
            payload,
            success,
            diverged,
            message,
            controller.name,
            scenario.name,
        )
    sys = closed_loop(controller, params, payload, wave)

    t_out = _output_grid(t_final, dt)
    edges = np.concatenate([[0.0], wave.switching_times(0.0, t_final), [t_final]])
    times: list[Array] = []
    states: list[Array] = []
    outputs: list[Array] = []
    x = x_init
    success, diverged, message = True, False, "completed"
    for a, b in zip(edges[:-1], edges[1:]):
        inside = t_out[(t_out > a) & (t_out < b)]
        seg_t = np.concatenate([[a], inside, [b]])
        resp = ct.input_output_response(
            sys,
            seg_t,
            0,
            x,
            params={"segment_midpoint": 0.5 * (a + b)},
            solve_ivp_method="RK45",
            solve_ivp_kwargs={"rtol": rtol, "atol": atol},
        )
        keep = slice(None) if not times else slice(1, None)
        times.append(resp.time[keep])
        states.append(resp.states[:, keep])
        outputs.append(resp.outputs[:, keep])
        x = resp.states[:, -1]
        if _diverged(reference, b, x, limit):
            success, diverged = False, True
            message = f"diverged by t = {b:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
            break
    t = np.concatenate(times)
    X = np.concatenate(states, axis=1)
    Y = np.concatenate(outputs, axis=1)
    on_grid = np.isin(t, t_out) if len(t) > len(t_out) else np.ones(len(t), dtype=bool)
    t, X, Y = t[on_grid], X[:, on_grid], Y[:, on_grid]
    return _result(
        t,
        X,
        Y,
        list(sys.output_labels),
        list(sys.state_labels),
        reference,
        payload,
        success,
        diverged,
        message,
        controller.name,
        scenario.name,
    )


def _result(
    t: Array,
    X: Array,
    Y: Array,
    output_labels: list[str],
    state_labels: list[str],
    reference: Reference,
    payload: PayloadProfile,
    success: bool,
    diverged: bool,
    message: str,
    controller: str,
    scenario: str,
) -> SimulationResult:
    response = ct.TimeResponseData(
        t,
        Y,
        X,
        None,
        output_labels=output_labels,
        state_labels=state_labels,
        title=f"{controller}, scenario {scenario}",
        issiso=False,
    )
    r = np.array([np.asarray(reference.position(ti), dtype=float) for ti in t]).T
    rd = np.array([np.asarray(reference.velocity(ti), dtype=float) for ti in t]).T
    return SimulationResult(
        response=response,
        t=t,
        e=r - Y[0:2],
        edot=rd - Y[2:4],
        torque=Y[4:6],
        disturbance=Y[6:8],
        payload=np.broadcast_to(np.asarray(payload(t), dtype=float), t.shape).copy(),
        success=success,
        diverged=diverged,
        message=message,
        controller=controller,
        scenario=scenario,
    )


def _fast_run(
    controller: ct.NonlinearIOSystem,
    params: ScaraParams,
    payload: PayloadProfile,
    reference: Reference,
    wave: SquareWave,
    x_init: Array,
    t_final: float,
    dt: float,
    rtol: float,
    atol: float,
    limit: float,
    sample_time: float | None,
) -> tuple[Array, Array, Array, bool, bool, str]:
    from scipy.integrate import solve_ivp

    from .robot import forward_dynamics_scalar

    upd, out = controller.updfcn, controller.outfcn
    cparams = dict(controller.params)
    n_c = controller.nstates

    def torque(t: float, x: Array) -> Array:
        return np.asarray(out(t, x[4:], x[:4], cparams), dtype=float)

    def rhs(t: float, x: Array, tc: Array, td: Array) -> Array:
        # Freeze a run whose plant state left the box (as scara_plant does), so the
        # integrator does not crawl; the error limit is checked between segments.
        if not np.abs(x[:4]).max() <= STATE_LIMIT:
            return np.zeros_like(x)
        dx = np.empty_like(x)
        dx[:2] = x[2:4]
        dx[2:4] = forward_dynamics_scalar(params, x, tc[0] + td[0], tc[1] + td[1], float(payload(t)))
        if n_c:
            dx[4:] = upd(t, x[4:], x[:4], cparams)
        return dx

    success, diverged, message = True, False, "completed"
    if sample_time is not None:
        n = int(np.floor(t_final / sample_time + 1e-9))
        t = sample_time * np.arange(n + 1)
        X = np.empty((len(x_init), n + 1))
        X[:, 0] = x_init
        x = x_init.copy()
        h = sample_time
        for k in range(n):
            tk = t[k]
            tc = torque(tk, x)
            td = np.asarray(wave(tk + 0.5 * h), dtype=float)
            k1 = rhs(tk, x, tc, td)
            k2 = rhs(tk + h / 2, x + h / 2 * k1, tc, td)
            k3 = rhs(tk + h / 2, x + h / 2 * k2, tc, td)
            k4 = rhs(tk + h, x + h * k3, tc, td)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            X[:, k + 1] = x
            if _diverged(reference, t[k + 1], x, limit):
                success, diverged = False, True
                message = f"diverged by t = {t[k + 1]:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
                t, X = t[: k + 2], X[:, : k + 2]
                break
        tc_all = np.array([torque(ti, X[:, i]) for i, ti in enumerate(t)]).T
    else:
        t_out = _output_grid(t_final, dt)
        edges = np.concatenate([[0.0], wave.switching_times(0.0, t_final), [t_final]])
        pieces_t: list[Array] = []
        pieces_x: list[Array] = []
        x = x_init
        for a, b in zip(edges[:-1], edges[1:]):
            td = np.asarray(wave(0.5 * (a + b)), dtype=float)
            t_eval = np.union1d(t_out[(t_out >= a) & (t_out <= b)], [b])

            def segment_rhs(tt: float, xx: Array, td: Array = td) -> Array:
                return rhs(tt, xx, torque(tt, xx), td)

            sol = solve_ivp(segment_rhs, (a, b), x, method=FAST_SOLVER, t_eval=t_eval, rtol=rtol, atol=atol)
            if not sol.success:
                success, message = False, f"integrator failed at t = {a:.3f} s: {sol.message}"
                break
            x = sol.y[:, -1]
            keep = ~np.isin(sol.t, pieces_t[-1][-1:]) if pieces_t else np.ones(sol.t.size, dtype=bool)
            pieces_t.append(sol.t[keep])
            pieces_x.append(sol.y[:, keep])
            if _diverged(reference, b, x, limit):
                success, diverged = False, True
                message = f"diverged by t = {b:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
                break
        t = np.concatenate(pieces_t)
        X = np.concatenate(pieces_x, axis=1)
        on_grid = np.isin(t, t_out)
        t, X = t[on_grid], X[:, on_grid]
        tc_all = np.array([torque(ti, X[:, i]) for i, ti in enumerate(t)]).T
    td_all = np.asarray(wave(t), dtype=float)
    Y = np.vstack([X[:4], tc_all, td_all])
    t_arr, X_arr, Y_arr = (np.asarray(a, dtype=float) for a in (t, X, Y))
    return t_arr, X_arr, Y_arr, success, diverged, message


def run_scenario(
    controller: str,
    scenario: Scenario | str,
    *,
    payload_on: bool = True,
    t_final: float = 20.0,
    torque_limit: Any = None,
    params: ScaraParams | None = None,
    method: str = "fast",
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    disturbance: SquareWave | None = None,
    K: ArrayLike | None = None,
) -> SimulationResult:
    """Run a named controller on a scenario (the paper's signals unless given).

    Parameters
    ----------
    controller : {'pid', 'smc', 'smc-sign'}
    scenario : Scenario or {'large', 'small'}
    payload_on : bool
        False sets ``m_p = 0`` (the setting of Figures 4-5).
    t_final : float
        Horizon, s.
    torque_limit : float or array_like of shape (2,), optional
        Per-joint saturation, N·m.
    params : ScaraParams, optional
        The robot (default: the paper's); the sliding-mode law uses it without payload.
    method : {'fast', 'interconnect'}
    reference, payload, disturbance : optional
        Default: the paper's ``sin t, cos t``, ``0.3 m2 (sin t + 1)`` and ±5 N·m square waves.
    K : array_like, shape (2, 6), optional
        PID gain (default: designed at (3, 90) on the published model).

    Controllers in :data:`SAMPLE_TIMES` run sampled with that period (``smc-sign``: 1 ms).

    Returns
    -------
    SimulationResult
    """
    params = params or ScaraParams()
    reference = reference or paper_reference()
    options: dict[str, Any] = {"params": params, "reference": reference, "torque_limit": torque_limit}
    if K is not None and controller == "pid":
        options["K"] = K
    ctrl = make_controller(controller, **options)
    if payload_on:
        profile = payload if payload is not None else paper_payload(params)
    else:
        profile = ConstantPayload(0.0)
    return simulate(
        ctrl,
        scenario,
        params=params,
        payload=profile,
        reference=reference,
        disturbance=disturbance,
        t_final=t_final,
        method=method,
        sample_time=SAMPLE_TIMES.get(controller),
    )


def _cmd_simulate(args: argparse.Namespace) -> str:
    if args.t_final <= 0:
        raise ValueError(f"`--t-final` must be > 0 s, found {args.t_final}")
    if args.torque_limit is not None and args.torque_limit <= 0:
        raise ValueError(f"`--torque-limit` must be > 0 N·m, found {args.torque_limit}")
    from .cli import resolve_model, resolve_setup
    from .design import design

    setup = resolve_setup(args)
    K = design(resolve_model(args, setup), 3.0, 90.0).K if args.controller == "pid" else None
    initial = setup.initial or SCENARIOS["large"]
    res = run_scenario(
        args.controller,
        initial,
        payload_on=args.payload == "on",
        t_final=args.t_final,
        torque_limit=args.torque_limit,
        K=K,
        **setup.signals(),
    )
    if args.plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from .cli import write_atomic
        from .plotting import plot_response

        fig = plot_response(res)
        write_atomic(args.plot, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
        plt.close(fig)
    frame = res.to_pandas()
    if not res.success:
        raise ValueError(f"`--controller {args.controller}`: the run failed: {res.message}")
    if args.format == "json":
        return json.dumps(
            {
                "controller": args.controller,
                "scenario": initial.name,
                "payload": args.payload,
                # the metrics are taken after 6 s; a shorter run has none
                "metrics": res.metrics().to_dict() if (res.t >= 6.0).sum() >= 2 else None,
                "series": frame.to_dict(orient="list"),
            }
        )
    return str(frame.to_csv(index=False))


def add_simulate_parser(sub: Any) -> None:
    """Register ``simulate`` on the command line's sub-parsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    from .cli import _finite_float, add_setup_options

    p = sub.add_parser("simulate", help="one closed-loop run and its time series")
    p.add_argument("--controller", choices=tuple(CONTROLLERS), default="pid")
    add_setup_options(p)
    p.add_argument("--payload", choices=("on", "off"), default="on")
    p.add_argument("--t-final", type=_finite_float, default=20.0, help="horizon, s (> 0)")
    p.add_argument("--torque-limit", type=_finite_float, default=None, help="per-joint saturation, N·m (> 0)")
    p.add_argument("--format", choices=("csv", "json"), default="csv")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--plot", metavar="FILE.png", help="save a figure laid out like the paper's Figure 3")
    p.set_defaults(func=_cmd_simulate)
