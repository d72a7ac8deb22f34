"""Which gain? A PID tuned to the tracking a user asks for, certified, and run on the nonlinear robot.

:class:`Requirements` states what the loop must do in the user's words (the largest tracking
error after a settling time, the sample time, the disturbance bound, the torque limit, the
smallest disk and delay margins and decay rate). :func:`tune_system` finds the smallest gain
whose certified tracking-error bound meets the error requirement
(:func:`~scara_robust.tune_gain` on the system's perturbed samples), checks the others, and
evaluates it beside any other gains (the paper's, a design file's) against the same
requirements: the certified bound next to the simulated error of every initial condition,
the certified and simulated peak torque, the sampled-data certificate at the sample time, the
margins. Where the requirements cannot all be met it says which binds and the best error
bound reachable under the others.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .._validation import check_real
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentValueError, OptionError
from ..lyapunov.gain import Design
from ..model.arm import arm_perturbed_samples
from ..model.initial import SCENARIOS, Scenario
from ..model.perturbation import PerturbedSamples
from ..model.robot import ConstantPayload, SinusoidalPayload, paper_payload, payload_range
from ..model.scara import scara_perturbed_samples
from ..model.signals import SquareWave
from ..paper import PAPER_DISTURBANCE_AMPLITUDE, PAPER_DISTURBANCE_PERIOD, PAPER_T_FINAL, PAPER_TRANSIENT
from ..robustness.loop_margins import LoopView, frozen_loop_views
from ..robustness.sampled import check_sample_time
from ..robustness.tracking import TrackingBound, tracking_bound, verified_ellipsoid
from ..robustness.tuning import GainTuning, TrackingGain, input_peaks, tune_gain
from ..simulation.arm import simulate_arm
from ..simulation.metrics import TRACKING_TOLERANCE
from ..simulation.run import run_scenarios
from .simulate import simulate_system
from .system import LoadedSystem, ScaraSystem

__all__ = ["Requirements", "TuneReport", "GainEvaluation", "TrackingSearch", "tune_system", "evaluate_gain",
           "search_tracking_error", "loop_checks", "worst_loop_views", "TUNE_GRID", "TUNE_CHECK_GRID",
           "ARM_TUNE_GRID", "ARM_TUNE_CHECK_GRID", "torque_limits"]

Array = NDArray[np.float64]

#: (reference times over one period, payloads) of the samples every bound holds on: the LMIs see an
#: active set of them (cutting planes), numpy checks every one.
TUNE_GRID = (73, 9)
#: A finer grid on which numpy re-verifies every bound (never seen by a solver).
TUNE_CHECK_GRID = (181, 11)
#: The grids of a URDF arm (3n states: each synthesis an LMI of 18 states and more, so fewer
#: samples; the drift's bounds keep their own finer grid, ``model.arm.ARM_DRIFT_GRID``).
ARM_TUNE_GRID, ARM_TUNE_CHECK_GRID = (13, 3), (37, 5)


def _grids(system: LoadedSystem, grid: tuple[int, int] | None,
           check_grid: tuple[int, int] | None) -> tuple[tuple[int, int], tuple[int, int]]:
    """The grids asked, else the system's defaults (:data:`TUNE_GRID` or :data:`ARM_TUNE_GRID` and their checks)."""
    arm = system.capabilities.run == "arm"
    return (grid or (ARM_TUNE_GRID if arm else TUNE_GRID),
            check_grid or (ARM_TUNE_CHECK_GRID if arm else TUNE_CHECK_GRID))


