"""Private validation helpers shared by every public function.

Each helper names the offending argument in backticks, says what was expected and
what was found, and raises `ValueError` (bad value or shape) or `TypeError` (bad type).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__: list[str] = []


def _describe(value: Any) -> str:
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
        raise TypeError(f"`{name}` must be a real number, found {type(value).__name__} {_describe(value)}")
    out = float(value)
    if not np.isfinite(out):
        raise ValueError(f"`{name}` must be finite, found {out}")
    if positive and out <= 0.0:
        raise ValueError(f"`{name}` must be > 0, found {out}")
    if nonnegative and out < 0.0:
        raise ValueError(f"`{name}` must be >= 0, found {out}")
    if minimum is not None and out < minimum:
        raise ValueError(f"`{name}` must be >= {minimum}, found {out}")
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
        raise TypeError(f"`{name}` must be a real array, found {_describe(value)}") from err
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"`{name}` must have {ndim} dimension(s), found shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"`{name}` must have shape {want}, found shape {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise ValueError(f"`{name}` must contain only finite values, found NaN or inf")
    return arr


def check_int(name: str, value: Any, minimum: int) -> int:
    """Return `value` as an int if it is an integer >= `minimum` (not a bool), else raise naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"`{name}` must be an integer >= {minimum}, found {value!r}")
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
        raise ValueError(
            f"`{name}` must be symmetric, found max |{name} - {name}ᵀ| = {gap:.3g} (relative {gap / scale:.1e})"
        )
    return np.asarray(0.5 * (arr + arr.T), dtype=float)


def check_choice(name: str, value: Any, choices: Sequence[str]) -> str:
    """Return `value` if it is one of `choices`, else raise listing them."""
    if not isinstance(value, str) or value not in choices:
        valid = ", ".join(repr(c) for c in choices)
        raise ValueError(f"`{name}` must be one of {valid}, found {_describe(value)}")
    return value


def check_callable(name: str, value: Any) -> Any:
    """Return `value` if it is callable, else raise naming `name`."""
    if not callable(value):
        raise TypeError(f"`{name}` must be callable, found {type(value).__name__}")
    return value
