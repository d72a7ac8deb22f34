"""``tune``: a PID tuned to stated tracking requirements, certified, run on the robot, beside the paper's gain."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

import numpy as np

from .._validation import os_error_text
from ..exceptions import ArgumentValueError
from ..io import file_requirements, write_design
from ..lyapunov.gain import design
from ..model.scara import paper_model
from ..paper import PAPER_DESIGN_POINT, PAPER_TRANSIENT
from ..plotting import plot_loop_views
from ..simulation.metrics import TRACKING_TOLERANCE
from ..workflow.system import load_input
from ..workflow.tune import Requirements, TuneReport, torque_limits, tune_system, worst_loop_views
from ._common import CommandLineError, add_setup_options, finite_float, save_figure
from ._parser import COMMAND_HELP
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]

#: The largest ‖K‖₂ the search goes to unless told (N·m/rad).
MAX_GAIN = 1e4


def add_parser(sub: Any) -> None:
    """Register ``tune``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("tune", help=COMMAND_HELP["tune"])
    add_setup_options(p, bounds=False, scenario="signals")
    p.add_argument("--error", type=finite_float, default=None, metavar="RAD",
                   help=f"largest tracking error allowed after the settling time, rad, per joint (default: the robot "
                        f"file's [requirements] error, else {TRACKING_TOLERANCE:g}); every requirement below also "
                        "comes from that table unless given here")
    p.add_argument("--settling-time", type=finite_float, default=None, metavar="S",
                   help=f"time after which the error must stay within --error, s (default {PAPER_TRANSIENT:g})")
    p.add_argument("--ts", type=finite_float, default=None, metavar="S",
                   help="the controller's sample time, s: the tuned PID discretized as export does must be "
                        "certified there, and the runs use it")
    p.add_argument("--disturbance", type=finite_float, default=None, metavar="NM",
                   help="bound on each joint's disturbance torque, N·m (default: the scenario's amplitude, 5, on "
                        "the SCARA; an arm's robot file's [disturbance])")
    p.add_argument("--torque-limit", type=finite_float, default=None, metavar="NM",
                   help="largest control torque allowed, N·m: the certified peak must stay below it")
    p.add_argument("--disk-margin", type=finite_float, default=None, metavar="ALPHA",
                   help="smallest symmetric disk margin of every loop over the frozen plants")
    p.add_argument("--delay-margin", type=finite_float, default=None, metavar="S",
                   help="smallest delay margin of every loop over the frozen plants, s")
    p.add_argument("--decay", type=finite_float, default=None, metavar="RATE",
                   help="smallest certified decay rate, 1/s")
    p.add_argument("--max-gain", type=finite_float, default=MAX_GAIN, metavar="NM_PER_RAD",
                   help=f"the largest ||K||_2 searched, N·m/rad (default {MAX_GAIN:g})")
    p.add_argument("--plot", metavar="FILE.png",
                   help="each loop's step response and Bode plot at its worst frozen plant, for every gain, with the "
                        "disk and delay margins (.png, .pdf or .svg)")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--output", dest="design_output", metavar="FILE.json",
                   help="write the tuned gain's design file (read by simulate/compare/export --design)")
    p.set_defaults(func=run)


