"""Matplotlib figures. Nothing here computes: every function draws a result object.

Every axis label carries its unit in brackets (``[rad]``, ``[N·m]``, ``[kg]``, ``[s]``;
``[-]`` for a dimensionless quantity) and so does every legend entry of a quantity; legends
sit beside or below the axes rather than on the data, and the figures are sized to be read
at about 800 pixels wide.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ._validation import check_choice, check_real
from .exceptions import ArgumentValueError
from .paper import PAPER_TRANSIENT
from .robustness.registry import analysis_methods

if TYPE_CHECKING:
    from .controller.scheduled import ScheduledGain
    from .lyapunov.surface import DesignSurface
    from .model.plant import UncertainPlant
    from .robustness.loop_margins import LoopMargins, LoopView
    from .simulation.arm import ArmRun
    from .simulation.plants import PlantRun
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
    "plot_plant_run",
    "plot_arm_run",
    "plot_schedule",
    "plot_loop_views",
]

#: Quantities :func:`plot_signals` draws, with their axis labels.
SIGNALS = {"error": "joint error [rad]", "torque": "control torque [N·m]"}

#: Markers of the margin methods, in the registry's order.
_MARGIN_MARKERS = ("o", "s", "D", "x", "+", "^", "v", "<", ">", "*")

#: Legend text size, pt (figures are 7-11 inches wide: 10 pt is about 12 px at 800 px wide).
_LEGEND_SIZE = 10
#: A window this long or shorter is labelled in milliseconds from its start, s.
_MS_WINDOW = 0.2


def _plain(value: float, digits: int = 3) -> str:
    """`value` in plain decimals with `digits` significant digits: ``0.0223``, ``1240``, never ``1.24e+03``."""
    if value == 0 or not np.isfinite(value):
        return f"{value:g}"
    return str(np.format_float_positional(value, precision=digits, unique=True, fractional=False, trim="-"))


def _plain_formatter(digits: int = 3) -> Any:
    from matplotlib.ticker import FuncFormatter

    return FuncFormatter(lambda v, _: _plain(v, digits).replace("-", "\N{MINUS SIGN}"))  # as matplotlib's ticks


def _check_quantile(clip_quantile: float) -> float:
    clip_quantile = check_real("clip_quantile", clip_quantile, positive=True)
    if clip_quantile > 1:
        raise ArgumentValueError("clip_quantile", f"must be in (0, 1], found {clip_quantile:g}")
    return clip_quantile


def _clip_level(values: Any, clip_quantile: float) -> float | None:
    """The level to draw `values` up to, or None when nothing sticks out.

    Values above the `clip_quantile` quantile are drawn at it only when the largest one
    lies more than a quarter of the drawn range above it (a spike such as max λ(Z) as
    ρ → 0); a surface without a spike is drawn whole.
    """
    top = float(np.quantile(values, clip_quantile))
    low = float(np.min(values))
    if clip_quantile < 1 and float(np.max(values)) > top + 0.25 * max(top - low, abs(top), 1e-12):
        return top
    return None


def _zero_centred(lo: float, hi: float) -> tuple[Any, Any]:
    """Colour map and norm with blue below zero and red above, white at zero (max λ(Z) = 0)."""
    import matplotlib as mpl
    from matplotlib.colors import ListedColormap, Normalize, TwoSlopeNorm

    base = mpl.colormaps["RdBu_r"]
    if lo < 0 < hi:
        return base, TwoSlopeNorm(vcenter=0.0, vmin=lo, vmax=hi)
    if hi <= 0:  # all certified: the blue half only
        return ListedColormap(base(np.linspace(0.0, 0.5, 128))), Normalize(vmin=lo, vmax=0.0)
    return ListedColormap(base(np.linspace(0.5, 1.0, 128))), Normalize(vmin=0.0, vmax=hi)


def _design_label(rho: float, eta: float) -> str:
    return f"(ρ, η) = ({rho:g}, {eta:g})"


def plot_surface(
    surface: DesignSurface,
    mark: tuple[float, float] | None = None,
    ax: Any = None,
    *,
    clip_quantile: float = 0.95,
    view: tuple[float, float] = (30.0, 15.0),
) -> Any:
    """3D graph of ``max λ(Z)`` over (ρ, η), like the paper's Figure 2, with the certified region shown.

    The colours are centred on zero (blue: max λ(Z) < 0, red: > 0), the z = 0 plane is
    drawn (translucent grey) with the zero contour on it (black), and the certified grid
    points (Ā Hurwitz and max λ(Z) < 0) are filled in green on the floor. When the
    surface has a spike (max λ(Z) grows without bound as ρ → 0), values above the
    `clip_quantile` quantile are drawn at that level so the negative region keeps its
    extent; the title says so and the colour bar ends in a triangle.

    Parameters
    ----------
    surface : DesignSurface
    mark : tuple of float, optional
        ``(rho, eta)`` to mark; it is placed at the nearest grid point.
    ax : mpl_toolkits.mplot3d.Axes3D, optional
        Axes to draw into (default: a new figure), created with ``computed_zorder=False``:
        the parts are drawn in call order, the part of the surface below z = 0 first.
    clip_quantile : float
        In (0, 1]; 1 draws every value as it is.
    view : tuple of float
        ``(elevation, azimuth)`` of the camera, degrees. The default looks from large ρ,
        where the certified region usually lies, so the ρ → 0 spike stands behind it
        and the η → 1 edge to its left.

    Returns
    -------
    mpl_toolkits.mplot3d.Axes3D
    """
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    clip_quantile = _check_quantile(clip_quantile)
    if len(view) != 2:
        raise ArgumentValueError("view", f"must be (elevation, azimuth) in degrees, found {view!r}")
    elevation, azimuth = (check_real("view", angle) for angle in view)
    if ax is None:
        fig = plt.figure(figsize=(8, 7))
        # computed_zorder=False: call order is drawing order (mplot3d sorts whole collections,
        # so a surface crossing the z = 0 plane is drawn in two parts around it)
        ax = fig.add_subplot(projection="3d", computed_zorder=False)
        fig.subplots_adjust(left=0.0, right=0.92, bottom=0.2, top=0.9)  # room for the legend below, title above
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    Z = surface.max_eig
    top = _clip_level(Z, clip_quantile)
    Zc = Z if top is None else np.minimum(Z, top)
    lo, hi = float(Zc.min()), float(Zc.max())
    span = max(hi, 0.0) - min(lo, 0.0) or 1.0
    floor = min(lo, 0.0) - 0.08 * span
    cmap, norm = _zero_centred(lo, hi)
    colors = cmap(norm(Zc))
    # a cell is drawn with its first corner's colour; it belongs to the lower part when any corner is <= 0
    corner = np.stack([Zc[:-1, :-1], Zc[1:, :-1], Zc[:-1, 1:], Zc[1:, 1:]])
    lower_cell = np.zeros(Zc.shape, dtype=bool)
    lower_cell[:-1, :-1] = (corner <= 0).any(axis=0)
    upper_cell = np.zeros(Zc.shape, dtype=bool)
    upper_cell[:-1, :-1] = (corner > 0).any(axis=0)

    certified = surface.certified
    if certified.any():
        ax.contourf(R, H, np.where(certified, 1.0, 0.0), levels=[0.5, 1.5], zdir="z", offset=floor,
                    colors=["tab:green"], alpha=0.55)
    if lower_cell.any():
        ax.plot_surface(R, H, Zc, facecolors=np.where(lower_cell[..., None], colors, 0.0), linewidth=0,
                        antialiased=False, shade=False)
    ax.plot_surface(R, H, np.zeros_like(Zc), color="0.55", alpha=0.3, linewidth=0, shade=False).set_gid("zero plane")
    if upper_cell.any():
        ax.plot_surface(R, H, Zc, facecolors=np.where(upper_cell[..., None], colors, 0.0), linewidth=0,
                        antialiased=False, shade=False)
    handles: list[Any] = [Patch(color="0.55", alpha=0.45, label="plane max λ(Z) = 0 [-]")]
    if lo < 0 < hi:
        ax.contour(R, H, Zc, levels=[0.0], colors="k", linewidths=2.0, zdir="z", offset=0.0)
        handles.append(Line2D([], [], color="k", lw=2.0, label="max λ(Z) = 0 [-] on the surface"))
    elif lo > 0:
        handles.append(Patch(color=cmap(0.6),
                             label=f"max λ(Z) ≥ {_plain(lo)} [-] on the whole grid: nothing certified"))
    handles.append(Patch(color="tab:green", alpha=0.55, label=(
        f"certified (max λ(Z) < 0 [-], Ā Hurwitz), on the floor: {int(certified.sum())} of {certified.size} "
        "grid points")))
    ax.set_zlim(floor, max(hi, 0.0) + 0.04 * span)
    ax.view_init(elev=elevation, azim=azimuth)
    mappable = ScalarMappable(norm=norm, cmap=cmap)
    cbar = ax.figure.colorbar(mappable, ax=ax, shrink=0.55, pad=0.1, extend="max" if top is not None else "neither",
                              label="max λ(Z) [-]")
    if lo < 0 < hi:
        cbar.ax.axhline(0.0, color="k", lw=1.5)
    if mark is not None:
        i = int(np.argmin(np.abs(surface.rhos - mark[0])))
        k = int(np.argmin(np.abs(surface.etas - mark[1])))
        z = float(surface.max_eig[i, k])
        zc = float(Zc[i, k])
        handles.append(ax.scatter(
            [surface.rhos[i]], [surface.etas[k]], [zc], s=70, facecolor="yellow", edgecolor="k", linewidths=1.2,
            depthshade=False, label=f"{_design_label(surface.rhos[i], surface.etas[k])}: max λ(Z) = {_plain(z)} [-]",
        ))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=1, fontsize=_LEGEND_SIZE,
              frameon=False)
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.zaxis.set_rotate_label(False)  # read bottom to top, whatever the view
    ax.set_zlabel("max λ(Z) [-]", rotation=90)
    title = f"Figure 2: max λ(Z) over (ρ, η) — {surface.model_name}, elements: {surface.elements}"
    if top is not None:
        title += (f"\nz axis clipped at {_plain(top)} [-], the {100 * clip_quantile:g}th percentile "
                  f"(grid maximum {_plain(float(Z.max()))} [-])")
    ax.set_title(title, fontsize=10)
    return ax


def plot_surface_contour(
    surface: DesignSurface,
    mark: tuple[float, float] | None = None,
    ax: Any = None,
    *,
    clip_quantile: float = 0.95,
) -> Any:
    """Contour view of ``max λ(Z)`` with the certified region (max λ(Z) < 0) hatched.

    Colours are centred on zero (blue below, red above); the zero contour is the black
    line labelled on the plot. When the surface has a spike (ρ → 0), the colour scale
    stops at the `clip_quantile` quantile and higher values share the top colour (the
    colour bar ends in a triangle and its label gives the grid maximum).

    Parameters
    ----------
    surface : DesignSurface
    mark : tuple of float, optional
        ``(rho, eta)`` to mark with a star.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    clip_quantile : float
        In (0, 1]; 1 spreads the colours over every value.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle
    from matplotlib.ticker import MaxNLocator

    clip_quantile = _check_quantile(clip_quantile)
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5.2))
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    Z = surface.max_eig
    top = _clip_level(Z, clip_quantile)
    lo = float(Z.min())
    hi = float(Z.max()) if top is None else top
    levels = MaxNLocator(nbins=16).tick_values(lo, hi if hi > lo else lo + 1.0)
    cmap, norm = _zero_centred(float(levels[0]), float(levels[-1]))
    cs = ax.contourf(R, H, Z, levels=levels, cmap=cmap, norm=norm, extend="max" if top is not None else "neither")
    label = "max λ(Z) [-]"
    if top is not None:
        label += f" (▲: above {_plain(float(levels[-1]))}, up to {_plain(float(Z.max()))})"
    cbar = ax.figure.colorbar(cs, ax=ax, label=label, format=_plain_formatter())
    handles = []
    if surface.certified.any():
        ax.contourf(R, H, np.where(surface.certified, 1.0, 0.0), levels=[0.5, 1.5], colors="none", hatches=["//"])
        handles.append(Rectangle((0, 0), 1, 1, fill=False, hatch="//", label="max λ(Z) < 0 (certified)"))
    else:
        handles.append(Rectangle((0, 0), 1, 1, fill=False, lw=0, label="no grid point has max λ(Z) < 0"))
    if lo < 0 < float(Z.max()):
        zero = ax.contour(R, H, Z, levels=[0.0], colors="k", linewidths=2)
        ax.clabel(zero, fmt={0.0: "max λ(Z) = 0"}, fontsize=8, inline=True)
        cbar.ax.axhline(0.0, color="k", lw=2)
    if mark is not None:
        (star,) = ax.plot(*mark, "*", color="yellow", markeredgecolor="k", markersize=14,
                          label=_design_label(*mark))
        handles.append(star)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=_LEGEND_SIZE,
              frameon=False)
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_title(f"max λ(Z) < 0 region — {surface.model_name}, elements: {surface.elements}", fontsize=10)
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


