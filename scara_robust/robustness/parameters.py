"""Margins in the plant's own units: how far each physical parameter may range, and how fast.

A plant's parameter box scaled by ``s`` about the nominal,
``[p₀ − s(p₀ − lower), p₀ + s(upper − p₀)]`` (:meth:`scara_robust.UncertainPlant.scaled`),
is nested in s (the nominal stays inside), and so is its interval hull. So each certificate
holds on an interval of s, found by doubling then bisection, and reported as the certified
range of every parameter in its unit:

==============  =====  ===================================================================
method          kind   what is certified at s
==============  =====  ===================================================================
``theorem1``    lower  the paper's Theorem 1 with the design's P on the hull of the box
``vertex``      lower  the design's P at every corner of the hull (exact for the hull)
``lmi``         lower  a common P at every corner of the hull (extra ``lmi``), numpy-verified
``frozen``      upper  a frozen plant of the family (a grid point of the box) is unstable at s:
                       no certificate of any kind exists beyond
==============  =====  ===================================================================

The lower bounds hold for parameters varying arbitrarily fast within the range. For a
bounded rate, :func:`parameter_rate` bisects the largest ``|ṗ|`` (unit/s) that a
parameter-dependent Lyapunov function certifies (:func:`scara_robust.max_certified_rate`),
and :func:`parameter_switching_growth` gives the evidence from the other side: the growth
of the loop under a periodic ramp of the parameter at a given rate.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_int, check_real
from ..exceptions import ArgumentError, ArgumentValueError
from ..lyapunov.gain import Design, design_or_none
from ..lyapunov.theorem1 import certify
from ..model.plant import Parameter, UncertainPlant, require_plant
from ..results import AnalysisResult, VerdictFromCertified
from ..sdp.backends import resolve_lmi_solver
from ._spectra import StabilityScan, spectral_abscissae
from .lmi import NOT_INSTALLED, cvxpy_available, lmi_search
from .pdl import RateMargin, max_certified_rate
from .polytope import MAX_BOX_ELEMENTS, fixed_p_certifies
from .registry import AnalysisMethod, analysis_methods, get_method, register_method
from .search import bisect

__all__ = [
    "PARAMETER_METHODS",
    "parameter_margin",
    "parameter_rate",
    "parameter_switching_growth",
    "rate_bracket",
    "RateBracket",
    "frozen_end",
    "frozen_limit",
]

Array = NDArray[np.float64]
_SCALE_MAX = 1e6
_FROZEN_RATIO = 1.02
_FROZEN_RTOL = 1e-9


class _Undefined(Exception):
    """The scaled box leaves where the plant is defined."""


def _hull(plant: UncertainPlant, s: float) -> object:
    try:
        return plant.interval_model(s)
    except ArgumentError as err:
        raise _Undefined(str(err)) from err


def _theorem1(plant: UncertainPlant, design: Design | None, K: Array) -> Callable[[float], bool]:
    def ok(s: float) -> bool:
        assert design is not None
        return bool(certify(_hull(plant, s), design).certified)  # type: ignore[arg-type]

    return ok


def _vertex(plant: UncertainPlant, design: Design | None, K: Array) -> Callable[[float], bool]:
    def ok(s: float) -> bool:
        assert design is not None
        hull = _hull(plant, s)
        return fixed_p_certifies(hull.vertex_closed_loops(K), design.P)  # type: ignore[attr-defined]

    return ok


def _lmi(plant: UncertainPlant, design: Design | None, K: Array) -> Callable[[float], bool]:
    test = lmi_search()

    def ok(s: float) -> bool:
        hull = _hull(plant, s)
        return bool(test(hull.vertex_closed_loops(K)).certified)  # type: ignore[attr-defined]

    return ok


def _physical(plant: UncertainPlant, design: Design | None, K: Array) -> Callable[[float], bool]:
    def ok(s: float) -> bool:
        assert design is not None
        return fixed_p_certifies(plant.samples(theta=s).closed_loops(K), design.P)

    return ok


def _lmi_physical(plant: UncertainPlant, design: Design | None, K: Array) -> Callable[[float], bool]:
    test = lmi_search()

    def ok(s: float) -> bool:
        # cutting planes on the coarse samples, grown from the samples' most violated: P holds on both
        return bool(test(plant.samples(plant.coarse_points(), theta=s).closed_loops(K),
                         [plant.samples(theta=s).closed_loops(K)]).certified)

    return ok


def _frozen(plant: UncertainPlant, design: Design | None, K: Array) -> Callable[[float], bool]:
    scan = StabilityScan()  # the scan's nearby scales: most loops proven stable by the last scale's P

    def ok(s: float) -> bool:
        try:
            loops = plant.samples(theta=s).closed_loops(K)
        except ArgumentError as err:
            raise _Undefined(str(err)) from err
        return scan.all_stable(loops)

    return ok


for _method in (
    AnalysisMethod("theorem1", "parameter", "lower", _theorem1, "Theorem 1's Z on the interval hull",
                   frozenset({"P", "intervals"}), cheap=True),
    AnalysisMethod("vertex", "parameter", "lower", _vertex, "the design's P at the hull's corners",
                   frozenset({"P", "vertices"}), cheap=True),
    AnalysisMethod("lmi", "parameter", "lower", _lmi, "a common P at the hull's corners",
                   frozenset({"vertices", "lmi"})),
    AnalysisMethod("physical", "parameter", "lower", _physical, "the design's P on the plant's own samples",
                   frozenset({"P", "parameters"}), cheap=True),
    AnalysisMethod("lmi-physical", "parameter", "lower", _lmi_physical,
                   "a common P on the coarse samples (cutting planes), verified by numpy on the samples",
                   frozenset({"parameters", "lmi"})),
    AnalysisMethod("frozen", "parameter", "upper", _frozen, "every frozen plant of the grid stable",
                   frozenset({"parameters"}), cheap=True),
):
    register_method(_method)

#: The built-in methods of :func:`parameter_margin` and the kind of bound each gives (the
#: registry holds them: :func:`~scara_robust.analysis_methods` ``('parameter')``).
PARAMETER_METHODS: dict[str, str] = {name: get_method("parameter", name).bound
                                     for name in analysis_methods("parameter")}


#: The built-in lower bounds whose certificate holds on the frozen row's samples: none holds where one is unstable.
_BELOW_FROZEN = frozenset({"physical", "lmi-physical"})


class _Capped:
    """A lower bound's test that answers False without testing at or above `cap` (the frozen bound)."""

    def __init__(self, ok: Callable[[float], bool], cap: float) -> None:
        self.ok, self.cap, self.answered = ok, cap, 0

    def __call__(self, s: float) -> bool:
        if s >= self.cap:
            self.answered += 1
            return False
        return self.ok(s)


