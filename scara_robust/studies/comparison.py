"""PID against sliding-mode control in one table (``python -m scara_robust.compare``).

Runs the PID of (ρ, η) = (3, 90) on the published model and both sliding-mode
variants on the ``large`` and ``small`` scenarios, and prints one row per controller ×
scenario with the metrics of :func:`scara_robust.tracking_metrics`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any

import pandas as pd
from tqdm import tqdm

from ..model.initial import SCENARIOS, Scenario
from ..paper import PAPER_T_FINAL
from ..simulation.metrics import METRIC_NAMES
from ..simulation.run import run_scenario

__all__ = ["compare_controllers", "COMPARISON_COLUMNS"]

#: Columns of :func:`compare_controllers`' table.
COMPARISON_COLUMNS = ("controller", "scenario", "payload", "success", "status", *METRIC_NAMES, "status_reason")


def compare_controllers(
    controllers: Sequence[str] = ("pid", "smc", "smc-sign"),
    scenarios: Sequence[str | Scenario] = tuple(SCENARIOS),
    *,
    payload_on: bool = True,
    t_final: float = PAPER_T_FINAL,
    progress: bool = False,
    **setup: Any,
) -> pd.DataFrame:
    """Simulate every controller on every scenario and tabulate the metrics.

    Parameters
    ----------
    controllers : sequence of str
        Names from :data:`scara_robust.CONTROLLERS`; default the paper's comparison, the
        continuous PID against the two sliding-mode laws (add ``'pid-sampled'`` for the
        deployable PID).
    scenarios : sequence of str or Scenario
        Names from :data:`scara_robust.SCENARIOS`, or :class:`~scara_robust.Scenario`.
    payload_on : bool
        The paper's ``m_p(t)`` (True) or ``m_p = 0`` (False).
    t_final : float
        Horizon, s (> 6 so the after-transient metrics exist).
    progress : bool
        Show a tqdm progress bar on stderr.
    **setup
        ``params``, ``reference``, ``payload``, ``disturbance``, ``K``,
        ``tracking_tolerance``, passed to :func:`scara_robust.run_scenario` (default: the
        paper's signals, 0.05 rad).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COMPARISON_COLUMNS`: ``controller, scenario, payload, success``,
        ``status`` (one of :data:`scara_robust.STATUSES`), the metric names (NaN for a run
        without them) and ``status_reason``.
    """
    pairs = [(c, s) for c in controllers for s in scenarios]
    rows: list[dict[str, Any]] = []
    for c, s in tqdm(pairs, disable=not progress, file=sys.stderr, desc="compare", unit="run"):
        res = run_scenario(c, s, payload_on=payload_on, t_final=t_final, **setup)
        row: dict[str, Any] = {
            "controller": c,
            "scenario": s if isinstance(s, str) else s.name,
            "payload": "on" if payload_on else "off",
            "success": res.success,
            "status": res.status,
            "status_reason": res.status_reason,
        }
        row.update(res.metrics().to_dict() if res.has_metrics else dict.fromkeys(METRIC_NAMES, math.nan))
        rows.append(row)
    return pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))
