"""Matplotlib figures. Nothing here computes: every function draws a result object."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ._validation import check_choice, check_real
from .exceptions import ArgumentValueError

if TYPE_CHECKING:
    from .lyapunov.surface import DesignSurface
    from .simulation.run import SimulationResult
    from .studies.antiwindup import AntiWindupStudy

__all__ = [
    "plot_surface",
    "plot_surface_contour",
    "plot_response",
    "plot_signals",
    "plot_campaign",
    "plot_comparison",
    "plot_margin_map",
    "plot_margin_bracket",
    "plot_anti_windup",
    "SIGNALS",
]

#: Quantities :func:`plot_signals` draws, with their axis labels.
SIGNALS = {"error": "joint error [rad]", "torque": "control torque [N·m]"}


def plot_surface(
    surface: DesignSurface,
    mark: tuple[float, float] | None = None,
    ax: Any = None,
    *,
    clip_quantile: float = 0.95,
) -> Any:
    """3D graph of ``max λ(Z)`` over (ρ, η), like the paper's Figure 2, with the certified region shown.

    The z = 0 plane is drawn (translucent grey) and the grid's certified points
    (max λ(Z) < 0) are filled in on the floor, so the region the figure is about is
    visible even where it is thin. Values above the `clip_quantile` quantile are drawn at
    that level (a spike as ρ → 0 would otherwise flatten the rest); the z label says so.

    Parameters
    ----------
    surface : DesignSurface
    mark : tuple of float, optional
        ``(rho, eta)`` to mark; it is placed at the nearest grid point.
    ax : mpl_toolkits.mplot3d.Axes3D, optional
        Axes to draw into (default: a new figure).
    clip_quantile : float
        In (0, 1]; 1 draws every value as it is.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    clip_quantile = check_real("clip_quantile", clip_quantile, positive=True)
    if clip_quantile > 1:
        raise ArgumentValueError("clip_quantile", f"must be in (0, 1], found {clip_quantile:g}")
    if ax is None:
        fig = plt.figure(figsize=(8, 6))
        # computed_zorder=False keeps the marker drawn above the surface
        ax = fig.add_subplot(projection="3d", computed_zorder=False)
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    Z = surface.max_eig
    top = float(np.quantile(Z, clip_quantile))
    clipped = bool(clip_quantile < 1 and (Z > top).any())
    Zc = np.minimum(Z, top) if clipped else Z
    lo = float(min(Zc.min(), 0.0))
    hi = float(max(Zc.max(), 0.0))
    floor = lo - 0.08 * (hi - lo or 1.0)
    certified = surface.certified
    if certified.any():  # drawn first: with computed_zorder=False, call order is drawing order
        ax.contourf(R, H, np.where(certified, 1.0, 0.0), levels=[0.5, 1.5], zdir="z", offset=floor,
                    colors=["tab:green"], alpha=0.6)
    surf = ax.plot_surface(R, H, Zc, cmap="viridis", linewidth=0, antialiased=True, alpha=0.85)
    ax.plot_surface(R, H, np.zeros_like(Zc), color="0.5", alpha=0.25, linewidth=0)
    ax.set_zlim(floor, hi + 0.05 * (hi - lo or 1.0))
    note = f", drawn at most {top:.3g} ({100 * clip_quantile:g}th percentile)" if clipped else ""
    ax.figure.colorbar(surf, ax=ax, shrink=0.6, pad=0.12, label=f"max λ(Z) [-]{note}")
    handles = [
        Patch(color="0.5", alpha=0.4, label="max λ(Z) = 0: below it, certified"),
        Patch(color="tab:green", alpha=0.6,
              label=f"certified grid points (floor): {int(certified.sum())} of {certified.size}"),
    ]
    if mark is not None:
        i = int(np.argmin(np.abs(surface.rhos - mark[0])))
        k = int(np.argmin(np.abs(surface.etas - mark[1])))
        z = surface.max_eig[i, k]
        handles.append(ax.scatter(
            [surface.rhos[i]], [surface.etas[k]], [min(z, top) if clipped else z], color="red", s=60,
            depthshade=False, zorder=10,
            label=f"(ρ, η) = ({surface.rhos[i]:g}, {surface.etas[k]:g}): max λ(Z) = {z:.3g}",
        ))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=1, fontsize=8, frameon=False)
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_zlabel("max λ(Z) [-]")
    ax.set_title(f"Figure 2: max λ(Z) over (ρ, η) — {surface.model_name}, elements: {surface.elements}",
                 fontsize=10)
    return ax


