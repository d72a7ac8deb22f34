"""What one campaign run gets: its arguments, built from a row's inputs, and the replay of a row.

A row of a campaign table holds everything that determines its run: the drawn inputs of
:func:`~scara_robust.draw_scenario` and the campaign's fixed ones (:data:`FIXED_COLUMNS`:
horizon, PID design point, robot). :func:`run_arguments` turns those inputs into the
arguments of :func:`scara_robust.run_scenario`; :func:`~scara_robust.studies.campaign.runner.run_draw` and
:func:`replay_scenario` both go through it, so a replayed row is the campaign's run.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

import numpy as np
import pandas as pd

from ..._validation import check_int
from ...exceptions import ArgumentValueError
from ...lyapunov.gain import design
from ...model.initial import Scenario
from ...model.robot import ConstantPayload, ScaraParams, SinusoidalPayload
from ...model.scara import paper_model
from ...model.signals import SquareWave, sinusoidal_reference
from ...simulation.engines import ENGINES
from ...simulation.metrics import TRACKING_TOLERANCE
from ...simulation.run import SimulationResult, run_scenario
from .spec import SPEC_FIELDS, CampaignSpec

__all__ = ["replay_scenario"]

#: Robot parameters stored per row, as ``robot_<name>`` (``cp`` is drawn, so it is a drawn column).
_ROBOT = tuple(f.name for f in fields(ScaraParams) if f.name != "cp")

#: Columns of a campaign table that hold the campaign's fixed inputs: horizon ``t_final``
#: (s), PID design point ``rho`` and ``eta``, and the robot's parameters ``robot_m1`` (kg),
#: ..., ``robot_I2`` (kg·m²) in the units of :data:`scara_robust.PARAM_UNITS`.
FIXED_COLUMNS = ("t_final", "rho", "eta", *(f"robot_{name}" for name in _ROBOT))

#: Columns of a campaign table that hold the drawn inputs of :func:`~scara_robust.draw_scenario`
#: (units in :data:`~scara_robust.studies.campaign.spec.SPEC_FIELDS`; ``e1_0`` and ``e2_0`` in rad).
DRAWN_COLUMNS = ("payload_profile", *[n for n in SPEC_FIELDS if n != "initial_error"], "e1_0", "e2_0")


@functools.lru_cache(maxsize=8)
def _paper_gain(rho: float, eta: float) -> np.ndarray:
    # one Riccati solve per design point and process, not one per run
    return design(paper_model(), rho, eta).K


def fixed_inputs(spec: CampaignSpec) -> dict[str, Any]:
    """The inputs that every run of `spec` shares, keyed by :data:`FIXED_COLUMNS`.

    Parameters
    ----------
    spec : CampaignSpec

    Returns
    -------
    dict of str to float
    """
    out: dict[str, Any] = {"t_final": float(spec.t_final), "rho": float(spec.rho), "eta": float(spec.eta)}
    out.update({f"robot_{name}": float(getattr(spec.robot, name)) for name in _ROBOT})
    return out


def drawn_payload(inputs: Mapping[str, Any]) -> SinusoidalPayload | ConstantPayload:
    """The payload of a row: ``payload_profile``, ``payload_peak`` (kg), ``payload_omega``, ``payload_phase``."""
    peak = float(inputs["payload_peak"])
    if inputs["payload_profile"] == "sinusoidal":
        return SinusoidalPayload(0.5 * peak, 0.5 * peak, float(inputs["payload_omega"]), float(inputs["payload_phase"]))
    return ConstantPayload(peak)


def drawn_disturbance(inputs: Mapping[str, Any], signs: tuple[float, ...] = (1.0, 1.0)) -> SquareWave:
    """The square wave of a row's ``disturbance_amplitude`` (N·m), ``_period`` (s) and ``_phase`` (rad)."""
    return SquareWave(float(inputs["disturbance_amplitude"]), float(inputs["disturbance_period"]),
                      float(inputs["disturbance_phase"]), signs)