def _legend_right(ax: Any, handles: Any = None) -> None:
    """Legend outside the axes, on the right, in the order the lines were drawn."""
    handles = [h for h in (ax.get_lines() if handles is None else handles) if not h.get_label().startswith("_")]
    ax.legend(handles, [h.get_label() for h in handles], loc="upper left", bbox_to_anchor=(1.01, 1.0),
              fontsize=_LEGEND_SIZE, frameon=False, handlelength=2.2)


def _torque_limits(ax: Any, t: Any, torque: Any, keep_visible: float = 0.0) -> Any:
    """Scale the torque axis to the steady torques (and `keep_visible`); mark where an initial spike leaves it.

    Returns the marker (with its legend entry: the peak, its time and unit) or None.
    """
    magnitude = np.abs(torque).max(axis=0)
    steady = float(np.quantile(magnitude, 0.98))
    peak = float(magnitude.max())
    limit = max(1.3 * steady, 1.1 * keep_visible)
    if not peak > max(3 * steady, limit) > 0:
        return None
    ax.set_ylim(-limit, limit)
    i = int(np.argmax(magnitude))
    j = int(np.argmax(np.abs(torque[:, i])))
    up = torque[j, i] > 0
    (marker,) = ax.plot([t[i]], [limit if up else -limit], "^" if up else "v", color="k", markersize=8,
                        clip_on=False, zorder=5, linestyle="none",
                        label=f"peak Tc{j + 1} = {_plain(float(torque[j, i]), 4)} N·m\nat t = {t[i]:.3g} s (off scale)")
    return marker


