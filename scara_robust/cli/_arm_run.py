"""``simulate --robot F`` and ``compare --robot F`` for a robot file naming a URDF: runs of the arm."""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
import pandas as pd

from ..io import square_wave
from ..lyapunov.gain import design
from ..lyapunov.theorem1 import certify
from ..model.arm import ArmSetup
from ..paper import PAPER_DISTURBANCE_PERIOD
from ..plotting import plot_arm_run
from ..robustness.decay import design_decay_rate
from ..robustness.loop_margins import worst_loop_margins
from ..robustness.parameters import frozen_limit, parameter_margin
from ..robustness.synthesis import synthesize
from ..simulation.arm import ARM_ENGINES, ArmRun, simulate_arm
from ..simulation.metrics import TRACKING_TOLERANCE
from ._common import CommandLineError, per_joint_values, resolve_design, save_figure
from ._options import given, option
from ._plant_run import option_floats, plant_gain, plant_profiles, series_output
from ._system import LoadedSystem

__all__ = ["run_arm", "compare_arm", "add_arm_run_options", "refuse_arm_options", "arm_run_inputs",
           "check_arm_options", "torque_limit_text"]

#: Options of the SCARA's or a plant file's runs that mean nothing for an arm.
_NOT_FOR_ARMS = ("controller", "from_campaign", "index", "payload")
#: Options of an arm's run only: its initial error.
_ARM_ONLY = ("e0", "edot0")


def add_arm_run_options(p: argparse.ArgumentParser) -> None:
    """Options of a URDF arm's runs: its initial error ``--e0``, ``--edot0`` (``--disturbance`` is shared).

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    p.add_argument("--e0", type=per_joint_values, default=None, metavar="E[,E2,...]",
                   help="with a URDF --robot: initial tracking error e(0) = r(0) - q(0), rad, one value for every "
                   "joint or one per joint (default: the robot file's [initial], else 0; a negative first value "
                   "as --e0=-1.5,2.5)")
    p.add_argument("--edot0", type=per_joint_values, default=None, metavar="V[,V2,...]",
                   help="with a URDF --robot: initial error rate, rad/s, one value for every joint or one per joint "
                   "(default: the robot file's [initial], else 0)")


def refuse_arm_options(args: argparse.Namespace, instead: str) -> None:
    """Refuse ``--e0``/``--edot0`` on a run that is not an arm's.

    Parameters
    ----------
    args : argparse.Namespace
    instead : str
        What gives that run its initial condition, for the message.

    Raises
    ------
    CommandLineError
    """
    arm_only = given(args, _ARM_ONLY)
    if arm_only:
        raise CommandLineError(f"`--{arm_only[0]}` is the initial error of a URDF robot's run; {instead}")


def _per_joint(option: str, values: list[float], n: int, unit: str) -> list[float]:
    if len(values) not in (1, n):
        raise CommandLineError(f"`{option}` takes 1 or {n} values in {unit} (one for every joint, or one per joint "
                               f"of the arm's {n}), found {len(values)}")
    return values * n if len(values) == 1 else values


def arm_run_inputs(args: argparse.Namespace, setup: ArmSetup) -> dict[str, Any]:
    """:func:`simulate_arm`'s ``e0``, ``edot0`` and ``disturbance`` from the options (None: the robot file's)."""
    n = setup.arm.n_joints
    inputs: dict[str, Any] = {}
    for key, unit in (("e0", "rad"), ("edot0", "rad/s")):
        values = option(args, key)
        inputs[key] = None if values is None else _per_joint(f"--{key}", values, n, unit)
    inputs["disturbance"] = None
    if option(args, "disturbance") is not None:
        amplitudes = _per_joint("--disturbance", option_floats("--disturbance", args.disturbance), n, "N·m")
        wave = setup.disturbance  # its period and phase, else the paper's
        inputs["disturbance"] = square_wave(amplitudes, PAPER_DISTURBANCE_PERIOD if wave is None else wave.period,
                                            0.0 if wave is None else wave.phase)
    return inputs


def torque_limit_text(setup: ArmSetup, given: list[float] | None) -> str:
    """How a run's head names the torque limits it clips to: ``--torque-limit``'s, else the arm's effort limits."""
    limits = given if given is not None else setup.torque_limit
    if limits is None:
        return ""
    values = ", ".join("none" if np.isinf(v) else f"{v:g}" for v in limits)
    source = "--torque-limit" if given is not None else "the arm's effort limits, from its URDF or robot file"
    return f", total torque clipped to ±[{values}] N·m ({source})"