@dataclass(frozen=True)
class Requirements:
    """What the loop must do, in the user's units.

    Attributes
    ----------
    error : float
        The largest tracking error allowed after `settling_time`, per joint, rad (> 0).
    settling_time : float
        s (>= 0).
    sample_time : float or None
        The controller's sample time, s (> 0): the tuned PID is discretized as ``export``
        does and must be certified there by the sampled-data certificate.
    disturbance : float or None
        Bound on each joint's disturbance torque, N·m (>= 0; None: the scenario's
        amplitude, the paper's 5 N·m).
    torque_limit : float or None
        The largest control torque allowed, N·m (> 0): the certified peak must stay below.
    disk_margin : float or None
        Smallest symmetric disk margin α of every loop over the frozen plants (> 0).
    delay_margin : float or None
        Smallest delay margin, s (> 0).
    decay : float or None
        Smallest certified decay rate, 1/s (> 0).
    scenarios : tuple of str
        The initial conditions the bound holds from and the runs start from (names of
        :data:`~scara_robust.SCENARIOS`).
    """

    error: float = TRACKING_TOLERANCE
    settling_time: float = PAPER_TRANSIENT
    sample_time: float | None = None
    disturbance: float | None = None
    torque_limit: float | None = None
    disk_margin: float | None = None
    delay_margin: float | None = None
    decay: float | None = None
    scenarios: tuple[str, ...] = ("large", "small")

    def __post_init__(self) -> None:
        check_real("error", self.error, positive=True)
        check_real("settling_time", self.settling_time, nonnegative=True)
        for name, unit in (("sample_time", "s"), ("torque_limit", "N·m"), ("disk_margin", ""),
                           ("delay_margin", "s"), ("decay", "1/s")):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ArgumentValueError(name, f"must be a finite number > 0{' ' + unit if unit else ''}, "
                                               f"found {value!r}")
        if self.disturbance is not None and not (math.isfinite(self.disturbance) and self.disturbance >= 0):
            raise ArgumentValueError("disturbance", f"must be a finite torque >= 0 N·m, found {self.disturbance!r}")
        if self.error > 3.2:
            raise ArgumentValueError("error", f"must be an angle in rad (below π), found {self.error!r}: "
                                              "degrees? divide by 57.3")
        unknown = [s for s in self.scenarios if s not in SCENARIOS]
        if unknown or not self.scenarios:
            raise ArgumentValueError("scenarios", f"must name scenarios of {sorted(SCENARIOS)}, found "
                                                  f"{list(self.scenarios)}")

    def rows(self) -> list[tuple[str, str]]:
        """Each requirement as ``(name, 'value unit')``, for the report's header.

        Returns
        -------
        list of (str, str)
        """
        out = [("error", f"|e| <= {self.error:g} rad after {self.settling_time:g} s")]
        labels = (("sample_time", "Ts = {:g} s"), ("disturbance", "|T_d| <= {:g} N·m"),
                  ("torque_limit", "|T_c| <= {:g} N·m"), ("disk_margin", "disk margin >= {:g}"),
                  ("delay_margin", "delay margin >= {:g} s"), ("decay", "decay >= {:g} 1/s"))
        for name, text in labels:
            value = getattr(self, name)
            if value is not None:
                out.append((name, text.format(value)))
        return out


@dataclass(frozen=True)
class GainEvaluation:
    """One gain against the requirements.

    Attributes
    ----------
    name : str
    K : ndarray, shape (m, n)
    bound : TrackingBound
        The certified tracking-error bound (on the tuning's samples and the check samples).
    simulated : dict
        Per scenario: the largest ``|e|`` after the settling time (rad), NaN if the run failed.
    simulated_torque : float
        The largest ``|T_c|`` over every run, N·m.
    certified_torque : float
        The largest torque on the ellipsoid that holds every trajectory, N·m (inf without
        one): checked joint by joint against :func:`torque_limits` (the requirement's, or an
        arm's effort limits).
    sampled : bool or None
        Certified at the sample time (None: none asked).
    disk_margin, delay_margin : float
        The smallest over the loops and frozen plants (s for the delay).
    decay : float
        The certified decay rate, 1/s.
    failed : tuple of str
        The requirements it does not meet.
    search : TrackingSearch or None
        The search over payload and disturbance profiles for a larger error (None: not run).
    certified_torques : ndarray, shape (m,), or None
        Each input's certified peak torque, N·m.
    torque_limits : ndarray, shape (m,) or (1,), or None
        What they are checked against (:func:`torque_limits`; None: nothing).
    """

    name: str
    K: Array
    bound: TrackingBound
    simulated: dict[str, float]
    simulated_torque: float
    certified_torque: float
    sampled: bool | None
    disk_margin: float
    delay_margin: float
    decay: float
    failed: tuple[str, ...]
    search: TrackingSearch | None = None
    certified_torques: Array | None = None
    torque_limits: Array | None = None


@dataclass(frozen=True)
class TrackingSearch:
    """The largest tracking error after the settling time found over payload and disturbance profiles.

    Attributes
    ----------
    worst : float
        The largest ``max |e(t)|`` for ``t >= T`` over the runs, rad (NaN if none finished).
    profile : str
        The run that gave it (scenario, payload, disturbance).
    runs : int
    failed : int
        Runs that did not finish (the integrator failed or the error diverged).
    """

    worst: float
    profile: str
    runs: int
    failed: int


