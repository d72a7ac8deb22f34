"""The system a design runs on, for every front end: :class:`LoadedSystem` and its kinds.

Three kinds of system reach the front ends: the built-in SCARA (optionally a robot data
file, a scenario and a choice of bounds), an arm from a robot file naming a URDF, and a
plant file (physical parameters, an interval box or a polytope). :func:`open_system` builds
one of :data:`SYSTEM_KINDS` from the files a user named, and the :class:`LoadedSystem` it
returns answers every front end alike: its plant and uncertainty set, how a header names
it, the plants of the sampled-data certificate, its decay rate, loop margins and input
limits, what it can do (:class:`Capabilities`). No front end asks which kind it holds; the
command line (``cli/_system.py``) and the design page only choose the kind and the files.

Errors name the options as a user gives them (``--robot``, ``--model``): they are the
:class:`~scara_robust.OptionError` a front end prints.

The files are read when a front end first asks for them (:attr:`LoadedSystem.setup`,
:attr:`LoadedSystem.plant`, ...), in the order the commands have always read them, so
that an error names the same option and file as before.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar, Literal, TypeAlias, TypeVar

import numpy as np
import pandas as pd

from .._validation import check_choice, os_error_text
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentError, InputFileError, OptionError
from ..io import controller_sample_time, load_arm, load_model, load_robot, load_scenario
from ..lyapunov.gain import Design, design_or_none
from ..model.arm import ArmSetup
from ..model.feedforward import ArmFeedforward, arm_feedforward
from ..model.initial import SCENARIOS, Scenario
from ..model.plant import UncertainPlant, as_model, as_plant
from ..model.polytopic import PolytopicModel
from ..model.robot import PayloadProfile, ScaraParams
from ..model.scara import physical_samples, scara_uncertain_plant
from ..model.signals import Reference, SquareWave
from ..model.uncertain import UncertainLTVModel
from ..robustness.actuator import InputLimitCertificate, input_limit_certificate, step_initial_errors
from ..robustness.decay import DecayRate, design_decay_rate
from ..robustness.loop_margins import LoopMargins, worst_loop_margins
from ..robustness.parameters import parameter_margin
from ..robustness.payload import payload_margin
from ..robustness.sampled import check_sample_time, interior_grid, max_sample_time

__all__ = [
    "CERTIFICATE_GRID",
    "CERTIFICATE_CHECK_GRID",
    "Capabilities",
    "LoadedSystem",
    "ScaraSystem",
    "PlantFileSystem",
    "ArmSystem",
    "PhysicalSet",
    "Setup",
    "SYSTEM_KINDS",
    "load_input",
    "open_system",
]

#: Sampling of the robot's physical set for the certificate, and the finer one it is checked on.
CERTIFICATE_GRID, CERTIFICATE_CHECK_GRID = (37, 5), (73, 9)

#: A plant, or an uncertainty set given directly.
Plant: TypeAlias = "UncertainPlant | UncertainLTVModel | PolytopicModel"


@dataclass(frozen=True)
class Setup:
    """Robot and signals of one command, from ``--robot`` and ``--scenario``.

    Attributes
    ----------
    params : ScaraParams
    reference, payload, disturbance
        None where the paper's apply.
    initial : Scenario or None
        Initial condition (named, or from the scenario file).
    robot_file : bool
        True when a robot file was given: the bounds then default to those derived from it.
    """

    params: ScaraParams
    reference: Reference | None
    payload: PayloadProfile | None
    disturbance: SquareWave | None
    initial: Scenario | None
    robot_file: bool

    def signals(self) -> dict[str, Any]:
        """Keyword arguments for :func:`scara_robust.run_scenario` and :func:`scara_robust.compare_controllers`.

        Returns
        -------
        dict
        """
        return {"params": self.params, "reference": self.reference, "payload": self.payload,
                "disturbance": self.disturbance}


@dataclass(frozen=True)
class Capabilities:
    """What a system can do, for the commands whose work depends on it.

    Attributes
    ----------
    run : {'scara', 'arm', 'plant'}
        The nonlinear closed loop ``simulate`` and ``compare`` run: the SCARA's engine
        (:func:`scara_robust.run_scenario`), the arm's (:func:`scara_robust.simulate_arm`)
        or a plant file's (:func:`scara_robust.simulate_plant`).
    element_margins : bool
        ``margin`` scales the elements of the uncertainty set; False for an arm, whose
        box has too many corners: its margin is its payload range in kg.
    """

    run: Literal["scara", "arm", "plant"]
    element_margins: bool


@dataclass(frozen=True)
class PhysicalSet:
    """The samples ``synthesize --set physical`` certifies a gain on.

    Attributes
    ----------
    plants, check : (ndarray, ndarray)
        ``(A, B)`` stacks the LMI is solved on, and the finer ones it is verified on.
    nominal : UncertainLTVModel
        The design-form model (structure and nominal of the gain).
    description : str
        How the summary names the set.
    objective : str
        The default objective on it.
    """

    plants: tuple[Any, Any]
    check: tuple[Any, Any]
    nominal: UncertainLTVModel | PolytopicModel
    description: str
    objective: str


@dataclass(frozen=True)
class LoadedSystem:
    """The system of a command's arguments; subclasses hold the kind's behaviour.

    Attributes
    ----------
    command : str
        The command it was loaded for.
    robot : str or None
        ``--robot`` as given: the SCARA's data file, or the URDF robot file of an arm.
    model_file : str or None
        ``--model``.
    scenario : str or None
        ``--scenario``: a named initial condition or a scenario file.
    scenario_kind : {'run', 'signals'}
        What ``--scenario`` means for the command.
    bounds_option : str or None
        ``--bounds``.
    capabilities : Capabilities
        What the system can do (a class attribute of each kind).
    """

    command: str
    robot: str | None
    model_file: str | None
    scenario: str | None
    scenario_kind: str
    bounds_option: str | None

    capabilities: ClassVar[Capabilities]

    @property
    def file(self) -> str | None:
        """The file that names the plant, as exports record it (None for the paper's SCARA)."""
        raise NotImplementedError

    @property
    def bounds(self) -> str | None:
        """The SCARA's interval model (``'paper'`` or ``'derived'``); None for a file's own plant."""
        return None

    @cached_property
    def setup(self) -> Setup:
        """The SCARA's robot and signals from ``--robot`` and ``--scenario`` (the paper's without them).

        Raises
        ------
        OptionError
            Naming the option and the file.
        """
        return _load_setup(self._setup_robot(), self.scenario, self.scenario_kind)

    def _setup_robot(self) -> str | None:
        return self.robot

    @cached_property
    def plant(self) -> Plant:
        """The plant: physical parameters, or an uncertainty set a file gives directly.

        Reads :attr:`setup` first, as every command has.

        Raises
        ------
        OptionError
            For a file that cannot be read, or options that do not go with this plant.
        """
        self.setup  # noqa: B018 - its files are checked before the plant's
        return self._load_plant()

    def _load_plant(self) -> Plant:
        raise NotImplementedError

    @cached_property
    def model(self) -> UncertainLTVModel | PolytopicModel:
        """The uncertainty set of :attr:`plant`: its interval hull, or the file's set."""
        return as_model("model", self.plant)

    @property
    def interval_elements(self) -> bool:
        """True when :attr:`model` is an interval box (elements with ranges), as Theorem 1 and its map need.

        False for a polytope, whose box hull has corners outside it.
        """
        return "intervals" in self.model.capabilities

    @property
    def physical(self) -> UncertainPlant | None:
        """:attr:`plant` when it has physical parameters, else None (an interval box or polytope file)."""
        return as_plant("model", self.plant)

    def require_physical(self, message: str, plant: Any = None) -> UncertainPlant:
        """The plant with physical parameters, or `message` as the error.

        Parameters
        ----------
        message : str
            The error for a file that describes only the uncertainty set.
        plant : UncertainPlant, UncertainLTVModel or PolytopicModel, optional
            The plant to check (default :attr:`plant`), e.g. with ranges replaced.

        Returns
        -------
        UncertainPlant

        Raises
        ------
        OptionError
        """
        physical = as_plant("model", self.plant if plant is None else plant)
        if physical is None:
            raise OptionError(message)
        return physical

    def decay_rate(self, design: Design | Any, P: Any = None) -> DecayRate:
        """The design's decay rate on this system, as every command reports it (:func:`scara_robust.design_decay_rate`).

        Parameters
        ----------
        design : Design or array_like, shape (m, n)
        P : array_like, shape (n, n), optional
            A plain gain's Lyapunov matrix (a design file's).

        Returns
        -------
        DecayRate
        """
        return design_decay_rate(self.model, design, P=P, plant=self.physical)

    def initial_errors(self, given: list[float] | None) -> np.ndarray | None:
        """The box of initial errors the input limits are certified for: ``--initial-error``, or a unit step.

        Parameters
        ----------
        given : list of float or None
            Half-widths on the design state (n values), or None: for a PID plant, a unit
            step of each reference from rest (``e(0) = 1`` output unit, ``∫e = ė = 0``).

        Returns
        -------
        ndarray, shape (n,), or None
            None when the plant has no input limit, or is not in the PID form and no box
            was given.

        Raises
        ------
        OptionError
            For a box of the wrong size or with a negative half-width.
        """
        physical = self.physical
        if physical is None or physical.input_limits is None:
            if given is not None:
                raise OptionError("`--initial-error` bounds the initial errors for the input limits of a plant "
                                       "file (`limit` of its [[inputs]]); this plant has none")
            return None
        n = physical.n_design_states
        if given is None:
            return step_initial_errors(physical) if physical.form == "pid" else None
        if len(given) != n or min(given) < 0:
            raise OptionError(f"`--initial-error` must give {n} half-widths >= 0 (one per state of the design "
                                   f"form), found {len(given)} value(s) {given}")
        return np.asarray(given, dtype=float)

    def input_limit(self, design: Design | Any, decay: DecayRate,
                    box: np.ndarray | None) -> InputLimitCertificate | None:
        """The initial errors certified within the input limits, with the best of the decay rate's verified P's.

        Parameters
        ----------
        design : Design or array_like, shape (m, n)
        decay : DecayRate
            Its certified P's (:meth:`decay_rate`, :attr:`~scara_robust.DecayRate.candidates`) make the
            invariant ellipsoids; the one certifying the largest scale answers.
        box : ndarray, shape (n,), or None
            Half-widths of the initial errors (:meth:`initial_errors`).

        Returns
        -------
        InputLimitCertificate or None
            None without limits or without a box.
        """
        physical = self.physical
        if physical is None or physical.input_limits is None or box is None:
            return None
        found = design_or_none(design)
        K = found.K if found is not None else np.asarray(design, dtype=float)
        if decay.P is None:  # no certified Lyapunov function: no invariant ellipsoid either
            return None
        # every P verified on the set makes invariant ellipsoids: the one that certifies the largest scale answers
        certificates = [input_limit_certificate(K, P, physical.input_limits, box, inputs=physical.inputs,
                                                closed_loops=decay.loops) for P in decay.candidates or (decay.P,)]
        return max(certificates, key=lambda cert: cert.scale)

    def feedforward(self) -> ArmFeedforward | None:
        """The model feedforward the loop was certified with (an arm's, from its robot file), or None.

        Returns
        -------
        ArmFeedforward or None
            Checked against Pinocchio on random states (:meth:`ArmFeedforward.check`).
        """
        return None

    def effort_limits(self) -> np.ndarray | None:
        """Each input's effort limit when every one has one (an arm's URDF or robot file), N·m; else None.

        Returns
        -------
        ndarray, shape (m,), or None
        """
        return None

    def loop_margins(self, design: Design | Any) -> LoopMargins:
        """Each input's worst disk and delay margin over the frozen plants (:func:`scara_robust.worst_loop_margins`).

        A plant's frozen plants on its default grid (each parameter's ``samples``), a set's
        corners or vertices.

        Parameters
        ----------
        design : Design or array_like, shape (m, n)

        Returns
        -------
        LoopMargins
        """
        physical = self.physical
        if physical is None:
            return worst_loop_margins(self.model, design)
        return worst_loop_margins(physical, design, points=physical.grid_points())

    @property
    def state_feedback(self) -> bool:
        """True when the gain is a static state feedback u = −K x (a plant in the state or integral form)."""
        physical = self.physical
        return physical is not None and physical.form != "pid"

    def plant_prefix(self, default: str) -> str:
        """The C prefix of exported code: the plant's, or `default` for a set given directly.

        Parameters
        ----------
        default : str

        Returns
        -------
        str
        """
        physical = self.physical
        return physical.prefix if physical is not None else default

    def signal_names(self) -> dict[str, Any]:
        """The plant's ``outputs`` and ``inputs`` (their names and units) for an export; empty for a set.

        Returns
        -------
        dict
        """
        physical = self.physical
        return {} if physical is None else {"outputs": physical.outputs, "inputs": physical.inputs}

    def joint_names(self) -> tuple[str, ...] | None:
        """The joints of the gain's rows: the plant's outputs (an arm's are ``q_<URDF joint>``); None for a set.

        Returns
        -------
        tuple of str or None
        """
        physical = self.physical
        return None if physical is None else tuple(signal.name for signal in physical.outputs)

    def source(self, model: UncertainLTVModel | PolytopicModel, sep: str = ": ") -> str:
        """How a header names the system: ``model: NAME`` or ``bounds: paper``.

        Parameters
        ----------
        model : UncertainLTVModel or PolytopicModel
            The set analysed (its name, after any ``--range``).
        sep : str
            Between the word and the name.

        Returns
        -------
        str
        """
        return f"model{sep}{model.name}"

    def title(self) -> str:
        """The design page's title: the plant's name, or which SCARA."""
        return self.model.name

    def options(self, *names: str) -> list[tuple[str, str]]:
        """The options among `names` (``'robot'``, ``'model'``, ``'bounds'``, ``'scenario'``) that were given.

        Parameters
        ----------
        *names : str

        Returns
        -------
        list of (str, str)
            ``(--option, value)``, in the order of `names`.
        """
        given = {"robot": self.robot, "model": self.model_file, "bounds": self.bounds_option,
                 "scenario": self.scenario}
        return [(f"--{name}", str(given[name])) for name in names if given[name] is not None]

    def robot_params(self, default: ScaraParams) -> ScaraParams:
        """The SCARA's parameters of ``--robot``, or `default` without a robot file.

        Parameters
        ----------
        default : ScaraParams

        Returns
        -------
        ScaraParams
        """
        return self.setup.params if self._setup_robot() is not None else default

    def robot_signals(self) -> dict[str, Any] | None:
        """The SCARA's robot and signals (:meth:`Setup.signals`); None for a plant of a file."""
        return None

    @property
    def controller_ts(self) -> float | None:
        """The sample time the system's file gives its controller (``[controller] sample_time``, s), or None."""
        path = self.file
        if path is None:
            return None
        return load_input("--model" if self.model_file is not None else "--robot", path, controller_sample_time)

    def sampled_headline(self, design: Design | Any) -> tuple[str, dict[str, Any]]:
        """What a design's certificate leads with: the sampled-data certificate of the controller as it will run.

        With ``[controller] sample_time`` in the system's file: the certificate at that Ts (a PID
        discretized as ``export`` does, Tustin integral and measured derivative; a state-form
        gain held), and where it fails the largest certified Ts. Without it: the largest Ts
        the sampled-data certificate holds at, so that a continuous-time "certified" is never
        read alone.

        Parameters
        ----------
        design : Design or array_like
            A Design, or a state-form gain K.

        Returns
        -------
        text : str
            One line.
        record : dict
            Its JSON record (``method`` ``sampled-at-ts`` or ``max-ts``).
        """
        plants, check, set_name = self.sampled()
        found = design_or_none(design)
        Ts = self.controller_ts
        if Ts is not None:
            K = found.K if found is not None else np.asarray(design, dtype=float)
            controller = SampledStateFeedback(K, Ts) if self.state_feedback or found is None else found.discretize(Ts)
            result = check_sample_time(plants, controller, check=check, set_name=set_name)
            word = "certified" if result.certified else "NOT certified"
            text = f"{word} at Ts = {Ts:g} s, the controller's sample time in {self.file!r}: {result.message}"
            return text, {"method": "sampled-at-ts", **result.record()}
        try:
            limit = max_sample_time(plants, found.K if self.state_feedback and found is not None else design,
                                    check=check, rtol=1e-3)
        except (ArgumentError, ValueError) as err:  # a model with no sampled-data controller (neither form)
            text = f"continuous-time certificates below; no sampled-data certificate for this model: {err}"
            return text, {"method": "max-ts", "verdict": "not computed", "certified": None, "detail": str(err)}
        text = (f"continuous-time certificates below; sampled as export discretizes the controller: {limit.message} "
                "([controller] sample_time in the file certifies at the controller's own)")
        return text, {"method": "max-ts", "verdict": limit.verdict, "certified": limit.certified,
                      "certified_ts [s]": limit.certified_ts if math.isfinite(limit.certified_ts) else None,
                      "unstable_ts [s]": limit.unstable_ts if math.isfinite(limit.unstable_ts) else None,
                      "detail": limit.message}

    def sampled(self) -> tuple[Any, Any, str]:
        """The plants the sampled-data certificate runs on, a second set to verify on, and their name.

        Returns
        -------
        plants, check : set or tuple (A, B)
        name : str
        """
        raise NotImplementedError

    def with_ranges(self, ranges: list[str] | None) -> Plant:
        """:attr:`plant` with the ranges of ``--range NAME=LO:HI`` (a plant file with parameters only).

        Parameters
        ----------
        ranges : list of str or None

        Returns
        -------
        UncertainPlant, UncertainLTVModel or PolytopicModel
            The plant, its ranges replaced.

        Raises
        ------
        OptionError
            For the SCARA, a set without parameters, or a bad range.
        """
        plant = self.plant
        if not ranges:
            return plant
        physical = self._rangeable()
        if physical is None:
            raise OptionError("`--range` changes a parameter of a plant file with [parameters] (--model)")
        parsed: dict[str, tuple[float, float]] = {}
        for text in ranges:
            name, _, bounds = text.partition("=")
            lo_text, _, hi_text = bounds.partition(":")
            try:
                lo, hi = float(lo_text), float(hi_text)
            except ValueError:
                raise OptionError(f"`--range` must be NAME=LO:HI, found {text!r}") from None
            if name not in physical.names:
                raise OptionError(f"`--range` names {name!r}, which is not a parameter of {self.file!r} "
                                       f"({', '.join(physical.names)})")
            if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
                raise OptionError(f"`--range` {name} must have finite LO <= HI, found {lo:g}:{hi:g}")
            parsed[name] = (lo, hi)
        try:
            return physical.with_ranges(parsed)
        except ArgumentError as err:
            raise OptionError(f"`--range` {err}") from err

    def _rangeable(self) -> UncertainPlant | None:
        return self.physical

    def payload_margin(self, design: Design, tol: float) -> pd.DataFrame | None:
        """The SCARA's payload margin (kg) over its own sampled set; None for a plant of a file.

        Parameters
        ----------
        design : Design
        tol : float

        Returns
        -------
        pandas.DataFrame or None
        """
        return None

    def unit_margin(self, plant: Any, design: Design, tol: float) -> pd.DataFrame | None:
        """The margin in the plant's own units (a plant file with parameters), else None.

        Parameters
        ----------
        plant : UncertainPlant, UncertainLTVModel or PolytopicModel
            The plant analysed (after any ``--range``).
        design : Design
        tol : float

        Returns
        -------
        pandas.DataFrame or None
        """
        return None

    def synthesis_set(self, chosen: str | None) -> str:
        """The set ``synthesize`` certifies: ``--set`` checked against this system, or its default.

        Reads the files of :attr:`setup` first.

        Parameters
        ----------
        chosen : {'physical', 'box'} or None

        Returns
        -------
        {'physical', 'box'}

        Raises
        ------
        OptionError
            For a set this system does not have, or ``--bounds`` without the box.
        """
        raise NotImplementedError

    def physical_set(self, grid: tuple[int, int], check_grid: tuple[int, int]) -> PhysicalSet:
        """The samples of ``synthesize --set physical``.

        Parameters
        ----------
        grid, check_grid : (int, int)
            The SCARA's (times, payloads) of the LMI and of the check (an arm uses its file's).

        Returns
        -------
        PhysicalSet
        """
        raise NotImplementedError

    def arm(self) -> ArmSetup:
        """The arm of a URDF robot file (its runs need the whole setup, not only the plant).

        Returns
        -------
        ArmSetup

        Raises
        ------
        OptionError
            For a system that is no arm (never reached: commands ask only where
            :attr:`Capabilities.run` is ``'arm'``).
        """
        raise OptionError("this command's robot is not a URDF arm")


@dataclass(frozen=True)
class ScaraSystem(LoadedSystem):
    """The built-in SCARA: the paper's robot or a ``--robot`` data file, with ``--scenario`` and ``--bounds``."""

    capabilities: ClassVar[Capabilities] = Capabilities(run="scara", element_margins=True)

    @property
    def file(self) -> str | None:
        """The robot file (None for the paper's robot)."""
        return self.robot

    @property
    def bounds(self) -> str:
        """``--bounds``, or its default: ``'derived'`` with a robot file, else ``'paper'``.

        A scenario file never changes the default: the bounds belong to the robot.
        """
        return self.bounds_option or ("derived" if self.robot is not None else "paper")

    def _load_plant(self) -> Plant:
        if self.bounds == "paper":
            if self.setup.robot_file:
                raise OptionError("`--bounds paper` holds only for the paper's robot (Tables 1-2); with --robot "
                                       "use --bounds derived")
            return scara_uncertain_plant(bounds="paper")
        setup = self.setup
        return scara_uncertain_plant(setup.params, setup.reference, setup.payload, bounds="derived")

    def source(self, model: UncertainLTVModel | PolytopicModel, sep: str = ": ") -> str:
        """``bounds: paper`` or ``bounds: derived`` (see :meth:`LoadedSystem.source`)."""
        return f"bounds{sep}{self.bounds}"

    def title(self) -> str:
        """``SCARA of 'FILE'`` or ``the paper's SCARA``."""
        return f"SCARA of {self.robot!r}" if self.robot is not None else "the paper's SCARA"

    def robot_signals(self) -> dict[str, Any] | None:
        """:meth:`Setup.signals` of :attr:`setup`."""
        return self.setup.signals()

    def _rangeable(self) -> UncertainPlant | None:
        return None

    def sampled(self) -> tuple[Any, Any, str]:
        """The robot's error dynamics along the reference, payload over its range (see :meth:`LoadedSystem.sampled`)."""
        physical = self.physical
        assert physical is not None
        coarse = physical.samples({"t_ref": CERTIFICATE_GRID[0], "m_p": CERTIFICATE_GRID[1]})
        fine = physical.samples({"t_ref": CERTIFICATE_CHECK_GRID[0], "m_p": CERTIFICATE_CHECK_GRID[1]})
        robot = f"the robot of {self.robot!r}" if self.robot is not None else "the paper's robot"
        return (coarse.A, coarse.B), (fine.A, fine.B), (
            f"{robot}: its error dynamics linearized along the reference at e = 0, payload over its range "
            f"({CERTIFICATE_GRID[0]} x {CERTIFICATE_GRID[1]} samples, verified on "
            f"{CERTIFICATE_CHECK_GRID[0]} x {CERTIFICATE_CHECK_GRID[1]})")

    def payload_margin(self, design: Design, tol: float) -> pd.DataFrame | None:
        """:func:`scara_robust.payload_margin` on the robot and reference of :attr:`setup`."""
        return payload_margin(design, self.setup.params, self.setup.reference, tol=tol)

    def synthesis_set(self, chosen: str | None) -> str:
        """``--set``, or ``'box'`` with ``--bounds`` and ``'physical'`` without (:meth:`LoadedSystem.synthesis_set`)."""
        self.setup  # noqa: B018 - its files are checked first
        if chosen == "physical" and self.bounds_option is not None:
            raise OptionError("`--bounds` chooses an interval model; it goes with --set box")
        return chosen or ("box" if self.bounds_option is not None else "physical")

    def physical_set(self, grid: tuple[int, int], check_grid: tuple[int, int]) -> PhysicalSet:
        """The robot's linearizations along the reference for every payload (see :meth:`LoadedSystem.physical_set`)."""
        nominal = self.model
        setup = self.setup
        samples = physical_samples(setup.params, setup.reference, setup.payload,
                                   times=np.linspace(0, 2 * np.pi, grid[0]), n_masses=grid[1])
        check = physical_samples(setup.params, setup.reference, setup.payload,
                                 times=np.linspace(0, 2 * np.pi, check_grid[0]), n_masses=check_grid[1])
        return PhysicalSet((samples.A, samples.B), (check.A, check.B), nominal,
                           f"the robot's physical set, {grid[0]} times x {grid[1]} payloads (checked on "
                           f"{check_grid[0]} x {check_grid[1]})", "l2")


@dataclass(frozen=True)
class PlantFileSystem(LoadedSystem):
    """A plant file of ``--model``: physical parameters, an interval box or a polytope."""

    capabilities: ClassVar[Capabilities] = Capabilities(run="plant", element_margins=True)

    @property
    def file(self) -> str | None:
        """The plant file."""
        return self.model_file

    def _load_plant(self) -> Plant:
        robot_options = [option for option, _ in self.options("robot", "bounds", "scenario")]
        if robot_options:
            raise OptionError(
                f"`--model` is your own plant; {', '.join(robot_options)} describe the SCARA and cannot go with it"
            )
        assert self.model_file is not None
        return load_input("--model", self.model_file, load_model)

    def sampled(self) -> tuple[Any, Any, str]:
        """A plant's parameter grid, a box's corners or a polytope's vertices (see :meth:`LoadedSystem.sampled`)."""
        physical, model = self.physical, self.model
        model_any: Any = model  # a box or a polytope, told apart by its capabilities
        if physical is not None:
            on, fine = physical.samples(), physical.samples(physical.fine_points())
            return (on.A, on.B), (fine.A, fine.B), (
                f"the plant of {self.model_file!r} on its parameter grid ({on.n_samples} frozen plants, verified on "
                f"{fine.n_samples})")
        if "intervals" in model.capabilities:
            grid = interior_grid(model_any)
            return model, grid, (f"the {2 ** model_any.n_elements} corners of the box of {self.model_file!r} "
                                 f"(verified on a {len(grid[0])}-plant grid of the box)")
        return model, None, f"the {model_any.n_vertices} vertices of the polytope of {self.model_file!r}"

    def unit_margin(self, plant: Any, design: Design, tol: float) -> pd.DataFrame | None:
        """:func:`scara_robust.parameter_margin` of a plant with parameters (see :meth:`LoadedSystem.unit_margin`)."""
        physical = as_plant("model", plant)
        return None if physical is None else parameter_margin(physical, design, tol=tol)

    def synthesis_set(self, chosen: str | None) -> str:
        """``--set box`` only (see :meth:`LoadedSystem.synthesis_set`)."""
        self.setup  # noqa: B018 - its files are checked first
        if chosen == "physical":
            raise OptionError("`--set physical` is the SCARA's own variation; with --model use --set box")
        return "box"


@dataclass(frozen=True)
class ArmSystem(LoadedSystem):
    """An arm of a robot file naming a URDF (``--robot F``), through its linearized error dynamics."""

    capabilities: ClassVar[Capabilities] = Capabilities(run="arm", element_margins=False)

    @property
    def file(self) -> str | None:
        """The robot file naming the URDF."""
        return self.robot

    def _setup_robot(self) -> str | None:
        return None  # the robot file is the arm's, not the SCARA's data

    def _load_plant(self) -> Plant:
        assert self.robot is not None
        return load_input("--robot", self.robot, load_model)

    def sampled(self) -> tuple[Any, Any, str]:
        """The arm's own grids: the LMI's coarse one, verified on the file's (see :meth:`LoadedSystem.sampled`)."""
        physical = self.physical
        assert physical is not None
        on, fine = physical.samples(physical.coarse_points()), physical.samples()
        return (on.A, on.B), (fine.A, fine.B), (
            f"the arm of {self.robot!r}: its error dynamics linearized along the reference at e = 0, payload over its "
            f"range ({on.n_samples} samples, verified on {fine.n_samples})")

    def synthesis_set(self, chosen: str | None) -> str:
        """``--set box``, else the arm's own samples (its box has too many corners for an LMI over them)."""
        self.setup  # noqa: B018 - its files are checked first
        return "box" if chosen == "box" else "physical"

    def physical_set(self, grid: tuple[int, int], check_grid: tuple[int, int]) -> PhysicalSet:
        """The arm's samples on its file's grids (see :meth:`LoadedSystem.physical_set`)."""
        plant = self.physical
        assert plant is not None
        on, check_on = plant.samples(plant.coarse_points()), plant.samples()
        return PhysicalSet((on.A, on.B), (check_on.A, check_on.B), as_model("model", plant),
                           f"the arm of {self.robot!r} on its samples, {on.n_samples} (checked on "
                           f"{check_on.n_samples})", "decay")

    def feedforward(self) -> ArmFeedforward | None:
        """The arm's feedforward at its nominal payload (None without one), checked against Pinocchio."""
        setup = self.arm()
        ff = arm_feedforward(setup)
        if ff is not None:
            ff.check(setup.arm)
        return ff

    def effort_limits(self) -> np.ndarray | None:
        """The arm's effort limits (its URDF's or robot file's), N·m, when every joint has one."""
        limits = self.arm().torque_limit
        return limits if limits is not None and np.all(np.isfinite(limits)) else None

    def arm(self) -> ArmSetup:
        """The arm, its payload range, reference and feedforward (:func:`scara_robust.load_arm`)."""
        assert self.robot is not None
        return load_input("--robot", self.robot, load_arm)


def _load_setup(robot: str | None, scenario: str | None, scenario_kind: str) -> Setup:
    """Load the files named by ``--robot`` and ``--scenario``."""
    params = ScaraParams()
    if robot is not None:
        params = load_input("--robot", robot, load_robot)
    reference = payload = disturbance = None
    initial: Scenario | None = None
    if scenario is not None and scenario in SCENARIOS:
        if scenario_kind != "run":
            raise OptionError(
                f"`--scenario` takes a scenario file here (its reference and payload); an initial condition "
                f"such as {scenario!r} means nothing for this command"
            )
        initial = SCENARIOS[scenario]
    elif scenario is not None:
        if not scenario.lower().endswith((".toml", ".json")):
            named = ", ".join(repr(n) for n in SCENARIOS)
            raise OptionError(f"`--scenario` must be {named} or a .toml/.json scenario file, found {scenario!r}")
        scen = load_input("--scenario", scenario, load_scenario)
        reference, payload, disturbance, initial = scen.reference, scen.payload, scen.disturbance, scen.initial
    return Setup(params, reference, payload, disturbance, initial, robot is not None)


_Loaded = TypeVar("_Loaded")


def load_input(option: str, path: str, load: Callable[[str], _Loaded]) -> _Loaded:
    r"""``load(path)``, with the option that named the file in any error.

    Parameters
    ----------
    option : str
        The option as the user gave it (``'--robot'``).
    path : str
    load : callable
        ``load(path)``: one of the package's file readers.

    Returns
    -------
    object
        What `load` returns.

    Raises
    ------
    OptionError
        ``\`--robot\` 'F.toml': No such file or directory``, or the reader's message.
    """
    try:
        return load(path)
    except OSError as err:
        raise OptionError(f"`{option}` {path!r}: {os_error_text(err)}") from err
    except InputFileError as err:
        raise OptionError(f"`{option}` {err}") from err


#: The kinds of system, by name: the built-in SCARA, a plant file, an arm of a URDF robot file.
SYSTEM_KINDS: dict[str, type[LoadedSystem]] = {"scara": ScaraSystem, "plant": PlantFileSystem, "arm": ArmSystem}


def open_system(kind: str, *, command: str, robot: str | None = None, model_file: str | None = None,
                scenario: str | None = None, scenario_kind: str = "run",
                bounds_option: str | None = None) -> LoadedSystem:
    """The system of kind `kind` over the files a user named; the files are read when first asked for.

    Parameters
    ----------
    kind : {'scara', 'plant', 'arm'}
        A name of :data:`SYSTEM_KINDS`.
    command : str
        What the system is opened for (a command's name): some answers depend on it.
    robot : str, optional
        The SCARA's robot data file, or the robot file naming an arm's URDF.
    model_file : str, optional
        A plant file.
    scenario : str, optional
        A named initial condition or a scenario file.
    scenario_kind : {'run', 'signals'}
        What `scenario` means for the command.
    bounds_option : {'paper', 'derived'}, optional
        The SCARA's interval model.

    Returns
    -------
    LoadedSystem
    """
    check_choice("kind", kind, tuple(SYSTEM_KINDS))
    return SYSTEM_KINDS[kind](command=command, robot=robot, model_file=model_file, scenario=scenario,
                              scenario_kind=scenario_kind, bounds_option=bounds_option)