def plot_surface_contour(surface: DesignSurface, mark: tuple[float, float] | None = None, ax: Any = None) -> Any:
    """Contour view of ``max λ(Z)`` with the certified region (max λ(Z) < 0) hatched.

    The colour scale runs from the grid minimum to the 95th percentile, so that a steep
    corner (ρ → 0) does not wash out the rest; higher values share the top colour.

    Parameters
    ----------
    surface : DesignSurface
    mark : tuple of float, optional
        ``(rho, eta)`` to mark with a star.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5))
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    lo, hi = float(surface.max_eig.min()), float(np.quantile(surface.max_eig, 0.95))
    levels = np.linspace(lo, hi if hi > lo else lo + 1.0, 30)
    cs = ax.contourf(R, H, surface.max_eig, levels=levels, cmap="viridis", extend="max")
    plt.colorbar(cs, ax=ax, label="max λ(Z) [-]")
    handles = []
    if surface.certified.any():
        ax.contourf(R, H, surface.max_eig, levels=[lo - 1.0, 0.0], colors="none", hatches=["//"])
        if not surface.certified.all():
            ax.contour(R, H, surface.max_eig, levels=[0.0], colors="red", linewidths=2)
        handles.append(Rectangle((0, 0), 1, 1, fill=False, hatch="//", label="max λ(Z) < 0 (certified)"))
    else:
        handles.append(Rectangle((0, 0), 1, 1, fill=False, lw=0, label="no grid point has max λ(Z) < 0"))
    if mark is not None:
        (star,) = ax.plot(*mark, "r*", markersize=12, label=f"(ρ, η) = ({mark[0]:g}, {mark[1]:g})")
        handles.append(star)
    ax.legend(handles=handles, loc="upper right", fontsize=8)
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_title(f"max λ(Z) < 0 region — {surface.model_name}, elements: {surface.elements}")
    return ax


def _window(result: SimulationResult, t_start: float, t_end: float | None = None) -> Any:
    t_start = check_real("t_start", t_start, nonnegative=True)
    keep = result.t >= t_start
    if t_end is not None:
        t_end = check_real("t_end", t_end, positive=True)
        keep &= result.t <= t_end
    if t_start >= result.t[-1]:
        raise ArgumentValueError("t_start", f"must be at most the final time {result.t[-1]:g} s, found {t_start:g}")
    if keep.sum() < 2:
        raise ArgumentValueError(
            "t_end", f"must leave at least two samples after t_start = {t_start:g} s, found {t_end}"
        )
    return keep


def _legend_right(ax: Any, handles: Any = None, gap: float = 1.01) -> None:
    """Legend outside the axes, on the right (beyond a twin axis's labels with a larger gap)."""
    handles = [h for h in (ax.get_lines() if handles is None else handles) if not h.get_label().startswith("_")]
    ax.legend(handles, [h.get_label() for h in handles], loc="upper left", bbox_to_anchor=(gap, 1.0), fontsize=8,
              frameon=False)


def _torque_limits(ax: Any, t: Any, torque: Any) -> None:
    """Scale the torque axis to the steady torques; say where an initial spike goes off scale."""
    magnitude = np.abs(torque).max(axis=0)
    steady = float(np.quantile(magnitude, 0.98))
    peak = float(magnitude.max())
    if peak > 3 * steady > 0:
        limit = 1.3 * steady
        ax.set_ylim(-limit, limit)
        i = int(np.argmax(magnitude))
        ax.annotate(f"peak |Tc| = {peak:.4g} N·m at t = {t[i]:.3g} s (off scale)", xy=(0.99, 0.04),
                    xycoords="axes fraction", ha="right", fontsize=8, color="0.3")


def _bound_lines(ax: Any, bound: float, label: str) -> Any:
    line = ax.axhline(bound, color="red", lw=0.9, ls=":", label=label)
    ax.axhline(-bound, color="red", lw=0.9, ls=":")
    return line


def plot_response(
    result: SimulationResult,
    *,
    title: str | None = None,
    t_start: float = 0.0,
    t_end: float | None = None,
    bounds: tuple[float | None, float | None] | None = None,
) -> Any:
    """Three panels for one run: errors, control torques, and the disturbance with the payload.

    The paper's Figure 3 puts the disturbance and the payload (scaled) beside the errors;
    here they get their own panel with their own units, so neither hides the errors.
    The torque axis is scaled to the steady torques; an initial spike beyond it is
    written out with its value.

    Parameters
    ----------
    result : SimulationResult
    title : str, optional
        Figure title (default: controller and scenario names).
    t_start, t_end : float
        Draw ``t_start <= t <= t_end``, s (default: the whole run).
    bounds : tuple of (float or None), optional
        ``(error bound [rad], torque bound [N·m])`` to draw as ± dotted red lines (the
        paper's 0.02 rad and 7.5 N·m after 6 s, for instance).

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes``: errors, torques, disturbance (then the payload's twin axis).
    """
    import matplotlib.pyplot as plt

    keep = _window(result, t_start, t_end)
    fig, (err, trq, sig) = plt.subplots(3, 1, figsize=(9.5, 7.5), sharex=True,
                                        gridspec_kw={"height_ratios": [3, 3, 1.6]})
    t = result.t[keep]
    err.plot(t, result.e[0, keep], "-.", label="e1 [rad]")
    err.plot(t, result.e[1, keep], "-", label="e2 [rad]")
    err.set_ylabel("joint error [rad]")
    trq.plot(t, result.torque[0, keep], "-.", label="Tc1 [N·m]")
    trq.plot(t, result.torque[1, keep], "-", label="Tc2 [N·m]")
    trq.set_ylabel("control torque [N·m]")
    _torque_limits(trq, t, result.torque[:, keep])
    if bounds is not None:
        if bounds[0] is not None:
            _bound_lines(err, bounds[0], f"bound ±{bounds[0]:g} rad")
        if bounds[1] is not None:
            _bound_lines(trq, bounds[1], f"bound ±{bounds[1]:g} N·m")
    sig.plot(t, result.disturbance[0, keep], color="0.45", lw=0.8, label="Td1 = Td2 [N·m]")
    sig.set_ylabel("Td [N·m]")
    mass = sig.twinx()
    mass.plot(t, result.payload[keep], color="tab:green", lw=1.2, label="m_p [kg]")
    mass.set_ylabel("m_p [kg]", color="tab:green")
    sig.set_xlabel("time t [s]")
    _legend_right(err)
    _legend_right(trq)
    _legend_right(sig, sig.get_lines() + mass.get_lines(), gap=1.09)
    fig.suptitle(title or f"{result.controller}, scenario {result.scenario}")
    fig.tight_layout()
    return fig


def plot_signals(
    results: Sequence[SimulationResult],
    signal: str = "error",
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
    t_start: float = 0.0,
    t_end: float | None = None,
) -> Any:
    """One panel per simulation, stacked, for one quantity (the layout of Figures 4 and 5).

    Parameters
    ----------
    results : sequence of SimulationResult
        The runs to show, one panel each, top to bottom.
    signal : {'error', 'torque'}
        ``'error'``: e1 (dash-dot) and e2 (solid) in rad, and a last panel with the
        disturbance torque in N·m (Figure 4). ``'torque'``: Tc1 (dash-dot) and Tc2
        (solid) in N·m (Figure 5).
    labels : sequence of str, optional
        Panel titles, one per result (default: controller and scenario names).
    title : str, optional
        Figure title.
    t_start, t_end : float
        Draw ``t_start <= t <= t_end``, s; a window of tens of ms shows a sampled law's
        switching.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    check_choice("signal", signal, tuple(SIGNALS))
    results = list(results)
    if not results:
        raise ArgumentValueError("results", "must hold at least one SimulationResult, found none")
    if labels is None:
        labels = [f"{r.controller}, scenario {r.scenario}" for r in results]
    elif len(labels) != len(results):
        raise ArgumentValueError("labels", f"must have one entry per result ({len(results)}), found {len(labels)}")
    extra = 1 if signal == "error" else 0
    ratios = [3] * len(results) + [1.4] * extra
    fig, axes = plt.subplots(len(results) + extra, 1, figsize=(9.5, 2.6 * len(results) + 1.6 * extra), sharex=True,
                             squeeze=False, gridspec_kw={"height_ratios": ratios})
    names = ("e1 [rad]", "e2 [rad]") if signal == "error" else ("Tc1 [N·m]", "Tc2 [N·m]")
    for ax, result, label in zip(axes[:, 0], results, labels):
        keep = _window(result, t_start, t_end)
        t = result.t[keep]
        data = result.e if signal == "error" else result.torque
        step = "post" if result.method == "rk4" and signal == "torque" else None
        if step:  # a sampled controller holds its torque over each step
            ax.step(t, data[0, keep], "-.", where="post", label=names[0])
            ax.step(t, data[1, keep], "-", where="post", label=names[1])
        else:
            ax.plot(t, data[0, keep], "-.", label=names[0])
            ax.plot(t, data[1, keep], "-", label=names[1])
        ax.set_ylabel(SIGNALS[signal])
        if signal == "torque":
            _torque_limits(ax, t, data[:, keep])
        ax.set_title(label, fontsize=10)
        _legend_right(ax)
    if extra:
        ax = axes[-1, 0]
        keep = _window(results[0], t_start, t_end)
        ax.plot(results[0].t[keep], results[0].disturbance[0, keep], color="0.45", lw=0.8, label="Td1 = Td2 [N·m]")
        ax.set_ylabel("Td [N·m]")
        _legend_right(ax)
    axes[-1, 0].set_xlabel("time t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_comparison(table: Any, *, bounds: dict[str, float] | None = None) -> Any:
    """Bars of the comparison metrics per controller and scenario (a :func:`scara_robust.compare_controllers` table).

    Parameters
    ----------
    table : pandas.DataFrame
        With columns ``controller``, ``scenario``, ``payload`` and the metrics.
    bounds : dict of str to float, optional
        Metric → the paper's bound for the PID, drawn as a short red segment over the PID
        bars only (default: 0.02 rad and 7.5 N·m after 6 s, Figures 3 and 6).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    bounds = {"max_abs_error_after_6s": 0.02, "max_abs_torque_after_6s": 7.5} if bounds is None else bounds
    panels = [
        ("max_abs_error_after_6s", "max |e| after 6 s [rad]", False),
        ("max_abs_torque_after_6s", "max |Tc| after 6 s [N·m]", False),
        ("chattering_index", "chattering index [N·m/s] (log)", True),
    ]
    controllers = list(dict.fromkeys(table["controller"]))
    scenarios = list(dict.fromkeys(table["scenario"]))
    width = 0.8 / len(scenarios)
    fig, axes = plt.subplots(1, len(panels), figsize=(14, 4.2))
    for ax, (metric, label, log) in zip(axes, panels):
        for s_index, scenario in enumerate(scenarios):
            rows = table[table["scenario"] == scenario].set_index("controller").reindex(controllers)
            x = np.arange(len(controllers)) + (s_index - (len(scenarios) - 1) / 2) * width
            ax.bar(x, rows[metric].astype(float), width=width, label=f"{scenario} initial condition")
        if metric in bounds and "pid" in controllers:
            i = controllers.index("pid")
            ax.hlines(bounds[metric], i - 0.45, i + 0.45, color="red", lw=2,
                      label=f"paper's PID bound {bounds[metric]:g} {label.split('[')[1].split(']')[0]}")
        ax.set_xticks(range(len(controllers)), controllers)
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
            _plain_log_ticks(ax)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    payload = ", ".join(sorted(set(map(str, table["payload"])))) if "payload" in table else "?"
    fig.suptitle(f"PID against sliding-mode control: metrics of 20-s runs, payload {payload}")
    fig.tight_layout()
    return fig


def _plain_log_ticks(ax: Any) -> None:
    """Decimal tick labels at 1, 2, 5 × 10^k on a log axis (``0.02``, ``50``), not ``10⁻²`` or ``9.8×10⁰``."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def plot_campaign(results: Any) -> Any:
    """Distributions of a campaign's metrics per controller (box plots; log scale where they span 20x).

    Parameters
    ----------
    results : pandas.DataFrame
        A table from :func:`scara_robust.run_campaign`; failed runs are left out and
        counted in the titles.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    panels = [
        ("max_abs_error_after_6s", "max |e| after 6 s [rad]"),
        ("max_abs_torque_after_6s", "max |Tc| after 6 s [N·m]"),
    ]
    names = sorted(results["controller"].unique())
    fig, axes = plt.subplots(1, len(panels), figsize=(11, 4))
    for ax, (metric, label) in zip(axes, panels):
        data, ticks = [], []
        for name in names:
            group = results[results["controller"] == name]
            ok = group[group["success"].astype(bool)][metric].astype(float).dropna()
            data.append(ok.to_numpy())
            if "status" in group:
                tracking = int((group["status"] == "tracking").sum())
                ticks.append(f"{name}\n({tracking} tracking, {len(group) - tracking} not)")
            else:
                ticks.append(f"{name}\n({len(ok)} ok, {len(group) - len(ok)} failed)")
        ax.boxplot(data, whis=(5, 95))
        ax.set_xticks(range(1, len(ticks) + 1), ticks)
        values = np.concatenate([d for d in data if len(d)]) if any(len(d) for d in data) else np.ones(1)
        values = values[values > 0]
        if values.size and values.max() > 20 * values.min():  # a log scale only where the data span one
            ax.set_yscale("log")
            _plain_log_ticks(ax)
            label = label.replace("]", "] (log)")
        ax.set_ylabel(label)
        ax.set_title(label.split(" [")[0] + ", per controller (whiskers 5-95 %)", fontsize=10)
    n = results["scenario"].nunique() if "scenario" in results else len(results)
    fig.suptitle(f"Monte-Carlo campaign: {n} scenarios")
    fig.tight_layout()
    return fig


def plot_margin_map(surface: DesignSurface, mark: tuple[float, float] | None = None, ax: Any = None) -> Any:
    """Filled contours of the robustness margin θ(ρ, η) of a :func:`scara_robust.design_surface`.

    Parameters
    ----------
    surface : DesignSurface
        Computed with ``measure='margin'``.
    mark : tuple of float, optional
        ``(rho, eta)`` to mark with a star (for instance the paper's (3, 90)).
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if surface.margin is None:
        raise ArgumentValueError("surface", "has no margins: compute it with design_surface(..., measure='margin')")
    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 4.8))
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    values = np.where(np.isfinite(surface.margin), surface.margin, np.nan)
    # the scale runs from the 5th percentile up, so a thin low corner does not wash out the rest
    lo, hi = float(np.nanquantile(values, 0.05)), float(np.nanmax(values))
    levels = np.linspace(lo, hi if hi > lo else lo + 1e-9, 16)
    cs = ax.contourf(R, H, values, levels=levels, cmap="viridis", extend="min")
    lines = ax.contour(R, H, values, levels=levels[::3], colors="k", linewidths=0.5)
    ax.clabel(lines, fmt="%.3g", fontsize=7)
    ax.figure.colorbar(cs, ax=ax, label=f"margin θ [-] ({surface.margin_method})", format="%.3g")
    i, k = np.unravel_index(int(np.nanargmax(values)), values.shape)
    handles = [ax.plot(surface.rhos[i], surface.etas[k], "wo", markeredgecolor="k", markersize=8, clip_on=False,
                       label=f"largest: θ = {values[i, k]:.3g} at ({surface.rhos[i]:g}, {surface.etas[k]:g})")[0]]
    if mark is not None:
        handles.append(ax.plot(*mark, "r*", markersize=12, label=f"(ρ, η) = ({mark[0]:g}, {mark[1]:g})")[0])
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=8, frameon=False)
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_title(f"Robustness margin θ(ρ, η) — {surface.model_name}, elements: {surface.elements}", fontsize=10)
    return ax


def plot_margin_bracket(tables: dict[str, Any], ax: Any = None) -> Any:
    """Each margin as a marker, and the bracket [best lower, best upper] as a bar, per uncertainty set.

    Parameters
    ----------
    tables : dict of str to pandas.DataFrame
        Label → a table of :func:`scara_robust.margin_table`.
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if not tables:
        raise ArgumentValueError("tables", "must hold at least one margin table, found none")
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 1.2 + 0.9 * len(tables)))
    markers = {"theorem1": "o", "vertex": "s", "lmi": "D", "frozen": "x", "falsifier": "+"}
    for y, table in enumerate(tables.values()):
        rows = table.set_index("method")
        lo, hi = float(rows.loc["bracket", "lo"]), float(rows.loc["bracket", "hi"])
        ax.barh(y, hi - lo if np.isfinite(hi) else 0.0, left=lo, height=0.35, color="tab:orange", alpha=0.5,
                label="bracket on the true margin" if y == 0 else None)
        for method, marker in markers.items():
            if method in rows.index and np.isfinite(rows.loc[method, "theta"]):
                ax.plot(rows.loc[method, "theta"], y, marker, color="k" if rows.loc[method, "kind"] == "lower"
                        else "tab:red", markersize=8, linestyle="none",
                        label=f"{method} ({rows.loc[method, 'kind']} bound)" if y == 0 else None)
    ax.set_yticks(range(len(tables)), list(tables))
    ax.set_ylim(-0.6, len(tables) - 0.4)
    ax.set_xlabel("θ: scaling of every uncertain range about the nominal [-]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.set_title("Robustness margins: lower bounds (black), upper bounds (red)", fontsize=10)
    return ax


def plot_anti_windup(study: AntiWindupStudy, torque_limit: float, *, t_torque: float = 2.0) -> Any:
    """Errors and torques of the sampled PID at one torque limit, with and without anti-windup.

    Parameters
    ----------
    study : AntiWindupStudy
        From :func:`scara_robust.anti_windup_study`.
    torque_limit : float
        One of the study's limits, N·m.
    t_torque : float
        The torque panels show ``[0, t_torque]`` s, where the limit is active.

    Returns
    -------
    matplotlib.figure.Figure
        Top: e1, e2 [rad] over the run, with the settling band; bottom: Tc1, Tc2 [N·m];
        the legend below the panels.
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    keys = {
        "no limit": ("0.55", "-", "no limit"),
        f"limit {torque_limit:g} N·m, no anti-windup": (
            "tab:red", "--", f"|Tc| ≤ {torque_limit:g} N·m, no anti-windup"
        ),
        f"limit {torque_limit:g} N·m, anti-windup": ("tab:blue", "-", f"|Tc| ≤ {torque_limit:g} N·m, back-calculation"),
    }
    missing = [k for k in keys if k not in study.runs]
    if missing:
        raise ArgumentValueError("torque_limit", f"must be a limit of the study, found {torque_limit:g} N·m")
    t_torque = check_real("t_torque", t_torque, positive=True)
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), constrained_layout=True)
    for key, (color, style, label) in keys.items():
        res = study.runs[key]
        for j in range(2):
            axes[0, j].plot(res.t, res.e[j], color=color, ls=style, lw=1.2, label=label)
            window = res.t <= t_torque
            axes[1, j].plot(res.t[window], res.torque[j, window], color=color, ls=style, lw=1.0, label=label)
    for j in range(2):
        for sign in (1, -1):
            axes[0, j].axhline(sign * study.band, color="k", lw=0.6, ls=":")
            axes[1, j].axhline(sign * torque_limit, color="k", lw=0.6, ls=":")
        axes[1, j].set_ylim(-2.5 * torque_limit, 2.5 * torque_limit)
        axes[0, j].set(xlabel="time t [s]", ylabel=f"error e{j + 1} [rad]", title=f"joint {j + 1}")
        axes[1, j].set(xlabel="time t [s]", ylabel=f"torque Tc{j + 1} [N·m]")
    handles = axes[0, 0].get_lines()[:3]
    bands = f"±{study.band:g} rad band / ±{torque_limit:g} N·m"
    handles += [Line2D([], [], color="k", lw=0.6, ls=":", label=bands)]
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(f"Sampled PID (Ts = {study.sample_time * 1e3:g} ms) under a torque limit "
                 "(the no-limit torque leaves the window at the start)", fontsize=10)
    return fig
