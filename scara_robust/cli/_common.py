"""What every command shares: options for robot and scenario files, parsing, output, errors.

The table :data:`OPTION_NAMES` is the one place where a library parameter's name is
mapped to the option a user typed; :func:`error_message` uses it to render a library
:class:`~scara_robust.exceptions.ArgumentError` in the user's terms.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np

from .._validation import os_error_text
from ..exceptions import ArgumentError, ArgumentValueError
from ..io import PID_CONTROLLER_METHOD, DesignFile, load_design, ros2_dof_name, write_atomic
from ..lyapunov.gain import Design, design
from ..model.polytopic import PolytopicModel
from ..model.scara import SCARA_BOUNDS
from ..model.uncertain import UncertainLTVModel
from ..robustness.registry import get_method
from ..workflow.system import load_input
from ._options import option
from ._parser import OPTION_NAMES, CommandLineError, Parser, error_message

__all__ = [
    "BOUNDS",
    "OPTION_NAMES",
    "CommandLineError",
    "Parser",
    "add_setup_options",
    "emit",
    "error_message",
    "check_outputs",
    "write_text",
    "OUTPUT_OPTIONS",
    "finite_float",
    "load_file",
    "method_names",
    "screen_table",
    "SCREEN_ROWS",
    "per_joint_values",
    "parse_range",
    "add_range_option",
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


def method_names(family: str, option: str, *, many: bool = False) -> Callable[[str], tuple[str, ...]]:
    """An option's text as registered method names of `family` (comma-separated when `many`).

    The registry is read when the option is parsed, so a method a script registered before
    calling :func:`scara_robust.cli.main` is accepted.

    Parameters
    ----------
    family : str
        A key of :data:`scara_robust.METHOD_FAMILIES`.
    option : str
        The option, for the error (``'--methods'``).
    many : bool
        Accept several names separated by commas.

    Returns
    -------
    callable ``parse(text) -> tuple of str``
        Raises ``argparse.ArgumentTypeError`` naming the registered methods and the closest
        to an unknown name.
    """

    def parse(text: str) -> tuple[str, ...]:
        names = tuple(n.strip() for n in text.split(",")) if many else (text,)
        for name in names:
            try:
                get_method(family, name, argument=option)
            except ArgumentValueError as err:
                raise argparse.ArgumentTypeError(err.problem) from None
        return names

    return parse


#: Rows of a table printed to the screen; longer tables print their head (``--output`` writes all).
SCREEN_ROWS = 40


def screen_table(frame: Any, output: str | None, **to_string: Any) -> str:
    """A table as text: whole into a file, its first :data:`SCREEN_ROWS` rows on the screen.

    Parameters
    ----------
    frame : pandas.DataFrame
    output : str or None
        The command's ``--output``: None prints to the screen.
    **to_string
        Options of ``DataFrame.to_string`` (``index``, ``float_format``).

    Returns
    -------
    str
        The table, followed on the screen by ``"... N more rows, --output F for all"`` when cut.
    """
    if output is not None or len(frame) <= SCREEN_ROWS:
        return str(frame.to_string(**to_string))
    more = len(frame) - SCREEN_ROWS
    return f"{frame.head(SCREEN_ROWS).to_string(**to_string)}\n... {more} more rows, --output F for all"


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
        raise CommandLineError(f"`{option}` {path!r}: {os_error_text(err)}") from err


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
    """Print `text` (nothing if empty), or write it atomically to `output` (the ``--output`` file) and say so.

    Parameters
    ----------
    text : str
    output : str or None
    """
    if output is not None:
        write_text("--output", output, text)
        sys.stdout.write(f"wrote {output}\n")  # one line, as every command that writes a file says
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
OUTPUT_OPTIONS = {"output": "--output", "series_output": "--output", "results_output": "--output",
                  "design_output": "--output", "plot": "--plot"}


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
    for attr, flag in OUTPUT_OPTIONS.items():
        path = option(args, attr)
        if path is None:
            continue
        if attr == "plot":
            _figure_format(flag, path)
        folder = os.path.dirname(os.path.abspath(path))
        if os.path.isdir(path):
            raise CommandLineError(f"`{flag}` {path!r}: is a directory")
        if not os.path.isdir(folder):
            raise CommandLineError(
                f"`{flag}` {path!r}: No such file or directory: the folder {folder!r} does not exist"
            )
        if not os.access(folder, os.W_OK):
            raise CommandLineError(f"`{flag}` {path!r}: the folder {folder!r} is not writable")


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


def load_file(option: str, path: str, load: Callable[[str], _Loaded]) -> _Loaded:
    """``load(path)``, with the option named in any error (:func:`scara_robust.workflow.system.load_input`)."""
    return load_input(option, path, load)


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


def add_design_option(p: argparse.ArgumentParser) -> None:
    """Add ``--design FILE.json`` (a gain written by ``synthesize --output``).

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    p.add_argument("--design", metavar="FILE.json",
                   help="a PID gain from a design file (written by synthesize --output), or a ros2_control "
                   "pid_controller file (.yaml: its per-joint p, i, d and output clamp, matched to the joints by name)")


