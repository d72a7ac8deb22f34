"""``simulate``: one closed-loop run and its time series."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from .._validation import os_error_text
from ..exceptions import ArgumentError
from ..io import PID_CONTROLLER_METHOD
from ..lyapunov.gain import design
from ..model.initial import SCENARIOS
from ..model.robot import ConstantPayload, paper_payload
from ..paper import PAPER_DESIGN_POINT, PAPER_T_FINAL
from ..plotting import plot_plant_run, plot_response
from ..simulation.controllers import CONTROLLERS, scheduled_pid_controller
from ..simulation.engines import ENGINES
from ..simulation.metrics import METRIC_UNITS, TRACKING_TOLERANCE
from ..simulation.plants import PLANT_TRACKING_RTOL
from ..simulation.run import SimulationResult, run_scenario, simulate
from ..studies.campaign.inputs import replay_scenario
from ..studies.campaign.runner import read_results
from ._arm_run import add_arm_run_options, refuse_arm_options, run_arm
from ._common import (
    CommandLineError,
    add_design_option,
    add_setup_options,
    finite_float,
    per_joint_values,
    resolve_design,
    save_figure,
    write_text,
)
from ._options import given
from ._parser import COMMAND_HELP
from ._plant_run import add_plant_run_options, plant_gain, plant_run, series_output, summary
from ._schedule import is_schedule_file, read_schedule
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``simulate``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("simulate", help=COMMAND_HELP["simulate"])
    p.add_argument(
        "--controller",
        choices=tuple(CONTROLLERS),
        default=None,
        help="default pid; with --from-campaign, the table's first controller",
    )
    add_design_option(p)
    add_setup_options(p, model=True)
    p.add_argument("--rho", type=finite_float, default=None,
                   help="with --model: design parameter rho > 0 (or --design)")
    p.add_argument("--eta", type=finite_float, default=None, help="with --model: design parameter eta >= 1")
    add_plant_run_options(p)
    add_arm_run_options(p)
    p.add_argument("--ts", type=finite_float, default=None, metavar="S",
                   help="with --model: the gain sampled every S seconds and held (zero-order hold), u = -K x(t_k) on "
                   "the design form, the loop that certify --max-ts certifies (default: continuous)")
    p.add_argument("--x0", default=None, metavar="X[,X2,...]",
                   help="with --model: the plant's initial state, in its states' units (default: at rest, zero)")
    p.add_argument("--payload", choices=("on", "off"), default=None, help="payload m_p(t) on (default) or off")
    p.add_argument(
        "--t-final",
        type=finite_float,
        default=None,
        help=f"horizon, s (> 0; default {PAPER_T_FINAL:g}, or the campaign's with --from-campaign)",
    )
    p.add_argument(
        "--method",
        choices=tuple(ENGINES),
        default=None,
        help="integration engine (default: lsoda for continuous controllers, rk4 for sampled ones)",
    )
    p.add_argument(
        "--from-campaign",
        metavar="R.csv|R.parquet",
        help="replay one run of a campaign table from its stored inputs (with --index; the campaign's "
        "engine gives the row's metrics exactly)",
    )
    p.add_argument("--index", type=int, default=None, help="scenario index of the run to replay (--from-campaign)")
    p.add_argument("--torque-limit", type=per_joint_values, default=None, metavar="L[,L2,...]",
                   help="per-joint saturation, N·m (> 0): one value for all joints or one per joint")
    p.add_argument(
        "--tolerance",
        type=finite_float,
        default=None,
        help=f"max |e| after the transient for the run to count as tracking: rad for the robot (default "
        f"{TRACKING_TOLERANCE:g}), the outputs' units with --model (default {PLANT_TRACKING_RTOL:g} x the reference)",
    )
    p.add_argument(
        "--format",
        choices=("text", "csv", "json"),
        default="text",
        help="text: a summary (status, metrics, files); csv, json: the time series (json with status and metrics)",
    )
    p.add_argument(
        "--output",
        dest="series_output",
        metavar="FILE",
        help="write the time series to FILE (.json: JSON, otherwise CSV) instead of stdout",
    )
    p.add_argument("--plot", metavar="FILE",
                   help="save a figure laid out like the paper's Figure 3 (.png, .pdf or .svg)")
    p.set_defaults(func=run)


def _summary(res: SimulationResult, payload: str, files: list[str]) -> str:
    lines = [
        f"{res.controller} on scenario {res.scenario}, payload {payload}, "
        f"{'stopped at ' if res.status == 'failed' else ''}{res.t[-1]:g} s ({res.method})",
        f"status: {res.status} ({res.status_reason})",
    ]
    if res.has_metrics:
        lines += [f"  {name} = {value:.4g} {unit}"
                  for (name, value), unit in zip(res.metrics().to_dict().items(), METRIC_UNITS.values())]
    lines += files or ["time series: not written (use --output FILE or --format csv|json)"]
    return "\n".join(lines)


def _announce_compilation(method: str | None) -> None:
    """On a terminal, say why the first compiled run of a process waits."""
    if method == "compiled" and sys.stderr.isatty():
        sys.stderr.write("compiling the simulation kernels (once; about 30 s where numba has no cache yet)\n")
        sys.stderr.flush()


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Simulate; the summary, CSV or JSON to print.

    The closed loop is the system's (:attr:`Capabilities.run`): the SCARA's engine, the
    arm's or a plant file's.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    if args.t_final is not None and args.t_final <= 0:
        raise CommandLineError(f"`--t-final` must be > 0 s, found {args.t_final}")
    if args.torque_limit is not None:
        limit = args.torque_limit
        if min(limit) <= 0:
            raise CommandLineError(f"`--torque-limit` must be > 0 N·m, found {limit[0] if len(limit) == 1 else limit}")
    if args.tolerance is not None and args.tolerance <= 0:
        raise CommandLineError(f"`--tolerance` must be > 0, found {args.tolerance}")
    if system.capabilities.run != "arm":
        refuse_arm_options(args, _INITIAL[system.capabilities.run])
    return _RUNS[system.capabilities.run](args, system)


#: What gives the SCARA's and a plant file's runs their initial condition, for a refused ``--e0``.
_INITIAL = {"scara": "the SCARA's is --scenario (large, small, or a scenario file's [initial])",
            "plant": "a plant file's run starts from --x0 (its initial state)"}


def _run_scara(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``simulate`` on the SCARA: a run of its engine, or the replay of a campaign's run."""
    plant_only = given(args, ("rho", "eta"))
    plant_only += given(args, {"profile": "constant", "reference": "1"})
    plant_only += given(args, ("parameter", "disturbance", "ts", "x0"))
    if plant_only:
        raise CommandLineError(f"`--{plant_only[0]}` describes a run of --model's plant; the robot's runs take "
                               "--design, --scenario and --payload")
    tolerance = TRACKING_TOLERANCE if args.tolerance is None else args.tolerance
    loaded = None
    if args.from_campaign is not None:
        res, controller = _replay(args, system, tolerance)
        payload = "drawn"
    else:
        if args.index is not None:
            raise CommandLineError("`--index` picks a run of a campaign table; it goes with --from-campaign")
        controller = args.controller or "pid"
        payload = args.payload or "on"
        setup = system.setup
        if is_schedule_file(args.design):
            return _run_scara_schedule(args, system, controller, payload, tolerance)
        if args.measurement_bias is not None:
            raise CommandLineError("`--measurement-bias` is the error of a scheduled gain's measurement; it goes "
                                   "with --design SCHEDULE.json")
        loaded = resolve_design(args)
        pid_like = controller in ("pid", "pid-sampled")
        if loaded is not None and not pid_like:
            raise CommandLineError(
                f"`--design` is a PID gain; it goes with --controller pid or pid-sampled, found {controller!r}"
            )
        K: np.ndarray | None = None
        torque_limit = args.torque_limit
        if loaded is not None:
            K = loaded.K
            clamp = loaded.info.get("u_clamp") if loaded.info.get("method") == PID_CONTROLLER_METHOD else None
            if torque_limit is None and clamp is not None and all(math.isfinite(v) for v in clamp):
                torque_limit = list(clamp)  # a pid_controller file's output clamp, unless --torque-limit
        elif pid_like:
            K = design(system.model, *PAPER_DESIGN_POINT).K
        _announce_compilation(args.method)
        res = run_scenario(
            controller,
            setup.initial or SCENARIOS["large"],
            payload_on=payload == "on",
            t_final=PAPER_T_FINAL if args.t_final is None else args.t_final,
            torque_limit=torque_limit,
            method=args.method,
            K=K,
            tracking_tolerance=tolerance,
            **setup.signals(),
        )
    files = []
    if args.plot is not None:
        save_figure("--plot", args.plot, plot_response(res))
        files.append(f"figure: {args.plot}")
    as_json = args.format == "json" or (args.format == "text" and str(args.series_output).lower().endswith(".json"))
    if as_json:
        series = json.dumps(
            {
                "controller": controller,
                "scenario": res.scenario,
                "payload": payload,
                "status": res.status,
                "status_reason": res.status_reason,
                "method": res.method,
                # the metrics are taken after the transient; a shorter run has none (status too-short)
                "metrics": res.metrics().to_dict() if res.has_metrics else None,
                "series": res.to_pandas().to_dict(orient="list"),
            }
        )
    else:
        series = str(res.to_pandas().to_csv(index=False))
    if args.series_output is not None:
        write_text("--output", args.series_output, series)
        files.append(f"time series: {args.series_output}")
    elif args.format != "text":
        return series
    if loaded is not None:
        files.insert(0, f"gain: design file {loaded.path}")
        if len(files) == 1:
            files.append("time series: not written (use --output FILE or --format csv|json)")
    return _summary(res, payload, files) if args.format == "text" else ""


