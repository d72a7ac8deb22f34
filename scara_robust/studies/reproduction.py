"""The paper's claims next to what this package computes.

Each row of :func:`reproduction_table` is one claim of the paper's Section 4 (or of
Figures 2, 3 and 6), the paper's figure as printed, the package's figure and whether the
claim holds for the package. Nothing is adjusted to make a row agree.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array
from ..lyapunov.gain import design
from ..lyapunov.surface import DesignSurface, design_surface
from ..lyapunov.theorem1 import certify
from ..model.robot import ScaraParams
from ..model.scara import paper_model
from ..model.signals import SquareWave
from ..paper import PAPER_DESIGN_POINT, PAPER_GAIN, PAPER_GAIN_DECIMALS, PAPER_T_FINAL, PAPER_TRANSIENT
from ..simulation.metrics import METRIC_NAMES
from ..simulation.run import run_scenario
from .comparison import compare_controllers

__all__ = ["reproduction_table", "error_sensitivity"]

_COLUMNS = ["claim", "source", "paper", "package", "unit", "holds"]


def gain_digits_matched(K: ArrayLike) -> NDArray[np.bool_]:
    """Which entries of a gain round to the paper's printed K.

    Parameters
    ----------
    K : array_like, shape (2, 6)
        A gain, e.g. ``sr.design(sr.paper_model(), 3, 90).K``.

    Returns
    -------
    ndarray of bool, shape (2, 6)
        True where ``K`` rounded to the printed number of decimals equals the printed entry.
    """
    K = check_array("K", K, shape=(2, 6))
    rounded = np.array(
        [[round(float(k), int(d)) for k, d in zip(row, drow)] for row, drow in zip(K, PAPER_GAIN_DECIMALS)]
    )
    return np.asarray(rounded == PAPER_GAIN)


def _timed_paper_surface() -> tuple[DesignSurface, float]:
    start = time.perf_counter()
    surface = design_surface(paper_model(), np.linspace(0.01, 10.0, 200), np.linspace(1.0, 200.0, 200), "all")
    return surface, time.perf_counter() - start


def _pid_metrics(comparison: pd.DataFrame, scenario: str) -> dict[str, float]:
    missing = {"controller", "scenario", "payload", *METRIC_NAMES} - set(comparison.columns)
    if missing:
        raise ValueError(f"`comparison` must have the columns of compare_controllers(), missing {sorted(missing)}")
    rows = comparison[
        (comparison["controller"] == "pid") & (comparison["scenario"] == scenario) & (comparison["payload"] == "on")
    ]
    if len(rows) != 1:
        raise ValueError(
            f"`comparison` must hold one 'pid' row with payload 'on' for scenario {scenario!r}, found {len(rows)}"
        )
    return {name: float(rows[name].iloc[0]) for name in METRIC_NAMES}


def reproduction_table(comparison: pd.DataFrame | None = None) -> pd.DataFrame:
    """Tabulate the paper's claims against this package's results.

    Parameters
    ----------
    comparison : pandas.DataFrame, optional
        A table from :func:`scara_robust.compare_controllers` with payload on and 20-s runs, holding
        the ``pid`` rows of scenarios ``large`` and ``small``. Computed (PID only, about
        5 s) when omitted.

    Returns
    -------
    pandas.DataFrame
        One row per claim with columns ``claim``, ``source`` (where the paper makes it),
        ``paper`` (as printed, a string), ``package`` (float), ``unit`` and ``holds``
        (bool: the claim is true of the package's result). The design surface of the
        claims "infinitely many certified (ρ, η)" and "less than 5 seconds" is the
        published model, all elements, on a 200 x 200 grid ρ ∈ [0.01, 10], η ∈ [1, 200],
        computed and timed here.

    References
    ----------
    Paper, Section 4 and Figures 2, 3 and 6; Section 3 for the sweep time.

    Examples
    --------
    >>> import scara_robust as sr
    >>> table = sr.reproduction_table()  # doctest: +SKIP
    >>> table[["claim", "paper", "package", "holds"]]  # doctest: +SKIP
    """
    if comparison is None:
        comparison = compare_controllers(("pid",), ("large", "small"))
    elif not isinstance(comparison, pd.DataFrame):
        raise TypeError(
            f"`comparison` must be a pandas DataFrame from compare_controllers(), found {type(comparison).__name__}"
        )
    large = _pid_metrics(comparison, "large")
    small = _pid_metrics(comparison, "small")
    surface, seconds = _timed_paper_surface()
    model = paper_model()
    d = design(model, *PAPER_DESIGN_POINT)
    matched = int(gain_digits_matched(d.K).sum())
    max_eig = certify(model, d, "all").max_eig
    n_certified = int(surface.certified.sum())
    grid = "x".join(str(n) for n in surface.max_eig.shape)
    # claim, source, as printed, package value, unit, holds
    rows: list[tuple[str, str, str, float, str, bool]] = [
        ("K(3, 90): entries equal to the printed digits", "Section 4", "12", matched, "of 12", matched == 12),
        ("max λ(Z(3, 90)), all elements", "Section 4", "-0.04", max_eig, "-", max_eig < 0),
        (f"(ρ, η) with max λ(Z) < 0, {grid} grid", "Figure 2", "infinitely many", n_certified, "points",
         n_certified > 0),
        ("large IC: max |e| after 6 s", "Figure 3", "≤ 0.02", large["max_abs_error_after_6s"], "rad",
         large["max_abs_error_after_6s"] <= 0.02),
        ("large IC: max |Tc| after 6 s", "Figure 3", "≤ 7.5", large["max_abs_torque_after_6s"], "N·m",
         large["max_abs_torque_after_6s"] <= 7.5),
        ("small IC: initial |Tc|", "Figure 6", "≤ 14.5", small["peak_torque"], "N·m", small["peak_torque"] <= 14.5),
        ("small IC: max |Tc| after 6 s", "Figure 6", "≤ 7.5", small["max_abs_torque_after_6s"], "N·m",
         small["max_abs_torque_after_6s"] <= 7.5),
        ("small IC: max |e| after 6 s", "Figure 6", "≤ 0.02", small["max_abs_error_after_6s"], "rad",
         small["max_abs_error_after_6s"] <= 0.02),
        (f"design-surface sweep, {grid} grid", "Section 3", "< 5 (MATLAB, Pentium D)", seconds, "s", seconds < 5.0),
    ]
    table = pd.DataFrame(rows, columns=_COLUMNS)
    return table.astype({"package": float, "holds": bool})


def error_sensitivity(t_final: float = PAPER_T_FINAL) -> pd.DataFrame:
    """Where the PID's max |e| after 6 s (large initial condition) comes from.

    Runs the paper's PID (K at (3, 90), published model) on the large initial condition
    while changing one thing at a time: the length of link 2 (which the paper does not
    give; 0.4 m here), the payload (on or off) and the disturbance's phase (not given; 0
    here). The max after 6 s is at the tail of the slow closed-loop transient, which a
    second column shows by starting one second later.

    Parameters
    ----------
    t_final : float
        Horizon, s (> 7).

    Returns
    -------
    pandas.DataFrame
        One row per case: ``case``, ``L2 [m]``, ``payload``, ``phase [rad]``,
        ``max |e| after 6 s [rad]``, ``at t [s]`` (where it is reached) and
        ``max |e| after 7 s [rad]``.
    """
    K = design(paper_model(), *PAPER_DESIGN_POINT).K
    cases: list[tuple[str, float, bool, float]] = [("this package", 0.4, True, 0.0)]
    cases += [(f"L2 = {L2:g} m", L2, True, 0.0) for L2 in (0.2, 0.3, 0.5)]
    cases += [("payload off", 0.4, False, 0.0)]
    cases += [(f"phase = {k}π/2", 0.4, True, k * np.pi / 2) for k in (1, 2, 3)]
    rows = []
    for label, L2, payload_on, phase in cases:
        params = ScaraParams(L2=L2, Lc2=min(ScaraParams().Lc2, L2))
        res = run_scenario(
            "pid", "large", params=params, payload_on=payload_on, disturbance=SquareWave(phase=phase), K=K,
            t_final=t_final,
        )
        error = np.abs(res.e).max(axis=0)
        after = res.t >= PAPER_TRANSIENT
        worst = int(np.argmax(np.where(after, error, -np.inf)))
        rows.append((label, L2, "on" if payload_on else "off", phase, float(error[worst]), float(res.t[worst]),
                     float(error[res.t >= PAPER_TRANSIENT + 1.0].max())))
    columns = ["case", "L2 [m]", "payload", "phase [rad]", "max |e| after 6 s [rad]", "at t [s]",
               "max |e| after 7 s [rad]"]
    return pd.DataFrame(rows, columns=columns)
