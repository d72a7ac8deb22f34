"""A gain scheduled on a measured parameter, and its certificate for a moving, mis-measured parameter.

The loop is ``ẋ = (A(p, q) − B(p, q) K(p̂)) x``: ``p`` the measured parameter (a payload),
``p̂`` what the controller measures, ``|p̂ − p| <= δ``, ``|ṗ| <= ν``, ``q`` the unmeasured
parameters (varying arbitrarily in their ranges), and ``K(p̂)`` a
:class:`~scara_robust.ScheduledGain`: gains ``K_j`` at breakpoints ``b_j``, linear between
them, clamped outside.

**Certificate** (:func:`schedule_certificate`). A Lyapunov matrix piecewise linear on the
same breakpoints, ``P(p) = (1 − s)P_j + s P_{j+1}`` on segment j (slope ``D_j``), proves
decay at rate α when at every p, q, admissible p̂ and ``ṗ = ±ν``::

    P(p) ≻ 0,   A_clᵀ P(p) + P(p) A_cl + ṗ D_j + 2α P(p) ≺ 0

(Gahinet, Apkarian and Chilali, IEEE TAC 41(3), 1996, with a piecewise-affine P as in
gridded LPV analysis). V = xᵀP(p)x is continuous in p, so the conditions of the two segments
at a breakpoint cover it. For fixed p the left side is affine in K(p̂), which is piecewise
linear in p̂: checking p̂ at the ends of ``[p − δ, p + δ]`` (clamped to the breakpoints) and
at the breakpoints inside it covers every p̂ exactly. In p and q the conditions are
gridded: solved on a grid of ``points`` per segment and the unmeasured parameters' coarse
samples (cutting planes: a few conditions at a time, the most violated added), then
re-verified with numpy on a grid four times finer in p and on the parameters' full samples.
``ν = inf`` asks for one P for all p (the common-P test), ``ν = 0`` for frozen p.

**Synthesis** (:func:`synthesize_schedule`). With ``X(p) = P(p)⁻¹`` and ``Y(p) = K(p)X(p)``
piecewise linear on the breakpoints, the conditions (at p̂ = p) become linear
(V̇ < 0 multiplied by X on both sides)::

    X(p) ≻ 0,   A X + X Aᵀ − B Y − Yᵀ Bᵀ ∓ ν X′_j + 2α X ≺ 0,
    X_j ⪰ μI,   [[κ²μI, Y_j], [Y_jᵀ, X_j]] ⪰ 0

so ``‖K_j‖ <= κ`` (as :func:`scara_robust.synthesize` bounds its gain); the decay α is
maximized by bisection. The gains ``K_j = Y_j X_j⁻¹`` are then tabulated, and the table as
it runs (linear in K between breakpoints, with the measurement error) is certified by
:func:`schedule_certificate` with its own P(p): the certificate covers the implementation,
not the synthesis' rational K(p).

**The paper's way, scheduled** (:func:`schedule_riccati`): the (ρ, η) Riccati design on the
plant frozen at each breakpoint (the other parameters' box kept).

cvxpy + Clarabel (extra ``lmi``). Units: the parameter's (p, δ), its unit per second (ν), 1/s
(α).
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_int, check_real
from ..controller.scheduled import ScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import design
from ..model.plant import UncertainPlant
from ..results import AnalysisResult, verdict_of
from ..sdp import LMIProblem, LMIVariable, solve_lmi_interior
from ..sdp.backends import resolve_lmi_solver
from ._cutting import grow_active_set
from .lmi import NOT_INSTALLED, cvxpy_available
from .pdl import _balancing
from .sampled import SampledCertificate, sampled_certificate
from .search import bisect

__all__ = ["ScheduleCertificate", "ScheduleSynthesis", "schedule_riccati", "schedule_certificate",
           "schedule_sampled_certificate",
           "synthesize_schedule", "synthesize_schedule_rate", "max_schedule_rate", "max_measurement_error",
           "schedule_decay",
           "scheduled_parameter", "SCHEDULE_POINTS", "SCHEDULE_REFINE"]

Array = NDArray[np.float64]

#: Grid points per segment (ends included) of the LMIs.
SCHEDULE_POINTS = 3
#: The numpy verification's grid is this many times finer per segment than the LMIs'.
SCHEDULE_REFINE = 4
#: An optimal margin t at or below this (normalized units) counts as no strict solution.
FEASIBILITY_TOL = 1e-9



def _run(problem: Any, t: Any, solver: str) -> tuple[str, float | None]:
    """Solve a cvxpy problem with `solver`; the status and the value of the variable t, or None."""
    import cvxpy as cp

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "inaccurate" is reported through the status
            problem.solve(solver=solver)
    except cp.SolverError as err:
        return f"solver error: {err}", None
    return str(problem.status), None if t.value is None else float(t.value)

def scheduled_parameter(plant: UncertainPlant, name: str | None = None) -> str:
    """The measured parameter a gain is scheduled on: `name`, or the plant's only measured one.

    Parameters
    ----------
    plant : UncertainPlant
    name : str, optional

    Returns
    -------
    str

    Raises
    ------
    ArgumentValueError
        Naming ``parameter`` when `name` is not a varying parameter of the plant, or when it
        is not given and the plant measures none or several.
    """
    if name is not None:
        check_choice("parameter", name, tuple(p.name for p in plant.varying))
        return name
    measured = plant.measured
    if len(measured) != 1:
        found = ", ".join(p.name for p in measured) or "none"
        raise ArgumentValueError("parameter", f"names the parameter to schedule on: the plant {plant.name!r} "
                                              f"marks {found} as measured (set `measured = true` on one)")
    return measured[0].name


def schedule_riccati(plant: UncertainPlant, parameter: str, breakpoints: ArrayLike, rho: float | ArrayLike,
                     eta: float | ArrayLike) -> ScheduledGain:
    """The paper's (ρ, η) design at each breakpoint: K_j designed on the plant frozen at ``p = b_j``.

    Parameters
    ----------
    plant : UncertainPlant
    parameter : str
        The measured parameter.
    breakpoints : array_like, shape (N + 1,)
        Strictly increasing, in the parameter's range (its unit).
    rho, eta : float or array_like, shape (N + 1,)
        One design point, or one per breakpoint.

    Returns
    -------
    ScheduledGain
        ``method = 'riccati'``; nothing certified yet.
    """
    name = scheduled_parameter(plant, parameter)
    b = _breakpoints(plant, name, breakpoints)
    rhos = np.broadcast_to(np.asarray(rho, dtype=float), b.shape)
    etas = np.broadcast_to(np.asarray(eta, dtype=float), b.shape)
    gains = [design(_frozen(plant, name, float(v)), float(r), float(e)).K for v, r, e in zip(b, rhos, etas)]
    return ScheduledGain(name, plant.parameter(name).unit, b, np.array(gains), "riccati")


def _frozen(plant: UncertainPlant, name: str, value: float) -> UncertainPlant:
    """The plant with parameter `name` fixed at `value` (no rate, not measured); the others' box kept."""
    params = tuple(dataclasses.replace(p, range=(value, value), nominal=None, rate=None, measured=False,
                                       measurement_error=0.0, measurement_delay=0.0) if p.name == name else p
                   for p in plant.parameters)
    return dataclasses.replace(plant, parameters=params, hull=None)


def _breakpoints(plant: UncertainPlant, name: str, breakpoints: ArrayLike) -> Array:
    b = check_array("breakpoints", breakpoints, ndim=1)
    lo, hi = plant.parameter(name).range
    if b.size < 2 or not np.all(np.diff(b) > 0):
        raise ArgumentValueError("breakpoints", f"must be at least 2 strictly increasing values, found {b.tolist()}")
    if b[0] < lo - 1e-12 * max(1.0, abs(lo)) or b[-1] > hi + 1e-12 * max(1.0, abs(hi)):
        unit = plant.parameter(name).unit
        raise ArgumentValueError("breakpoints", f"must lie in {name}'s range [{lo:g}, {hi:g}] {unit}, found "
                                                f"[{b[0]:g}, {b[-1]:g}]")
    return np.asarray(b, dtype=float)


