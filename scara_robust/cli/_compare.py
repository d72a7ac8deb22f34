"""``compare``: PID against sliding-mode control on both scenarios."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from ..controller.scheduled import ScheduledGain
from ..exceptions import ArgumentError
from ..lyapunov.gain import design
from ..model.initial import SCENARIOS
from ..model.plant import as_model
from ..paper import PAPER_DESIGN_POINT, PAPER_T_FINAL, PAPER_TRANSIENT
from ..robustness.synthesis import synthesize
from ..simulation.metrics import METRIC_NAMES
from ..studies.comparison import (
    ScheduleRun,
    arm_schedule_run,
    compare_controllers,
    compare_plant_designs,
    compare_schedules,
    plant_schedule_run,
    scara_schedule_run,
)
from ._arm_run import add_arm_run_options, arm_run_inputs, check_arm_options, compare_arm, refuse_arm_options
from ._common import CommandLineError, add_setup_options, finite_float, resolve_design
from ._options import given
from ._parser import COMMAND_HELP
from ._plant_run import add_plant_run_options, plant_profiles, run_inputs
from ._schedule import add_schedule_options, is_schedule_file, read_schedule, refuse_schedule_options
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``compare``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("compare", help=COMMAND_HELP["compare"])
    add_setup_options(p, model=True)
    p.add_argument("--rho", type=finite_float, default=None,
                   help=f"with --model: the Riccati PID's rho (default {PAPER_DESIGN_POINT[0]:g})")
    p.add_argument("--eta", type=finite_float, default=None,
                   help=f"with --model: the Riccati PID's eta (default {PAPER_DESIGN_POINT[1]:g})")
    p.add_argument("--no-synthesis", action="store_true",
                   help="with --model: leave out the synthesized PID (an LMI, extra lmi)")
    add_plant_run_options(p)
    add_schedule_options(p, synthesis=False)
    add_arm_run_options(p)
    p.add_argument("--design", metavar="FILE.json", action="append",
                   help="add rows for the PID gain of a design file (written by synthesize --output, or a ros2_control "
                   "pid_controller .yaml); repeatable. "
                   "A schedule file (synthesize --schedule --output) is compared instead with the best fixed gain of "
                   "its gain bound (synthesize's, or a second --design file's): certified range, decay, rate and "
                   "measurement error, runs with the payload (parameter) moving at the rate bound")
    p.add_argument("--format", choices=("text", "markdown", "csv", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--t-final", type=finite_float, default=PAPER_T_FINAL, help=f"horizon, s (> {PAPER_TRANSIENT:g})")
    p.add_argument("--payload", choices=("on", "off"), default=None, help="the robot's payload on (default) or off")
    p.add_argument("--tolerance", type=finite_float, default=None,
                   help="with --model: max |e| after t_final/2 for a run to count as tracking, in the outputs' units")
    p.add_argument("--progress", action="store_true", help="show a progress bar even when stderr is not a terminal")
    p.set_defaults(func=run)


def _has_tabulate() -> bool:
    try:
        import tabulate  # noqa: F401
    except ImportError:
        return False
    return True


def _markdown(table: pd.DataFrame) -> str:
    def fmt(v: Any) -> str:
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(table.columns) + " |", "|" + "---|" * len(table.columns)]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in table.itertuples(index=False)]
    return "\n".join(lines)


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Run the comparison; the table to print.

    The runs are the system's closed loop (:attr:`Capabilities.run`): the SCARA's
    controllers, or the designs for an arm or a plant file side by side.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    if args.t_final <= PAPER_TRANSIENT:
        raise CommandLineError(
            f"`--t-final` must be > {PAPER_TRANSIENT:g} s (metrics are taken after {PAPER_TRANSIENT:g} s), "
            f"found {args.t_final}"
        )
    if system.capabilities.run != "arm":
        refuse_arm_options(args, "the SCARA's runs start from --scenario's initial errors" if
                           system.capabilities.run == "scara" else "a plant file's runs start at rest")
    if any(is_schedule_file(path) for path in args.design or []):
        return _compare_schedule(args, system)
    refuse_schedule_options(args, "--design SCHEDULE.json")
    return _COMPARES[system.capabilities.run](args, system)


def _compare_scara(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``compare`` on the SCARA: PID against sliding-mode control on both scenarios."""
    plant_only = given(args, ("rho", "eta", "parameter", "disturbance", "tolerance"))
    plant_only += given(args, {"profile": "constant", "reference": "1", "no_synthesis": False})
    if plant_only:
        raise CommandLineError(f"`--{plant_only[0].replace('_', '-')}` describes the comparison for --model's plant")
    payload = args.payload or "on"
    setup = system.setup
    K = design(system.model, *PAPER_DESIGN_POINT).K
    scenarios = list(SCENARIOS) if setup.initial is None else [setup.initial]
    designs = {}
    for path in args.design or []:
        loaded = resolve_design(argparse.Namespace(design=path))
        assert loaded is not None
        designs[f"pid:{os.path.basename(path)}"] = loaded.K
    start = time.perf_counter()
    table = compare_controllers(
        scenarios=scenarios,
        payload_on=payload == "on",
        t_final=args.t_final,
        progress=sys.stderr.isatty() or args.progress,
        K=K,
        designs=designs,
        **setup.signals(),
    )
    elapsed = time.perf_counter() - start
    sys.stderr.write(f"compare: {len(table)} runs in {elapsed:.1f} s\n")
    if args.format == "json":
        keys = ["controller", "scenario", "payload", *METRIC_NAMES, "status", "status_reason"]
        return json.dumps(table[keys].to_dict(orient="records"), indent=2)
    if args.format == "csv":
        return str(table.to_csv(index=False))
    shown = table.drop(columns="status_reason")
    if args.format == "markdown":
        return shown.to_markdown(index=False, floatfmt=".4g") if _has_tabulate() else _markdown(shown)
    return str(shown.to_string(index=False, float_format="%.4g"))


