"""Matplotlib figures. Nothing here computes: every function draws a result object."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .simulation import SimulationResult
    from .surface import DesignSurface

__all__ = ["plot_surface", "plot_surface_contour", "plot_response"]


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
        ax = fig.add_subplot(projection="3d")
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
            label=f"(ρ, η) = ({surface.rhos[i]:g}, {surface.etas[k]:g}): max λ(Z) = {z:.3g}",
        )
        ax.legend(loc="upper left")
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_zlabel("max λ(Z) [-]")
    ax.set_title(f"Figure 2: max λ(Z) over (ρ, η) — {surface.model_name}, elements: {surface.elements}")
    return ax


def plot_surface_contour(surface: DesignSurface, mark: tuple[float, float] | None = None, ax: Any = None) -> Any:
    """Contour view of ``max λ(Z)`` with the certified region (max λ(Z) < 0) outlined."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5))
    R, H = np.meshgrid(surface.rhos, surface.etas, indexing="ij")
    cs = ax.contourf(R, H, surface.max_eig, levels=30, cmap="viridis")
    plt.colorbar(cs, ax=ax, label="max λ(Z) [-]")
    if (surface.max_eig < 0).any() and (surface.max_eig >= 0).any():
        ax.contour(R, H, surface.max_eig, levels=[0.0], colors="red", linewidths=2)
    if mark is not None:
        ax.plot(*mark, "r*", markersize=12, label=f"(ρ, η) = ({mark[0]:g}, {mark[1]:g})")
        ax.legend()
    ax.set_xlabel("ρ [-]")
    ax.set_ylabel("η [-]")
    ax.set_title(f"max λ(Z) < 0 region (red line = 0) — {surface.model_name}, {surface.elements}")
    return ax


def plot_response(result: SimulationResult, *, title: str | None = None) -> Any:
    """Two panels laid out like the paper's Figure 3.

    Upper: errors e1 (dash-dot) and e2 (solid) in rad on the left axis; disturbance
    torques (N·m) and payload mass (kg) on the right axis. Lower: control torques
    Tc1 (dash-dot) and Tc2 (solid) in N·m.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = result.t
    top.plot(t, result.e[0], "-.", label="e1 [rad]")
    top.plot(t, result.e[1], "-", label="e2 [rad]")
    top.set_ylabel("joint error [rad]")
    right = top.twinx()
    right.plot(t, result.disturbance[0], color="0.6", lw=0.8, label="Td1, Td2 [N·m]")
    right.plot(t, result.payload, color="tab:green", lw=1.0, label="m_p [kg]")
    right.set_ylabel("Td [N·m], m_p [kg]")
    lines = top.get_lines() + right.get_lines()
    top.legend(lines, [ln.get_label() for ln in lines], loc="upper right", fontsize=8)
    bottom.plot(t, result.torque[0], "-.", label="Tc1")
    bottom.plot(t, result.torque[1], "-", label="Tc2")
    bottom.set_xlabel("time t [s]")
    bottom.set_ylabel("control torque [N·m]")
    bottom.legend(loc="upper right", fontsize=8)
    fig.suptitle(title or f"{result.controller}, scenario {result.scenario}")
    fig.tight_layout()
    return fig
