"""Command line: ``python -m scara_robust {design,surface,certify,simulate,compare,campaign,campaign-report} ...``.

The front end of the package: it imports the library and nothing in the library imports
it. One private module per command, each with ``add_parser(sub)`` and ``run(args) -> str``.
Every command accepts ``--help``. Bad input prints one line on stderr and exits 2.
Output files are written to a temporary file in the target folder and renamed, so an
interrupted or failed run never leaves a half-written file.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..exceptions import ScaraRobustError
from . import _campaign, _certify, _compare, _design, _report, _simulate, _surface
from ._common import CommandLineError, Parser, emit, error_message

__all__ = ["main", "build_parser", "CommandLineError"]

#: The commands, in the order ``--help`` lists them.
_COMMANDS = (_design, _surface, _certify, _simulate, _compare, _campaign, _report)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m scara_robust``.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = Parser(prog="scara_robust", description="Robust PID design for a SCARA with a time-varying payload.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in _COMMANDS:
        command.add_parser(sub)
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
    import matplotlib

    matplotlib.use("Agg")  # figures go to files; no display is needed
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        text = args.func(args)
        emit(text, getattr(args, "output", None))
    except (CommandLineError, ScaraRobustError, ValueError, TypeError, OSError) as err:
        sys.stderr.write(f"scara_robust: error: {error_message(err)}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("scara_robust: interrupted; finished work is kept (a campaign continues with --resume)\n")
        return 130
    return 0
