"""Scheduled gains on the command line: ``synthesize --schedule NAME`` writes one, ``certify --design F`` reads it."""

from __future__ import annotations

import argparse
import json
import math
import os
from typing import Any

import numpy as np

from .._validation import os_error_text
from ..controller.scheduled import SCHEDULE_KIND, SampledScheduledGain, ScheduledGain, load_schedule
from ..exceptions import ArgumentError, InputFileError
from ..export import export_controller
from ..model.plant import Signal, UncertainPlant
from ..robustness.lmi import NOT_INSTALLED
from ..robustness.scheduled import (
    ScheduleCertificate,
    max_measurement_error,
    max_schedule_rate,
    schedule_certificate,
    schedule_decay,
    schedule_riccati,
    schedule_sampled_certificate,
    scheduled_parameter,
    synthesize_schedule,
    synthesize_schedule_rate,
)
from ._board import run_board
from ._common import CommandLineError
from ._options import option
from ._system import LoadedSystem

__all__ = ["is_schedule_file", "read_schedule", "add_schedule_options", "refuse_schedule_options",
           "run_schedule_synthesis", "run_schedule_riccati", "run_schedule_certificate", "run_schedule_margin",
           "run_schedule_export"]


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


def read_schedule(path: str) -> ScheduledGain:
    """The schedule file of ``--design``, its errors as one command-line line."""
    try:
        return load_schedule(path)
    except InputFileError as err:
        raise CommandLineError(str(err)) from err


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


def refuse_schedule_options(args: argparse.Namespace, goes_with: str) -> None:
    """Refuse ``--rate`` and ``--measurement-error`` where no scheduled gain is analysed.

    Parameters
    ----------
    args : argparse.Namespace
    goes_with : str
        The option that would make them mean something (``'--design SCHEDULE.json'``).
    """
    given = [o for o, v in (("--rate", args.schedule_rate), ("--measurement-error", args.measurement_error))
             if v is not None]
    if given:
        raise CommandLineError(f"`{given[0]}` describes a scheduled gain; it goes with {goes_with}")


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
    for flag, value in (("--rate", args.schedule_rate), ("--measurement-error", args.measurement_error)):
        if value is not None and not (value >= 0 and not math.isnan(value)):
            raise CommandLineError(f"`{flag}` must be >= 0, found {value:g}")


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


def _option_error(err: ArgumentError) -> CommandLineError:
    option = {"parameter": "--schedule", "breakpoints": "--breakpoints", "rate": "--rate",
              "measurement_error": "--measurement-error", "rho": "--rho", "eta": "--eta"}.get(
        err.argument, f"--{err.argument}")
    return CommandLineError(f"`{option}` {err.problem}")


def _schedule_output(args: argparse.Namespace) -> str | None:
    """The schedule file ``synthesize --output`` names (.json); the summary goes to stdout."""
    output: str | None = args.design_output
    if output is not None and not output.lower().endswith(".json"):
        raise CommandLineError(f"`--output` {output!r}: a schedule file is .json")
    return output


def _save(gain: ScheduledGain, output: str | None) -> list[str]:
    if output is None:
        return []
    try:
        gain.save(output)
    except OSError as err:
        raise CommandLineError(f"`--output` {output!r}: {os_error_text(err)}") from err
    return [f"schedule file: {output}"]


