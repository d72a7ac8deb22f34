"""Per-controller statistics of a campaign's results table."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pandas as pd

from ...exceptions import ArgumentValueError
from ...simulation.metrics import METRIC_NAMES, STATUSES

__all__ = ["campaign_report"]


def campaign_report(results: pd.DataFrame, quantiles: Sequence[float] = (0.05, 0.5, 0.95)) -> pd.DataFrame:
    """Per-controller statistics of a campaign table.

    Parameters
    ----------
    results : pandas.DataFrame
        From :func:`run_campaign` or :func:`read_results`.
    quantiles : sequence of float
        Quantiles of each metric over the runs that finished, in [0, 1].

    Returns
    -------
    pandas.DataFrame
        Index: controller. Columns ``runs``; one count per status of
        :data:`scara_robust.STATUSES` (``tracking``, ``not-tracking``, ``diverged``,
        ``failed``, ``too-short``); ``failures`` (runs that are not ``tracking``) and
        ``failure_rate``; and, for each metric, ``<metric> q<p>`` for every quantile and
        ``<metric> max``.
    """
    needed = {"controller", "status", "success", *METRIC_NAMES}
    if not isinstance(results, pd.DataFrame) or not needed <= set(results.columns):
        raise ArgumentValueError(
            "results", "must be a campaign table with controller, status, success and metric columns"
        )
    qs = [float(q) for q in quantiles]
    if not qs or any(not 0.0 <= q <= 1.0 for q in qs):
        raise ArgumentValueError("quantiles", f"must be numbers in [0, 1], found {list(quantiles)!r}")
    rows = {}
    for name, group in results.groupby("controller", sort=True):
        ok = group[group["success"].astype(bool)]
        row: dict[str, float] = {"runs": len(group)}
        counts = group["status"].value_counts()
        row.update({status: int(counts.get(status, 0)) for status in STATUSES})
        row["failures"] = row["runs"] - row["tracking"]
        row["failure_rate"] = row["failures"] / row["runs"]
        for metric in METRIC_NAMES:
            values = ok[metric].astype(float).dropna()
            for q in qs:
                row[f"{metric} q{q * 100:g}"] = float(values.quantile(q)) if len(values) else math.nan
            row[f"{metric} max"] = float(values.max()) if len(values) else math.nan
        rows[name] = row
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("controller")