@dataclass(frozen=True)
class TuneReport:
    """What :func:`tune_system` found.

    Attributes
    ----------
    requirements : Requirements
    tuning : GainTuning
    design : Design or None
        The tuned gain in the system's design form (what a design file holds).
    gains : tuple of GainEvaluation
        The tuned gain first, then the others asked for.
    samples : str
        The samples the bounds hold on.
    seconds : float
    """

    requirements: Requirements
    tuning: GainTuning
    design: Design | None
    gains: tuple[GainEvaluation, ...]
    samples: str
    seconds: float = field(default=math.nan)

    def table(self) -> pd.DataFrame:
        """One row per gain: certified bound and simulated error side by side, and every check.

        Returns
        -------
        pandas.DataFrame
        """
        rows = []
        for g in self.gains:
            row: dict[str, Any] = {"gain": g.name, "||K||_2 [N·m/rad]": float(np.linalg.norm(g.K, 2)),
                                   "certified |e| after T [rad]": g.bound.worst}
            for name, value in g.simulated.items():
                row[f"simulated |e| after T, {name} [rad]"] = value
            row["certified peak torque [N·m]"] = g.certified_torque
            row["simulated peak torque [N·m]"] = g.simulated_torque
            if self.requirements.sample_time is not None:
                row[f"certified at Ts = {self.requirements.sample_time:g} s"] = g.sampled
            if g.search is not None:
                row["worst searched |e| after T [rad]"] = g.search.worst
            row["disk margin"] = g.disk_margin
            row["delay margin [s]"] = g.delay_margin
            row["decay [1/s]"] = g.decay
            row["meets"] = "all" if not g.failed else "not: " + ", ".join(g.failed)
            rows.append(row)
        return pd.DataFrame(rows)


def _perturbed(system: LoadedSystem, grid: tuple[int, int], disturbance: float | None) -> PerturbedSamples:
    """The system's perturbed samples: the SCARA's or an arm's (a plant file is refused, naming the option)."""
    if system.capabilities.run == "arm":
        return arm_perturbed_samples(system.arm(), disturbance=disturbance, grid=grid)
    if not isinstance(system, ScaraSystem):
        raise OptionError("tune needs a model of the perturbation (the drift along the reference and the disturbance "
                          "through M⁻¹): the SCARA's or a URDF arm's; a plant file (--model) is not supported yet")
    setup = system.setup
    return scara_perturbed_samples(setup.params, setup.reference, setup.payload,
                                   disturbance=PAPER_DISTURBANCE_AMPLITUDE if disturbance is None else disturbance,
                                   times=np.linspace(0.0, 2 * np.pi, grid[0]), n_masses=grid[1])


def _starts(system: LoadedSystem, scenarios: Sequence[str]) -> tuple[Array, tuple[str, ...]]:
    """The initial states ``[∫e, e, ė]`` the bound holds from, and their names: the scenarios, or an arm's file's."""
    if system.capabilities.run == "arm":
        setup = system.arm()
        n = setup.arm.n_joints
        e0 = np.zeros(n) if setup.e0 is None else np.asarray(setup.e0, dtype=float)
        edot0 = np.zeros(n) if setup.edot0 is None else np.asarray(setup.edot0, dtype=float)
        return np.r_[np.zeros(n), e0, edot0][None, :], ("the file's initial error",)
    return _initial_states(scenarios), tuple(scenarios)


def _initial_states(scenarios: Sequence[str]) -> Array:
    """The PID-form states ``[∫e, e, ė]`` (∫e = 0) of the scenarios, shape (k, 6)."""
    out = []
    for name in scenarios:
        s: Scenario = SCENARIOS[name]
        out.append(np.r_[0.0, 0.0, s.e0, s.edot0])
    return np.asarray(out, dtype=float)


def _error_output(n: int, m: int) -> Array:
    C = np.zeros((m, n))
    C[:, m:2 * m] = np.eye(m)
    return C


def _certified_torques(K: Array, P: Array | None, mu: Array | None, alpha: float, initial_level: float,
                       absorbed: PerturbedSamples | None) -> Array:
    """Each input's largest torque on ``{xᵀPx <= max(V(0), V∞)}``, which holds every trajectory, N·m, shape (m,).

    ``|k_i x|`` (the feedback), or, with the drift absorbed by the integral in the samples
    `absorbed` (:meth:`~scara_robust.PerturbedSamples.integral_form`), the whole torque
    ``|τ_id,i| + |k_i z|``.
    """
    if P is None or mu is None:
        return np.full(K.shape[0], math.inf)
    gains = input_peaks(K, P, max(initial_level, float(np.sum(mu)) / alpha))
    if absorbed is not None and absorbed.integral is not None:
        gains = gains + absorbed.integral.torque
    return np.asarray(gains, dtype=float)