def _search(ok: Callable[[float], bool], tol: float, ratio: float, cap: float = math.inf) -> tuple[float, float, str]:
    """Largest s with ok(s): (lo, hi, note); hi = inf when none failed up to the cap.

    With a finite `cap` (a scale where ok is known to fail) the first test after the nominal
    point is just below it, ``cap·(1 − tol/2)``: when it holds, the search ends there.
    """
    try:
        if not ok(0.0):
            return 0.0, 0.0, "not even at the nominal point"
    except _Undefined as err:
        return 0.0, 0.0, f"undefined at the nominal point: {err}"
    if math.isfinite(cap) and cap > 0.0:
        near = cap * (1.0 - tol / 2)
        try:
            good = ok(near)
        except _Undefined:
            good = False
        if good:
            lo, hi = bisect(ok, near, cap, tol, fails=(_Undefined,), desc="parameter range")
            return lo, hi, ""
    lo, s = 0.0, 1.0
    while s <= _SCALE_MAX:
        try:
            good = ok(s)
        except _Undefined as err:
            lo, hi = bisect(ok, lo, s, tol, fails=(_Undefined,), desc="parameter range")
            return lo, hi, f"the plant is undefined beyond: {err}"
        if not good:
            lo, hi = bisect(ok, lo, s, tol, fails=(_Undefined,), desc="parameter range")
            return lo, hi, ""
        lo, s = s, s * ratio
    return lo, math.inf, f"holds up to the scale {_SCALE_MAX:g} searched"