def _run_scara_schedule(args: argparse.Namespace, system: LoadedSystem, controller: str, payload: str,
                        tolerance: float) -> str:
    """``simulate --design SCHEDULE.json`` on the SCARA: the PID with K(m̂_p), m̂_p = m_p(t) + --measurement-bias."""
    if controller != "pid":
        raise CommandLineError(f"`--design` SCHEDULE.json is a scheduled PID; it goes with --controller pid, found "
                               f"{controller!r}")
    gain = read_schedule(args.design)
    if gain.parameter != "m_p" or gain.shape != (2, 6):
        raise CommandLineError(f"`--design` {args.design!r}: schedules {gain.parameter!r} with gains of shape "
                               f"{gain.shape}; the SCARA's PID is scheduled on m_p with (2, 6) gains")
    setup = system.setup
    profile = (setup.payload or paper_payload(setup.params)) if payload == "on" else ConstantPayload(0.0)
    bias = 0.0 if args.measurement_bias is None else args.measurement_bias
    _announce_compilation(args.method)
    try:
        pid = scheduled_pid_controller(gain, profile, setup.reference, measurement_bias=bias,
                                       torque_limit=args.torque_limit)
    except ArgumentError as err:
        raise CommandLineError(f"`--{err.argument.replace('_', '-')}` {err.problem}") from err
    res = simulate(pid, setup.initial or SCENARIOS["large"], params=setup.params, payload=profile,
                   reference=setup.reference, disturbance=setup.disturbance, method=args.method,
                   t_final=PAPER_T_FINAL if args.t_final is None else args.t_final, tracking_tolerance=tolerance)
    files = []
    if args.plot is not None:
        save_figure("--plot", args.plot, plot_response(res))
        files.append(f"figure: {args.plot}")
    text, written = series_output(args, res.to_pandas(), {
        "controller": "pid-scheduled", "scenario": res.scenario, "payload": payload, "measurement_bias": bias,
        "status": res.status, "status_reason": res.status_reason, "method": res.method,
        "metrics": res.metrics().to_dict() if res.has_metrics else None})
    if text is not None:
        return text
    files = [f"gain: schedule file {args.design} (m_p measured {bias:+g} kg off)", *files,
             written or "time series: not written (use --output FILE or --format csv|json)"]
    return _summary(res, payload, files)