def _bound_lines(ax: Any, bound: float, t0: float, t1: float, label: str, style: str = ":") -> Any:
    (line,) = ax.plot([t0, t1], [bound, bound], color="red", lw=1.3, ls=style, label=label)
    ax.plot([t0, t1], [-bound, -bound], color="red", lw=1.3, ls=style, label="_" + label)
    return line


def _time_axis(ax: Any, t0: float, t1: float) -> None:
    """Label the time axis; a window of 0.2 s or less is read in ms from its start."""
    if t1 - t0 <= _MS_WINDOW:
        from matplotlib.ticker import FuncFormatter

        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{1000 * (v - t0):.0f}"))
        ax.set_xlabel(f"time t − {t0:g} s [ms]")
    else:
        ax.set_xlabel("time t [s]")
    ax.set_xlim(t0, t1)


def _disturbance_panel(ax: Any, t: Any, disturbance: Any) -> None:
    if np.array_equal(disturbance[0], disturbance[1]):
        ax.plot(t, disturbance[0], color="0.35", lw=0.9, label="Td1 = Td2 [N·m]")
    else:
        ax.plot(t, disturbance[0], "-.", color="0.35", lw=0.9, label="Td1 [N·m]")
        ax.plot(t, disturbance[1], "-", color="0.6", lw=0.9, label="Td2 [N·m]")
    amplitude = float(np.abs(disturbance).max()) or 1.0
    ax.set_ylim(-1.35 * amplitude, 1.35 * amplitude)
    ax.set_ylabel("Td [N·m]")


