"""``synthesize``: a gain designed together with its Lyapunov certificate (LMI)."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

import numpy as np

from .._validation import os_error_text
from ..io import design_record, write_design
from ..lyapunov.gain import Design
from ..model.plant import as_model
from ..robustness.lmi import NOT_INSTALLED
from ..robustness.margins import robustness_margin
from ..robustness.payload import payload_margin
from ..robustness.sampled import check_sample_time
from ..robustness.sampled_synthesis import synthesize_sampled
from ..robustness.synthesis import GAIN_BOUND, L2_DECAY, OBJECTIVES, STRUCTURES, Synthesis, synthesize
from ._common import CommandLineError, add_range_option, add_setup_options, finite_float, per_joint_values
from ._parser import COMMAND_HELP
from ._schedule import add_schedule_options, refuse_schedule_options, run_schedule_synthesis
from ._system import LoadedSystem

__all__ = ["add_parser", "run", "PHYSICAL_GRID", "CHECK_GRID"]

#: (reference times over one period, payload masses) of the robot's physical set used by the synthesis.
PHYSICAL_GRID = (37, 5)
#: The finer, independent grid on which numpy re-verifies the answer (never seen by the solver).
CHECK_GRID = (361, 9)


def add_parser(sub: Any) -> None:
    """Register ``synthesize``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("synthesize", help=COMMAND_HELP["synthesize"])
    p.add_argument(
        "--set",
        dest="uncertainty_set",
        choices=("physical", "box"),
        default=None,
        help="the variation certified: the robot's own linearizations along the reference for every payload "
        "('physical', the default for the SCARA) or the corners of the interval model ('box', the only one with "
        "--model)",
    )
    add_setup_options(p, scenario="signals", model=True)
    add_range_option(p, "synthesize for")
    p.add_argument(
        "--objective",
        choices=(*OBJECTIVES, "rate"),
        default=None,
        help="'l2': smallest worst-case gain from a disturbance at the inputs (a torque on a robot) to the tracking "
        "error (default for PID-structured plants); 'decay': fastest certified decay; 'margin': largest scaling "
        "of the box one gain certifies; with --schedule, 'decay' (default) or 'rate': the fastest parameter "
        "certified at --decay (default 0)",
    )
    p.add_argument("--decay", type=finite_float, default=None,
                   help=f"decay rate α required of the state, 1/s, with dV/dt <= -2αV (>= 0; default: maximized, "
                   f"{L2_DECAY:g} for the l2 objective)")
    p.add_argument("--structure", choices=STRUCTURES, default="full",
                   help="'full': any gain (default); 'decentralized': one PID per joint, each torque from its own "
                   "joint's error only (what ros2_control's pid_controller runs; export --format ros2)")
    p.add_argument("--gain-bound", type=finite_float, default=GAIN_BOUND,
                   help=f"bound on ||K||_2 (default {GAIN_BOUND:g})")
    p.add_argument("--within-limits", action="store_true",
                   help="keep every input within the plant file's `limit` (of its [[inputs]]) from the initial errors "
                   "of --initial-error: constraints of the LMI, the answer re-verified with numpy")
    p.add_argument("--initial-error", type=per_joint_values, metavar="V,V,...",
                   help="with --within-limits: half-widths of the box of initial errors on the design state "
                   "(default: a unit step of each reference from rest, e(0) = 1 output unit)")
    add_schedule_options(p, synthesis=True)
    p.add_argument("--ts", type=finite_float, default=None, metavar="TS",
                   help="a gain certified at this sample time, s: u = -K x(t_k) held, found by an LMI on the "
                   "zero-order-hold plants and certified at TS (its own P verified by numpy, and the sampled-data "
                   "certificate's own); the PID discretized as export does is checked at TS too")
    p.add_argument("--format", choices=("text", "json"), default="text")
    # dest is not `output`: the design file goes there, the summary to stdout
    p.add_argument("--output", dest="design_output", metavar="FILE.json",
                   help="write a design file (read by simulate/compare --design) instead of printing JSON")
    p.set_defaults(func=run)


def _l2_unit(system: LoadedSystem) -> str:
    """The L2 gain's unit, tracking error per input disturbance (``rad/(N·m)`` for a robot, ``rad/A`` for a motor)."""
    signals = system.signal_names()
    outputs = {s.unit for s in signals.get("outputs", ())}
    inputs = {s.unit for s in signals.get("inputs", ())}
    if len(outputs) != 1 or len(inputs) != 1:
        return "(error unit)/(input unit)" if signals else "rad/(N·m)"
    out, inp = outputs.pop(), inputs.pop()
    return f"{out}/({inp})" if any(c in inp for c in "·*/ ") else f"{out}/{inp}"


