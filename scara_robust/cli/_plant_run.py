"""``simulate --model F`` and ``compare --model F``: runs of a plant file's closed loop."""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from .._validation import os_error_text
from ..controller.kinds import schedule_of
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentError, InputFileError
from ..export._common import per_second
from ..lyapunov.gain import design
from ..model.plant import UncertainPlant, as_model
from ..simulation.plants import PROFILES, PlantRun, parameter_profile, simulate_plant
from ._common import CommandLineError, check_gain_options, resolve_design, write_text
from ._options import option
from ._schedule import is_schedule_file, read_schedule

__all__ = ["add_plant_run_options", "option_floats", "plant_gain", "plant_profiles", "plant_run", "run_inputs",
           "series_output", "summary"]


def add_plant_run_options(p: argparse.ArgumentParser) -> None:
    """Options of a plant file's run (``--profile``, ``--parameter``, ``--reference``, ``--disturbance``).

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    p.add_argument("--profile", default="constant", metavar="SPEC",
                   help="with --model: how the parameter varies: constant[:VALUE], sinusoid[:PERIOD_S], ramp, "
                   "random-walk[:SEED] (within its rate bound) or FILE.csv:COLUMN (against column t, s); default "
                   "constant at the nominal")
    p.add_argument("--parameter", default=None, metavar="NAME",
                   help="with --model: the parameter --profile drives (default: the one with a rate bound, else the "
                   "last with a range)")
    p.add_argument("--reference", default="1", metavar="A[,OMEGA]",
                   help="with --model: reference a·sin(omega t) per output, in the outputs' units and rad/s; "
                   "OMEGA 0 or absent: a step of height A (default 1)")
    p.add_argument("--measurement-bias", type=float, default=None, metavar="DELTA",
                   help="with a schedule file as --design: what the measurement of its parameter adds to the true "
                   "value, in the parameter's unit (default 0; +-measurement_error is the worst the certificate "
                   "covers)")
    p.add_argument("--disturbance", default=None, metavar="D[,D2,...]",
                   help="with --model: constant input disturbance from t_final/4 on, in the inputs' units; with a "
                   "URDF --robot: the amplitudes, N·m, one for every joint or one per joint, of a square-wave "
                   "disturbance torque whose period and phase are the robot file's [disturbance] (default pi/5 s, "
                   "0 rad); 0 switches the file's off")


def plant_gain(args: argparse.Namespace, plant: UncertainPlant, what: str) -> tuple[Any, str]:
    """The gain of a run: from ``--design`` or designed at ``--rho``/``--eta``, and how to name it.

    Parameters
    ----------
    args : argparse.Namespace
    plant : UncertainPlant
    what : str
        The design form, as an error message names it.

    Returns
    -------
    K : ndarray, shape (m, n)
    label : str
    """
    if is_schedule_file(option(args, "design")):
        schedule = read_schedule(args.design)
        if schedule.parameter not in plant.names or schedule.shape != (plant.n_inputs, plant.n_design_states):
            raise CommandLineError(f"`--design` {args.design!r}: schedules {schedule.parameter!r} with gains of shape "
                                   f"{schedule.shape}; this plant needs a parameter of {plant.names} and "
                                   f"({plant.n_inputs}, {plant.n_design_states})")
        return schedule, f"gain of {args.design!r} scheduled on {schedule.parameter}"
    if option(args, "measurement_bias") is not None:
        raise CommandLineError("`--measurement-bias` is the error of a scheduled gain's measurement; it goes with "
                               "--design SCHEDULE.json")
    check_gain_options(args)
    loaded = resolve_design(args, (plant.n_inputs, plant.n_design_states), what,
                            tuple(signal.name for signal in plant.outputs))
    if loaded is not None:
        return loaded.K, f"gain of {loaded.path!r}"
    d = design(as_model("model", plant), args.rho, args.eta)
    return d.K, f"K(rho={d.rho:g}, eta={d.eta:g})"


def series_output(args: argparse.Namespace, frame: Any, record: dict[str, Any]) -> tuple[str | None, str | None]:
    """A run's time series as ``--format`` and ``--output`` ask: JSON (`record` with the series) or CSV.

    Parameters
    ----------
    args : argparse.Namespace
    frame : pandas.DataFrame
        The run's samples.
    record : dict
        What the JSON holds beside the series (name, status, ...).

    Returns
    -------
    text : str or None
        The series to print instead of the summary (``--format csv|json`` without ``--output``).
    line : str or None
        The summary's line naming the file written.
    """
    if args.format == "json" or (args.format == "text" and str(args.series_output).lower().endswith(".json")):
        series = json.dumps({**record, "series": frame.to_dict(orient="list")})
    else:
        series = str(frame.to_csv(index=False))
    if args.series_output is not None:
        write_text("--output", args.series_output, series)
        return None, f"time series: {args.series_output}"
    return (series if args.format != "text" else None), None


def option_floats(option: str, text: str) -> list[float]:
    """An option's ``V,V,...`` as finite floats, or a :class:`CommandLineError` naming `option`."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise CommandLineError(f"`{option}` must be numbers separated by commas, found {text!r}") from None
    if not all(np.isfinite(values)):
        raise CommandLineError(f"`{option}` must be finite, found {text!r}")
    return values