def plot_response(
    result: SimulationResult,
    *,
    title: str | None = None,
    t_start: float = 0.0,
    t_end: float | None = None,
    bounds: tuple[float | None, float | None] | None = None,
    bounds_after: float = 0.0,
    initial_torque_bound: float | None = None,
) -> Any:
    """Four panels for one run: errors, control torques, the disturbance, and the payload.

    The paper's Figures 3 and 6 draw the disturbance (×0.01) and the payload (×0.04)
    beside the errors; here each has a panel of its own with its own unit, so neither
    hides the errors. The torque axis is scaled to the steady torques; an initial spike
    beyond it is marked on the axis edge and written out in the legend.

    Parameters
    ----------
    result : SimulationResult
    title : str, optional
        Figure title (default: controller and scenario names).
    t_start, t_end : float
        Draw ``t_start <= t <= t_end``, s (default: the whole run).
    bounds : tuple of (float or None), optional
        ``(error bound [rad], torque bound [N·m])`` to draw as ± dotted red lines from
        `bounds_after` on (the paper's 0.02 rad and 7.5 N·m after 6 s, for instance).
    bounds_after : float
        Time from which `bounds` hold, s (the paper's :data:`scara_robust.PAPER_TRANSIENT`,
        6 s; default 0: the whole window).
    initial_torque_bound : float, optional
        A bound on the initial torques, N·m (the paper's 14.5 N·m for Figure 6), drawn as
        ± dashed red lines over the whole window.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes``: errors, torques, disturbance, payload.
    """
    import matplotlib.pyplot as plt

    keep = _window(result, t_start, t_end)
    bounds_after = check_real("bounds_after", bounds_after, nonnegative=True)
    fig, (err, trq, sig, mass) = plt.subplots(4, 1, figsize=(9, 8.2), sharex=True,
                                              gridspec_kw={"height_ratios": [3, 3, 1.1, 1.1]})
    t = result.t[keep]
    t0, t1 = float(t[0]), float(t[-1])
    err.plot(t, result.e[0, keep], "-.", label="e1 [rad]")
    err.plot(t, result.e[1, keep], "-", label="e2 [rad]")
    err.set_ylabel("joint error [rad]")
    trq.plot(t, result.torque[0, keep], "-.", label="Tc1 [N·m]")
    trq.plot(t, result.torque[1, keep], "-", label="Tc2 [N·m]")
    trq.set_ylabel("control torque [N·m]")
    drawn = [b for b in ((bounds or (None, None))[1], initial_torque_bound) if b is not None]
    peak = _torque_limits(trq, t, result.torque[:, keep], keep_visible=max(drawn, default=0.0))
    start = max(bounds_after, t0)
    after = f" for t ≥ {bounds_after:g} s" if bounds_after > t0 else ""
    if bounds is not None and start < t1:
        if bounds[0] is not None:
            _bound_lines(err, bounds[0], start, t1, f"bound ±{bounds[0]:g} rad{after}")
        if bounds[1] is not None:
            _bound_lines(trq, bounds[1], start, t1, f"bound ±{bounds[1]:g} N·m{after}")
    if initial_torque_bound is not None:
        _bound_lines(trq, initial_torque_bound, t0, t1, f"bound ±{initial_torque_bound:g} N·m (initial)", "--")
    if peak is not None:  # last in the legend, below the lines
        peak.remove()
        trq.add_line(peak)
    _disturbance_panel(sig, t, result.disturbance[:, keep])
    mass.plot(t, result.payload[keep], color="tab:green", lw=1.3, label="m_p [kg]")
    mass.set_ylabel("m_p [kg]")
    top = float(result.payload[keep].max())
    mass.set_ylim(-0.1 * (top or 1.0), 1.2 * (top or 1.0))
    _time_axis(mass, t0, t1)
    for ax in (err, trq, sig, mass):
        _legend_right(ax)
        ax.grid(True, lw=0.4, alpha=0.5)
    fig.align_ylabels()
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
    sharey: bool = False,
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
        Draw ``t_start <= t <= t_end``, s. A window of tens of ms shows a sampled law's
        switching; a window of 0.2 s or less is labelled in ms from `t_start`.
    sharey : bool
        One value scale for the panels of the runs (to compare their amplitudes); the
        torque scale is then not cut to the steady torques.

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
    ratios = [3] * len(results) + [1.2] * extra
    fig, axes = plt.subplots(len(results) + extra, 1, figsize=(9, 2.5 * len(results) + 1.4 * extra + 0.6),
                             sharex=True, squeeze=False, gridspec_kw={"height_ratios": ratios})
    panels = list(axes[:, 0])
    if sharey and len(results) > 1:
        for ax in panels[1 : len(results)]:
            ax.sharey(panels[0])
    names = ("e1 [rad]", "e2 [rad]") if signal == "error" else ("Tc1 [N·m]", "Tc2 [N·m]")
    t0, t1 = np.inf, -np.inf
    for ax, result, label in zip(panels, results, labels):
        keep = _window(result, t_start, t_end)
        t = result.t[keep]
        t0, t1 = min(t0, float(t[0])), max(t1, float(t[-1]))
        data = result.e if signal == "error" else result.torque
        if result.method == "rk4" and signal == "torque":  # a sampled controller holds its torque over each step
            ax.step(t, data[0, keep], "-.", where="post", label=names[0])
            ax.step(t, data[1, keep], "-", where="post", label=names[1])
        else:
            ax.plot(t, data[0, keep], "-.", label=names[0])
            ax.plot(t, data[1, keep], "-", label=names[1])
        ax.set_ylabel(SIGNALS[signal])
        if signal == "torque" and not sharey:
            _torque_limits(ax, t, data[:, keep])
        ax.set_title(label, fontsize=10)
    if extra:
        keep = _window(results[0], t_start, t_end)
        _disturbance_panel(panels[-1], results[0].t[keep], results[0].disturbance[:, keep])
    for ax in panels:
        _legend_right(ax)
        ax.grid(True, lw=0.4, alpha=0.5)
    _time_axis(panels[-1], t0, t1)
    fig.align_ylabels()
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_comparison(table: Any, *, bounds: dict[str, float] | None = None, title: str | None = None) -> Any:
    """Bars of the comparison metrics per controller and scenario (a :func:`scara_robust.compare_controllers` table).

    Parameters
    ----------
    table : pandas.DataFrame
        With columns ``controller``, ``scenario``, ``payload`` and the metrics.
    bounds : dict of str to float, optional
        Metric → the paper's bound for the PID, drawn as a short red segment over the PID
        bars only (default: 0.02 rad and 7.5 N·m after 6 s, Figures 3 and 6).
    title : str, optional
        Figure title (default: names the payload of the table's rows).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    bounds = {"max_abs_error_after_6s": 0.02, "max_abs_torque_after_6s": 7.5} if bounds is None else bounds
    after = f"after {PAPER_TRANSIENT:g} s"
    panels = [
        ("max_abs_error_after_6s", f"max |e| {after} [rad]", False),
        ("max_abs_torque_after_6s", f"max |Tc| {after} [N·m]", False),
        ("chattering_index", "chattering index [N·m/s] (log)", True),
    ]
    controllers = list(dict.fromkeys(table["controller"]))
    scenarios = list(dict.fromkeys(table["scenario"]))
    width = 0.8 / len(scenarios)
    fig, axes = plt.subplots(1, len(panels), figsize=(11, 4.4))
    handles: list[Any] = []
    for ax, (metric, label, log) in zip(axes, panels):
        for s_index, scenario in enumerate(scenarios):
            rows = table[table["scenario"] == scenario].set_index("controller").reindex(controllers)
            x = np.arange(len(controllers)) + (s_index - (len(scenarios) - 1) / 2) * width
            values = rows[metric].astype(float).to_numpy()
            bars = ax.bar(x, values, width=width, label=f"{scenario} initial condition")
            ax.bar_label(bars, labels=[_plain(v) if np.isfinite(v) else "" for v in values], fontsize=8, padding=3,
                         rotation=90)
            if ax is axes[0]:
                handles.append(bars)
        if metric in bounds and "pid" in controllers:
            i = controllers.index("pid")
            unit = label.split("[")[1].split("]")[0]
            ax.hlines(bounds[metric], i - 0.45, i + 0.45, color="red", lw=2.2,
                      label=f"paper's PID bound {bounds[metric]:g} {unit}")
        ax.set_xticks(range(len(controllers)), controllers)
        ax.set_xlabel("controller")
        ax.set_ylabel(label)
        ax.set_title(label.split(" [")[0], fontsize=10)
        if log:  # from the decade below the smallest bar, so every bar has a height; room above for the labels
            ax.set_yscale("log")
            positive = table[metric].astype(float).to_numpy()
            positive = positive[positive > 0]
            if positive.size:
                ax.set_ylim(10 ** np.floor(np.log10(positive.min())), ax.get_ylim()[1] * 4)
            _plain_log_ticks(ax)
        else:
            ax.set_ylim(top=ax.get_ylim()[1] * 1.25)
    text = ", ".join(f"{bounds[m]:g} {lab.split('[')[1].split(']')[0]}" for m, lab, _ in panels if m in bounds)
    if text and "pid" in controllers:
        handles.append(Line2D([], [], color="red", lw=2.2, label=f"paper's bound for the PID {after} ({text})"))
    fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.0), ncol=len(handles),
               fontsize=_LEGEND_SIZE, frameon=False)
    if title is None:
        payload = ", ".join(sorted(set(map(str, table["payload"])))) if "payload" in table else "?"
        title = f"PID against sliding-mode control, payload {payload}: metrics {after} (the transient)"
    fig.suptitle(title)
    fig.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))  # the legend below the panels, inside the figure
    return fig


def _plain_log_ticks(ax: Any) -> None:
    """Decimal tick labels at 1, 2, 5 × 10^k on a log axis (``0.02``, ``50``), not ``10⁻²`` or ``9.8×10⁰``."""
    from matplotlib.ticker import LogLocator, NullFormatter

    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(_plain_formatter())
    ax.yaxis.set_minor_formatter(NullFormatter())


#: Above this many runs per controller a campaign's figure shows their density, not every run.
_STRIP_RUNS = 200


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
        ("max_abs_error_after_6s", f"max |e| after {PAPER_TRANSIENT:g} s [rad]"),
        ("max_abs_torque_after_6s", f"max |Tc| after {PAPER_TRANSIENT:g} s [N·m]"),
    ]
    names = sorted(results["controller"].unique())
    many = bool((results.groupby("controller").size() > _STRIP_RUNS).any())
    fig, axes = plt.subplots(1, len(panels), figsize=(9, 4.6))
    for ax, (metric, label) in zip(axes, panels):
        data, ticks = [], []
        for name in names:
            group = results[results["controller"] == name]
            ok = group[group["success"].astype(bool)][metric].astype(float).dropna()
            data.append(ok.to_numpy())
            if "status" in group:
                tracking = int((group["status"] == "tracking").sum())
                ticks.append(f"{name}\n({tracking} tracking,\n{len(group) - tracking} not)")
            else:
                ticks.append(f"{name}\n({len(ok)} ok,\n{len(group) - len(ok)} failed)")
        ax.boxplot(data, whis=(5, 95), showfliers=False)  # the dots show the runs
        for x, values in enumerate(data, start=1):  # beside its box: every run, or density and the tails
            if many and len(values) > 1 and np.ptp(values) > 0:
                body = ax.violinplot(values, positions=[x + 0.3], widths=0.35, showextrema=False)
                for patch in body["bodies"]:
                    patch.set_facecolor("0.6")
                    patch.set_alpha(0.6)
                low, high = np.percentile(values, [5, 95])
                values = values[(values < low) | (values > high)]
            ax.plot(np.full(len(values), x + 0.3), values, "o", color="0.3", markersize=3, alpha=0.5)
        ax.set_xticks(range(1, len(ticks) + 1), ticks)
        values = np.concatenate([d for d in data if len(d)]) if any(len(d) for d in data) else np.ones(1)
        values = values[values > 0]
        if values.size and values.max() > 20 * values.min():  # a log scale only where the data span one
            ax.set_yscale("log")
            _plain_log_ticks(ax)
            label = label.replace("]", "] (log)")
        ax.set_ylabel(label)
        ax.grid(True, axis="y", lw=0.4, alpha=0.5)
        ax.set_title(label.split(" [")[0] + ", per controller", fontsize=10)
    n = results["scenario"].nunique() if "scenario" in results else len(results)
    dots = "shaded: density, dots: runs outside 5-95 %" if many else "dots: runs"
    fig.suptitle(f"Monte-Carlo campaign: {n} scenarios\n(box: quartiles, whiskers: 5-95 %, {dots})", fontsize=11)
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
    from matplotlib.ticker import MaxNLocator

    if surface.margin is None:
        raise ArgumentValueError("surface", "has no margins: compute it with design_surface(..., measure='margin')")
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5.2))
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    values = np.where(np.isfinite(surface.margin), surface.margin, np.nan)
    # the scale runs from the 5th percentile up, so a thin low corner does not wash out the rest
    lo, hi = float(np.nanquantile(values, 0.05)), float(np.nanmax(values))
    levels = MaxNLocator(nbins=10).tick_values(lo, hi if hi > lo else lo + 1e-9)
    cs = ax.contourf(R, H, values, levels=levels, cmap="viridis", extend="min")
    lines = ax.contour(R, H, values, levels=levels[1::2], colors="k", linewidths=0.5)
    ax.clabel(lines, fmt=lambda v: _plain(v), fontsize=8)
    ax.figure.colorbar(cs, ax=ax, label=f"margin θ [-] ({surface.margin_method})", format=_plain_formatter())
    i, k = np.unravel_index(int(np.nanargmax(values)), values.shape)
    handles = [ax.plot(surface.rhos[i], surface.etas[k], "wo", markeredgecolor="k", markersize=8, clip_on=False,
                       label=f"largest θ = {_plain(values[i, k])} [-] at "
                             f"{_design_label(surface.rhos[i], surface.etas[k])}")[0]]
    if mark is not None:
        handles.append(ax.plot(*mark, "*", color="yellow", markeredgecolor="k", markersize=14,
                               label=_design_label(*mark))[0])
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=_LEGEND_SIZE,
              frameon=False)
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_title(f"Robustness margin θ(ρ, η) — {surface.model_name}, elements: {surface.elements}", fontsize=10,
                 pad=10)
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
        _, ax = plt.subplots(figsize=(7, 1.4 + 0.9 * len(tables)))
    markers = dict(zip(analysis_methods("margin"), _MARGIN_MARKERS))  # one marker per registered method
    for y, table in enumerate(tables.values()):
        rows = table.set_index("method")
        lo, hi = float(rows.loc["bracket", "lo"]), float(rows.loc["bracket", "hi"])
        ax.barh(y, hi - lo if np.isfinite(hi) else 0.0, left=lo, height=0.35, color="tab:orange", alpha=0.5,
                label="bracket on the true margin θ [-]" if y == 0 else None)
        for method, marker in markers.items():
            if method in rows.index and np.isfinite(rows.loc[method, "theta"]):
                ax.plot(rows.loc[method, "theta"], y, marker, color="k" if rows.loc[method, "kind"] == "lower"
                        else "tab:red", markersize=8, linestyle="none",
                        label=f"{method}: {rows.loc[method, 'kind']} bound on θ [-]" if y == 0 else None)
    ax.set_yticks(range(len(tables)), list(tables))
    ax.set_ylim(-0.6, len(tables) - 0.4)
    ax.set_xlabel("θ: scaling of every uncertain range about the nominal [-]")
    ax.grid(True, axis="x", lw=0.4, alpha=0.5)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=_LEGEND_SIZE, frameon=False)
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
    fig.suptitle(f"Sampled PID (Ts = {study.Ts * 1e3:g} ms) under a torque limit "
                 "(the no-limit torque leaves the window at the start)", fontsize=10)
    return fig


def plot_plant_run(run: PlantRun, plant: UncertainPlant, *, title: str | None = None) -> Any:
    """Panels for one run of a plant: outputs and references, the tracking errors, the inputs, the parameters.

    Parameters
    ----------
    run : PlantRun
        From :func:`scara_robust.simulate_plant`.
    plant : UncertainPlant
        The plant simulated (names and units of the signals).
    title : str, optional
        Figure title (default: the plant's name and the run's status).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    varying = [k for k, p in enumerate(plant.parameters) if p.varies]
    n_panels = 3 + (1 if varying else 0)
    fig, axes = plt.subplots(n_panels, 1, figsize=(9, 2.2 * n_panels + 0.6), sharex=True, layout="constrained")
    t = run.t
    out_ax, err_ax, in_ax = axes[0], axes[1], axes[2]
    for k, sig in enumerate(plant.outputs):
        out_ax.plot(t, run.y[k], label=f"{sig.name} [{sig.unit}]")
        out_ax.plot(t, run.r[k], ":", label=f"{sig.name} reference [{sig.unit}]")
        err_ax.plot(t, run.e[k], label=f"e = {sig.name} reference − {sig.name} [{sig.unit}]")
    units = sorted({s.unit for s in plant.outputs})
    out_ax.set_ylabel(f"output [{', '.join(units)}]")
    err_ax.set_ylabel(f"tracking error [{', '.join(units)}]")
    err_ax.axhline(0.0, color="0.6", lw=0.8)
    # an initial kick (a step reference through K_P) would flatten the rest: scale to the
    # inputs after the first 5 % of the run and name the peak in the legend
    late = t >= t[0] + 0.05 * (t[-1] - t[0])
    late_lo, late_hi = float(run.u[:, late].min()), float(run.u[:, late].max())
    span = max(late_hi - late_lo, 1e-12 * max(1.0, float(np.abs(run.u).max())))
    clip = bool(np.abs(run.u).max() > max(abs(late_lo), abs(late_hi)) + 2 * span)
    for k, sig in enumerate(plant.inputs):
        peak = int(np.argmax(np.abs(run.u[k])))
        note = f" (peak {run.u[k, peak]:.3g} {sig.unit} at t = {t[peak]:.3g} s, off scale)" if clip else ""
        in_ax.plot(t, run.u[k], label=f"{sig.name} [{sig.unit}]{note}")
    if clip:
        in_ax.set_ylim(late_lo - 0.25 * span, late_hi + 0.25 * span)
    in_ax.set_ylabel(f"input [{', '.join(sorted({s.unit for s in plant.inputs}))}]")
    for ax in (out_ax, err_ax, in_ax):
        _legend_right(ax)
    if varying:
        p_ax = axes[3]
        for k in varying:
            prm = plant.parameters[k]
            p_ax.plot(t, run.p[k], label=f"{prm.name} [{prm.unit}]")
            p_ax.axhline(prm.range[0], color="0.6", ls="--", lw=0.8)
            p_ax.axhline(prm.range[1], color="0.6", ls="--", lw=0.8, label=f"{prm.name} range [{prm.unit}]")
        p_ax.set_ylabel("parameter [" + ", ".join(plant.parameters[k].unit for k in varying) + "]")
        _legend_right(p_ax)
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(t[0], t[-1])
    fig.suptitle(title or f"{plant.name}: {run.status}")
    return fig