# --- the gridded conditions ----------------------------------------------------------------


@dataclass(frozen=True)
class _Grid:
    """Plants on a grid of (p, q) with each p's segment and weight: the conditions' ingredients."""

    p: Array  # (c,)
    segment: NDArray[np.int64]  # (c,)
    weight: Array  # (c,): s of P(p) = (1 − s) P_j + s P_{j+1}
    A: Array  # (c, n, n) design form
    B: Array  # (c, n, m)


def _segment_points(b: Array, points: int) -> tuple[Array, NDArray[np.int64], Array]:
    p, seg, w = [], [], []
    for j in range(b.size - 1):
        s = np.linspace(0.0, 1.0, points)
        p.append(b[j] + s * (b[j + 1] - b[j]))
        seg.append(np.full(points, j))
        w.append(s)
    return np.concatenate(p), np.concatenate(seg).astype(np.int64), np.concatenate(w)


def _grid(plant: UncertainPlant, name: str, b: Array, points: int, others: Mapping[str, int]) -> _Grid:
    p, seg, w = _segment_points(b, points)
    rest = plant.grid_values({**others, name: 1})
    col = plant.names.index(name)
    rows = np.repeat(rest, p.size, axis=0)
    rows[:, col] = np.tile(p, rest.shape[0])
    A, B = plant.design_form(*plant.plant_matrices(rows))
    return _Grid(np.tile(p, rest.shape[0]), np.tile(seg, rest.shape[0]), np.tile(w, rest.shape[0]),
                 np.asarray(A), np.asarray(B))


def _measured_points(p: float, delta: float, b: Array) -> list[float]:
    """The p̂ that cover ``[p − δ, p + δ]`` for a gain linear between breakpoints: its ends and inner breakpoints."""
    if delta == 0:
        return [p]
    lo, hi = max(p - delta, b[0]), min(p + delta, b[-1])
    inner = [float(v) for v in b if lo < v < hi]
    return sorted({lo, hi, *inner})


@dataclass(frozen=True)
class _Conditions:
    """The closed loops of the certificate's conditions and where they sit."""

    A: Array  # (c, n, n): A(p, q) − B(p, q) K(p̂)
    segment: NDArray[np.int64]
    weight: Array
    sign: Array  # ṗ / ν: +1, −1 (or 0 for a frozen or common P)
    p: Array
    p_hat: Array


def _measured_pairs(grid: _Grid, gain: ScheduledGain, delta: float) -> tuple[NDArray[np.int64], Array]:
    """Each grid point's index, repeated once per p̂ of :func:`_measured_points`, and those p̂."""
    idx, hats = [], []
    for i, p in enumerate(grid.p):
        for ph in _measured_points(float(p), delta, gain.breakpoints):
            idx.append(i)
            hats.append(ph)
    return np.array(idx, dtype=np.int64), np.array(hats)


def _conditions(grid: _Grid, gain: ScheduledGain, delta: float, moving: bool) -> _Conditions:
    index, p_hat = _measured_pairs(grid, gain, delta)
    closed = grid.A[index] - grid.B[index] @ gain.gain(p_hat)
    signs = (1.0, -1.0) if moving else (0.0,)
    k = len(signs)
    return _Conditions(np.repeat(closed, k, axis=0), np.repeat(grid.segment[index], k),
                       np.repeat(grid.weight[index], k), np.tile(np.array(signs), index.size),
                       np.repeat(grid.p[index], k), np.repeat(p_hat, k))


def _lhs(cond: _Conditions, P: Array, b: Array, rate: float, decay: float) -> Array:
    """The left sides ``A_clᵀP(p) + P(p)A_cl + ṗD_j + 2αP(p)``, shape (c, n, n)."""
    j, s = cond.segment, cond.weight[:, None, None]
    Pp = (1.0 - s) * P[j] + s * P[j + 1]
    L = np.swapaxes(cond.A, 1, 2) @ Pp + Pp @ cond.A + 2.0 * decay * Pp
    if math.isfinite(rate) and rate > 0:
        D = (P[1:] - P[:-1]) / np.diff(b)[:, None, None]
        L = L + (cond.sign * rate)[:, None, None] * D[j]
    return np.asarray(0.5 * (L + np.swapaxes(L, 1, 2)))


def _max_eigs(L: Array, scale: float) -> Array:
    return np.asarray(np.linalg.eigvalsh(L)[:, -1] / scale)


# --- the certificate -----------------------------------------------------------------------


@dataclass(frozen=True)
class ScheduleCertificate(AnalysisResult):
    """A scheduled loop's certificate for a moving, mis-measured parameter, verified with numpy.

    Attributes
    ----------
    status : str
        ``'certified'`` (numpy verified every condition on both grids), ``'infeasible'`` (no
        P(p) on the LMIs' grid), ``'not verified'`` (the answer fails numpy's check on the
        finer grid), ``'optimal_inaccurate'`` or another solver status, or ``'not installed'``.
    parameter : str
    rate : float
        ν, the parameter's unit per second (``inf``: any rate, one P).
    measurement_error : float
        δ, the parameter's unit.
    decay : float
        α, 1/s.
    P : ndarray, shape (N + 1, n, n), or None
        P(b_j) at the breakpoints.
    conditions : int
        Conditions of the LMIs' grid (p × q × p̂ × ±ṗ).
    active : int
        Those the last solve held (cutting planes).
    verified_on : int
        Conditions numpy re-verified on the finer grid.
    margin : float
        Largest eigenvalue of a condition's left side on the finer grid, over ``max_j ‖P_j‖₂``
        (negative: verified), 1/s.
    covers : str
        What is proved: the grids, and that p̂ is covered exactly between them.
    seconds : float
    message : str
    active_conditions : ndarray of int, or None
        The conditions the last solve held (their indices on the LMIs' grid): a search's next
        certificate on the same grid starts from them (`start` of :func:`schedule_certificate`).
    """

    status: str
    parameter: str
    rate: float
    measurement_error: float
    decay: float
    P: Array | None
    conditions: int
    active: int
    verified_on: int
    margin: float
    covers: str
    seconds: float
    message: str
    active_conditions: NDArray[np.int64] | None = field(default=None, repr=False, compare=False)

    units: ClassVar[dict[str, str]] = {"decay": "1/s", "margin": "1/s", "seconds": "s"}

    @property
    def certified(self) -> bool:
        """True when numpy verified every condition."""
        return self.status == "certified"

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not certified'``."""
        return verdict_of(self.certified)


def _units(A: Array) -> tuple[Array, float]:
    """A coordinate change T and a time unit that even out the loop's scales (see pdl's ``_solve``)."""
    T = _balancing(A)
    decays = np.abs(np.linalg.eigvals(np.linalg.solve(T, A @ T)).real)
    scale = float(np.sqrt(decays.max() * decays.min())) if decays.min() > 0 else float(np.abs(A).max() or 1.0)
    return T, scale or 1.0


