"""A design's decay rate: one number for every command that reports one.

The decay rate α of a design on an uncertainty set is the largest α with ``V̇ ≤ −2αV``
for some quadratic ``V = xᵀPx`` on every closed loop of the set (the state then decays as
``exp(−αt)`` up to the condition number of P). Two matrices are candidates: the design's own
P (the Riccati P of Eq. (4), or the P of a design file) and the common P an LMI finds
(:func:`~scara_robust.lmi_certificate`). For a given P the rate is exact:
``α(P) = min_i −λmax(P^{-1/2}(A_iᵀP + PA_i)P^{-1/2}) / 2`` (:func:`~scara_robust.decay_rate`),
checked with numpy on every closed loop; the answer is the larger of the two, labelled
with the P that gives it.

The set is the one the design's certificate is about: the interval box's corners (or the
polytope's vertices) when they can be enumerated and a rate is certified there (exact for
the box, parameters varying arbitrarily within it), otherwise the plant's own frozen
plants (the LMI solved on its coarse grid, every rate verified on its grid and on the
refined grid); the message names the set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_closed_loops
from ..lyapunov.gain import Design, design_or_none
from ..model.plant import UncertainPlant
from ..model.polytopic import PolytopicModel
from ..model.uncertain import UncertainLTVModel
from ..results import AnalysisResult
from ..sdp.backends import resolve_lmi_solver
from .lmi import NOT_INSTALLED, cvxpy_available, decay_floor, decay_rate, lmi_certificate
from .polytope import MAX_BOX_ELEMENTS

__all__ = ["DecayRate", "certified_decay_rate", "design_decay_rate"]

Array = NDArray[np.float64]

#: The labels of :attr:`DecayRate.source`.
DECAY_SOURCES = ("the design's P", "a common P by LMI")


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
        The LMI's P's rate, 1/s (nan when the LMI found none or cvxpy is missing).
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
        if not self.certified:
            return f"no decay rate certified on {self.set_name} ({'; '.join(other)})"
        return f"decay rate α = {self.rate:.4g} 1/s ({'; '.join([self.source, *other])}) on {self.set_name}"

    def to_pandas(self) -> pd.DataFrame:
        """One row: rate, source, own, lmi, set."""
        return pd.DataFrame([{"decay rate [1/s]": self.rate, "from": self.source, "design's P [1/s]": self.own,
                              "LMI's P [1/s]": self.lmi, "set": self.set_name}])


def certified_decay_rate(
    closed_loops: ArrayLike,
    P: ArrayLike | None = None,
    *,
    check: list[ArrayLike] | tuple[ArrayLike, ...] = (),
    set_name: str = "the given closed loops",
    lmi: bool = True,
    solver: str | None = None,
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

    Returns
    -------
    DecayRate
    """
    solver = resolve_lmi_solver(solver)
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
    if lmi:
        if cvxpy_available():
            # cutting planes on the set, grown from the checks' most violated loops: P holds on all of them
            found = lmi_certificate(loops, check=checks, solver=solver)
            status = found.status
            if found.P is not None:
                P_lmi = found.P
                lmi_rate = rate_of(P_lmi)
        else:
            status = NOT_INSTALLED
    candidates = [(r, src, M) for r, src, M in ((own, DECAY_SOURCES[0], P), (lmi_rate, DECAY_SOURCES[1], P_lmi))
                  if np.isfinite(r) and r > 0 and r >= floor]
    n_loops = sum(len(c) for c in every)
    if not candidates:
        return DecayRate(math.nan, "", own, lmi_rate, status, set_name, n_loops, floor, None, loops)
    rate, source, best = max(candidates, key=lambda c: c[0])
    return DecayRate(rate, source, own, lmi_rate, status, set_name, n_loops, floor, best, loops)


def design_decay_rate(
    model: UncertainLTVModel | PolytopicModel | UncertainPlant,
    design: Design | ArrayLike,
    *,
    P: ArrayLike | None = None,
    plant: UncertainPlant | None = None,
    lmi: bool = True,
    solver: str | None = None,
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
        on_box = certified_decay_rate(loops, own, set_name=name, lmi=lmi, solver=solver)
        if on_box.certified or plant is None:
            return on_box
    coarse = plant.samples(plant.coarse_points())
    grid, fine = plant.samples(), plant.samples(plant.fine_points())
    name = (f"the plant's frozen plants ({coarse.n_samples} samples for the LMI, verified on {grid.n_samples} "
            f"and {fine.n_samples})")
    return certified_decay_rate(coarse.closed_loops(K), own, check=[grid.closed_loops(K), fine.closed_loops(K)],
                                set_name=name, lmi=lmi, solver=solver)