def resolve_design(args: argparse.Namespace, shape: tuple[int, int] = (2, 6),
                   what: str = "the SCARA's PID (x = [∫e, e, ė])",
                   joints: Sequence[str] | None = ("q1", "q2")) -> DesignFile | None:
    """The design file of ``--design``, checked to hold a gain of `shape` (the SCARA's, by default).

    A ros2_control ``pid_controller`` file (``.yaml``) names its joints: its gains are put
    in the order of `joints` (the system's, :meth:`LoadedSystem.joint_names`), and a file
    that names other joints is refused.

    Parameters
    ----------
    args : argparse.Namespace
    shape : (int, int)
        The gain's shape (m, n).
    what : str
        What the gain is for, in the error.
    joints : sequence of str or None
        The system's joints, in the order of its gain's rows (default the SCARA's).

    Returns
    -------
    DesignFile or None
    """
    path = option(args, "design")
    if path is None:
        return None
    loaded = load_file("--design", path, load_design)
    named = loaded.info.get("joints") if loaded.info.get("method") == PID_CONTROLLER_METHOD else None
    if named is not None:
        loaded = _in_joint_order(path, loaded, list(named), joints)
    if loaded.K.shape != shape:
        raise CommandLineError(f"`--design` {path!r}: field `K` must have shape {shape} for {what}, found "
                               f"{loaded.K.shape}")
    return loaded


def _in_joint_order(path: str, loaded: DesignFile, named: list[str], joints: Sequence[str] | None) -> DesignFile:
    """A pid_controller file's gain with its rows (and each block's columns) in the order of `joints`.

    A ``dof_names`` entry names the output of its row, or a URDF joint (an arm's output is ``q_<joint>``).
    """
    outputs = list(joints or [])
    by_dof = {ros2_dof_name(output): output for output in outputs}
    dof = {name: name if name in outputs else by_dof.get(name, name) for name in named}
    if joints is None or sorted(dof.values()) != sorted(outputs):
        system = "this system names no joints" if joints is None else f"the system's joints are {outputs}"
        raise CommandLineError(f"`--design` {path!r}: its dof_names are {named}; {system}")
    order = [list(dof.values()).index(j) for j in outputs]
    m = len(order)
    columns = [block * m + k for block in range(loaded.K.shape[1] // m) for k in order]
    info = {key: ([value[k] for k in order] if isinstance(value, list) and len(value) == m else value)
            for key, value in loaded.info.items()}
    return DesignFile(loaded.path, loaded.K[np.ix_(order, columns)], None, info)


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
    path: str | None = option(args, "design")
    if path is not None and (args.rho is not None or args.eta is not None):
        raise CommandLineError("`--design` gives the gain; it cannot go with --rho/--eta")
    if path is None and (args.rho is None or args.eta is None):
        raise CommandLineError("give the gain: --rho and --eta (designed here), or --design FILE.json (your own K)")
    return path


class UnstableGainError(CommandLineError):
    """A design file's gain (without P) whose nominal closed loop is unstable: an answer for ``certify``.

    Parameters
    ----------
    message : str
        The one line for commands that need a Lyapunov matrix.
    eigenvalue : complex
        The nominal closed loop's eigenvalue of largest real part, 1/s.
    """

    def __init__(self, message: str, eigenvalue: complex) -> None:
        super().__init__(message)
        self.eigenvalue = eigenvalue


def resolve_gain(args: argparse.Namespace, model: UncertainLTVModel | PolytopicModel,
                 joints: Sequence[str] | None = None) -> tuple[Design, str]:
    """The gain analysed: designed at ``--rho``/``--eta``, or your own from ``--design FILE.json``.

    A design file's K is taken as it is (:meth:`~scara_robust.Design.from_gain`), with the
    file's P when it has one and otherwise the Lyapunov solution of its nominal loop.

    Parameters
    ----------
    args : argparse.Namespace
        With ``rho``, ``eta`` and ``design``.
    model : UncertainLTVModel or PolytopicModel
        The design-form model.
    joints : sequence of str, optional
        The system's joints (:meth:`LoadedSystem.joint_names`), for a pid_controller file.

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
    loaded = resolve_design(args, (model.n_inputs, model.n_states), "this plant's design form", joints)
    assert loaded is not None
    try:
        d = Design.from_gain(model, loaded.K, loaded.P)
    except ArgumentError as err:
        poles = np.linalg.eigvals(model.A - model.B @ loaded.K)
        if err.argument == "K" and loaded.P is None and poles.real.max() >= 0:
            raise UnstableGainError(f"`--design` {path!r}: field `K` {err.problem}",
                                    complex(poles[np.argmax(poles.real)])) from err
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
