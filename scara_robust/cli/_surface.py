"""``surface``: max λ(Z) over a (ρ, η) grid (Figure 2)."""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from ..lyapunov.surface import (
    MARGIN_MAP_METHODS,
    MAX_SURFACE_POINTS,
    SURFACE_MEASURES,
    design_surface,
    surface_memory,
)
from ..model.plant import as_box
from ..plotting import plot_margin_map, plot_surface
from ._common import (
    RANGE_HELP,
    CommandLineError,
    finite_float,
    parse_range,
    save_figure,
    screen_table,
)
from ._design import add_model_options
from ._parser import COMMAND_HELP
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``surface``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("surface", help=COMMAND_HELP["surface"])
    p.add_argument("--rho", type=parse_range, required=True, metavar="START:STOP:NUM", help=f"rho grid: {RANGE_HELP}")
    p.add_argument("--eta", type=parse_range, required=True, metavar="START:STOP:NUM", help=f"eta grid: {RANGE_HELP}")
    add_model_options(p)
    p.add_argument("--format", choices=("text", "csv", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--plot", metavar="FILE", help="also save the 3D surface (.png, .pdf or .svg)")
    p.add_argument(
        "--measure",
        choices=SURFACE_MEASURES,
        default="max_eig",
        help="'margin' adds the robustness margin theta of every design (the largest scaling of the uncertain "
        "ranges still certified)",
    )
    p.add_argument("--margin-method", choices=MARGIN_MAP_METHODS, default="theorem1",
                   help="certificate of the margin: Theorem 1 or the design's P at the box's vertices")
    p.add_argument(
        "--mark",
        type=_point,
        metavar="RHO,ETA",
        help="(rho, eta) to mark on the --plot figure (default: the grid's best Hurwitz point)",
    )
    p.set_defaults(func=run)


def _point(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected RHO,ETA, found {text!r}")
    rho, eta = (finite_float(part) for part in parts)
    return rho, eta


def _check_mark(mark: tuple[float, float], rhos: np.ndarray, etas: np.ndarray) -> None:
    """Refuse a ``--mark`` outside the grid (the figure would put it at the nearest corner)."""
    for name, value, grid in (("rho", mark[0], rhos), ("eta", mark[1], etas)):
        low, high = float(grid.min()), float(grid.max())
        if not low <= value <= high:
            raise CommandLineError(
                f"`--mark` {name} = {value:g} is outside the --{name} grid [{low:g}, {high:g}]; "
                "mark a point of the grid"
            )


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Evaluate the surface; the text, CSV or JSON to print.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    points = args.rho.size * args.eta.size
    if points > MAX_SURFACE_POINTS:
        raise CommandLineError(
            f"`--rho` x `--eta` is a grid of {points:,} points (about {surface_memory(points, 6) / 1e9:.3g} GB of "
            f"memory); at most {MAX_SURFACE_POINTS:,} points: use fewer, or several commands"
        )
    if args.mark is not None and args.plot is None:
        raise CommandLineError("`--mark` marks a point on the --plot figure; give --plot FILE.png too")
    if args.mark is not None:
        _check_mark(args.mark, args.rho, args.eta)
    model = system.model
    note = ""
    if not system.interval_elements:  # Theorem 1 needs intervals: the box around the polytope
        model = model.interval_hull()
        note = f"Theorem 1 on the {model.name} (its corners need not be in the polytope)\n"
    surface = design_surface(
        as_box("model", model), args.rho, args.eta, args.elements, measure=args.measure,
        margin_method=args.margin_method,
    )
    frame = surface.to_pandas()
    if args.plot is not None:
        mark = args.mark
        if surface.margin is not None:  # --measure margin: the map of θ, marked at its largest
            if mark is None:
                rho, eta, _ = surface.best_margin()
                mark = (rho, eta)
            save_figure("--plot", args.plot, plot_margin_map(surface, mark=mark).figure)
        else:
            if mark is None and surface.hurwitz.any():
                rho, eta, _ = surface.best()
                mark = (rho, eta)
            save_figure("--plot", args.plot, plot_surface(surface, mark=mark).figure)
    if args.format == "json":
        return json.dumps(frame.to_dict(orient="records"))
    if args.format == "csv":
        return str(frame.to_csv(index=False))
    rho, eta, best = surface.best()
    header = (
        f"{frame.shape[0]} grid points, {int(surface.certified.sum())} certified "
        f"(max eig Z < 0); best: rho={rho:g}, eta={eta:g}, max eig Z={best:.6g}\n"
    )
    if surface.margin is not None:
        rho, eta, theta = surface.best_margin()
        header += f"largest {args.margin_method} margin: theta={theta:.6g} at rho={rho:g}, eta={eta:g}\n"
    return note + header + screen_table(frame, args.output, index=False, float_format="%.6g")

