"""``margin``: how much of its uncertainty set a design tolerates (lower and upper bounds)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

import pandas as pd

from ..lyapunov.gain import Design
from ..model.arm import effort_limited_payload
from ..model.plant import UncertainPlant, as_model
from ..model.uncertain import ANCHORS
from ..robustness.margins import MARGIN_TOL, margin_table, robustness_margin
from ..robustness.parameters import parameter_margin, rate_bracket
from ..robustness.registry import analysis_methods, get_method
from ._common import CommandLineError, add_range_option, add_setup_options, finite_float, method_names, resolve_gain
from ._parser import COMMAND_HELP
from ._schedule import is_schedule_file, run_schedule_margin
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``margin``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser(
        "margin",
        help=COMMAND_HELP["margin"],
    )
    p.add_argument("--rho", type=finite_float, help="design parameter rho > 0 (or --design)")
    p.add_argument("--eta", type=finite_float, help="design parameter eta >= 1 (or --design)")
    p.add_argument("--design", metavar="FILE.json",
                   help="the margins of your own gain instead: a design file with `K` on the plant's design form "
                   "(and optionally `P`, which Theorem 1 and the vertex test use; without it, P solves the nominal "
                   "loop's Lyapunov equation), or a ros2_control pid_controller file (.yaml: its per-joint p, i, d)")
    add_setup_options(p, scenario=None, model=True)
    p.add_argument("--elements", choices=("all", "A", "B"), default="all", help="elements scaled and varying")
    p.add_argument("--anchor", choices=ANCHORS, default="lower",
                   help="what theta scales the set about: the design plant at the lower corner, [theta*lower, "
                   "theta*upper] (the paper's convention, default), or the set's centre; with 'lower' the "
                   "centre-scaled vertex and frozen bounds are printed beside")
    names = analysis_methods("margin")
    p.add_argument("--method", type=_one_method, default="all", metavar="|".join(("all", *names)),
                   help="one registered method, or all of them and the bracket (default)")
    p.add_argument("--tol", type=finite_float, default=MARGIN_TOL, help=f"relative tolerance of the bisections "
                   f"(default {MARGIN_TOL:g})")
    p.add_argument("--tries", type=int, default=10, help="falsifier trajectories per try (default 10)")
    p.add_argument("--no-payload", action="store_true",
                   help="skip the physical margin: the robot's payload (kg), or a plant file's parameters in their "
                   "units")
    add_range_option(p, "analyze")
    p.add_argument("--rate", action="store_true",
                   help="also: how fast may the parameter vary (a plant file: its rate-bounded parameter, unit/s; the "
                   "robot: the payload, kg/s); a parameter-dependent Lyapunov certificate below, a growing periodic "
                   "variation above (extra lmi)")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.set_defaults(func=run)


def _one_method(text: str) -> str:
    """``--method``: 'all' or one registered margin method."""
    return text if text == "all" else method_names("margin", "--method")(text)[0]


def _number(value: Any) -> Any:
    return None if isinstance(value, float) and not math.isfinite(value) else value


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Compute the margins; the table to print.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    if not 0 < args.tol < 1:  # a relative width of 1 or more ends every bisection where it starts
        raise CommandLineError(f"`--tol` must be a relative tolerance in (0, 1), found {args.tol:g}")
    if args.tries < 1:
        raise CommandLineError(f"`--tries` must be an integer >= 1, found {args.tries}")
    if is_schedule_file(args.design):
        given = [o for o, v in (("--range", args.range), ("--rho", args.rho), ("--eta", args.eta)) if v]
        if given:
            raise CommandLineError(f"`{given[0]}` goes with a fixed gain; a schedule's margins are its rate, "
                                   "measurement error and decay (at the plant's rate bound and error)")
        return run_schedule_margin(args, system)
    plant = system.with_ranges(args.range)
    model = as_model("model", plant)
    d, label = resolve_gain(args, model, system.joint_names())
    if not system.capabilities.element_margins:
        return _margin_arm(args, system, system.require_physical("the arm has no physical parameters", plant), d, label)
    rated = None
    if args.rate:
        rated = system.require_physical("`--rate` needs a plant with physical parameters (a plant file with "
                                        "[parameters], or the robot); this file describes the set by elements or "
                                        "vertices", plant)
    if args.anchor == "center" and args.elements != "all":
        raise CommandLineError(f"`--anchor center` scales every element; it cannot go with --elements {args.elements}")
    if args.method == "all":
        table = margin_table(model, d, elements=args.elements, tol=args.tol, falsifier_tries=args.tries,
                             anchor=args.anchor, progress=sys.stderr.isatty())
    else:
        m = robustness_margin(model, d, args.method, elements=args.elements, tol=args.tol,
                              falsifier_tries=args.tries, anchor=args.anchor)
        table = pd.DataFrame([(m.method, m.bound, m.theta, *m.bracket, m.seconds, m.message)],
                             columns=["method", "kind", "theta", "lo", "hi", "seconds", "message"])
    table.insert(2, "anchor", args.anchor)
    beside = []
    if args.anchor == "lower" and args.elements == "all" and args.method == "all":
        beside = [robustness_margin(model, d, method, tol=args.tol, anchor="center") for method in ("vertex", "frozen")]
    payload = units = None
    if not args.no_payload:  # the robot's payload in kg, or a plant file's parameters in their units
        payload = system.payload_margin(d, tol=max(args.tol, 1e-3))
        units = system.unit_margin(plant, d, tol=max(args.tol, 1e-3))
    rate = rate_text = None
    if rated is not None:
        rate, rate_text = _rate(rated, d)
    source = system.source(model)
    if args.format == "json":
        rows = [{k: _number(v) for k, v in row.items()} for row in table.to_dict(orient="records")]
        rows += [{"method": f"{m.method}-center", "kind": m.bound, "anchor": "center", "theta": _number(m.theta),
                  "lo": _number(m.bracket[0]), "hi": _number(m.bracket[1]), "seconds": m.seconds,
                  "message": m.message} for m in beside]
        if payload is not None:
            rows += [{k: _number(v) for k, v in row.items()} for row in payload.to_dict(orient="records")]
        if units is not None:
            rows += [{"table": "parameters", **{k: _number(v) for k, v in row.items()}}
                     for row in units.to_dict(orient="records")]
        if rate is not None:
            rows.append({"table": "rate", **{k: _number(v) for k, v in rate.items()}})
        return json.dumps(rows, indent=2)
    meaning = ("every element range scaled about the design plant (lower corner), [theta*lower, theta*upper]"
               if args.anchor == "lower" else "every element range scaled about the box's centre, "
               "[c - theta*w/2, c + theta*w/2]")
    lines = [f"margins of {label}, {source}, elements: {args.elements}",
             f"theta (anchor {args.anchor}): {meaning}",
             table.drop(columns="message").to_string(index=False, float_format="%.6g"), "",
             *[f"  {row.method}: {row.message}" for row in table.itertuples()]]
    if beside:
        vertex, frozen = beside
        lines += ["", f"scaled about the set's centre instead (--anchor center): the vertex test certifies theta >= "
                      f"{vertex.theta:.6g}; a frozen vertex is unstable at theta = {frozen.theta:.6g}"]
    if payload is not None:
        lines += ["", "payload margin of the robot's own sampled set (peak mass of m_p = (M/2)(1 + sin t)):",
                  pd.DataFrame(payload).drop(columns="message").to_string(index=False, float_format="%.6g")]
    if units is not None:
        lines += ["", "margin in the plant's units: every parameter range scaled about its nominal by `scale` "
                      "(1 = the file's ranges), the range each method certifies:",
                  units.drop(columns="message").to_string(index=False, float_format="%.6g"),
                  *[f"  {row.method}: {row.message}" for row in units.itertuples()]]
    if rate_text is not None:
        lines += ["", rate_text]
    return "\n".join(lines)


def _margin_arm(args: argparse.Namespace, system: LoadedSystem, plant: UncertainPlant, d: Design, label: str) -> str:
    """``margin --robot F`` on an arm: the certified payload range in kg, and with ``--rate`` its rate in kg/s.

    The interval box of an arm has too many corners for the element margins; the payload
    range is scaled about the nominal payload with the reference time kept whole.
    """
    if args.method != "all" or args.elements != "all" or args.anchor != "lower":
        raise CommandLineError("`--method`, `--elements` and `--anchor` scale the elements of an interval box; an "
                               "arm's margin is its payload range (Theorem 1, the design's P and the LMI on its "
                               "samples, frozen)")
    # every registered default that applies: the box of an arm has too many corners for the vertex tests
    methods = [name for name in analysis_methods("parameter", defaults=True)
               if "vertices" not in get_method("parameter", name).needs]
    table = parameter_margin(plant, d, methods, tol=max(args.tol, 1e-3))
    rate = rate_text = None
    if args.rate:
        rate, rate_text = _rate(plant, d)
    m = plant.parameter("m_p")
    effort = effort_limited_payload(system.arm())
    if args.format == "json":
        rows = [{"table": "payload", **{k: _number(v) for k, v in row.items()}} for row in table.to_dict("records")]
        rows.append({"table": "effort", "mass [kg]": _number(effort.mass), "joint": effort.joint,
                     "t_ref [s]": _number(effort.t), "message": effort.message})
        if rate is not None:
            rows.append({"table": "rate", **{k: _number(v) for k, v in rate.items()}})
        return json.dumps(rows, indent=2)
    lines = [f"payload margin of {label} on {system.file!r}: the payload range "
             f"[{m.range[0]:g}, {m.range[1]:g}] kg scaled about the nominal {m.nominal:g} kg by `scale`, the "
             "reference time kept whole; the range each method certifies:",
             table.drop(columns=[c for c in table.columns if c.startswith("t_ref")] + ["message"]).to_string(
                 index=False, float_format="%.6g"),
             *[f"  {row.method}: {row.message}" for row in table.itertuples()],
             "", f"effort: {effort.message} (the torque that holds the reference, e = 0; the stability margin above "
                 "does not look at the limits)"]
    if rate_text is not None:
        lines += ["", rate_text]
    return "\n".join(lines)


def _rate(plant: UncertainPlant, d: Design) -> tuple[dict[str, Any], str]:
    """The rate answer of ``--rate``: its record and its text."""
    result = rate_bracket(plant, d)
    p = plant.parameter(result.parameter)
    unit = f"{p.unit}/s"
    record = {"parameter": p.name, f"certified rate [{unit}]": result.rate,
              f"growing at [{unit}]": result.unstable, "seconds": result.seconds, "message": result.message}
    where = f"rate of {p.name} over [{p.range[0]:.6g}, {p.range[1]:.6g}] {p.unit}"
    if math.isinf(result.rate):
        text = f"{where}: certified for any |d{p.name}/dt| (it may vary arbitrarily fast within the range)"
    elif math.isnan(result.rate):
        text = f"{where}: not certified, not even frozen with an affine P({p.name})"
    else:
        text = (f"{where}: certified for |d{p.name}/dt| <= {result.rate:.6g} {unit}"
                + (f"; a periodic variation at {result.unstable:.6g} {unit} grows" if math.isfinite(result.unstable)
                   else ""))
    text += f"\n  {result.message}"
    return record, text
