"""What the page computes, without the page: the map, one design's answers, cancellable slow work.

:class:`DesignExplorer` holds the plant (the SCARA or a plant file), the (ρ, η) grid and its
map, and answers for one selected design: first the gain and Theorem 1's verdict (fast),
then the closed-loop response, then the certificates, margins and sample time (slow). The
slow answers run on a worker thread (the response on a second one, so it never waits behind
them); :meth:`DesignExplorer.submit` starts them for a new
selection and drops every pending answer of the previous one.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from ..controller.scheduled import ScheduledGain
from ..exceptions import ArgumentError, ArgumentValueError
from ..lyapunov.gain import Design, design
from ..lyapunov.surface import DesignSurface, design_surface
from ..lyapunov.theorem1 import certify
from ..model.plant import UncertainPlant
from ..model.robot import paper_payload
from ..model.uncertain import UncertainLTVModel
from ..robustness.actuator import input_limit_certificate, step_initial_errors
from ..robustness.decay import design_decay_rate
from ..robustness.loop_margins import frozen_loop_views, worst_loop_margins
from ..robustness.margins import robustness_margin
from ..robustness.payload import payload_margin
from ..robustness.registry import analysis_methods, get_method
from ..robustness.sampled import check_sample_time, max_sample_time
from ..robustness.scheduled import schedule_certificate
from ..robustness.table import certificate_table
from ..simulation.plants import simulate_plant
from ..simulation.run import run_scenario

__all__ = ["MEASURES", "PAYLOAD_MAP_POINTS", "PAYLOAD_MAP_TOL", "Answer", "DesignExplorer", "QuickAnswer", "Response",
           "RunSettings"]

Array = NDArray[np.float64]

#: Map measures: key -> (label with unit, what it is).
MEASURES: dict[str, tuple[str, str]] = {
    "max_eig": ("max λ(Z) [-]", "Theorem 1: certified where max λ(Z) < 0"),
    "margin": ("margin θ [-]", "Theorem 1 margin: the largest scaling of every element range it certifies "
                               "(certified where θ >= 1)"),
    "payload": ("certified payload [kg]", "the largest peak payload the design's P certifies, on a coarse grid "
                                          "(certified where it reaches the robot's payload)"),
    "deployable": ("log₁₀ s* [-]", "certified and within the input limits: a unit step of the reference is "
                                   "certified within every input's limit where s* >= 1 (log₁₀ s* >= 0); grey where "
                                   "Theorem 1 does not certify"),
}

#: Points per axis of the payload map (one payload bisection per point, about half a second each).
PAYLOAD_MAP_POINTS = 12
#: Relative tolerance of the payload map's bisections.
PAYLOAD_MAP_TOL = 5e-2


@dataclass(frozen=True)
class QuickAnswer:
    """The gain of one (ρ, η) and Theorem 1's verdict: what a click shows at once.

    Attributes
    ----------
    rho, eta : float
    design : Design
    max_eig : float
        max λ(Z) of Theorem 1 (certified when < 0).
    certified : bool
    seconds : float
        Wall time of the design and the certificate, s.
    """

    rho: float
    eta: float
    design: Design
    max_eig: float
    certified: bool
    seconds: float


@dataclass(frozen=True)
class RunSettings:
    """The scenario of the SCARA's response on the page.

    Attributes
    ----------
    initial : {'large', 'small'}
        The initial tracking error (:data:`scara_robust.SCENARIOS`).
    payload_on : bool
        False: the run without the load (``m_p = 0``).
    torque_limit : tuple of float, optional
        Per-joint saturation, N·m (one value: both joints).
    """

    initial: str = "large"
    payload_on: bool = True
    torque_limit: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Response:
    """A closed-loop run of the selected design.

    Attributes
    ----------
    t : ndarray, shape (k,)
        s.
    errors : ndarray, shape (q, k)
        Tracking errors, in the outputs' unit.
    inputs : ndarray, shape (m, k)
        Controller outputs, in the inputs' unit (legends and units: :attr:`DesignExplorer.signals`).
    status : str
    reason : str
    seconds : float
        Wall time of the run, s.
    """

    t: Array
    errors: Array
    inputs: Array
    status: str
    reason: str
    seconds: float


@dataclass(frozen=True)
class Answer:
    """One slow answer for the selected design.

    Attributes
    ----------
    kind : {'response', 'margins', 'certificates', 'payload', 'sample_time'}
    generation : int
        The selection it belongs to.
    value : object
        A pandas table or a dict, by kind.
    error : str
        Why it failed, if it did ("" otherwise).
    seconds : float
    """

    kind: str
    generation: int
    value: Any
    error: str
    seconds: float


@dataclass
class DesignExplorer:
    """The graphical design of one plant: its (ρ, η) map and the answers for a selected design.

    Parameters
    ----------
    model : UncertainLTVModel
        The interval model the PID is designed and certified on.
    title : str
        What the page calls the plant.
    plant : UncertainPlant, optional
        Its physical parameters (a plant file's, or the robot's payload and reference time):
        the physical certificate rows and, for a plant file, the simulation.
    plant_source : callable, optional
        A picklable call that builds `plant` again (a worker process computes the physical
        certificate rows with it; a plant's own functions cannot be sent to a process).
    robot_signals : mapping, optional
        Keyword arguments of :func:`scara_robust.run_scenario` (the SCARA's robot, reference,
        payload and disturbance): the response is the SCARA's 20-s run on the compiled
        engine. Without it the response is :func:`scara_robust.simulate_plant` on `plant`.
    sampled : (plants, check, name), optional
        The sampled-data certificate's plants, a set to verify on, and their description.
    controller_ts : float, optional
        The controller's sample time its file gives, s: the sample-time answer is then the
        certificate at it (:func:`scara_robust.check_sample_time`), and the page leads with it;
        without it, the largest certified Ts.
    design_file : callable, optional
        ``design_file(rho, eta) -> text``: the design file (JSON) of (ρ, η), as ``design
        --format json`` writes it.
    exporter : callable, optional
        ``exporter(rho, eta, Ts, torque_limit) -> {file name: text}``; raises
        ``ValueError`` (or a subclass) with a one-line message when it refuses.
    parse_grid : callable, optional
        Parses a grid ``START:STOP:NUM`` into its values; raises with a message.
    rhos, etas : array_like
        The map's grid.
    elements : {'all', 'A', 'B'}
        The uncertain elements entering Theorem 1's Z (the others at their lower bounds), on
        the map and in the selected design's verdict.
    t_final : float
        Horizon of the response, s.
    schedule : ScheduledGain, optional
        A gain scheduled on a parameter of `plant` (a schedule file): the page draws its
        entries against the parameter, the selected design's beside them, and re-verifies
        the certificate its file records (:meth:`schedule_check`).
    """

    model: UncertainLTVModel
    title: str
    plant: UncertainPlant | None = None
    plant_source: Callable[[], Any] | None = None
    robot_signals: Mapping[str, Any] | None = None
    sampled: tuple[Any, Any, str] | None = None
    controller_ts: float | None = None
    exporter: Callable[[float, float, float, list[float] | None], dict[str, str]] | None = None
    design_file: Callable[[float, float], str] | None = None
    parse_grid: Callable[[str], Array] | None = None
    rhos: Any = field(default_factory=lambda: np.linspace(0.1, 10.0, 100))
    etas: Any = field(default_factory=lambda: np.linspace(1.0, 200.0, 200))
    elements: str = "all"
    t_final: float = 20.0
    schedule: ScheduledGain | None = None
    surface: DesignSurface | None = field(default=None, init=False)
    _generation: int = field(default=0, init=False)
    _pending: list[Future[tuple[Any, str, float]]] = field(default_factory=list, init=False)
    _lock: Any = field(default_factory=threading.RLock, init=False)
    _process: ProcessPoolExecutor | None = field(default=None, init=False)
    _runner: ProcessPoolExecutor | None = field(default=None, init=False)
    _runs: int = field(default=0, init=False)
    _mapper: ProcessPoolExecutor | None = field(default=None, init=False)
    _map_jobs: list[Future[Any]] = field(default_factory=list, init=False)
    payload_values: Array | None = field(default=None, init=False)
    _deployable: tuple[DesignSurface, Array] | None = field(default=None, init=False, repr=False)
    settings: RunSettings = field(default_factory=RunSettings, init=False)
    _schedule_future: Future[Any] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.schedule is not None:
            shape = (self.model.n_inputs, self.model.n_states)
            if self.plant is None or self.schedule.parameter not in self.plant.names or self.schedule.shape != shape:
                raise ArgumentValueError("schedule", f"must schedule gains of shape {shape} on a parameter of the "
                                                     f"plant, found {self.schedule.shape} on "
                                                     f"{self.schedule.parameter!r}")
        self.compute_map(self.rhos, self.etas)

    @property
    def signals(self) -> tuple[tuple[str, ...], tuple[str, ...], str, str]:
        """Legend entries of the errors and of the inputs (with units), and the two units."""
        if self.robot_signals is not None or self.plant is None:
            return ("e₁ [rad]", "e₂ [rad]"), ("τ₁ [N·m]", "τ₂ [N·m]"), "rad", "N·m"
        out, inp = self.plant.outputs, self.plant.inputs
        return (tuple(f"e {s.name} [{s.unit}]" for s in out), tuple(f"{s.name} [{s.unit}]" for s in inp),
                out[0].unit, inp[0].unit)

    def deployable(self, response: Response) -> tuple[bool, str] | None:
        """Whether the response's inputs stay within the plant file's input limits, and why.

        Parameters
        ----------
        response : Response
            The selected design's run (its ``inputs``, shape (m, n_t), in the inputs' units).

        Returns
        -------
        (bool, str) or None
            None when the plant gives no input limit.
        """
        limits = None if self.plant is None or self.robot_signals is not None else self.plant.input_limits
        if limits is None:
            return None
        peaks = np.abs(np.asarray(response.inputs, dtype=float)).max(axis=1)
        inputs = self.plant.inputs  # type: ignore[union-attr]
        parts = [f"peak |{s.name}| = {peak:.4g} {s.unit} (limit {limit:g} {s.unit})"
                 for s, peak, limit in zip(inputs, peaks, limits) if np.isfinite(limit)]
        over = [f"{s.name} needs {peak:.4g} {s.unit}, beyond its limit of {limit:g} {s.unit}"
                for s, peak, limit in zip(inputs, peaks, limits) if peak > limit]
        if over:
            return False, "; ".join(over) + " in this run: not deployable on this actuator"
        return True, "; ".join(parts) + " in this run"

    @property
    def limit_name(self) -> str:
        """What the page calls the saturation of the controller's outputs."""
        return "torque limit" if self.robot_signals is not None or self.plant is None else "input limit"

    # -- the map -----------------------------------------------------------------------------

    def compute_map(self, rhos: Any, etas: Any) -> DesignSurface:
        """Evaluate max λ(Z) and the Theorem 1 margin on ``rhos × etas`` (refused beyond the CLI's limit).

        Parameters
        ----------
        rhos, etas : array_like

        Returns
        -------
        DesignSurface

        Raises
        ------
        ArgumentValueError
            For a grid the ``surface`` command refuses too (values, or more points than
            :data:`scara_robust.MAX_SURFACE_POINTS`).
        """
        surface = design_surface(self.model, rhos, etas, self.elements, measure="margin")
        self.surface, self.rhos, self.etas = surface, surface.rhos, surface.etas
        self._stop_payload_map()
        return surface

    # -- the payload map (the SCARA) ------------------------------------------------------------

    @property
    def payload_level(self) -> float:
        """The robot's payload peak, kg: the payload map's certification level."""
        if self.robot_signals is None:
            raise ValueError("the payload map needs the SCARA")
        profile = self.robot_signals.get("payload") or paper_payload(self.robot_signals.get("params"))
        return float(profile.bounds[1])

    def payload_grid(self, n: int = PAYLOAD_MAP_POINTS) -> tuple[Array, Array]:
        """The payload map's grid: `n` evenly spaced values over each axis of the map's range.

        Parameters
        ----------
        n : int

        Returns
        -------
        rhos, etas : ndarray, shape (n,)
        """
        return (np.linspace(self.rhos[0], self.rhos[-1], n), np.linspace(self.etas[0], self.etas[-1], n))

    def start_payload_map(self, on_column: Callable[[int, Array], None], n: int = PAYLOAD_MAP_POINTS) -> Array:
        """Compute the certified payload over :meth:`payload_grid`, one ρ column per job, in a worker process.

        The column's values go into the returned array as it finishes, then `on_column(i,
        masses)` is called (on a worker thread). A new map grid stops the computation.

        Parameters
        ----------
        on_column : callable
        n : int
            Points per axis.

        Returns
        -------
        ndarray, shape (n, n)
            NaN until each column arrives, then the largest certified peak payload, kg.
        """
        if self.robot_signals is None:
            raise ValueError("the payload map needs the SCARA")
        self._stop_payload_map()
        rhos, etas = self.payload_grid(n)
        values = np.full((n, n), np.nan)
        self.payload_values = values
        if self._mapper is None:  # its own worker: the map's minute of work never delays a click's answers
            self._mapper = ProcessPoolExecutor(1, mp_context=_WORKER_CONTEXT,
                                               initializer=_lower_priority)
        params, reference = self.robot_signals.get("params"), self.robot_signals.get("reference")

        def finish(i: int, done: Future[Array]) -> None:
            if done.cancelled() or self.payload_values is not values:
                return
            values[i] = done.result()
            on_column(i, values[i])

        for i, rho in enumerate(rhos):
            future = self._mapper.submit(_payload_column, self.model, float(rho), etas, params, reference)
            future.add_done_callback(partial(finish, i))
            self._map_jobs.append(future)
        return values

    def _stop_payload_map(self) -> None:
        for future in self._map_jobs:
            future.cancel()
        self._map_jobs = []
        self.payload_values = None

    @property
    def has_input_limits(self) -> bool:
        """True for a plant file in the PID form whose inputs have limits: the map's ``deployable`` measure."""
        return (self.robot_signals is None and self.plant is not None and self.plant.form == "pid"
                and self.plant.input_limits is not None)

    def deployable_map(self) -> Array:
        """log₁₀ s* over the map: the unit step certified within the input limits where >= 0.

        For each design the invariant ellipsoids of its own P (:func:`scara_robust.input_limit_certificate`)
        give s*, the scale of the initial errors of a unit step of each reference (``e(0) = 1``
        output unit) certified within every input's limit. For fixed ρ the Riccati P is fixed
        and ``K = ηK₁`` (see :mod:`scara_robust.lyapunov.surface`), so ``s*(ρ, η) = s*(ρ, 1)/η``:
        one certificate per ρ. NaN where Theorem 1 does not certify the design (its P is then
        no Lyapunov function of the set).

        Returns
        -------
        ndarray, shape (n_rho, n_eta)
        """
        assert self.surface is not None and self.plant is not None and self.plant.input_limits is not None
        if self._deployable is not None and self._deployable[0] is self.surface:
            return self._deployable[1]
        step = step_initial_errors(self.plant)
        per_rho = np.array([input_limit_certificate(d.K, d.P, self.plant.input_limits, step).scale
                            for d in (design(self.model, float(rho), 1.0) for rho in self.rhos)])
        with np.errstate(divide="ignore"):
            values = np.log10(per_rho[:, None] / np.asarray(self.etas)[None, :])
        values = np.where(self.surface.certified, values, np.nan)
        self._deployable = (self.surface, values)
        return values

    def measure(self, key: str) -> Array:
        """The map's values of one measure.

        Parameters
        ----------
        key : str
            A key of :data:`MEASURES`.

        Returns
        -------
        ndarray, shape (n_rho, n_eta)
        """
        assert self.surface is not None
        if key == "deployable":
            return self.deployable_map()
        values = self.surface.max_eig if key == "max_eig" else self.surface.margin
        assert values is not None
        return np.asarray(values, dtype=float)

    def nearest(self, rho: float, eta: float) -> tuple[int, int]:
        """Grid indices ``(i, k)`` of the map's point nearest (ρ, η), axis by axis.

        Parameters
        ----------
        rho, eta : float

        Returns
        -------
        (int, int)
        """
        i = int(np.abs(self.rhos - rho).argmin())
        k = int(np.abs(self.etas - eta).argmin())
        return i, k

    # -- one design --------------------------------------------------------------------------

    def quick(self, rho: float, eta: float) -> QuickAnswer:
        """The gain at (ρ, η) and Theorem 1's verdict.

        Parameters
        ----------
        rho : float
            > 0.
        eta : float
            >= 1.

        Returns
        -------
        QuickAnswer

        Raises
        ------
        ArgumentValueError
            Naming ``rho`` or ``eta`` when out of range.
        """
        start = time.perf_counter()
        d = design(self.model, rho, eta)
        cert = certify(self.model, d, self.elements)
        return QuickAnswer(d.rho, d.eta, d, float(cert.max_eig), bool(cert.certified), time.perf_counter() - start)

    def response(self, d: Design) -> Response:
        """The closed-loop run of design `d`: the SCARA on the compiled engine, or the plant file's loop.

        Parameters
        ----------
        d : Design

        Returns
        -------
        Response
        """
        return _response(d, self.robot_signals, self.plant, self.t_final, self.settings)

    # -- slow answers ------------------------------------------------------------------------

    def slow_answers(self, d: Design) -> dict[str, tuple[Callable[..., Any], tuple[Any, ...]]]:
        """The slow answers for design `d`, by kind, in the order they are computed.

        Parameters
        ----------
        d : Design

        Returns
        -------
        dict
            Kind -> ``(function, arguments)``: module-level functions and picklable
            arguments, run in a worker process.
        """
        answers: dict[str, tuple[Callable[..., Any], tuple[Any, ...]]] = {
            "response": (_response_in_worker, (d, self.robot_signals, self.plant_source, self.t_final,
                                               self.settings)),
            "margins": (_margins, (self.model, d)),
            "certificates": (_certificates, (self.model, d, self.plant_source)),
            "decay": (_decay, (self.model, d, self.plant_source)),
            "loop_margins": (_loop_margins, (self.model, d, self.plant_source)),
        }
        if self.robot_signals is not None:
            answers["payload"] = (_payload, (d, self.robot_signals.get("params"), self.robot_signals.get("reference")))
        if self.sampled is not None:
            plants, check, set_name = self.sampled
            answers["sample_time"] = (_sample_time, (plants, check, d, self.controller_ts, set_name))
        return answers

    def submit(self, d: Design, deliver: Callable[[Answer], None]) -> int:
        """Start the slow answers of a new selection; drop the pending ones of the previous.

        The response runs in one worker process, the other answers in another (at a lower
        priority, started once the response is delivered), so that neither their computation
        nor Python's interpreter lock slows the page's next click.

        Parameters
        ----------
        d : Design
        deliver : callable
            Called (on a worker thread) with each :class:`Answer` of this selection, never
            with an answer of a superseded one.

        Returns
        -------
        int
            The selection's generation.
        """
        answers = self.slow_answers(d)
        later = {kind: job for kind, job in answers.items() if kind != "response"}
        with self._lock:
            self._generation += 1
            generation = self._generation
            for future in self._pending:
                future.cancel()  # not started: never runs; running: its answer is dropped
            self._pending = []
            if "response" in answers:
                work, args = answers["response"]
                future = self._run_pool().submit(_timed, work, *args)
                future.add_done_callback(partial(self._finish, "response", generation, deliver))
                # the worker process starts once the response is delivered: the click's response then
                # has the machine's cores to itself (the worker's answers take seconds, not milliseconds)
                future.add_done_callback(lambda _: self._start_workers(generation, later, deliver))
                self._pending.append(future)
            else:
                self._start_workers(generation, later, deliver)
        return generation

    def _start_workers(self, generation: int, jobs: Mapping[str, tuple[Callable[..., Any], tuple[Any, ...]]],
                       deliver: Callable[[Answer], None]) -> None:
        """Submit `jobs` of selection `generation` to the worker process, unless a newer selection exists."""
        with self._lock:
            if generation != self._generation:
                return
            for kind, (work, args) in jobs.items():
                future = self._workers().submit(_timed, work, *args)
                future.add_done_callback(partial(self._finish, kind, generation, deliver))
                self._pending.append(future)

    def rerun(self, d: Design, settings: RunSettings, deliver: Callable[[Answer], None]) -> None:
        """Run the selected design's response again in `settings`; the other answers stay.

        Parameters
        ----------
        d : Design
            The selected design.
        settings : RunSettings
        deliver : callable
            Called with the response's :class:`Answer`, unless a newer selection or run exists.
        """
        with self._lock:
            self.settings = settings
            self._runs += 1
            generation, run = self._generation, self._runs
            work, args = self.slow_answers(d)["response"]
            future = self._run_pool().submit(_timed, work, *args)

            def finish(done: Future[tuple[Any, str, float]]) -> None:
                if run == self._runs:
                    self._finish("response", generation, deliver, done)

            future.add_done_callback(finish)
            self._pending.append(future)

    def figures(self, d: Design | None, measure: str, mark: tuple[float, float]) -> Future[Any]:
        """The map (with `mark`) and the response of `d` (in :attr:`settings`) as PNG files, drawn in a worker.

        Parameters
        ----------
        d : Design, optional
            The selected design (None: the map only).
        measure : str
            A key of :data:`MEASURES`: the map drawn.
        mark : (float, float)
            The selected (ρ, η).

        Returns
        -------
        concurrent.futures.Future
            Of ``(files, error, seconds)``; files: name -> PNG bytes.
        """
        assert self.surface is not None
        return self._run_pool().submit(_timed, _figures, d, self.robot_signals, self.plant_source, self.t_final,
                                       self.settings, self.surface, measure, mark, self.title)

    def start_workers(self) -> None:
        """Start the worker processes now rather than at the first selection (a second or two each).

        The response's worker also runs one response, so that the SCARA's compiled engine is loaded
        before the first click.
        """
        self._workers().submit(int)
        d = design(self.model, float(self.rhos[0]), float(self.etas[0]))
        self._run_pool().submit(_response_in_worker, d, self.robot_signals, self.plant_source, self.t_final,
                                self.settings)

    def _run_pool(self) -> ProcessPoolExecutor:
        if self._runner is None:
            self._runner = ProcessPoolExecutor(1, mp_context=_WORKER_CONTEXT,
                                               initializer=threadpool_limits, initargs=(1,))
        return self._runner

    def _workers(self) -> ProcessPoolExecutor:
        if self._process is None:
            # at a lower priority: a click's K and response, and the browser, come first on the machine's cores
            self._process = ProcessPoolExecutor(1, mp_context=_WORKER_CONTEXT,
                                                initializer=_lower_priority)
        return self._process

    @property
    def generation(self) -> int:
        """The current selection's number."""
        return self._generation

    def _finish(self, kind: str, generation: int, deliver: Callable[[Answer], None], future: Future[Any]) -> None:
        if future.cancelled() or generation != self._generation:
            return
        try:
            value, error, seconds = future.result()
        except (BrokenProcessPool, OSError) as err:  # the worker died (killed, out of memory)
            value, error, seconds = None, f"the worker process stopped: {err}", math.nan
        except Exception as err:  # noqa: BLE001  # any other failure is shown on the page, not left "computing…"
            value, error, seconds = None, f"{type(err).__name__}: {err}", math.nan
        if generation == self._generation:
            deliver(Answer(kind, generation, value, error, seconds))

    def export(self, rho: float, eta: float, ts: float, torque_limit: list[float] | None) -> dict[str, str]:
        """The controller files of (ρ, η) at Ts, as ``export`` writes them.

        Parameters
        ----------
        rho, eta : float
        ts : float
            Sample time, s.
        torque_limit : list of float, optional
            Saturation of each controller output, in the inputs' unit (N·m for the SCARA).

        Returns
        -------
        dict
            File name -> text.

        Raises
        ------
        ValueError
            With the reason (a Ts the certificate refuses, a bad limit) when nothing is written.
        """
        if self.exporter is None:
            raise ValueError("this page has no exporter")
        if not (math.isfinite(ts) and ts > 0):
            raise ValueError(f"Ts must be a sample time > 0 s, found {ts:g}")
        if torque_limit is not None and min(torque_limit) <= 0:
            raise ValueError(f"the {self.limit_name} must be > 0 {self.signals[3]}, found {min(torque_limit):g}")
        return self.exporter(rho, eta, ts, torque_limit)

    def schedule_check(self) -> Future[Any]:
        """The schedule's certificate re-verified, in a worker, at the rate and error its file records.

        Stability (decay 0) at the rate and measurement error of its ``certified`` record (the
        plant's when it records none) on :attr:`plant` (:func:`scara_robust.schedule_certificate`).

        Returns
        -------
        concurrent.futures.Future
            Of ``(certificate, error, seconds)``.
        """
        if self.schedule is None:
            raise ArgumentValueError("schedule", "is not given: this page has no scheduled gain")
        with self._lock:  # once per page: every browser that opens it shows the same check
            if self._schedule_future is None:
                plant = self.plant if self.plant_source is None else None  # a plant's functions cannot be sent
                self._schedule_future = self._workers().submit(_timed, _schedule_check, self.plant_source, plant,
                                                               self.schedule)
            return self._schedule_future

    def close(self) -> None:
        """Stop the worker processes (pending answers are dropped)."""
        self._generation += 1
        self._stop_payload_map()
        for pool in (self._runner, self._process, self._mapper):
            if pool is not None:
                # a worker still computing an answer nobody will read is stopped, not waited for
                workers = list(getattr(pool, "_processes", {}).values())
                pool.shutdown(wait=False, cancel_futures=True)
                for worker in workers:
                    worker.terminate()



