"""Campaigns on a URDF arm: the PID K(ρ, η) of the arm's plant on drawn scenarios.

``campaign --robot F`` with a robot file naming a URDF runs here. A spec for an arm
(:func:`~scara_robust.arm_campaign_spec`) draws, per scenario, the payload profile and its numbers, the
square-wave disturbance, one initial error per joint, the torque limit, a scale of the
robot file's reference amplitudes and the measurement noise
(:data:`~scara_robust.ARM_SPEC_FIELDS`); the SCARA's own fields
(``cp``, ``reference_amplitude``, ``reference_omega``) are refused, the arm's payload
inertia and reference being its robot file's. Scenario ``i`` of seed ``s`` is drawn from
``default_rng([s, i])``, its noise's frequencies and phases from ``default_rng([s, i, 1])``,
so a scenario is the same however the campaign is split, resumed or distributed.

Each run is :func:`scara_robust.simulate_arm` of the drawn inputs: on the compiled engine
(``engine='compiled'``) or LSODA with Pinocchio's dynamics (``'scipy'``), judged by the same
metrics and statuses as the SCARA's runs.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ..._validation import check_int
from ...exceptions import ArgumentValueError, CampaignSpecError
from ...io import load_arm
from ...lyapunov.gain import design
from ...model.arm import ArmSetup, JointSinusoids
from ...model.signals import MeasurementNoise
from ...simulation.arm import ArmRun, simulate_arm
from ...simulation.metrics import METRIC_NAMES
from .inputs import drawn_disturbance, drawn_payload
from .spec import ARM_SPEC_FIELDS, SCARA_ONLY_FIELDS, SPEC_FIELDS, CampaignSpec, Range, _default_ranges

__all__ = ["arm_campaign_spec", "draw_arm_scenario", "run_arm_draws", "replay_arm_scenario"]

#: Controllers an arm campaign runs: the PID K(ρ, η) designed on the arm's plant.
ARM_CONTROLLERS = ("pid",)
#: Columns of an arm campaign's table that hold its fixed inputs: horizon (s), design point, robot file.
ARM_FIXED_COLUMNS = ("t_final", "rho", "eta", "robot_file")
#: Sinusoids per joint of the drawn measurement noise.
NOISE_COMPONENTS = 8
#: Drawn fields of an arm campaign, in the order they are drawn (after the payload profile).
_ARM_DRAWN = tuple(n for n in SPEC_FIELDS if n not in SCARA_ONLY_FIELDS and n != "initial_error")


def _file_digest(robot_file: str, urdf: str) -> str:
    sha = hashlib.sha256()
    for path in (robot_file, urdf):
        with open(path, "rb") as handle:
            sha.update(handle.read())
    return sha.hexdigest()[:12]


def arm_campaign_spec(spec: CampaignSpec, robot_file: str | os.PathLike[str]) -> CampaignSpec:
    """`spec` for the arm of `robot_file`: its arm fields completed, its SCARA fields refused.

    Parameters
    ----------
    spec : CampaignSpec
        As read by :func:`~scara_robust.load_spec`.
    robot_file : path-like
        A robot file naming a URDF (:func:`scara_robust.load_arm`).

    Returns
    -------
    CampaignSpec
        With ``robot_file`` (absolute), ``robot_digest`` and every arm field.

    Raises
    ------
    CampaignSpecError
        Naming the field: a SCARA-only field given, or a controller an arm does not run.
    """
    defaults = _default_ranges()
    for name in SCARA_ONLY_FIELDS:
        if spec.ranges[name] != defaults[name]:
            raise CampaignSpecError(
                f"campaign spec field `{name}`: describes the SCARA; the arm of {os.fspath(robot_file)!r} takes its "
                "payload inertia and reference from its robot file (scale its reference with `reference_scale`)")
    others = [c for c in spec.controllers if c not in ARM_CONTROLLERS]
    if others:
        raise CampaignSpecError(
            f"campaign spec field `controllers`: an arm campaign runs {', '.join(ARM_CONTROLLERS)} (the PID K(rho, "
            f"eta) on the arm's plant), found {others[0]!r} (the default is the SCARA's pid and smc: write "
            "controllers = [\"pid\"])")
    path = os.path.abspath(os.fspath(robot_file))
    setup = load_arm(path)
    ranges = {name: Range(v[3], v[3]) for name, v in ARM_SPEC_FIELDS.items()}
    ranges.update(spec.arm_ranges)
    return dataclasses.replace(spec, arm_ranges=ranges, robot_file=path,
                               robot_digest=_file_digest(path, setup.arm.urdf))


def arm_drawn_columns(n: int) -> tuple[str, ...]:
    """Columns of an arm campaign's table that hold its drawn inputs (``e1_0 ... en_0`` in rad).

    Parameters
    ----------
    n : int
        Joints.

    Returns
    -------
    tuple of str
    """
    return ("payload_profile", *_ARM_DRAWN, *ARM_SPEC_FIELDS, *(f"e{k + 1}_0" for k in range(n)))


def draw_arm_scenario(spec: CampaignSpec, seed: int, index: int, n: int) -> dict[str, Any]:
    """The inputs of scenario `index` of an arm campaign, drawn from ``default_rng([seed, index])``.

    Parameters
    ----------
    spec : CampaignSpec
        Of :func:`~scara_robust.arm_campaign_spec`.
    seed, index : int
    n : int
        The arm's joints.

    Returns
    -------
    dict
        ``scenario``, ``payload_profile``, one value per drawn field and ``e1_0 ... en_0``.
    """
    rng = np.random.default_rng([int(seed), int(index)])
    out: dict[str, Any] = {"scenario": int(index)}
    out["payload_profile"] = spec.payload_profiles[int(rng.integers(len(spec.payload_profiles)))]
    for name in _ARM_DRAWN:
        out[name] = spec.ranges[name].draw(rng)
    for name in ARM_SPEC_FIELDS:
        out[name] = spec.arm_ranges[name].draw(rng)
    for k in range(n):
        out[f"e{k + 1}_0"] = spec.ranges["initial_error"].draw(rng)
    return out


@functools.lru_cache(maxsize=4)
def _arm(robot_file: str, rho: float, eta: float) -> tuple[ArmSetup, np.ndarray]:
    # one load and one Riccati solve per process, not one per run
    setup = load_arm(robot_file)
    return setup, design(setup.plant, rho, eta).K


def arm_context(spec: CampaignSpec) -> tuple[ArmSetup, np.ndarray]:
    """The arm of `spec` and its PID gain K(ρ, η), loaded once per process.

    Parameters
    ----------
    spec : CampaignSpec
        Of :func:`~scara_robust.arm_campaign_spec`.

    Returns
    -------
    setup : ArmSetup
    K : ndarray, shape (n, 3n)
    """
    assert spec.robot_file is not None
    return _arm(spec.robot_file, float(spec.rho), float(spec.eta))


def arm_run_arguments(spec: CampaignSpec, inputs: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """The arguments of :func:`scara_robust.simulate_arm` for one drawn scenario.

    Parameters
    ----------
    spec : CampaignSpec
        Of :func:`~scara_robust.arm_campaign_spec`.
    inputs : mapping
        A draw of :func:`~scara_robust.draw_arm_scenario` (or a row of the table).
    seed : int
        The campaign's seed (the noise is drawn from ``default_rng([seed, scenario, 1])``).

    Returns
    -------
    dict
        ``setup`` (the reference scaled), ``K``, ``payload``, ``e0``, ``edot0``,
        ``disturbance``, ``t_final``, ``torque_limit`` and ``noise``.
    """
    setup, K = arm_context(spec)
    n = setup.arm.n_joints
    ref = setup.reference
    scale = float(inputs["reference_scale"])
    if scale != 1.0:
        ref = JointSinusoids(ref.center, tuple(scale * a for a in ref.amplitude), ref.omega, ref.phase)
        setup = dataclasses.replace(setup, reference=ref)
    payload = drawn_payload(inputs)
    signs = setup.disturbance.signs if setup.disturbance is not None else (1.0,) * n
    disturbance = drawn_disturbance(inputs, signs)
    rms = float(inputs["measurement_noise"])
    noise = None
    if rms > 0:
        rng = np.random.default_rng([int(seed), int(inputs["scenario"]), 1])
        noise = MeasurementNoise.draw(rms, float(inputs["noise_bandwidth"]), n, rng, NOISE_COMPONENTS)
    limit = float(inputs["torque_limit"])
    return {
        "setup": setup,
        "K": K,
        "payload": payload,
        "e0": np.array([float(inputs[f"e{k + 1}_0"]) for k in range(n)]),
        "edot0": np.zeros(n),
        "disturbance": disturbance,
        "t_final": float(spec.t_final),
        "torque_limit": None if math.isinf(limit) else limit,
        "noise": noise,
    }


def run_arm_draws(spec: CampaignSpec, draws: Sequence[Mapping[str, Any]], seed: int,
                  engine: str = "scipy") -> list[dict[str, Any]]:
    """Run the PID on each drawn scenario of an arm campaign; one row each.

    Parameters
    ----------
    spec : CampaignSpec
        Of :func:`~scara_robust.arm_campaign_spec`.
    draws : sequence of mapping
        From :func:`~scara_robust.draw_arm_scenario`.
    seed : int
        The campaign's seed.
    engine : {'scipy', 'compiled'}
        ``'compiled'``: :func:`~scara_robust.simulate_arm`'s compiled engine (BDF);
        ``'scipy'``: LSODA on Pinocchio's dynamics.

    Returns
    -------
    list of dict
        The drawn and fixed inputs, ``controller``, ``method``, ``success``, ``diverged``,
        ``error``, ``status``, ``status_reason`` and the metrics of
        :func:`scara_robust.tracking_metrics`; a run that raises is a ``failed`` row.
    """
    method = "compiled" if engine == "compiled" else "lsoda"
    fixed = {"t_final": float(spec.t_final), "rho": float(spec.rho), "eta": float(spec.eta),
             "robot_file": spec.robot_file}
    rows: list[dict[str, Any]] = []
    for draw in draws:
        row: dict[str, Any] = {**draw, **fixed, "controller": "pid", "method": method}
        metrics = dict.fromkeys(METRIC_NAMES, math.nan)
        try:
            run = simulate_arm(method=method, **arm_run_arguments(spec, draw, seed))
        except Exception as err:  # a failed scenario is data, not a crash
            error = f"{type(err).__name__}: {err}"
            row.update(success=False, diverged=False, error=error, status="failed", status_reason=error)
        else:
            row.update(success=run.success, diverged=run.diverged, error="" if run.success else run.message,
                       status=run.status, status_reason=run.status_reason)
            if run.success and run.has_metrics:
                metrics = run.metrics().to_dict()
        row.update(metrics)
        rows.append(row)
    return rows


def replay_arm_scenario(results: pd.DataFrame, index: int, *, method: str | None = None,
                        t_final: float | None = None) -> ArmRun:
    """Run scenario `index` of an arm campaign's table again, from the inputs in its row.

    Parameters
    ----------
    results : pandas.DataFrame
        An arm campaign's table (:func:`~scara_robust.read_results`).
    index : int
        The scenario index, >= 0.
    method : {'compiled', 'lsoda'}, optional
        Default: the engine the row used.
    t_final : float, optional
        Horizon, s (default: the campaign's).

    Returns
    -------
    ArmRun
        With the row's engine and horizon, its metrics and status are the row's.

    Raises
    ------
    ArgumentValueError
        If the table is not an arm campaign's (`results`) or lacks scenario `index`.
    """
    index = check_int("index", index, 0)
    if not isinstance(results, pd.DataFrame) or "robot_file" not in results.columns:
        raise ArgumentValueError("results", "must be an arm campaign's table (with a robot_file column)")
    rows = results[results["scenario"] == index]
    if not len(rows):
        raise ArgumentValueError("index", f"must be a scenario of the table, found {index}")
    row = rows.iloc[0].to_dict()
    spec = CampaignSpec(controllers=ARM_CONTROLLERS, t_final=float(row["t_final"]), rho=float(row["rho"]),
                        eta=float(row["eta"]), robot_file=str(row["robot_file"]))
    arguments = arm_run_arguments(spec, row, int(row["seed"]))
    if t_final is not None:
        arguments["t_final"] = t_final
    return simulate_arm(method=method or str(row["method"]), **arguments)
