"""What a request needs, estimated from its sizes before any work: one check for every size argument.

Each size that a user chooses (a simulation's horizon over its output step, a grid's
points, a campaign's runs, a box's 2^N corners) goes through :func:`check_memory` with an
estimate of the bytes it makes the package hold at once. A request whose estimate exceeds
:data:`MEMORY_FRACTION` of the memory this machine has available is refused up front, with
an :class:`~scara_robust.exceptions.ArgumentValueError` naming the argument and the
estimate, instead of dying later with numpy's ``MemoryError``.
"""

from __future__ import annotations

import os

from .exceptions import ArgumentValueError

__all__ = ["MEMORY_FRACTION", "available_memory", "check_memory", "format_bytes", "simulation_bytes",
           "corners_bytes", "table_bytes"]

#: Share of the available memory one request may plan to hold.
MEMORY_FRACTION = 0.5
_FALLBACK = 8 * 2**30  # where the operating system does not say (8 GiB)


def available_memory() -> int:
    """Memory available to this process now, bytes (physical pages not in use).

    Returns
    -------
    int
    """
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return _FALLBACK


def format_bytes(n_bytes: float) -> str:
    """``n_bytes`` in the largest binary unit that keeps it >= 1 (``'74.5 GiB'``).

    Parameters
    ----------
    n_bytes : float

    Returns
    -------
    str
    """
    value, unit = float(n_bytes), "B"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(value) < 1024 or unit == "EiB":
            break
        value /= 1024
    return f"{value:.3g} {unit}"


def check_memory(argument: str, n_bytes: float, what: str) -> None:
    """Refuse a request whose estimated memory does not fit.

    Parameters
    ----------
    argument : str
        The parameter whose size drives the estimate (named in the error).
    n_bytes : float
        Estimated bytes held at once.
    what : str
        What the bytes are for, e.g. ``"2e+10 output samples of 16 values"``.

    Raises
    ------
    ArgumentValueError
        If `n_bytes` exceeds :data:`MEMORY_FRACTION` of :func:`available_memory`.
    """
    limit = MEMORY_FRACTION * available_memory()
    if n_bytes > limit:
        raise ArgumentValueError(
            argument,
            f"asks for {what}: about {format_bytes(n_bytes)} of memory, more than the {format_bytes(limit)} one "
            f"request may use on this machine ({MEMORY_FRACTION:.0%} of the {format_bytes(available_memory())} "
            "available); ask for less",
        )


def simulation_bytes(t_final: float, dt: float, n_states: int, n_outputs: int = 10, copies: int = 8) -> float:
    """Memory of one simulated run: ``t_final/dt + 1`` output samples, each stored `copies` times.

    Parameters
    ----------
    t_final, dt : float
        Horizon and output step, s.
    n_states : int
    n_outputs : int
        Other values per sample (time, torques, errors and rates).
    copies : int
        How many arrays of that size exist at once (integrator output, result, metrics,
        tables).

    Returns
    -------
    float
        Bytes.
    """
    return 8.0 * (t_final / dt + 1) * (n_states + n_outputs) * copies


def corners_bytes(n_elements: int, n_states: int) -> float:
    """Memory of an interval box's 2^N corners with one n x n closed loop each, bytes.

    Parameters
    ----------
    n_elements, n_states : int

    Returns
    -------
    float
    """
    return 8.0 * 2.0**n_elements * (n_elements + 3 * n_states**2)


def table_bytes(rows: float, columns: int = 64) -> float:
    """Memory of a results table (a campaign's), bytes, with room for one copy.

    Parameters
    ----------
    rows : float
    columns : int

    Returns
    -------
    float
    """
    return 8.0 * rows * columns * 3