def _compare_arm(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``compare --robot F`` on an arm: the designs side by side, with runs of the nonlinear arm."""
    rho = PAPER_DESIGN_POINT[0] if args.rho is None else args.rho
    eta = PAPER_DESIGN_POINT[1] if args.eta is None else args.eta
    if args.payload is not None:
        raise CommandLineError("`--payload` is the SCARA's; an arm's payload follows --profile")
    arm_table = compare_arm(args, system, rho, eta, None if args.t_final == PAPER_T_FINAL else args.t_final)
    if args.format == "json":
        return json.dumps(arm_table.to_dict(orient="records"), indent=2, default=str)
    if args.format == "csv":
        return str(arm_table.to_csv(index=False))
    head = (f"{system.file}: designs side by side on the arm; runs of the nonlinear arm, payload {args.profile}"
            f"{arm_table.attrs.get('inputs', '')}")
    return "\n".join([head, str(arm_table.T.to_string(header=False, float_format=lambda v: f"{v:.4g}")),
                      *arm_table.attrs.get("notes", [])])


def _compare_plant(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``compare --model F``: the Riccati PID, the synthesized PID and design files for the plant file."""
    if args.payload is not None:
        raise CommandLineError("`--payload` is the robot's; it cannot go with --model")
    plant = system.require_physical("`--model` must have [parameters] to be compared (runs need a plant to "
                                    "simulate)")
    model = as_model("model", plant)
    rho = PAPER_DESIGN_POINT[0] if args.rho is None else args.rho
    eta = PAPER_DESIGN_POINT[1] if args.eta is None else args.eta
    d = design(model, rho, eta)
    designs: dict[str, tuple[Any, Any]] = {f"riccati (rho={d.rho:g}, eta={d.eta:g})": (d.K, d.P)}
    notes = []
    if not args.no_synthesis:
        synth = synthesize(model)
        if synth.design is not None and synth.certified:
            designs["synthesized (LMI, decay)"] = (synth.design.K, synth.design.P)
        else:
            notes.append(f"synthesized PID left out: {synth.message}")
    n = plant.n_design_states
    for path in args.design or []:
        loaded = resolve_design(argparse.Namespace(design=path), (plant.n_inputs, n), "this plant's design form",
                                system.joint_names())
        assert loaded is not None
        designs[f"file {os.path.basename(path)}"] = (loaded.K, loaded.P)
    t_final = 20.0 if args.t_final == PAPER_T_FINAL else args.t_final
    name, profiles = plant_profiles(args, plant, t_final)
    reference, disturbance = run_inputs(args, plant)
    table = compare_plant_designs(plant, designs, profiles=profiles, reference=reference, disturbance=disturbance,
                                  t_final=t_final)
    if args.format == "json":
        return json.dumps(table.to_dict(orient="records"), indent=2, default=str)
    if args.format == "csv":
        return str(table.to_csv(index=False))
    if args.format == "markdown":
        return table.to_markdown(index=False, floatfmt=".4g") if _has_tabulate() else _markdown(table)
    head = f"{plant.name}: designs side by side; runs of {t_final:g} s, profile {args.profile}" + (
        f" of {name}" if name else "")
    return "\n".join([head, str(table.T.to_string(header=False, float_format=lambda v: f"{v:.4g}")), *notes])


def _schedule_runs(args: argparse.Namespace, system: LoadedSystem, t_final: float) -> tuple[ScheduleRun, str]:
    """How the schedule comparison runs each gain on this system, and what the runs are."""
    kind = system.capabilities.run
    if kind == "plant":
        return plant_schedule_run(system.require_physical(""), t_final), ""
    if args.profile != "constant" or args.parameter is not None:
        option = "--profile" if args.profile != "constant" else "--parameter"
        raise CommandLineError(f"`{option}`: a schedule is compared with the payload ramping and sweeping at its rate "
                               "bound (--rate)")
    if kind == "arm":
        check_arm_options(args, system)
        setup = system.arm()
        return arm_schedule_run(setup, t_final, **arm_run_inputs(args, setup)), " of the nonlinear arm"
    scenario = system.setup.initial or "small"
    name = scenario if isinstance(scenario, str) else scenario.name
    return (scara_schedule_run(scenario, t_final, **system.setup.signals()),
            f" of the nonlinear SCARA ({name} scenario)")


def _compare_schedule(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``compare --design SCHEDULE.json``: the schedule against the best fixed gain of the same bound.

    The fixed gain is a second ``--design`` file's, else ``synthesize``'s (the largest decay
    with ‖K‖ at most the schedule's gain bound, one Lyapunov matrix on the coarse samples,
    checked on the fine ones). Both get the same certificate (a P(p) following the parameter).
    """
    if args.payload is not None:
        raise CommandLineError("`--payload`: a schedule is compared with the payload moving at its rate bound")
    plant = system.require_physical("a scheduled gain needs a plant with named physical parameters (a plant file "
                                    "with [parameters], a robot); this file describes only the uncertainty set")
    paths = list(args.design or [])
    schedules = [path for path in paths if is_schedule_file(path)]
    others = [path for path in paths if path not in schedules]
    if len(schedules) != 1 or len(others) > 1:
        raise CommandLineError("`--design`: give one schedule file, and at most one design file as the fixed gain to "
                               "compare it with (default: the best fixed gain of the schedule's gain bound)")
    gain = read_schedule(schedules[0])
    shape = (plant.n_inputs, plant.n_design_states)
    if gain.parameter not in plant.names or gain.shape != shape:
        raise CommandLineError(f"`--design` {schedules[0]!r}: schedules {gain.parameter!r} with gains of shape "
                               f"{gain.shape}, not a gain of {plant.name!r} (its {shape})")
    t_final = 20.0 if args.t_final == PAPER_T_FINAL else args.t_final
    run, runs = _schedule_runs(args, system, t_final)
    bound = float(gain.certified.get("gain_bound", 0.0)) or float(np.ceil(gain.max_norm))
    notes: list[str] = []
    fixed_K: np.ndarray | None
    if others:
        loaded = resolve_design(argparse.Namespace(design=others[0]), shape, f"{plant.name}'s design form",
                                system.joint_names())
        assert loaded is not None
        fixed_K, fixed_name = loaded.K, f"fixed gain {os.path.basename(others[0])}"
    else:
        coarse, fine = plant.samples(plant.coarse_points()), plant.samples()
        best = synthesize((coarse.A, coarse.B), objective="decay", gain_bound=bound, check=(fine.A, fine.B))
        fixed_K, fixed_name = (best.K, f"best fixed gain (synthesize, ||K|| <= {bound:g})") \
            if best.K is not None and best.certified else (None, "")
        if fixed_K is None:
            notes.append(f"no fixed gain with ||K|| <= {bound:g} is certified: {best.message}")
    gains = {f"schedule {os.path.basename(schedules[0])}": gain}
    if fixed_K is not None:
        fixed = ScheduledGain(gain.parameter, gain.unit, gain.breakpoints,
                              np.stack([fixed_K] * gain.breakpoints.size), "fixed")
        gains = {fixed_name: fixed, **gains}
    try:
        table = compare_schedules(plant, gains, rate=args.schedule_rate, measurement_error=args.measurement_error,
                                  t_final=t_final, run=run)
    except ArgumentError as err:
        raise CommandLineError(f"`--design` {schedules[0]!r}: {err}") from err
    if args.format == "json":
        return json.dumps(table.reset_index().to_dict(orient="records"), indent=2, default=str)
    if args.format == "csv":
        return str(table.reset_index().to_csv(index=False))
    if args.format == "markdown":
        frame = table.reset_index()
        return frame.to_markdown(index=False, floatfmt=".4g") if _has_tabulate() else _markdown(frame)
    name = system.title() if system.capabilities.run == "scara" else plant.name
    head = (f"{name}: a gain scheduled on {gain.parameter} against a fixed gain; runs{runs} of {t_final:g} s with "
            f"{gain.parameter} moving at its rate bound")
    return "\n".join([head, str(table.T.to_string(float_format=lambda v: f"{v:.4g}")), *notes])


#: The comparison of each system's closed loop (:attr:`Capabilities.run`).
_COMPARES: dict[str, Callable[[argparse.Namespace, LoadedSystem], str]] = {
    "scara": _compare_scara, "arm": _compare_arm, "plant": _compare_plant}
