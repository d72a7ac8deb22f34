"""``design``: K from (ρ, η), certified by Theorem 1."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
import pandas as pd

from ..model.uncertain import ELEMENT_SETS
from ..workflow.design import design_answer
from ._common import CommandLineError, add_setup_options, finite_float, screen_table
from ._parser import COMMAND_HELP
from ._schedule import add_schedule_options, refuse_schedule_options, run_schedule_riccati
from ._system import LoadedSystem

__all__ = ["add_parser", "add_model_options", "run"]


def add_model_options(p: argparse.ArgumentParser) -> None:
    """``--robot``, ``--scenario``, ``--bounds`` and ``--elements``.

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    add_setup_options(p, scenario=None, model=True)  # the bounds come from the robot, never from a scenario
    p.add_argument("--elements", choices=ELEMENT_SETS, default="all", help="uncertain elements entering Theorem 1's Z")


def add_parser(sub: Any) -> None:
    """Register ``design``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("design", help=COMMAND_HELP["design"])
    p.add_argument("--rho", type=finite_float, required=True, help="design parameter rho > 0")
    p.add_argument("--eta", type=finite_float, required=True, help="design parameter eta >= 1")
    add_model_options(p)
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="json: a design file (for simulate --design, compare --design) with the certificate")
    p.add_argument("--output", help="write to this file instead of stdout (with --schedule: the schedule file, .json)")
    add_schedule_options(p, synthesis=True)
    p.set_defaults(func=run)


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Design and certify; the text or JSON to print.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    if args.schedule is not None:
        return run_schedule_riccati(args, system)
    refuse_schedule_options(args, "--schedule NAME")
    if args.format == "json" and args.output is not None and not args.output.lower().endswith(".json"):
        raise CommandLineError(f"`--output` {args.output!r}: --format json writes a design file, which --design "
                               "reads as .json")
    model = system.model
    answer = design_answer(system, args.rho, args.eta, args.elements)
    d, out = answer.design, answer.record
    source = system.source(model)
    lines = [
        f"design (rho, eta) = ({d.rho:g}, {d.eta:g}), {source}, elements: {args.elements}",
        "K (u = -K x) =",
        np.array2string(d.K, precision=4, suppress_small=True, max_line_width=120),
    ]
    if d.n_joints is not None:
        lines += [f"{name} = {np.array2string(np.array(out[name]), precision=4, suppress_small=True)}"
                  for name in ("K_I", "K_P", "K_D")] + ["(u = K_I ∫e + K_P e + K_D ė)"]
    lines.append(f"closed loop Hurwitz: {d.hurwitz} (largest real part {max(out['closed_loop_poles_real']):.4g} 1/s)")
    if not system.interval_elements:  # a polytope: the exact test at its vertices
        vertex = answer.certificate
        lines += [f"Theorem 1 needs interval elements; exact test over the {vertex.n_vertices} vertices: "
                  f"{vertex.message}"]
    else:
        lines += [
            f"max eig Z: {answer.certificate.max_eig:.6g}  ->  certified: {answer.certificate.certified}",
            "",
            "contributions of each element to Z:",
            screen_table(pd.DataFrame(out["contributions"]), args.output, index=False, float_format="%.4g"),
        ]
    if args.format == "json":  # a design file (load_design, simulate --design) that also holds the certificate
        return answer.file_text()
    return "\n".join(lines)