def parameter_margin(
    plant: UncertainPlant,
    design: Design | ArrayLike,
    methods: Sequence[str] | None = None,
    *,
    tol: float = 1e-3,
) -> pd.DataFrame:
    """The largest scaling of the parameter box each method certifies, as ranges in the parameters' units.

    Parameters
    ----------
    plant : UncertainPlant
    design : Design or array_like, shape (m, n)
        A design for the plant's design form, or a plain gain K of ``u = −Kx`` (then only
        the methods that need no Lyapunov matrix: 'lmi', 'lmi-physical' and 'frozen').
    methods : sequence of str, optional
        Registered names (:func:`~scara_robust.analysis_methods` ``('parameter')``; default:
        those registered as defaults). The built-in ones, :data:`PARAMETER_METHODS`:
        'theorem1' (Z on the interval hull), 'vertex'
        (the design's P at the hull's corners), 'lmi' (a common P at the corners),
        'physical' (the design's P on the plant's own samples), 'lmi-physical' (a common P
        found by cutting planes on the coarse samples, verified by numpy on the samples), 'frozen' (every
        sample stable: an upper bound). The corner methods need at most
        2^``MAX_BOX_ELEMENTS`` corners.
    tol : float
        Relative width of the bisections on the scale (the frozen bound is bisected to
        1e-9 whatever `tol`: eigenvalues are cheap).

    Returns
    -------
    pandas.DataFrame
        One row per method: ``method``, ``kind`` ('lower' or 'upper'), ``scale`` (s; 1 is the
        plant's own box; NaN, and NaN ranges, for a lower bound that fails at the nominal
        point), ``bracket`` (the s where the answer changes), then for each varying
        parameter ``NAME low [UNIT]`` and ``NAME high [UNIT]`` (its range at s), ``seconds``
        and ``message``.

    See Also
    --------
    parameter_rate : how fast the parameters may vary.
    robustness_margin : the margin of the interval box.

    Examples
    --------
    >>> import scara_robust as sr
    >>> motor = sr.load_plant("examples/plant-dc-motor.toml")
    >>> table = sr.parameter_margin(motor, sr.design(motor, 1, 2), ["frozen"])
    >>> round(float(table["J high [kg·m²]"].iloc[0]), 4)
    0.174
    """
    K = _gain(plant, design)  # the plant's type and K's shape
    found = design_or_none(design)
    names = analysis_methods("parameter", defaults=True) if methods is None else tuple(methods)
    chosen = [get_method("parameter", name, argument="methods") for name in names]
    for entry in chosen:
        if found is None and "P" in entry.needs:
            plain = [repr(n) for n in analysis_methods("parameter") if "P" not in get_method("parameter", n).needs]
            without = ", ".join(plain[:-1]) + f" and {plain[-1]}" if len(plain) > 1 else "".join(plain)
            raise ArgumentValueError("methods", f"{entry.name!r} tests the design's Lyapunov matrix P: pass a Design, "
                                                f"or use {without} with a plain K")
    corner_methods = [m.name for m in chosen if "vertices" in m.needs]
    if corner_methods:
        n_elements = plant.interval_model().n_elements
        if n_elements > MAX_BOX_ELEMENTS:
            raise ArgumentValueError("methods", f"{corner_methods[0]!r} enumerates the 2^{n_elements} corners of the "
                                                "interval box; use 'theorem1', 'physical', 'lmi-physical' and 'frozen'")
    tol = check_real("tol", tol, positive=True)
    varying = plant.varying
    if not varying:
        raise ArgumentValueError("plant", "has no parameter with a range: there is nothing to scale")
    # the frozen row first: a P verified on the samples at a scale where one of them is unstable
    # cannot exist, so the sample-based lower searches take a failure there without a solve
    order = sorted(range(len(chosen)), key=lambda i: chosen[i].name != "frozen")
    rows: list[tuple[Any, ...]] = [()] * len(chosen)
    cap = math.inf
    for i in order:
        entry = chosen[i]
        method, kind = entry.name, entry.bound
        start = time.perf_counter()
        if "lmi" in entry.needs and not cvxpy_available():
            rows[i] = (method, kind, math.nan, "", *([math.nan] * 2 * len(varying)), 0.0, NOT_INSTALLED)
            continue
        ok = entry.run(plant, found, K)
        capped = _Capped(ok, cap if method in _BELOW_FROZEN else math.inf)
        # an upper bound tests eigenvalues only: cheap, so bisected to 1e-9 on a finer scan
        upper = kind == "upper"
        lo, hi, note = _search(capped, _FROZEN_RTOL if upper else tol, _FROZEN_RATIO if upper else 2.0, capped.cap)
        if method == "frozen" and not note:
            cap = hi
        # a lower bound that fails at the nominal point certifies no range, not the nominal point alone
        scale = (math.nan if hi == 0.0 else lo) if kind == "lower" else hi
        end = ""
        if upper and math.isfinite(hi):
            end, where = frozen_end(plant, K, hi)
            message = (f"{where} (a frozen plant of the grid, {plant.grid_values().shape[0]} points, is unstable at "
                       f"the scale hi; scan ratio x{_FROZEN_RATIO:g})")
        elif upper:
            message = "no unstable frozen plant"
        else:
            message = "certified up to lo, not at hi" if hi > 0.0 else "no range certified"
        if capped.answered or (kind == "lower" and hi >= capped.cap):
            message = f"{message} (hi is at or above the frozen bound {capped.cap:.6g}, where a sample is unstable)"
        if note:
            message = f"{message}; {note}"
        stops = _at_limits(varying, scale)
        if stops:
            message = f"{message}; {stops}"
        ranges = []
        for p in varying:
            ranges += list(_range_at(p, scale))
        rows[i] = (method, kind, scale, f"[{lo:.6g}, {hi:.6g}]", *ranges, end, time.perf_counter() - start, message)
    columns = ["method", "kind", "scale", "bracket"]
    for p in varying:
        columns += [f"{p.name} low [{p.unit}]", f"{p.name} high [{p.unit}]"]
    return pd.DataFrame(rows, columns=[*columns, "end", "seconds", "message"])


