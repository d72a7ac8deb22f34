"""How much uncertainty does a design tolerate? Robustness margins by scaling the uncertainty set.

The margin θ of a design is the largest scaling of its uncertainty set for which a method
still certifies. θ scales about an **anchor**: by default the design plant at the box's
lower corner, every element range ``[θ·l_j, θ·u_j]`` (a polytope: vertices
``A₀ + θ(A_i − A₀)``), the paper's convention; with ``anchor='center'`` about the set's
centre, ``[c_j − θw_j/2, c_j + θw_j/2]``. Both are the set itself at θ = 1, and they
differ elsewhere: a margin is only meaningful with its anchor. Each certificate gives a **lower** bound on the true
margin (the largest θ with robust stability); instability gives **upper** bounds:

==============  =====  ==========================================================================
method          kind   how
==============  =====  ==========================================================================
``theorem1``    lower  exact: Z(θ) = Z₀ + θZ₁ is affine in θ and Z₀ = −2Q ≺ 0, so the certified θ
                       form an interval whose end is a generalized eigenvalue (no bisection)
``vertex``      lower  exact: the design's P at every vertex, each affine in θ, the least end
``lmi``         lower  bisection on θ with the common-P LMI (extra ``lmi``); the feasible θ are an
                       interval when the scaled boxes are nested (every [l_j, u_j] holds 0). Only a
                       numpy-verified P moves the lower end; any other answer moves the upper end,
                       and the message says whether the answer there was a proven infeasibility
``frozen``      upper  the smallest θ found where a frozen vertex is unstable: beyond it no
                       certificate of any kind exists (a geometric scan, ratio
                       :data:`FROZEN_SCAN_RATIO`, then bisection to :data:`FROZEN_RTOL`; its message states
                       the scan's resolution)
``falsifier``   upper  the smallest θ found with a destabilizing switching signal (bisection;
                       the falsifier is a search, so this bound is valid, not tight)
==============  =====  ==========================================================================

:func:`margin_table` runs them all and reports the bracket [best lower, best upper];
:func:`scara_robust.parameter_margin` answers in the units of a plant's parameters, and
:func:`scara_robust.payload_margin` the robot's version in kilograms of payload.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from tqdm import tqdm

from .._deprecation import renamed_field
from .._validation import check_choice, check_int, check_real
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..lyapunov.gain import Design, as_design
from ..lyapunov.theorem1 import affine_margin, theorem1_scaling
from ..model.plant import as_model
from ..model.polytopic import PolytopicModel
from ..model.uncertain import ANCHORS, ELEMENT_SETS, UncertainLTVModel
from ..results import AnalysisResult, VerdictFromCertified, verdict_of
from ._spectra import StabilityScan
from .falsifier import falsify
from .lmi import NOT_INSTALLED, cvxpy_available, lmi_search
from .registry import AnalysisMethod, analysis_methods, checked_result, get_method, register_method
from .search import bisect

__all__ = ["Margin", "MARGIN_METHODS", "MARGIN_TOL", "robustness_margin", "margin_table"]

Array = NDArray[np.float64]
Model = UncertainLTVModel | PolytopicModel

#: Default relative tolerance of the bisections.
MARGIN_TOL = 1e-3
_THETA_MAX = 1e6


@dataclass(frozen=True)
class Margin(VerdictFromCertified, AnalysisResult):
    """A robustness margin: a bound on the largest tolerated scaling of the uncertainty set.

    Attributes
    ----------
    method : str
        A key of :data:`MARGIN_METHODS`.
    bound : {'lower', 'upper'}
        A lower bound (certified up to `theta`) or an upper bound (unstable at `theta`).
    theta : float
        The bound: the scaling of every element range about the nominal (``inf`` when no
        instability was found; 0 when not even the nominal is certified).
    bracket : tuple of float
        ``(lo, hi)`` where the method's answer changes: certified at lo, not at hi
        (equal for the exact methods).
    seconds : float
    message : str
    """

    method: str
    bound: str
    theta: float
    bracket: tuple[float, float]
    seconds: float
    message: str

    kind = renamed_field("kind", "bound")

    @property
    def certified(self) -> bool | None:
        """Whether the bound settles the set as given (θ = 1): a lower bound θ >= 1 certifies it, an
        upper bound θ <= 1 disproves it; otherwise None."""
        if self.bound == "lower":
            return True if self.theta >= 1 else None
        return False if self.theta <= 1 else None

    @property
    def verdict(self) -> str:
        """``'certified'``, ``'not certified'`` or ``'unknown'`` at θ = 1; ``'not installed'`` without cvxpy."""
        return NOT_INSTALLED if self.message == NOT_INSTALLED else verdict_of(self.certified)


def _closed_loops(model: Model, design: Design, theta: float, anchor: str = "lower") -> Array:
    return model.scaled(theta, anchor).vertex_closed_loops(design.K)


def _unstable(model: Model, design: Design, theta: float, anchor: str = "lower") -> bool:
    return bool(np.linalg.eigvals(_closed_loops(model, design, theta, anchor)).real.max() > 0)


def _theorem1(model: Model, design: Design, elements: str, anchor: str) -> tuple[float, str]:
    if "intervals" not in model.capabilities:
        raise ArgumentValueError("method", "'theorem1' needs interval elements; use model.box_hull() or 'vertex'")
    theta = float(affine_margin(*theorem1_scaling(model, design, elements, anchor)))
    return theta, "exact: generalized eigenvalue of Z(θ) = Z₀ + θZ₁"


def _vertex(model: Model, design: Design, elements: str, anchor: str) -> tuple[float, str]:
    """The design's P at every vertex: each vertex's closed loop is ``Ā + C + θ·D_v``, affine in θ."""
    P = design.P
    C, D = model.affine_vertex_loops(design.K, elements, anchor)
    where = f"{len(D)} vertices of the {model.kind}"
    PA = P @ (model.A - model.B @ design.K + C)  # the set's own nominal loop
    base = PA + PA.T
    S = P @ D + np.swapaxes(D, -1, -2) @ P
    theta = float(affine_margin(np.broadcast_to(base, S.shape), S).min())
    return theta, f"exact: the design's P at the {where}, each affine in θ"


#: Ratio between successive θ of the frozen scan: an interval of instability narrower than
#: this (relative) between two scanned θ can be missed, and the message says so.
FROZEN_SCAN_RATIO = 1.02
#: Relative width to which the frozen bound is bisected, whatever `tol` (eigenvalues are
#: cheap), so the bound does not depend on where the scan started.
FROZEN_RTOL = 1e-9


def _frozen(model: Model, design: Design, lo: float, anchor: str = "lower") -> tuple[float, tuple[float, float], str]:
    """Scan θ geometrically from `lo` (a certified θ, or 0) until a frozen vertex is unstable, then bisect.

    Below the design P's exact vertex margin every frozen vertex is stable (P proves it), so
    the scan starts there when that is further than `lo`.
    """
    proven = _vertex(model, design, "all", anchor)[0]
    if math.isinf(proven):
        return math.inf, (math.inf, math.inf), "the design's P certifies every θ, so no frozen vertex is unstable"
    start = max(lo, proven, 1e-6)
    # the vertices keep their order across θ: a vertex's Lyapunov matrix at one θ mostly proves it at the next
    scan = StabilityScan(strict=False)

    def unstable(t: float) -> bool:
        return not scan.all_stable(_closed_loops(model, design, t, anchor))

    theta, prev = start, lo
    while theta <= _THETA_MAX:
        if unstable(theta):
            lo_, hi_ = bisect(lambda t: not unstable(t), prev, theta, FROZEN_RTOL, midpoint="near-zero")
            return hi_, (lo_, hi_), (
                f"a frozen vertex is unstable at θ = hi; scanned from θ = {start:.4g} in steps of "
                f"x{FROZEN_SCAN_RATIO:g}, so a window of instability narrower than "
                f"{100 * (FROZEN_SCAN_RATIO - 1):g} % below hi could be missed")
        prev, theta = theta, theta * FROZEN_SCAN_RATIO
    return math.inf, (prev, math.inf), (f"every frozen vertex is stable on a scan from θ = {start:.4g} to "
                                        f"{_THETA_MAX:g} in steps of x{FROZEN_SCAN_RATIO:g}")


def robustness_margin(
    model: Model,
    design: Design | ArrayLike,
    method: str = "theorem1",
    *,
    elements: str = "all",
    tol: float = MARGIN_TOL,
    lower: float = 0.0,
    upper: float | None = None,
    falsifier_tries: int = 10,
    seed: int = 0,
    anchor: str = "lower",
) -> Margin:
    """One robustness margin of a design (see the module's table).

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
        The uncertainty set at θ = 1.
    design : Design or array_like, shape (m, n)
        A design, or a gain K of your own (``u = −Kx``), taken as
        ``Design.from_gain(model, K)``: Theorem 1 and the vertex test then use the P of
        ``PĀ + ĀᵀP = −2I``; the other methods do not depend on P.
    method : {'theorem1', 'vertex', 'lmi', 'frozen', 'falsifier'}
    elements : {'all', 'A', 'B'}
        For ``theorem1`` and ``vertex`` on an interval model: which elements vary (the
        others held at ``θ·lower``).
    tol : float
        Relative tolerance of the LMI and falsifier bisections (> 0); the exact methods
        ignore it, and the frozen bound is bisected to :data:`FROZEN_RTOL`.
    lower, upper : float
        A θ known to be certified (``lmi``, ``falsifier`` start there) and one known to be
        unstable (``lmi``, ``falsifier``; default: the ``frozen`` bound).
    falsifier_tries : int
        Trajectories per falsifier call.
    seed : int
        Falsifier seed.
    anchor : {'lower', 'center'}
        What θ scales the set about: ``'lower'`` (the paper's convention and the default:
        every range ``[θ·l_j, θ·u_j]`` from the design plant) or ``'center'`` (the set's
        centre; needs ``elements='all'``). See :meth:`UncertainLTVModel.scaled`.

    Returns
    -------
    Margin

    Raises
    ------
    ArgumentValueError
        For an unknown method, ``tol <= 0``, a model without uncertain elements, or
        ``theorem1`` on a polytope.

    See Also
    --------
    margin_table : every method's margin side by side.
    parameter_margin : the margin in the plant's parameters and units.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> box = sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
    ...                            (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))
    >>> round(sr.robustness_margin(box, sr.design(box, 1.0, 2.0), "vertex").theta, 4)
    1.5842
    """
    model = as_model("model", model)
    design = as_design(model, design)
    entry = get_method("margin", method)
    check_choice("elements", elements, ELEMENT_SETS)
    check_choice("anchor", anchor, ANCHORS)
    if anchor == "center" and elements != "all":
        raise ArgumentValueError("elements", f"must be 'all' with anchor 'center', found {elements!r}")
    tol = check_real("tol", tol, positive=True)
    lower = check_real("lower", lower, nonnegative=True)
    falsifier_tries = check_int("falsifier_tries", falsifier_tries, 1)
    if model.is_fixed:
        raise ArgumentValueError("model", "has no uncertain elements: there is nothing to scale")
    model.subset(elements)  # a polytope takes 'all' only
    start = time.perf_counter()
    if "upper" in entry.needs:
        upper = (_frozen(model, design, lower, anchor)[0] if upper is None
                 else check_real("upper", upper, positive=True))
    result = checked_result(entry, entry.run(model, design, elements=elements, anchor=anchor, lower=lower,
                                             upper=upper, tol=tol, falsifier_tries=falsifier_tries, seed=seed))
    if not isinstance(result, Margin):
        raise ArgumentTypeError("method", f"{method!r} returned a {type(result).__name__}, not a Margin")
    return replace(result, method=method, bound=entry.bound, seconds=time.perf_counter() - start)


def _lmi_margin(
    model: Model, design: Design, lo: float, hi: float, tol: float, anchor: str = "lower"
) -> tuple[float, tuple[float, float], str]:
    """Bisect the common-P LMI on θ, trusting only numpy-verified P and proven infeasibility.

    Only a numpy-verified P moves the lower end. Any other answer moves the upper end of
    the search, but only a solver's proof of infeasibility (or an unstable frozen vertex)
    is reported as infeasible: an inaccurate or unknown answer is named as such.
    """
    if not cvxpy_available():
        return math.nan, (math.nan, math.nan), NOT_INSTALLED
    answers: dict[float, str] = {}
    test = lmi_search()  # the vertices keep their order across θ: each solve starts from the last active set

    def at(theta: float) -> str:
        answers[theta] = test(_closed_loops(model, design, theta, anchor)).verdict
        return answers[theta]

    if lo > 0 and at(lo) != "certified":
        lo = 0.0  # the hint from another method does not hold for the LMI: start from the nominal
        if at(lo) != "certified":
            return 0.0, (0.0, 0.0), f"no verified common quadratic P even for the nominal (θ = 0): {answers[0.0]}"
    if math.isinf(hi):
        hi = max(2 * lo, 1.0)
        while at(hi) == "certified":
            if hi >= _THETA_MAX:
                return hi, (hi, math.inf), f"common quadratic P verified up to θ = {hi:g}, the largest searched"
            lo, hi = hi, 2 * hi
    elif _unstable(model, design, hi, anchor):
        answers[hi] = "infeasible"
    elif at(hi) == "certified":
        return hi, (hi, hi), f"common quadratic P verified at θ = {hi:g} (the upper end given)"
    lo, hi = bisect(lambda t: at(t) == "certified", lo, hi, tol, desc="margin θ")
    proven = min((t for t, v in answers.items() if v == "infeasible"), default=math.inf)
    message = f"common quadratic P verified with numpy at lo = {lo:.6g}; at hi = {hi:.6g} the LMI is {answers[hi]}"
    if answers[hi] != "infeasible":
        message += (" (neither certified nor proven infeasible)"
                    + (f"; infeasibility is proven from θ = {proven:.6g}" if math.isfinite(proven)
                       else "; infeasibility is proven nowhere searched"))
    return lo, (lo, hi), message


def _falsifier_margin(
    model: Model, design: Design, lo: float, hi: float, tol: float, tries: int, seed: int, anchor: str = "lower"
) -> tuple[float, tuple[float, float], str]:
    def found(theta: float) -> bool:
        return falsify(_closed_loops(model, design, theta, anchor), design.P, n_tries=tries, seed=seed).found

    if math.isinf(hi):
        return math.inf, (lo, math.inf), "no frozen instability to start from; no switching signal searched"
    top = hi
    while not found(hi):  # the falsifier needs growth by 10 within its horizon: look further out
        lo, hi = hi, 2 * hi
        if hi > 8 * top:
            return math.inf, (lo, math.inf), f"no destabilizing switching signal found up to θ = {lo:g}"
    lo, hi = bisect(lambda t: not found(t), lo, hi, tol, midpoint="near-zero")
    return hi, (lo, hi), "a destabilizing switching signal found at θ = hi (none found at lo)"


def _result(theta: float, bracket: tuple[float, float], message: str) -> Margin:
    # robustness_margin fills in the method, its bound and the time
    return Margin("", "", float(theta), (float(bracket[0]), float(bracket[1])), 0.0, message)


def _run_theorem1(model: Model, design: Design, *, elements: str, anchor: str, **_: object) -> Margin:
    theta, message = _theorem1(model, design, elements, anchor)
    return _result(theta, (theta, theta), message)


def _run_vertex(model: Model, design: Design, *, elements: str, anchor: str, **_: object) -> Margin:
    theta, message = _vertex(model, design, elements, anchor)
    return _result(theta, (theta, theta), message)


def _run_frozen(model: Model, design: Design, *, anchor: str, lower: float, **_: object) -> Margin:
    return _result(*_frozen(model, design, lower, anchor))


def _run_lmi(model: Model, design: Design, *, anchor: str, lower: float, upper: float, tol: float,
             **_: object) -> Margin:
    return _result(*_lmi_margin(model, design, lower, upper, tol, anchor))


def _run_falsifier(model: Model, design: Design, *, anchor: str, lower: float, upper: float, tol: float,
                   falsifier_tries: int, seed: int, **_: object) -> Margin:
    return _result(*_falsifier_margin(model, design, lower, upper, tol, falsifier_tries, seed, anchor))


for _method in (
    AnalysisMethod("theorem1", "margin", "lower", _run_theorem1,
                   "exact: Z(θ) is affine in θ, the end is a generalized eigenvalue",
                   frozenset({"P", "intervals"}), cheap=True),
    AnalysisMethod("vertex", "margin", "lower", _run_vertex,
                   "exact: the design's P at every vertex, each affine in θ", frozenset({"P", "vertices"}), cheap=True),
    AnalysisMethod("lmi", "margin", "lower", _run_lmi, "bisection on θ with the common-P LMI",
                   frozenset({"vertices", "lmi", "lower", "upper"})),
    AnalysisMethod("frozen", "margin", "upper", _run_frozen, "the smallest θ with an unstable frozen vertex",
                   frozenset({"vertices", "lower"}), cheap=True),
    AnalysisMethod("falsifier", "margin", "upper", _run_falsifier,
                   "the smallest θ found with a destabilizing switching signal",
                   frozenset({"vertices", "lower", "upper"})),
):
    register_method(_method)

#: The built-in methods of :func:`robustness_margin` and whether each gives a lower or an upper
#: bound (the registry holds them: :func:`~scara_robust.analysis_methods` ``('margin')``).
MARGIN_METHODS: dict[str, str] = {name: get_method("margin", name).bound for name in analysis_methods("margin")}


def margin_table(
    model: Model, design: Design | ArrayLike, *, elements: str = "all", tol: float = MARGIN_TOL,
    falsifier_tries: int = 10, seed: int = 0, anchor: str = "lower", progress: bool = False,
) -> pd.DataFrame:
    """Every registered margin method, each bound feeding the searches after it.

    The cheap methods run first (the exact lower bounds, then the frozen upper bound from
    the best of them), so the LMI and falsifier searches start from both ends of what is
    known; the rows keep the registry's order.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
    design : Design or array_like, shape (m, n)
        A design, or a gain K of your own (see :func:`robustness_margin`).
    elements : {'all', 'A', 'B'}
    tol : float
    falsifier_tries, seed : int
    anchor : {'lower', 'center'}
        What θ scales the set about (see :func:`robustness_margin`).
    progress : bool
        Show a tqdm bar over the methods on stderr (the LMI and falsifier searches take
        up to a minute on the robot's 1024-corner box).

    Returns
    -------
    pandas.DataFrame
        One row per method (``theorem1`` skipped for a polytope): ``method``, ``kind``,
        ``theta``, ``lo`` and ``hi`` (where the method's answer changes), ``seconds``,
        ``message``; then a row ``bracket`` whose ``lo`` is the best lower bound and ``hi``
        the best upper bound on the true margin.
    """
    design = as_design(as_model("model", model), design)
    done: dict[str, Margin] = {}
    best = 0.0
    names = [name for name in analysis_methods("margin", defaults=True)
             if get_method("margin", name).applies_to(model.capabilities)]
    order = sorted(names, key=lambda name: not get_method("margin", name).cheap)  # stable: cheap first, in order
    for method in tqdm(order, disable=not progress, file=sys.stderr, desc="margin", unit="method"):
        entry = get_method("margin", method)
        upper = min((r.theta for r in done.values() if r.bound == "upper" and math.isfinite(r.theta)), default=None)
        margin = robustness_margin(model, design, method, elements=elements, tol=tol,
                                   lower=best if "lower" in entry.needs else 0.0, upper=upper,
                                   falsifier_tries=falsifier_tries, seed=seed, anchor=anchor)
        done[method] = margin
        if margin.bound == "lower" and math.isfinite(margin.theta):
            best = max(best, margin.theta)
    rows = [done[name] for name in names]
    lowers = [r.theta for r in rows if r.bound == "lower" and not math.isnan(r.theta)]
    uppers = [r.theta for r in rows if r.bound == "upper" and not math.isnan(r.theta)]
    lo, hi = max(lowers), min(uppers)
    width = f", the bracket is {100 * (hi - lo) / lo:.2g} % of the lower bound" if 0 < lo and hi < math.inf else ""
    frame = pd.DataFrame(
        [(r.method, r.bound, r.theta, r.bracket[0], r.bracket[1], r.seconds, r.message) for r in rows]
        + [("bracket", "both", lo, lo, hi, sum(r.seconds for r in rows),
            f"true margin in [{lo:.4g}, {hi:.4g}]{width}")],
        columns=["method", "kind", "theta", "lo", "hi", "seconds", "message"],
    )
    return frame