def run_schedule_riccati(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``design --schedule NAME``: the paper's (ρ, η) design at each breakpoint, its certificate; the summary.

    The gain at each breakpoint is :func:`scara_robust.design` on the plant frozen there
    (:func:`scara_robust.schedule_riccati`); the table is then certified as it runs
    (:func:`scara_robust.schedule_certificate`) at the rate and measurement error asked, and
    the largest decay it guarantees is searched. ``--format json`` gives the schedule file (to
    ``--output``, as ``design`` gives a design file), with the certificate recorded when
    there is one.

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
        name = scheduled_parameter(plant, args.schedule)
        gain = schedule_riccati(plant, name, _breakpoints(args.breakpoints, plant, name), args.rho, args.eta)
        cert = schedule_certificate(plant, gain, rate=args.schedule_rate, measurement_error=args.measurement_error)
        decay, _ = schedule_decay(plant, gain, rate=args.schedule_rate, measurement_error=args.measurement_error,
                                  known=cert)
    except ArgumentError as err:
        raise _option_error(err) from err
    if cert.status == NOT_INSTALLED:
        raise CommandLineError("a scheduled gain's certificate needs cvxpy: pip install '.[lmi]'")
    unit = plant.parameter(name).unit
    if cert.certified:
        gain = gain.with_certificate(range=list(gain.range), rate=cert.rate, measurement_error=cert.measurement_error,
                                     decay=decay, plant=plant.name, checked_conditions=cert.verified_on)
    lines = [f"design: (rho, eta) = ({args.rho:g}, {args.eta:g}) at each breakpoint of {name}, {plant.name}",
             *_table(gain), *_certificate_lines(cert, unit)]
    if args.format == "json":  # the schedule file
        return gain.to_json()
    if cert.certified:
        lines.append(f"guaranteed decay rate: {decay:.4g} 1/s")
    return "\n".join(lines)


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
    objective = args.objective or "decay"
    if objective not in ("decay", "rate"):
        raise CommandLineError(f"`--objective {objective}` is not there for a scheduled gain; it takes 'decay' or "
                               "'rate'")
    if objective == "rate" and args.schedule_rate is not None:
        raise CommandLineError("`--rate` bounds the rate; `--objective rate` searches the largest one")
    output = _schedule_output(args)
    plant = _plant(system)
    try:
        name = scheduled_parameter(plant, args.schedule)
        breakpoints = _breakpoints(args.breakpoints, plant, name)
        if objective == "rate":
            result = synthesize_schedule_rate(plant, breakpoints, parameter=name, decay=args.decay or 0.0,
                                              measurement_error=args.measurement_error, gain_bound=args.gain_bound)
        else:
            result = synthesize_schedule(plant, breakpoints, parameter=name, rate=args.schedule_rate,
                                         measurement_error=args.measurement_error, decay=args.decay,
                                         gain_bound=args.gain_bound)
    except ArgumentError as err:
        raise _option_error(err) from err
    if result.status == NOT_INSTALLED:
        raise CommandLineError("synthesize needs cvxpy: pip install '.[lmi]'")
    unit = plant.parameter(name).unit
    lines = [f"synthesize: a gain scheduled on {name} of {plant.name}, ||K_j|| <= {args.gain_bound:g}, objective "
             f"{objective}", f"status: {result.status} ({result.message})"]
    if result.gain is None or result.certificate is None:
        return "\n".join(lines)
    lines += _table(result.gain) + _certificate_lines(result.certificate, unit)
    return "\n".join(lines + _save(result.gain, output))


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
    return _schedule_answers(args, system, with_certificate=True)


def run_schedule_margin(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``margin --design SCHEDULE.json``: the largest rate, measurement error and decay the schedule is certified for.

    At the plant's rate bound and measurement error (each search holds the other at it).

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    return _schedule_answers(args, system, with_certificate=False)


def _schedule_answers(args: argparse.Namespace, system: LoadedSystem, *, with_certificate: bool) -> str:
    """The certificate (with `with_certificate`) and the three searches of a schedule file, as text or JSON."""
    rate_bound = option(args, "schedule_rate")
    error_bound = option(args, "measurement_error")
    if with_certificate:
        _check_numbers(args)
    plant = _plant(system)
    gain = read_schedule(args.design)
    try:
        cert = schedule_certificate(plant, gain, rate=rate_bound, measurement_error=error_bound) \
            if with_certificate else None
        rate, _ = max_schedule_rate(plant, gain, measurement_error=error_bound)
        delta, _ = max_measurement_error(plant, gain, rate=rate_bound)
        decay, _ = schedule_decay(plant, gain, rate=rate_bound, measurement_error=error_bound, known=cert)
    except ArgumentError as err:
        raise CommandLineError(f"`--design` {args.design!r}: {err}") from err
    if cert is not None and cert.status == NOT_INSTALLED:
        raise CommandLineError("a scheduled gain's certificate needs cvxpy: pip install '.[lmi]'")
    param = plant.parameter(gain.parameter)
    unit = param.unit
    nu, error = param.motion_bounds(rate_bound, error_bound)
    info: dict[str, Any] = {"method": "scheduled", "parameter": gain.parameter, "rate": nu, "measurement_error": error,
                            "largest_rate": rate, "largest_measurement_error": delta, "decay": decay}
    if cert is not None:
        info.update(certified=cert.certified, status=cert.status, covers=cert.covers, message=cert.message)
    if args.format == "json":
        return json.dumps({k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                           for k, v in info.items()}, indent=2)
    what = "certificate" if cert is not None else "margins"
    return "\n".join([f"{what} of the schedule {args.design!r} on {plant.name}", *_table(gain),
                      *(_certificate_lines(cert, unit) if cert is not None else []),
                      f"largest certified rate: {rate:.4g} {unit}/s (measurement error {error:g} {unit})",
                      f"largest certified measurement error: {delta:.4g} {unit} (rate {nu:g} {unit}/s)",
                      f"guaranteed decay rate: {decay:.4g} 1/s (rate {nu:g} {unit}/s, measurement error "
                      f"{error:g} {unit})"])


def _state_signals(plant: UncertainPlant) -> list[Signal] | None:
    """The design-form state the scheduled gain reads: ``[∫e, e, ė]`` of a PID form, named with units."""
    outs = list(plant.outputs)
    if plant.form == "pid" and plant.n_design_states == 3 * len(outs):
        return ([Signal(f"integral of {s.name} error", f"{s.unit}·s") for s in outs]
                + [Signal(f"{s.name} error", s.unit) for s in outs]
                + [Signal(f"{s.name} error rate", f"{s.unit}/s") for s in outs])
    return None


def run_schedule_export(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``export --design SCHEDULE.json``: a scheduled gain to C or JSON, with its certificates checked first.

    Refused (nothing written) unless ``--allow-uncertified``, which the header records: a
    rate or measurement error the schedule is not certified for (the file's certificate, or
    where it is asked beyond it, :func:`scara_robust.schedule_certificate` as ``certify``
    computes it), and a Ts the sampled-data certificate does not hold at.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
    """
    _check_numbers(args)
    if system.capabilities.run == "arm" and system.arm().feedforward != "none":
        raise CommandLineError(f"`--design` {args.design!r}: {system.file!r} certifies the arm's loop with its "
                               f"{system.arm().feedforward} feedforward, and a schedule's export does not carry a "
                               "model feedforward yet; export a fixed gain (its C carries it), or schedule on a "
                               "robot file with feedforward = \"none\"")
    plant = _plant(system)
    gain = read_schedule(args.design)
    name = gain.parameter
    if name not in plant.names:
        raise CommandLineError(f"`--design` {args.design!r}: schedules {name!r}, which {plant.name!r} does not have")
    param = plant.parameter(name)
    rate, delta = param.motion_bounds(args.schedule_rate, args.measurement_error)
    problems = []
    covered = bool(gain.certified) and rate <= (gain.recorded("rate") or 0.0) \
        and delta <= (gain.recorded("measurement_error") or 0.0)
    if not covered:
        # beyond what the file records: the certificate `certify` gives, at the rate and error asked
        try:
            now = schedule_certificate(plant, gain, rate=rate, measurement_error=delta)
        except ArgumentError as err:
            raise CommandLineError(f"`--design` {args.design!r}: {err}") from err
        if not now.certified:
            problems.append(f"at rate {rate:g} {param.unit}/s and measurement error {delta:g} {param.unit}: "
                            f"{now.message}")
    try:
        sampled = schedule_sampled_certificate(plant, gain, args.ts, measurement_error=delta)
    except ArgumentError as err:
        raise CommandLineError(f"`--design` {args.design!r}: {err}") from err
    if not sampled.certified:
        problems.append(f"the sampled-data certificate: {sampled.message}")
    if problems and not args.allow_uncertified:
        raise CommandLineError(f"`--design` {args.design!r}: not certified for this export ({'; '.join(problems)}); "
                               "nothing written (--allow-uncertified writes it anyway)")
    notes = [f"Sampled-data certificate at Ts (one P for every {name}, so any rate between samples; "
             f"measurement error {delta:g} {param.unit}): {sampled.message}."]
    if problems:
        notes.insert(0, "WARNING: NOT CERTIFIED as asked (" + "; ".join(problems) + "); written with "
                        "--allow-uncertified. Do not deploy it without your own analysis.")
    meta = {"schedule_file": args.design, "plant": plant.name, "plant_file": system.file,
            "asked": {"rate": rate, "measurement_error": delta}, "sampled_certificate": {
                "Ts [s]": sampled.Ts, "certified": sampled.certified, "spectral_radius": sampled.spectral_radius,
                "decay_rate [1/s]": sampled.rate if math.isfinite(sampled.rate) else None,
                "plants": sampled.n_plants, "message": sampled.message},
            "allow_uncertified": bool(problems), "precision": args.precision}
    prefix = args.prefix or f"{system.plant_prefix('plant')}_scheduled"
    controller = SampledScheduledGain(gain, args.ts)
    board = run_board(args, controller, prefix)
    if board is not None:
        notes.append(f"Run on an emulated board: {board.message}.")
    files = export_controller(controller, args.folder, format=args.format, prefix=prefix,
                              metadata=meta, notes=notes, precision=args.precision, outputs=list(plant.inputs),
                              inputs=_state_signals(plant))
    head = (f"gain scheduled on {name} of {args.design!r}, {plant.name}, Ts = {args.ts:g} s, u = -K(p_hat) x(t_k) "
            f"held, {args.precision} precision")
    status = ("WARNING: not certified as asked: " + "; ".join(problems)) if problems else \
        f"certified for rate {rate:g} {param.unit}/s and measurement error {delta:g} {param.unit}"
    shown = [] if board is None else [board.message]
    return "\n".join([head, status, sampled.message, *shown, *(f"wrote {f}" for f in files)])
