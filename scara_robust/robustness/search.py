"""The one bisection behind every margin: the scaling θ, a parameter's range, a rate, a sample time.

Every search of the package looks for the end of an interval on which a test holds: the
largest θ (or scale, rate ν, sample time Ts) that a certificate still proves, or the
smallest at which a frozen plant is unstable. Each starts from a bracket ``[lo, hi]`` with
``ok(lo)`` true and ``ok(hi)`` false and shrinks it with :func:`bisect` until
``hi − lo <= rtol·hi``. Searches differ only in where they split the bracket
(:data:`MIDPOINTS`: the arithmetic mean for a scale, the geometric mean for a sample time,
a first step close to zero for a margin that may be tiny) and when they give up (a floor below
which the answer means nothing).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from .._progress import steps
from .._validation import check_choice, check_real

__all__ = ["bisect", "MIDPOINTS"]


def _arithmetic(lo: float, hi: float, rtol: float) -> float:
    return 0.5 * (lo + hi)


def _geometric(lo: float, hi: float, rtol: float) -> float:
    return math.sqrt(lo * hi)


def _near_zero(lo: float, hi: float, rtol: float) -> float:
    # from lo = 0 a margin may be tiny: probe 1e-3·hi first, then halve
    if lo > 0:
        return 0.5 * (lo + hi)
    mid = hi * 1e-3 if hi > 1e-3 else 0.5 * hi
    return 0.5 * hi if mid <= rtol * hi else mid


def _eighth(lo: float, hi: float, rtol: float) -> float:
    # from lo = 0 a relative width cannot be reached by halving: shrink by 8 until certified
    return 0.5 * (lo + hi) if lo > 0 else hi / 8


#: Where :func:`bisect` splits ``[lo, hi]``, by name: ``(lo, hi, rtol) -> mid``.
MIDPOINTS: dict[str, Callable[[float, float, float], float]] = {
    "arithmetic": _arithmetic,
    "geometric": _geometric,
    "near-zero": _near_zero,
    "eighth": _eighth,
}


def bisect(
    ok: Callable[[float], bool],
    lo: float,
    hi: float,
    rtol: float,
    *,
    midpoint: str = "arithmetic",
    fails: tuple[type[Exception], ...] = (),
    stop: Callable[[float, float, float], bool] | None = None,
    desc: str = "bisection",
    first: float | None = None,
) -> tuple[float, float]:
    """Shrink ``[lo, hi]``, with ``ok(lo)`` true and ``ok(hi)`` false, to a relative width `rtol`.

    Parameters
    ----------
    ok : callable ``ok(x) -> bool``
        The test, monotone on the bracket (true below the end, false above).
    lo, hi : float
        The bracket, ``0 <= lo < hi`` (same unit as x: θ, a scale, 1/s, s, ...).
    rtol : float
        Stop when ``hi − lo <= rtol·hi`` (> 0).
    midpoint : str
        A key of :data:`MIDPOINTS`.
    fails : tuple of exception types
        Exceptions of `ok` that count as a failed test (x where the plant is undefined).
    stop : callable ``stop(lo, hi, mid) -> bool``, optional
        Stop before testing `mid` when it returns True (a bracket below which the answer
        means nothing, e.g. a rate under 1e-12 of the largest searched).
    desc : str
        What is searched, for the progress a front end shows (on stderr, at a terminal).
    first : float, optional
        The first x tested, instead of the midpoint, when it lies inside the bracket: just
        below an upper bound the answer is expected near (``hi·(1 − rtol/2)``: one test
        ends the search when it holds, one test more than the bisection when it fails).

    Returns
    -------
    lo, hi : float
        The final bracket: `ok` held at lo (or lo is the given one), failed at hi.

    Examples
    --------
    >>> lo, hi = bisect(lambda x: x * x < 2.0, 1.0, 2.0, 1e-9)
    >>> round(lo, 6), round(hi, 6)
    (1.414214, 1.414214)
    """
    check_choice("midpoint", midpoint, tuple(MIDPOINTS))
    rtol = check_real("rtol", rtol, positive=True)
    split = MIDPOINTS[midpoint]
    # the steps a halving bisection takes to the width asked: the bar's estimate of what remains
    expected = max(1, math.ceil(math.log2(max((hi - lo) / (rtol * hi), 1.0)))) if hi > 0 else None
    bar = steps(desc, expected, unit="test")
    try:
        while hi - lo > rtol * hi:
            mid = split(lo, hi, rtol)
            if first is not None and lo < first < hi:
                mid, first = first, None
            if stop is not None and stop(lo, hi, mid):
                break
            try:
                good = ok(mid)
            except fails:
                good = False
            if good:
                lo = mid
            else:
                hi = mid
            bar.update(1)
            bar.set_postfix_str(f"[{lo:.4g}, {hi:.4g}]")
    finally:
        bar.close()
    return lo, hi
