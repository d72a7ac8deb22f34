"""PID against sliding-mode control in one table (``python -m scara_robust.compare``).

Runs the PID of (ρ, η) = (3, 90) on the published model, the PID whose gain was
synthesized with its certificate (``pid-lmi``) and both sliding-mode variants on the
``large`` and ``small`` scenarios, and prints one row per controller × scenario with the
metrics of :func:`scara_robust.tracking_metrics`.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from tqdm import tqdm

from .._validation import check_array
from ..controller.scheduled import ScheduledGain
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import Design
from ..lyapunov.theorem1 import certify
from ..model.arm import ArmSetup
from ..model.initial import SCENARIOS, Scenario
from ..model.plant import UncertainPlant
from ..paper import PAPER_T_FINAL, PAPER_TRANSIENT
from ..robustness.actuator import input_limit_certificate, peak_inputs, step_initial_errors
from ..robustness.decay import design_decay_rate
from ..robustness.loop_margins import worst_loop_margins
from ..robustness.parameters import frozen_limit, parameter_margin
from ..robustness.sampled import max_sample_time
from ..robustness.scheduled import max_measurement_error, max_schedule_rate, schedule_decay
from ..simulation.arm import simulate_arm
from ..simulation.controllers import scheduled_pid_controller
from ..simulation.metrics import METRIC_NAMES
from ..simulation.plants import parameter_profile, simulate_plant
from ..simulation.run import run_scenario, simulate

__all__ = ["compare_controllers", "COMPARISON_COLUMNS", "COMPARED_CONTROLLERS", "compare_plant_designs",
           "compare_schedules", "ScheduleRun", "plant_schedule_run", "scara_schedule_run", "arm_schedule_run"]

#: One run of a scheduled gain, ``run(gain, profile, bias) -> columns``: the parameter follows
#: ``profile(t)``, the controller measures it ``bias`` off; the columns are the run's ``status``,
#: its max |e| and peak input, their names with units.
ScheduleRun = Callable[[ScheduledGain, Callable[[float], float], float], dict[str, Any]]

#: Controllers of the default comparison: the paper's PID, the synthesized PID, both sliding modes.
COMPARED_CONTROLLERS = ("pid", "pid-lmi", "smc", "smc-sign")

#: Columns of :func:`compare_controllers`' table.
COMPARISON_COLUMNS = ("controller", "scenario", "payload", "success", "status", *METRIC_NAMES, "status_reason")


def compare_controllers(
    controllers: Sequence[str] = COMPARED_CONTROLLERS,
    scenarios: Sequence[str | Scenario] = tuple(SCENARIOS),
    *,
    payload_on: bool = True,
    t_final: float = PAPER_T_FINAL,
    progress: bool = False,
    designs: Mapping[str, ArrayLike] | None = None,
    **setup: Any,
) -> pd.DataFrame:
    """Simulate every controller on every scenario and tabulate the metrics.

    Parameters
    ----------
    controllers : sequence of str
        Names from :data:`scara_robust.CONTROLLERS`; default :data:`COMPARED_CONTROLLERS`,
        the paper's comparison (the continuous PID against the two sliding-mode laws) and
        the synthesized PID (add ``'pid-sampled'`` for the deployable discrete PID).
    scenarios : sequence of str or Scenario
        Names from :data:`scara_robust.SCENARIOS`, or :class:`~scara_robust.Scenario`.
    payload_on : bool
        The paper's ``m_p(t)`` (True) or ``m_p = 0`` (False).
    t_final : float
        Horizon, s (> 6 so the after-transient metrics exist).
    progress : bool
        Show a tqdm progress bar on stderr.
    designs : mapping of str to array_like of shape (2, 6), optional
        More PID gains, each run as ``pid`` with that ``K`` and labelled by its key in the
        ``controller`` column (for example gains read from design files).
    **setup
        ``params``, ``reference``, ``payload``, ``disturbance``, ``K``,
        ``tracking_tolerance``, passed to :func:`scara_robust.run_scenario` (default: the
        paper's signals, 0.05 rad).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COMPARISON_COLUMNS`: ``controller, scenario, payload``, ``success``
        (True only when the run tracks), ``status`` (one of :data:`scara_robust.STATUSES`),
        the metric names (NaN for a run without them) and ``status_reason``.
    """
    extra = {label: check_array(f"designs[{label!r}]", K, shape=(2, 6)) for label, K in (designs or {}).items()}
    clash = sorted(set(extra) & set(controllers))
    if clash:
        raise ArgumentValueError("designs", f"labels must differ from the controllers' names, found {clash}")
    pairs = [(c, s) for c in [*controllers, *extra] for s in scenarios]
    rows: list[dict[str, Any]] = []
    for c, s in tqdm(pairs, disable=not progress, file=sys.stderr, desc="compare", unit="run"):
        if c in extra:
            res = run_scenario("pid", s, payload_on=payload_on, t_final=t_final, **{**setup, "K": extra[c]})
        else:
            res = run_scenario(c, s, payload_on=payload_on, t_final=t_final, **setup)
        row: dict[str, Any] = {
            "controller": c,
            "scenario": s if isinstance(s, str) else s.name,
            "payload": "on" if payload_on else "off",
            "success": res.status == "tracking",
            "status": res.status,
            "status_reason": res.status_reason,
        }
        row.update(res.metrics().to_dict() if res.has_metrics else dict.fromkeys(METRIC_NAMES, math.nan))
        rows.append(row)
    return pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))


def compare_plant_designs(
    plant: UncertainPlant,
    designs: Mapping[str, tuple[Any, Any]],
    *,
    profiles: Mapping[str, Any] | None = None,
    reference: tuple[Any, float] | None = None,
    disturbance: Any = None,
    t_final: float = 20.0,
) -> pd.DataFrame:
    """Gains for one plant side by side: their certificates, margins and a simulated run.

    Parameters
    ----------
    plant : UncertainPlant
    designs : mapping of str to (K, P)
        Name -> gain K, shape (m, n), on the design form, and its Lyapunov matrix P,
        shape (n, n), or None (Theorem 1 and the design-P margin need one).
    profiles, reference, disturbance, t_final
        The run, as for :func:`scara_robust.simulate_plant`.

    Returns
    -------
    pandas.DataFrame
        One row per design: ``design``, the gains (``K_I``, ``K_P``, ``K_D`` for the PID
        form, else ``K``), ``theorem1 max eig`` (NaN without P), ``decay rate [1/s]`` and
        ``decay rate from`` (the state decay α, ``V̇ <= −2αV``, of
        :func:`~scara_robust.design_decay_rate`: the larger of the design's own P and a
        common P by LMI, and which; NaN when none verifies), ``disk margin α`` and
        ``delay margin [s]`` (the worst over the inputs and the frozen plants of the
        parameter grid, :func:`~scara_robust.worst_loop_margins`; 0 when a frozen loop is
        unstable),
        for each varying parameter ``NAME certified high [UNIT]`` (the design-P vertex
        margin, NaN without P), ``NAME frozen limit [UNIT]`` (a frozen plant is unstable
        beyond, NaN when none is found up to the physical limits or the search's cap) and
        ``NAME frozen end`` (``'lower'``, ``'upper'`` or ``'none'``: the end that fails),
        then the run's ``status``, ``max |e| [UNIT]`` and ``peak |u| [UNIT]``; ``certified Ts
        [s]`` and ``unstable Ts [s]`` (:func:`~scara_robust.max_sample_time` on the plant's grid,
        verified on its refinement, as ``certify --max-ts`` and ``export``); for a PID-form
        plant with input limits, ``run within input limits`` and ``unit step certified
        within limits s*`` (:func:`~scara_robust.input_limit_certificate` with the P of the
        decay rate).
    """
    hull = plant.interval_model()
    rows = []
    for name, (K_raw, P_raw) in designs.items():
        K = check_array(f"designs[{name!r}][0]", K_raw, shape=(plant.n_inputs, plant.n_design_states))
        P = None if P_raw is None else check_array(f"designs[{name!r}][1]", P_raw, shape=(K.shape[1], K.shape[1]))
        row: dict[str, Any] = {"design": name}
        if plant.form == "pid":
            q = plant.n_states // 2
            for label, block in (("K_I", -K[:, :q]), ("K_P", -K[:, q:2 * q]), ("K_D", -K[:, 2 * q:])):
                row[label] = float(block[0, 0]) if block.size == 1 else str(block.round(6).tolist())
        else:
            row["K"] = str(K.round(6).tolist())
        design = None if P is None else Design._of_gain(hull.A, hull.B, K, P, "given", hull.n_joints)
        row["theorem1 max eig"] = certify(hull, design).max_eig if design is not None else math.nan
        decay = design_decay_rate(hull, K, P=P, plant=plant)
        row["decay rate [1/s]"] = decay.rate
        row["decay rate from"] = decay.source or "none"
        loops = worst_loop_margins(plant, K, points=plant.grid_points())
        row["disk margin α"] = float(loops.disk_margin.min()) if loops.certified else 0.0
        row["delay margin [s]"] = float(loops.delay_margin.min()) if loops.certified else 0.0
        margins = parameter_margin(plant, design if design is not None else K,
                                   ["vertex", "frozen"] if design is not None else ["frozen"])
        for prm in plant.varying:
            column = f"{prm.name} high [{prm.unit}]"
            vertex = margins.loc[margins["method"] == "vertex", column]
            row[f"{prm.name} certified high [{prm.unit}]"] = float(vertex.iloc[0]) if len(vertex) else math.nan
            row[f"{prm.name} frozen limit [{prm.unit}]"], row[f"{prm.name} frozen end"] = frozen_limit(margins, prm)
        run = simulate_plant(plant, K, profiles=profiles, reference=reference, disturbance=disturbance,
                             t_final=t_final)
        out_unit, in_unit = plant.outputs[0].unit, plant.inputs[0].unit
        row.update({"status": run.status, f"max |e| [{out_unit}]": run.max_abs_error,
                    f"peak |u| [{in_unit}]": run.peak_input})
        # the certified sample time, on the sets certify --max-ts and export use (the plant's grid, verified on
        # its refinement): a PID discretized as export does; a state-form gain u = −K x(t_k) held
        on, fine = plant.samples(), plant.samples(plant.fine_points())
        held = design if design is not None else Design.from_gain(hull, K) if plant.form == "pid" else K
        limit = max_sample_time((on.A, on.B), held if plant.form == "pid" else K, check=(fine.A, fine.B))
        row["certified Ts [s]"], row["unstable Ts [s]"] = limit.certified_ts, limit.unstable_ts
        limits = plant.input_limits
        if limits is not None and plant.form == "pid":  # deployable: the run and the certificate against the limits
            row["run within input limits"] = bool((peak_inputs(run) <= limits).all())
            row["unit step certified within limits s*"] = (
                input_limit_certificate(K, decay.P, limits, step_initial_errors(plant), closed_loops=decay.loops).scale
                if decay.P is not None else math.nan)
        rows.append(row)
    return pd.DataFrame(rows)


def plant_schedule_run(plant: UncertainPlant, t_final: float = 20.0) -> ScheduleRun:
    """Runs of a plant file's linear loop (:func:`scara_robust.simulate_plant`) for :func:`compare_schedules`.

    Parameters
    ----------
    plant : UncertainPlant
    t_final : float
        Horizon, s.

    Returns
    -------
    ScheduleRun
        Columns ``status``, ``max |e| [OUTPUT UNIT]`` (over the run) and ``peak |u| [INPUT UNIT]``.
    """
    out_unit, in_unit = plant.outputs[0].unit, plant.inputs[0].unit

    def run(gain: ScheduledGain, profile: Callable[[float], float], bias: float) -> dict[str, Any]:
        result = simulate_plant(plant, gain, profiles={gain.parameter: profile}, t_final=t_final,
                                measurement_bias=bias)
        return {"status": result.status, f"max |e| [{out_unit}]": result.max_abs_error,
                f"peak |u| [{in_unit}]": result.peak_input}

    return run


def scara_schedule_run(scenario: Scenario | str = "small", t_final: float = PAPER_T_FINAL,
                       **signals: Any) -> ScheduleRun:
    """Runs of the nonlinear SCARA under :func:`scara_robust.scheduled_pid_controller` for :func:`compare_schedules`.

    Parameters
    ----------
    scenario : Scenario or {'large', 'small'}
        Initial tracking error.
    t_final : float
        Horizon, s.
    **signals
        ``params``, ``reference``, ``disturbance`` of :func:`scara_robust.simulate` (the
        payload is the profile of each run).

    Returns
    -------
    ScheduleRun
        Columns ``status``, ``max |e| after 6 s [rad]`` and ``peak |τ| [N·m]``.
    """
    reference = signals.get("reference")
    kwargs = {k: v for k, v in signals.items() if k in ("params", "reference", "disturbance")}

    def run(gain: ScheduledGain, profile: Callable[[float], float], bias: float) -> dict[str, Any]:
        controller = scheduled_pid_controller(gain, profile, reference, measurement_bias=bias)
        result = simulate(controller, scenario, payload=profile, t_final=t_final, **kwargs)
        return {"status": result.status,
                f"max |e| after {PAPER_TRANSIENT:g} s [rad]": result.metrics().max_abs_error
                if result.has_metrics and not result.diverged else math.nan,
                "peak |τ| [N·m]": result.peak_torque}

    return run


def arm_schedule_run(setup: ArmSetup, t_final: float = 20.0, **inputs: Any) -> ScheduleRun:
    """Runs of an arm from its URDF (:func:`scara_robust.simulate_arm`) for :func:`compare_schedules`.

    Parameters
    ----------
    setup : ArmSetup
    t_final : float
        Horizon, s.
    **inputs
        Further keywords of :func:`scara_robust.simulate_arm` (``e0``, ``disturbance``, ...;
        default the robot file's).

    Returns
    -------
    ScheduleRun
        Columns ``status``, ``max |e| after 6 s [rad]`` and ``peak |τ| [N·m]``.
    """

    def run(gain: ScheduledGain, profile: Callable[[float], float], bias: float) -> dict[str, Any]:
        result = simulate_arm(setup, gain, profile, t_final=t_final, measurement_bias=bias, **inputs)
        return {"status": result.status,
                f"max |e| after {result.t_transient:g} s [rad]": result.metrics().max_abs_error
                if result.has_metrics and not result.diverged else math.nan,
                "peak |τ| [N·m]": float(np.abs(result.torque).max())}

    return run


def compare_schedules(
    plant: UncertainPlant,
    gains: Mapping[str, ScheduledGain],
    *,
    rate: float | None = None,
    measurement_error: float | None = None,
    decay: float | None = None,
    t_final: float = 20.0,
    run: ScheduleRun | None = None,
) -> pd.DataFrame:
    """Scheduled (and fixed) gains side by side under one rate bound and measurement error.

    A fixed gain enters as a :class:`~scara_robust.ScheduledGain` whose entries are all
    equal, and gets the same certificate (a P(p) following the parameter) as a scheduled one.

    Parameters
    ----------
    plant : UncertainPlant
        The plant the certificates are of (for a robot, its linearization:
        :func:`scara_robust.scara_uncertain_plant`, :attr:`ArmSetup.plant`).
    gains : mapping of str to ScheduledGain
        Name -> gain, all on the same parameter.
    rate, measurement_error : float, optional
        ν (unit/s) and δ (unit); default the parameter's.
    decay : float, optional
        A decay rate α (1/s) at which the largest certified rate is also reported.
    t_final : float
        Horizon of the runs, s.
    run : ScheduleRun, optional
        How a gain is run (default :func:`plant_schedule_run` of `plant`;
        :func:`scara_schedule_run` and :func:`arm_schedule_run` run the nonlinear robots).

    Returns
    -------
    pandas.DataFrame
        One row per gain: ``max ‖K_j‖``, ``certified range [UNIT]`` (the plant's range of
        the parameter when the loop is certified at ν and δ, else ``none``), ``decay
        [1/s]`` (guaranteed at ν and δ), ``rate [UNIT/s]`` (largest certified at decay 0,
        δ), ``rate at decay α [UNIT/s]`` (with `decay`), ``measurement error [UNIT]``
        (largest certified at ν), and for two runs with the parameter moving at the rate
        bound, a ramp across the range (the controller's measurement off by +δ) and a
        sinusoid between the range's ends, the columns of `run` prefixed ``ramp:`` and
        ``sinusoid:``.
    """
    if not gains:
        raise ArgumentValueError("gains", "must name at least one gain")
    names = {g.parameter for g in gains.values()}
    if len(names) != 1:
        raise ArgumentValueError("gains", f"must all schedule one parameter, found {sorted(names)}")
    name = names.pop()
    param = plant.parameter(name)
    nu, delta = param.motion_bounds(rate, measurement_error)
    unit = param.unit
    run = plant_schedule_run(plant, t_final) if run is None else run
    moving = _with_rate(plant, name, nu) if math.isfinite(nu) else plant  # the runs move at ν
    profiles = {"ramp": parameter_profile(moving, name, "ramp", t_final=t_final),
                "sinusoid": parameter_profile(moving, name, "sinusoid", t_final=t_final)}
    lo, hi = param.range
    rows = []
    for label, gain in gains.items():
        alpha, held = schedule_decay(plant, gain, rate=nu, measurement_error=delta)
        fastest, _ = max_schedule_rate(plant, gain, measurement_error=delta)
        error, _ = max_measurement_error(plant, gain, rate=nu)
        row: dict[str, Any] = {"gain": label, "max ‖K_j‖": gain.max_norm,
                               f"certified range [{unit}]": f"{lo:g}-{hi:g}" if held is not None else "none",
                               "decay [1/s]": alpha if held is not None else math.nan, f"rate [{unit}/s]": fastest,
                               f"measurement error [{unit}]": error}
        if decay is not None:
            row[f"rate at decay {decay:g} [{unit}/s]"] = max_schedule_rate(
                plant, gain, measurement_error=delta, decay=decay)[0]
        fixed = bool(np.all(gain.gains == gain.gains[0]))
        for kind, profile in profiles.items():
            bias = delta if kind == "ramp" and not fixed else 0.0
            row.update({f"{kind}: {key}": value for key, value in run(gain, profile, bias).items()})
        rows.append(row)
    return pd.DataFrame(rows).set_index("gain")


def _with_rate(plant: UncertainPlant, name: str, rate: float) -> UncertainPlant:
    params = tuple(dataclasses.replace(p, rate=rate) if p.name == name else p for p in plant.parameters)
    return dataclasses.replace(plant, parameters=params)

