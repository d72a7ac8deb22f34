"""Progress of long computations on stderr: for a person at a terminal, never in a pipe or a log.

The command line turns it on (:func:`shown`) when its standard error is a terminal; the library
then reports the steps of its searches (each bisection, :func:`scara_robust.robustness.search.bisect`)
through :func:`steps`, a tqdm bar with the count, the rate and the estimated time that remains.
Off, :func:`steps` costs nothing and prints nothing, so a library call or a piped command's
output is the same with and without it.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from typing import Any

__all__ = ["shown", "steps", "progress_on"]

_state = {"on": False}


def progress_on() -> bool:
    """True while a front end shows progress."""
    return _state["on"]


@contextlib.contextmanager
def shown(on: bool) -> Iterator[None]:
    """Show the library's progress on stderr within the block, when `on`."""
    before = _state["on"]
    _state["on"] = bool(on)
    try:
        yield
    finally:
        _state["on"] = before


class _Silent:
    """The bar of a computation nobody watches: every method does nothing."""

    def update(self, n: int = 1) -> None:
        """Nothing."""

    def set_postfix_str(self, text: str) -> None:
        """Nothing."""

    def close(self) -> None:
        """Nothing."""


def steps(desc: str, total: int | None = None, unit: str = "step") -> Any:
    """A progress bar of `total` steps on stderr (tqdm), or a silent one when progress is off.

    Parameters
    ----------
    desc : str
        What is being computed.
    total : int, optional
        The steps expected (the bar estimates the time that remains from it).
    unit : str

    Returns
    -------
    object
        With ``update(n)``, ``set_postfix_str(text)`` and ``close()``.
    """
    if not _state["on"]:
        return _Silent()
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, leave=False, dynamic_ncols=True)
