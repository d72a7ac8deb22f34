"""Command line: ``python -m scara_robust {design,surface,certify,simulate,compare,campaign,campaign-report} ...``.

Every command accepts ``--help``. Bad input prints one line on stderr and exits 2.
Output files are written to a temporary file in the target folder and renamed, so an
interrupted or failed run never leaves a half-written file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NoReturn, TypeVar

import numpy as np

from .certificate import certify
from .design import design
from .robot import PayloadProfile, ScaraParams
from .signals import Reference, SquareWave
from .simulation import SCENARIOS, Scenario
from .surface import design_surface
from .uncertain import ELEMENT_SETS, UncertainLTVModel, derived_model, paper_model

__all__ = [
    "main",
    "BOUNDS",
    "CommandLineError",
    "Setup",
    "add_setup_options",
    "parse_range",
    "resolve_bounds",
    "resolve_model",
    "resolve_setup",
    "write_atomic",
]

_Loaded = TypeVar("_Loaded")

#: Interval models selectable with ``--bounds``.
BOUNDS: dict[str, Callable[[], UncertainLTVModel]] = {"paper": paper_model, "derived": derived_model}


class CommandLineError(Exception):
    """Bad command-line input; reported as one line on stderr with exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise CommandLineError(f"{self.prog}: {message}")


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


def _finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from err
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, found {text!r}")
    return value


def write_atomic(path: str, write: Callable[[str], None]) -> None:
    """Call ``write(tmp_path)`` then rename the temporary file onto `path`.

    Parameters
    ----------
    path : str
        Destination file.
    write : callable
        ``write(tmp_path) -> None`` writes the whole content to ``tmp_path``.


    Raises
    ------
    OSError
        If the folder does not exist or is not writable, or `path` is a folder.
    """
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise IsADirectoryError(f"`--output` {path!r} is a directory")
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=os.path.splitext(path)[1])
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _emit(text: str, output: str | None) -> None:
    if output is None:
        sys.stdout.write(text if text.endswith("\n") else text + "\n")
        return

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text if text.endswith("\n") else text + "\n")

    write_atomic(output, write)


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
        """Keyword arguments for :func:`scara_robust.run_scenario` and :func:`scara_robust.compare`."""
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
    from .inputs import InputFileError

    try:
        return load(path)
    except OSError as err:
        raise OSError(f"`{option}` {path!r}: {err.strerror or err}") from err
    except InputFileError as err:
        raise InputFileError(f"`{option}` {err}") from err


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
    OSError, InputFileError
        Naming the option and the file.
    """
    from .inputs import load_robot, load_scenario

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
            raise ValueError(
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
    ValueError
        If published bounds are asked for with a robot or scenario file.
    """
    if resolve_bounds(args, setup) == "paper":
        if setup.from_files:
            raise ValueError(
                "`--bounds paper` holds only for the paper's robot and signals; with --robot or a scenario file "
                "use --bounds derived"
            )
        return paper_model()
    return derived_model(setup.params, setup.reference, setup.payload)


def _add_model_options(p: argparse.ArgumentParser) -> None:
    add_setup_options(p)
    p.add_argument("--elements", choices=ELEMENT_SETS, default="all", help="uncertain elements entering Theorem 1's Z")


def _design_payload(args: argparse.Namespace) -> dict[str, Any]:
    setup = resolve_setup(args)
    model = resolve_model(args, setup)
    d = design(model, args.rho, args.eta)
    cert = certify(model, d, args.elements)
    return {
        "rho": d.rho,
        "eta": d.eta,
        "bounds": resolve_bounds(args, setup),
        "elements": args.elements,
        "K": d.K.tolist(),
        "closed_loop_poles_real": np.sort(d.poles.real).tolist(),
        "closed_loop_hurwitz": d.hurwitz,
        "max_eig_Z": cert.max_eig,
        "certified": cert.certified,
        "care_residual": d.care_residual,
        "lyapunov_residual": cert.lyapunov_residual,
        "contributions": cert.contributions().to_dict(orient="records"),
    }


