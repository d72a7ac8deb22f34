"""``campaign``: a Monte-Carlo campaign from a TOML spec."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import Any

from ..studies.campaign.arm import arm_campaign_spec
from ..studies.campaign.runner import CAMPAIGN_ENGINES, SCHEDULERS, run_campaign
from ..studies.campaign.spec import SPEC_FIELDS, load_spec
from ._common import CommandLineError, output_exists
from ._parser import COMMAND_HELP
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``campaign``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser(
        "campaign",
        help=COMMAND_HELP["campaign"],
        description="Fields of the spec (TOML): controllers, t_final [s], rho, eta, payload_profiles, runs, seed, "
        + ", ".join(f"{n} [{v[0]}]" for n, v in SPEC_FIELDS.items())
        + "; each drawn field is a number or {min = ..., max = ...}. See examples/campaign.toml.",
    )
    p.add_argument("spec", help="campaign spec, TOML")
    p.add_argument("--robot", metavar="FILE",
                   help="robot file (default: the paper's robot; cp is drawn by the spec), or one naming a URDF: the "
                        "campaign runs that arm's PID K(rho, eta) (fields reference_scale, measurement_noise [rad], "
                        "noise_bandwidth [Hz]; see examples/campaign-arm6.toml)")
    p.add_argument("--runs", type=int, help="number of scenarios (default: the spec's)")
    p.add_argument("--seed", type=int, help="seed (default: the spec's)")
    p.add_argument("--workers", type=int, default=1, help="processes or dask workers (default 1)")
    p.add_argument("--scheduler", choices=SCHEDULERS, default="local")
    p.add_argument("--address", help="address of a running dask scheduler (with --scheduler dask)")
    # dest is not `output`: the summary line goes to stdout, the table to this file
    p.add_argument("--output", dest="results_output", help="results file, .csv or .parquet (default results.csv)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted campaign in --output")
    p.add_argument("--progress", action="store_true", help="show the progress bar even when stderr is not a terminal "
                   "(by default it is drawn on a terminal only, so a redirected log is not flooded)")
    p.add_argument("--chunk-size", type=int, default=4, help="scenarios per task (default 4)")
    p.add_argument("--checkpoint", type=float, default=2.0, metavar="S",
                   help="least time between two rewrites of --output, s (default 2; 0: after every chunk)")
    p.add_argument("--engine", choices=CAMPAIGN_ENGINES, default="auto",
                   help="'compiled' (numba, extra compiled; the default when installed) or 'scipy'")
    p.set_defaults(func=run)


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Run the campaign; the summary line to print.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem
        The SCARA of ``--robot``, whose parameters replace the spec's, or the arm of a
        robot file naming a URDF.

    Returns
    -------
    str
    """
    spec = load_spec(args.spec)
    if system.capabilities.run == "arm":
        assert system.robot is not None
        spec = arm_campaign_spec(spec, system.robot)
    else:
        spec = replace(spec, robot=system.robot_params(spec.robot))
    output = args.results_output or "results.csv"
    if output_exists(output) and not args.resume:
        raise CommandLineError(f"`--output` {output!r} exists; pass --resume to continue it, or choose another file")
    table = run_campaign(
        spec,
        output,
        runs=args.runs,
        seed=args.seed,
        workers=args.workers,
        scheduler=args.scheduler,
        address=args.address,
        resume=args.resume,
        chunk_size=args.chunk_size,
        progress=sys.stderr.isatty() or args.progress,
        engine=args.engine,
        checkpoint=args.checkpoint,
    )
    # the report's failures: every run that is not tracking; of them, the runs whose integration failed
    not_tracking = int((table["status"] != "tracking").sum())
    broken = int((~table["success"].astype(bool)).sum())
    return (
        f"campaign: {table['scenario'].nunique()} scenarios x {len(spec.controllers)} controllers "
        f"= {len(table)} rows in {output} ({not_tracking} runs not tracking, the report's failures; "
        f"{broken} of them with a failed integration)"
    )