def _text(result: Synthesis, what: str, margin: str, l2_unit: str) -> str:
    lines = [f"synthesize: {what}" + ("" if result.structure == "full" else f", structure {result.structure}"),
             f"status: {result.status} ({result.message})"]
    if result.K is None or result.design is None:
        return "\n".join(lines)
    # + 0.0: no "-0." where a structure puts exact zeros
    lines += ["K (u = -K x) =", np.array2string(result.K + 0.0, precision=4, suppress_small=True, max_line_width=120)]
    if result.design.n_joints is not None:
        for name, mat in zip(("K_I", "K_P", "K_D"), result.design.pid_matrices()):
            lines.append(f"{name} = " + np.array2string(mat + 0.0, precision=4, suppress_small=True,
                                                        max_line_width=120))
    lines.append(f"decay rate α (dV/dt <= -2αV): {result.decay:.4g} 1/s required, {result.verified_decay:.4g} 1/s "
                 "verified by numpy")
    if not math.isnan(result.check_decay):
        lines.append(f"independent check ({result.n_checked} samples): α >= {result.check_decay:.4g} 1/s")
    if result.search:
        lines.append(f"search: {result.search}")
    if result.objective == "l2":
        lines.append(f"worst-case L2 gain (input disturbance -> tracking error) <= {result.gamma:.4g} {l2_unit}")
    if result.objective == "margin":
        lines.append(f"certified scaling of the box: theta = {result.theta:.4g}")
    lines.append(f"||K||_2 = {result.gain_norm:.4g} (bound {result.gain_bound:g}); {result.seconds:.1f} s")
    lines.append(margin)
    return "\n".join(lines)


