"""Per-controller statistics of a campaign's results table, with intervals that fit large N.

:func:`campaign_report` gives, per controller, the status counts, the failure rate (runs
that are not ``tracking``) with its Wilson score interval (:func:`wilson_interval`), and
quantiles of each metric with percentile-bootstrap intervals
(:func:`bootstrap_quantiles`: seeded, :data:`BOOTSTRAP_RESAMPLES` resamples, vectorized
with numpy so it stays fast at N = 10 000). :func:`worst_scenarios` lists the worst runs
of each controller with the inputs that produced them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.stats import norm

from ..._validation import check_array, check_int, check_real
from ...exceptions import ArgumentValueError
from ...simulation.metrics import METRIC_NAMES, STATUSES
from .inputs import DRAWN_COLUMNS

__all__ = ["campaign_report", "worst_scenarios"]

#: Resamples of the percentile bootstrap of :func:`campaign_report`.
BOOTSTRAP_RESAMPLES = 2000
#: Confidence level of the intervals of :func:`campaign_report`.
REPORT_CONFIDENCE = 0.95

#: Resamples per block of the bootstrap: bounds the memory at ~block x n integers.
_BLOCK = 250


def _z(confidence: float) -> float:
    c = check_real("confidence", confidence)
    if not 0.0 < c < 1.0:
        raise ArgumentValueError("confidence", f"must be in (0, 1), found {c}")
    return float(norm.ppf(0.5 + 0.5 * c))


def wilson_interval(
    successes: ArrayLike, trials: ArrayLike, confidence: float = REPORT_CONFIDENCE
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Wilson score interval of a binomial proportion.

    With ``p̂ = k/n`` and ``z`` the standard normal quantile of ``(1 + confidence)/2``,
    the interval is ``(p̂ + z²/2n ± z √(p̂(1 − p̂)/n + z²/4n²)) / (1 + z²/n)``. Unlike
    ``p̂ ± z √(p̂(1 − p̂)/n)`` it stays in [0, 1] and is not empty at k = 0 or k = n,
    which matters for rare failures.

    Parameters
    ----------
    successes : array_like of int
        Counts k (here: failures), 0 <= k <= n.
    trials : array_like of int, same shape as `successes`
        Counts n >= 1.
    confidence : float
        In (0, 1).

    Returns
    -------
    low, high : ndarray, shape of the broadcast inputs
        Bounds of the interval, in [0, 1].

    References
    ----------
    E. B. Wilson, "Probable inference, the law of succession, and statistical inference",
    J. Am. Stat. Assoc. 22 (1927) 209-212.

    Examples
    --------
    >>> from scara_robust.studies.campaign.report import wilson_interval
    >>> low, high = wilson_interval(0, 10)
    >>> float(low), round(float(high), 4)
    (0.0, 0.2775)
    """
    z = _z(confidence)
    k = check_array("successes", successes)
    n = check_array("trials", trials)
    if np.any(n < 1) or np.any(n != np.round(n)):
        raise ArgumentValueError("trials", f"must be integers >= 1, found {n.tolist()}")
    if np.any(k < 0) or np.any(k > n) or np.any(k != np.round(k)):
        raise ArgumentValueError("successes", f"must be integers in [0, trials], found {k.tolist()}")
    p = k / n
    denominator = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    # k = 0 and k = n give centre - half = 0 and centre + half = 1 exactly, but for rounding
    low = np.where(k == 0, 0.0, np.clip(centre - half, 0.0, 1.0))
    high = np.where(k == n, 1.0, np.clip(centre + half, 0.0, 1.0))
    return low, high