def _feedback_share(samples: PerturbedSamples, limits: Array | None, m: int) -> tuple[Array | None, str]:
    """What each joint's limit leaves the feedback ``|k_i z|`` (N·m, shape (m,)) and, where the reference alone
    needs more than a limit, a phrase naming the joint.

    With the drift absorbed by the integral the whole torque is ``τ_id − Kz``
    (:mod:`~scara_robust.model.perturbation`), so the feedback has ``ū_i − max|τ_id,i|``;
    otherwise the limit itself (the feedback torque, as :func:`_certified_torques`).
    """
    if limits is None:
        return None, ""
    share = np.broadcast_to(np.asarray(limits, dtype=float), (m,)).copy()
    if samples.integral is not None:
        share = share - samples.integral.torque
    over = np.flatnonzero(share <= 0)
    if len(over) == 0:
        return share, ""
    j = int(over[0])
    assert samples.integral is not None
    return (np.maximum(share, 1e-9), f" (joint {j + 1}: the reference alone needs {samples.integral.torque[j]:.4g} "
                                     f"N·m)")


def torque_limits(system: LoadedSystem, requirements: Requirements) -> Array | None:
    """The torque each input must stay within, N·m, shape (m,): the requirement's, else an arm's effort limits.

    Parameters
    ----------
    system : LoadedSystem
    requirements : Requirements

    Returns
    -------
    ndarray, shape (m,) or (1,), or None
        ``inf`` where a joint has no limit (shape (1,): the requirement's, for every input);
        None when nothing limits the torque (the
        requirements give none, and the system is not an arm whose URDF or robot file gives
        effort limits).
    """
    if requirements.torque_limit is not None:
        return np.array([float(requirements.torque_limit)])  # one for every input (broadcast)
    if system.capabilities.run == "arm":
        limits = system.arm().torque_limit
        return None if limits is None else np.asarray(limits, dtype=float)
    return None


def _integral(samples: PerturbedSamples, K: Array | None, X0: Array) -> tuple[Array, Array, Array] | None:
    """The channels and initial states with the drift absorbed by `K`'s integral, where the samples allow it."""
    return samples.integral_form(K, X0) if samples.integral is not None else None


def _channels(samples: PerturbedSamples, K: Array, X0: Array) -> tuple[Array, Array, Array]:
    """The channels, bounds and initial states `K`'s bound holds with: the integral form where there is one."""
    found = _integral(samples, K, X0)
    return found if found is not None else (samples.disturbance, samples.w_bound, X0)


def _gain_bound(coarse: PerturbedSamples, fine: PerturbedSamples, K: Array, C: Array, X0: Array, T: float,
                ellipsoid: TrackingGain | None) -> tuple[TrackingBound, bool]:
    """`K`'s certified bound, and whether the drift is absorbed by its integral in it.

    With the tuning's `ellipsoid`, numpy re-checks it on both grids in the form it was found
    in (the integral's, where the samples have one). Otherwise the analysis LMI in both
    forms where both exist (each a valid bound; the smaller is kept: a small integral gain
    does better with the drift's size, a large one with its rate).
    """
    loops = np.concatenate([coarse.A - coarse.B @ K, fine.A - fine.B @ K])
    forms = [(True, _integral(coarse, K, X0), _integral(fine, K, X0))]
    if ellipsoid is None or forms[0][1] is None:
        forms.append((False, (coarse.disturbance, coarse.w_bound, X0), (fine.disturbance, fine.w_bound, X0)))
    best: tuple[TrackingBound, bool] | None = None
    for absorbed, at_coarse, at_fine in forms:
        if at_coarse is None or at_fine is None:
            continue
        (Bw_c, w, starts), (Bw_f, w_f, _) = at_coarse, at_fine
        w = np.maximum(w, w_f)
        if ellipsoid is not None and ellipsoid.P is not None and ellipsoid.mu is not None:
            start = time.perf_counter()
            b, u, v0, mu, alpha = verified_ellipsoid(loops, np.concatenate([Bw_c, Bw_f]), w, C, starts, T,
                                                     ellipsoid.P, ellipsoid.mu, ellipsoid.alpha)
            ok = bool(np.all(np.isfinite(b)))
            bound = TrackingBound(b, u, T, alpha, ellipsoid.P if ok else None, mu if ok else None,
                                  v0, "optimal" if ok else "not verified on the check samples", len(loops),
                                  time.perf_counter() - start)
        else:
            bound = tracking_bound(coarse.A - coarse.B @ K, Bw_c, w, C, initial_states=starts,
                                   settling_time=T, check=(fine.A - fine.B @ K, Bw_f))
        if best is None or bound.worst < best[0].worst:
            best = (bound, absorbed)
    assert best is not None
    return best


