"""The one place the command line reads its parsed options by name.

Each command's parser registers only the options that command takes, so one command's
namespace lacks another's options. :func:`option` reads one option (its default where the
command has no such option) and :func:`given` lists those given; every other module of the
command line reads ``args.NAME`` of the options its own command registers, or asks here.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["given", "option"]


def option(args: argparse.Namespace, name: str, default: Any = None) -> Any:
    """The value of option `name` (its ``dest``), or `default` where the command has no such option.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of one command.
    name : str
        The option's ``dest`` (``'measurement_bias'`` for ``--measurement-bias``).
    default : object, optional
        What an absent option reads as.

    Returns
    -------
    object
    """
    return getattr(args, name, default)


def given(args: argparse.Namespace, names: Iterable[str] | Mapping[str, Any]) -> list[str]:
    """The options among `names` that were given: not None, or not their default.

    Parameters
    ----------
    args : argparse.Namespace
    names : iterable of str, or mapping of str to object
        Option names (``dest``), in the order to report them; a mapping gives each its
        default value (an absent option reads as it), an iterable means a default of None.

    Returns
    -------
    list of str
        The names given, in the order of `names`.
    """
    defaults = dict(names) if isinstance(names, Mapping) else dict.fromkeys(names)
    return [name for name, default in defaults.items() if option(args, name, default) != default]