def _range_at(p: Parameter, scale: float) -> tuple[float, float]:
    """The parameter's range at the scale; at an infinite scale, what is left of it (nan when unbounded both ways)."""
    if math.isnan(scale):
        return (math.nan, math.nan)
    if math.isfinite(scale):
        return p.scaled_range(scale)
    lo, hi = p.range
    p0 = float(p.nominal)  # type: ignore[arg-type]
    if not p.scales:
        return (lo, hi)
    return (p.physical[0] if lo < p0 else lo, p.physical[1] if hi > p0 else hi)


def _at_limits(varying: Sequence[Parameter], scale: float) -> str:
    """"m stops at its physical limit 0 kg" for each parameter whose scaled range reached its limits."""
    parts = []
    for p in varying:
        side = p.at_limit(scale) if not math.isnan(scale) else ""
        ends = {"lower": [0], "upper": [1], "both": [0, 1]}.get(side, [])
        for k in (k for k in ends if math.isfinite(p.physical[k])):
            parts.append(f"{p.name} stops at its physical limit {p.physical[k]:g} {p.unit}")
    return "; ".join(parts)


def frozen_limit(margins: pd.DataFrame, parameter: Parameter) -> tuple[float, str]:
    """One parameter's frozen bound from a :func:`parameter_margin` table: its value at the end that fails.

    Parameters
    ----------
    margins : pandas.DataFrame
        A table of :func:`parameter_margin` with its ``frozen`` row.
    parameter : Parameter
        A varying parameter of the plant.

    Returns
    -------
    value : float
        Where a frozen plant becomes unstable, in the parameter's unit; nan when no end of
        its range fails (none found up to the physical limits or the search's cap).
    end : str
        ``'lower'``, ``'upper'`` or ``'none'``.
    """
    row = margins.loc[margins["method"] == "frozen"].iloc[0]
    ends = dict(item.rsplit(" ", 1) for item in str(row["end"]).split(", ") if " " in item)
    end = ends.get(parameter.name)
    if end is None:
        return math.nan, "none"
    return float(row[f"{parameter.name} {'low' if end == 'lower' else 'high'} [{parameter.unit}]"]), end