def requirements_of(args: argparse.Namespace, file: str | None = None) -> Requirements:
    """The :class:`~scara_robust.Requirements` of the robot file's ``[requirements]`` and the options over them.

    Parameters
    ----------
    args : argparse.Namespace
    file : str, optional
        The robot file (its ``[requirements]`` table, checked with the file and field named).

    Returns
    -------
    Requirements
    """
    given: dict[str, Any] = {}
    if file is not None:
        given = load_input("--robot", file, file_requirements)
        try:
            Requirements(**given)
        except ArgumentValueError as err:
            raise CommandLineError(f"{file!r}: field `requirements.{err.argument}` {err.problem}") from err
    options = {"error": args.error, "settling_time": args.settling_time, "sample_time": args.ts,
               "disturbance": args.disturbance, "torque_limit": args.torque_limit, "disk_margin": args.disk_margin,
               "delay_margin": args.delay_margin, "decay": args.decay}
    if args.error is not None and args.error <= 0:
        raise CommandLineError(f"`--error` must be > 0 rad, found {args.error:g}")
    if args.error is not None and args.error > 3.2:
        raise CommandLineError(f"`--error` is in rad, found {args.error:g} (degrees? divide by 57.3)")
    if args.settling_time is not None and args.settling_time < 0:
        raise CommandLineError(f"`--settling-time` must be >= 0 s, found {args.settling_time:g}")
    positive = (("--ts", args.ts, " s"), ("--torque-limit", args.torque_limit, " N·m"),
                ("--disk-margin", args.disk_margin, ""), ("--delay-margin", args.delay_margin, " s"),
                ("--decay", args.decay, " 1/s"))
    for name, value, unit in positive:
        if value is not None and value <= 0:
            raise CommandLineError(f"`{name}` must be > 0{unit}, found {value:g}")
    if args.disturbance is not None and args.disturbance < 0:
        raise CommandLineError(f"`--disturbance` must be >= 0 N·m, found {args.disturbance:g}")
    if args.max_gain <= 1:
        raise CommandLineError(f"`--max-gain` must be > 1 N·m/rad, found {args.max_gain:g}")
    merged = {**given, **{k: v for k, v in options.items() if v is not None}}
    if merged.get("disk_margin") is not None and merged["disk_margin"] >= 2:
        raise CommandLineError(f"`--disk-margin` must be below 2 (a symmetric disk margin of 2 is an infinite "
                               f"gain margin), found {merged['disk_margin']:g}")
    ts, settle = merged.get("sample_time"), merged.get("settling_time", PAPER_TRANSIENT)
    if ts is not None and ts >= settle > 0:
        raise CommandLineError(f"`--ts` {ts:g} s is not below `--settling-time` {settle:g} s: the loop cannot "
                               "settle within one sample")
    return Requirements(**merged)


def _number(value: float) -> str:
    return "inf" if value == math.inf else f"{value:.4g}"


def _text(report: TuneReport, effort: np.ndarray | None = None) -> str:
    tuning = report.tuning
    rows = [text for _, text in report.requirements.rows()]
    if effort is not None:
        rows.append(f"|T| <= the effort limits {np.array2string(effort, precision=4)} N·m, joint by joint")
    lines = ["tune: the smallest gain whose certified tracking-error bound meets the requirements",
             "requirements: " + "; ".join(rows),
             f"samples: {report.samples}",
             f"{tuning.verdict}: {tuning.message}"]
    if report.design is not None:
        lines += ["K (u = -K x) =", np.array2string(report.design.K + 0.0, precision=4, suppress_small=True,
                                                     max_line_width=120)]
        for name, mat in zip(("K_I", "K_P", "K_D"), report.design.pid_matrices()):
            lines.append(f"{name} = " + np.array2string(mat + 0.0, precision=4, suppress_small=True,
                                                        max_line_width=120))
    lines.append(f"search: {tuning.search}")
    lines.append("")
    for g in report.gains:
        sims = ", ".join(f"{k} {_number(v)}" for k, v in g.simulated.items())
        lines.append(f"{g.name}: ||K||_2 = {np.linalg.norm(g.K, 2):.4g} N·m/rad")
        lines.append(f"  |e| after {report.requirements.settling_time:g} s: certified <= {_number(g.bound.worst)} rad, "
                     f"simulated {sims} rad")
        if g.search is not None:
            lines.append(f"  largest |e| after {report.requirements.settling_time:g} s over {g.search.runs} payload "
                         f"and disturbance profiles ({g.search.failed} failed): {_number(g.search.worst)} rad "
                         f"({g.search.profile})")
        lines.append(f"  peak torque: certified <= {_number(g.certified_torque)} N·m, simulated "
                     f"{_number(g.simulated_torque)} N·m")
        if g.torque_limits is not None and g.certified_torques is not None and g.torque_limits.size > 1:
            lines.append(f"  certified peak torque of each joint {np.array2string(g.certified_torques, precision=4)} "
                         f"N·m against {np.array2string(g.torque_limits, precision=4)} N·m")
        if g.sampled is not None:
            lines.append(f"  sampled-data certificate at Ts = {report.requirements.sample_time:g} s: "
                         + ("certified" if g.sampled else "NOT certified"))
        lines.append(f"  disk margin {g.disk_margin:.3g}, delay margin {_number(g.delay_margin)} s, certified decay "
                     f"{g.decay:.3g} 1/s")
        lines.append("  meets every requirement" if not g.failed else "  does NOT meet: " + ", ".join(g.failed))
    lines.append(f"{report.seconds:.1f} s")
    return "\n".join(lines)


