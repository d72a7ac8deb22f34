"""``certify``: every certificate of one design (Theorem 1, vertex, physical, LMI, falsifier)."""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from ..robustness.sampled import max_sample_time
from ..robustness.table import certificate_table
from ._common import (
    CommandLineError,
    UnstableGainError,
    add_setup_options,
    finite_float,
    method_names,
    per_joint_values,
    resolve_gain,
)
from ._parser import COMMAND_HELP
from ._schedule import add_schedule_options, is_schedule_file, refuse_schedule_options, run_schedule_certificate
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``certify``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("certify", help=COMMAND_HELP["certify"])
    p.add_argument("--rho", type=finite_float, help="design parameter rho > 0 (or --design)")
    p.add_argument("--eta", type=finite_float, help="design parameter eta >= 1 (or --design)")
    p.add_argument("--design", metavar="FILE.json",
                   help="certify your own gain instead: a design file with `K` on the plant's design form (and "
                   "optionally `P`; without it, P solves the nominal loop's Lyapunov equation), or a schedule file "
                   "of synthesize --schedule (its certificate for a moving, mis-measured parameter), or a ros2_control "
                   "pid_controller file (.yaml: its per-joint p, i, d, matched to the joints by name)")
    add_setup_options(p, scenario="signals", model=True)
    p.add_argument("--methods", type=method_names("certificate", "--methods", many=True), metavar="NAME[,NAME...]",
                   help="the rows to run, by registered name (default: every default row; e.g. 'l2-rate-bounded', "
                   "the worst-case L2 gain for a rate-bounded parameter, runs only when named)")
    p.add_argument("--tries", type=int, default=30, help="falsifier trajectories per set (default 30)")
    p.add_argument("--seed", type=int, default=0, help="falsifier seed")
    p.add_argument("--max-ts", action="store_true",
                   help="also: the largest sample time the sampled-data certificate holds at (a PID discretized as "
                   "export does: Tustin integral, measured derivative; a gain on a plant file's state or integral "
                   "form: u = -K x(t_k) held), and the smallest at which a frozen plant is unstable (extra lmi)")
    p.add_argument("--initial-error", type=per_joint_values, metavar="V,V,...",
                   help="half-widths of the box of initial errors on the design state (x = [∫e, e, ė] for a PID) for "
                   "which the plant file's input limits are certified (default: a unit step of each reference from "
                   "rest, e(0) = 1 output unit)")
    add_schedule_options(p, synthesis=False)
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.set_defaults(func=run)


def _json_value(value: Any) -> Any:
    if isinstance(value, (float, np.floating)) and not np.isfinite(value):
        return None
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Run the certificate table; the text or JSON to print.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    if args.tries < 1:
        raise CommandLineError(f"`--tries` must be an integer >= 1, found {args.tries}")
    if is_schedule_file(args.design):
        return run_schedule_certificate(args, system)
    refuse_schedule_options(args, "--design SCHEDULE.json")
    model = system.model
    try:
        d, label = resolve_gain(args, model, system.joint_names())
    except UnstableGainError as err:  # an answer, not bad input: no certificate can hold
        detail = (f"not certified: the gain's nominal closed loop is unstable (eigenvalue {err.eigenvalue:.4g} 1/s), "
                  "so no Lyapunov function exists and no method can certify it")
        if args.format == "json":
            return json.dumps([{"method": "nominal-loop", "verdict": "not certified", "certified": False,
                                "detail": detail}], indent=2)
        return f"certificates of the gain of {args.design!r}, model: {model.name}\n{detail}"
    table = certificate_table(model, d, plant=system.physical, falsifier_tries=args.tries, seed=args.seed,
                              methods=args.methods)
    decay = system.decay_rate(d)
    loops = system.loop_margins(d)
    limit_box = system.initial_errors(args.initial_error)
    within = system.input_limit(d, decay, limit_box)
    limits = [] if limit_box is None else [
        "input limits: " + (within.message if within is not None else
                            "no certified Lyapunov function, so no certified bound on the inputs")
        + f" (initial errors: the box of half-widths {np.round(limit_box, 6).tolist()} on the design state)"]
    # the headline: the sampled-data certificate at the file's controller Ts, else the largest certified Ts
    headline, head_record = system.sampled_headline(d.K if system.state_feedback else d)
    limit = None
    if args.max_ts and head_record["method"] == "sampled-at-ts":
        plants, check, set_name = system.sampled()
        # a state-form plant's gain: u = −K x(t_k) held, on the design form
        limit = max_sample_time(plants, d.K if system.state_feedback else d, check=check, rtol=1e-3)
    if args.format == "json":
        records = [{k: _json_value(v) for k, v in head_record.items()}]
        records += [{k: _json_value(v) for k, v in row.items()} for row in table.to_dict(orient="records")]
        records.append({"method": "decay-rate", "verdict": decay.verdict, "certified": decay.certified,
                        "decay_rate [1/s]": _json_value(decay.rate), "from": decay.source, "set": decay.set_name,
                        "detail": decay.message})
        records += [{"method": "loop-margins", "verdict": loops.verdict, "certified": loops.certified,
                     **{k: _json_value(v) for k, v in row.items()}, "detail": loops.message}
                    for row in loops.to_pandas().to_dict(orient="records")]
        if limit_box is not None:
            records.append({"method": "input-limits", "verdict": within.verdict if within else "not certified",
                            "certified": bool(within is not None and within.certified),
                            "scale": _json_value(within.scale) if within else None,
                            "initial_errors": limit_box.tolist(), "detail": limits[0]})
        if limit is not None:
            records.append({"method": "max-ts", "verdict": limit.verdict, "certified": limit.certified,
                            "certified_ts [s]": _json_value(limit.certified_ts),
                            "unstable_ts [s]": _json_value(limit.unstable_ts), "detail": limit.message})
        return json.dumps(records, indent=2)
    header = f"certificates of {label}, {system.source(model)}"
    shown = table.drop(columns="detail").assign(
        certified=table["certified"].map({True: "yes", False: "no", None: "-"})
    )
    details = [f"  {row.method}: {row.detail}" for row in table.itertuples()]
    sampled = [] if limit is None else ["", f"sample time on {set_name}: {limit.message}"]
    return "\n".join([headline, header, shown.to_string(index=False, float_format="%.4g"), "", "details:", *details,
                      "", decay.message, f"loop margins: {loops.message}", *limits, *sampled])