def evaluate_gain(system: LoadedSystem, name: str, K: Any, requirements: Requirements, *,
                  grid: tuple[int, int] | None = None, check_grid: tuple[int, int] | None = None,
                  ellipsoid: TrackingGain | None = None, simulate: bool = True,
                  search: bool = False, checks: tuple[bool | None, float, float, float] | None = None
                  ) -> GainEvaluation:
    """One gain against `requirements` on `system` (see :class:`GainEvaluation`).

    Parameters
    ----------
    system : LoadedSystem
    name : str
    K : array_like, shape (m, n)
    requirements : Requirements
    grid, check_grid : (int, int), optional
        Samples of the bound's LMI and of numpy's second check (default :data:`TUNE_GRID` and
        :data:`TUNE_CHECK_GRID`, on an arm :data:`ARM_TUNE_GRID` and :data:`ARM_TUNE_CHECK_GRID`).
    ellipsoid : TrackingGain, optional
        The tuning's own ellipsoid for this gain: numpy re-checks it on the check samples
        instead of solving the analysis LMI again.
    simulate : bool
        Run the scenarios on the nonlinear robot (False: none).
    search : bool
        Also :func:`search_tracking_error` (with `simulate`).
    checks : tuple, optional
        This gain's :func:`loop_checks`, when already computed.

    Returns
    -------
    GainEvaluation
    """
    K = np.asarray(K, dtype=float)
    grid, check_grid = _grids(system, grid, check_grid)
    disturbance = _disturbance(system, requirements)
    coarse, fine = _perturbed(system, grid, disturbance), _perturbed(system, check_grid, disturbance)
    C = _error_output(coarse.A.shape[1], coarse.B.shape[2])
    X0, _ = _starts(system, requirements.scenarios)
    T = requirements.settling_time
    bound, absorbed = _gain_bound(coarse, fine, K, C, X0, T, ellipsoid)
    design = Design.from_gain(system.model, K)
    simulated, torque = _runs(system, design, requirements) if simulate else ({}, math.nan)
    sampled, disk, delay, decay = loop_checks(system, design, requirements) if checks is None else checks
    torques = _certified_torques(K, bound.P, bound.mu, bound.alpha, bound.initial_level, coarse if absorbed else None)
    certified_torque = float(np.max(torques))
    limits = torque_limits(system, requirements)
    failed = []
    if not bound.worst <= requirements.error:
        failed.append("error")
    if any(not v <= requirements.error for v in simulated.values()):
        failed.append("simulated error")
    if requirements.sample_time is not None and not sampled:
        failed.append("sample_time")
    if limits is not None and not np.all(torques <= limits):
        failed.append("torque_limit")
    if requirements.disk_margin is not None and not disk >= requirements.disk_margin:
        failed.append("disk_margin")
    if requirements.delay_margin is not None and not delay >= requirements.delay_margin:
        failed.append("delay_margin")
    if requirements.decay is not None and not decay >= requirements.decay:
        failed.append("decay")
    found = search_tracking_error(system, K, requirements) if simulate and search else None
    if found is not None and not found.worst <= requirements.error:
        failed.append("searched error")
    return GainEvaluation(name, K, bound, simulated, torque, certified_torque, sampled, disk, delay, decay,
                          tuple(failed), found, torques, limits)


def loop_checks(system: LoadedSystem, design: Design,
                requirements: Requirements) -> tuple[bool | None, float, float, float]:
    """The checks of a gain that need no bound: sampled-data certificate at Ts, margins, decay rate.

    Parameters
    ----------
    system : LoadedSystem
    design : Design
    requirements : Requirements

    Returns
    -------
    sampled : bool or None
        Certified at the sample time (None without one).
    disk_margin, delay_margin : float
        The smallest over the loops and frozen plants (the delay in s).
    decay : float
        The certified decay rate, 1/s.
    """
    sampled = None
    if requirements.sample_time is not None:
        plants, check, set_name = system.sampled()
        sampled = check_sample_time(plants, design.discretize(requirements.sample_time), check=check,
                                    set_name=set_name).certified
    margins = system.loop_margins(design)
    disk, delay = float(np.min(margins.disk_margin)), float(np.min(margins.delay_margin))
    return sampled, disk, delay, system.decay_rate(design).rate


def _disturbance(system: LoadedSystem, requirements: Requirements) -> float | None:
    """The disturbance bound asked, or the system's own (the SCARA's scenario; None: an arm's file decides)."""
    if requirements.disturbance is not None:
        return requirements.disturbance
    if system.capabilities.run == "arm":
        return None
    signals = system.setup.disturbance
    return float(signals.amplitude) if signals is not None else PAPER_DISTURBANCE_AMPLITUDE


def _runs(system: LoadedSystem, design: Design, requirements: Requirements) -> tuple[dict[str, float], float]:
    """The largest |e| after T of each scenario's run (the PID discretized at Ts where one is asked) and peak torque."""
    controller: Any = design if requirements.sample_time is None else design.discretize(requirements.sample_time)
    if system.capabilities.run == "arm":  # one run, from the file's initial error, with the file's signals
        K = design.K if requirements.sample_time is None else SampledStateFeedback(design.K, requirements.sample_time)
        run = simulate_system(system, K, t_transient=requirements.settling_time)
        value = float(run.max_abs_error) if run.status in ("tracking", "not-tracking") else math.nan
        return {"the file's initial error": value}, float(run.peak_input)
    errors, torque = {}, 0.0
    for name in requirements.scenarios:
        run = simulate_system(system, controller, scenario=name, t_transient=requirements.settling_time)
        errors[name] = float(run.max_abs_error) if run.status in ("tracking", "not-tracking") else math.nan
        torque = max(torque, float(run.peak_input))
    return errors, torque