def frozen_end(plant: UncertainPlant, K: ArrayLike, scale: float) -> tuple[str, str]:
    """Which end of the scaled box holds an unstable frozen plant, named in the parameters' units.

    Parameters
    ----------
    plant : UncertainPlant
    K : array_like, shape (m, n)
        Gain of ``u = −Kx`` on the design form.
    scale : float
        A scale at which a frozen plant of the grid is unstable (the frozen bound's hi).

    Returns
    -------
    end : str
        ``"NAME lower"`` or ``"NAME upper"`` for the parameter(s) at an end of their range
        at the most unstable sample (several joined by ``", "``); ``"interior"`` when none is
        at an end; ``""`` when no sample is unstable.
    text : str
        E.g. ``"the upper end: a frozen plant is unstable above m = 2.45 kg"``.
    """
    samples = plant.samples(theta=scale)
    growth = spectral_abscissae(samples.closed_loops(K))
    if not growth.max() >= 0:
        return "", "no frozen plant of the grid is unstable"
    worst = samples.values[int(np.argmax(growth))]
    ends, words = [], []
    for p in plant.varying:
        value = float(worst[plant.names.index(p.name)])
        a, b = p.scaled_range(scale)
        if p.scales and value == a and a < float(p.nominal):  # type: ignore[arg-type]
            ends.append(f"{p.name} lower")
            words.append(f"the lower end: a frozen plant is unstable below {p.name} = {value:.6g} {p.unit}")
        elif p.scales and value == b and b > float(p.nominal):  # type: ignore[arg-type]
            ends.append(f"{p.name} upper")
            words.append(f"the upper end: a frozen plant is unstable above {p.name} = {value:.6g} {p.unit}")
    if not ends:
        at = ", ".join(f"{name} = {v:.6g} {plant.parameter(name).unit}" for name, v in zip(plant.names, worst))
        return "interior", f"a frozen plant inside the box is unstable, at {at}"
    return ", ".join(ends), "; ".join(words)


def _gain(plant: UncertainPlant, design: Design | ArrayLike) -> Array:
    """K of a Design or a plain gain, checked against the plant's design form."""
    require_plant("plant", plant)
    found = design_or_none(design)
    K = found.K if found is not None else check_array("design", design, ndim=2)
    shape = (plant.n_inputs, plant.n_design_states)
    if K.shape != shape:
        raise ArgumentValueError("design", f"must have K of shape {shape} for the plant, found {K.shape}")
    return np.asarray(K, dtype=float)


def _rate_parameter(plant: UncertainPlant, name: str | None) -> str:
    names = [p.name for p in plant.varying]
    if not names:
        raise ArgumentValueError("plant", "has no parameter with a range: no rate to bound")
    if name is None:
        rated = [p.name for p in plant.varying if p.rate is not None]
        return rated[0] if rated else names[-1]
    check_choice("name", name, tuple(names))
    return name


