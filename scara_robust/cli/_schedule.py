"""Scheduled gains on the command line: ``synthesize --schedule NAME`` writes one, ``certify --design F`` reads it."""

from __future__ import annotations

import argparse
import json
import math
import os
from typing import Any

import numpy as np

from ..controller.scheduled import SCHEDULE_KIND, ScheduledGain, load_schedule
from ..exceptions import ArgumentError, InputFileError
from ..model.plant import UncertainPlant
from ..robustness.lmi import NOT_INSTALLED
from ..robustness.scheduled import (
    ScheduleCertificate,
    max_measurement_error,
    max_schedule_rate,
    schedule_certificate,
    schedule_decay,
    scheduled_parameter,
    synthesize_schedule,
)
from ._common import CommandLineError
from ._system import LoadedSystem

__all__ = ["is_schedule_file", "add_schedule_options", "run_schedule_synthesis", "run_schedule_certificate"]


def is_schedule_file(path: str | None) -> bool:
    """True when `path` is a JSON file of ``kind = 'scheduled-gain'`` (a schedule, not a design file)."""
    if path is None or not path.lower().endswith(".json") or not os.path.isfile(path):
        return False
    try:
        with open(path, encoding="utf-8") as handle:
            data = json.load(handle)
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("kind") == SCHEDULE_KIND


def add_schedule_options(p: argparse.ArgumentParser, *, synthesis: bool) -> None:
    """The options of a scheduled gain: rate and measurement error (and, to synthesize, the schedule).

    Parameters
    ----------
    p : argparse.ArgumentParser
    synthesis : bool
        Add ``--schedule`` and ``--breakpoints`` (``synthesize``).
    """
    if synthesis:
        p.add_argument("--schedule", metavar="NAME",
                       help="synthesize a gain scheduled on this measured parameter of the plant (a breakpoint "
                       "table, linear between; written by --output as a schedule file)")
        p.add_argument("--breakpoints", default="5", metavar="N|V,V,...",
                       help="with --schedule: N equally spaced breakpoints over the parameter's range, or their "
                       "values in its unit (default 5)")
    p.add_argument("--rate", dest="schedule_rate", type=float, default=None, metavar="NU",
                   help="with a scheduled gain: the bound on the parameter's rate, its unit per second (default "
                   "the plant's `rate`, else any rate)")
    p.add_argument("--measurement-error", type=float, default=None, metavar="DELTA",
                   help="with a scheduled gain: the bound on |measured − true| in the parameter's unit (default the "
                   "plant's `measurement_error`, its delay included)")


def _plant(system: LoadedSystem) -> UncertainPlant:
    return system.require_physical("a scheduled gain needs a plant with named physical parameters (a plant file "
                                   "with [parameters], or the SCARA); this file describes only the uncertainty set")


def _breakpoints(text: str, plant: UncertainPlant, name: str) -> np.ndarray:
    lo, hi = plant.parameter(name).range
    words = [w for w in text.split(",") if w.strip()]
    try:
        values = [float(w) for w in words]
    except ValueError:
        raise CommandLineError(f"`--breakpoints` must be a count or comma-separated values, found {text!r}") from None
    if len(values) == 1 and float(values[0]).is_integer() and values[0] >= 2 and "." not in text:
        return np.linspace(lo, hi, int(values[0]))
    return np.array(values)


def _check_numbers(args: argparse.Namespace) -> None:
    for option, value in (("--rate", args.schedule_rate), ("--measurement-error", args.measurement_error)):
        if value is not None and not (value >= 0 and not math.isnan(value)):
            raise CommandLineError(f"`{option}` must be >= 0, found {value:g}")


def _certificate_lines(cert: ScheduleCertificate, unit: str) -> list[str]:
    return [f"certificate: {cert.verdict} ({cert.message})",
            f"covers: {cert.covers}",
            f"rate |d{cert.parameter}/dt| <= {cert.rate:g} {unit}/s, measurement error <= "
            f"{cert.measurement_error:g} {unit}, decay >= {cert.decay:.4g} 1/s"]