def _solve_lyapunov(cond: _Conditions, b: Array, rate: float, decay: float, T: Array, scale: float,
                    active: NDArray[np.int64], solver: str) -> tuple[str, Array | None]:
    """Maximize t: tI ⪯ P_j ⪯ I, the active conditions ⪯ −tI (coordinates T, time unit 1/scale)."""
    n = cond.A.shape[1]
    T_inv = np.linalg.inv(T)
    common = math.isinf(rate)
    if solver == "IPM":
        return _solve_lyapunov_ipm(cond, b, rate, decay, T_inv @ cond.A[active] @ T / scale, scale, active,
                                   np.asarray(T_inv, dtype=float))
    import cvxpy as cp

    Q = ([cp.Variable((n, n), symmetric=True) for _ in b] if not common
         else [cp.Variable((n, n), symmetric=True)] * b.size)
    t = cp.Variable()
    eye = np.eye(n)
    cons = [t <= 1.0]
    for Qj in (Q if not common else Q[:1]):
        cons += [Qj >> t * eye, Qj << eye]
    h = np.diff(b)
    for i in active:
        A = T_inv @ cond.A[i] @ T / scale
        j, s = int(cond.segment[i]), float(cond.weight[i])
        Pp = (1.0 - s) * Q[j] + s * Q[j + 1]
        M = A.T @ Pp + Pp @ A + (2.0 * decay / scale) * Pp
        if not common and rate > 0 and cond.sign[i] != 0:
            M = M + (float(cond.sign[i]) * rate / scale / h[j]) * (Q[j + 1] - Q[j])
        cons.append(0.5 * (M + M.T) << -t * eye)
    problem = cp.Problem(cp.Maximize(t), cons)
    status, _ = _run(problem, t, solver)
    if t.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return status, None
    t_star = float(t.value)
    if t_star <= FEASIBILITY_TOL:
        return ("infeasible" if status == cp.OPTIMAL else status), None
    if status != cp.OPTIMAL:
        # at the optimum the solver often stalls short of its tolerances; the strictly
        # interior point t = t*/2 is asked for instead (as pdl's rate-bounded test does)
        status, _ = _run(cp.Problem(cp.Minimize(0), [*cons[1:], t == 0.5 * t_star]), t, solver)
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or any(Qj.value is None for Qj in Q):
            return status, None
    P = np.array([T_inv.T @ np.asarray(Qj.value, dtype=float) @ T_inv for Qj in Q])
    return status, 0.5 * (P + np.swapaxes(P, 1, 2))


def schedule_lyapunov_problem(A_s: Array, segment: NDArray[np.int64], weight: Array, sign: Array, b: Array,
                              rate: float, decay: float) -> tuple[LMIProblem, list[LMIVariable], LMIVariable]:
    """The scheduled certificate's LMI (:func:`_solve_lyapunov`) written for the package's solver.

    ``maximize t <= 1`` with ``tI ⪯ P_j ⪯ I`` at every breakpoint and, at every condition i
    (segment j, weight s, sign σ of ṗ), ``−(AᵢᵀP + PAᵢ + 2dP + σ ν/h_j (P_{j+1} − P_j)) ⪰ tI``
    with ``P = (1 − s)P_j + sP_{j+1}``; one P for an infinite rate. Units: the caller's (time
    already scaled: `decay` and `rate` in the same unit as `A_s`).

    Parameters
    ----------
    A_s : ndarray, shape (c, n, n)
    segment : ndarray of int, shape (c,)
    weight, sign : ndarray, shape (c,)
    b : ndarray, shape (k,)
        Breakpoints.
    rate, decay : float

    Returns
    -------
    problem : LMIProblem
    P : list of LMIVariable
        One per breakpoint, or one for an infinite rate.
    t : LMIVariable
    """
    n = A_s.shape[1]
    eye = np.eye(n)
    common = math.isinf(rate)
    problem = LMIProblem()
    Q = [problem.symmetric(f"P{j}", n) for j in range(1 if common else b.size)]
    t = problem.scalar("t")
    problem.add_lmi(scalars=[(t, -np.ones((1, 1)))], const=np.ones((1, 1)), name="t <= 1")
    for Qj in Q:
        problem.add_lmi(terms=[(Qj, 0.5 * eye, eye)], scalars=[(t, -eye)], name=f"{Qj.name} >= tI")
        problem.add_lmi(terms=[(Qj, -0.5 * eye, eye)], const=eye, name=f"{Qj.name} <= I")
    h = np.diff(b)
    seg, weight, sign = segment, weight[:, None, None], sign[:, None, None]
    V = A_s + decay * eye  # −(AᵀP + PA + 2dP) = UᵀPV + VᵀPU with U = −I, V = A + dI
    for j in np.unique(seg).tolist():
        at = seg == j
        if common:
            terms = [(Q[0], -np.broadcast_to(eye, V[at].shape), V[at])]
        else:
            # the slope's terms ±(ν/h)(P_{j+1} − P_j) merged into the flow's: with U = cI, UᵀXV + VᵀXU
            # is the term (X, I, cV), and two terms of one X with U = I are one (two Kronecker terms
            # per condition instead of four: a quarter of the Schur complement's term pairs)
            k = (rate / h[j]) * sign[at] if rate > 0 else np.zeros_like(sign[at])
            I = np.broadcast_to(eye, V[at].shape)
            terms = [(Q[j], I, -(1.0 - weight[at]) * V[at] + 0.5 * k * eye),
                     (Q[j + 1], I, -weight[at] * V[at] - 0.5 * k * eye)]
        problem.add_lmi(terms=terms, scalars=[(t, -eye)], name=f"segment {j}")
    problem.maximize({t: 1.0})
    return problem, Q, t


def _solve_lyapunov_ipm(cond: _Conditions, b: Array, rate: float, decay: float, A_s: Array, scale: float,
                        active: NDArray[np.int64], T_inv: Array) -> tuple[str, Array | None]:
    """:func:`_solve_lyapunov` on the package's solver; `A_s` the active conditions' loops in its units."""
    common = math.isinf(rate)
    problem, Q, t = schedule_lyapunov_problem(A_s, cond.segment[active], cond.weight[active], cond.sign[active], b,
                                              rate / scale, decay / scale)
    result = solve_lmi_interior(problem, t, floor=FEASIBILITY_TOL)
    if result.y is None:
        return result.status, None
    if result.value(t) <= FEASIBILITY_TOL:
        return ("infeasible" if result.status == "optimal" else result.status), None
    P = np.array([T_inv.T @ result.value(Q[0 if common else j]) @ T_inv for j in range(b.size)])
    return result.status, 0.5 * (P + np.swapaxes(P, 1, 2))


def _others(plant: UncertainPlant, name: str, fine: bool) -> dict[str, int]:
    return {p.name: (p.samples if fine else int(p.coarse)) for p in plant.varying  # type: ignore[arg-type]
            if p.name != name}