def _describe_inputs(inputs: dict[str, Any], setup: ArmSetup) -> str:
    """How a run's head names its initial error and disturbance ("" when the run has neither)."""
    e0 = inputs["e0"] if inputs["e0"] is not None else setup.e0
    edot0 = inputs["edot0"] if inputs["edot0"] is not None else setup.edot0
    wave = inputs["disturbance"] if inputs["disturbance"] is not None else setup.disturbance
    parts = []
    if (e0 is not None and any(e0)) or (edot0 is not None and any(edot0)):
        zero = [0.0] * setup.arm.n_joints
        parts.append(f"from e0 = [{', '.join(f'{v:g}' for v in e0 or zero)}] rad, "
                     f"ė0 = [{', '.join(f'{v:g}' for v in edot0 or zero)}] rad/s")
    if wave is not None and wave.amplitude > 0:
        torques = ", ".join(f"{wave.amplitude * s:g}" for s in wave.signs)
        parts.append(f"disturbance ±[{torques}] N·m square wave of period {wave.period:.4g} s")
    return "".join(f", {p}" for p in parts)


def check_arm_options(args: argparse.Namespace, system: LoadedSystem) -> None:
    """Refuse the options of the SCARA's or a plant file's runs on a URDF arm's, in one line each."""
    if option(args, "x0") is not None:
        raise CommandLineError("`--x0` is a plant file's initial state; a URDF robot's run starts from the initial "
                               "error --e0 (rad) and --edot0 (rad/s), one value per joint")
    refused = given(args, {**dict.fromkeys(_NOT_FOR_ARMS), "reference": "1"})
    if refused:
        raise CommandLineError(f"`--{refused[0].replace('_', '-')}` is not an option of a URDF robot's runs (its "
                               f"reference and payload range are in {system.file!r}; --profile drives the payload)")
    if option(args, "parameter") not in (None, "m_p"):
        raise CommandLineError(f"`--parameter` of an arm's run is its payload m_p, found {args.parameter!r}")
    if option(args, "method") not in (None, *ARM_ENGINES):
        raise CommandLineError(f"`--method` of an arm's run is one of {', '.join(ARM_ENGINES)}, found {args.method!r}")


def _payload(args: argparse.Namespace, setup: ArmSetup, t_final: float) -> Any:
    if not setup.plant.parameter("m_p").varies:
        return None
    return plant_profiles(args, setup.plant, t_final, parameter="m_p")[1]["m_p"]  # --profile drives the payload


def _lines(run: ArmRun, elapsed: float) -> list[str]:
    worst = (f"= {run.metrics().max_abs_error:.4g} rad" if run.has_metrics else
             f"not resolved (the run ends at {run.t[-1]:g} s)")
    lines = [f"status: {run.status} ({run.status_reason})",
             f"  max |e| after {run.t_transient:g} s {worst}; peak |τ| = {np.abs(run.torque).max():.4g} N·m",
             f"  payload in [{run.payload.min():.4g}, {run.payload.max():.4g}] kg",
             f"  run: {elapsed:.2f} s of computing for {run.t[-1]:g} s simulated ({run.method})"]
    for i, joint in enumerate(run.joints):
        after = run.t >= run.t_transient
        e_i = f"= {float(np.abs(run.e[i, after]).max()):.4g} rad" if after.sum() >= 2 else "not resolved"
        lines.append(f"    {joint}: max |e| after {e_i}, peak |τ| = {np.abs(run.torque[i]).max():.4g} N·m")
    return lines


def run_arm(args: argparse.Namespace, system: LoadedSystem) -> str:
    """``simulate --robot F`` on an arm: the nonlinear loop (Pinocchio's ABA) under the PID.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem
        An arm (:meth:`LoadedSystem.arm`).

    Returns
    -------
    str
    """
    check_arm_options(args, system)
    setup = system.arm()
    plant = setup.plant
    n = setup.arm.n_joints
    K, gain = plant_gain(args, plant, f"this arm's PID form ({n} joints)")
    t_final = 20.0 if args.t_final is None else args.t_final
    inputs = arm_run_inputs(args, setup)
    start = time.perf_counter()
    engine: dict[str, Any] = {} if args.method is None else {"method": args.method}
    if option(args, "measurement_bias") is not None:
        engine["measurement_bias"] = args.measurement_bias  # a schedule file's (plant_gain refuses it otherwise)
    if option(args, "torque_limit") is not None:
        engine["torque_limit"] = _per_joint("--torque-limit", args.torque_limit, n, "N·m")
    run = simulate_arm(setup, K, _payload(args, setup, t_final), t_final=t_final,
                       tracking_tolerance=TRACKING_TOLERANCE if args.tolerance is None else args.tolerance,
                       **engine, **inputs)
    elapsed = time.perf_counter() - start
    files = []
    if args.plot is not None:
        save_figure("--plot", args.plot, plot_arm_run(run, title=f"{setup.name}, {gain}: {run.status}"))
        files.append(f"figure: {args.plot}")
    text, written = series_output(args, run.to_pandas(), {
        "robot": setup.name, "status": run.status, "status_reason": run.status_reason,
        "max_abs_error": run.metrics().max_abs_error if run.has_metrics else None})
    if text is not None:
        return text
    files += [written] if written else []
    measured = f" measured {args.measurement_bias:+g} kg off" if "measurement_bias" in engine else ""
    head = (f"{setup.name} ({n} joints, feedforward {setup.feedforward}), {gain}, {t_final:g} s, payload {args.profile}"
            f"{measured}{_describe_inputs(inputs, setup)}{torque_limit_text(setup, engine.get('torque_limit'))}")
    return "\n".join([head, *_lines(run, elapsed),
                      *(files or ["time series: not written (use --output FILE or --format csv|json)"])])


