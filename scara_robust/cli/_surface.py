"""``surface``: max λ(Z) over a (ρ, η) grid (Figure 2)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ..lyapunov.surface import design_surface
from ..plotting import plot_surface
from ._common import parse_range, resolve_model, resolve_setup, save_figure
from ._design import add_model_options

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``surface``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("surface", help="max eig Z over a (rho, eta) grid (Figure 2)")
    p.add_argument("--rho", type=parse_range, required=True, metavar="START:STOP:NUM")
    p.add_argument("--eta", type=parse_range, required=True, metavar="START:STOP:NUM")
    add_model_options(p)
    p.add_argument("--format", choices=("text", "csv", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--plot", metavar="FILE.png", help="also save the 3D surface as a PNG")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> str:
    """Evaluate the surface; the text, CSV or JSON to print.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    str
    """
    model = resolve_model(args, resolve_setup(args))
    surface = design_surface(model, args.rho, args.eta, args.elements)
    frame = surface.to_frame()
    if args.plot is not None:
        mark = None
        if surface.hurwitz.any():
            rho, eta, _ = surface.best()
            mark = (rho, eta)
        save_figure("--plot", args.plot, plot_surface(surface, mark=mark).figure)
    if args.format == "json":
        return json.dumps(frame.to_dict(orient="records"))
    if args.format == "csv":
        return str(frame.to_csv(index=False))
    rho, eta, best = surface.best()
    return (
        f"{frame.shape[0]} grid points, {int(surface.certified.sum())} certified "
        f"(max eig Z < 0); best: rho={rho:g}, eta={eta:g}, max eig Z={best:.6g}\n"
        + str(frame.to_string(index=False, float_format="%.6g"))
    )