def tune_system(system: LoadedSystem, requirements: Requirements, *,
                others: Mapping[str, Any] | None = None, grid: tuple[int, int] | None = None,
                check_grid: tuple[int, int] | None = None, kappa_range: tuple[float, float] = (1.0, 1e4),
                simulate: bool = True, search: bool = True) -> TuneReport:
    """Tune a PID to `requirements` on `system`, then evaluate it and `others` against them.

    Parameters
    ----------
    system : LoadedSystem
        The SCARA (its robot file's parameters, reference and payload) or a URDF arm.
    requirements : Requirements
    others : mapping of str to array_like (m, n), optional
        More gains to evaluate in the same table (the paper's, a design file's).
    grid, check_grid : (int, int), optional
        (reference times, payloads) of the LMI's samples and of numpy's independent check
        (default :data:`TUNE_GRID` and :data:`TUNE_CHECK_GRID`; on an arm :data:`ARM_TUNE_GRID`
        and :data:`ARM_TUNE_CHECK_GRID`).
    kappa_range : (float, float)
        The gain bounds ``‖K‖₂ <= κ`` searched, N·m/rad.
    simulate : bool
        Run every gain on the nonlinear robot from each scenario.
    search : bool
        Search payload and disturbance profiles for a larger error (:func:`search_tracking_error`).

    Returns
    -------
    TuneReport
    """
    start = time.perf_counter()
    grid, check_grid = _grids(system, grid, check_grid)
    disturbance = _disturbance(system, requirements)
    # the LMI sees an active set of both grids (cutting planes); numpy verifies every sample of both
    coarse, fine = _perturbed(system, grid, disturbance), _perturbed(system, check_grid, disturbance)
    samples = replace(coarse, A=np.concatenate([coarse.A, fine.A]), B=np.concatenate([coarse.B, fine.B]),
                      disturbance=np.concatenate([coarse.disturbance, fine.disturbance]),
                      w_bound=np.maximum(coarse.w_bound, fine.w_bound))
    n, m = samples.A.shape[1], samples.B.shape[2]
    C = _error_output(n, m)
    X0, _ = _starts(system, requirements.scenarios)

    checked: dict[bytes, tuple[bool | None, float, float, float]] = {}

    def checks_of(K: Array) -> tuple[bool | None, float, float, float]:
        if K.tobytes() not in checked:
            checked[K.tobytes()] = loop_checks(system, Design.from_gain(system.model, K), requirements)
        return checked[K.tobytes()]

    def accept(found: TrackingGain) -> str:
        if found.K is None or found.P is None or found.mu is None:
            return "no gain"
        if limits is not None:  # the cheap check first: the ellipsoid's torque
            starts = _channels(samples, found.K, X0)[2]
            v0 = float(np.einsum("ki,ij,kj->k", starts, found.P, starts).max()) if len(starts) else 0.0
            torques = _certified_torques(found.K, found.P, found.mu, found.alpha, v0,
                                         samples if _integral(samples, found.K, X0) is not None else None)
            if not np.all(torques <= limits):
                return "torque_limit"
        failed = evaluate_gain(system, "candidate", found.K, requirements, grid=grid, check_grid=check_grid,
                               ellipsoid=found, simulate=False, checks=checks_of(found.K)).failed
        return ", ".join(f for f in failed if f != "error")

    limits = torque_limits(system, requirements)
    checks = limits is not None or any(getattr(requirements, k) is not None for k in
                                       ("sample_time", "disk_margin", "delay_margin", "decay"))
    held, short = _feedback_share(samples, limits, m)
    tuning = tune_gain((samples.A, samples.B), samples.disturbance, samples.w_bound, C, requirements.error,
                       initial_states=X0, settling_time=requirements.settling_time, kappa_range=kappa_range,
                       accept=accept if checks else None,
                       channels=(lambda K: _integral(samples, K, X0)) if samples.integral is not None else None,
                       input_bound=held)
    if tuning.binding == "input_bound":  # the input bounds are the limits less the reference's own torque
        tuning = replace(tuning, binding="torque_limit" + (short or " (the feedback's share of it)"))
    gains: list[GainEvaluation] = []
    design = None
    if tuning.K is not None:
        design = Design.from_gain(system.model, tuning.K)
        own = TrackingGain(tuning.kappa, tuning.best_reachable, tuning.bound, tuning.K, tuning.P, tuning.mu,
                           tuning.alpha)
        gains.append(evaluate_gain(system, "tuned", tuning.K, requirements, grid=grid, check_grid=check_grid,
                                   ellipsoid=own, simulate=simulate, search=search, checks=checks_of(tuning.K)))
    for name, K in (others or {}).items():
        gains.append(evaluate_gain(system, name, K, requirements, grid=grid, check_grid=check_grid,
                                   simulate=simulate, search=search))
    absorbed = "" if samples.integral is None else (
        f"; the drift absorbed by the integral, |dτ_r/dt| <= {np.array2string(samples.integral.rate, precision=3)}"
        f" N·m/s ({samples.integral.description})")
    return TuneReport(requirements, tuning, design, tuple(gains),
                      f"{coarse.description} and {check_grid[0]} x {check_grid[1]}: the LMIs on the samples that "
                      f"bind (cutting planes), numpy on every one{absorbed}",
                      time.perf_counter() - start)


