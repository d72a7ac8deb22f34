"""PID against sliding-mode control in one table (``python -m scara_robust.compare``).

Runs the PID of (ρ, η) = (3, 90) on the published model, the PID whose gain was
synthesized with its certificate (``pid-lmi``) and both sliding-mode variants on the
``large`` and ``small`` scenarios, and prints one row per controller × scenario with the
metrics of :func:`scara_robust.tracking_metrics`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd
from numpy.typing import ArrayLike
from tqdm import tqdm

from .._validation import check_array
from ..exceptions import ArgumentValueError
from ..model.initial import SCENARIOS, Scenario
from ..paper import PAPER_T_FINAL
from ..simulation.metrics import METRIC_NAMES
from ..simulation.run import run_scenario

__all__ = ["compare_controllers", "COMPARISON_COLUMNS", "COMPARED_CONTROLLERS"]

#: Controllers of the default comparison: the paper's PID, the synthesized PID, both sliding modes.
COMPARED_CONTROLLERS = ("pid", "pid-lmi", "smc", "smc-sign")

#: Columns of :func:`compare_controllers`' table.
COMPARISON_COLUMNS = ("controller", "scenario", "payload", "success", "status", *METRIC_NAMES, "status_reason")


def compare_controllers(
    controllers: Sequence[str] = COMPARED_CONTROLLERS,
    scenarios: Sequence[str | Scenario] = tuple(SCENARIOS),
    *,
    payload_on: bool = True,
    t_final: float = PAPER_T_FINAL,
    progress: bool = False,
    designs: Mapping[str, ArrayLike] | None = None,
    **setup: Any,
) -> pd.DataFrame:
    """Simulate every controller on every scenario and tabulate the metrics.

    Parameters
    ----------
    controllers : sequence of str
        Names from :data:`scara_robust.CONTROLLERS`; default :data:`COMPARED_CONTROLLERS`,
        the paper's comparison (the continuous PID against the two sliding-mode laws) and
        the synthesized PID (add ``'pid-sampled'`` for the deployable discrete PID).
    scenarios : sequence of str or Scenario
        Names from :data:`scara_robust.SCENARIOS`, or :class:`~scara_robust.Scenario`.
    payload_on : bool
        The paper's ``m_p(t)`` (True) or ``m_p = 0`` (False).
    t_final : float
        Horizon, s (> 6 so the after-transient metrics exist).
    progress : bool
        Show a tqdm progress bar on stderr.
    designs : mapping of str to array_like of shape (2, 6), optional
        More PID gains, each run as ``pid`` with that ``K`` and labelled by its key in the
        ``controller`` column (for example gains read from design files).
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
    extra = {label: check_array(f"designs[{label!r}]", K, shape=(2, 6)) for label, K in (designs or {}).items()}
    clash = sorted(set(extra) & set(controllers))
    if clash:
        raise ArgumentValueError("designs", f"labels must differ from the controllers' names, found {clash}")
    pairs = [(c, s) for c in [*controllers, *extra] for s in scenarios]
    rows: list[dict[str, Any]] = []
    for c, s in tqdm(pairs, disable=not progress, file=sys.stderr, desc="compare", unit="run"):
        if c in extra:
            res = run_scenario("pid", s, payload_on=payload_on, t_final=t_final, **{**setup, "K": extra[c]})
        else:
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