def plot_arm_run(run: ArmRun, *, title: str | None = None) -> Any:
    """The joint errors, the joint torques and the payload of one arm run, over time.

    Parameters
    ----------
    run : ArmRun
        From :func:`scara_robust.simulate_arm`.
    title : str, optional
        Figure title (default: the run's status and its max |e| after the transient).

    Returns
    -------
    matplotlib.figure.Figure
        Three panels sharing the time axis: errors ``e_i = r_i − q_i`` [rad] (the window
        after the transient inset as its own scale), torques ``τ_i`` [N·m], payload
        ``m_p`` [kg].
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(10, 8.4), sharex=True, layout="constrained",
                             gridspec_kw={"height_ratios": [3, 3, 1.3]})
    err_ax, tau_ax, m_ax = axes
    t = run.t
    for i, joint in enumerate(run.joints):
        err_ax.plot(t, run.e[i], lw=1.1, label=f"e {joint} [rad]")
        tau_ax.plot(t, run.torque[i], lw=1.1, label=f"τ {joint} [N·m]")
    err_ax.axhline(0.0, color="0.6", lw=0.8)
    after = t >= run.t_transient
    if after.sum() >= 2:
        err_ax.axvline(run.t_transient, color="0.5", ls=":", lw=1.0)
        worst = float(np.abs(run.e[:, after]).max())
        err_ax.set_ylim(-1.6 * worst, 1.6 * worst)
        err_ax.text(0.01, 0.97, f"max |e| after {run.t_transient:g} s (dotted line) = {_plain(worst)} rad",
                    transform=err_ax.transAxes, va="top", fontsize=_LEGEND_SIZE)
        err_ax.set_ylabel("joint error [rad]\n(scale of the tracking phase)")
    else:
        err_ax.set_ylabel("joint error [rad]")
    tau_ax.set_ylabel("joint torque [N·m]")
    m_ax.plot(t, run.payload, color="k", lw=1.1, label="m_p [kg]")
    m_ax.set_ylabel("payload [kg]")
    for ax in axes:
        _legend_right(ax)
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(t[0], t[-1])
    fig.suptitle(title or f"{run.status}: {run.status_reason}")
    return fig


def _pid_design_form(plant: UncertainPlant) -> bool:
    """The design state is ``[∫e, e, ė]``, one of each per output: the gain's entries are K_I, K_P, K_D."""
    return plant.form == "pid" and plant.n_design_states == 3 * len(plant.outputs)


