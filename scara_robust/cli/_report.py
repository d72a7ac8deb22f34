"""``campaign-report``: per-controller statistics of a campaign, its worst runs, and a figure."""

from __future__ import annotations

import argparse
import json
from typing import Any

import pandas as pd

from ..plotting import plot_campaign
from ..simulation.metrics import METRIC_UNITS
from ..studies.campaign.inputs import DRAWN_COLUMNS
from ..studies.campaign.report import (
    BOOTSTRAP_RESAMPLES,
    REPORT_CONFIDENCE,
    campaign_report,
    worst_scenarios,
)
from ..studies.campaign.runner import read_results
from ..studies.campaign.spec import SPEC_FIELDS
from ._common import CommandLineError, save_figure
from ._parser import COMMAND_HELP
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]

#: Seed of the bootstrap: the same table gives the same report.
_SEED = 0


def add_parser(sub: Any) -> None:
    """Register ``campaign-report``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser(
        "campaign-report",
        help=COMMAND_HELP["campaign-report"],
    )
    p.add_argument("results", help="results file of `campaign` (.csv or .parquet)")
    p.add_argument(
        "--format",
        choices=("text", "csv", "json"),
        default="text",
        help="csv: the statistics table, an empty line, the worst-runs table; json: both, with units",
    )
    p.add_argument("--worst", type=int, default=5, help="worst runs listed per controller (default 5)")
    p.add_argument("--plot", metavar="FILE.png", help="also save a figure of the metrics per controller")
    p.add_argument("--output", help="write the statistics to this file instead of stdout")
    p.set_defaults(func=run)


def _units() -> dict[str, str]:
    """Unit of every metric and drawn-input column."""
    units = dict(METRIC_UNITS)
    units.update({name: spec[0] for name, spec in SPEC_FIELDS.items() if name in DRAWN_COLUMNS})
    units.update({"e1_0": "rad", "e2_0": "rad"})
    return units


def _with_unit(label: str, units: dict[str, str]) -> str:
    unit = units.get(label.split(" ")[0])
    return f"{label} [{unit}]" if unit else label


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Summarize a results file; the statistics and worst runs to print.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem
        Unused: the results file holds the runs' inputs.

    Returns
    -------
    str
    """
    if args.worst < 1:
        raise CommandLineError(f"`--worst` must be an integer >= 1, found {args.worst}")
    results = read_results(args.results)
    report = campaign_report(results, resamples=BOOTSTRAP_RESAMPLES, seed=_SEED)
    worst = worst_scenarios(results, args.worst)
    if args.plot is not None:
        save_figure("--plot", args.plot, plot_campaign(results))
    units = _units()
    if args.format == "json":
        return json.dumps(
            {
                "confidence": REPORT_CONFIDENCE,
                "bootstrap": {"method": "percentile", "resamples": BOOTSTRAP_RESAMPLES, "seed": _SEED},
                "units": units,
                "statistics": json.loads(str(report.reset_index().to_json(orient="records"))),
                "worst": json.loads(str(worst.to_json(orient="records"))),
            },
            indent=2,
            ensure_ascii=False,
        )
    if args.format == "csv":
        return str(report.to_csv()) + "\n" + str(worst.to_csv(index=False))
    level = f"{REPORT_CONFIDENCE * 100:g} %"
    # counts stay integers once transposed beside the floats
    counts = {str(c) for c in report.columns if pd.api.types.is_integer_dtype(report[c])}
    shown = pd.DataFrame(
        {c: [f"{int(v)}" if str(c) in counts else f"{v:.4g}" for v in report[c]] for c in report.columns},
        index=report.index,
    ).T.rename(index=lambda label: _with_unit(str(label), units))
    table = worst.rename(columns=lambda label: _with_unit(str(label), units))
    lines = [
        f"statistics per controller; low/high: {level} intervals (failure_rate: Wilson score; quantiles: "
        f"percentile bootstrap, {BOOTSTRAP_RESAMPLES} resamples, seed {_SEED})",
        str(shown.to_string()),
        "",
        f"worst {args.worst} runs per controller (not tracking first, then the largest max_abs_error_after_6s); "
        "replay one with simulate --from-campaign RESULTS --index SCENARIO --controller NAME",
        _transpose_worst(table).to_string(),
    ]
    if args.plot is not None:
        lines.append(f"figure: {args.plot}")
    return "\n".join(lines)


def _transpose_worst(table: pd.DataFrame) -> pd.DataFrame:
    """One column per run (``<controller> #<rank>``): the table is too wide for a terminal otherwise."""
    labels = [f"{c} #{r}" for c, r in zip(table["controller"], table["rank"])]
    body = table.drop(columns=["controller", "rank"]).set_axis(labels)
    # columns of mixed type once transposed: format the numbers here
    body = body.apply(lambda col: col.map(lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)))
    return body.T