def plant_profiles(args: argparse.Namespace, plant: UncertainPlant, t_final: float,
                   parameter: str | None = None) -> tuple[str, dict[str, Any]]:
    """The parameter driven and its profile, from ``--parameter`` and ``--profile``.

    Parameters
    ----------
    args : argparse.Namespace
    plant : UncertainPlant
    t_final : float
        Horizon, s.
    parameter : str, optional
        The parameter driven, instead of ``--parameter`` (an arm's payload ``m_p``).

    Returns
    -------
    name : str
    profiles : dict
        ``{name: p(t)}``.
    """
    varying = [p.name for p in plant.varying]
    if not varying:
        return "", {}
    name = args.parameter if parameter is None else parameter
    if name is None:
        rated = [p.name for p in plant.varying if p.rate is not None]
        name = rated[0] if rated else varying[-1]
    elif name not in plant.names:
        raise CommandLineError(f"`--parameter` must be one of {', '.join(plant.names)}, found {name!r}")
    kind, _, rest = args.profile.partition(":")
    kwargs: dict[str, Any] = {"t_final": t_final}
    if kind.lower().endswith(".csv"):
        if not rest:
            raise CommandLineError(f"`--profile` FILE.csv:COLUMN names a column, found {args.profile!r}")
        kwargs.update(path=kind, column=rest)
        kind = "csv"
    elif kind not in PROFILES or kind == "csv":
        raise CommandLineError(f"`--profile` must be constant[:VALUE], sinusoid[:PERIOD_S], ramp, random-walk[:SEED] "
                               f"or FILE.csv:COLUMN, found {args.profile!r}")
    elif rest:
        if kind == "ramp":
            raise CommandLineError(f"`--profile` ramp takes no value (it runs at the rate bound), found "
                                   f"{args.profile!r}")
        value = option_floats("--profile", rest)[0]
        key = {"constant": "value", "sinusoid": "period", "random-walk": "seed"}[kind]
        if key == "seed":
            if value != int(value) or value < 0:
                raise CommandLineError(f"`--profile` random-walk:SEED takes an integer >= 0, found {rest!r}")
            kwargs[key] = int(value)
        else:
            kwargs[key] = value
    try:
        profile = parameter_profile(plant, name, kind, **kwargs)
    except InputFileError as err:
        raise CommandLineError(f"`--profile` {err}") from err
    except OSError as err:
        raise CommandLineError(f"`--profile` {kwargs.get('path')!r}: {os_error_text(err)}") from err
    except ArgumentError as err:
        raise CommandLineError(f"`--profile` {args.profile!r}: `{err.argument}` {err.problem}") from err
    return name, {name: profile}