def gain_entry_labels(plant: UncertainPlant) -> tuple[list[str], list[str]]:
    """Each design-form state's gain name and the unit of the state it multiplies (``rad·s`` for K_I)."""
    n = plant.n_design_states
    outs = list(plant.outputs)
    if _pid_design_form(plant):
        names, units = [], []
        for kind, unit in (("K_I", "({}·s)"), ("K_P", "{}"), ("K_D", "({}/s)")):
            for k, sig in enumerate(outs):
                names.append(kind if len(outs) == 1 else f"{kind}[{k}]")
                units.append(unit.format(sig.unit))
        return names, units
    return [f"x{j}" for j in range(n)], ["state unit"] * n


def plot_schedule(gain: ScheduledGain, plant: UncertainPlant, *, fixed: Any = None,
                  title: str | None = None) -> Any:
    """Each entry of a scheduled gain against its parameter, the fixed gain beside it.

    One panel per nonzero entry (at most 12, the largest first): the table's values at the
    breakpoints (markers), linear between them as the controller interpolates, and a fixed
    gain's entry as a dashed line. A PID-form plant's entries are drawn as its PID gains
    ``K_I, K_P, K_D`` of ``u = K_P e + K_I ∫e + K_D ė`` (the entries of ``−K``), as the command
    line prints them; any other plant's as the entries of ``K`` in ``u = −K x``.

    Parameters
    ----------
    gain : ScheduledGain
    plant : UncertainPlant
        The plant it controls (names and units of the inputs and outputs).
    fixed : array_like, shape (m, n), optional
        A fixed gain to draw beside it.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    m, n = gain.shape
    K_fixed = None if fixed is None else np.asarray(fixed, dtype=float).reshape(m, n)
    names, per = gain_entry_labels(plant)
    pid = _pid_design_form(plant)
    sign = -1.0 if pid else 1.0  # u = −K x with x = [∫e, e, ė]: the PID gains are −K
    ins: list[Any] = list(plant.inputs) or [None] * m
    size = np.abs(gain.gains).max(axis=0)
    entries = [(i, j) for i, j in zip(*np.unravel_index(np.argsort(-size, axis=None), size.shape)) if size[i, j] > 0]
    entries = entries[:12]
    cols = min(3, len(entries))
    rows = -(-len(entries) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols + 1.0, 2.6 * rows + 0.8), squeeze=False,
                             layout="constrained")
    p = np.linspace(*gain.range, 201)
    curve = gain.gain(p)
    for ax, (i, j) in zip(axes.flat, entries):
        unit = f"{ins[i].unit}/{per[j]}" if ins[i] is not None else "input unit per state unit"
        label = names[j] if m == 1 else f"{names[j]} → {ins[i].name if ins[i] is not None else i}"
        ax.plot(p, sign * curve[:, i, j], color="C0", label="scheduled gain at p̂")
        ax.plot(gain.breakpoints, sign * gain.gains[:, i, j], "o", color="C0", ms=4, label="breakpoints")
        if K_fixed is not None:
            ax.axhline(sign * K_fixed[i, j], color="C1", ls="--", label="fixed gain")
        ax.set_title(label, fontsize=_LEGEND_SIZE + 1)
        ax.set_ylabel(f"gain [{unit}]")
        ax.set_xlabel(f"measured {gain.parameter} [{gain.unit}]")
        ax.set_xlim(*gain.range)
    for ax in list(axes.flat)[len(entries):]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=_LEGEND_SIZE)
    what = "PID gains (u = K_P e + K_I ∫e + K_D ė)" if pid else "K of u = −K x"
    fig.suptitle(title or f"{plant.name}: {what}, scheduled on {gain.parameter} ({gain.method})")
    return fig



def plot_loop_views(views: Mapping[str, Sequence[LoopView]], *, margins: Mapping[str, LoopMargins] | None = None,
                    outputs: Sequence[str] | None = None, title: str | None = None) -> Any:
    """Step responses and Bode plots of each loop of each gain, with the disk and delay margins.

    Parameters
    ----------
    views : mapping of str to sequence of LoopView
        Per gain (its name), one view per loop (:func:`scara_robust.worst_loop_views`).
    margins : mapping of str to LoopMargins, optional
        Per gain, the worst margins over every frozen plant: the legend gives these
        (default: each view's own plant's).
    outputs : sequence of str, optional
        The loops' names (default ``joint 1``, ``joint 2``, ...).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        One row per loop: the outputs after a unit step of its reference (rad per rad), the
        loop transfer's magnitude (dB, the gain crossover of the delay margin marked) and
        phase (degrees, −180° marked); the margins in the legend below the panels.
    """
    import matplotlib.pyplot as plt

    names = list(views)
    m = len(next(iter(views.values())))
    labels = list(outputs) if outputs is not None else [f"joint {i + 1}" for i in range(m)]
    fig, axes = plt.subplots(m, 3, figsize=(13, 3.4 * m + 1.2), layout="constrained", squeeze=False)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    handles = []
    for g, name in enumerate(names):
        color = colors[g % len(colors)]
        for i, view in enumerate(views[name]):
            step_ax, mag_ax, phase_ax = axes[i]
            (line,) = step_ax.plot(view.t, view.step[i], color=color, lw=1.3)
            for j in range(view.step.shape[0]):
                if j != i:
                    step_ax.plot(view.t, view.step[j], color=color, lw=0.9, ls="--")
            magnitude = 20 * np.log10(np.maximum(np.abs(view.L), 1e-300))
            phase = np.degrees(np.unwrap(np.angle(view.L)))
            # the branch on which the phase at the gain crossover lies in (−360°, 0]: the margin is its distance
            # to −180°
            at = np.interp(np.log(view.crossover), np.log(view.omega), phase) if np.isfinite(view.crossover) \
                else phase[-1]
            phase = phase - 360.0 * np.ceil(at / 360.0)
            mag_ax.semilogx(view.omega, magnitude, color=color, lw=1.3)
            phase_ax.semilogx(view.omega, phase, color=color, lw=1.3)
            if np.isfinite(view.crossover):
                mag_ax.axvline(view.crossover, color=color, ls=":", lw=1.0)
                phase_ax.axvline(view.crossover, color=color, ls=":", lw=1.0)
            if i == 0:
                handles.append(line)
            line.set_label(None)
        worst = None if margins is None else margins.get(name)
        parts = []
        for i, v in enumerate(views[name]):
            disk = v.disk_margin if worst is None else float(worst.disk_margin[i])
            delay = v.delay_margin if worst is None else float(worst.delay_margin[i])
            parts.append(f"{labels[i]} disk margin {_plain(disk)}, delay margin {_plain(delay * 1e3)} ms")
        rows = [";  ".join(parts[k:k + 3]) for k in range(0, len(parts), 3)]  # three loops a line: legible
        handles[-1].set_label(f"{name}: " + ";\n".join(rows) + (" (worst over the frozen plants)" if worst else ""))
    for i in range(m):
        step_ax, mag_ax, phase_ax = axes[i]
        step_ax.axhline(1.0, color="0.6", lw=0.8)
        step_ax.set_ylabel(f"{labels[i]} step: output [rad/rad]")
        mag_ax.axhline(0.0, color="0.6", lw=0.8)
        mag_ax.set_ylabel(f"|L| at input {i + 1} [dB]")
        phase_ax.axhline(-180.0, color="0.6", lw=0.8)
        phase_ax.set_ylabel(f"arg L at input {i + 1} [deg]")
        for ax in (mag_ax, phase_ax):
            ax.set_xlabel("frequency [rad/s]")
            ax.grid(True, which="major", color="0.9")
        step_ax.set_xlabel("time [s]")
    axes[0, 0].set_title("unit reference step" + (" (dashed: the other outputs)" if m > 1 else ""), fontsize=10)
    axes[0, 1].set_title("|L(jω)| (dotted: gain crossover)", fontsize=10)
    axes[0, 2].set_title("arg L(jω) (grey: −180°)", fontsize=10)
    fig.legend(handles=handles, loc="outside lower center", fontsize=_LEGEND_SIZE, frameon=False)
    if title:
        fig.suptitle(title)
    return fig
