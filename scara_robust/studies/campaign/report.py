"""Per-controller statistics of a campaign's results table."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pandas as pd

from ...exceptions import ArgumentValueError
from ...simulation.metrics import METRIC_NAMES

__all__ = ["campaign_report"]


def campaign_report(results: pd.DataFrame, quantiles: Sequence[float] = (0.05, 0.5, 0.95)) -> pd.DataFrame:
    """Per-controller statistics of a campaign table.

    Parameters
    ----------
    results : pandas.DataFrame
        From :func:`run_campaign` or :func:`read_results`.
    quantiles : sequence of float
        Quantiles of each metric over the successful runs, in [0, 1].

    Returns
    -------
    pandas.DataFrame
        Index: controller. Columns ``runs``, ``failures``, ``failure_rate`` and, for
        each metric, ``<metric> q<p>`` for every quantile and ``<metric> max``.
    """
    if not isinstance(results, pd.DataFrame) or not {"controller", "success", *METRIC_NAMES} <= set(results.columns):
        raise ArgumentValueError("results", "must be a campaign table with controller, success and metric columns")
    qs = [float(q) for q in quantiles]
    if not qs or any(not 0.0 <= q <= 1.0 for q in qs):
        raise ArgumentValueError("quantiles", f"must be numbers in [0, 1], found {list(quantiles)!r}")
    rows = {}
    for name, group in results.groupby("controller", sort=True):
        ok = group[group["success"].astype(bool)]
        row: dict[str, float] = {
            "runs": len(group),
            "failures": int((~group["success"].astype(bool)).sum()),
        }
        row["failure_rate"] = row["failures"] / row["runs"]
        for metric in METRIC_NAMES:
            values = ok[metric].astype(float)
            for q in qs:
                row[f"{metric} q{q * 100:g}"] = float(values.quantile(q)) if len(values) else math.nan
            row[f"{metric} max"] = float(values.max()) if len(values) else math.nan
        rows[name] = row
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("controller")
