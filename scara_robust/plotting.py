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

__all__ = [
    "plot_surface",
    "plot_surface_contour",
    "plot_response",
    "plot_signals",
    "plot_campaign",
    "plot_margin_map",
    "plot_margin_bracket",
    "SIGNALS",
]

#: Quantities :func:`plot_signals` draws, with their axis labels.
SIGNALS = {"error": "joint error [rad]", "torque": "control torque [N·m]"}


def plot_surface(surface: DesignSurface, mark: tuple[float, float] | None = None, ax: Any = None) -> Any:
    """3D graph of ``max λ(Z)`` over (ρ, η), like the paper's Figure 2.

    Parameters
    ----------
    surface : DesignSurface
    mark : tuple of float, optional
        ``(rho, eta)`` to mark with a sphere-like marker; it is placed at the nearest
        grid point.
    ax : mpl_toolkits.mplot3d.Axes3D, optional
        Axes to draw into (default: a new figure).

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=(7, 5))
        # computed_zorder=False keeps the marker drawn above the surface
        ax = fig.add_subplot(projection="3d", computed_zorder=False)
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    ax.plot_surface(R, H, surface.max_eig, cmap="viridis", linewidth=0, antialiased=True, alpha=0.9)
    if mark is not None:
        i = int(np.argmin(np.abs(surface.rhos - mark[0])))
        k = int(np.argmin(np.abs(surface.etas - mark[1])))
        z = surface.max_eig[i, k]
        ax.scatter(
            [surface.rhos[i]],
            [surface.etas[k]],
            [z],
            color="red",
            s=60,
            depthshade=False,
            zorder=10,
            label=f"(ρ, η) = ({surface.rhos[i]:g}, {surface.etas[k]:g}): max λ(Z) = {z:.3g}",
        )
        ax.legend(loc="upper left")
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_zlabel("max λ(Z) [-]")
    ax.set_title(f"Figure 2: max λ(Z) over (ρ, η) — {surface.model_name}, elements: {surface.elements}")
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


def _window(result: SimulationResult, t_start: float) -> Any:
    t_start = check_real("t_start", t_start, nonnegative=True)
    keep = result.t >= t_start
    if not keep.any():
        raise ValueError(f"`t_start` must be at most the final time {result.t[-1]:g} s, found {t_start:g}")
    return keep


def plot_response(result: SimulationResult, *, title: str | None = None, t_start: float = 0.0) -> Any:
    """Two panels laid out like the paper's Figure 3.

    Upper: errors e1 (dash-dot) and e2 (solid) in rad on the left axis; disturbance
    torques (N·m) and payload mass (kg) on the right axis. Lower: control torques
    Tc1 (dash-dot) and Tc2 (solid) in N·m.

    Parameters
    ----------
    result : SimulationResult
    title : str, optional
        Figure title (default: controller and scenario names).
    t_start : float
        Draw from this time on, s (e.g. 6 to see the bounds after the transient).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    keep = _window(result, t_start)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = result.t[keep]
    top.plot(t, result.e[0, keep], "-.", label="e1 [rad]")
    top.plot(t, result.e[1, keep], "-", label="e2 [rad]")
    top.set_ylabel("joint error [rad]")
    right = top.twinx()
    right.plot(t, result.disturbance[0, keep], color="0.6", lw=0.8, label="Td1, Td2 [N·m]")
    right.plot(t, result.payload[keep], color="tab:green", lw=1.0, label="m_p [kg]")
    right.set_ylabel("Td [N·m], m_p [kg]")
    lines = top.get_lines() + right.get_lines()
    top.legend(lines, [ln.get_label() for ln in lines], loc="upper right", fontsize=8)
    bottom.plot(t, result.torque[0, keep], "-.", label="Tc1")
    bottom.plot(t, result.torque[1, keep], "-", label="Tc2")
    bottom.set_xlabel("time t [s]")
    bottom.set_ylabel("control torque [N·m]")
    bottom.legend(loc="upper right", fontsize=8)
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
) -> Any:
    """One panel per simulation, stacked, for one quantity (the layout of Figures 4 and 5).

    Parameters
    ----------
    results : sequence of SimulationResult
        The runs to show, one panel each, top to bottom.
    signal : {'error', 'torque'}
        ``'error'``: e1 (dash-dot) and e2 (solid) in rad, with the disturbance torque in
        N·m on a right axis (Figure 4). ``'torque'``: Tc1 (dash-dot) and Tc2 (solid) in
        N·m (Figure 5).
    labels : sequence of str, optional
        Panel titles, one per result (default: controller and scenario names).
    title : str, optional
        Figure title.
    t_start : float
        Draw from this time on, s.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    check_choice("signal", signal, tuple(SIGNALS))
    results = list(results)
    if not results:
        raise ValueError("`results` must hold at least one SimulationResult, found none")
    if labels is None:
        labels = [f"{r.controller}, scenario {r.scenario}" for r in results]
    elif len(labels) != len(results):
        raise ValueError(f"`labels` must have one entry per result ({len(results)}), found {len(labels)}")
    fig, axes = plt.subplots(len(results), 1, figsize=(8, 2.8 * len(results)), sharex=True, squeeze=False)
    for ax, result, label in zip(axes[:, 0], results, labels):
        keep = _window(result, t_start)
        t = result.t[keep]
        data, names = (result.e, ("e1", "e2")) if signal == "error" else (result.torque, ("Tc1", "Tc2"))
        ax.plot(t, data[0, keep], "-.", label=names[0])
        ax.plot(t, data[1, keep], "-", label=names[1])
        ax.set_ylabel(SIGNALS[signal])
        ax.set_title(label, fontsize=10)
        lines = ax.get_lines()
        if signal == "error":
            right = ax.twinx()
            right.plot(t, result.disturbance[0, keep], color="0.6", lw=0.8, label="Td1, Td2")
            right.set_ylabel("Td [N·m]")
            lines = lines + right.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_campaign(results: Any) -> Any:
    """Distributions of a campaign's metrics per controller (box plots, log scale).

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
            ticks.append(f"{name}\n({len(ok)} ok, {len(group) - len(ok)} failed)")
        ax.boxplot(data, whis=(5, 95))
        ax.set_xticks(range(1, len(ticks) + 1), ticks)
        ax.set_yscale("log")
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
