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
import importlib
import sys
from collections.abc import Collection, Sequence
from types import ModuleType

from .. import __version__
from ..exceptions import ScaraRobustError
from ._options import option
from ._parser import COMMANDS, CommandLineError, Parser, error_message

__all__ = ["main", "build_parser", "CommandLineError"]

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


def _command_module(name: str) -> ModuleType:
    """The module of command `name` (its options and its ``run``), imported on first use."""
    return importlib.import_module(f".{COMMANDS[name][0]}", __name__)


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser of ``python -m scara_robust``.

    Parameters
    ----------
    commands : collection of str, optional
        The commands whose options are registered (their modules alone are imported); the
        others are listed with their one-line help. Default: every command's options.

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
    for name, (_, text) in COMMANDS.items():
        if commands is None or name in commands:
            _command_module(name).add_parser(sub)
        else:
            sub.add_parser(name, help=text)
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
    tokens = list(sys.argv[1:] if argv is None else argv)
    # the command given (the first word that is not an option): only its module is imported
    command = next((token for token in tokens if token in COMMANDS), None)
    try:
        parser = build_parser(() if command is None else (command,))
        try:
            args, extras = parser.parse_known_args(tokens)
        except CommandLineError:
            _refuse_unknown_options(parser, tokens)
            raise
        if extras:
            _refuse_unknown(parser, args.command, extras)
        # the library, imported now that the arguments are known to parse
        import matplotlib

        from .._progress import shown
        from ._allocator import keep_freed_memory
        from ._common import check_outputs, emit
        from ._system import load_system

        keep_freed_memory()  # the searches' temporaries reused, not mapped and faulted in again (glibc)
        matplotlib.use("Agg")  # figures go to files; no display is needed
        system = load_system(args)  # the one place that tells the SCARA, an arm and a plant file apart
        check_outputs(args)
        with shown(sys.stderr.isatty()):  # the searches' progress, for a person at a terminal only
            text = args.func(args, system)
        emit(text, option(args, "output"))
    except (CommandLineError, ScaraRobustError, ValueError, TypeError, OSError, ImportError) as err:
        sys.stderr.write(f"scara_robust: error: {error_message(err)}\n")
        return 2
    except KeyboardInterrupt:
        # a campaign checkpoints its finished runs; every other command writes its outputs only when it completes
        kept = ("the runs finished so far are kept in --output (continue with --resume)"
                if command == "campaign" else "nothing was written")
        sys.stderr.write(f"scara_robust: interrupted; {kept}\n")
        return 130
    return 0