def _resonance(system: LoadedSystem, K: Array) -> float:
    """The frequency (rad/s) where the frozen closed loops' largest |T_d → e| peaks (python-control's linfnorm)."""
    setup = system.setup
    samples = scara_perturbed_samples(setup.params, setup.reference, setup.payload, times=np.linspace(0, 2 * np.pi, 9),
                                      n_masses=2)
    C = _error_output(6, 2)
    best, omega = -1.0, 1.0
    for A, B in zip(samples.A, samples.B):
        gain, w = ct.linfnorm(ct.ss(A - B @ K, B, C, 0))
        if math.isfinite(gain) and gain > best and w > 0:
            best, omega = gain, float(w)
    return omega


def _arm_resonance(samples: PerturbedSamples, K: Array) -> float:
    """The frequency (rad/s) where an arm's frozen closed loops' largest ``|T_d → e|`` peaks (python-control)."""
    n = samples.B.shape[2]
    C = _error_output(3 * n, n)
    best, omega = -1.0, 1.0
    for A, B in zip(samples.A, samples.B):
        gain, w = ct.linfnorm(ct.ss(A - B @ K, B, C, 0))
        if math.isfinite(gain) and gain > best and w > 0:
            best, omega = gain, float(w)
    return omega


def _search_arm(system: LoadedSystem, K: Array, requirements: Requirements, periods: int) -> TrackingSearch:
    """:func:`search_tracking_error` on a URDF arm: :func:`~scara_robust.simulate_arm`'s compiled engine."""
    setup = system.arm()
    n = setup.arm.n_joints
    asked = _disturbance(system, requirements)
    wave = setup.disturbance
    amplitude = float(asked) if asked is not None else (float(wave.amplitude) if wave is not None else 0.0)
    omega = _arm_resonance(arm_perturbed_samples(setup, disturbance=max(amplitude, 1e-12), grid=(7, 2)), K)
    period_list = [2 * math.pi / omega, math.pi / omega, 4 * math.pi / omega, setup.reference.period][:periods]
    lo, hi = setup.payload_mass
    payloads: list[tuple[str, Any]] = [("constant min", ConstantPayload(lo)), ("constant max", ConstantPayload(hi))]
    if hi > lo and setup.payload_rate:
        fastest = 2.0 * setup.payload_rate / (hi - lo)  # a sinusoid over the range at the rate bound
        payloads += [(f"sinusoid at {setup.payload_rate:g} kg/s", SinusoidalPayload((lo + hi) / 2, (hi - lo) / 2,
                                                                                   fastest, 0.0)),
                     (f"sinusoid at {setup.payload_rate:g} kg/s, mirrored",
                      SinusoidalPayload((lo + hi) / 2, (hi - lo) / 2, fastest, math.pi))]
    alternate = tuple(float((-1) ** j) for j in range(n))
    T = requirements.settling_time
    t_final = T + max(setup.reference.period, 2 * max(period_list))
    worst, where, failed, runs = math.nan, "", 0, 0
    for pname, profile in payloads:
        for period in period_list:
            for signs in ((1.0,) * n, alternate):
                for phase in (0.0, math.pi):
                    runs += 1
                    label = (f"payload {pname}, T_d ±{amplitude:g} N·m period {period:.3g} s "
                             f"{'same signs' if signs == (1.0,) * n else 'alternating signs'}, "
                             f"phase {phase:.3g}")
                    try:
                        run = simulate_arm(setup, K, profile, disturbance=SquareWave(amplitude, period, phase, signs),
                                           t_final=t_final, method="compiled", t_transient=T)
                    except Exception:  # a failed run is counted, not a crash
                        failed += 1
                        continue
                    if not run.success:
                        failed += 1
                        continue
                    value = float(run.max_abs_error)
                    if not value <= worst:
                        worst, where = value, label
    return TrackingSearch(worst, where, runs, failed)


