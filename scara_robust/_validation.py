"""Private validation helpers, the one place where arguments and file fields are checked.

Each helper names the offending argument (or file and field) in backticks, says what was
expected and what was found, and raises :class:`~scara_robust.exceptions.ArgumentValueError`
(bad value or shape) or :class:`~scara_robust.exceptions.ArgumentTypeError` (bad type) for
arguments, and :class:`~scara_robust.exceptions.InputFileError` (or the subclass the caller
passes) for fields of a file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .exceptions import ArgumentTypeError, ArgumentValueError, InputFileError

__all__: list[str] = []


def describe(value: Any) -> str:
    """``repr(value)``, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_real(
    name: str,
    value: Any,
    *,
    positive: bool = False,
    nonnegative: bool = False,
    minimum: float | None = None,
) -> float:
    """Return `value` as a finite float, or raise naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ArgumentTypeError(name, f"must be a real number, found {type(value).__name__} {describe(value)}")
    out = float(value)
    if not np.isfinite(out):
        raise ArgumentValueError(name, f"must be finite, found {out}")
    if positive and out <= 0.0:
        raise ArgumentValueError(name, f"must be > 0, found {out}")
    if nonnegative and out < 0.0:
        raise ArgumentValueError(name, f"must be >= 0, found {out}")
    if minimum is not None and out < minimum:
        raise ArgumentValueError(name, f"must be >= {minimum}, found {out}")
    return out


def check_array(
    name: str,
    value: Any,
    *,
    shape: Sequence[int | None] | None = None,
    ndim: int | None = None,
    finite: bool = True,
) -> NDArray[np.float64]:
    """Return `value` as a float array of the given shape (``None`` = any size)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ArgumentTypeError(name, f"must be a real array, found {describe(value)}") from err
    if ndim is not None and arr.ndim != ndim:
        raise ArgumentValueError(name, f"must have {ndim} dimension(s), found shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
            raise ArgumentValueError(name, f"must have shape {want}, found shape {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise ArgumentValueError(name, "must contain only finite values, found NaN or inf")
    return arr


def check_closed_loops(name: str, value: Any) -> NDArray[np.float64]:
    """Return `value` as a stack of square matrices, shape (V >= 1, n, n), or raise naming `name`."""
    arr = check_array(name, value, ndim=3)
    if arr.shape[0] == 0 or arr.shape[1] != arr.shape[2] or arr.shape[1] == 0:
        raise ArgumentValueError(name, f"must have shape (V >= 1, n, n), found {arr.shape}")
    return arr


def check_int(name: str, value: Any, minimum: int) -> int:
    """Return `value` as an int >= `minimum`; a non-integer type (or a bool) is a type error."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ArgumentTypeError(name, f"must be an integer >= {minimum}, found {type(value).__name__} {value!r}")
    if value < minimum:
        raise ArgumentValueError(name, f"must be an integer >= {minimum}, found {value!r}")
    return int(value)


def check_symmetric(name: str, value: Any, rtol: float = 1e-8) -> NDArray[np.float64]:
    """Return the symmetric part of a square matrix that is symmetric up to `rtol`, else raise.

    Rounding-level asymmetry is removed; anything larger is refused rather than
    silently symmetrized, since the caller assumed a symmetric matrix.
    """
    arr = np.asarray(value, dtype=float)
    scale = max(float(np.abs(arr).max()), 1e-300)
    gap = float(np.abs(arr - arr.T).max())
    if gap > rtol * scale:
        raise ArgumentValueError(
            name, f"must be symmetric, found max |{name} - {name}ᵀ| = {gap:.3g} (relative {gap / scale:.1e})"
        )
    return np.asarray(0.5 * (arr + arr.T), dtype=float)


def check_per_item(name: str, value: Any, m: int, item: str = "torque") -> NDArray[np.float64]:
    """`value` as one float per item, shape (m,): a scalar (or one value) for all, or m values."""
    arr = check_array(name, value)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size not in (1, m)):
        found = f"{arr.size} values" if arr.ndim == 1 else f"shape {arr.shape}"
        raise ArgumentValueError(name, f"must be one value or one per {item} ({m}), found {found}")
    return np.broadcast_to(arr, (m,)).astype(float)


def check_choice(name: str, value: Any, choices: Sequence[str]) -> str:
    """Return `value` if it is one of `choices`, else raise listing them."""
    if not isinstance(value, str) or value not in choices:
        valid = ", ".join(repr(c) for c in choices)
        raise ArgumentValueError(name, f"must be one of {valid}, found {describe(value)}")
    return value


def check_callable(name: str, value: Any) -> Any:
    """Return `value` if it is callable, else raise naming `name`."""
    if not callable(value):
        raise ArgumentTypeError(name, f"must be callable, found {type(value).__name__}")
    return value


def check_instance(name: str, value: Any, cls: type | tuple[type, ...], what: str) -> Any:
    """Return `value` if it is an instance of `cls`, else raise saying it must be `what`."""
    if not isinstance(value, cls):
        raise ArgumentTypeError(name, f"must be {what}, found {type(value).__name__}")
    return value


# -- fields of a file -------------------------------------------------------------------


def field_number(
    where: str,
    field: str,
    value: Any,
    unit: str,
    *,
    error: type[InputFileError] = InputFileError,
    allow_inf: bool = False,
) -> float:
    """Return a file field as a float, or raise `error` naming `where`, the field and its unit.

    Parameters
    ----------
    where : str
        What the message starts with: the file (``"'robot.toml':"``) or the spec.
    field : str
        Dotted field name, e.g. ``'robot.m1'``.
    value : any
        The value read.
    unit : str
        The field's unit, e.g. ``'kg'``.
    error : type
        The exception class to raise.
    allow_inf : bool
        Accept ``+inf`` (a field where infinity means "none").

    Returns
    -------
    float
    """
    # a dimensionless field ('-', '1' or none) is "a finite number", not "a finite number in -"
    what = "a finite number" + ("" if unit in ("", "-", "1") else f" in {unit}")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise error(f"{where} field `{field}` must be {what}, found {describe(value)}")
    out = float(value)
    if math.isnan(out) or (math.isinf(out) and not (allow_inf and out > 0)):
        raise error(f"{where} field `{field}` must be {what}, found {out}")
    return out


def field_table(
    where: str,
    data: Mapping[str, Any],
    key: str,
    allowed: Mapping[str, str],
    *,
    error: type[InputFileError] = InputFileError,
) -> dict[str, Any]:
    """The sub-table `key` of `data` (empty if absent), refusing fields not in `allowed`.

    Parameters
    ----------
    where : str
        The file, as the message should name it.
    data : mapping
        The file's top-level table.
    key : str
        Name of the sub-table.
    allowed : mapping of str to str
        Allowed field names and their units.
    error : type
        The exception class to raise.

    Returns
    -------
    dict
    """
    where = where.rstrip(":")  # a caller's "'F.toml':" reads as the file, once
    table = data.get(key, {})
    if not isinstance(table, Mapping):
        raise error(f"{where}: `{key}` must be a table, found {describe(table)}")
    for name in table:
        if name not in allowed:
            raise error(f"{where}: unknown field `{key}.{name}`; valid: {', '.join(f'{key}.{n}' for n in allowed)}")
    return dict(table)


def os_error_text(err: OSError) -> str:
    """What went wrong with a file, without its path: ``'No such file or directory'``.

    Some libraries raise ``FileNotFoundError(path)`` with no ``strerror``; that still reads
    as the missing file it is.

    Parameters
    ----------
    err : OSError

    Returns
    -------
    str
    """
    if err.strerror:
        return str(err.strerror)
    if isinstance(err, FileNotFoundError):
        return "No such file or directory"
    return str(err) or type(err).__name__