def _table(gain: ScheduledGain) -> list[str]:
    lines = [f"schedule on {gain.parameter} [{gain.unit}] ({gain.method}), K (u = -K x) at each breakpoint:"]
    for b, K in zip(gain.breakpoints, gain.gains):
        text = np.array2string(K, precision=4, suppress_small=True, max_line_width=140).replace("\n", "\n    ")
        lines.append(f"  {gain.parameter} = {b:g} {gain.unit}: ||K|| = {np.linalg.norm(K, 2):.4g}\n    {text}")
    return lines


def run_schedule_synthesis(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``synthesize --schedule NAME``: the LMI synthesis of a scheduled gain; the summary (and the file written).

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    _check_numbers(args)
    output = args.design_output
    if output is not None and not output.lower().endswith(".json"):
        raise CommandLineError(f"`--output` {output!r}: a schedule file is .json")
    plant = _plant(system)
    try:
        name = scheduled_parameter(plant, args.schedule)
        breakpoints = _breakpoints(args.breakpoints, plant, name)
        result = synthesize_schedule(plant, breakpoints, parameter=name, rate=args.schedule_rate,
                                     measurement_error=args.measurement_error, decay=args.decay,
                                     gain_bound=args.gain_bound)
    except ArgumentError as err:
        option = {"parameter": "--schedule", "breakpoints": "--breakpoints", "rate": "--rate",
                  "measurement_error": "--measurement-error"}.get(err.argument, f"--{err.argument}")
        raise CommandLineError(f"`{option}` {err.problem}") from err
    if result.status == NOT_INSTALLED:
        raise CommandLineError("synthesize needs cvxpy: pip install '.[lmi]'")
    unit = plant.parameter(name).unit
    lines = [f"synthesize: a gain scheduled on {name} of {plant.name}, ||K_j|| <= {args.gain_bound:g}",
             f"status: {result.status} ({result.message})"]
    if result.gain is None or result.certificate is None:
        return "\n".join(lines)
    lines += _table(result.gain) + _certificate_lines(result.certificate, unit)
    if output is not None:
        try:
            result.gain.save(output)
        except OSError as err:
            raise CommandLineError(f"`--output` {output!r}: {err.strerror or err}") from err
        lines.append(f"schedule file: {output}")
    return "\n".join(lines)


def run_schedule_certificate(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``certify --design SCHEDULE.json``: the certificate, the largest rate, error and decay; the text or JSON.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    _check_numbers(args)
    plant = _plant(system)
    try:
        gain = load_schedule(args.design)
    except InputFileError as err:
        raise CommandLineError(str(err)) from err
    try:
        cert = schedule_certificate(plant, gain, rate=args.schedule_rate, measurement_error=args.measurement_error)
        rate, _ = max_schedule_rate(plant, gain, measurement_error=args.measurement_error)
        delta, _ = max_measurement_error(plant, gain, rate=args.schedule_rate)
        decay, _ = schedule_decay(plant, gain, rate=args.schedule_rate, measurement_error=args.measurement_error)
    except ArgumentError as err:
        raise CommandLineError(f"`--design` {args.design!r}: {err}") from err
    if cert.status == NOT_INSTALLED:
        raise CommandLineError("a scheduled gain's certificate needs cvxpy: pip install '.[lmi]'")
    unit = plant.parameter(gain.parameter).unit
    info: dict[str, Any] = {
        "method": "scheduled", "parameter": gain.parameter, "certified": cert.certified, "status": cert.status,
        "rate": cert.rate, "measurement_error": cert.measurement_error, "largest_rate": rate,
        "largest_measurement_error": delta, "decay": decay, "covers": cert.covers, "message": cert.message}
    if args.format == "json":
        return json.dumps({k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                           for k, v in info.items()}, indent=2)
    return "\n".join([f"certificate of the schedule {args.design!r} on {plant.name}", *_table(gain),
                      *_certificate_lines(cert, unit),
                      f"largest certified rate: {rate:.4g} {unit}/s (measurement error {cert.measurement_error:g} "
                      f"{unit})",
                      f"largest certified measurement error: {delta:.4g} {unit} (rate {cert.rate:g} {unit}/s)",
                      f"guaranteed decay rate: {decay:.4g} 1/s (rate {cert.rate:g} {unit}/s, measurement error "
                      f"{cert.measurement_error:g} {unit})"])