def search_tracking_error(system: LoadedSystem, K: Any, requirements: Requirements, *,
                          periods: int = 4) -> TrackingSearch:
    """Look for a larger tracking error than the bound: the nonlinear robot over payload and disturbance profiles.

    Square waves of the disturbance bound on both joints, in phase and in opposition, at
    the closed loop's resonant period (where the frozen loops' ``|T_d → e|`` peaks), half
    and twice it and the paper's π/5 s, each at phases 0 and π; payloads: the scenario's
    profile, its mirror (phase π), and constant at both ends of its range (the
    slowest variations; the scenario's is the fastest the rate bound allows). Every
    initial condition of the requirements. The continuous PID (the loop the bound is about)
    on the compiled engine, batched.

    On a URDF arm (:func:`~scara_robust.simulate_arm`'s compiled engine, from the file's
    initial error): square waves on every joint, all of one sign and alternating, at the
    resonant period, half and twice it and the reference's period, phases 0 and π;
    payloads constant at both ends of the range and a sinusoid over it at the rate bound
    (and its mirror).

    Parameters
    ----------
    system : LoadedSystem
    K : array_like, shape (2, 6), or (n, 3n) on an arm
    requirements : Requirements
    periods : int
        How many of the periods listed (1–4, in that order).

    Returns
    -------
    TrackingSearch
    """
    K = np.asarray(K, dtype=float)
    if system.capabilities.run == "arm":
        return _search_arm(system, K, requirements, periods)
    setup = system.setup
    asked = _disturbance(system, requirements)
    amplitude = PAPER_DISTURBANCE_AMPLITUDE if asked is None else asked
    omega = _resonance(system, K)
    period_list = [2 * math.pi / omega, math.pi / omega, 4 * math.pi / omega, PAPER_DISTURBANCE_PERIOD][:periods]
    payload = setup.payload or paper_payload(setup.params)
    lo, hi = payload_range(payload, np.linspace(0.0, 2 * math.pi, 721))
    payloads: list[tuple[str, Any]] = [("scenario's", payload), ("constant min", ConstantPayload(lo)),
                                       ("constant max", ConstantPayload(hi))]
    if isinstance(payload, SinusoidalPayload):
        payloads.append(("mirrored", replace(payload, phase=payload.phase + math.pi)))
    controller = "pid"  # the continuous loop the bound is about (the compiled engine runs it; the runs of
    requests, labels = [], []  # evaluate_gain use the sampled PID where a Ts is asked)
    for scenario in requirements.scenarios:
        for pname, profile in payloads:
            for period in period_list:
                for signs in ((1.0, 1.0), (1.0, -1.0)):
                    for phase in (0.0, math.pi):
                        wave = SquareWave(amplitude, period, phase, signs)
                        requests.append({"controller": controller, "scenario": scenario, "K": K, "params": setup.params,
                                         "reference": setup.reference, "payload": profile, "disturbance": wave,
                                         "method": "compiled", "t_transient": requirements.settling_time,
                                         "t_final": max(PAPER_T_FINAL, requirements.settling_time + 10.0)})
                        labels.append(f"{scenario}, payload {pname}, T_d ±{amplitude:g} N·m period {period:.3g} s "
                                      f"signs {signs}, phase {phase:.3g}")
    runs = run_scenarios(requests, errors="return")
    worst, where, failed = math.nan, "", 0
    for run, label in zip(runs, labels):
        if isinstance(run, Exception) or not run.success:
            failed += 1
            continue
        value = float(run.metrics().max_abs_error)
        if not value <= worst:
            worst, where = value, label
    return TrackingSearch(worst, where, len(runs), failed)


def worst_loop_views(system: LoadedSystem, K: Any, *, t_final: float = PAPER_TRANSIENT) -> tuple[LoopView, ...]:
    """Each loop's step response and Bode data at its worst frozen plant (the smallest delay margin).

    Parameters
    ----------
    system : LoadedSystem
        A system with physical parameters (the SCARA: reference time and payload).
    K : array_like, shape (m, 3m)
    t_final : float
        Horizon of the step responses, s.

    Returns
    -------
    tuple of LoopView
        One per input, in order; each at the frozen plant where :meth:`LoadedSystem.loop_margins`
        finds that input's smallest delay margin (the Bode plot shows it: the phase at the
        gain crossover).
    """
    K = np.asarray(K, dtype=float)
    physical = system.require_physical("the loop views need a plant with physical parameters")
    return frozen_loop_views(physical, K, system.loop_margins(K), t_final=t_final)
