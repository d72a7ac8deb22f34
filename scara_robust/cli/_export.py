"""``export``: the designed PID, discretized, as JSON or C99 source for a controller board."""

from __future__ import annotations

import argparse
import os
import tempfile
from typing import Any

import numpy as np

from ..export import DEFAULT_PREFIX, EXPORT_FORMATS, _check_prefix, export_controller
from ..lyapunov.discrete import DERIVATIVE_MODES, INTEGRATOR_METHODS
from ..lyapunov.gain import design
from ._common import CommandLineError, add_setup_options, finite_float, resolve_bounds, resolve_model, resolve_setup

__all__ = ["add_parser", "run"]


def _positive_list(text: str) -> list[float] | float:
    values = [finite_float(v) for v in text.split(",")]
    return values[0] if len(values) == 1 else values


def add_parser(sub: Any) -> None:
    """Register ``export``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser(
        "export",
        help="the designed PID, discretized at --ts, as C99 source (.h, .c) or JSON",
        description="Design K at (rho, eta), discretize it (Design.discretize) and write it into the folder "
        "--output: --format c writes PREFIX.h and PREFIX.c (PREFIX_init, PREFIX_step), --format json "
        "PREFIX.json with every gain and limit. Without options, the controller of Design.discretize(Ts).",
    )
    p.add_argument("--rho", type=finite_float, required=True, help="design parameter rho > 0")
    p.add_argument("--eta", type=finite_float, required=True, help="design parameter eta >= 1")
    add_setup_options(p, scenario=None, model=True)
    p.add_argument("--ts", type=finite_float, required=True, help="sample time, s (> 0)")
    p.add_argument("--integrator", choices=INTEGRATOR_METHODS, default="tustin", help="discretization of the integral")
    p.add_argument("--derivative", choices=DERIVATIVE_MODES, default="measured",
                   help="measured edot, or a filtered difference of e (no joint velocity needed)")
    p.add_argument("--filter-n", type=finite_float, default=100.0, help="derivative filter bandwidth N, 1/s (> 0)")
    p.add_argument("--torque-limit", type=_positive_list, default=None, metavar="L[,L2,...]",
                   help="per-joint torque limit, N·m (> 0): one value for all joints or one per joint")
    p.add_argument("--tracking-time", type=_positive_list, default=None, metavar="T[,T2,...]",
                   help="anti-windup tracking time T_t, s (>= Ts; default sqrt(T_i T_d) per joint)")
    p.add_argument("--no-anti-windup", action="store_true", help="leave the integrator free against the limit")
    p.add_argument("--format", choices=EXPORT_FORMATS, default="c")
    p.add_argument("--prefix", default=DEFAULT_PREFIX, help=f"C identifier of the names and files ({DEFAULT_PREFIX})")
    p.add_argument("--output", dest="folder", metavar="DIR", required=True, help="existing, writable folder")
    p.set_defaults(func=run)


def _check_folder(folder: str) -> None:
    if not os.path.isdir(folder):
        why = "is a file, not a folder" if os.path.exists(folder) else "no such folder"
        raise CommandLineError(f"`--output` {folder!r}: {why}")
    try:  # os.access says yes to root on read-only file systems; a real probe does not
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".tmp-")
    except OSError as err:
        raise CommandLineError(f"`--output` {folder!r}: the folder is not writable ({err.strerror or err})") from err
    os.close(fd)
    os.unlink(probe)


def run(args: argparse.Namespace) -> str:
    """Design, discretize and write the files; the list of files written.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    str
    """
    _check_folder(args.folder)  # before any computation
    _check_prefix(args.prefix)
    setup = resolve_setup(args)
    model = resolve_model(args, setup)
    d = design(model, args.rho, args.eta)
    pid = d.discretize(
        args.ts,
        integrator=args.integrator,
        derivative=args.derivative,
        N=args.filter_n,
        torque_limit=args.torque_limit,
        tracking_time=args.tracking_time,
        anti_windup=not args.no_anti_windup,
    )
    source = f"model {model.name}" if args.model is not None else f"bounds {resolve_bounds(args, setup)}"
    meta = {"rho": d.rho, "eta": d.eta, "model": model.name}
    files = export_controller(pid, args.folder, format=args.format, prefix=args.prefix, metadata=meta)
    lines = [f"PID at (rho, eta) = ({d.rho:g}, {d.eta:g}), {source}, Ts = {pid.Ts:g} s, "
             f"integrator {pid.integrator}, derivative {pid.derivative}"]
    if pid.torque_limit is not None:
        tt = [round(float(v), 4) for v in np.atleast_1d(np.asarray(pid.tracking_time, dtype=float))]
        lines.append(f"torque limit {[round(float(v), 6) for v in pid.torque_limit]} N·m, anti-windup "
                     + ("off" if not pid.anti_windup else f"T_t = {tt} s"))
    lines += [f"wrote {f}" for f in files]
    return "\n".join(lines)