class _WorkerProcess(multiprocessing.context.SpawnProcess):
    """A spawned worker of the page that never receives SIGINT.

    Ctrl-C in a terminal sends SIGINT to the whole process group; the page's own process
    stops the workers (:meth:`DesignExplorer.close`), so a worker, even one still importing,
    must not end in a ``KeyboardInterrupt`` traceback of its own. SIGINT is blocked in the
    starting thread while the worker is spawned, and the new process keeps that mask.
    """

    def start(self) -> None:
        """Start the process with SIGINT blocked in it."""
        if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - Windows has no signal masks
            super().start()
            return
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            super().start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)


class _WorkerContext(multiprocessing.context.SpawnContext):
    """The spawn context of the page's worker processes (:class:`_WorkerProcess`)."""

    Process = _WorkerProcess


_WORKER_CONTEXT = _WorkerContext()

def _timed(work: Callable[..., Any], *args: Any) -> tuple[Any, str, float]:
    """``work(*args)``, its error message ("" if none) and its wall time, s (run in a worker)."""
    start = time.perf_counter()
    try:
        return work(*args), "", time.perf_counter() - start
    except (ArgumentError, ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
        return None, " ".join(str(err).split()), time.perf_counter() - start


def _lower_priority() -> None:
    """Lower the calling process's CPU priority (nice +10) where the system has one; one BLAS thread."""
    if hasattr(os, "nice"):
        os.nice(10)
    threadpool_limits(1)


def _cheap(family: str, capabilities: frozenset[str]) -> tuple[str, ...]:
    """The registered methods of a family that answer in milliseconds and apply to these capabilities."""
    methods = (get_method(family, name) for name in analysis_methods(family, defaults=True))
    return tuple(m.name for m in methods if m.cheap and m.applies_to(capabilities))


def _schedule_check(plant_source: Callable[[], Any] | None, plant: UncertainPlant | None,
                    gain: ScheduledGain) -> Any:
    """:func:`schedule_certificate` of `gain` (stability, decay 0) at its file's recorded rate and error."""
    on = _plant_of(plant_source) if plant_source is not None else plant
    if on is None:
        raise ArgumentValueError("plant", "is needed to certify a scheduled gain")
    return schedule_certificate(on, gain, rate=gain.recorded("rate"),
                                measurement_error=gain.recorded("measurement_error"))


def _margins(model: UncertainLTVModel, d: Design) -> dict[str, Any]:
    """The margin bracket of the cheap methods (Theorem 1 and the vertex test below, a frozen unstable plant above)."""
    rows = {m: robustness_margin(model, d, m, tol=1e-3) for m in _cheap("margin", model.capabilities)}
    return {"lower": max(r.theta for r in rows.values() if r.bound == "lower"),
            "upper": min(r.theta for r in rows.values() if r.bound == "upper"), "rows": rows}


#: The worker process's plants, by the repr of the call that builds them (built once per process).
_PLANTS: dict[str, UncertainPlant | None] = {}


def _plant_of(plant_source: Callable[[], Any] | None) -> UncertainPlant | None:
    """The plant `plant_source` builds, built once per process."""
    key = repr(plant_source)
    if key not in _PLANTS:
        _PLANTS[key] = None if plant_source is None else plant_source()
    return _PLANTS[key]


def _run(d: Design, robot_signals: Mapping[str, Any] | None, plant: UncertainPlant | None, t_final: float,
         settings: RunSettings) -> Any:
    """The SCARA's :class:`~scara_robust.SimulationResult` on the compiled engine (`robot_signals`, in
    `settings`), or else `plant`'s :class:`~scara_robust.PlantRun`."""
    if robot_signals is not None:
        return run_scenario("pid", settings.initial, payload_on=settings.payload_on, K=d.K, t_final=t_final,
                            torque_limit=None if settings.torque_limit is None else list(settings.torque_limit),
                            method="compiled", **robot_signals)
    if plant is None:
        raise ValueError("this page has no plant to simulate")
    return simulate_plant(plant, d.K, t_final=t_final, n_points=1001)


def _response(d: Design, robot_signals: Mapping[str, Any] | None, plant: UncertainPlant | None,
              t_final: float, settings: RunSettings = RunSettings()) -> Response:
    """The run of :func:`_run`, as the page draws it."""
    start = time.perf_counter()
    res = _run(d, robot_signals, plant, t_final, settings)
    if robot_signals is not None:
        return Response(np.asarray(res.t, dtype=float), np.asarray(res.e, dtype=float),
                        np.asarray(res.torque, dtype=float), res.status, res.status_reason,
                        time.perf_counter() - start)
    return Response(res.t, res.e, res.u, res.status, res.reason, time.perf_counter() - start)


def _response_in_worker(d: Design, robot_signals: Mapping[str, Any] | None,
                        plant_source: Callable[[], Any] | None, t_final: float,
                        settings: RunSettings = RunSettings()) -> Response:
    """:func:`_response` in a worker process, with the plant `plant_source` builds."""
    return _response(d, robot_signals, None if robot_signals is not None else _plant_of(plant_source), t_final,
                     settings)


def _figures(d: Design | None, robot_signals: Mapping[str, Any] | None, plant_source: Callable[[], Any] | None,
             t_final: float, settings: RunSettings, surface: DesignSurface, measure: str, mark: tuple[float, float],
             title: str) -> dict[str, bytes]:
    """PNG files: the map with the selected design marked, and the response of `d` (run again here)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plotting import plot_loop_views, plot_margin_map, plot_plant_run, plot_response, plot_surface_contour

    def png(fig: Any) -> bytes:
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", dpi=130, bbox_inches="tight")
        plt.close(fig)
        return buffer.getvalue()

    ax = (plot_margin_map if measure == "margin" else plot_surface_contour)(surface, mark=mark)
    files = {"design-map.png": png(ax.figure)}
    if d is not None:
        name = f"{title} at ρ = {mark[0]:.4g}, η = {mark[1]:.4g}"
        plant = None if robot_signals is not None else _plant_of(plant_source)
        result = _run(d, robot_signals, plant, t_final, settings)
        if plant is not None:
            files["response.png"] = png(plot_plant_run(result, plant, title=name))
        else:
            files["response.png"] = png(plot_response(result, title=name))
        physical = _plant_of(plant_source)
        if physical is not None and physical.form == "pid":  # each loop at its worst frozen plant
            margins = worst_loop_margins(physical, d, points=physical.grid_points())
            views = frozen_loop_views(physical, d.K, margins, t_final=t_final)
            files["loops.png"] = png(plot_loop_views({name: views}, margins={name: margins},
                                                     title=f"{title}: each loop at its worst frozen plant "
                                                           "(smallest delay margin)"))
    return files


def _certificates(model: UncertainLTVModel, d: Design, plant_source: Callable[[], Any] | None) -> Any:
    """Every certificate row (Theorem 1, vertex, physical, LMI, falsifier)."""
    return certificate_table(model, d, plant=_plant_of(plant_source), falsifier_tries=5, seed=0)


def _decay(model: UncertainLTVModel, d: Design, plant_source: Callable[[], Any] | None) -> Any:
    """The design's decay rate, as certify, compare and export report it."""
    return design_decay_rate(model, d, plant=_plant_of(plant_source))


def _loop_margins(model: UncertainLTVModel, d: Design, plant_source: Callable[[], Any] | None) -> Any:
    """Each input's worst disk and delay margin, as certify reports them."""
    plant = _plant_of(plant_source)
    if plant is None:
        return worst_loop_margins(model, d)
    return worst_loop_margins(plant, d, points=plant.grid_points())


def _payload(d: Design, params: Any, reference: Any) -> Any:
    """The SCARA's payload bracket in kg: the design's P below, a frozen unstable payload above."""
    return payload_margin(d, params, reference, tol=1e-2,
                          methods=_cheap("payload", frozenset({"parameters", "intervals", "vertices"})))


def _payload_column(model: UncertainLTVModel, rho: float, etas: Array, params: Any, reference: Any) -> Array:
    """The largest certified peak payload (kg, the design's P) of the designs (ρ, η) for each η of `etas`."""
    masses = np.empty(len(etas))
    for k, eta in enumerate(etas):
        table = payload_margin(design(model, rho, float(eta)), params, reference, tol=PAYLOAD_MAP_TOL,
                               methods=("payload-design-P",))
        masses[k] = float(table["mass [kg]"].iloc[0])
    return masses


def _sample_time(plants: Any, check: Any, d: Design, Ts: float | None = None, set_name: str = "") -> Any:
    """The certificate at the controller's Ts (the PID discretized as export does), else the largest certified Ts."""
    if Ts is not None:
        return check_sample_time(plants, d.discretize(Ts), check=check, set_name=set_name or "the given plants")
    return max_sample_time(plants, d, check=check)
