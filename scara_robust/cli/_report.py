"""``campaign-report``: per-controller statistics of a campaign, and a figure."""

from __future__ import annotations

import argparse
from typing import Any

from ..plotting import plot_campaign
from ..studies.campaign.report import campaign_report
from ..studies.campaign.runner import read_results
from ._common import save_figure

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``campaign-report``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("campaign-report", help="per-controller statistics of a campaign, and a figure")
    p.add_argument("results", help="results file of `campaign` (.csv or .parquet)")
    p.add_argument("--format", choices=("text", "csv", "json"), default="text")
    p.add_argument("--plot", metavar="FILE.png", help="also save a figure of the metrics per controller")
    p.add_argument("--output", help="write the statistics to this file instead of stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> str:
    """Summarize a results file; the statistics to print.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    str
    """
    results = read_results(args.results)
    report = campaign_report(results)
    if args.plot is not None:
        save_figure("--plot", args.plot, plot_campaign(results))
    if args.format == "json":
        return str(report.reset_index().to_json(orient="records", indent=2))
    if args.format == "csv":
        return str(report.to_csv())
    figure = f"\nfigure: {args.plot}" if args.plot is not None else ""
    return str(report.T.to_string(float_format="%.4g")) + figure