def parameter_rate(
    plant: UncertainPlant,
    design: Design | ArrayLike,
    name: str | None = None,
    *,
    rate_max: float | None = None,
    tol: float = 1e-2,
    solver: str | None = None,
) -> RateMargin:
    """The largest rate ``|ṗ|`` (unit/s) of parameter `name` that an affine ``P(p)`` certifies.

    The frozen closed loops on the parameter's coarse grid (the other parameters on
    theirs, varying arbitrarily) enter :func:`scara_robust.max_certified_rate`; every
    answer is verified with numpy on the default grid refined once.

    Parameters
    ----------
    plant : UncertainPlant
    design : Design or array_like, shape (m, n)
        The design, or a plain gain K of ``u = −Kx`` on the design form.
    name : str, optional
        The rate-bounded parameter (default: the first with a ``rate``, else the last
        varying one).
    rate_max : float, optional
        Largest rate tried, unit/s (default 1e6 times the parameter's range).
    tol : float
        Relative width of the final bracket.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    RateMargin
        ``rate`` in the parameter's unit per second; ``inf`` when a common P certifies
        any rate.

    See Also
    --------
    rate_bracket : the certified rate and a rate that destabilizes.
    rate_bounded_certificate : the test behind it.
    """
    solver = resolve_lmi_solver(solver)
    K = _gain(plant, design)
    key = _rate_parameter(plant, name)
    width = plant.parameter(key).range[1] - plant.parameter(key).range[0]
    cap = 1e6 * width if rate_max is None else check_real("rate_max", rate_max, positive=True)
    coarse = plant.samples(plant.coarse_points())
    fine = plant.samples(plant.fine_points())
    return max_certified_rate(coarse.closed_loops(K), coarse.column(key),
                              check=(fine.closed_loops(K), fine.column(key)), rate_max=cap, tol=tol,
                              solver=solver)


def parameter_switching_growth(
    plant: UncertainPlant,
    K: Array,
    name: str,
    rate: float,
    *,
    hold_high: float = 0.0,
    hold_low: float = 0.0,
    at: dict[str, float] | None = None,
    n_ramp: int = 100,
) -> float:
    """Floquet growth rate (1/s) of the loop under a periodic ramp of one parameter at `rate`.

    One period holds the parameter at its upper end for `hold_high`, ramps it down to the
    lower end at ``−rate``, holds it for `hold_low` and ramps back up; the other parameters
    stay at `at` (default: nominal). Each ramp is `n_ramp` steps held at their midpoints.
    A positive growth rate means ‖x‖ grows without bound, so no certificate exists for
    that rate: the upper side of :func:`parameter_rate`.

    Parameters
    ----------
    plant : UncertainPlant
    K : array_like, shape (m, n)
        Gain of ``u = −Kx`` on the design form.
    name : str
        The parameter ramped.
    rate : float
        |ṗ| on the ramps, unit/s (> 0).
    hold_high, hold_low : float
        Dwell at each end, s (>= 0).
    at : dict, optional
        Values of the other parameters.
    n_ramp : int
        Steps per ramp (>= 1).

    Returns
    -------
    float
        The growth rate, 1/s.
    """
    K = _gain(plant, K)
    key = _rate_parameter(plant, name)
    rate = check_real("rate", rate, positive=True)
    hold_high = check_real("hold_high", hold_high, nonnegative=True)
    hold_low = check_real("hold_low", hold_low, nonnegative=True)
    n_ramp = check_int("n_ramp", n_ramp, 1)
    lo, hi = plant.parameter(key).range
    point = {**plant.nominal, **(at or {})}
    values = np.linspace(lo, hi, 2 * n_ramp + 1)
    grid = np.array([[v if n == key else point[n] for n in plant.names] for v in values])
    A, B = plant.plant_matrices(grid)
    A_aug, B_aug = plant.design_form(A, B)
    closed = A_aug - B_aug @ np.asarray(K, dtype=float)
    size = closed.shape[1]
    step = scipy.linalg.expm(closed[1::2] * ((hi - lo) / n_ramp / rate))
    down = np.eye(size)
    for E in step[::-1]:
        down = E @ down
    up = np.eye(size)
    for E in step:
        up = E @ up
    period = up @ scipy.linalg.expm(closed[0] * hold_low) @ down @ scipy.linalg.expm(closed[-1] * hold_high)
    duration = hold_high + hold_low + 2 * (hi - lo) / rate
    return float(np.log(np.abs(np.linalg.eigvals(period)).max()) / duration)