def compare_arm(args: argparse.Namespace, system: LoadedSystem, rho: float, eta: float,
                t_final: float | None) -> pd.DataFrame:
    """``compare --robot F`` on an arm: the Riccati PID, the synthesized PID and design files side by side.

    Each row: the gain's size, Theorem 1 on the interval box (with the Riccati design's
    P), the decay rate ``V̇ <= −2αV`` of :func:`scara_robust.design_decay_rate` on the
    arm's samples (the larger of the design's own P and a common P found by the LMI, each
    verified by numpy on the file's grids; a lower bound on the best one, to
    :data:`~scara_robust.DECAY_RTOL`, with the LMI certificate solved only where the search
    needs it: ``certificate=False``), the payload
    beyond which a frozen plant is unstable (kg, and which end) and a run of the
    nonlinear arm, the worst disk and delay margins over the arm's samples
    (:func:`scara_robust.worst_loop_margins`; 0 when a frozen loop is unstable).

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem
        An arm (:meth:`LoadedSystem.arm`).
    rho, eta : float
        The Riccati design point.
    t_final : float or None
        Horizon of the runs, s (None: 20 s).

    Returns
    -------
    pandas.DataFrame
    """
    check_arm_options(args, system)
    setup = system.arm()
    plant = setup.plant
    model = plant.interval_model()
    n = setup.arm.n_joints
    d = design(model, rho, eta)
    designs: dict[str, Any] = {f"riccati (rho={d.rho:g}, eta={d.eta:g})": d}
    notes: list[str] = []
    on = plant.samples(plant.coarse_points())
    if not args.no_synthesis:
        synth = synthesize((on.A, on.B))
        if synth.design is not None and synth.certified:
            designs["synthesized (LMI on samples, decay)"] = synth.design
        else:
            notes.append(f"synthesized PID left out: {synth.message}")
    for path in args.design or []:
        loaded = resolve_design(argparse.Namespace(design=path), (n, 3 * n), f"this arm's PID form ({n} joints)",
                                system.joint_names())
        assert loaded is not None
        designs[f"file {path}"] = (loaded.K, loaded.P)
    t_final = 20.0 if t_final is None else t_final
    payload = _payload(args, setup, t_final)
    inputs = arm_run_inputs(args, setup)
    rows = []
    for name, des in designs.items():
        K, P_file = des if isinstance(des, tuple) else (des.K, None)
        row: dict[str, Any] = {"design": name, "max |K|": float(np.abs(K).max())}
        # Theorem 1 needs the Riccati design's P; the decay is the larger of what a common P found by
        # the LMI on the arm's coarse samples and the file's own P prove, each verified on the file's grid
        row["theorem1 max eig"] = certify(model, des).max_eig if not isinstance(des, tuple) else np.nan
        # the rate alone is reported: the LMI certificate is solved only where the search needs it
        decay = design_decay_rate(model, K if isinstance(des, tuple) else des, P=P_file, plant=plant,
                                  certificate=False)
        row["decay rate [1/s]"] = decay.rate
        row["decay rate from"] = decay.source or "none"
        loops = worst_loop_margins(plant, K, points=plant.grid_points())
        row["disk margin α"] = float(loops.disk_margin.min()) if loops.certified else 0.0
        row["delay margin [s]"] = float(loops.delay_margin.min()) if loops.certified else 0.0
        row["m_p frozen limit [kg]"], row["m_p frozen end"] = frozen_limit(parameter_margin(plant, K, ["frozen"]),
                                                                           plant.parameter("m_p"))
        start = time.perf_counter()
        run = simulate_arm(setup, K, payload, t_final=t_final, **inputs)
        row.update({"status": run.status,
                    "max |e| after 6 s [rad]": run.metrics().max_abs_error if run.has_metrics else np.nan,
                    "peak |τ| [N·m]": float(np.abs(run.torque).max()),
                    "run [s]": time.perf_counter() - start})
        rows.append(row)
    table = pd.DataFrame(rows)
    table.attrs["notes"] = notes
    table.attrs["inputs"] = _describe_inputs(inputs, setup)  # the runs' initial error and disturbance, for the head
    return table
