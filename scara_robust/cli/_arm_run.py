"""``simulate --robot F`` and ``compare --robot F`` for a robot file naming a URDF: runs of the arm."""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
import pandas as pd

from ..lyapunov.gain import design
from ..lyapunov.theorem1 import certify
from ..model.arm import ArmSetup
from ..plotting import plot_arm_run
from ..robustness.lmi import lmi_certificate
from ..robustness.parameters import parameter_margin
from ..robustness.synthesis import decay_rate, synthesize
from ..simulation.arm import ArmRun, simulate_arm
from ..simulation.metrics import TRACKING_TOLERANCE
from ._common import CommandLineError, resolve_design, save_figure
from ._plant_run import plant_gain, plant_profiles, series_output
from ._system import LoadedSystem

__all__ = ["run_arm", "compare_arm"]

#: Options of the SCARA's or a plant file's runs that mean nothing for an arm.
_NOT_FOR_ARMS = ("controller", "from_campaign", "index", "payload", "method", "torque_limit", "disturbance")


def _refuse(args: argparse.Namespace, system: LoadedSystem) -> None:
    given = [o for o in _NOT_FOR_ARMS if getattr(args, o, None) is not None]
    if getattr(args, "reference", "1") != "1":
        given.append("reference")
    if given:
        raise CommandLineError(f"`--{given[0].replace('_', '-')}` is not an option of a URDF robot's runs (its "
                               f"reference and payload range are in {system.file!r}; --profile drives the payload)")
    if getattr(args, "parameter", None) not in (None, "m_p"):
        raise CommandLineError(f"`--parameter` of an arm's run is its payload m_p, found {args.parameter!r}")


def _payload(args: argparse.Namespace, setup: ArmSetup, t_final: float) -> Any:
    if not setup.plant.parameter("m_p").varies:
        return None
    return plant_profiles(args, setup.plant, t_final, parameter="m_p")[1]["m_p"]  # --profile drives the payload


def _lines(run: ArmRun, elapsed: float) -> list[str]:
    worst = run.metrics().max_abs_error if run.has_metrics else float("nan")
    lines = [f"status: {run.status} ({run.status_reason})",
             f"  max |e| after {run.t_transient:g} s = {worst:.4g} rad; peak |τ| = {np.abs(run.torque).max():.4g} N·m",
             f"  payload in [{run.payload.min():.4g}, {run.payload.max():.4g}] kg",
             f"  run: {elapsed:.2f} s of computing for {run.t[-1]:g} s simulated ({run.method})"]
    for i, joint in enumerate(run.joints):
        after = run.t >= run.t_transient
        e_i = float(np.abs(run.e[i, after]).max()) if after.sum() else float("nan")
        lines.append(f"    {joint}: max |e| after = {e_i:.4g} rad, peak |τ| = {np.abs(run.torque[i]).max():.4g} N·m")
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
    _refuse(args, system)
    setup = system.arm()
    plant = setup.plant
    n = setup.arm.n_joints
    K, gain = plant_gain(args, plant, f"this arm's PID form ({n} joints)")
    t_final = 20.0 if args.t_final is None else args.t_final
    start = time.perf_counter()
    run = simulate_arm(setup, K, _payload(args, setup, t_final), t_final=t_final,
                       tracking_tolerance=TRACKING_TOLERANCE if args.tolerance is None else args.tolerance)
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
    head = f"{setup.name} ({n} joints, feedforward {setup.feedforward}), {gain}, {t_final:g} s, payload {args.profile}"
    return "\n".join([head, *_lines(run, elapsed),
                      *(files or ["time series: not written (use --output FILE or --format csv|json)"])])


def compare_arm(args: argparse.Namespace, system: LoadedSystem, rho: float, eta: float,
                t_final: float | None) -> pd.DataFrame:
    """``compare --robot F`` on an arm: the Riccati PID, the synthesized PID and design files side by side.

    Each row: the gain's size, Theorem 1 on the interval box (with the Riccati design's
    P), the decay rate ``V̇ <= −2αV`` that a common P proves on the arm's samples (the
    larger of one found by the LMI and a design file's own P, each verified by numpy on
    the file's grid; a lower bound on the best one), the payload beyond which a frozen
    plant is unstable (kg) and a run of the nonlinear arm.

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
    _refuse(args, system)
    setup = system.arm()
    plant = setup.plant
    model = plant.interval_model()
    n = setup.arm.n_joints
    d = design(model, rho, eta)
    designs: dict[str, Any] = {f"riccati (rho={d.rho:g}, eta={d.eta:g})": d}
    notes: list[str] = []
    on, check = plant.samples(plant.coarse_points()), plant.samples()
    if not args.no_synthesis:
        synth = synthesize((on.A, on.B))
        if synth.design is not None and synth.certified:
            designs["synthesized (LMI on samples, decay)"] = synth.design
        else:
            notes.append(f"synthesized PID left out: {synth.message}")
    for path in args.design or []:
        loaded = resolve_design(argparse.Namespace(design=path), (n, 3 * n), f"this arm's PID form ({n} joints)")
        assert loaded is not None
        designs[f"file {path}"] = (loaded.K, loaded.P)
    t_final = 20.0 if t_final is None else t_final
    payload = _payload(args, setup, t_final)
    rows = []
    for name, des in designs.items():
        K, P_file = des if isinstance(des, tuple) else (des.K, None)
        row: dict[str, Any] = {"design": name, "max |K|": float(np.abs(K).max())}
        # Theorem 1 needs the Riccati design's P; the decay is the larger of what a common P found by
        # the LMI on the arm's coarse samples and the file's own P prove, each verified on the file's grid
        row["theorem1 max eig"] = certify(model, des).max_eig if not isinstance(des, tuple) else np.nan
        loops, coarse = check.closed_loops(K), on.closed_loops(K)
        lmi = lmi_certificate(coarse)
        candidates = [P for P in (lmi.P, P_file) if P is not None]
        decay = max((min(decay_rate(coarse, P), decay_rate(loops, P)) for P in candidates), default=np.nan)
        row["decay rate [1/s]"] = decay if decay > 0 else np.nan
        row["m_p frozen limit [kg]"] = float(parameter_margin(plant, K, ["frozen"])["m_p high [kg]"].iloc[0])
        start = time.perf_counter()
        run = simulate_arm(setup, K, payload, t_final=t_final)
        row.update({"status": run.status,
                    "max |e| after 6 s [rad]": run.metrics().max_abs_error if run.has_metrics else np.nan,
                    "peak |τ| [N·m]": float(np.abs(run.torque).max()),
                    "run [s]": time.perf_counter() - start})
        rows.append(row)
    table = pd.DataFrame(rows)
    table.attrs["notes"] = notes
    return table
