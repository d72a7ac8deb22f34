"""The command line's parser and its errors, without the library: ``--help`` and bad options answer at once.

Importing the numerical stack (scipy, pandas, python-control, matplotlib) takes a second or
more; the top-level ``--help``, ``--version`` and a mistyped command need none of it, and a
command's own module (its options and its ``run``) is imported only when that command is
given. :data:`OPTION_NAMES` is the one place where a library parameter's name is mapped to the
option a user typed; :func:`error_message` uses it to render a library
:class:`~scara_robust.exceptions.ArgumentError` in the user's terms.
"""

from __future__ import annotations

import argparse
import os
from typing import NoReturn

from .._validation import os_error_text
from ..exceptions import ArgumentError

__all__ = ["COMMANDS", "COMMAND_HELP", "CommandLineError", "OPTION_NAMES", "Parser", "error_message"]

#: The commands, in the order ``--help`` lists them: name -> (its module in this package, its one-line help).
COMMANDS: dict[str, tuple[str, str]] = {
    "design": ("_design", 'design K from (rho, eta) and certify it with Theorem 1'),
    "surface": ("_surface", 'max eig Z over a (rho, eta) grid (Figure 2)'),
    "certify": ("_certify", 'every certificate of one design: Theorem 1, vertex, LMI, falsifier'),
    "margin": ("_margin",
              'robustness margins: the largest scaling of the uncertainty '
              'set each method certifies, and upper bounds'),
    "synthesize": ("_synthesize", 'synthesize a PID gain together with its Lyapunov certificate (LMI)'),
    "tune": ("_tune", "the smallest PID gain whose certified tracking error meets stated requirements (error after "
                      "a settling time, Ts, disturbance, torque, margins), run on the robot beside the paper's"),
    "simulate": ("_simulate", 'one closed-loop run and its time series'),
    "compare": ("_compare",
               'PID vs sliding-mode control on both scenarios; with '
               '--model, the designs for your plant side by side'),
    "campaign": ("_campaign", 'Monte-Carlo campaign: draw scenarios from a TOML spec, simulate every controller'),
    "campaign-report": ("_report",
                       'per-controller statistics of a campaign (with 95 %% '
                       'intervals), its worst runs, and a figure'),
    "export": ("_export",
              "the designed PID (or a state-form plant's static feedback), "
              'sampled at --ts, as C99 source (.h, .c) or JSON'),
    "app": ("_app", "the graphical design as a local web page: click the (rho, eta) map, read the design's answers"),
}

#: Each command's one-line help (``--help`` lists them; the command's module registers it with it).
COMMAND_HELP: dict[str, str] = {name: text for name, (_, text) in COMMANDS.items()}


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
    "error": "--error",
    "settling_time": "--settling-time",
    "sample_time": "--ts",
    "disk_margin": "--disk-margin",
    "delay_margin": "--delay-margin",
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
    elif isinstance(err, OSError):
        path = err.filename if err.filename is not None else (
            str(err) if isinstance(err, FileNotFoundError) and not err.strerror else None)
        text = f"{os.fspath(path)!r}: {os_error_text(err)}" if path else os_error_text(err)
    else:
        text = str(err)
    return " ".join(text.split())
