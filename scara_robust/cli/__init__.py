"""Command line: ``python -m scara_robust COMMAND`` (design, surface, certify, margin, simulate, compare,
campaign, campaign-report, export).

The front end of the package: it imports the library and nothing in the library imports
it. One private module per command, each with ``add_parser(sub)`` and ``run(args) -> str``.
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
from . import _campaign, _certify, _compare, _design, _export, _margin, _report, _simulate, _surface, _synthesize
from ._common import CommandLineError, Parser, check_outputs, emit, error_message

__all__ = ["main", "build_parser", "CommandLineError"]

#: The commands, in the order ``--help`` lists them.
_COMMANDS = (_design, _surface, _certify, _margin, _synthesize, _simulate, _compare, _campaign, _report, _export)

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


def _refuse_unknown(parser: argparse.ArgumentParser, command: str, extras: list[str]) -> None:
    """Refuse arguments no option takes, suggesting the closest option of the command."""
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    options = sorted(subparsers.choices[command]._option_string_actions)
    word = extras[0].split("=", 1)[0]
    close = difflib.get_close_matches(word, options, n=1)
    hint = f"; did you mean {close[0]}?" if close else f"; see python -m scara_robust {command} --help"
    raise CommandLineError(f"{command}: unrecognized arguments: {' '.join(extras)}{hint}")


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
        args, extras = parser.parse_known_args(argv)
        if extras:
            _refuse_unknown(parser, args.command, extras)
        check_outputs(args)
        text = args.func(args)
        emit(text, getattr(args, "output", None))
    except (CommandLineError, ScaraRobustError, ValueError, TypeError, OSError) as err:
        sys.stderr.write(f"scara_robust: error: {error_message(err)}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("scara_robust: interrupted; finished work is kept (a campaign continues with --resume)\n")
        return 130
    return 0
