"""A design's decay rate: one number for every command that reports one.

The decay rate α of a design on an uncertainty set is the largest α with ``V̇ ≤ −2αV``
for some quadratic ``V = xᵀPx`` on every closed loop of the set (the state then decays as
``exp(−αt)`` up to the condition number of P). Two matrices are candidates: the design's own
P (the Riccati P of Eq. (4), or the P of a design file) and the common P an LMI finds
(:func:`~scara_robust.lmi_certificate`). For a given P the rate is exact:
``α(P) = min_i −λmax(P^{-1/2}(A_iᵀP + PA_i)P^{-1/2}) / 2`` (:func:`~scara_robust.decay_rate`),
checked with numpy on every closed loop; the answer is the larger of the two, labelled
with the P that gives it.

The LMI's own objective (the condition number of P, :func:`~scara_robust.lmi_certificate`)
is not the decay rate, and its optimum is not unique: two solvers' optima can prove
different rates. The LMI's P is therefore refined towards the decay-optimal common P, the
generalized eigenvalue problem ``maximize α: AᵢᵀP + PAᵢ + 2αP ≺ 0, P ≻ 0`` (Boyd et al.
1994, §5.1.3), quasiconvex in α: a search on the shift α of the loops ``Aᵢ + αI`` from the
best rate a verified P (the design's or the certificate's) already proves, each step one LMI
solve that stops at the first P numpy verifies on the shifted loops (and jumps the lower end to
that P's exact rate) or once the solver's dual bound shows none, until the bracket is
:data:`DECAY_RTOL` of the rate wide. The bracket's upper end starts at ``min_i −max Re λ(Aᵢ)``
(no quadratic V decays faster on a loop than its slowest mode), where the first probe is made,
just below it, and comes down where a shifted LMI has no P; every P's rate is numpy's, on every set.

The set is the one the design's certificate is about: the interval box's corners (or the
polytope's vertices) when they can be enumerated and a rate is certified there (exact for
the box, parameters varying arbitrarily within it), otherwise the plant's own frozen
plants (the LMI solved on its coarse grid, every rate verified on its grid and on the
refined grid); the message names the set.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_closed_loops
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import Design, design_or_none
from ..model.plant import UncertainPlant
from ..model.polytopic import PolytopicModel
from ..model.uncertain import UncertainLTVModel
from ..results import AnalysisResult
from ..sdp.backends import resolve_lmi_solver
from .lmi import NOT_INSTALLED, cvxpy_available, decay_floor, decay_rate, lmi_certificate, lmi_search
from .polytope import MAX_BOX_ELEMENTS

__all__ = ["DECAY_RTOL", "DecayRate", "certified_decay_rate", "design_decay_rate"]

Array = NDArray[np.float64]

#: The labels of :attr:`DecayRate.source`.
DECAY_SOURCES = ("the design's P", "a common P by LMI")

#: The decay-optimal common P is searched until its bracket is this fraction of the rate wide (each probe
#: is an LMI solve: on the 6-joint arm's 95 plants of 18 states 0.4 s with a P, about 1 s without).
DECAY_RTOL = 5e-2


@dataclass(frozen=True)
class DecayRate(AnalysisResult):
    """The decay rate a design has on a set: the larger of its own P's and an LMI's.

    Attributes
    ----------
    rate : float
        α, 1/s (``V̇ <= −2αV`` on every closed loop of the set); nan when neither P proves
        a rate above :attr:`floor`.
    source : str
        Which P gives it: ``"the design's P"`` or ``"a common P by LMI"`` ('' when none).
    own : float
        The design's own P's rate, 1/s (nan without one).
    lmi : float
        The LMI's P's rate, 1/s: the decay-optimal search's best where it improved on the LMI's
        certificate, else the certificate's (nan when the LMI found none or cvxpy is missing).
    lmi_status : str
        The LMI's status (``'not installed'`` without cvxpy).
    set_name : str
        The set, e.g. ``"the interval box's 4 corners"``.
    n_loops : int
        Closed loops tested (the verification sets included).
    floor : float
        The smallest rate reported as certified, 1/s (``decay_floor`` of the LMI module: a fraction of the loops' norm).
    P : ndarray, shape (n, n), or None
        The P that gives :attr:`rate`.
    loops : ndarray, shape (V, n, n), or None
        The closed loops of the set (the LMI's; P was verified on them and on the checks).
    lmi_upper : float
        The decay-optimal search's upper end on the LMI's loops, 1/s: no common P with a
        larger rate was found there (a bound proven by the loops' eigenvalues where it is
        ``min_i −max Re λ(A_i)``, otherwise where the solver found no P); nan when no search ran.
    lmi_solves : int
        LMI solves of that search (the first, the LMI's own objective, not counted).
    lmi_certificate : float
        The rate of the LMI certificate's own P, 1/s, the search's start (nan without one).
    candidates : tuple of ndarray, shape (n, n)
        Every P verified on every loop of the set with a rate above :attr:`floor` (the
        design's, the LMI's, the search's best), best first: each makes invariant ellipsoids
        for :func:`~scara_robust.input_limit_certificate`.
    """

    rate: float
    source: str
    own: float
    lmi: float
    lmi_status: str
    set_name: str
    n_loops: int
    floor: float
    P: Array | None = None
    loops: Array | None = field(default=None, repr=False)
    lmi_upper: float = math.nan
    lmi_solves: int = 0
    candidates: tuple[Array, ...] = field(default=(), repr=False)
    lmi_certificate: float = math.nan

    @property
    def certified(self) -> bool:
        """True when a verified P proves a decay rate above the floor."""
        return bool(np.isfinite(self.rate) and self.rate > 0)

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not certified'``."""
        return "certified" if self.certified else "not certified"

    @property
    def status(self) -> str:
        """The verdict."""
        return self.verdict

    @property
    def message(self) -> str:
        """E.g. ``"decay rate α = 0.477 1/s (the design's P; a common P by LMI: 0.31 1/s) on ..."``."""
        other = []
        if self.source != DECAY_SOURCES[0] and np.isfinite(self.own):
            other.append(f"the design's P: {self.own:.4g} 1/s")
        if self.source != DECAY_SOURCES[1]:
            other.append(f"a common P by LMI: {self.lmi:.4g} 1/s" if np.isfinite(self.lmi)
                         else f"a common P by LMI: none ({self.lmi_status})")
        if np.isfinite(self.lmi) and np.isfinite(self.lmi_upper):
            refined = (f"from the LMI certificate's {self.lmi_certificate:.4g} 1/s, "
                       if self.lmi > self.lmi_certificate else "")
            other.append(f"decay-optimal search: {refined}no common P above {self.lmi_upper:.4g} 1/s found on "
                         f"the LMI's loops in {self.lmi_solves} solve{'' if self.lmi_solves == 1 else 's'}")
        if not self.certified:
            return f"no decay rate certified on {self.set_name} ({'; '.join(other)})"
        return f"decay rate α = {self.rate:.4g} 1/s ({'; '.join([self.source, *other])}) on {self.set_name}"

    def to_pandas(self) -> pd.DataFrame:
        """One row: rate, source, own, lmi, set."""
        return pd.DataFrame([{"decay rate [1/s]": self.rate, "from": self.source, "design's P [1/s]": self.own,
                              "LMI's P [1/s]": self.lmi, "LMI search's upper end [1/s]": self.lmi_upper,
                              "set": self.set_name}])


def certified_decay_rate(
    closed_loops: ArrayLike,
    P: ArrayLike | None = None,
    *,
    check: list[ArrayLike] | tuple[ArrayLike, ...] = (),
    set_name: str = "the given closed loops",
    lmi: bool = True,
    solver: str | None = None,
    rtol: float = DECAY_RTOL,
    certificate: bool = True,
) -> DecayRate:
    """The decay rate of a design on closed loops: the better of its own P and an LMI's P.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        The set's closed loops ``A_i − B_i K``.
    P : array_like, shape (n, n), optional
        The design's own Lyapunov matrix.
    check : sequence of array_like, shape (V_k, n, n)
        Further closed loops on which each P must also hold (a finer grid); the rate is
        the minimum over all. The LMI is solved on the set by cutting planes, grown from the
        checks' loops where its P does not verify.
    set_name : str
        What the loops are, for the message.
    lmi : bool
        Also search a common P (extra ``lmi``).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    rtol : float
        The LMI's P is refined towards the decay-optimal common P on `closed_loops` until the
        search's bracket is this fraction of the rate wide (``inf``: the LMI's own P only).
    certificate : bool
        True (default): the LMI certificate (:func:`~scara_robust.lmi_certificate`, its own
        objective) is solved first, and the search starts from the better of its P and the
        design's. False, for a caller that reports the rate alone: the search first tries to
        close its bracket without it, from the design's P and one probe just below the
        eigenvalue bound; the certificate is solved, and the search run as with True, only
        where that fails. The rate is then known to `rtol` all the same, and is the one True
        gives unless the certificate's P proves a larger rate inside the closed bracket;
        :attr:`DecayRate.candidates` lacks the certificate's P where it was not solved.

    Returns
    -------
    DecayRate

    Examples
    --------
    Two loops with the same eigenvectors share their best P; the rate is the slower loop's
    slowest mode, 0.5 1/s, to within :data:`DECAY_RTOL`:

    >>> import numpy as np, scara_robust as sr
    >>> T = np.array([[1.0, 1.0], [0.0, 1.0]])
    >>> loops = [T @ np.diag(d) @ np.linalg.inv(T) for d in ([-1.0, -2.0], [-0.5, -3.0])]
    >>> found = sr.certified_decay_rate(loops)
    >>> bool(0.5 / (1 + sr.DECAY_RTOL) <= found.rate <= 0.5)
    True
    """
    solver = resolve_lmi_solver(solver)
    if not (isinstance(rtol, (int, float)) and not isinstance(rtol, bool) and rtol > 0):
        raise ArgumentValueError("rtol", f"must be a number > 0 (inf: no refinement), found {rtol!r}")
    if not isinstance(certificate, bool):
        raise ArgumentValueError("certificate", f"must be True or False, found {certificate!r}")
    loops = check_closed_loops("closed_loops", closed_loops)
    checks = [check_array(f"check[{k}]", c, shape=(None, *loops.shape[1:])) for k, c in enumerate(check)]
    every = [loops, *checks]
    floor = decay_floor(loops)

    def rate_of(M: Array) -> float:
        return min(decay_rate(c, M) for c in every)

    own = math.nan
    if P is not None:
        P = check_array("P", P, shape=loops.shape[1:])
        own = rate_of(P)
    lmi_rate, status, P_lmi = math.nan, "not asked", None
    first_rate = math.nan
    found_p: list[tuple[float, str, Array]] = []
    upper, solves = math.nan, 0
    if lmi and cvxpy_available() and not certificate and math.isfinite(rtol):
        closed = _closed_without_certificate(loops, P, own, rate_of, solver, rtol)
        if closed is not None:
            best_p, best_rate, upper, solves, status = closed
            candidates = sorted(((r, src, M) for r, src, M in
                                 ((own, DECAY_SOURCES[0], P), (best_rate, DECAY_SOURCES[1], best_p))
                                 if M is not None and np.isfinite(r) and r > 0 and r >= floor), key=lambda c: -c[0])
            n_loops = sum(len(c) for c in every)
            if candidates:  # a tie goes to the design's own P (first, and the sort is stable)
                rate, source, best = candidates[0]
                return DecayRate(rate, source, own, best_rate, status, set_name, n_loops, floor, best, loops,
                                 upper, solves, tuple(M for _, _, M in candidates))
    if lmi:
        if cvxpy_available():
            # cutting planes on the set, grown from the checks' most violated loops: P holds on all of them
            found = lmi_certificate(loops, check=checks, solver=solver)
            status = found.status
            if found.P is not None:
                P_lmi = found.P
                lmi_rate = first_rate = rate_of(P_lmi)
                found_p.append((lmi_rate, DECAY_SOURCES[1], P_lmi))
                if found.certified and math.isfinite(rtol):
                    starts = [M for M in (P, P_lmi) if M is not None]
                    known = max(lmi_rate, own if P is not None else -math.inf)
                    best_p, best_rate, upper, solves = _decay_optimal(loops, starts, known, rate_of, solver, rtol)
                    if best_p is not None:
                        found_p.append((best_rate, DECAY_SOURCES[1], best_p))
                        lmi_rate = best_rate
        else:
            status = NOT_INSTALLED
    if P is not None:
        found_p.insert(0, (own, DECAY_SOURCES[0], P))  # a tie goes to the design's own P
    candidates = sorted(((r, src, M) for r, src, M in found_p if np.isfinite(r) and r > 0 and r >= floor),
                        key=lambda c: -c[0])
    n_loops = sum(len(c) for c in every)
    if not candidates:
        return DecayRate(math.nan, "", own, lmi_rate, status, set_name, n_loops, floor, None, loops, upper, solves,
                         lmi_certificate=first_rate)
    rate, source, best = candidates[0]
    return DecayRate(rate, source, own, lmi_rate, status, set_name, n_loops, floor, best, loops, upper, solves,
                     tuple(M for _, _, M in candidates), first_rate)


def _closed_without_certificate(loops: Array, P: Array | None, own: float, rate_of: Callable[[Array], float],
                                solver: str, rtol: float) -> tuple[Array | None, float, float, int, str] | None:
    """The decay-optimal search's bracket closed without the LMI certificate, or None.

    Returns (the probe's P or None, its rate on every set or nan, the upper end, the solves,
    the status) where the best rate a verified P proves on every set, the design's or the
    first probe's, is within `rtol` of the upper end: the loops' eigenvalue bound, or the
    first probe's shift where it found no P. That probe is :func:`_decay_optimal`'s first
    (the same loops, shift and stop; :func:`~scara_robust.lmi_certificate` keeps its answer),
    so where the bracket stays open the search with the certificate repeats no solve.
    """
    high = float(-np.linalg.eigvals(loops).real.max())
    best = own if P is not None and np.isfinite(own) else -math.inf
    if best > 0 and high - best <= rtol * best:
        return None, math.nan, high, 0, (f"not needed: the design's P is within {100 * rtol:g} % of the loops' "
                                          "eigenvalue bound")
    shift = high * (1.0 - rtol / 2)
    if P is not None and decay_rate(loops, P) >= shift:
        return None  # the search with the certificate does not probe there: no probe to share
    found = lmi_search(solver=solver, stop="probe")(loops + shift * np.eye(loops.shape[1]))
    if found.P is not None and decay_rate(loops, found.P) > shift:
        P_probe, rate = found.P, rate_of(found.P)
        best = max(best, rate)
    else:
        P_probe, rate, high = None, math.nan, shift  # no P at this shift: the upper end comes down to it
    if best > 0 and high - best <= rtol * best:
        status = found.status if P_probe is not None else (
            f"not needed: no P found just below the loops' eigenvalue bound, and the design's P is within "
            f"{100 * rtol:g} % of where the search found none")
        return P_probe, rate, high, 1, status
    return None


def _decay_optimal(loops: Array, starts: list[Array], start_rate: float, rate_of: Callable[[Array], float],
                   solver: str, rtol: float) -> tuple[Array | None, float, float, int]:
    """The decay-optimal common P on `loops`, by bisection on the loops' shift.

    Returns (the best P or None, its rate on every set, the upper end, the solves).

    ``AᵢᵀP + PAᵢ + 2αP ≺ 0`` is the common-P LMI of ``Aᵢ + αI``, feasible exactly below the
    optimal rate α*. The first probe is just below the loops' eigenvalue bound (no quadratic V
    decays faster than a loop's slowest mode), where the optimum often sits, the next ones at the
    bracket's middle. Each probe asks only whether a P exists at its shift: it stops
    at the first P numpy verifies on every shifted loop, or once the solver's dual bound shows none
    (``stop='probe'`` of :func:`~scara_robust.lmi_search`, each probe's cutting planes started from
    the last one's active loops), and that P's exact rate
    on `loops` raises the lower end; a probe without one is the upper end. The last P found (the
    largest rate on `loops`) is returned where its rate on every set (`rate_of`, the checks
    included) beats `start_rate` (the best of `starts`', the P's already verified), so the answer
    never falls below theirs. The bracket's lower end starts at their best rate on `loops`.
    """
    eye = np.eye(loops.shape[1])
    low = max(decay_rate(loops, M) for M in starts)
    # a V that decays at α on a loop bounds its slowest mode's real part by −α
    high = float(-np.linalg.eigvals(loops).real.max())
    last, solves = None, 0
    probe = lmi_search(solver=solver, stop="probe")
    # the first probe just below the eigenvalue bound, where the optimum often sits: a P found there ends
    # the search, within rtol/2 of the best any quadratic V can do (a probe stops at the first P, just
    # above its shift, so the higher probe of the two that end the search, high / (1 + rtol) and this
    # one, gives the better P: measured on the Panda, 0.7633 against 0.7515 1/s); then a bisection
    shift = high * (1.0 - rtol / 2)
    while high - low > rtol * low:
        shift = shift if solves == 0 and shift > low else 0.5 * (low + high)
        found = probe(loops + shift * eye)
        solves += 1
        rate = decay_rate(loops, found.P) if found.P is not None else -math.inf
        if rate > shift:
            low, last = rate, found.P
        else:
            high = shift
    # the last P found has the largest rate on `loops`; it is kept where its rate on every set beats `start`'s
    rate = rate_of(last) if last is not None else -math.inf
    return (last, rate, high, solves) if rate > start_rate else (None, math.nan, high, solves)


def design_decay_rate(
    model: UncertainLTVModel | PolytopicModel | UncertainPlant,
    design: Design | ArrayLike,
    *,
    P: ArrayLike | None = None,
    plant: UncertainPlant | None = None,
    lmi: bool = True,
    solver: str | None = None,
    rtol: float = DECAY_RTOL,
    certificate: bool = True,
) -> DecayRate:
    """The decay rate of a design on its uncertainty set, as every command reports it.

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel or UncertainPlant
        The set: its corners when they can be enumerated (at most 2^``MAX_BOX_ELEMENTS``)
        and certify a rate, else the frozen plants of `plant` (a plant's own interval hull
        is used for the corners).
    design : Design or array_like, shape (m, n)
        The design (its P is a candidate) or a plain gain K of ``u = −Kx``.
    P : array_like, shape (n, n), optional
        The design's Lyapunov matrix when `design` is a plain gain (a design file's P).
    plant : UncertainPlant, optional
        Whose frozen plants make the set when the corners are too many (default: `model`
        when it is a plant).
    lmi : bool
        Also search a common P (extra ``lmi``).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    rtol : float
        The decay-optimal search's relative bracket (:func:`certified_decay_rate`).
    certificate : bool
        Solve the LMI certificate before the search (default), or only where the search
        needs it (:func:`certified_decay_rate`).

    Returns
    -------
    DecayRate
    """
    solver = resolve_lmi_solver(solver)
    if "parameters" in model.capabilities:  # a plant: its own interval hull has the corners
        plant = model if plant is None else plant  # type: ignore[assignment]
        model = model.interval_model()  # type: ignore[union-attr]
    own: Array | None
    found = design_or_none(design)
    if found is not None:
        K, own = found.K, found.P
    else:
        K = check_array("design", design, ndim=2)
        own = None if P is None else check_array("P", P, shape=(K.shape[1], K.shape[1]))
    polytope = "intervals" not in model.capabilities
    n_elements = 0 if polytope else len(model.elements)  # type: ignore[union-attr]
    if n_elements <= MAX_BOX_ELEMENTS or plant is None:
        loops = np.asarray(model.vertex_closed_loops(K))  # type: ignore[union-attr]
        name = (f"the polytope's {len(loops)} vertices" if polytope else
                f"the interval box's {len(loops)} corners")
        on_box = certified_decay_rate(loops, own, set_name=name, lmi=lmi, solver=solver, rtol=rtol,
                                      certificate=certificate)
        if on_box.certified or plant is None:
            return on_box
    coarse = plant.samples(plant.coarse_points())
    grid, fine = plant.samples(), plant.samples(plant.fine_points())
    name = (f"the plant's frozen plants ({coarse.n_samples} samples for the LMI, verified on {grid.n_samples} "
            f"and {fine.n_samples})")
    return certified_decay_rate(coarse.closed_loops(K), own, check=[grid.closed_loops(K), fine.closed_loops(K)],
                                set_name=name, lmi=lmi, solver=solver, rtol=rtol, certificate=certificate)
