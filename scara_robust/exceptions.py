"""The package's exceptions: one base class, and the errors a user can act on.

Every error raised on purpose derives from :class:`ScaraRobustError` and from the
built-in class a caller would catch anyway (``ValueError`` for a bad value, ``TypeError``
for a bad type), so ``except ValueError`` keeps working.

An :class:`ArgumentError` carries the library's own parameter name (``argument``) and
what is wrong with it (``problem``) as separate fields; a front end that calls the
parameter something else (the command line's ``--rho`` for ``rho``) rebuilds the message
from those fields instead of editing the text.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "ScaraRobustError",
    "ArgumentError",
    "ArgumentValueError",
    "ArgumentTypeError",
    "MissingToolError",
    "InputFileError",
    "CampaignSpecError",
    "OptionError",
]


class ScaraRobustError(Exception):
    """Base class of every error the package raises on purpose."""


class ArgumentError(ScaraRobustError):
    """A bad argument of a public function.

    Parameters
    ----------
    argument : str
        The parameter's name as the function spells it (``'rho'``, ``'m1 [kg]'``).
    problem : str
        What was expected and what was found (``'must be > 0, found -1.0'``).

    Attributes
    ----------
    argument, problem : str
        As given; ``str(error)`` is ```argument` problem``.
    """

    def __init__(self, argument: str, problem: str) -> None:
        super().__init__(f"`{argument}` {problem}")
        self.argument = argument
        self.problem = problem

    def __reduce__(self) -> tuple[Any, tuple[str, str]]:
        # Keep the two fields across pickling (process pools and Dask send errors back).
        return (type(self), (self.argument, self.problem))


class ArgumentValueError(ArgumentError, ValueError):
    """An argument of the right type with a bad value or shape."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of the wrong type."""


class MissingToolError(ScaraRobustError, RuntimeError):
    """An external program a command needs (a cross-compiler, an emulator) is not installed; the
    message names it and the packages that install it."""


class InputFileError(ScaraRobustError, ValueError):
    """A robot, scenario or model file that cannot be used; the message names the file and field."""


class CampaignSpecError(InputFileError):
    """A campaign spec that cannot be used; the message names the field."""


class OptionError(ScaraRobustError, ValueError):
    """Input of a front end (an option, or a file it names) that cannot be used together or read.

    Raised by the workflow layer (``scara_robust.workflow``) that the command line and the
    design page share; the message names the option as the user gave it (``--robot``).
    """