@dataclass(frozen=True)
class RateBracket(VerdictFromCertified, AnalysisResult):
    """How fast a parameter may vary: a certified rate below, a growing variation above.

    Attributes
    ----------
    parameter : str
    rate : float
        Largest certified ``|ṗ|``, unit/s (``inf``: a common P certifies any rate; nan:
        not even a frozen parameter is certified).
    unstable : float
        Smallest rate found at which a periodic ramp between the range's ends makes the
        loop grow, unit/s (``inf`` when none was found on the scan).
    margin : RateMargin
        The certificate's details.
    seconds : float
    message : str
    """

    parameter: str
    rate: float
    unstable: float
    margin: RateMargin
    seconds: float
    message: str

    @property
    def certified(self) -> bool | None:
        """True when some rate is certified (ν = 0, a frozen parameter, at least), else None."""
        return None if math.isnan(self.rate) else True


def rate_bracket(
    plant: UncertainPlant,
    design: Design | ArrayLike,
    name: str | None = None,
    *,
    scan_ratio: float = 1.25,
    scan_span: float = 1e3,
    tol: float = 1e-2,
) -> RateBracket:
    """Bracket the largest tolerated rate of a parameter (unit/s): certificate below, growth above.

    The lower end is :func:`parameter_rate`. Above it, rates ``ν·scan_ratio^k`` up to
    ``scan_span·ν`` are tried with :func:`parameter_switching_growth` (the parameter ramping
    between its range's ends, with no dwell and with dwells of one and four ramp times, the
    other parameters at their nominal): the first rate with a positive growth rate is the
    upper end. The scan is a search, so the upper end is valid, not tight.

    Parameters
    ----------
    plant : UncertainPlant
    design : Design or array_like, shape (m, n)
        The design, or a plain gain K.
    name : str, optional
        As for :func:`parameter_rate`.
    scan_ratio : float
        Ratio between scanned rates (> 1).
    scan_span : float
        How far above the certified rate the scan goes (> 1).
    tol : float
        Relative width of the certificate's bisection.

    Returns
    -------
    RateBracket
    """
    start = time.perf_counter()
    K = _gain(plant, design)
    key = _rate_parameter(plant, name)
    scan_ratio = check_real("scan_ratio", scan_ratio, minimum=1.0 + 1e-9)
    scan_span = check_real("scan_span", scan_span, minimum=1.0 + 1e-9)
    margin = parameter_rate(plant, K, key, tol=tol)
    lower = margin.rate
    if margin.certificate is None and not math.isinf(lower):
        return RateBracket(key, math.nan, math.nan, margin, time.perf_counter() - start, margin.message)
    if math.isinf(lower):
        return RateBracket(key, math.inf, math.inf, margin, time.perf_counter() - start,
                           "a common quadratic P certifies the whole range at any rate")
    lo, hi = plant.parameter(key).range
    base = max(lower, 1e-12 * (hi - lo))
    rate = base * scan_ratio
    while rate <= base * scan_span:
        ramp = (hi - lo) / rate
        if any(parameter_switching_growth(plant, K, key, rate, hold_high=h, hold_low=h) > 0
               for h in (0.0, ramp, 4 * ramp)):
            return RateBracket(key, lower, rate, margin, time.perf_counter() - start,
                               f"{margin.message}; a periodic ramp between {lo:.6g} and {hi:.6g} at the upper rate "
                               "grows (Floquet)")
        rate *= scan_ratio
    return RateBracket(key, lower, math.inf, margin, time.perf_counter() - start,
                       f"{margin.message}; no growing periodic ramp found up to {scan_span:g} x the certified rate")
