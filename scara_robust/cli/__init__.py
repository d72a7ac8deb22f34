"""Command line: ``python -m scara_robust COMMAND`` (design, surface, certify, margin, simulate, compare,
campaign, campaign-report, export).

The front end of the package: it imports the library and nothing in the library imports
it. One private module per command, each with ``add_parser(sub)`` and ``run(args, system) -> str``, where
``system`` is the :class:`~._system.LoadedSystem` of the arguments (:func:`~._system.load_system`).
Every command accepts ``--help``. Bad input prints one line on stderr and exits 2.
Output files are written to a temporary file in the target folder and renamed, so an
interrupted or failed run never leaves a half-written file.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from collections.abc import Sequence

from .. import __version__
from ..exceptions import ScaraRobustError
from . import _app, _campaign, _certify, _compare, _design, _export, _margin, _report, _simulate, _surface, _synthesize
from ._common import CommandLineError, Parser, check_outputs, emit, error_message
from ._system import load_system

__all__ = ["main", "build_parser", "CommandLineError"]

#: The commands, in the order ``--help`` lists them.
_COMMANDS = (_design, _surface, _certify, _margin, _synthesize, _simulate, _compare, _campaign, _report, _export,
             _app)

_EXAMPLES = """examples:
  python -m scara_robust design --rho 3 --eta 90
  python -m scara_robust surface --rho 0.1:10:50 --eta 1:200:50 --plot surface.png
  python -m scara_robust certify --rho 3 --eta 90 --format json
  python -m scara_robust margin --rho 3 --eta 90 --tol 0.01
  python -m scara_robust simulate --controller smc --scenario small --output run.csv
  python -m scara_robust compare --format markdown
  python -m scara_robust campaign examples/campaign.toml --runs 20 --output results.csv
  python -m scara_robust campaign-report results.csv --plot report.png --worst 3
  python -m scara_robust export --rho 3 --eta 90 --ts 0.001 --torque-limit 50 --output .
  python -m scara_robust simulate --from-campaign results.csv --index 1 --controller smc

Every command takes --help. Bad input: one line on stderr, exit code 2."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m scara_robust``.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = Parser(
        prog="scara_robust",
        description="Robust PID design for a SCARA with a time-varying payload.",
        epilog=_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"scara_robust {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in _COMMANDS:
        command.add_parser(sub)
    return parser


def _command_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-command parsers of `parser`, by command name."""
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(subparsers.choices)


def _refuse_unknown(parser: argparse.ArgumentParser, command: str, extras: list[str]) -> None:
    """Refuse arguments no option takes, suggesting the closest option of the command."""
    options = sorted(_command_parsers(parser)[command]._option_string_actions)
    word = extras[0].split("=", 1)[0]
    close = difflib.get_close_matches(word, options, n=1)
    hint = f"; did you mean {close[0]}?" if close else f"; see python -m scara_robust {command} --help"
    raise CommandLineError(f"{command}: unrecognized arguments: {' '.join(extras)}{hint}")


def _takes_value(token: str) -> bool:
    """True if `token` reads as the value of an option rather than as an option."""
    if not token.startswith("-"):
        return True
    try:
        float(token)
    except ValueError:
        return False
    return True


def _refuse_unknown_options(parser: argparse.ArgumentParser, argv: Sequence[str]) -> None:
    """Refuse ``--name`` tokens the command does not know, if any (argv failed to parse).

    argparse reports a missing required option before an unknown one, so a typo such as
    ``--etta 90`` would read "the following arguments are required: --eta"; the typo is
    the cause, and is reported first (with the value after it, and a suggestion).
    """
    command = next((token for token in argv if not token.startswith("-")), None)
    commands = _command_parsers(parser)
    if command not in commands:
        return
    options = commands[command]._option_string_actions
    tokens = list(argv)[list(argv).index(command) + 1:]
    unknown: list[str] = []
    for i, token in enumerate(tokens):
        if token == "--":
            break
        name = token.split("=", 1)[0]
        if not token.startswith("--") or any(option.startswith(name) for option in options):
            continue  # a value, a short option, an option or an abbreviation argparse accepts
        unknown.append(token)
        if "=" not in token and i + 1 < len(tokens) and _takes_value(tokens[i + 1]):
            unknown.append(tokens[i + 1])
    if unknown:
        _refuse_unknown(parser, command, unknown)


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
    import matplotlib

    matplotlib.use("Agg")  # figures go to files; no display is needed
    parser = build_parser()
    try:
        try:
            args, extras = parser.parse_known_args(argv)
        except CommandLineError:
            _refuse_unknown_options(parser, sys.argv[1:] if argv is None else argv)
            raise
        if extras:
            _refuse_unknown(parser, args.command, extras)
        system = load_system(args)  # the one place that tells the SCARA, an arm and a plant file apart
        check_outputs(args)
        text = args.func(args, system)
        emit(text, getattr(args, "output", None))
    except (CommandLineError, ScaraRobustError, ValueError, TypeError, OSError, ImportError) as err:
        sys.stderr.write(f"scara_robust: error: {error_message(err)}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("scara_robust: interrupted; finished work is kept (a campaign continues with --resume)\n")
        return 130
    return 0