#: Options that describe a run's inputs beside the robot's; a replayed run takes them from its campaign table.
_INPUT_OPTIONS = ("design", "payload", "torque_limit", "measurement_bias")


def _replay(args: argparse.Namespace, system: LoadedSystem, tolerance: float) -> tuple[SimulationResult, str | None]:
    """The run of ``--from-campaign`` at ``--index``, from the inputs stored in its row, and its controller."""
    refused = [option for option, _ in system.options("robot", "scenario", "bounds")]
    refused += [f"--{name.replace('_', '-')}" for name in given(args, _INPUT_OPTIONS)]
    if refused:
        raise CommandLineError(
            f"`--from-campaign` replays a run from the inputs in its table; {', '.join(refused)} cannot go with it"
        )
    if args.index is None:
        raise CommandLineError("`--index` is needed with --from-campaign: the scenario index of the run to replay")
    path = args.from_campaign
    try:
        results = read_results(path)
    except OSError as err:
        raise CommandLineError(f"`--from-campaign` {path!r}: {os_error_text(err)}") from err
    except ArgumentError as err:
        raise CommandLineError(f"`--from-campaign` {err.problem}") from err
    rows = results[results["scenario"] == args.index]
    controller = args.controller
    if controller is None and len(rows):
        controller = str(rows["controller"].iloc[0])  # the default of replay_scenario, named for the output
    try:
        res = replay_scenario(
            results,
            args.index,
            controller,
            method=args.method,
            t_final=args.t_final,
            tracking_tolerance=tolerance,
        )
    except ArgumentError as err:
        if err.argument != "results":
            raise
        raise CommandLineError(f"`--from-campaign` {path!r} {err.problem}") from err
    return res, controller


