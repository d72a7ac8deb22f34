"""Closed-loop runs of any :class:`~scara_robust.UncertainPlant` with time-varying parameters.

The loop is the plant in its own coordinates, ``ẋ = A(p(t))x + B(p(t))(u + d(t))``, the
controller the design's static gain on the design form (for ``form='pid'`` the PID
``u = −K[∫e, e, ė]`` with ``e = r − q``, ``ė = ṙ − q̇``; for ``form='integral'``
``u = −K[∫(r − Cx), x]``; for ``form='state'`` ``u = −Kx``), simulated by python-control
(``control.nlsys`` and ``control.input_output_response``, LSODA). The parameters follow a
profile of :data:`PROFILES`; every sample of the run records them.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._resources import check_memory, simulation_bytes
from .._validation import check_array, check_choice, check_int, check_real
from ..controller.kinds import held_gain, schedule_of
from ..controller.scheduled import ScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentValueError, InputFileError
from ..model.plant import UncertainPlant
from .metrics import STATUSES

__all__ = ["PROFILES", "parameter_profile", "PlantRun", "simulate_plant", "PLANT_TRACKING_RTOL"]

Array = NDArray[np.float64]
#: Parameter profiles of :func:`parameter_profile`.
PROFILES = ("constant", "sinusoid", "ramp", "random-walk", "csv")
#: A run tracks when max |e| after the transient is at most this times the reference's
#: peak (or this many output units for a zero reference), per output.
PLANT_TRACKING_RTOL = 0.02
_DIVERGED = 1e6
#: The output grid of :func:`simulate_plant` takes at least this many samples per time scale
#: ``1/|λ|`` of the closed loop's transient modes, and per period of the reference / 2.
_SAMPLES_PER_TIME_SCALE = 10
#: A mode belongs to the transient when it decays at most this many times faster than the
#: slowest (dominant) mode of its frozen plant; faster ones are over within a tenth of it.
_TRANSIENT_SPREAD = 10.0


def parameter_profile(
    plant: UncertainPlant,
    name: str,
    kind: str = "constant",
    *,
    value: float | None = None,
    period: float | None = None,
    t_final: float = 10.0,
    seed: int = 0,
    path: str | os.PathLike[str] | None = None,
    column: str | None = None,
) -> Callable[[float], float]:
    """A profile ``p(t)`` (in the parameter's unit) for parameter `name`.

    Parameters
    ----------
    plant : UncertainPlant
    name : str
        A parameter with a range.
    kind : {'constant', 'sinusoid', 'ramp', 'random-walk', 'csv'}
        ``constant``: `value` (default the nominal). ``sinusoid``: between the range's ends
        with `period` (default: the fastest the rate bound allows, else 10 s), starting at
        the lower end. ``ramp``: from the lower to the upper end at the rate bound (default:
        over `t_final`), then held. ``random-walk``: slopes drawn uniformly within ± the rate
        bound, redrawn every 0.1 of the range's traversal time, reflected at the ends
        (needs a rate bound). ``csv``: column `column` of the CSV file `path` against its
        column ``t`` (s), interpolated linearly and held beyond its ends.
    value : float, optional
    period : float, optional
        s (> 0).
    t_final : float
        Horizon the profile must cover, s.
    seed : int
        Seed of the random walk.
    path : path-like, optional
    column : str, optional

    Returns
    -------
    callable
        ``p(t) -> float`` (a ``ParameterProfile``, which names its kind and numbers).

    Raises
    ------
    ArgumentValueError
        For a fixed parameter, a value outside the range, a random walk without rate bound.
    InputFileError
        For a CSV file without the columns, or values outside the range.
    """
    check_choice("kind", kind, PROFILES)
    param = plant.parameter(name)
    lo, hi = param.range
    t_final = check_real("t_final", t_final, positive=True)
    if kind == "constant":
        v = float(param.nominal) if value is None else check_real("value", value)  # type: ignore[arg-type]
        if not lo <= v <= hi:
            raise ArgumentValueError("value", f"must lie in {name}'s range [{lo:g}, {hi:g}] {param.unit}, found {v:g}")
        return ParameterProfile("constant", (v,))
    if not param.varies:
        raise ArgumentValueError("name", f"{name!r} is fixed at {lo:g} {param.unit}; a {kind} profile needs a range")
    if kind == "sinusoid":
        if period is None:
            period = math.pi * (hi - lo) / param.rate if param.rate else 10.0
        period = check_real("period", period, positive=True)
        mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
        return ParameterProfile("sinusoid", (mid, amp, period))
    if kind == "ramp":
        rate = param.rate if param.rate else (hi - lo) / t_final
        return ParameterProfile("ramp", (lo, hi, rate))
    if kind == "random-walk":
        if not param.rate:
            raise ArgumentValueError("kind", f"'random-walk' moves within {name}'s rate bound; {name} has none")
        dwell = 0.1 * (hi - lo) / param.rate
        n = int(math.ceil(t_final / dwell)) + 1
        slopes = np.random.default_rng(check_int("seed", seed, 0)).uniform(-param.rate, param.rate, n)
        knots = np.empty(n + 1)
        knots[0] = float(param.nominal)  # type: ignore[arg-type]
        for k in range(n):
            nxt = knots[k] + slopes[k] * dwell
            knots[k + 1] = 2 * hi - nxt if nxt > hi else (2 * lo - nxt if nxt < lo else nxt)
        times = dwell * np.arange(n + 1)
        return ParameterProfile("random-walk", times=np.asarray(times, dtype=float), values=knots)
    if path is None or column is None:
        raise ArgumentValueError("path", "and `column` are needed by a 'csv' profile")
    text_path = os.fspath(path)
    try:
        frame = pd.read_csv(text_path)
    except (OSError, ValueError, csv.Error) as err:
        raise InputFileError(f"{text_path!r}: cannot be read as CSV ({err})") from err
    for key in ("t", column):
        if key not in frame.columns:
            raise InputFileError(f"{text_path!r}: missing column `{key}`; found {', '.join(map(str, frame.columns))}")
    t_col = pd.to_numeric(frame["t"], errors="coerce").to_numpy(dtype=float)
    v_col = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    if not (np.isfinite(t_col).all() and np.isfinite(v_col).all()) or t_col.size < 2 or np.any(np.diff(t_col) <= 0):
        raise InputFileError(f"{text_path!r}: columns `t` (s, increasing) and `{column}` ({param.unit}) must hold at "
                             "least two finite rows")
    if v_col.min() < lo or v_col.max() > hi:
        raise InputFileError(f"{text_path!r}: column `{column}` leaves {name}'s range [{lo:g}, {hi:g}] {param.unit} "
                             f"(found [{v_col.min():g}, {v_col.max():g}])")
    return ParameterProfile("csv", times=t_col, values=v_col)


@dataclass(frozen=True, eq=False)
class ParameterProfile:
    """A profile ``p(t)`` of :func:`parameter_profile`: callable, and it says what it is.

    So a compiled engine can evaluate the same profile in machine code.

    Attributes
    ----------
    kind : str
        One of :data:`PROFILES`.
    numbers : tuple of float
        ``constant``: ``(value,)``; ``sinusoid``: ``(mid, amplitude, period)`` for
        ``mid − amplitude cos(2π t / period)``; ``ramp``: ``(low, high, rate)`` for
        ``min(high, low + rate max(t, 0))``; empty for a table.
    times, values : ndarray, shape (k,), or None
        ``random-walk`` and ``csv``: the table interpolated linearly (``np.interp``, held
        beyond its ends), times in s.
    """

    kind: str
    numbers: tuple[float, ...] = ()
    times: Array | None = None
    values: Array | None = None

    def __call__(self, t: Any) -> Any:
        """``p(t)`` in the parameter's unit, t in s: a float, or an array of t's shape for an array."""
        if np.ndim(t) > 0:
            return np.array([self(float(tk)) for tk in np.ravel(t)]).reshape(np.shape(t))
        if self.kind == "constant":
            return self.numbers[0]
        if self.kind == "sinusoid":
            mid, amp, period = self.numbers
            return mid - amp * math.cos(2 * math.pi * t / period)
        if self.kind == "ramp":
            lo, hi, rate = self.numbers
            return min(hi, lo + rate * max(t, 0.0))
        assert self.times is not None and self.values is not None
        return float(np.interp(t, self.times, self.values))


@dataclass(frozen=True)
class PlantRun:
    """One closed-loop run of a plant.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Times, s.
    y : ndarray, shape (q, k)
        Controlled outputs, in their units.
    r : ndarray, shape (q, k)
        Reference.
    e : ndarray, shape (q, k)
        ``r − y``.
    u : ndarray, shape (m, k)
        Controller outputs, in the inputs' units.
    p : ndarray, shape (n_parameters, k)
        Parameter values, in their units.
    status : str
        One of :data:`scara_robust.STATUSES`.
    reason : str
    max_abs_error : float
        max |e| after the transient, over outputs.
    peak_input : float
        max |u| over the run.
    max_rate : ndarray, shape (n_parameters,)
        Largest |ṗ| of the profile, on the samples, unit/s.
    labels : tuple of str
        Column names with units, for :meth:`to_pandas`.
    """

    t: Array
    y: Array
    r: Array
    e: Array
    u: Array
    p: Array
    status: str
    reason: str
    max_abs_error: float
    peak_input: float
    max_rate: Array
    labels: tuple[str, ...]

    def to_pandas(self) -> pd.DataFrame:
        """The time series, one column per signal with its unit (``t [s]``, ``angle [rad]``, ...).

        Returns
        -------
        pandas.DataFrame
        """
        data = np.vstack([self.t[None], self.y, self.r, self.u, self.p]).T
        return pd.DataFrame(data, columns=list(self.labels))


def simulate_plant(
    plant: UncertainPlant,
    K: ArrayLike | SampledStateFeedback | ScheduledGain,
    *,
    profiles: Mapping[str, Callable[[float], float]] | None = None,
    measurement_bias: float = 0.0,
    reference: tuple[ArrayLike, float] | None = None,
    disturbance: ArrayLike | None = None,
    t_final: float = 10.0,
    n_points: int = 2001,
    x0: ArrayLike | None = None,
    t_transient: float | None = None,
    tolerance: float | None = None,
) -> PlantRun:
    """Simulate the plant in closed loop with the gain K while its parameters follow `profiles`.

    The gain acts continuously, ``u(t) = −K ξ(t)`` on the design-form state ξ, or, given a
    :class:`~scara_robust.SampledStateFeedback`, sampled: ``u(t) = −K ξ(t_k)`` held by a
    zero-order hold over ``[t_k, t_k + Ts)``, the plant (and the error integral of the PID
    and integral forms) integrated in continuous time between samples. This is the loop
    the sampled-data certificate (:func:`~scara_robust.max_sample_time` with the gain)
    certifies.

    Parameters
    ----------
    plant : UncertainPlant
    K : array_like, shape (m, n), SampledStateFeedback or ScheduledGain
        Gain on the design form (a :class:`~scara_robust.Design`'s ``K``), the same gain
        sampled at its ``Ts``, or a gain scheduled on a parameter: ``u = −K(p̂(t)) ξ`` with
        the measured ``p̂(t) = p(t) + measurement_bias``.
    profiles : mapping of str to callable, optional
        ``p(t)`` per parameter (:func:`parameter_profile`); the others stay nominal.
    measurement_bias : float
        With a :class:`~scara_robust.ScheduledGain`: what the controller's measurement of
        its parameter adds to the true value, in the parameter's unit (a bias of δ is the
        worst a certificate with measurement error δ covers).
    reference : (amplitude, omega), optional
        ``r(t) = a·sin(ωt)`` per output, or a step of height a at t = 0 for ω = 0;
        amplitude array_like, shape (q,), in the outputs' units, ω in rad/s (default: a
        unit step). Not used for ``form='state'`` (regulation). A plant of
        :meth:`UncertainPlant.from_nonlinear` linearized along a reference runs along that
        one (the default) and refuses another.
    disturbance : array_like, shape (m,), optional
        A constant input disturbance added from ``t_final/4`` on, in the inputs' units.
    t_final : float
        Horizon, s.
    n_points : int
        Output samples, at least: where ``t_final/(n_points − 1)`` would be coarser than
        the step that resolves the closed loop's transient (a tenth of the shortest time
        scale ``1/|λ|`` of the transient modes of the frozen closed loops on the coarse
        parameter grid, the modes decaying at most ten times faster than the slowest; a
        twentieth of the reference's period; the sample time Ts), the run takes that step
        instead, so that its samples and metrics show the transient. Faster modes (a PID's
        derivative action on a light load) are over within a tenth of the transient and
        are not resolved.
    x0 : array_like, shape (n_x,), optional
        Initial plant state (default zero).
    t_transient : float, optional
        Start of the tracking judgement, s (default ``t_final/2``: the second half of the
        run, after the disturbance has acted for a quarter of it).
    tolerance : float, optional
        Largest max |e| after the transient that counts as tracking, in the outputs' units
        (default :data:`PLANT_TRACKING_RTOL` times the reference's peak).

    Returns
    -------
    PlantRun
        Status ``too-short`` (and ``max_abs_error`` NaN) when fewer than two samples
        follow `t_transient`: the tracking is then not judged.

    Raises
    ------
    ArgumentValueError
        Naming ``t_final``, when the resolved output grid would need more memory than one
        request may use (the memory check of the SCARA's runs; the message gives
        the samples and the memory).

    See Also
    --------
    parameter_profile : the parameter trajectories.
    plot_plant_run : draws the run.
    """
    n_x, m = plant.n_states, plant.n_inputs
    bias = check_real("measurement_bias", measurement_bias)
    schedule, K, Ts = _gain_parts(plant, K, bias)
    t_final = check_real("t_final", t_final, positive=True)
    n_points = check_int("n_points", n_points, 3)
    profiles = dict(profiles or {})
    for key in profiles:
        check_choice("profiles", key, plant.names)
    nominal = plant.nominal
    q = len(plant.outputs)
    C = _output_matrix(plant)
    amp, omega = _reference_wave(plant, reference)
    d = np.zeros(m) if disturbance is None else check_array("disturbance", disturbance, shape=(m,))
    x_init = np.zeros(n_x) if x0 is None else check_array("x0", x0, shape=(n_x,))
    t_on = 0.25 * t_final
    n_int = q if plant.form != "state" else 0
    n_points = _output_points(plant, K, omega, Ts, t_final, n_points, n_int)

    def ref(t: float) -> tuple[Array, Array]:
        if omega == 0.0:
            return amp.copy(), np.zeros(q)
        return amp * math.sin(omega * t), amp * omega * math.cos(omega * t)

    def params_at(t: float) -> dict[str, float]:
        return {k: (profiles[k](t) if k in profiles else v) for k, v in nominal.items()}

    def gain_at(t: float) -> Array:
        if schedule is None:
            return K
        return schedule.gain(params_at(t)[schedule.parameter] + bias)

    def control(t: float, x: Array, z: Array) -> Array:
        r, rd = ref(t)
        Kt = gain_at(t)
        if plant.form == "pid":
            e, ed = r - x[:q], rd - x[q:2 * q]
            return np.asarray(-Kt @ np.concatenate([z, e, ed]))
        if plant.form == "integral":
            return np.asarray(-Kt @ np.concatenate([z, x]))
        return np.asarray(-Kt @ x)

    def update(t: float, xs: Array, u_in: Array, params: object) -> Array:
        x, z = xs[:n_x], xs[n_x:]
        u = (control(t, x, z) if Ts is None else u_in) + (d if t >= t_on else 0.0)
        dz = ref(t)[0] - C[:q] @ x if n_int else np.zeros(0)
        if plant.dynamics is not None:  # a nonlinear system: itself, not its linearization
            return np.concatenate([plant.dynamics.rhs(t, x, u, params_at(t)), dz])
        A, B = plant.plant_matrices(params_at(t))
        return np.concatenate([A @ x + B @ u, dz])

    sys = ct.nlsys(update, None, states=n_x + n_int, inputs=m if Ts else 0, outputs=n_x + n_int, name=plant.name)
    T = np.linspace(0.0, t_final, n_points)
    states, held, ok, message = _solve(sys, T, Ts, t_on, np.concatenate([x_init, np.zeros(n_int)]), m,
                                       lambda t, xs: control(t, xs[:n_x], xs[n_x:]), _DIVERGED * _scale(amp, x_init))
    T, stopped = T[:states.shape[1]], (float(T[states.shape[1]]) if states.shape[1] < T.size else None)
    x, z = states[:n_x], states[n_x:]
    r = np.array([ref(t)[0] for t in T]).T.reshape(q, -1)
    y = C[:q] @ x if plant.form != "state" else x[:q]
    e = r - y
    u = held if Ts is not None else np.array([control(t, x[:, k], z[:, k]) for k, t in enumerate(T)]).T.reshape(m, -1)
    if plant.dynamics is not None:  # the input applied: the operating input and the controller's
        u = u + np.array([plant.dynamics.operating_point(t)[1] for t in T]).T.reshape(m, -1)
    p = np.array([[params_at(t)[name] for t in T] for name in plant.names]).reshape(len(plant.names), -1)
    rates = np.abs(np.diff(p, axis=1) / np.diff(T)).max(axis=1) if p.size else np.zeros(0)
    finite = bool(np.isfinite(states).all())
    status, reason, worst = _judge(plant, T, e, amp, x_init, finite, ok, message, tolerance, t_transient, stopped)
    return PlantRun(T, y, r, e, u, p, status, reason, worst, float(np.abs(u).max()) if finite else math.inf,
                    rates, _labels(plant))


def _transient_step(plant: UncertainPlant, K: ArrayLike, omega: float = 0.0,
                   Ts: float | None = None) -> tuple[float, str]:
    """The largest output step (s) that resolves the closed loop's transient, and why.

    Over the frozen closed loops ``A_i − B_i K`` on the plant's coarse parameter grid, the
    transient modes of each are its eigenvalues λ that decay at most ``_TRANSIENT_SPREAD``
    (10) times faster than its slowest mode (the dominant one: the
    error's settling; faster modes are over within a tenth of it and are not resolved); the
    step is a tenth of the shortest time scale ``1/|λ|`` (decay and oscillation) among them,
    at most a twentieth of the reference's period ``2π/ω`` (ω > 0) and at most the sample
    time Ts of a sampled gain.

    Parameters
    ----------
    plant : UncertainPlant
    K : array_like, shape (m, n)
        Gain on the design form.
    omega : float
        Reference frequency, rad/s (0: a step).
    Ts : float, optional
        Sample time of a sampled gain, s.

    Returns
    -------
    step : float
        s (``inf`` when nothing bounds it: every closed-loop eigenvalue zero, a step
        reference, a continuous gain).
    why : str
        What sets it, for messages.
    """
    loops = plant.samples(plant.coarse_points()).closed_loops(K)
    lam = np.linalg.eigvals(loops)
    size = np.abs(lam)
    alive = size > 1e-12 * np.maximum(size.max(axis=1, keepdims=True), np.finfo(float).tiny)
    decay = np.where(alive, np.abs(lam.real), np.inf)
    transient = alive & (decay <= _TRANSIENT_SPREAD * decay.min(axis=1, keepdims=True))
    rate = float(np.where(transient, size, 0.0).max()) if lam.size else 0.0
    bounds = [(math.inf, "no time scale bounds it")]
    if rate > 0:
        bounds.append((1.0 / (_SAMPLES_PER_TIME_SCALE * rate),
                       f"a tenth of the closed loop's shortest transient time scale 1/|λ| = {1 / rate:.3g} s"))
    if omega > 0:
        bounds.append((2 * math.pi / omega / (2 * _SAMPLES_PER_TIME_SCALE),
                       f"a twentieth of the reference's period {2 * math.pi / omega:.3g} s"))
    if Ts is not None:
        bounds.append((float(Ts), f"the sample time Ts = {Ts:g} s"))
    return min(bounds, key=lambda b: b[0])


def _integrate(sys: ct.NonlinearIOSystem, T: Array, U: Array, x0: Array) -> Array:
    """python-control's LSODA response of `sys` on times T (s) from x0; its states, shape (n, len(T))."""
    res = ct.input_output_response(sys, T, U, x0, solve_ivp_method="LSODA",
                                   solve_ivp_kwargs={"rtol": 1e-8, "atol": 1e-10})
    return np.asarray(res.states, dtype=float).reshape(x0.size, -1)


def _integrate_sampled(
    sys: ct.NonlinearIOSystem, T: Array, Ts: float, t_on: float, x0: Array, control: Callable[[float, Array], Array],
    limit: float,
) -> tuple[Array, Array]:
    """The loop with the input sampled every Ts (s) and held: segment by segment, on output times T.

    The input ``control(t_k, x(t_k))`` is held over ``[t_k, t_k + Ts)``; the segments also
    break at `t_on` (s), where the disturbance steps, so no input is interpolated across a
    step. Returns the states on T, shape (n, k), and the held input on T, shape (m, k):
    k = len(T), or fewer when a state left ``±limit`` (or became NaN) at the end of a
    segment, where the run stops.
    """
    samples = np.arange(0.0, T[-1], Ts)
    breaks = np.union1d(np.append(samples, T[-1]), [t_on] if 0.0 < t_on < T[-1] else [])
    states = np.empty((x0.size, T.size))
    held = np.empty((sys.ninputs, T.size))
    x, u = x0.copy(), np.zeros(sys.ninputs)
    sampled = np.isin(breaks, samples)
    for i, (a, b) in enumerate(zip(breaks[:-1], breaks[1:])):
        if sampled[i]:
            u = control(a, x)
        inside = (T >= a) & ((T < b) | (b == T[-1]))
        times = np.union1d([a, b], T[inside])
        out = _integrate(sys, times, np.repeat(u[:, None], times.size, axis=1), x)
        keep = np.isin(times, T[inside])
        states[:, inside] = out[:, keep]
        held[:, inside] = u[:, None]
        x = out[:, -1]
        if not np.abs(x).max(initial=0.0) <= limit:  # diverged (or NaN): stop after this segment's samples
            kept = int(np.flatnonzero(inside)[-1]) + 1 if inside.any() else int((T < a).sum())
            return states[:, :kept], held[:, :kept]
    return states, held


def _output_matrix(plant: UncertainPlant) -> Array:
    """The rows of the state that are the plant's outputs (the PID form's e, the integral form's C, else I)."""
    n_x, q = plant.n_states, len(plant.outputs)
    if plant.form == "pid":
        return np.hstack([np.eye(q), np.zeros((q, n_x - q))])
    if plant.form == "integral":
        assert plant.C is not None
        return np.asarray(plant.C)
    return np.eye(n_x)


def _output_points(plant: UncertainPlant, K: Array, omega: float, Ts: float | None, t_final: float, n_points: int,
                   n_int: int) -> int:
    """Output samples of a run: `n_points`, or more where the transient needs them; refused beyond the memory.

    Never coarser than the transient: a grid that misses it would show (and judge) nothing of it.
    """
    step, why = _transient_step(plant, K, omega, Ts)
    rows = float(n_points)
    if t_final / (n_points - 1) > step:
        rows = t_final / step + 1.0
        rows = float(math.ceil(rows)) if math.isfinite(rows) else rows  # an infinite estimate is refused
    else:
        why = f"n_points = {n_points}"
    segments = 0.0 if Ts is None else t_final / Ts + 1  # a sampled loop's breaks and held inputs
    n_out = 1 + 2 * len(plant.outputs) + plant.n_inputs + len(plant.names)
    check_memory("t_final", simulation_bytes(t_final, t_final / (rows - 1), plant.n_states + n_int, n_out)
                 + 32.0 * segments,
                 f"{rows:.3g} output samples ({t_final:g} s every {t_final / (rows - 1):.3g} s: {why})")
    return int(rows)


def _judge(plant: UncertainPlant, T: Array, e: Array, amp: Array, x_init: Array, finite: bool, ok: bool,
           message: str, tolerance: float | None, t_transient: float | None,
           stopped: float | None = None) -> tuple[str, str, float]:
    """``(status, reason, max |e| after the transient)`` of a run (`stopped`: when a diverging run stopped, s)."""
    if stopped is not None:
        return "diverged", (f"the state grew beyond {_DIVERGED:g} times its scale by t = {stopped:.4g} s; the run "
                            "stopped there"), math.inf
    t_final = float(T[-1])
    peak_r = float(np.abs(amp).max()) if amp.size else 0.0
    tol = (PLANT_TRACKING_RTOL * peak_r if peak_r > 0 else PLANT_TRACKING_RTOL) if tolerance is None else \
        check_real("tolerance", tolerance, positive=True)
    start = 0.5 * t_final if t_transient is None else check_real("t_transient", t_transient, nonnegative=True)
    after = T >= start
    judged = int(after.sum()) >= 2
    worst = (float(np.abs(e[:, after]).max()) if judged else math.nan) if finite else math.inf
    scale = _scale(amp, x_init)
    unit = plant.outputs[0].unit
    if not ok:
        status, reason = "failed", message
    elif finite and not judged:
        status, reason = "too-short", (f"fewer than 2 samples after {start:g} s (the run ends at {t_final:g} s): "
                                       "max |e| after the transient is not resolved; tracking is not judged")
    elif not finite or worst > _DIVERGED * scale:
        status, reason = "diverged", f"the state grew beyond {_DIVERGED:g} times its scale"
    elif worst <= tol:
        status, reason = "tracking", f"max |e| after {start:g} s = {worst:.3g} {unit} <= {tol:.3g} {unit}"
    else:
        status, reason = "not-tracking", f"max |e| after {start:g} s = {worst:.3g} {unit} > {tol:.3g} {unit}"
    assert status in STATUSES
    return status, reason, worst


def _scale(amp: Array, x_init: Array) -> float:
    """The scale a run's divergence is measured on: 1, the reference's peak or the initial state's."""
    return max(1.0, float(np.abs(amp).max()) if amp.size else 0.0, float(np.abs(x_init).max()) if x_init.size else 0.0)


def _gain_parts(plant: UncertainPlant, K: Any, bias: float) -> tuple[ScheduledGain | None, Array, float | None]:
    """``(schedule, K, Ts)``: a schedule (its gain at the nominal K), or a fixed gain, held with its Ts or not."""
    m, n = plant.n_inputs, plant.n_design_states
    schedule = schedule_of(K)
    if schedule is not None:
        check_choice("K.parameter", schedule.parameter, plant.names)
        if schedule.shape != (m, n):
            raise ArgumentValueError("K", f"must hold gains of shape ({m}, {n}) for this plant, found {schedule.shape}")
        K = schedule.gain(plant.nominal[schedule.parameter])  # the transient's time step is estimated with it
    elif bias != 0:
        raise ArgumentValueError("measurement_bias", "applies to a ScheduledGain (the measured parameter's error)")
    K, Ts = held_gain(K)
    return schedule, check_array("K", K, shape=(m, n)), Ts


def _labels(plant: UncertainPlant) -> tuple[str, ...]:
    """The columns of a plant's run: time, outputs, references, inputs, parameters, with units."""
    return ("t [s]", *(f"{s.name} [{s.unit}]" for s in plant.outputs),
            *(f"{s.name} reference [{s.unit}]" for s in plant.outputs),
            *(f"{s.name} [{s.unit}]" for s in plant.inputs),
            *(f"{prm.name} [{prm.unit}]" for prm in plant.parameters))


def _solve(sys: ct.NonlinearIOSystem, T: Array, Ts: float | None, t_on: float, xs0: Array, m: int,
           law: Callable[[float, Array], Array], limit: float) -> tuple[Array, Array, bool, str]:
    """``(states, held inputs, ok, message)`` of a plant's loop: continuous, or `law` sampled every `Ts` and held.

    A failed solve (python-control raises) gives NaN states and the error as the message; a
    sampled loop whose state leaves ``±limit`` stops there (fewer columns than `T`).
    """
    held = np.zeros((m, T.size))
    try:
        if Ts is None:
            states = _integrate(sys, T, np.zeros((0, T.size)), xs0)
        else:
            states, held = _integrate_sampled(sys, T, Ts, t_on, xs0, law, limit)
        return states, held, True, "integrated"
    except (ValueError, RuntimeError, OverflowError) as err:  # python-control raises on a failed solve
        return np.full((xs0.size, T.size), np.nan), held, False, f"the integrator failed: {err}"


def _reference_wave(plant: UncertainPlant, reference: tuple[ArrayLike, float] | None) -> tuple[Array, float]:
    """``(a, ω)`` of the run's reference ``a sin ωt`` (default a unit step, or the one a nonlinear plant was
    linearized along; none for the state form)."""
    q = len(plant.outputs)
    own = None if plant.dynamics is None else plant.dynamics.reference
    if own is not None:  # its feedforward holds that reference alone: another would be run without its model
        if reference is None:
            return own[0].copy(), float(own[1])
        given = np.broadcast_to(np.asarray(reference[0], dtype=float), (q,))
        if not (np.array_equal(given, own[0]) and float(reference[1]) == float(own[1])):
            raise ArgumentValueError("reference", f"must be the one the plant was linearized along, a = "
                                                  f"{own[0].tolist()}, ω = {float(own[1]):g} rad/s (its feedforward "
                                                  f"holds that one), found a = {given.tolist()}, ω = "
                                                  f"{float(reference[1]):g}")
    amp = np.ones(q) if reference is None else check_array("reference[0]", np.broadcast_to(reference[0], (q,)))
    omega = 0.0 if reference is None else check_real("reference[1]", reference[1], nonnegative=True)
    return (np.zeros(q) if plant.form == "state" else amp), omega
