"""What every command shares: options for robot and scenario files, parsing, output, errors.

The table :data:`OPTION_NAMES` is the one place where a library parameter's name is
mapped to the option a user typed; :func:`error_message` uses it to render a library
:class:`~scara_robust.exceptions.ArgumentError` in the user's terms.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NoReturn, TypeVar

import numpy as np

from ..exceptions import ArgumentError, InputFileError
from ..io import DesignFile, is_arm_file, load_design, load_model, load_robot, load_scenario, write_atomic
from ..lyapunov.gain import Design, design
from ..model.initial import SCENARIOS, Scenario
from ..model.plant import UncertainPlant, as_model, as_plant
from ..model.polytopic import PolytopicModel
from ..model.robot import PayloadProfile, ScaraParams
from ..model.scara import SCARA_BOUNDS, scara_uncertain_plant
from ..model.signals import Reference, SquareWave
from ..model.uncertain import UncertainLTVModel
from ..robustness.sampled import interior_grid

__all__ = [
    "BOUNDS",
    "OPTION_NAMES",
    "CommandLineError",
    "Parser",
    "Setup",
    "add_setup_options",
    "emit",
    "error_message",
    "check_outputs",
    "write_text",
    "OUTPUT_OPTIONS",
    "finite_float",
    "per_joint_values",
    "parse_range",
    "resolve_bounds",
    "resolve_model",
    "route_arm_file",
    "resolve_plant",
    "sampled_plants",
    "add_range_option",
    "with_ranges",
    "resolve_setup",
    "RANGE_HELP",
    "save_figure",
    "FIGURE_FORMATS",
    "output_exists",
    "add_design_option",
    "resolve_design",
    "resolve_gain",
    "check_gain_options",
]

_Loaded = TypeVar("_Loaded")

#: Interval models selectable with ``--bounds``.
BOUNDS = SCARA_BOUNDS

#: Library parameter -> the option (or positional) that sets it on the command line.
OPTION_NAMES: dict[str, str] = {
    "rho": "--rho",
    "eta": "--eta",
    "rhos": "--rho",
    "etas": "--eta",
    "elements": "--elements",
    "t_final": "--t-final",
    "torque_limit": "--torque-limit",
    "runs": "--runs",
    "seed": "--seed",
    "workers": "--workers",
    "chunk_size": "--chunk-size",
    "engine": "--engine",
    "scheduler": "--scheduler",
    "address": "--address",
    "output": "--output",
    "resume": "--resume",
    "path": "RESULTS",
    "falsifier_tries": "--tries",
    "tol": "--tol",
    "Ts": "--ts",
    "N": "--filter-n",
    "tracking_time": "--tracking-time",
    "integrator": "--integrator",
    "derivative": "--derivative",
    "prefix": "--prefix",
    "index": "--index",
    "checkpoint": "--checkpoint",
    "controller": "--controller",
    "method": "--method",
}


class CommandLineError(Exception):
    """Bad command-line input; reported as one line on stderr with exit code 2."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are :class:`CommandLineError` (one line, exit 2)."""

    def error(self, message: str) -> NoReturn:
        """Raise :class:`CommandLineError` with the program name and `message`.

        Parameters
        ----------
        message : str
        """
        command = self.prog.removeprefix("scara_robust").strip()  # main() adds "scara_robust: error:"
        raise CommandLineError(f"{command}: {message}" if command else message)


def error_message(err: BaseException) -> str:
    """One line for `err`, naming options rather than library parameters.

    Parameters
    ----------
    err : BaseException

    Returns
    -------
    str
    """
    if isinstance(err, ArgumentError) and err.argument in OPTION_NAMES:
        text = f"`{OPTION_NAMES[err.argument]}` {err.problem}"
    else:
        text = str(err)
    return " ".join(text.split())


#: How a range option is written, for ``--help``.
RANGE_HELP = "START:STOP:NUM, NUM evenly spaced values from START to STOP inclusive (NUM >= 2, or 1 with START = STOP)"


