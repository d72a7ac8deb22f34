"""``design``: K from (ρ, η), certified by Theorem 1."""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
import pandas as pd

from ..lyapunov.gain import design
from ..lyapunov.theorem1 import certify
from ..model.uncertain import ELEMENT_SETS
from ._common import add_setup_options, finite_float, resolve_bounds, resolve_model, resolve_setup

__all__ = ["add_parser", "add_model_options", "run"]


def add_model_options(p: argparse.ArgumentParser) -> None:
    """``--robot``, ``--scenario``, ``--bounds`` and ``--elements``.

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    add_setup_options(p, scenario=None)  # the bounds come from the robot, never from a scenario
    p.add_argument("--elements", choices=ELEMENT_SETS, default="all", help="uncertain elements entering Theorem 1's Z")


def add_parser(sub: Any) -> None:
    """Register ``design``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser("design", help="design K from (rho, eta) and certify it with Theorem 1")
    p.add_argument("--rho", type=finite_float, required=True, help="design parameter rho > 0")
    p.add_argument("--eta", type=finite_float, required=True, help="design parameter eta >= 1")
    add_model_options(p)
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> str:
    """Design and certify; the text or JSON to print.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    str
    """
    setup = resolve_setup(args)
    model = resolve_model(args, setup)
    d = design(model, args.rho, args.eta)
    cert = certify(model, d, args.elements)
    out = {
        "rho": d.rho,
        "eta": d.eta,
        "bounds": resolve_bounds(args, setup),
        "elements": args.elements,
        "K": d.K.tolist(),
        "closed_loop_poles_real": np.sort(d.poles.real).tolist(),
        "closed_loop_hurwitz": d.hurwitz,
        "max_eig_Z": cert.max_eig,
        "certified": cert.certified,
        "care_residual": d.care_residual,
        "lyapunov_residual": cert.lyapunov_residual,
        "contributions": cert.contributions().to_dict(orient="records"),
    }
    if args.format == "json":
        return json.dumps(out, indent=2)
    lines = [
        f"design (rho, eta) = ({d.rho:g}, {d.eta:g}), bounds: {out['bounds']}, elements: {args.elements}",
        "K =",
        np.array2string(d.K, precision=4, suppress_small=True, max_line_width=120),
        f"closed loop Hurwitz: {d.hurwitz} (largest real part {max(out['closed_loop_poles_real']):.4g} 1/s)",
        f"max eig Z: {cert.max_eig:.6g}  ->  certified: {cert.certified}",
        "",
        "contributions of each element to Z:",
        pd.DataFrame(out["contributions"]).to_string(index=False, float_format="%.4g"),
    ]
    return "\n".join(lines)