def _run_sampled(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``synthesize --ts TS``: a gain certified for the loop held at TS, on the sampled-data certificate's plants."""
    if args.ts <= 0:
        raise CommandLineError(f"`--ts` must be > 0 s, found {args.ts:g}")
    continuous = (("--objective", args.objective, None), ("--decay", args.decay, None),
                  ("--structure", args.structure, "full"), ("--within-limits", args.within_limits, False),
                  ("--range", args.range, None))
    changed = [o for o, v, d in continuous if v not in (d, [])]
    if changed:
        raise CommandLineError(f"`{changed[0]}` is an option of the continuous-time synthesis; --ts synthesizes the "
                               "held loop (full gain, fastest certified decay)")
    output = args.design_output
    if output is not None and not output.lower().endswith(".json"):
        raise CommandLineError(f"`--output` {output!r}: a design file is .json")
    plants, check, set_name = system.sampled()
    result = synthesize_sampled(plants, args.ts, check=check, gain_bound=args.gain_bound)
    lines = [f"synthesize at Ts = {args.ts:g} s on {set_name}", f"{result.verdict}: {result.message}"]
    info: dict[str, Any] = {"method": "synthesize --ts", "Ts": args.ts, "certified": result.certified,
                            "message": result.message, "decay_asked": result.decay,
                            "verified_decay": result.verified_rate if math.isfinite(result.verified_rate) else None,
                            "gain_norm": result.gain_norm if math.isfinite(result.gain_norm) else None}
    if result.K is not None:
        lines += ["K (u = -K x(t_k), held) =",
                  np.array2string(result.K + 0.0, precision=4, suppress_small=True, max_line_width=120)]
        if not system.state_feedback:  # the PID form: what export would run, checked at the same Ts
            d = Design.from_gain(system.model, result.K)
            pid = check_sample_time(plants, d.discretize(args.ts), check=check, set_name=set_name)
            lines.append(f"the PID of this gain discretized as export does (Tustin): {pid.message}")
            info["pid_certified"] = pid.certified
    if output is not None:
        if result.K is None or not result.certified:
            raise CommandLineError(f"`--output` {output!r} not written: {result.message}")
        try:
            write_design(output, result.K, None, **info)
        except OSError as err:
            raise CommandLineError(f"`--output` {output!r}: {os_error_text(err)}") from err
        lines.append(f"design file: {output}")
    elif args.format == "json":
        return json.dumps({**info, "K": None if result.K is None else result.K.tolist()}, indent=2)
    return "\n".join(lines)


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Synthesize; the text or JSON to print (or the design file written).

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    if args.gain_bound <= 0:
        raise CommandLineError(f"`--gain-bound` must be > 0, found {args.gain_bound:g}")
    if args.decay is not None and args.decay < 0:
        raise CommandLineError(f"`--decay` must be >= 0 1/s, found {args.decay:g}")
    if args.schedule is not None:
        if args.structure != "full":
            raise CommandLineError("`--structure` restricts a fixed PID gain; a schedule's gains are full")
        return run_schedule_synthesis(args, system)
    refuse_schedule_options(args, "--schedule NAME")
    if args.ts is not None:
        return _run_sampled(args, system)
    if args.objective == "rate":
        raise CommandLineError("`--objective rate` is the fastest parameter a scheduled gain is certified for; it "
                               "goes with --schedule NAME")
    output = args.design_output
    if output is not None and not output.lower().endswith(".json"):
        raise CommandLineError(f"`--output` {output!r}: a design file is .json")
    uncertainty_set = system.synthesis_set(args.uncertainty_set)
    if args.range and uncertainty_set != "box":
        raise CommandLineError("`--range` changes a parameter of a plant file (--model); it goes with --set box")
    model = as_model("model", system.with_ranges(args.range)) if uncertainty_set == "box" else None
    limits: dict[str, Any] = {}
    if args.within_limits:
        physical_plant = system.physical
        box = system.initial_errors(args.initial_error)
        if physical_plant is None or physical_plant.input_limits is None or box is None or model is None:
            raise CommandLineError("`--within-limits` needs a plant file in the PID form (or --initial-error) whose "
                                   "[[inputs]] give a `limit`, and --set box")
        limits = {"input_limits": physical_plant.input_limits, "initial_errors": box,
                  "inputs": physical_plant.inputs}
    elif args.initial_error is not None:
        raise CommandLineError("`--initial-error` goes with --within-limits")
    if uncertainty_set == "physical":  # the SCARA's physical set, or an arm's samples
        physical = system.physical_set(PHYSICAL_GRID, CHECK_GRID)
        objective = args.objective or physical.objective
        if objective == "margin":
            raise CommandLineError("`--objective margin` scales an interval box; it goes with --set box")
        result = synthesize(physical.plants, objective=objective, decay=args.decay, gain_bound=args.gain_bound,
                            check=physical.check, nominal=physical.nominal, structure=args.structure)
        what = f"{physical.description}, objective {objective}"
    else:
        assert model is not None
        structured = model.B.shape[0] == 3 * model.B.shape[1]
        objective = args.objective or ("l2" if structured else "decay")
        result = synthesize(model, objective=objective, decay=args.decay, gain_bound=args.gain_bound,
                            structure=args.structure, **limits)
        kind = model.kind
        what = f"the {kind} of {model.name}, objective {objective}"
    if result.status == NOT_INSTALLED:
        raise CommandLineError("synthesize needs cvxpy: pip install '.[lmi]'")
    margin = ""
    margin_value: dict[str, Any] = {}
    if result.design is not None and result.certified:
        if uncertainty_set == "physical" and result.K is not None and result.K.shape == (2, 6):
            setup = system.setup  # the SCARA's robot and reference (an arm's run on the paper's, as before)
            row = payload_margin(result.design, setup.params, setup.reference, methods=("payload-design-P",)).iloc[0]
            margin = (f"payload margin with this P: peak payload up to {row['mass [kg]']:.4g} kg certified "
                      f"(bracket {row['bracket [kg]']} kg)")
            margin_value = {"payload_margin_kg": float(row["mass [kg]"])}
        elif model is not None:
            m = robustness_margin(model, result.design, "vertex")
            margin = f"robustness margin with this P (vertex test): theta = {m.theta:.4g} ({m.message})"
            margin_value = {"margin_theta": m.theta}
    info: dict[str, Any] = {
        "method": "synthesize", "set": uncertainty_set, "objective": objective, "structure": args.structure,
        "status": result.status,
        "certified": result.certified, "message": result.message, "decay": result.decay,
        "verified_decay": result.verified_decay, "check_decay": result.check_decay, "gamma": result.gamma,
        "check_gamma": result.check_gamma, "theta": result.theta, "gain_norm": result.gain_norm,
        "gain_bound": result.gain_bound, "n_vertices": result.n_vertices, "n_checked": result.n_checked,
        "solver_status": result.solver_status, **margin_value,
    }
    if limits and result.input_limit is not None:
        info["input_limits"] = {"certified": result.input_limit.certified, "scale": result.input_limit.scale,
                                "limits": [float(v) for v in limits["input_limits"]],
                                "initial_errors": limits["initial_errors"].tolist(),
                                "message": result.input_limit.message}
    info = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in info.items()}
    if output is not None:  # the design file; main() prints the summary
        if result.K is None:
            raise CommandLineError(f"`--output` {output!r} not written: {result.message}")
        if not result.certified:  # a design file holds a certified gain; --format json shows the solver's answer
            raise CommandLineError(f"`--output` {output!r} not written: the gain is not certified ({result.message}); "
                                   "--format json prints it")
        try:
            write_design(output, result.K, result.P, **info)
        except OSError as err:
            raise CommandLineError(f"`--output` {output!r}: {os_error_text(err)}") from err
        return _text(result, what, margin, _l2_unit(system)) + f"\ndesign file: {output}"
    if args.format == "json":
        if result.K is None:
            return json.dumps(info, indent=2)
        return json.dumps(design_record(result.K, result.P, **info), indent=2)
    return _text(result, what, margin, _l2_unit(system))