def schedule_certificate(
    plant: UncertainPlant,
    gain: ScheduledGain,
    *,
    rate: float | None = None,
    measurement_error: float | None = None,
    decay: float = 0.0,
    points: int = SCHEDULE_POINTS,
    refine: int = SCHEDULE_REFINE,
    solver: str | None = None,
    start_conditions: ArrayLike | None = None,
) -> ScheduleCertificate:
    """Certify the scheduled loop ``A(p, q) − B(p, q) K(p̂)`` for a moving, mis-measured parameter.

    Parameters
    ----------
    plant : UncertainPlant
        With the gain's parameter among its varying ones; the breakpoints span its range.
    gain : ScheduledGain
    rate : float, optional
        ν >= 0, the parameter's unit per second (default the parameter's ``rate``, else
        ``inf``: any rate, one P for all p).
    measurement_error : float, optional
        δ >= 0, the parameter's unit (default the parameter's error, its delay included:
        :attr:`~scara_robust.Parameter.effective_error`).
    decay : float
        α >= 0 required of V, 1/s.
    points : int
        Grid points per segment of the LMIs (>= 2, ends included).
    refine : int
        The numpy verification's grid is `refine` times finer per segment (>= 2), on the
        unmeasured parameters' full samples (the LMIs: their coarse ones).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    start_conditions : array_like of int, optional
        The conditions the cutting planes start from (:attr:`ScheduleCertificate.active_conditions`
        of a certificate on the same grid, as a search passes it); indices beyond the grid are
        dropped. Default: the least stable frozen loop of each segment.

    Returns
    -------
    ScheduleCertificate
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    name = scheduled_parameter(plant, gain.parameter)
    param = plant.parameter(name)
    b = gain.breakpoints
    lo, hi = param.range
    if abs(b[0] - lo) > 1e-9 * max(1.0, abs(lo)) or abs(b[-1] - hi) > 1e-9 * max(1.0, abs(hi)):
        raise ArgumentValueError("gain", f"its breakpoints must span {name}'s range [{lo:g}, {hi:g}] {param.unit} "
                                         f"(the certificate covers that range), found [{b[0]:g}, {b[-1]:g}]")
    n, m = plant.n_design_states, plant.n_inputs
    if gain.shape != (m, n):
        raise ArgumentValueError("gain", f"must hold gains of shape ({m}, {n}) for this plant, found {gain.shape}")
    nu, delta = param.motion_bounds(rate, measurement_error)
    decay = check_real("decay", decay, nonnegative=True)
    points = check_int("points", points, 2)
    refine = check_int("refine", refine, 2)
    fine_points = refine * (points - 1) + 1
    covers = (f"p = {name} on {b.size - 1} segments, {points} points each for the LMIs and {fine_points} for the "
              f"check; p̂ exactly within ±{delta:g} {param.unit}; |ṗ| <= {nu:g} {param.unit}/s; the other "
              "parameters on their coarse and full samples")

    def result(status: str, P: Array | None, n_cond: int, active: int, verified: int, margin: float,
               message: str, conditions: NDArray[np.int64] | None = None) -> ScheduleCertificate:
        return ScheduleCertificate(status, name, nu, delta, decay, P, n_cond, active, verified, margin, covers,
                                   time.perf_counter() - start, message, conditions)

    if not cvxpy_available():
        return result(NOT_INSTALLED, None, 0, 0, 0, math.nan, "cvxpy is not installed (extra `lmi`)")
    moving = math.isfinite(nu) and nu > 0
    coarse = _conditions(_grid(plant, name, b, points, _others(plant, name, False)), gain, delta, moving)
    centre = int(np.argmin(np.abs(coarse.p - 0.5 * (lo + hi)) + np.abs(coarse.sign)))
    T, scale = _units(coarse.A[centre])
    # start from the least stable frozen loops, one per segment
    spectral = np.linalg.eigvals(coarse.A).real.max(axis=1)
    if spectral.max() >= -decay:
        worst = coarse.p[int(np.argmax(spectral))]
        return result("infeasible", None, coarse.A.shape[0], 0, 0, math.nan,
                      f"a frozen loop decays slower than {decay:g} 1/s (at {name} = {worst:g} {param.unit}, "
                      f"p̂ within ±{delta:g}): no P(p) exists")
    first = np.unique(np.concatenate([np.flatnonzero(coarse.segment == j)[
        [int(np.argmax(spectral[coarse.segment == j]))]] for j in range(b.size - 1)]))
    if start_conditions is not None:  # a search's last active set, on a grid indexed alike
        given = np.asarray(start_conditions, dtype=np.int64)
        given = np.unique(given[(given >= 0) & (given < coarse.A.shape[0])])
        first = np.union1d(first, given)

    fine = _conditions(_grid(plant, name, b, fine_points, _others(plant, name, True)), gain, delta, moving)

    def attempt(rate: float, what: str) -> ScheduleCertificate:
        def solve(active: NDArray[np.int64]) -> tuple[str, Array | None]:
            return _solve_lyapunov(coarse, b, rate, decay, T, scale, active, solver)

        def violation(P: Array) -> Array:
            return _max_eigs(_lhs(coarse, P, b, rate, decay), 1.0)

        status, P, active = grow_active_set(solve, violation, first)
        if P is None:
            message = (f"no {what} on the LMIs' grid" if status == "infeasible" else f"the solver returned {status!r}")
            return result(status, None, coarse.A.shape[0], int(active.size), 0, math.nan, message, active)
        size = float(max(np.linalg.norm(Pj, 2) for Pj in P))
        worst = _max_eigs(_lhs(fine, P, b, rate, decay), size)
        margin = float(worst.max())
        positive = float(min(np.linalg.eigvalsh(Pj)[0] for Pj in P))
        if status != "optimal":
            verdict = status  # an inaccurate answer is never a certificate, whatever numpy says
            message = f"the solver returned {status!r}; not a certificate"
        elif margin < 0 and positive > 0:
            verdict = "certified"
            message = (f"{what} verified on {fine.A.shape[0]} conditions (largest eigenvalue {margin:.3g} of ‖P‖, "
                       f"solved on {active.size} of {coarse.A.shape[0]})")
        else:
            verdict = "not verified"
            message = (f"the LMIs' {what} fails numpy's check on the finer grid (largest eigenvalue {margin:.3g} of "
                       f"‖P‖ at {name} = {fine.p[int(np.argmax(worst))]:g})")
        return result(verdict, P, coarse.A.shape[0], int(active.size), fine.A.shape[0], margin, message, active)

    found = attempt(nu, "P(p)" if moving else "P")
    if found.certified or math.isinf(nu):
        return found
    # One P for every p is a P(p) with no slope, and its LMI is better conditioned: where the
    # P(p) solve fails (numerically, or infeasible on the grid), it may still hold; what holds at
    # any rate holds at every bound on it, a frozen parameter (ν = 0) included
    common = attempt(math.inf, "one P for all p")
    return common if common.certified else found


# --- the sampled-data certificate ----------------------------------------------------------


def _sampled_pairs(plant: UncertainPlant, gain: ScheduledGain, name: str, points: int, fine: bool,
                   delta: float) -> tuple[Array, Array]:
    grid = _grid(plant, name, gain.breakpoints, points, _others(plant, name, fine))
    index, p_hat = _measured_pairs(grid, gain, delta)
    return grid.A[index], grid.B[index] @ gain.gain(p_hat)


def schedule_sampled_certificate(plant: UncertainPlant, gain: ScheduledGain, Ts: float, *,
                                 measurement_error: float | None = None, points: int = SCHEDULE_POINTS,
                                 refine: int = SCHEDULE_REFINE, solver: str | None = None) -> SampledCertificate:
    """The sampled-data certificate of the scheduled gain held by a zero-order hold at Ts.

    ``u_k = −K(p̂_k) x(t_k)`` held over ``[t_k, t_k + Ts)``: the loops ``x_{k+1} =
    (Φ(p, q) − Γ(p, q)K(p̂)) x_k`` at every grid point p, q and every p̂ that covers
    ``|p̂ − p| <= δ`` must share one discrete Lyapunov matrix
    (:func:`scara_robust.sampled_certificate`, solved on the LMIs' grid and re-verified on the
    finer one). One P for every p covers the parameter changing at any rate between
    samples; the discrete condition is convex in the closed loop, which is affine in K, so
    the ends of ``[p − δ, p + δ]`` and the breakpoints inside it cover every p̂ exactly.

    Parameters
    ----------
    plant : UncertainPlant
    gain : ScheduledGain
    Ts : float
        Sample time, s (> 0).
    measurement_error : float, optional
        δ (default the parameter's effective error).
    points, refine : int
        As :func:`schedule_certificate`.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    SampledCertificate
        Of the pairs ``(A(p, q), B(p, q) K(p̂))`` under ``u' = −x`` (the gain folded into B).
    """
    solver = resolve_lmi_solver(solver)
    name = scheduled_parameter(plant, gain.parameter)
    Ts = check_real("Ts", Ts, positive=True)
    _, delta = plant.parameter(name).motion_bounds(measurement_error=measurement_error)
    n = plant.n_design_states
    fine_points = check_int("refine", refine, 2) * (check_int("points", points, 2) - 1) + 1
    coarse = _sampled_pairs(plant, gain, name, points, False, delta)
    check = _sampled_pairs(plant, gain, name, fine_points, True, delta)
    return sampled_certificate(coarse, SampledStateFeedback(np.eye(n), Ts), check=check, solver=solver)


# --- searches over the certificate ---------------------------------------------------------


#: Rates :func:`max_schedule_rate` probes (halving from one range width per second) when the
#: frozen parameter's gridded certificate fails.
RATE_PROBES = 8


def _first_decay_test(plant: UncertainPlant, gain: ScheduledGain, known: ScheduleCertificate, *,
              rate: float | None, measurement_error: float | None) -> bool:
    """Whether `known` is the certificate of `gain` at these bounds (read as in schedule_certificate) and α = 0.

    The decay search's first test is then already answered, certified or not (`known`
    computed with the search's ``points``, ``refine`` and ``solver``).
    """
    if known.decay != 0.0:
        return False
    name = scheduled_parameter(plant, gain.parameter)
    if known.parameter != name:
        return False
    nu, delta = plant.parameter(name).motion_bounds(rate, measurement_error)
    return known.rate == nu and known.measurement_error == delta


def _largest_rate(ok: Callable[[float], bool], width: float, cap: float, tol: float,
                  **bisection: Any) -> float | None:
    """The largest rate ν <= `cap` with ``ok(ν)`` (``inf`` first), or None when none is found.

    ``ok`` is monotone in ν. Any rate is tried first, then the frozen parameter. A certificate
    at ν covers every slower rate, a frozen parameter too (its condition is affine in ṗ,
    checked at ±ν); but with ν = 0 nothing bounds P(p)'s slope, and a P found on the grid can
    fail the finer check between its points where a bounded slope holds: so rates halving
    from one range width per second (:data:`RATE_PROBES`) are probed before giving up. Then a
    bracket by doubling, and bisection (`bisection`: options of
    :func:`~scara_robust.robustness.search.bisect`).
    """
    if ok(math.inf):
        return math.inf
    lo, hi = 0.0, min(width, cap)
    if not ok(0.0):
        held = next((nu for nu in (hi * 0.5 ** k for k in range(RATE_PROBES)) if ok(nu)), None)
        if held is None:
            return None
        if held >= cap:
            return cap
        lo, hi = held, min(2.0 * held, cap)
    while ok(hi):
        lo = hi
        if hi >= cap:
            return cap
        hi = min(2.0 * hi, cap)
    lo, _ = bisect(ok, lo, hi, tol, **bisection)
    return lo


def max_schedule_rate(plant: UncertainPlant, gain: ScheduledGain, *, measurement_error: float | None = None,
                      decay: float = 0.0, rate_max: float | None = None, tol: float = 0.02,
                      **options: Any) -> tuple[float, ScheduleCertificate | None]:
    """The largest ν (unit/s) :func:`schedule_certificate` certifies, by bisection.

    Parameters
    ----------
    plant, gain : as :func:`schedule_certificate`
    measurement_error, decay : as :func:`schedule_certificate`
    rate_max : float, optional
        Largest rate tried (default 1e4 range widths per second); certified there: ``inf``
        is tried (one common P) and returned when it holds.
    tol : float
        Relative width of the final bracket.
    **options
        ``points``, ``refine``, ``solver``.

    Returns
    -------
    rate : float
        Largest certified rate (``inf`` when one P holds for any rate; 0 with None when no
        certificate holds, frozen or at any of :data:`RATE_PROBES` rates halving from one
        range width per second: a certificate at ν covers the frozen parameter too).
    certificate : ScheduleCertificate or None
        The certificate at that rate.
    """
    width = float(np.ptp(gain.breakpoints))
    cap = 1e4 * width if rate_max is None else check_real("rate_max", rate_max, positive=True)
    found: dict[float, ScheduleCertificate] = {}
    memory: dict[str, Any] = {}  # the last certificate's active conditions: the next one starts there

    def ok(nu: float) -> bool:
        cert = schedule_certificate(plant, gain, rate=nu, measurement_error=measurement_error, decay=decay,
                                    start_conditions=memory.get("active"), **options)
        memory["active"] = cert.active_conditions
        found[nu] = cert
        return cert.certified

    rate = _largest_rate(ok, width, cap, tol, midpoint="eighth", stop=lambda a, h, mid: mid < 1e-12 * cap)
    if rate is None:
        return 0.0, None
    return rate, found.get(rate)


def max_measurement_error(plant: UncertainPlant, gain: ScheduledGain, *, rate: float | None = None,
                          decay: float = 0.0, tol: float = 0.02,
                          **options: Any) -> tuple[float, ScheduleCertificate | None]:
    """The largest measurement error δ (the parameter's unit) certified, by bisection up to the range's width.

    Parameters
    ----------
    plant, gain : as :func:`schedule_certificate`
    rate, decay : as :func:`schedule_certificate`
    tol : float
        Relative width of the final bracket.
    **options
        ``points``, ``refine``, ``solver``.

    Returns
    -------
    delta : float
    certificate : ScheduleCertificate or None
    """
    width = float(np.ptp(gain.breakpoints))
    found: dict[float, ScheduleCertificate] = {}
    memory: dict[str, Any] = {}  # the last certificate's active conditions: the next one starts there

    def ok(delta: float) -> bool:
        cert = schedule_certificate(plant, gain, rate=rate, measurement_error=delta, decay=decay,
                                    start_conditions=memory.get("active"), **options)
        memory["active"] = cert.active_conditions
        found[delta] = cert
        return cert.certified

    if not ok(0.0):
        return 0.0, None
    if ok(width):
        return width, found[width]
    lo, _ = bisect(ok, 0.0, width, tol)
    return lo, found.get(lo)


def _decay_reach(fine: _Conditions, gain: ScheduledGain,
                 cert: ScheduleCertificate) -> Callable[[float], ScheduleCertificate | None]:
    """The largest decay a certificate's own P(p) holds, and that certificate re-verified there.

    The numpy check of :func:`schedule_certificate` (every condition of the finer grid) is
    affine in α with the slope ``2P(p) ≻ 0`` (`fine`: its conditions): each condition holds for α below the smallest
    generalized eigenvalue of ``(−L₀, 2P(p))`` (L₀ its left side at α = 0), and the P holds up
    to the smallest over the conditions. Returns ``reach(cap)``: the certificate at the decay
    ``min(cap, that α (1 − 10⁻⁶))``, verified by the same check, or None when the check
    fails there.
    """
    b = gain.breakpoints
    assert cert.P is not None
    P = cert.P
    j, s = fine.segment, fine.weight[:, None, None]
    Pp = (1.0 - s) * P[j] + s * P[j + 1]
    L0 = _lhs(fine, P, b, cert.rate, 0.0)
    C = np.linalg.cholesky(2.0 * Pp)
    Ci = np.linalg.inv(C)
    pencil = -(Ci @ L0 @ np.swapaxes(Ci, 1, 2))
    alpha_p = float(np.linalg.eigvalsh(0.5 * (pencil + np.swapaxes(pencil, 1, 2)))[:, 0].min())
    size = float(max(np.linalg.norm(Pj, 2) for Pj in P))

    def reach(cap: float) -> ScheduleCertificate | None:
        alpha = min(cap, alpha_p * (1.0 - 1e-6))
        if alpha == cert.decay:
            return cert
        margin = float(_max_eigs(_lhs(fine, P, b, cert.rate, alpha), size).max())
        if not margin < 0:
            return None
        return dataclasses.replace(cert, decay=alpha, margin=margin, message=(
            f"{cert.message}; the same P verified by numpy at the decay {alpha:.6g} 1/s (largest eigenvalue "
            f"{margin:.3g} of ‖P‖; found by the LMI at {cert.decay:.6g} 1/s)"))

    return reach


def schedule_decay(plant: UncertainPlant, gain: ScheduledGain, *, rate: float | None = None,
                   measurement_error: float | None = None, tol: float = 0.01,
                   known: ScheduleCertificate | None = None,
                   **options: Any) -> tuple[float, ScheduleCertificate | None]:
    """The largest decay rate α (1/s) certified for the scheduled loop, by bisection.

    The bisection halves ``[0, α_f]`` (α_f the frozen loops' slowest decay, which bounds α
    from above), but a test costs an LMI only where it is not already answered: every
    certificate's own P(p) holds up to a decay its numpy check gives in closed form (it is
    affine in α), which answers every test below it, and a failed test answers every test
    above it. The first test solved is just below α_f (``α_f(1 − tol/2)``), where a common
    P(p) often holds. The answer is the bisection's lower end, with the certificate whose
    P(p) answered it re-verified there by the same check (the P is not pushed to the end of
    what the check's grid allows: between the grid's points it would hold with no slack).

    Parameters
    ----------
    plant, gain : as :func:`schedule_certificate`
    rate, measurement_error : as :func:`schedule_certificate`
    tol : float
        Relative width of the final bracket.
    known : ScheduleCertificate, optional
        This gain's certificate already computed at this rate and measurement error with
        α = 0 (``certify``'s at the plant's bounds): it is the first test's answer, α = 0.
    **options
        ``points``, ``refine``, ``solver``.

    Returns
    -------
    decay : float
        0 with None when not certified at α = 0.
    certificate : ScheduleCertificate or None
        Verified at `decay`.
    """
    memory: dict[str, Any] = {}  # the last certificate's active conditions: the next one starts there
    points = options.get("points", SCHEDULE_POINTS)
    refine = options.get("refine", SCHEDULE_REFINE)
    reached: list[tuple[float, ScheduleCertificate, Callable[[float], ScheduleCertificate | None]]] = []
    failed = [math.inf]  # the smallest decay a solved test failed at

    fine: dict[bool, _Conditions] = {}  # the numpy check's conditions, by whether the parameter moves

    def note(cert: ScheduleCertificate, cap: float) -> None:
        moving = math.isfinite(cert.rate) and cert.rate > 0
        if moving not in fine:
            name = cert.parameter
            fine[moving] = _conditions(_grid(plant, name, gain.breakpoints, refine * (points - 1) + 1,
                                             _others(plant, name, True)), gain, cert.measurement_error, moving)
        reach = _decay_reach(fine[moving], gain, cert)
        extended = reach(cap)
        reached.append((cert.decay if extended is None else max(cert.decay, extended.decay), cert, reach))

    def answered(alpha: float) -> tuple[ScheduleCertificate, Callable[[float], ScheduleCertificate | None]] | None:
        """A certificate whose P(p) holds at `alpha`, if one was found."""
        holding = [(cert, reach) for top_alpha, cert, reach in reached if alpha <= top_alpha]
        return holding[0] if holding else None

    def ok(alpha: float) -> bool:
        if answered(alpha) is not None:
            return True
        if alpha >= failed[0]:
            return False
        cert = schedule_certificate(plant, gain, rate=rate, measurement_error=measurement_error, decay=alpha,
                                    start_conditions=memory.get("active"), **options)
        memory["active"] = cert.active_conditions
        if cert.certified:
            note(cert, top)
        else:
            failed[0] = min(failed[0], alpha)
        return cert.certified

    # the frozen loops' slowest decay bounds α from above
    grid = _grid(plant, gain.parameter, gain.breakpoints, 2, _others(plant, gain.parameter, False))
    top = max(float(-np.linalg.eigvals(grid.A - grid.B @ gain.gain(grid.p)).real.max()), 1e-12)
    if known is not None and _first_decay_test(plant, gain, known, rate=rate, measurement_error=measurement_error):
        if not known.certified:
            return 0.0, None
        memory["active"] = known.active_conditions
        note(known, top)
    elif not ok(0.0):
        return 0.0, None
    before = dict(memory)
    if not ok(top * (1.0 - tol / 2)):
        # a failed probe's active set is that of a failed solve: the bisection starts from the last certificate's
        memory.clear()
        memory.update(before)
    lo, _ = bisect(ok, 0.0, top, tol)
    found = answered(lo)
    assert found is not None
    cert, reach = found
    if cert.decay == lo:
        return lo, cert
    at_lo = reach(lo)
    assert at_lo is not None  # the check is monotone in α: a P verified above lo is verified at lo
    return lo, at_lo


# --- synthesis -----------------------------------------------------------------------------


@dataclass(frozen=True)
class ScheduleSynthesis(AnalysisResult):
    """A scheduled gain synthesized by LMIs, and the certificate of the table as it runs.

    Attributes
    ----------
    gain : ScheduledGain or None
        ``K_j = Y_j X_j⁻¹``; its ``certified`` records what :attr:`certificate` proved.
    decay : float
        Decay rate α the synthesis reached on its grid, 1/s.
    certificate : ScheduleCertificate or None
        The implemented table (linear in K between breakpoints, with the measurement error)
        certified with its own P(p) at that decay.
    gain_bound : float
        κ, ``‖K_j‖₂ <= κ``.
    rate : float
        ν of the synthesis, unit/s.
    steps : int
        LMI solves of the bisection.
    seconds : float
    status : str
    message : str
    """

    gain: ScheduledGain | None
    decay: float
    certificate: ScheduleCertificate | None
    gain_bound: float
    rate: float
    steps: int
    seconds: float
    status: str
    message: str

    units: ClassVar[dict[str, str]] = {"decay": "1/s", "seconds": "s"}

    @property
    def certified(self) -> bool:
        """True when the implemented table is certified."""
        return self.certificate is not None and self.certificate.certified

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not certified'``."""
        return verdict_of(self.certified)


def _solve_synthesis(grid: _Grid, b: Array, rate: float, decay: float, bound: float, T: Array, scale: float,
                     active: NDArray[np.int64], solver: str) -> tuple[str, tuple[Array, Array] | None]:
    """Maximize t: X_j ⪯ I, X_j ⪰ μI, ‖Y_j X_j⁻¹‖ <= κ, the active conditions ⪯ −tI (coordinates T, time 1/scale).

    ``‖K_j‖ <= κ`` is kept as :func:`scara_robust.synthesize` keeps it: ``X ⪰ μI`` and
    ``[[κ²μI, Y], [Yᵀ, X]] ⪰ 0`` give ``K Kᵀ = Y X⁻² Yᵀ ⪯ Y X⁻¹ Yᵀ / μ ⪯ κ² I``.
    """
    if solver == "IPM":
        return _solve_synthesis_ipm(grid, b, rate, decay, bound, T, scale, active)
    import cvxpy as cp

    n, m = grid.B.shape[1], grid.B.shape[2]
    T_inv = np.linalg.inv(T)
    # in z = T⁻¹x: X_z = T⁻¹ X T⁻ᵀ, Y_z = Y T⁻ᵀ (so K = Y_z X_z⁻¹ T⁻¹ = Y X⁻¹)
    common = math.isinf(rate)
    X = ([cp.Variable((n, n), symmetric=True) for _ in b] if not common
         else [cp.Variable((n, n), symmetric=True)] * b.size)
    Y = [cp.Variable((m, n)) for _ in b]
    t, mu = cp.Variable(), cp.Variable()
    eye_n, eye_m = np.eye(n), np.eye(m)
    cons = [t <= 1.0]
    for Xj, Yj in zip(X if not common else X[:1] * len(Y), Y):
        Xx, Yx = T @ Xj @ T.T, Yj @ T.T  # in x
        Xx = 0.5 * (Xx + Xx.T)
        cons += [Xj << eye_n, Xx >> mu * eye_n, cp.bmat([[bound**2 * mu * eye_m, Yx], [Yx.T, Xx]]) >> 0]  # type: ignore[attr-defined]
    h = np.diff(b)
    for i in active:
        A = T_inv @ grid.A[i] @ T / scale
        Bz = T_inv @ grid.B[i] / scale
        j, s = int(grid.segment[i]), float(grid.weight[i])
        Xp = (1.0 - s) * X[j] + s * X[j + 1]
        Yp: Any = (1.0 - s) * Y[j] + s * Y[j + 1]
        base = A @ Xp + Xp @ A.T - Bz @ Yp - Yp.T @ Bz.T + (2.0 * decay / scale) * Xp
        slope = (rate / scale / h[j]) * (X[j + 1] - X[j]) if not common and rate > 0 else None
        for sign in ((1.0, -1.0) if slope is not None else (0.0,)):
            M = base - sign * slope if slope is not None else base
            cons.append(0.5 * (M + M.T) << -t * eye_n)
    problem = cp.Problem(cp.Maximize(t), cons)
    status, _ = _run(problem, t, solver)
    if t.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return status, None
    if float(t.value) <= FEASIBILITY_TOL:
        return ("infeasible" if status == cp.OPTIMAL else status), None
    Xv = np.array([T @ np.asarray(Xj.value, dtype=float) @ T.T for Xj in X])
    Yv = np.array([np.asarray(Yj.value, dtype=float) @ T.T for Yj in Y])
    return status, (0.5 * (Xv + np.swapaxes(Xv, 1, 2)), Yv)


def _solve_synthesis_ipm(grid: _Grid, b: Array, rate: float, decay: float, bound: float, T: Array, scale: float,
                         active: NDArray[np.int64]) -> tuple[str, tuple[Array, Array] | None]:
    """:func:`_solve_synthesis` on the package's solver (the same LMIs, written as terms)."""
    n, m = grid.B.shape[1], grid.B.shape[2]
    T_inv = np.linalg.inv(T)
    eye, one = np.eye(n), np.ones((1, 1))
    common = math.isinf(rate)
    problem = LMIProblem()
    X = [problem.symmetric(f"X{j}", n) for j in range(1 if common else b.size)]
    Y = [problem.matrix(f"Y{j}", m, n) for j in range(b.size)]
    t, mu = problem.scalar("t"), problem.scalar("mu")
    problem.add_lmi(scalars=[(t, -one)], const=one, name="t <= 1")
    top, bottom = np.eye(m, m + n), np.eye(n, m + n, m)
    for Xj in X:
        problem.add_lmi(terms=[(Xj, -0.5 * eye, eye)], const=eye, name=f"{Xj.name} <= I")
        problem.add_lmi(terms=[(Xj, 0.5 * T.T, T.T)], scalars=[(mu, -eye)], name=f"T {Xj.name} Tᵀ >= mu I")
    for j, Yj in enumerate(Y):
        Xj = X[0 if common else j]
        # [[κ²μI, Y Tᵀ], [T Yᵀ, T X Tᵀ]] ⪰ 0
        problem.add_lmi(terms=[(Yj, top, T.T @ bottom), (Xj, 0.5 * T.T @ bottom, T.T @ bottom)],
                        scalars=[(mu, bound**2 * np.diag(np.r_[np.ones(m), np.zeros(n)]))], name=f"gain bound {j}")
    h = np.diff(b)
    A_s = T_inv @ grid.A[active] @ T / scale
    B_s = T_inv @ grid.B[active] / scale
    seg, weight = grid.segment[active], grid.weight[active][:, None, None]
    U = -(np.swapaxes(A_s, 1, 2) + (decay / scale) * eye)  # −(AX + XAᵀ + 2dX) = UᵀXV + VᵀXU, V = I
    for j in np.unique(seg).tolist():
        at = seg == j
        w = weight[at]
        Xa, Xb = X[0 if common else j], X[0 if common else j + 1]
        ident = np.broadcast_to(eye, U[at].shape)
        gains = [(Y[j], (1.0 - w) * np.swapaxes(B_s[at], 1, 2), ident),
                 (Y[j + 1], w * np.swapaxes(B_s[at], 1, 2), ident)]
        signs = (1.0, -1.0) if not common and rate > 0 else (0.0,)
        for sign in signs:
            # terms of one X with V = I are one term, their U's summed (UᵀXV + VᵀXU is linear in U):
            # the flow's and the slope's ±(ν/h)(X_{j+1} − X_j), and one X for any rate
            k = sign * rate / scale / h[j]
            flows = [(Xa, U[at], ident)] if common else [(Xa, (1.0 - w) * U[at] - 0.5 * k * eye, ident),
                                                         (Xb, w * U[at] + 0.5 * k * eye, ident)]
            problem.add_lmi(terms=flows + gains, scalars=[(t, -eye)], name=f"segment {j}, rate {sign:+g}")
    problem.maximize({t: 1.0})
    result = solve_lmi_interior(problem, t, floor=FEASIBILITY_TOL)
    if result.y is None:
        return result.status, None
    if result.value(t) <= FEASIBILITY_TOL:
        return ("infeasible" if result.status == "optimal" else result.status), None
    Xv = np.array([T @ result.value(X[0 if common else j]) @ T.T for j in range(b.size)])
    Yv = np.array([result.value(Yj) @ T.T for Yj in Y])
    return result.status, (0.5 * (Xv + np.swapaxes(Xv, 1, 2)), Yv)


def _synthesis_violation(grid: _Grid, b: Array, rate: float, decay: float, X: Array, Y: Array) -> Array:
    j, s = grid.segment, grid.weight[:, None, None]
    Xp = (1.0 - s) * X[j] + s * X[j + 1]
    Yp = (1.0 - s) * Y[j] + s * Y[j + 1]
    AX = grid.A @ Xp - grid.B @ Yp
    base = AX + np.swapaxes(AX, 1, 2) + 2.0 * decay * Xp
    worst = np.linalg.eigvalsh(base)[:, -1]
    if math.isfinite(rate) and rate > 0:
        D = ((X[1:] - X[:-1]) / np.diff(b)[:, None, None])[j] * rate
        worst = np.maximum(np.linalg.eigvalsh(base + D)[:, -1], np.linalg.eigvalsh(base - D)[:, -1])
    size = float(max(np.linalg.norm(Xj, 2) for Xj in X))
    return np.asarray(worst / size)


def synthesize_schedule(
    plant: UncertainPlant,
    breakpoints: ArrayLike,
    *,
    parameter: str | None = None,
    rate: float | None = None,
    measurement_error: float | None = None,
    decay: float | None = None,
    gain_bound: float = 1e3,
    points: int = SCHEDULE_POINTS,
    refine: int = SCHEDULE_REFINE,
    tol: float = 0.02,
    solver: str | None = None,
    progress: Callable[[float, bool], None] | None = None,
) -> ScheduleSynthesis:
    """Synthesize a gain scheduled on a measured parameter: the largest certified decay at ‖K_j‖ <= κ.

    Parameters
    ----------
    plant : UncertainPlant
    breakpoints : array_like, shape (N + 1,)
        Strictly increasing; the first and last at the ends of the parameter's range.
    parameter : str, optional
        Default: the plant's one measured parameter.
    rate : float, optional
        ν, unit/s (default the parameter's ``rate``; ``inf`` when it has none: the
        synthesis then asks one X for all p).
    measurement_error : float, optional
        δ covered by the certificate of the table (default the parameter's effective error).
    decay : float, optional
        A required decay α (1/s) instead of the largest.
    gain_bound : float
        κ > 0: ``‖K_j‖₂ <= κ`` at every breakpoint (so at every p̂, K being linear between).
    points, refine : int
        As :func:`schedule_certificate`.
    tol : float
        Relative tolerance of the bisection on α.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    progress : callable ``progress(alpha, ok)``, optional
        Called after each step of the bisection.

    Returns
    -------
    ScheduleSynthesis
        Each step counts only when the table it gives is certified by
        :func:`schedule_certificate` (with δ and ν) at that α.
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    name = scheduled_parameter(plant, parameter)
    param = plant.parameter(name)
    b = _breakpoints(plant, name, breakpoints)
    lo, hi = param.range
    if abs(b[0] - lo) > 1e-9 * max(1.0, abs(lo)) or abs(b[-1] - hi) > 1e-9 * max(1.0, abs(hi)):
        raise ArgumentValueError("breakpoints", f"must start and end at {name}'s range [{lo:g}, {hi:g}] "
                                                f"{param.unit}, found [{b[0]:g}, {b[-1]:g}]")
    nu, _ = param.motion_bounds(rate)
    kappa = check_real("gain_bound", gain_bound, positive=True)
    if not cvxpy_available():
        return ScheduleSynthesis(None, math.nan, None, kappa, nu, 0, 0.0, NOT_INSTALLED,
                                 "cvxpy is not installed (extra `lmi`)")
    grid = _grid(plant, name, b, points, _others(plant, name, False))
    # the coordinates of the open loop at the centre: A itself may be unstable, so balance
    # the loop of a stabilizing Riccati gain there
    centre = int(np.argmin(np.abs(grid.p - 0.5 * (lo + hi))))
    ref_gain = design(_frozen(plant, name, float(grid.p[centre])), 1.0, 10.0).K
    T, scale = _units(grid.A[centre] - grid.B[centre] @ ref_gain)
    steps = 0
    best: tuple[float, ScheduledGain, ScheduleCertificate] | None = None
    active_memory = np.unique(np.concatenate([np.flatnonzero(grid.segment == j)[:1] for j in range(b.size - 1)]))

    def attempt(alpha: float) -> tuple[ScheduledGain, ScheduleCertificate] | None:
        nonlocal steps, active_memory
        steps += 1

        def solve(active: NDArray[np.int64]) -> tuple[str, tuple[Array, Array] | None]:
            return _solve_synthesis(grid, b, nu, alpha, kappa, T, scale, active, solver)

        def violation(answer: tuple[Array, Array]) -> Array:
            return _synthesis_violation(grid, b, nu, alpha, *answer)

        status, answer, active = grow_active_set(solve, violation, active_memory)
        active_memory = active
        if answer is None:
            return None
        # an inaccurate solve is only a candidate: the table it gives is certified below, or not
        X, Y = answer
        K = np.array([Yj @ np.linalg.inv(Xj) for Xj, Yj in zip(X, Y)])
        table = ScheduledGain(name, param.unit, b, K, "lmi")
        cert = schedule_certificate(plant, table, rate=nu, measurement_error=measurement_error, decay=alpha,
                                    points=points, refine=refine, solver=solver)
        return (table, cert) if cert.certified else None

    def ok(alpha: float) -> bool:
        nonlocal best
        found = attempt(alpha)
        if found is not None and (best is None or alpha >= best[0]):
            best = (alpha, *found)
        if progress is not None:
            progress(alpha, found is not None)
        return found is not None

    if decay is not None:
        ok(check_real("decay", decay, nonnegative=True))
    elif ok(0.0):
        # a bracket by doubling from a tenth of the loop's time unit, then bisection; no gain
        # of norm κ makes a loop decay faster than ‖A‖ + κ‖B‖
        top = float(kappa * max(np.linalg.norm(Bi, 2) for Bi in grid.B) + max(np.linalg.norm(Ai, 2) for Ai in grid.A))
        low, high = 0.0, min(0.1 * scale, top)
        while high < top and ok(high):
            low, high = high, min(2.0 * high, top)
        if high > low and not (high >= top and best is not None and best[0] >= top):
            bisect(ok, low, high, tol)
    seconds = time.perf_counter() - start
    if best is None:
        return ScheduleSynthesis(None, math.nan, None, kappa, nu, steps, seconds, "infeasible",
                                 "no scheduled gain certified" + (f" at decay {decay:g} 1/s" if decay is not None
                                                                   else ""))
    alpha, table, cert = best
    record = {"range": [float(b[0]), float(b[-1])], "rate": nu, "measurement_error": cert.measurement_error,
              "decay": alpha, "plant": plant.name, "checked_conditions": cert.verified_on, "gain_bound": kappa}
    table = table.with_certificate(**record)
    return ScheduleSynthesis(table, alpha, cert, kappa, nu, steps, seconds, "certified",
                             f"decay {alpha:.4g} 1/s certified for the table with |d{name}/dt| <= {nu:g} "
                             f"{param.unit}/s and measurement error {cert.measurement_error:g} {param.unit} "
                             f"({steps} LMI steps, {seconds:.1f} s)")


def synthesize_schedule_rate(
    plant: UncertainPlant,
    breakpoints: ArrayLike,
    *,
    parameter: str | None = None,
    decay: float = 0.0,
    measurement_error: float | None = None,
    gain_bound: float = 1e3,
    rate_max: float | None = None,
    tol: float = 0.05,
    points: int = SCHEDULE_POINTS,
    refine: int = SCHEDULE_REFINE,
    solver: str | None = None,
    progress: Callable[[float, bool], None] | None = None,
) -> ScheduleSynthesis:
    """Synthesize the scheduled gain certified for the fastest parameter: the largest ν at decay α.

    Each step is :func:`synthesize_schedule` at a required decay α and a rate ν, counted
    only when the table it gives is certified as it runs. Feasibility is monotone in ν
    (the conditions at ν' < ν are convex combinations of those at ±ν), so the largest ν
    is bracketed by doubling from one range width per second and then bisected. Any rate
    (one X for every p) is tried first; when the frozen parameter's table fails its
    gridded check, slower rates are probed (the search of :func:`max_schedule_rate`).

    Parameters
    ----------
    plant : UncertainPlant
    breakpoints : array_like, shape (N + 1,)
        Strictly increasing; the first and last at the ends of the parameter's range.
    parameter : str, optional
        Default: the plant's one measured parameter.
    decay : float
        α >= 0 (1/s) required at every rate.
    measurement_error : float, optional
        δ (default the parameter's effective error).
    gain_bound : float
        κ > 0, ``‖K_j‖₂ <= κ``.
    rate_max : float, optional
        Largest rate tried (default 1e4 range widths per second).
    tol : float
        Relative tolerance of the bisection on ν.
    points, refine : int
        As :func:`schedule_certificate`.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    progress : callable ``progress(rate, ok)``, optional

    Returns
    -------
    ScheduleSynthesis
        The table of the largest certified ν (:attr:`ScheduleSynthesis.rate`; ``inf``: any
        rate), at decay α; ``status`` ``'infeasible'`` when not even a frozen parameter
        (ν = 0) nor any probed rate gives one.
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    name = scheduled_parameter(plant, parameter)
    param = plant.parameter(name)
    alpha = check_real("decay", decay, nonnegative=True)
    kappa = check_real("gain_bound", gain_bound, positive=True)
    lo, hi = param.range
    width = hi - lo
    cap = 1e4 * width if rate_max is None else check_real("rate_max", rate_max, positive=True)
    found: dict[float, ScheduleSynthesis] = {}
    steps = 0

    def ok(nu: float) -> bool:
        nonlocal steps
        result = synthesize_schedule(plant, breakpoints, parameter=name, rate=nu, measurement_error=measurement_error,
                                     decay=alpha, gain_bound=kappa, points=points, refine=refine, solver=solver)
        steps += result.steps
        if result.status == NOT_INSTALLED:
            raise _NotInstalled
        if progress is not None:
            progress(nu, result.gain is not None)
        if result.gain is not None:
            found[nu] = result
        return result.gain is not None

    try:
        _largest_rate(ok, width, cap, tol)
    except _NotInstalled:
        return ScheduleSynthesis(None, math.nan, None, kappa, math.nan, steps, time.perf_counter() - start,
                                 NOT_INSTALLED, "cvxpy is not installed (extra `lmi`)")
    seconds = time.perf_counter() - start
    if not found:
        return ScheduleSynthesis(None, math.nan, None, kappa, 0.0, steps, seconds, "infeasible",
                                 f"no scheduled gain certified at decay {alpha:g} 1/s, even for a frozen {name}")
    nu = max(found)
    best = found[nu]
    what = "any rate" if math.isinf(nu) else f"|d{name}/dt| <= {nu:.4g} {param.unit}/s"
    capped = " (the largest rate tried)" if nu == cap else ""
    return ScheduleSynthesis(best.gain, alpha, best.certificate, kappa, nu, steps, seconds, "certified",
                             f"{what}{capped} certified at decay {alpha:g} 1/s for the table, measurement error "
                             f"{best.certificate.measurement_error if best.certificate else math.nan:g} "
                             f"{param.unit} ({steps} LMI steps, {seconds:.1f} s)")


class _NotInstalled(Exception):
    """cvxpy is missing: the search stops."""