def plant_run(args: argparse.Namespace, plant: UncertainPlant, K: Any, t_final: float) -> PlantRun:
    """Simulate the plant with gain K under the options' profile, reference and disturbance.

    Parameters
    ----------
    args : argparse.Namespace
    plant : UncertainPlant
    K : ndarray, shape (m, n)
    t_final : float

    Returns
    -------
    PlantRun
    """
    _, profiles = plant_profiles(args, plant, t_final)
    reference, dist = run_inputs(args, plant)
    ts = option(args, "ts")
    if ts is not None and not (np.isfinite(ts) and ts > 0):
        raise CommandLineError(f"`--ts` must be a sample time > 0 s, found {ts:g}")
    bias = option(args, "measurement_bias")
    if schedule_of(K) is not None:
        if ts is not None:
            raise CommandLineError("`--ts` samples a fixed gain here; a scheduled gain runs continuous (its sampled-"
                                   "data certificate is export's)")
        if bias is not None and not np.isfinite(bias):
            raise CommandLineError(f"`--measurement-bias` must be a number, found {bias}")
    gain = K if ts is None else SampledStateFeedback(K, ts)
    x0 = None
    if option(args, "x0") is not None:
        x0 = option_floats("--x0", args.x0)
        if len(x0) != plant.n_states:
            raise CommandLineError(f"`--x0` takes {plant.n_states} values (one per state of the plant), found "
                                   f"{len(x0)}")
    if plant.form == "state" and dist is None and (x0 is None or not any(x0)):
        raise CommandLineError("a plant in the state form is regulated to zero and starts at rest: give --x0 (an "
                               "initial state) or --disturbance, or nothing moves")
    return simulate_plant(plant, gain, profiles=profiles, reference=reference, disturbance=dist, t_final=t_final,
                          x0=x0, tolerance=args.tolerance, measurement_bias=bias or 0.0)


def run_inputs(args: argparse.Namespace, plant: UncertainPlant) -> tuple[tuple[float, float], Any]:
    """The reference ``(amplitude, omega)`` and the input disturbance of ``--reference``, ``--disturbance``.

    Parameters
    ----------
    args : argparse.Namespace
    plant : UncertainPlant

    Returns
    -------
    reference : (float, float)
    disturbance : ndarray, shape (m,), or None
    """
    ref = option_floats("--reference", args.reference)
    if len(ref) > 2:
        raise CommandLineError(f"`--reference` is A or A,OMEGA, found {args.reference!r}")
    if len(ref) == 2 and ref[1] < 0:
        raise CommandLineError(f"`--reference` OMEGA must be >= 0 rad/s, found {ref[1]:g}")
    dist = None
    if args.disturbance is not None:
        values = option_floats("--disturbance", args.disturbance)
        m = plant.n_inputs
        if len(values) not in (1, m):
            raise CommandLineError(f"`--disturbance` takes 1 or {m} values (one per input), found {len(values)}")
        dist = np.broadcast_to(values, (m,)).astype(float)
    return (ref[0], ref[1] if len(ref) == 2 else 0.0), dist


def summary(run: PlantRun, plant: UncertainPlant, head: str) -> list[str]:
    """Lines summarizing a plant run: status, errors and inputs with units, parameter ranges and rates.

    Parameters
    ----------
    run : PlantRun
    plant : UncertainPlant
    head : str
        The first line.

    Returns
    -------
    list of str
    """
    out_unit = plant.outputs[0].unit
    worst = ("not resolved (fewer than 2 samples after it)" if np.isnan(run.max_abs_error)
             else f"= {run.max_abs_error:.4g} {out_unit}")
    lines = [head, f"status: {run.status} ({run.reason})", f"  max |e| after the transient {worst}",
             *[f"  peak |{s.name}| = {float(np.abs(run.u[k]).max()):.4g} {s.unit}" for k, s in enumerate(plant.inputs)]]
    for k, prm in enumerate(plant.parameters):
        if prm.varies:
            rate = "" if prm.rate is None else f" (bound {prm.rate:.4g})"
            lines.append(f"  {prm.name} in [{run.p[k].min():.6g}, {run.p[k].max():.6g}] {prm.unit}, "
                         f"max |d{prm.name}/dt| = {run.max_rate[k]:.4g} {per_second(prm.unit)}{rate}")
    return lines
