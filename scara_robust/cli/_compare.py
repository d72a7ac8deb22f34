"""``compare``: PID against sliding-mode control on both scenarios."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

import pandas as pd

from ..lyapunov.gain import design
from ..model.initial import SCENARIOS
from ..paper import PAPER_DESIGN_POINT, PAPER_T_FINAL, PAPER_TRANSIENT
from ..simulation.metrics import METRIC_NAMES
from ..studies.comparison import compare_controllers
from ._common import (
    CommandLineError,
    add_setup_options,
    finite_float,
    resolve_design,
    resolve_model,
    resolve_setup,
)

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``compare``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("compare", help="PID vs sliding-mode control on both scenarios")
    add_setup_options(p)
    p.add_argument("--design", metavar="FILE.json", action="append",
                   help="add rows for the PID gain of a design file (written by synthesize --output); repeatable")
    p.add_argument("--format", choices=("text", "markdown", "csv", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--t-final", type=finite_float, default=PAPER_T_FINAL, help=f"horizon, s (> {PAPER_TRANSIENT:g})")
    p.add_argument("--payload", choices=("on", "off"), default="on")
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


def run(args: argparse.Namespace) -> str:
    """Run the comparison; the table to print.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    str
    """
    if args.t_final <= PAPER_TRANSIENT:
        raise CommandLineError(
            f"`--t-final` must be > {PAPER_TRANSIENT:g} s (metrics are taken after {PAPER_TRANSIENT:g} s), "
            f"found {args.t_final}"
        )
    setup = resolve_setup(args)
    K = design(resolve_model(args, setup), *PAPER_DESIGN_POINT).K
    scenarios = list(SCENARIOS) if setup.initial is None else [setup.initial]
    designs = {}
    for path in args.design or []:
        loaded = resolve_design(argparse.Namespace(design=path))
        assert loaded is not None
        designs[f"pid:{os.path.basename(path)}"] = loaded.K
    start = time.perf_counter()
    table = compare_controllers(
        scenarios=scenarios,
        payload_on=args.payload == "on",
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
