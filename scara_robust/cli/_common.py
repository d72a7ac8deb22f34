"""What every command shares: options for robot and scenario files, parsing, output, errors.

The table :data:`OPTION_NAMES` is the one place where a library parameter's name is
mapped to the option a user typed; :func:`error_message` uses it to render a library
:class:`~scara_robust.exceptions.ArgumentError` in the user's terms.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NoReturn, TypeVar

import numpy as np

from ..exceptions import ArgumentError, InputFileError
from ..io import load_robot, load_scenario, write_atomic
from ..model.initial import SCENARIOS, Scenario
from ..model.robot import PayloadProfile, ScaraParams
from ..model.signals import Reference, SquareWave
from ..model.uncertain import UncertainLTVModel, derived_model, paper_model

__all__ = [
    "BOUNDS",
    "OPTION_NAMES",
    "CommandLineError",
    "Parser",
    "Setup",
    "add_setup_options",
    "emit",
    "error_message",
    "finite_float",
    "parse_range",
    "resolve_bounds",
    "resolve_model",
    "resolve_setup",
    "save_figure",
    "output_exists",
]

_Loaded = TypeVar("_Loaded")

#: Interval models selectable with ``--bounds``.
BOUNDS: dict[str, Callable[[], UncertainLTVModel]] = {"paper": paper_model, "derived": derived_model}

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
    "scheduler": "--scheduler",
    "address": "--address",
    "output": "--output",
    "resume": "--resume",
    "path": "RESULTS",
    "falsifier_tries": "--tries",
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
        raise CommandLineError(f"{self.prog}: {message}")


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


def _write(option: str, path: str, write: Callable[[str], None]) -> None:
    try:
        write_atomic(path, write)
    except OSError as err:
        raise CommandLineError(f"`{option}` {path!r}: {err.strerror or err}") from err


def emit(text: str, output: str | None) -> None:
    """Print `text`, or write it atomically to `output` (the ``--output`` file).

    Parameters
    ----------
    text : str
    output : str or None
    """
    text = text if text.endswith("\n") else text + "\n"
    if output is None:
        sys.stdout.write(text)
        return

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    _write("--output", output, write)


def save_figure(option: str, path: str, fig: Any) -> None:
    """Save a matplotlib figure as PNG atomically and close it.

    Parameters
    ----------
    option : str
        The option that named the file, for errors.
    path : str
    fig : matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    try:
        _write(option, path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
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
    from_files : bool
        True when a robot or scenario file was given.
    """

    params: ScaraParams
    reference: Reference | None
    payload: PayloadProfile | None
    disturbance: SquareWave | None
    initial: Scenario | None
    from_files: bool

    def signals(self) -> dict[str, Any]:
        """Keyword arguments for :func:`scara_robust.run_scenario` and :func:`scara_robust.compare_controllers`.

        Returns
        -------
        dict
        """
        return {"params": self.params, "reference": self.reference, "payload": self.payload,
                "disturbance": self.disturbance}


def add_setup_options(p: argparse.ArgumentParser, *, bounds: bool = True, scenario: bool = True) -> None:
    """Add ``--robot FILE``, ``--scenario NAME|FILE`` and ``--bounds`` to a sub-command.

    Parameters
    ----------
    p : argparse.ArgumentParser
    bounds : bool
        Add ``--bounds``.
    scenario : bool
        Add ``--scenario``.
    """
    p.add_argument("--robot", metavar="FILE", help="robot file (.toml/.json, see examples/robot-paper.toml)")
    if scenario:
        p.add_argument(
            "--scenario",
            metavar="NAME|FILE",
            help="initial condition 'large' or 'small', or a scenario file (payload, reference, disturbance, "
            "initial error; see examples/scenario-paper.toml)",
        )
    if bounds:
        p.add_argument(
            "--bounds",
            choices=sorted(BOUNDS),
            default=None,
            help="interval model of the PID design: published Tables 1-2 ('paper', the default without files) "
            "or derived from the robot ('derived', the default with --robot or a scenario file)",
        )


def _load_file(option: str, path: str, load: Callable[[str], _Loaded]) -> _Loaded:
    """``load(path)``, with the option named in any error."""
    try:
        return load(path)
    except OSError as err:
        raise CommandLineError(f"`{option}` {path!r}: {err.strerror or err}") from err
    except InputFileError as err:
        raise CommandLineError(f"`{option}` {err}") from err


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
    params, from_files = ScaraParams(), False
    robot = getattr(args, "robot", None)
    if robot is not None:
        params = _load_file("--robot", robot, load_robot)
        from_files = True
    scenario = getattr(args, "scenario", None)
    reference = payload = disturbance = None
    initial: Scenario | None = None
    if scenario is not None and scenario in SCENARIOS:
        initial = SCENARIOS[scenario]
    elif scenario is not None:
        if not scenario.lower().endswith((".toml", ".json")):
            raise CommandLineError(
                f"`--scenario` must be {', '.join(repr(n) for n in SCENARIOS)} or a .toml/.json scenario file, "
                f"found {scenario!r}"
            )
        scen = _load_file("--scenario", scenario, load_scenario)
        reference, payload, disturbance, initial = scen.reference, scen.payload, scen.disturbance, scen.initial
        from_files = True
    return Setup(params, reference, payload, disturbance, initial, from_files)


def resolve_bounds(args: argparse.Namespace, setup: Setup) -> str:
    """``--bounds``, or its default: ``'derived'`` with files, else ``'paper'``.

    Parameters
    ----------
    args : argparse.Namespace
    setup : Setup

    Returns
    -------
    {'paper', 'derived'}
    """
    return getattr(args, "bounds", None) or ("derived" if setup.from_files else "paper")


def resolve_model(args: argparse.Namespace, setup: Setup) -> UncertainLTVModel:
    """The interval model of ``--bounds`` for this setup (refusing published bounds for other data).

    Parameters
    ----------
    args : argparse.Namespace
    setup : Setup

    Returns
    -------
    UncertainLTVModel

    Raises
    ------
    CommandLineError
        If published bounds are asked for with a robot or scenario file.
    """
    if resolve_bounds(args, setup) == "paper":
        if setup.from_files:
            raise CommandLineError(
                "`--bounds paper` holds only for the paper's robot and signals; with --robot or a scenario file "
                "use --bounds derived"
            )
        return paper_model()
    return derived_model(setup.params, setup.reference, setup.payload)


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