def _json(report: TuneReport) -> str:
    def clean(v: float) -> float | None:
        return None if not math.isfinite(v) else float(v)

    return json.dumps({
        "requirements": dict(report.requirements.rows()),
        "verdict": report.tuning.verdict, "message": report.tuning.message, "binding": report.tuning.binding,
        "best_reachable [rad]": clean(report.tuning.best_reachable),
        "torque_limit_scale_needed": clean(report.tuning.input_scale),
        "gains": [{"name": g.name, "K": g.K.tolist(), "certified_error [rad]": clean(g.bound.worst),
                   "simulated_error [rad]": {k: clean(v) for k, v in g.simulated.items()},
                   "certified_torque [N·m]": clean(g.certified_torque),
                   "simulated_torque [N·m]": clean(g.simulated_torque), "sampled_certified": g.sampled,
                   "searched_error [rad]": None if g.search is None else clean(g.search.worst),
                   "searched_profile": None if g.search is None else g.search.profile,
                   "disk_margin": clean(g.disk_margin), "delay_margin [s]": clean(g.delay_margin),
                   "decay [1/s]": clean(g.decay), "failed": list(g.failed)} for g in report.gains],
    }, indent=2)


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Tune; the text or JSON to print (and the design file written).

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    requirements = requirements_of(args, system.file)
    output = args.design_output
    if output is not None and not output.lower().endswith(".json"):
        raise CommandLineError(f"`--output` {output!r}: a design file is .json")
    rho, eta = PAPER_DESIGN_POINT
    others = {} if system.file is not None else {f"paper (rho, eta) = ({rho:g}, {eta:g})":
                                                 design(paper_model(), rho, eta).K}
    report = tune_system(system, requirements, others=others, kappa_range=(1.0, args.max_gain))
    effort = torque_limits(system, requirements) if requirements.torque_limit is None else None
    text = _json(report) if args.format == "json" else _text(report, effort)
    if args.plot is not None:
        if not report.gains:
            print(text, flush=True)
            raise CommandLineError(f"`--plot` {args.plot!r} not drawn: no gain to draw ({report.tuning.message})")
        views = {g.name: worst_loop_views(system, g.K, t_final=requirements.settling_time) for g in report.gains}
        margins = {g.name: system.loop_margins(g.K) for g in report.gains}
        save_figure("--plot", args.plot, plot_loop_views(views, margins=margins, title=f"{system.title()}: each loop "
                                                             "at its worst frozen plant (smallest delay margin)"))
        text += f"\nfigure: {args.plot}"
    if output is not None:
        tuned = report.gains[0] if report.gains and report.gains[0].name == "tuned" else None
        if tuned is None or tuned.failed or report.design is None:
            print(text, flush=True)  # the table is the answer: printed, then the file refused in one line
            raise CommandLineError(f"`--output` {output!r} not written: {report.tuning.message}")
        try:
            write_design(output, report.design.K, report.tuning.P, method="tune",
                         requirements=dict(requirements.rows()),
                         certified_error=tuned.bound.worst, simulated_error=tuned.simulated)
        except OSError as err:
            raise CommandLineError(f"`--output` {output!r}: {os_error_text(err)}") from err
        text += f"\ndesign file: {output}"
    return text
