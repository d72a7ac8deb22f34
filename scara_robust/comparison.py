"""PID against sliding-mode control in one table (``python -m scara_robust.compare``).

Runs the PID of (ρ, η) = (3, 90) on the published model and both sliding-mode
variants on the ``large`` and ``small`` scenarios, and prints one row per controller ×
scenario with the metrics of :func:`scara_robust.tracking_metrics`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from typing import Any

import pandas as pd

from .controllers import CONTROLLERS
from .metrics import METRIC_NAMES
from .simulation import SCENARIOS, Scenario, run_scenario

__all__ = ["compare_controllers", "add_compare_parser"]


def compare_controllers(
    controllers: Sequence[str] = tuple(CONTROLLERS),
    scenarios: Sequence[str | Scenario] = tuple(SCENARIOS),
    *,
    payload_on: bool = True,
    t_final: float = 20.0,
    progress: bool = False,
    **setup: Any,
) -> pd.DataFrame:
    """Simulate every controller on every scenario and tabulate the metrics.

    Parameters
    ----------
    controllers : sequence of str
        Names from :data:`scara_robust.CONTROLLERS`.
    scenarios : sequence of str or Scenario
        Names from :data:`scara_robust.SCENARIOS`, or :class:`~scara_robust.Scenario`.
    payload_on : bool
        The paper's ``m_p(t)`` (True) or ``m_p = 0`` (False).
    t_final : float
        Horizon, s (> 6 so the after-transient metrics exist).
    progress : bool
        Show a tqdm progress bar on stderr.
    **setup
        ``params``, ``reference``, ``payload``, ``disturbance``, ``K``, passed to
        :func:`scara_robust.run_scenario` (default: the paper's).

    Returns
    -------
    pandas.DataFrame
        Columns ``controller, scenario, payload, success`` and the metric names.
    """
    from tqdm import tqdm

    pairs = [(c, s) for c in controllers for s in scenarios]
    rows: list[dict[str, Any]] = []
    for c, s in tqdm(pairs, disable=not progress, file=sys.stderr, desc="compare", unit="run"):
        res = run_scenario(c, s, payload_on=payload_on, t_final=t_final, **setup)
        row: dict[str, Any] = {
            "controller": c,
            "scenario": s if isinstance(s, str) else s.name,
            "payload": "on" if payload_on else "off",
            "success": res.success,
        }
        row.update(res.metrics().to_dict())
        rows.append(row)
    return pd.DataFrame(rows, columns=["controller", "scenario", "payload", "success", *METRIC_NAMES])


def _cmd_compare(args: argparse.Namespace) -> str:
    if args.t_final <= 6.0:
        raise ValueError(f"`--t-final` must be > 6 s (metrics are taken after 6 s), found {args.t_final}")
    from .cli import resolve_model, resolve_setup
    from .design import design

    setup = resolve_setup(args)
    K = design(resolve_model(args, setup), 3.0, 90.0).K
    scenarios = list(SCENARIOS) if setup.initial is None else [setup.initial]
    start = time.perf_counter()
    table = compare_controllers(
        scenarios=scenarios,
        payload_on=args.payload == "on",
        t_final=args.t_final,
        progress=sys.stderr.isatty() or args.progress,
        K=K,
        **setup.signals(),
    )
    elapsed = time.perf_counter() - start
    sys.stderr.write(f"compare: {len(table)} runs in {elapsed:.1f} s\n")
    if args.format == "json":
        keys = ["controller", "scenario", "payload", *METRIC_NAMES]
        return json.dumps(table[keys].to_dict(orient="records"), indent=2)
    if args.format == "csv":
        return str(table.to_csv(index=False))
    if args.format == "markdown":
        return table.to_markdown(index=False, floatfmt=".4g") if _has_tabulate() else _markdown(table)
    return str(table.to_string(index=False, float_format="%.4g"))


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


def add_compare_parser(sub: Any) -> None:
    """Register ``compare`` on the command line's sub-parsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    from .cli import _finite_float, add_setup_options

    p = sub.add_parser("compare", help="PID vs sliding-mode control on both scenarios")
    add_setup_options(p)
    p.add_argument("--format", choices=("text", "markdown", "csv", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--t-final", type=_finite_float, default=20.0, help="horizon, s (> 6)")
    p.add_argument("--payload", choices=("on", "off"), default="on")
    p.add_argument("--progress", action="store_true", help="show a progress bar even when stderr is not a terminal")
    p.set_defaults(func=_cmd_compare)