def bootstrap_quantiles(
    values: ArrayLike,
    quantiles: Sequence[float],
    *,
    resamples: int = BOOTSTRAP_RESAMPLES,
    confidence: float = REPORT_CONFIDENCE,
    seed: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Percentile-bootstrap intervals of sample quantiles.

    Each resample draws ``n`` of the values with replacement (``numpy.random.default_rng(seed)``);
    its quantiles are taken like :func:`numpy.quantile` (linear interpolation, the same as
    pandas), and the interval is the ``(1 ∓ confidence)/2`` percentiles of the resampled
    quantiles. The resamples are counts of each sorted value, built in blocks with
    ``numpy.bincount``; an order statistic of a resample is where its cumulative count
    passes the rank, so no resample is sorted: O(resamples x n) time.

    Parameters
    ----------
    values : array_like, shape (n,)
        Finite samples, n >= 1.
    quantiles : sequence of float
        Levels in [0, 1].
    resamples : int
        Number of bootstrap resamples (>= 1).
    confidence : float
        In (0, 1).
    seed : int
        Seed (>= 0): the same inputs give the same intervals.

    Returns
    -------
    low, high : ndarray, shape (len(quantiles),)
        Bounds of each quantile's interval, in the unit of `values`.

    Examples
    --------
    >>> import numpy as np
    >>> from scara_robust.studies.campaign.report import bootstrap_quantiles
    >>> low, high = bootstrap_quantiles(np.arange(100.0), [0.5])
    >>> bool(low[0] < 49.5 < high[0])
    True
    """
    x = np.sort(check_array("values", values, ndim=1))
    if x.size == 0:
        raise ArgumentValueError("values", "must hold at least one value, found none")
    qs = check_array("quantiles", quantiles, ndim=1)
    if qs.size == 0 or np.any((qs < 0) | (qs > 1)):
        raise ArgumentValueError("quantiles", f"must be numbers in [0, 1], found {qs.tolist()}")
    b = check_int("resamples", resamples, 1)
    seed = check_int("seed", seed, 0)
    z_alpha = 0.5 * (1.0 - check_real("confidence", confidence))
    _z(confidence)
    n = x.size
    h = (n - 1) * qs
    lower = np.floor(h).astype(np.int64)
    upper = np.minimum(lower + 1, n - 1)
    frac = h - lower
    rng = np.random.default_rng(seed)
    estimates = np.empty((b, qs.size))
    for start in range(0, b, _BLOCK):
        m = min(_BLOCK, b - start)
        picks = rng.integers(0, n, size=(m, n)) + n * np.arange(m)[:, None]
        cumulative = np.bincount(picks.ravel(), minlength=m * n).reshape(m, n).cumsum(axis=1)
        # Order statistic r (0-based) of a resample: the first sorted value whose cumulative
        # count exceeds r. Each row of counts ends at n, so offsetting row i by i (n + 1)
        # makes the whole block one sorted array and one searchsorted finds every row's.
        offsets = (n + 1) * np.arange(m)[:, None]
        flat = (cumulative + offsets).ravel()
        lo = x[np.searchsorted(flat, lower[None, :] + offsets, side="right") - n * np.arange(m)[:, None]]
        hi = x[np.searchsorted(flat, upper[None, :] + offsets, side="right") - n * np.arange(m)[:, None]]
        estimates[start : start + m] = lo + frac * (hi - lo)
    low = np.quantile(estimates, z_alpha, axis=0)
    high = np.quantile(estimates, 1.0 - z_alpha, axis=0)
    return np.asarray(low, dtype=float), np.asarray(high, dtype=float)


def _check_table(results: pd.DataFrame) -> None:
    needed = {"controller", "status", "success", *METRIC_NAMES}
    if not isinstance(results, pd.DataFrame) or not needed <= set(results.columns):
        raise ArgumentValueError(
            "results", "must be a campaign table with controller, status, success and metric columns"
        )


def campaign_report(
    results: pd.DataFrame,
    quantiles: Sequence[float] = (0.05, 0.5, 0.95),
    *,
    confidence: float = REPORT_CONFIDENCE,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = 0,
) -> pd.DataFrame:
    """Per-controller statistics of a campaign table, with confidence intervals.

    Parameters
    ----------
    results : pandas.DataFrame
        From :func:`run_campaign` or :func:`read_results`.
    quantiles : sequence of float
        Quantiles of each metric over the runs that finished, in [0, 1].
    confidence : float
        Level of every interval, in (0, 1) (default 0.95).
    resamples : int
        Bootstrap resamples of the quantile intervals (default
        :data:`BOOTSTRAP_RESAMPLES`).
    seed : int
        Seed of the bootstrap (>= 0); each controller uses it, so the report is reproducible.

    Returns
    -------
    pandas.DataFrame
        Index: controller. Columns ``runs``; one count per status of
        :data:`scara_robust.STATUSES` (``tracking``, ``not-tracking``, ``diverged``,
        ``failed``, ``too-short``); ``failures`` (runs that are not ``tracking``),
        ``failure_rate`` and its Wilson score interval ``failure_rate low``,
        ``failure_rate high`` (:func:`wilson_interval`); and, for each metric (units in
        ``scara_robust.simulation.metrics.METRIC_UNITS``), ``<metric> q<p>`` for every quantile with its
        percentile-bootstrap interval ``<metric> q<p> low`` and ``<metric> q<p> high``
        (:func:`bootstrap_quantiles`), and ``<metric> max``. A metric no run has is NaN.
    """
    _check_table(results)
    qs = [float(q) for q in quantiles]
    if not qs or any(not 0.0 <= q <= 1.0 for q in qs):
        raise ArgumentValueError("quantiles", f"must be numbers in [0, 1], found {list(quantiles)!r}")
    _z(confidence)
    rows = {}
    for name, group in results.groupby("controller", sort=True):
        ok = group[group["success"].astype(bool)]
        row: dict[str, float] = {"runs": len(group)}
        counts = group["status"].value_counts()
        row.update({status: int(counts.get(status, 0)) for status in STATUSES})
        row["failures"] = row["runs"] - row["tracking"]
        row["failure_rate"] = row["failures"] / row["runs"]
        low, high = wilson_interval(row["failures"], row["runs"], confidence)
        row["failure_rate low"], row["failure_rate high"] = float(low), float(high)
        for metric in METRIC_NAMES:
            values = ok[metric].astype(float).dropna()
            if len(values):
                lows, highs = bootstrap_quantiles(
                    values.to_numpy(), qs, resamples=resamples, confidence=confidence, seed=seed
                )
            else:
                lows = highs = np.full(len(qs), math.nan)
            for q, q_low, q_high in zip(qs, lows, highs):
                label = f"{metric} q{q * 100:g}"
                row[label] = float(values.quantile(q)) if len(values) else math.nan
                row[f"{label} low"], row[f"{label} high"] = float(q_low), float(q_high)
            row[f"{metric} max"] = float(values.max()) if len(values) else math.nan
        rows[name] = row
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("controller")


def worst_scenarios(results: pd.DataFrame, n: int = 5) -> pd.DataFrame:
    """The `n` worst runs of each controller, with the inputs that produced them.

    Worst first: runs that are not ``tracking`` (failed, diverged, not tracking, too
    short), then the largest ``max_abs_error_after_6s``; a run without the metric (it
    failed or diverged) counts as the largest error; ties go to the lower scenario index.

    Parameters
    ----------
    results : pandas.DataFrame
        A campaign table.
    n : int
        Runs per controller (>= 1).

    Returns
    -------
    pandas.DataFrame
        One row per run, controllers in sorted order: ``controller``, ``rank`` (1 is the
        worst), ``scenario``, ``status``, the metrics (units in
        ``scara_robust.simulation.metrics.METRIC_UNITS``) and the drawn inputs
        (``scara_robust.studies.campaign.inputs.DRAWN_COLUMNS``, units in
        ``scara_robust.studies.campaign.spec.SPEC_FIELDS``) that the table has. Replay one with
        :func:`scara_robust.replay_scenario`.
    """
    _check_table(results)
    count = check_int("n", n, 1)
    if "scenario" not in results.columns:
        raise ArgumentValueError("results", "must be a campaign table with a scenario column")
    metric = METRIC_NAMES[0]
    frame = results.assign(
        _tracks=results["status"] == "tracking",
        _error=results[metric].astype(float).fillna(math.inf),
    ).sort_values(["controller", "_tracks", "_error", "scenario"], ascending=[True, True, False, True], kind="stable")
    frame = frame.groupby("controller", sort=True).head(count)
    frame = frame.assign(rank=frame.groupby("controller").cumcount() + 1)
    drawn = [c for c in DRAWN_COLUMNS if c in frame.columns]
    columns = ["controller", "rank", "scenario", "status", *METRIC_NAMES, *drawn]
    return frame[columns].reset_index(drop=True)