def _cmd_design(args: argparse.Namespace) -> str:
    out = _design_payload(args)
    if args.format == "json":
        return json.dumps(out, indent=2)
    K = np.array(out["K"])
    lines = [
        f"design (rho, eta) = ({out['rho']:g}, {out['eta']:g}), bounds: {out['bounds']}, elements: {args.elements}",
        "K =",
        np.array2string(K, precision=4, suppress_small=True, max_line_width=120),
        f"closed loop Hurwitz: {out['closed_loop_hurwitz']} "
        f"(largest real part {max(out['closed_loop_poles_real']):.4g} 1/s)",
        f"max eig Z: {out['max_eig_Z']:.6g}  ->  certified: {out['certified']}",
        "",
        "contributions of each element to Z:",
        __import__("pandas").DataFrame(out["contributions"]).to_string(index=False, float_format="%.4g"),
    ]
    return "\n".join(lines)


def _cmd_surface(args: argparse.Namespace) -> str:
    model = resolve_model(args, resolve_setup(args))
    try:
        surface = design_surface(model, args.rho, args.eta, args.elements)
    except ValueError as err:
        msg = str(err).replace("`rhos`", "`--rho`").replace("`etas`", "`--eta`")
        raise ValueError(msg) from err
    frame = surface.to_frame()
    if args.plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        rho, eta, best = surface.best() if surface.hurwitz.any() else (np.nan, np.nan, np.nan)
        ax = surface.plot(mark=None if np.isnan(rho) else (rho, eta))
        write_atomic(args.plot, lambda tmp: ax.figure.savefig(tmp, dpi=120, format="png"))
        plt.close(ax.figure)
    if args.format == "json":
        return json.dumps(frame.to_dict(orient="records"))
    if args.format == "csv":
        return str(frame.to_csv(index=False))
    rho, eta, best = surface.best()
    return (
        f"{frame.shape[0]} grid points, {int(surface.certified.sum())} certified "
        f"(max eig Z < 0); best: rho={rho:g}, eta={eta:g}, max eig Z={best:.6g}\n"
        + str(frame.to_string(index=False, float_format="%.6g"))
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m scara_robust``."""
    parser = _Parser(prog="scara_robust", description="Robust PID design for a SCARA with a time-varying payload.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("design", help="design K from (rho, eta) and certify it with Theorem 1")
    p.add_argument("--rho", type=_finite_float, required=True, help="design parameter rho > 0")
    p.add_argument("--eta", type=_finite_float, required=True, help="design parameter eta >= 1")
    _add_model_options(p)
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.set_defaults(func=_cmd_design)

    p = sub.add_parser("surface", help="max eig Z over a (rho, eta) grid (Figure 2)")
    p.add_argument("--rho", type=parse_range, required=True, metavar="START:STOP:NUM")
    p.add_argument("--eta", type=parse_range, required=True, metavar="START:STOP:NUM")
    _add_model_options(p)
    p.add_argument("--format", choices=("text", "csv", "json"), default="text")
    p.add_argument("--output", help="write to this file instead of stdout")
    p.add_argument("--plot", metavar="FILE.png", help="also save the 3D surface as a PNG")
    p.set_defaults(func=_cmd_surface)

    from .campaign import add_campaign_parsers
    from .comparison import add_compare_parser
    from .conservatism import add_certify_parser
    from .simulation import add_simulate_parser

    add_certify_parser(sub)
    add_simulate_parser(sub)
    add_compare_parser(sub)
    add_campaign_parsers(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code (0 ok, 2 bad input or I/O error).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments after the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on bad input or an I/O error (one line on stderr), 130 when
        interrupted.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        text = args.func(args)
        _emit(text, getattr(args, "output", None))
    except (CommandLineError, ValueError, TypeError, OSError) as err:
        message = " ".join(str(err).split())
        sys.stderr.write(f"scara_robust: error: {message}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("scara_robust: interrupted; finished work is kept (a campaign continues with --resume)\n")
        return 130
    return 0
