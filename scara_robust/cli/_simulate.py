"""``simulate``: one closed-loop run and its time series."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ..lyapunov.gain import design
from ..model.initial import SCENARIOS
from ..paper import PAPER_DESIGN_POINT, PAPER_T_FINAL, PAPER_TRANSIENT
from ..plotting import plot_response
from ..simulation.controllers import CONTROLLERS
from ..simulation.run import run_scenario
from ._common import CommandLineError, add_setup_options, finite_float, resolve_model, resolve_setup, save_figure

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``simulate``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("simulate", help="one closed-loop run and its time series")
    p.add_argument("--controller", choices=tuple(CONTROLLERS), default="pid")
    add_setup_options(p)
    p.add_argument("--payload", choices=("on", "off"), default="on")
    p.add_argument("--t-final", type=finite_float, default=PAPER_T_FINAL, help="horizon, s (> 0)")
    p.add_argument("--torque-limit", type=finite_float, default=None, help="per-joint saturation, N·m (> 0)")
    p.add_argument("--format", choices=("csv", "json"), default="csv")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--plot", metavar="FILE.png", help="save a figure laid out like the paper's Figure 3")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> str:
    """Simulate; the CSV or JSON to print.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    str
    """
    if args.t_final <= 0:
        raise CommandLineError(f"`--t-final` must be > 0 s, found {args.t_final}")
    if args.torque_limit is not None and args.torque_limit <= 0:
        raise CommandLineError(f"`--torque-limit` must be > 0 N·m, found {args.torque_limit}")
    setup = resolve_setup(args)
    K = design(resolve_model(args, setup), *PAPER_DESIGN_POINT).K if args.controller == "pid" else None
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
        save_figure("--plot", args.plot, plot_response(res))
    frame = res.to_pandas()
    if not res.success:
        raise CommandLineError(f"`--controller {args.controller}`: the run failed: {res.message}")
    if args.format == "json":
        return json.dumps(
            {
                "controller": args.controller,
                "scenario": initial.name,
                "payload": args.payload,
                # the metrics are taken after the transient; a shorter run has none
                "metrics": res.metrics().to_dict() if (res.t >= PAPER_TRANSIENT).sum() >= 2 else None,
                "series": frame.to_dict(orient="list"),
            }
        )
    return str(frame.to_csv(index=False))
