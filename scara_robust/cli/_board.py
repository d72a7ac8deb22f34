"""``export --target BOARD``: the exported controller run on an emulated board before it is written."""

from __future__ import annotations

import argparse
from typing import Any

from ..export import BOARDS, BoardRun, board_inputs, check_toolchain, run_on_board
from ._common import CommandLineError, finite_float

__all__ = ["add_board_options", "check_board_options", "run_board", "BOARD_STEPS"]

#: Random input steps the board runs (and the Python step runs beside it).
BOARD_STEPS = 10_000


def add_board_options(p: argparse.ArgumentParser) -> None:
    """Add ``--target`` and ``--clock`` to the ``export`` parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    p.add_argument("--target", metavar="BOARD", default=None,
                   help=f"before writing, cross-compile the C and run it on an emulated board ({', '.join(BOARDS)}): "
                   f"{BOARD_STEPS} steps of random inputs against the Python step, instructions per step, flash and "
                   "RAM, the step's share of Ts (needs the board's Debian packages)")
    p.add_argument("--clock", type=finite_float, default=None, metavar="HZ",
                   help="clock of the board's time estimate, Hz (default 168e6 for cortex-m4f)")


def check_board_options(args: argparse.Namespace) -> None:
    """Refuse an unknown board, a format other than C and a missing toolchain, before any computation.

    Parameters
    ----------
    args : argparse.Namespace
    """
    if args.target is None:
        if args.clock is not None:
            raise CommandLineError("`--clock` is the clock of `--target`'s estimate; give --target too")
        return
    if args.target not in BOARDS:
        raise CommandLineError(f"`--target` must be one of {', '.join(repr(b) for b in BOARDS)}, found {args.target!r}")
    if args.format != "c":
        raise CommandLineError(f"`--target` runs the C on the board; --format is {args.format!r}, not 'c'")
    if args.clock is not None and args.clock <= 0:
        raise CommandLineError(f"`--clock` must be > 0 Hz, found {args.clock:g}")
    check_toolchain(args.target)  # MissingToolError: one line naming the packages, exit 2


def run_board(args: argparse.Namespace, controller: Any, prefix: str) -> BoardRun | None:
    """The board run of `controller` (None without ``--target``); refused when it does not agree.

    Parameters
    ----------
    args : argparse.Namespace
    controller : DiscretePID, SampledStateFeedback or SampledScheduledGain
    prefix : str

    Returns
    -------
    BoardRun or None
    """
    if args.target is None:
        return None
    run = run_on_board(controller, board_inputs(controller, BOARD_STEPS), board=args.target,
                       precision=args.precision, prefix=prefix, clock_hz=args.clock)
    if not run.agrees:
        raise CommandLineError(f"`--target` {run.message}; nothing written")
    return run