def run_arguments(inputs: Mapping[str, Any]) -> dict[str, Any]:
    """The keyword arguments of :func:`scara_robust.run_scenario` for one campaign run.

    Parameters
    ----------
    inputs : mapping
        ``scenario`` (the index), the drawn inputs (:data:`DRAWN_COLUMNS`) and the fixed
        ones (:data:`FIXED_COLUMNS`): a draw of :func:`~scara_robust.draw_scenario`
        merged with :func:`fixed_inputs`, or a row of a campaign table.

    Returns
    -------
    dict
        ``scenario`` (a :class:`~scara_robust.Scenario` named ``mc-<index>``, e(0) drawn,
        ė(0) = 0), ``t_final``, ``torque_limit`` (None for an infinite limit),
        ``params``, ``reference``, ``payload``, ``disturbance`` and ``K`` (the PID gain
        K(ρ, η) on the published model; the other controllers ignore it).

    Raises
    ------
    ArgumentValueError
        If an input is missing (`inputs`).
    """
    missing = [c for c in ("scenario", *DRAWN_COLUMNS, *FIXED_COLUMNS) if c not in inputs]
    if missing:
        raise ArgumentValueError("inputs", f"lacks the campaign inputs {missing}")
    robot = {name: float(inputs[f"robot_{name}"]) for name in _ROBOT}
    params = ScaraParams(**robot, cp=float(inputs["cp"]))
    limit = float(inputs["torque_limit"])
    return {
        "scenario": Scenario(f"mc-{int(inputs['scenario'])}", (float(inputs["e1_0"]), float(inputs["e2_0"])),
                             (0.0, 0.0)),
        "t_final": float(inputs["t_final"]),
        "torque_limit": None if math.isinf(limit) else limit,
        "params": params,
        "reference": sinusoidal_reference(float(inputs["reference_amplitude"]), float(inputs["reference_omega"])),
        "payload": drawn_payload(inputs),
        "disturbance": drawn_disturbance(inputs),
        "K": _paper_gain(float(inputs["rho"]), float(inputs["eta"])).copy(),
    }


def replay_scenario(
    results: pd.DataFrame,
    index: int,
    controller: str | None = None,
    *,
    method: str | None = None,
    t_final: float | None = None,
    tracking_tolerance: float = TRACKING_TOLERANCE,
) -> SimulationResult:
    """Run scenario `index` of a campaign table again, from the inputs stored in its row.

    Parameters
    ----------
    results : pandas.DataFrame
        A campaign table (:func:`~scara_robust.read_results`), with the columns
        :data:`DRAWN_COLUMNS` and :data:`FIXED_COLUMNS`.
    index : int
        The scenario index (column ``scenario``), >= 0.
    controller : str, optional
        A controller of the table (default: the first of the table's, in its order).
    method : str, optional
        A key of :data:`scara_robust.ENGINES` (default: the engine the row's run used,
        column ``method``; the default engine of :func:`scara_robust.simulate` for a
        table without it).
    t_final : float, optional
        Horizon, s (default: the campaign's, stored in the row).
    tracking_tolerance : float
        Tolerance of the run's status, rad (default: the campaign's).

    Returns
    -------
    SimulationResult
        With the same engine and horizon as the campaign, its metrics and status equal
        the row's exactly.

    Raises
    ------
    ArgumentValueError
        If `index` or `controller` is not in the table, or the table lacks the
        inputs (`results`: a table written before they were stored).
    """
    index = check_int("index", index, 0)
    if not isinstance(results, pd.DataFrame) or "scenario" not in results or "controller" not in results:
        raise ArgumentValueError("results", "must be a campaign table with scenario and controller columns")
    if "robot_file" in results.columns:
        raise ArgumentValueError("results", "holds an arm campaign (a URDF robot): replay its rows with "
                                            "scara_robust.replay_arm_scenario")
    missing = [c for c in (*DRAWN_COLUMNS, *FIXED_COLUMNS) if c not in results.columns]
    if missing:
        raise ArgumentValueError("results", f"lacks the inputs needed to replay a run: missing columns {missing}")
    rows = results[results["scenario"] == index]
    if not len(rows):
        have = results["scenario"]
        span = f"{int(have.min())}..{int(have.max())}" if len(have) else "none"
        raise ArgumentValueError("index", f"must be a scenario of the table (indices {span}), found {index}")
    names = list(dict.fromkeys(rows["controller"]))
    name = names[0] if controller is None else controller
    if name not in names:
        raise ArgumentValueError("controller", f"must be one of the table's {names}, found {name!r}")
    row = rows[rows["controller"] == name].iloc[0].to_dict()
    arguments = run_arguments(row)
    if method is None and str(row.get("method", "")) in ENGINES:
        method = str(row["method"])
    if t_final is not None:
        arguments["t_final"] = t_final
    return run_scenario(name, method=method, tracking_tolerance=tracking_tolerance, **arguments)