def parse_range(text: str) -> np.ndarray:
    """Parse ``START:STOP:NUM`` into ``numpy.linspace(START, STOP, NUM)``.

    Parameters
    ----------
    text : str

    Returns
    -------
    ndarray, shape (NUM,)

    Raises
    ------
    argparse.ArgumentTypeError
        If the text is not three fields, a bound is not a finite number or NUM is not
        an integer >= 1.
    """
    parts = text.split(":")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM, found {text!r}")
    try:
        start, stop = float(parts[0]), float(parts[1])
        num = int(parts[2])
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM with numbers, found {text!r}") from err
    if not (np.isfinite(start) and np.isfinite(stop)):
        raise argparse.ArgumentTypeError(f"START and STOP must be finite, found {text!r}")
    if num < 1:
        raise argparse.ArgumentTypeError(f"NUM must be >= 1, found {num}")
    if num == 1 and start != stop:
        raise argparse.ArgumentTypeError(
            f"NUM = 1 would keep START alone and drop STOP in {text!r}; write {parts[0]}:{parts[0]}:1 for one "
            "value, or NUM >= 2"
        )
    return np.linspace(start, stop, num)


def finite_float(text: str) -> float:
    """An option's text as a finite float.

    Parameters
    ----------
    text : str

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        If it is not a number, or not finite.
    """
    try:
        value = float(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from err
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, found {text!r}")
    return value


def per_joint_values(text: str) -> list[float]:
    """An option's ``V[,V2,...]`` text: one value for all joints, or one per joint.

    The type of every per-joint option (``--torque-limit``, ``--tracking-time``), so that
    all commands read them alike. The count and the sign are checked where they are known
    (the library names the number of torques and the unit).

    Parameters
    ----------
    text : str

    Returns
    -------
    list of float
        One or more finite numbers.

    Raises
    ------
    argparse.ArgumentTypeError
        If a field is not a finite number.
    """
    return [finite_float(v) for v in text.split(",")]


def _write(option: str, path: str, write: Callable[[str], None]) -> None:
    try:
        write_atomic(path, write)
    except OSError as err:
        raise CommandLineError(f"`{option}` {path!r}: {err.strerror or err}") from err


def write_text(option: str, path: str, text: str) -> None:
    """Write `text` atomically to `path`, naming `option` in any error.

    Parameters
    ----------
    option : str
    path : str
    text : str
    """
    text = text if text.endswith("\n") else text + "\n"

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    _write(option, path, write)


def emit(text: str, output: str | None) -> None:
    """Print `text` (nothing if empty), or write it atomically to `output` (the ``--output`` file).

    Parameters
    ----------
    text : str
    output : str or None
    """
    if output is not None:
        write_text("--output", output, text)
    elif text:
        sys.stdout.write(text if text.endswith("\n") else text + "\n")


#: Figure formats of ``--plot``, chosen by the file's extension.
FIGURE_FORMATS = ("png", "pdf", "svg")


def _figure_format(option: str, path: str) -> str:
    """The format of a figure file from its extension, or :class:`CommandLineError` naming `option`."""
    extension = os.path.splitext(path)[1].lower().removeprefix(".")
    if extension not in FIGURE_FORMATS:
        allowed = ", ".join(f".{f}" for f in FIGURE_FORMATS[:-1]) + f" or .{FIGURE_FORMATS[-1]}"
        raise CommandLineError(f"`{option}` {path!r}: the format follows the extension; use {allowed}")
    return extension


#: Attributes of a command's arguments that name files it writes, and their options.
OUTPUT_OPTIONS = {"output": "--output", "series_output": "--output", "results_output": "--output", "plot": "--plot"}


def check_outputs(args: argparse.Namespace) -> None:
    """Refuse, before any computation, output paths that cannot be written.

    Parameters
    ----------
    args : argparse.Namespace

    Raises
    ------
    CommandLineError
        Naming the option and the path the user gave: a folder, or a file in a folder
        that does not exist or is not writable; a figure (``plot``) whose extension is
        not one of :data:`FIGURE_FORMATS`.
    """
    for attr, option in OUTPUT_OPTIONS.items():
        path = getattr(args, attr, None)
        if path is None:
            continue
        if attr == "plot":
            _figure_format(option, path)
        folder = os.path.dirname(os.path.abspath(path))
        if os.path.isdir(path):
            raise CommandLineError(f"`{option}` {path!r}: is a directory")
        if not os.path.isdir(folder):
            raise CommandLineError(
                f"`{option}` {path!r}: No such file or directory: the folder {folder!r} does not exist"
            )
        if not os.access(folder, os.W_OK):
            raise CommandLineError(f"`{option}` {path!r}: the folder {folder!r} is not writable")


def save_figure(option: str, path: str, fig: Any) -> None:
    """Save a matplotlib figure atomically, in the format of its extension, and close it.

    Parameters
    ----------
    option : str
        The option that named the file, for errors.
    path : str
        ``.png``, ``.pdf`` or ``.svg`` (:data:`FIGURE_FORMATS`).
    fig : matplotlib.figure.Figure

    Raises
    ------
    CommandLineError
        If the extension is not one of :data:`FIGURE_FORMATS` (the figure is closed
        unwritten), or the file cannot be written.
    """
    import matplotlib.pyplot as plt

    try:
        fmt = _figure_format(option, path)
        _write(option, path, lambda tmp: fig.savefig(tmp, dpi=120, format=fmt))
    finally:
        plt.close(fig)


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


def add_setup_options(
    p: argparse.ArgumentParser, *, bounds: bool = True, scenario: str | None = "run", model: bool = False
) -> None:
    """Add ``--robot FILE``, ``--scenario`` and ``--bounds`` to a sub-command.

    Parameters
    ----------
    p : argparse.ArgumentParser
    bounds : bool
        Add ``--bounds``.
    scenario : {'run', 'signals'} or None
        ``'run'``: ``--scenario NAME|FILE`` (initial condition and signals of a run);
        ``'signals'``: ``--scenario FILE`` (the reference and payload of the robot's
        physical set; a named initial condition means nothing there); None: no option.
    model : bool
        Add ``--model FILE`` (your own plant; excludes the robot's options).
    """
    p.add_argument("--robot", metavar="FILE", help="robot file (.toml/.json, see examples/robot-paper.toml)")
    if scenario == "run":
        p.add_argument(
            "--scenario",
            metavar="NAME|FILE",
            help="initial condition 'large' or 'small', or a scenario file (payload, reference, disturbance, "
            "initial error; see examples/scenario-paper.toml)",
        )
    elif scenario == "signals":
        p.set_defaults(scenario_kind="signals")
        p.add_argument(
            "--scenario",
            metavar="FILE",
            help="scenario file whose reference and payload define the robot's physical set "
            "(see examples/scenario-paper.toml)",
        )
    if model:
        p.add_argument(
            "--model",
            metavar="FILE",
            help="your own plant instead of the SCARA: physical parameters, an interval model or a polytope "
            "(.toml/.json, see examples/plant-dc-motor.toml, examples/plant-polytope.toml)",
        )
    if bounds:
        p.add_argument(
            "--bounds",
            choices=sorted(BOUNDS),
            default=None,
            help="interval model of the PID design: published Tables 1-2 ('paper', the default without --robot) "
            "or derived from the robot ('derived', the default with --robot)",
        )


def _load_file(option: str, path: str, load: Callable[[str], _Loaded]) -> _Loaded:
    """``load(path)``, with the option named in any error."""
    try:
        return load(path)
    except OSError as err:
        raise CommandLineError(f"`{option}` {path!r}: {err.strerror or err}") from err
    except InputFileError as err:
        raise CommandLineError(f"`{option}` {err}") from err


#: Commands that run on a robot file naming a URDF (through its linearized error dynamics).
ARM_COMMANDS = ("design", "certify", "margin", "synthesize", "simulate", "compare", "export", "surface")


def route_arm_file(args: argparse.Namespace) -> None:
    """Send ``--robot F`` to the plant path when F names a URDF (an arm, not the SCARA's data).

    Sets ``args.arm_file`` (the file, or None) and, for an arm, ``args.model`` to it.

    Raises
    ------
    CommandLineError
        If the command does not take an arm, or an option of the built-in SCARA goes with one.
    """
    robot = getattr(args, "robot", None)
    args.arm_file = None
    if robot is None or not is_arm_file(robot):
        return
    if args.command not in ARM_COMMANDS:
        raise CommandLineError(f"`--robot` {robot!r} names a URDF; `{args.command}` runs on the built-in SCARA only "
                               f"(a URDF robot goes with {', '.join(ARM_COMMANDS)})")
    if getattr(args, "model", None) is not None:
        raise CommandLineError("`--robot` and `--model` each name the plant; give one")
    for option in ("bounds", "scenario"):
        if getattr(args, option, None) is not None:
            raise CommandLineError(f"`--{option}` describes the built-in SCARA; a URDF robot's reference, payload "
                                   f"and linearization are in its file {robot!r}")
    args.arm_file, args.model, args.robot = robot, robot, None


def resolve_setup(args: argparse.Namespace) -> Setup:
    """Load the files named by ``--robot`` and ``--scenario``.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    Setup

    Raises
    ------
    CommandLineError
        Naming the option and the file.
    """
    params = ScaraParams()
    robot = getattr(args, "robot", None)
    if robot is not None:
        params = _load_file("--robot", robot, load_robot)
    scenario = getattr(args, "scenario", None)
    reference = payload = disturbance = None
    initial: Scenario | None = None
    if scenario is not None and scenario in SCENARIOS:
        if getattr(args, "scenario_kind", "run") != "run":
            raise CommandLineError(
                f"`--scenario` takes a scenario file here (its reference and payload); an initial condition "
                f"such as {scenario!r} means nothing for this command"
            )
        initial = SCENARIOS[scenario]
    elif scenario is not None:
        if not scenario.lower().endswith((".toml", ".json")):
            named = ", ".join(repr(n) for n in SCENARIOS)
            raise CommandLineError(f"`--scenario` must be {named} or a .toml/.json scenario file, found {scenario!r}")
        scen = _load_file("--scenario", scenario, load_scenario)
        reference, payload, disturbance, initial = scen.reference, scen.payload, scen.disturbance, scen.initial
    return Setup(params, reference, payload, disturbance, initial, robot is not None)


def resolve_bounds(args: argparse.Namespace, setup: Setup) -> str:
    """``--bounds``, or its default: ``'derived'`` with a robot file, else ``'paper'``.

    A scenario file never changes the default: the bounds belong to the robot.

    Parameters
    ----------
    args : argparse.Namespace
    setup : Setup

    Returns
    -------
    {'paper', 'derived'}
    """
    return getattr(args, "bounds", None) or ("derived" if setup.robot_file else "paper")


def resolve_model(args: argparse.Namespace, setup: Setup) -> UncertainLTVModel | PolytopicModel:
    """The uncertainty set of :func:`resolve_plant`: a plant's interval hull, or the file's set."""
    return as_model("model", resolve_plant(args, setup))


def resolve_plant(args: argparse.Namespace, setup: Setup) -> UncertainPlant | UncertainLTVModel | PolytopicModel:
    """The plant of ``--model``, or the SCARA as a plant with the interval view of ``--bounds``.

    Parameters
    ----------
    args : argparse.Namespace
    setup : Setup

    Returns
    -------
    UncertainPlant, UncertainLTVModel or PolytopicModel
        A file with physical parameters, or the SCARA, gives a plant; a file of elements
        or vertices gives the set itself.

    Raises
    ------
    CommandLineError
        If published bounds are asked for with a robot file, or ``--model`` with an
        option of the robot.
    """
    model_file = getattr(args, "model", None)
    if model_file is not None:
        robot_options = [f"--{o}" for o in ("robot", "bounds", "scenario") if getattr(args, o, None) is not None]
        if robot_options:
            raise CommandLineError(
                f"`--model` is your own plant; {', '.join(robot_options)} describe the SCARA and cannot go with it"
            )
        return _load_file("--robot" if getattr(args, "arm_file", None) else "--model", model_file, load_model)
    if resolve_bounds(args, setup) == "paper":
        if setup.robot_file:
            raise CommandLineError(
                "`--bounds paper` holds only for the paper's robot (Tables 1-2); with --robot use --bounds derived"
            )
        return scara_uncertain_plant(bounds="paper")
    return scara_uncertain_plant(setup.params, setup.reference, setup.payload, bounds="derived")


#: Sampling of the robot's physical set for the certificate, and the finer one it is checked on.
CERTIFICATE_GRID, CERTIFICATE_CHECK_GRID = (37, 5), (73, 9)


def sampled_plants(args: argparse.Namespace, plant: Any, model: Any) -> tuple[Any, Any, str]:
    """The plants the sampled-data certificate runs on, a second set to verify on, and their name.

    Parameters
    ----------
    args : argparse.Namespace
    plant : UncertainPlant, UncertainLTVModel or PolytopicModel
        From :func:`resolve_plant`.
    model : UncertainLTVModel or PolytopicModel
        Its uncertainty set.

    Returns
    -------
    plants, check : set or tuple (A, B)
    name : str
    """
    physical = as_plant("model", plant)
    arm = getattr(args, "arm_file", None)
    if args.model is not None and physical is not None and arm is None:
        on, fine = physical.samples(), physical.samples(physical.fine_points())
        return (on.A, on.B), (fine.A, fine.B), (
            f"the plant of {args.model!r} on its parameter grid ({on.n_samples} frozen plants, verified on "
            f"{fine.n_samples})")
    if args.model is not None and arm is None:
        if model.kind == "box":
            grid = interior_grid(model)
            return model, grid, (f"the {2 ** model.n_elements} corners of the box of {args.model!r} "
                                 f"(verified on a {len(grid[0])}-plant grid of the box)")
        return model, None, f"the {model.n_vertices} vertices of the polytope of {args.model!r}"
    assert physical is not None
    if arm is not None:  # the arm's own grids: the LMI's coarse one, verified on the file's
        on, fine = physical.samples(physical.coarse_points()), physical.samples()
        return (on.A, on.B), (fine.A, fine.B), (
            f"the arm of {arm!r}: its error dynamics linearized along the reference at e = 0, payload over its "
            f"range ({on.n_samples} samples, verified on {fine.n_samples})")
    coarse = physical.samples({"t_ref": CERTIFICATE_GRID[0], "m_p": CERTIFICATE_GRID[1]})
    fine = physical.samples({"t_ref": CERTIFICATE_CHECK_GRID[0], "m_p": CERTIFICATE_CHECK_GRID[1]})
    plants, check = (coarse.A, coarse.B), (fine.A, fine.B)
    robot = f"the robot of {args.robot!r}" if args.robot is not None else "the paper's robot"
    return plants, check, (f"{robot}: its error dynamics linearized along the reference at e = 0, payload over "
                           f"its range ({CERTIFICATE_GRID[0]} x {CERTIFICATE_GRID[1]} samples, verified on "
                           f"{CERTIFICATE_CHECK_GRID[0]} x {CERTIFICATE_CHECK_GRID[1]})")


def add_range_option(p: argparse.ArgumentParser, verb: str) -> None:
    """Add ``--range NAME=LO:HI`` (repeatable) to a sub-command that takes ``--model``.

    Parameters
    ----------
    p : argparse.ArgumentParser
    verb : str
        What the command does with the plant (for the help).
    """
    p.add_argument("--range", action="append", metavar="NAME=LO:HI", default=None,
                   help=f"with --model: {verb} the plant with this parameter's range replaced (its units; nominal "
                   "at LO); repeatable")


def with_ranges(args: argparse.Namespace, plant: Any) -> Any:
    """The plant with the ranges of ``--range NAME=LO:HI`` (a plant file with parameters only).

    Parameters
    ----------
    args : argparse.Namespace
    plant : UncertainPlant, UncertainLTVModel or PolytopicModel

    Returns
    -------
    The plant, its ranges replaced.
    """
    if not args.range:
        return plant
    physical = as_plant("model", plant)
    if physical is None or args.model is None:
        raise CommandLineError("`--range` changes a parameter of a plant file with [parameters] (--model)")
    ranges: dict[str, tuple[float, float]] = {}
    for text in args.range:
        name, _, bounds = text.partition("=")
        lo_text, _, hi_text = bounds.partition(":")
        try:
            lo, hi = float(lo_text), float(hi_text)
        except ValueError:
            raise CommandLineError(f"`--range` must be NAME=LO:HI, found {text!r}") from None
        if name not in physical.names:
            raise CommandLineError(f"`--range` names {name!r}, which is not a parameter of {args.model!r} "
                                   f"({', '.join(physical.names)})")
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise CommandLineError(f"`--range` {name} must have finite LO <= HI, found {lo:g}:{hi:g}")
        ranges[name] = (lo, hi)
    try:
        return physical.with_ranges(ranges)
    except ArgumentError as err:
        raise CommandLineError(f"`--range` {err}") from err


def add_design_option(p: argparse.ArgumentParser) -> None:
    """Add ``--design FILE.json`` (a gain written by ``synthesize --output``).

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    p.add_argument("--design", metavar="FILE.json",
                   help="a PID gain from a design file (written by synthesize --output)")


def resolve_design(args: argparse.Namespace, shape: tuple[int, int] = (2, 6),
                   what: str = "the SCARA's PID (x = [∫e, e, ė])") -> DesignFile | None:
    """The design file of ``--design``, checked to hold a gain of `shape` (the SCARA's, by default).

    Parameters
    ----------
    args : argparse.Namespace
    shape : (int, int)
        The gain's shape (m, n).
    what : str
        What the gain is for, in the error.

    Returns
    -------
    DesignFile or None
    """
    path = getattr(args, "design", None)
    if path is None:
        return None
    loaded = _load_file("--design", path, load_design)
    if loaded.K.shape != shape:
        raise CommandLineError(f"`--design` {path!r}: field `K` must have shape {shape} for {what}, found "
                               f"{loaded.K.shape}")
    return loaded


def check_gain_options(args: argparse.Namespace) -> str | None:
    """The gain's source: ``--design FILE.json``, or ``--rho`` and ``--eta``, exactly one of the two.

    Parameters
    ----------
    args : argparse.Namespace
        With ``rho``, ``eta`` and ``design``.

    Returns
    -------
    str or None
        The design file's path, or None when the gain is designed at (ρ, η).

    Raises
    ------
    CommandLineError
        For both, or neither.
    """
    path: str | None = getattr(args, "design", None)
    if path is not None and (args.rho is not None or args.eta is not None):
        raise CommandLineError("`--design` gives the gain; it cannot go with --rho/--eta")
    if path is None and (args.rho is None or args.eta is None):
        raise CommandLineError("give the gain: --rho and --eta (designed here), or --design FILE.json (your own K)")
    return path


def resolve_gain(args: argparse.Namespace, model: UncertainLTVModel | PolytopicModel) -> tuple[Design, str]:
    """The gain analysed: designed at ``--rho``/``--eta``, or your own from ``--design FILE.json``.

    A design file's K is taken as it is (:meth:`~scara_robust.Design.from_gain`), with the
    file's P when it has one and otherwise the Lyapunov solution of its nominal loop.

    Parameters
    ----------
    args : argparse.Namespace
        With ``rho``, ``eta`` and ``design``.
    model : UncertainLTVModel or PolytopicModel
        The design-form model.

    Returns
    -------
    design : Design
    label : str
        How a report names the gain: ``K(rho=3, eta=90)`` or ``the gain of 'FILE.json' (P: ...)``.
    """
    path = check_gain_options(args)
    if path is None:
        d = design(model, args.rho, args.eta)
        return d, f"K(rho={d.rho:g}, eta={d.eta:g})"
    loaded = resolve_design(args, (model.n_inputs, model.n_states), "this plant's design form")
    assert loaded is not None
    try:
        d = Design.from_gain(model, loaded.K, loaded.P)
    except ArgumentError as err:
        raise CommandLineError(f"`--design` {path!r}: field `{err.argument}` {err.problem}") from err
    source = {"given": "the file's P", "lyapunov": "P from the nominal loop's Lyapunov equation"}[d.P_source]
    return d, f"the gain of {path!r} ({source})"


def output_exists(path: str | None) -> bool:
    """True if `path` names an existing file (used before long computations).

    Parameters
    ----------
    path : str or None

    Returns
    -------
    bool
    """
    return path is not None and os.path.isfile(path)