def _run_plant(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``simulate --model F``: the plant file's closed loop under the chosen parameter profile."""
    robot_only = given(args, ("controller", "from_campaign", "index", "payload", "method", "torque_limit"))
    if robot_only:
        raise CommandLineError(f"`--{robot_only[0].replace('_', '-')}` is an option of the robot's runs; it cannot go "
                               "with --model")
    plant = system.require_physical("`--model` must have [parameters] to be simulated (a plant file with physical "
                                    "parameters); this file describes only the uncertainty set")
    K, gain = plant_gain(args, plant, "this plant's design form")
    t_final = 20.0 if args.t_final is None else args.t_final
    run_ = plant_run(args, plant, K, t_final)
    files = []
    if args.plot is not None:
        save_figure("--plot", args.plot, plot_plant_run(run_, plant))
        files.append(f"figure: {args.plot}")
    text, written = series_output(args, run_.to_pandas(), {"plant": plant.name, "status": run_.status,
                                                           "status_reason": run_.reason,
                                                           "max_abs_error": None if np.isnan(run_.max_abs_error)
                                                           else run_.max_abs_error})
    if text is not None:
        return text
    files += [written] if written else []
    sampling = "" if args.ts is None else f", sampled every {args.ts:g} s (u = -K x(t_k) held)"
    head = f"{plant.name}, {gain}{sampling}, {t_final:g} s, profile {args.profile}"
    return "\n".join([*summary(run_, plant, head),
                      *(files or ["time series: not written (use --output FILE or --format csv|json)"])])


#: The run of each system's closed loop (:attr:`Capabilities.run`).
_RUNS: dict[str, Callable[[argparse.Namespace, LoadedSystem], str]] = {
    "scara": _run_scara, "arm": run_arm, "plant": _run_plant}
