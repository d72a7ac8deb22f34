"""Robust synthesis: a state-feedback (PID) gain designed together with its Lyapunov certificate.

For an uncertainty set given by its vertices or samples ``(A_i, B_i)``, find ``Q ≻ 0`` and
``Y`` with (Boyd et al., *Linear Matrix Inequalities in System and Control Theory*, 1994,
§7.2.1)::

    A_i Q + Q A_iᵀ − B_i Y − Yᵀ B_iᵀ + 2α Q ≺ 0      at every i,

then ``K = Y Q⁻¹`` (``u = −Kx``) and ``P = Q⁻¹``: ``V = xᵀPx`` decays at least as fast as
``e^{−2αt}`` for any time variation inside the convex hull. The decay rate α is maximized
by bisection (each step an LMI, cvxpy + Clarabel: extra ``lmi``). ``‖K‖₂ <= κ`` is kept by
``Q ⪰ μI`` and ``[[κ²μI, Y], [Yᵀ, Q]] ⪰ 0``. Two other objectives share the same LMI:
``'l2'`` adds the state-feedback bounded-real inequality (§7.5.1) and minimizes the bound
γ on the worst-case L2 gain from a disturbance to the tracking error; ``'margin'`` bisects
the largest scaling θ of the uncertainty set one gain certifies. The answer is re-verified
with numpy on the same set and, when given, on an independent one; a gain numpy cannot
verify is reported as not certified.

Input limits ``|u_i| <= ū_i`` from a set of initial errors with vertices v are constraints
of every objective (§5.2.2, §7.2.3): with the level of ``E = {xᵀQ⁻¹x <= 1}`` fixed at 1,
``[[1, vᵀ], [v, Q]] ⪰ 0`` puts every v in E and ``[[ū_i², Y_i], [Y_iᵀ, Q]] ⪰ 0`` keeps
``|K_i x| <= ū_i`` on E, which V makes invariant
(:func:`~scara_robust.input_limit_certificate` re-verifies both with numpy).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_real
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import Design
from ..model.plant import ModelLike, Signal, as_model, is_model
from ..results import AnalysisResult
from ..sdp import LMIProblem, LMIVariable, solve_lmi
from ..sdp.backends import resolve_lmi_solver
from ._cutting import grow_active_set
from .actuator import InputLimitCertificate, initial_error_vertices, input_limit_certificate, input_limits_of
from .l2gain import L2_INFLATION, bounded_real_ok
from .lmi import (
    DECAY_FLOOR_RTOL,
    DIRECT_LOOPS,
    NOT_INSTALLED,
    VERIFY_FARKAS_RTOL,
    cvxpy_available,
    decay_floor,
    decay_rate,
    lmi_verdict,
    solver_said,
)
from .search import bisect

__all__ = ["Synthesis", "synthesize", "GAIN_BOUND", "OBJECTIVES", "STRUCTURES", "LIMIT_MARGIN", "MAX_LIMIT_VERTICES",
           "decentralized_pattern"]

Array = NDArray[np.float64]

#: Default bound on ‖K‖₂. The paper's gain at (3, 90) has ‖K‖₂ = 378 (N·m per rad, rad·s,
#: rad/s mixed); 1000 leaves the synthesis room (2.6 times that) while keeping the closed
#: loop's fastest poles within what a 1-kHz controller and the default engines follow.
GAIN_BOUND = 1e3

#: Decay rate (1/s) the ``'l2'`` objective requires by default. The disturbance-to-error
#: gain does not see the integral states, so without a floor the L2 optimum leaves an
#: integrator mode at −10⁻⁵ 1/s; 0.5 1/s brings an initial error down by e⁻³ within the
#: paper's 6-s transient (V decays as e^{−2αt}, the state as e^{−αt}).
L2_DECAY = 0.5

#: The synthesis objectives.
OBJECTIVES = ("decay", "l2", "margin")

#: The gain structures of :func:`synthesize`: any K, or one PID per joint.
STRUCTURES = ("full", "decentralized")


def decentralized_pattern(n: int, m: int) -> tuple[Array, Array]:
    """The zero pattern of a decentralized PID: ``(S_Q (n, n), S_Y (m, n))`` of zeros and ones.

    In the PID form ``x = [∫e, e, ė]`` (n = 3m) state ``a`` belongs to joint ``a mod m``;
    ``S_Q[a, b] = 1`` when a and b belong to the same joint, ``S_Y[i, b] = 1`` when b belongs
    to joint i. With Q and Y zero outside them, ``K = Y Q⁻¹`` is zero outside ``S_Y``: torque
    i reads joint i's ``∫e_i, e_i, ė_i`` only.

    Parameters
    ----------
    n : int
        States (3m).
    m : int
        Torques, one per joint.

    Returns
    -------
    S_Q : ndarray, shape (n, n)
    S_Y : ndarray, shape (m, n)
    """
    if m < 1 or n != 3 * m:
        raise ArgumentValueError("structure", f"'decentralized' needs the PID form (n = 3m states, one torque per "
                                              f"joint), found n = {n}, m = {m}")
    joint = np.arange(n) % m
    return (joint[:, None] == joint[None, :]).astype(float), (np.arange(m)[:, None] == joint[None, :]).astype(float)


#: Largest scaling θ searched by the ``'margin'`` objective.
MARGIN_CAP = 1e3

#: With input limits, the initial errors the LMI must hold are the given ones scaled by
#: ``1 + LIMIT_MARGIN``, so that numpy's re-verification of the solver's answer
#: (:func:`~scara_robust.input_limit_certificate`, ``s* >= 1``) is not a coin toss on its
#: tolerances (~1e-8).
LIMIT_MARGIN = 1e-3

#: The most points of an initial-error set the synthesis takes (one LMI each).
MAX_LIMIT_VERTICES = 1024

#: The ``'margin'`` objective's default decay rate, relative to the plants' largest spectral
#: norm ‖A_i‖₂ (1/s): with no decay required the LMI returns gains at the edge of
#: feasibility, whose decay (~1e-7 1/s) numpy cannot tell from zero.
MARGIN_DECAY_RTOL = 1e-4


def vertices_of(model: ModelLike) -> tuple[Array, Array]:
    """The ``(A_i, B_i)`` whose convex hull is the model's uncertainty set.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
        An interval box (its 2^N corners) or a polytope (its vertices).

    Returns
    -------
    A : ndarray, shape (V, n, n)
    B : ndarray, shape (V, n, m)
    """
    return as_model("model", model).vertex_matrices()


@dataclass(frozen=True)
class Synthesis(AnalysisResult):
    """A synthesized gain and its certificate.

    Attributes
    ----------
    status : str
        ``'certified'``, ``'marginal'`` (numpy verifies a decay, but below `decay_floor`),
        ``'infeasible'`` (the solver proved that no gain within the bound makes every
        vertex decay), ``'not verified'`` (the solver's answer fails numpy's check), a
        solver status (``'optimal_inaccurate'``, ``'solver error: ...'``) or ``'not installed'``.
    K : ndarray, shape (m, n), or None
        Gain of ``u = −Kx``.
    P : ndarray, shape (n, n), or None
        Lyapunov matrix ``Q⁻¹``.
    decay : float
        The decay rate the LMI reached, 1/s (NaN without a gain).
    verified_decay : float
        numpy's decay rate (:func:`decay_rate`) on the synthesis set, 1/s.
    check_decay : float
        numpy's decay rate on the independent check set (NaN when none was given), 1/s.
    gain_norm : float
        ``‖K‖₂``.
    gain_bound : float
        κ used.
    n_vertices, n_checked : int
        Sizes of the synthesis and check sets.
    solver_status : str
        What the solver said of the last feasible LMI (``'optimal'``, ``'optimal_inaccurate'``, ...).
    seconds : float
    objective : str
        ``'decay'``, ``'l2'`` or ``'margin'``.
    gamma : float
        ``'l2'``: the bound on the worst-case L2 gain of the returned K that numpy verifies
        with P on the synthesis set (units of the output per unit of the disturbance: rad
        per N·m for the robot), ``inf`` if it cannot; NaN for the other objectives. It is
        an upper bound for this K, not the LMI's infimum: on the robot that infimum is
        approached only as P grows without bound along ∫e, so an interior-point solver
        stops short of it where its tolerances are met, at a point (and a K) that depends
        on rounding; another machine returns another K with a verified γ a few per cent
        away.
    check_gamma : float
        The same bound checked on the independent set (``inf`` if P does not verify it there).
    theta : float
        ``'margin'``: the largest scaling of the set certified (the decay and K are the ones
        found at θ); NaN for the other objectives.
    search : str
        Where and why a bisection (on α or θ) stopped; empty without one.
    decay_floor : float
        The smallest decay rate reported as certified (:func:`decay_floor`), 1/s.
    design : Design or None
        The gain as a :class:`~scara_robust.Design` on the model's nominal (ρ and η NaN),
        so every certificate, margin and simulation takes it.
    input_limits : ndarray, shape (m,), or None
        The limits ``ū_i`` the gain must keep, in the inputs' units (``inf``: none); None
        without.
    input_limit : InputLimitCertificate or None
        With ``input_limits``: numpy's check that the initial errors lie in an invariant
        ellipsoid of P on which every input stays within its limit (certified only then);
        P is scaled so that ellipsoid is ``{xᵀPx <= 1}``. None without limits.
    structure : str
        ``'full'`` or ``'decentralized'`` (a PID per joint), as asked.
    """

    status: str
    K: Array | None
    P: Array | None
    decay: float
    verified_decay: float
    check_decay: float
    gain_norm: float
    gain_bound: float
    n_vertices: int
    n_checked: int
    seconds: float
    design: Design | None
    solver_status: str = ""
    objective: str = "decay"
    gamma: float = math.nan
    check_gamma: float = math.nan
    theta: float = math.nan
    search: str = ""
    decay_floor: float = math.nan
    input_limits: Array | None = None
    input_limit: InputLimitCertificate | None = None
    structure: str = "full"

    @property
    def verdict(self) -> str:
        """What the answer proves: ``'certified'``, ``'marginal'`` (verified, but the decay is
        below :attr:`decay_floor`), ``'infeasible'`` (the solver proved it), ``'inaccurate'`` or
        ``'unknown'`` (see :data:`~scara_robust.LMI_VERDICTS`)."""
        if self.certified:
            return "certified"
        if self.status in ("marginal", "infeasible"):
            return self.status
        if self.status == "not verified":
            return "inaccurate"
        return lmi_verdict(self.status, False)

    @property
    def certified(self) -> bool:
        """numpy verified a positive decay on the synthesis set and, if given, on the check set."""
        checked = math.isnan(self.check_decay) or self.check_decay > 0
        return bool(self.status == "certified" and self.verified_decay > 0 and checked)

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.certified:
            said = "" if self.solver_status == "optimal" else f" (the solver said {self.solver_status})"
            extra = said + ("" if math.isnan(self.check_decay) else (
                f"; on {self.n_checked} independent samples α >= {self.check_decay:.4g} 1/s"))
            if self.objective == "l2":
                extra += f"; worst-case L2 gain <= {self.gamma:.4g}"
                if not math.isnan(self.check_gamma):
                    extra += (f" (on the independent samples <= {self.check_gamma:.4g})"
                              if math.isfinite(self.check_gamma) else " (not verified by P on the independent samples)")
            if self.objective == "margin":
                extra += f"; the set scaled by θ = {self.theta:.4g} is certified ({self.search})"
            if self.input_limit is not None:
                extra += f"; inputs within their limits: {self.input_limit.message}"
            return (f"gain found with ‖K‖ = {self.gain_norm:.4g} <= {self.gain_bound:g}; numpy verifies the decay "
                    f"rate α >= {self.verified_decay:.4g} 1/s (V̇ <= −2αV) on the {self.n_vertices} synthesis "
                    f"points{extra}")
        if self.status == "infeasible":
            limits = "" if self.input_limits is None else (
                " that keeps every input within its limit from the initial errors")
            return f"no gain with ‖K‖ <= {self.gain_bound:g} and a common quadratic Lyapunov function exists{limits}"
        if self.status == "marginal":
            return (f"marginal, not certified: numpy verifies a decay of only {self.verified_decay:.3g} 1/s, below "
                    f"the floor {self.decay_floor:.3g} 1/s ({DECAY_FLOOR_RTOL:g} of the loops' norm), within the "
                    "solver's tolerances of zero")
        if self.K is not None:
            limits = "" if self.input_limit is None else f"; input limits: {self.input_limit.message}"
            return (f"the solver returned a gain ({self.status}) that numpy does not certify: decay "
                    f"{self.verified_decay:.4g} 1/s on the synthesis set, {self.check_decay:.4g} on the check set"
                    f"{limits}")
        return f"no gain: {solver_said(self.status)}"


#: The decay LMI's strictness: ``A_iQ − B_iY + (·)ᵀ + 2αQ ⪯ −10⁻⁶I`` (Q ⪰ I).
_DECAY_LMI_SLACK = 1e-6


def _solve(
    A: Array, B: Array, alpha: float, kappa: float, solver: str, l2: tuple[Array, Array] | None = None,
    limits: tuple[Array, Array] | None = None, pattern: tuple[Array, Array] | None = None,
    accept: Callable[[Array, Array], bool] | None = None,
) -> tuple[str, Array | None, Array | None, float]:
    """One LMI: decay ``alpha`` and ``‖K‖ <= κ``; with ``l2 = (B_w, C)`` also minimize γ.

    With ``limits = (ū (m,), V (k, n))`` also ``[[1, v_jᵀ], [v_j, Q]] ⪰ 0`` for every point
    and ``[[ū_i², Y_i], [Y_iᵀ, Q]] ⪰ 0`` for every finite ū_i. With ``pattern = (S_Q (n, n),
    S_Y (m, n))`` of zeros and ones, Q and Y are zero where the pattern is (the solver's
    residue there, at its tolerance, is set to exactly zero before Q and Y are returned).

    With the package's solver (``'IPM'``) and `accept(Q, Y)`, the first (Q, Y) it accepts is
    returned. Returns the solver status, Q, Y and γ (NaN without `l2`).
    """
    if solver == "IPM" and l2 is None and limits is None:
        return _solve_ipm(A, B, alpha, kappa, pattern, accept)
    problem, var = performance_synthesis_problem(A, B, alpha, kappa, l2, limits, pattern)
    result = solve_lmi(problem, solver)
    if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
        return result.status, None, None, math.nan
    g = float(result.value(var["gamma"])) if "gamma" in var else math.nan
    if l2 is not None:
        # γ* sits on the boundary of the feasible set, where the gain is as fragile as the LMI is tight:
        # the most interior (Q, Y) at γ*(1 + L2_INFLATION), as l2_gain's check does for a given loop
        g *= 1 + L2_INFLATION
        interior, inner = performance_synthesis_problem(A, B, alpha, kappa, l2, limits, pattern, gamma=g)
        second = solve_lmi(interior, solver)
        if second.y is not None and second.status in ("optimal", "optimal_inaccurate") \
                and second.value(inner["t"]) > 0:
            result, var = second, inner
    Q_value, Y_value = result.value(var["Q"]), result.value(var["Y"])
    status = result.status
    Q_value, Y_value = np.asarray(Q_value, dtype=float), np.asarray(Y_value, dtype=float)
    if pattern is not None:
        Q_value, Y_value = Q_value * pattern[0], Y_value * pattern[1]
    return status, Q_value, Y_value, g


def performance_synthesis_problem(
    A: Array, B: Array, alpha: float, kappa: float, l2: tuple[Array, Array] | None,
    limits: tuple[Array, Array] | None, pattern: tuple[Array, Array] | None = None, *, gamma: float | None = None,
) -> tuple[LMIProblem, dict[str, LMIVariable]]:
    """The synthesis LMI (decay, L2 objective or input limits) as an :class:`~scara_robust.LMIProblem`.

    Q ⪰ μI, μ >= 0 and ``[[κ²μI, Y], [Yᵀ, Q]] ⪰ 0`` (so ‖K‖ = ‖YQ⁻¹‖ <= κ), the decay
    ``−(A_iQ − B_iY + (·)ᵀ + 2αQ) ⪰ 10⁻⁶ I`` at every plant, and:

    - with ``l2 = (B_w (V, n, q), C (p, n))``: ``minimize γ`` with the bounded-real block
      ``−[[A_iQ − B_iY + (·)ᵀ, B_w,i, QCᵀ], [B_w,iᵀ, −γI, 0], [CQ, 0, −γI]] ⪰ 10⁻⁹ I``;
    - with ``limits = (ū (m,), V (k, n))``: ``[[1, v_jᵀ], [v_j, Q]] ⪰ 0`` for every point and
      ``[[ū_i², Y_i], [Y_iᵀ, Q]] ⪰ 0`` for every finite ū_i; without `l2`, ``maximize μ <= 1``
      (the ellipsoid as round as the limits allow);
    - with `l2` and a given `gamma`: ``maximize t <= 1`` with the decay and bounded-real blocks
      ⪰ tI at that γ: the most interior (Q, Y) of the level set;
    - with neither: μ = 1 (the decay LMI is homogeneous in (Q, Y)) and ``minimize trace Q``,
      the decay synthesis as cvxpy's solvers answer it (the package's solver takes
      :func:`synthesis_problem`, its always-feasible form).

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    B : ndarray, shape (V, n, m)
    alpha, kappa : float
    l2 : (ndarray (V, n, q), ndarray (p, n)) or None
    limits : (ndarray (m,), ndarray (k, n)) or None
    pattern : (ndarray (n, n), ndarray (m, n)), optional
    gamma : float, optional
        A fixed γ (with `l2`).

    Returns
    -------
    problem : LMIProblem
    variables : dict
        ``'Q'``, ``'Y'``; with `l2` or `limits` ``'mu'``; with `l2`, ``'gamma'`` (or ``'t'`` with `gamma`).
    """
    n, m = A.shape[1], B.shape[2]
    eye = np.eye(n)
    problem = LMIProblem()
    Q = problem.symmetric("Q", n, pattern=None if pattern is None else pattern[0])
    Y = problem.matrix("Y", m, n, pattern=None if pattern is None else pattern[1])
    variables = {"Q": Q, "Y": Y}
    one = np.ones((1, 1))
    top, bottom = np.eye(m, m + n), np.eye(n, m + n, m)
    upper_left = kappa**2 * np.diag(np.r_[np.ones(m), np.zeros(n)])
    if l2 is None and limits is None:
        problem.add_lmi(terms=[(Q, 0.5 * eye, eye)], const=-eye, name="Q >= I")
        problem.add_lmi(terms=[(Y, top, bottom), (Q, 0.5 * bottom, bottom)], const=upper_left, name="gain bound")
        problem.add_lmi(terms=[(Q, -np.swapaxes(A, 1, 2) - alpha * eye, eye), (Y, np.swapaxes(B, 1, 2), eye)],
                        const=-_DECAY_LMI_SLACK * eye, name="decay")
        problem.minimize({Q: eye})
        return problem, variables
    mu = problem.scalar("mu")
    variables["mu"] = mu
    problem.add_lmi(terms=[(Q, 0.5 * eye, eye)], scalars=[(mu, -eye)], name="Q >= mu I")
    problem.add_lmi(scalars=[(mu, one)], name="mu >= 0")
    problem.add_lmi(terms=[(Y, top, bottom), (Q, 0.5 * bottom, bottom)], scalars=[(mu, upper_left)],
                    name="gain bound")
    t = problem.scalar("t") if l2 is not None and gamma is not None else None
    margin = [] if t is None else [(t, -eye)]
    problem.add_lmi(terms=[(Q, -np.swapaxes(A, 1, 2) - alpha * eye, eye), (Y, np.swapaxes(B, 1, 2), eye)],
                    scalars=margin, const=-_DECAY_LMI_SLACK * eye, name="decay")
    if l2 is not None:
        Bw, C = l2
        q, p = Bw.shape[2], C.shape[0]
        size = n + q + p
        En, Ep = np.eye(n, size), np.eye(p, size, n + q)
        const = np.zeros((A.shape[0], size, size))
        const[:, :n, n:n + q] = -Bw
        const[:, n:n + q, :n] = -np.swapaxes(Bw, 1, 2)
        corner = np.diag(np.r_[np.zeros(n), np.ones(q + p)])
        terms = [(Q, -np.swapaxes(A, 1, 2) @ En, En), (Y, np.swapaxes(B, 1, 2) @ En, En), (Q, -En, C.T @ Ep)]
        if t is None or gamma is None:
            g = problem.scalar("gamma")
            variables["gamma"] = g
            problem.add_lmi(terms=terms, scalars=[(g, corner)], const=const - 1e-9 * np.eye(size),
                            name="bounded real")
            problem.minimize({g: 1.0})
        else:
            variables["t"] = t
            problem.add_lmi(terms=terms, scalars=[(t, -np.eye(size))], const=const + gamma * corner,
                            name="bounded real")
            problem.add_lmi(scalars=[(t, -one)], const=one, name="t <= 1")
            problem.maximize({t: 1.0})
    if limits is not None:
        u_max, points = limits
        F = np.eye(n, 1 + n, 1)
        if len(points):
            const = np.zeros((len(points), 1 + n, 1 + n))
            const[:, 0, 0] = 1.0
            const[:, 0, 1:], const[:, 1:, 0] = points, points
            problem.add_lmi(terms=[(Q, 0.5 * F, F)], const=const, name="initial errors inside")
        for k in np.flatnonzero(np.isfinite(u_max)).tolist():
            U = np.zeros((m, 1 + n))
            U[k, 0] = 1.0
            problem.add_lmi(terms=[(Y, U, F), (Q, 0.5 * F, F)], const=np.diag(np.r_[u_max[k] ** 2, np.zeros(n)]),
                            name=f"input {k} limit")
        if l2 is None:
            # the feasible Q are bounded above by the limits, not below: make E as round as the limits allow
            # (Q ⪰ μI, μ <= 1, the size of the initial errors) instead of shrinking it onto them
            problem.add_lmi(scalars=[(mu, -one)], const=one, name="mu <= 1")
            problem.maximize({mu: 1.0})
    return problem, variables


def synthesis_problem(A: Array, B: Array, alpha: float, kappa: float,
                      pattern: tuple[Array, Array] | None = None) -> tuple[LMIProblem, dict[str, LMIVariable]]:
    """The decay synthesis LMI in its always-feasible form, for the package's solver.

    ``maximize t`` subject to ``Q ⪯ I``, ``Q ⪰ μI``, ``μ >= t``, ``[[κ²μI, Y], [Yᵀ, Q]] ⪰ 0`` and
    ``−(A_iQ + QA_iᵀ − B_iY − YᵀB_iᵀ + 2αQ) ⪰ tI`` at every plant: strictly feasible for any data
    (``Q = I/2``, ``Y = 0``, t → −∞), and t* > 0 exactly when the LMI of :func:`_solve` (Q ⪰ I,
    μ = 1, strict decay) has a solution, which is ``(Q/μ, Y/μ)``.

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    B : ndarray, shape (V, n, m)
    alpha, kappa : float
    pattern : (ndarray (n, n), ndarray (m, n)), optional

    Returns
    -------
    problem : LMIProblem
    variables : dict
        ``'Q'``, ``'Y'``, ``'mu'``, ``'t'``.
    """
    n, m = A.shape[1], B.shape[2]
    eye = np.eye(n)
    problem = LMIProblem()
    Q = problem.symmetric("Q", n, pattern=None if pattern is None else pattern[0])
    Y = problem.matrix("Y", m, n, pattern=None if pattern is None else pattern[1])
    mu, t = problem.scalar("mu"), problem.scalar("t")
    problem.add_lmi(terms=[(Q, -0.5 * eye, eye)], const=eye, name="Q <= I")
    problem.add_lmi(terms=[(Q, 0.5 * eye, eye)], scalars=[(mu, -eye)], name="Q >= mu I")
    problem.add_lmi(scalars=[(mu, np.ones((1, 1))), (t, -np.ones((1, 1)))], name="mu >= t")
    top, bottom = np.eye(m, m + n), np.eye(n, m + n, m)
    problem.add_lmi(terms=[(Y, top, bottom), (Q, 0.5 * bottom, bottom)],
                    scalars=[(mu, kappa**2 * np.diag(np.r_[np.ones(m), np.zeros(n)]))], name="gain bound")
    problem.add_lmi(terms=[(Q, -np.swapaxes(A, 1, 2) - alpha * eye, eye), (Y, np.swapaxes(B, 1, 2), eye)],
                    scalars=[(t, -eye)], name="decay")
    problem.maximize({t: 1.0})
    return problem, {"Q": Q, "Y": Y, "mu": mu, "t": t}


def _solve_ipm(A: Array, B: Array, alpha: float, kappa: float, pattern: tuple[Array, Array] | None,
               accept: Callable[[Array, Array], bool] | None = None) -> tuple[str, Array | None, Array | None, float]:
    """:func:`_solve`'s decay LMI (no L2 term, no limits) by the package's solver: status, Q (⪰ I), Y, NaN.

    With `accept(Q, Y)`, the solver stops at the first (Q, Y) it accepts.
    """
    problem, var = synthesis_problem(A, B, alpha, kappa, pattern)
    Q, Y, mu, t = var["Q"], var["Y"], var["mu"], var["t"]

    def take(y: Array) -> bool:
        m_y = float(y[mu.offset])
        return accept is not None and y[t.offset] > 0 and m_y > 0 and accept(Q.value(y) / m_y, Y.value(y) / m_y)

    result = solve_lmi(problem, "IPM", accept=take if accept is not None else None)
    if result.y is None:
        return result.status, None, None, math.nan
    t_val, mu_val = result.value(t), result.value(mu)
    if t_val <= 0 or mu_val <= 0:
        # t* <= 0: infeasible when the dual blocks prove it (numpy's check), else not proven
        proven = result.duals is not None and synthesis_farkas_holds(A, B, alpha, kappa, result.duals)
        return ("infeasible" if proven else "infeasible_inaccurate"), None, None, math.nan
    return result.status, result.value(Q) / mu_val, result.value(Y) / mu_val, math.nan


def synthesis_farkas_holds(A: Array, B: Array, alpha: float, kappa: float, duals: Sequence[Array]) -> bool:
    """numpy's check of a proof that no gain with ``‖K‖ <= κ`` and decay ``alpha`` exists.

    For the dual blocks of :func:`synthesis_problem` (``Z_Q`` of ``Q ⪰ μI``, ``Z_G`` of the gain
    bound, ``Z_i`` of the plants), projected on the positive semidefinite cone: every
    solution (Q ≻ 0, ``Y = KQ``, ``0 < μ <= λmin(Q)``) would give ``0 <= Σ⟨Z_i, D_i⟩ <= ⟨T, Q⟩``
    with ``D_i = −(A_iQ + QA_iᵀ − B_iY − YᵀB_iᵀ + 2αQ) ⪰ 0``,
    ``T = −Σ(A_iᵀZ_i + Z_iA_i + 2αZ_i) + Z_G,22 + κ² tr(Z_G,11) Z_Q / tr(Z_Q) + κ‖E‖₂ I`` and
    ``E = 2Σ B_iᵀZ_i + 2Z_G,12`` (using ``⟨Z_G, G⟩ >= 0``, ``μ <= ⟨Q, Z_Q⟩/tr(Z_Q)`` and
    ``|⟨E, KQ⟩| <= κ‖E‖₂ tr Q``); ``T ≺ 0`` makes that impossible (Boyd et al. 1994, §2.2.3).

    Parameters
    ----------
    A : ndarray, shape (V, n, n)
    B : ndarray, shape (V, n, m)
    alpha, kappa : float
    duals : sequence of ndarray
        The families' dual blocks, in :func:`synthesis_problem`'s order.

    Returns
    -------
    bool
        True when ``λmax(T) < −VERIFY_FARKAS_RTOL · ‖Σ(A_iᵀZ_i + Z_iA_i)‖₂``.
    """
    def psd(Z: Array) -> Array:
        w, V = np.linalg.eigh(0.5 * (Z + np.swapaxes(Z, -1, -2)))
        return np.asarray((V * np.clip(w, 0.0, None)[..., None, :]) @ np.swapaxes(V, -1, -2))

    n, m = A.shape[1], B.shape[2]
    Z_Q, Z_G, Z_i = psd(duals[1][0]), psd(duals[3][0]), psd(duals[4])
    AZ = np.swapaxes(A, 1, 2) @ Z_i
    lyap = (AZ + np.swapaxes(AZ, 1, 2)).sum(axis=0)
    E = 2.0 * (np.swapaxes(B, 1, 2) @ Z_i).sum(axis=0) + 2.0 * Z_G[:m, m:]
    mu_term = kappa**2 * np.trace(Z_G[:m, :m])
    T = -lyap - 2 * alpha * Z_i.sum(axis=0) + Z_G[m:, m:] + kappa * np.linalg.norm(E, 2) * np.eye(n)
    T += mu_term * Z_Q / np.trace(Z_Q) if np.trace(Z_Q) > 0 else mu_term * np.eye(n)
    scale = max(float(np.linalg.norm(lyap, 2)), 1e-300)
    return bool(np.linalg.eigvalsh(0.5 * (T + T.T))[-1] < -VERIFY_FARKAS_RTOL * scale)


def _solve_by_cuts(
    A: Array, B: Array, alpha: float, kappa: float, solver: str, active: list[NDArray[np.int64]],
    limits: tuple[Array, Array] | None = None, pattern: tuple[Array, Array] | None = None,
) -> tuple[str, Array | None, Array | None, float]:
    """:func:`_solve` (no L2 term) by cutting planes over the plants: the same answer, on a few of them at a time.

    The LMI is solved on an active set of plants, grown by the plants whose decay constraint
    ``A_iQ − B_iY + (·)ᵀ + 2αQ ⪯ −10⁻⁶I`` the answer violates most, until none does: (Q, Y)
    then satisfies every plant's constraint, as a solve on all of them would. `active` holds
    the last active set, carried from one solve of a search to the next (plants indexed alike).
    """
    extra = {} if limits is None else {"limits": limits}  # without limits, _solve is called as before
    if pattern is not None:
        extra["pattern"] = pattern

    def violation(answer: tuple[Array, Array, float]) -> Array:
        Q, Y, _ = answer
        AQ = A @ Q - B @ Y
        lhs = AQ + np.swapaxes(AQ, -1, -2) + 2 * alpha * Q
        return np.asarray(np.linalg.eigvalsh(lhs)[:, -1] + _DECAY_LMI_SLACK)

    def solve(idx: NDArray[np.int64]) -> tuple[str, tuple[Array, Array, float] | None]:
        options: dict[str, Any] = dict(extra)
        if solver == "IPM":
            # the first (Q, Y) whose decay constraint holds at every plant answers the search's question
            options["accept"] = lambda Q, Y: bool((violation((Q, Y, 0.0)) <= 0).all())
        status, Q, Y, g = _solve(A[idx], B[idx], alpha, kappa, solver, **options)
        return status, None if Q is None or Y is None else (Q, Y, g)

    n_plants = A.shape[0]
    if n_plants <= DIRECT_LOOPS:  # (every plant at once is slower here, also with the package's solver)
        first = np.arange(n_plants)
    elif active and active[0][-1] < n_plants:
        first = active[0]
    else:  # the plant of largest norm: the fastest dynamics the gain must hold
        first = np.array([int(np.argmax(np.linalg.norm(A, 2, axis=(1, 2))))])
    status, answer, found = grow_active_set(solve, violation, first)
    active[:] = [found]
    if answer is None:
        return status, None, None, math.nan
    return status, answer[0], answer[1], answer[2]


def _largest(
    verdict: Callable[[float], str], start: float, tol: float, cap: float, floor: float
) -> tuple[float, float, str]:
    """Largest x in [0, cap] with ``verdict(x) == 'certified'`` (monotone), given it at 0: doubling, then bisection.

    Only ``'certified'`` moves the lower end. Any other verdict moves the upper end of the
    search, and the reason names it: only ``'infeasible'`` is a proof that x is out of reach.
    The search ends when the bracket is `tol` relative, or its upper end below `floor`.

    Returns
    -------
    lo, hi : float
        Certified at lo; hi the first x not certified (inf if none up to `cap`).
    reason : str
        Where the search ended, and what the answer at hi was.
    """
    lo, hi = 0.0, start
    answer = ""
    while True:
        if hi >= cap:
            return lo, math.inf, f"certified up to {lo:g}, the largest searched"
        answer = verdict(hi)
        if answer != "certified":
            break
        lo, hi = hi, 2 * hi
    def certified(x: float) -> bool:
        nonlocal answer
        step = verdict(x)
        if step != "certified":
            answer = step
        return step == "certified"

    lo, hi = bisect(certified, lo, hi, tol, stop=lambda lo, hi, mid: hi <= floor, desc="decay")
    proof = "proven infeasible" if answer == "infeasible" else f"{answer}, neither certified nor proven infeasible"
    return lo, hi, f"certified at {lo:.6g}; at {hi:.6g} the LMI is {proof}"


def _verdict(A: Array, B: Array, solution: tuple[str, Array | None, Array | None, float], alpha: float,
             accept: Callable[[Array, Array], bool] | None = None) -> str:
    """One synthesis LMI's answer, checked with numpy: certified only if V decays at >= α and the floor.

    `accept(K, P)`, when given, must also hold (the input limits).
    """
    status, Q, Y, _ = solution
    if Q is None or Y is None:
        return lmi_verdict(status, False)
    P = np.linalg.inv(Q)
    K = Y @ P
    loops = A - B @ K
    rate = decay_rate(loops, 0.5 * (P + P.T))
    if accept is not None and not accept(K, 0.5 * (P + P.T)):
        return lmi_verdict(status, False)
    if rate >= max(alpha * (1 - 1e-6), decay_floor(loops)):
        return "certified"
    return "marginal" if rate > 0 else lmi_verdict(status, False)


def _verified_gamma(A_cl: Array, Bw: Array, C: Array, P: Array, gamma: float) -> float:
    """The smallest of γ(1 + 10⁻⁶), γ(1 + 10⁻³), γ(1.01) that numpy's bounded-real check accepts (inf if none).

    The LMI in (Q, γ) is the bounded-real inequality for ``P̃ = γQ⁻¹`` (multiply its Schur
    complement by γ), so that is the matrix checked.
    """
    for factor in (1 + 1e-6, 1 + 1e-3, 1.01):
        if bounded_real_ok(A_cl, Bw, C, gamma * P, gamma * factor):
            return gamma * factor
    return math.inf


def error_output(n_states: int, n_inputs: int) -> Array:
    """``C = [0, I, 0]``: the tracking error ``e`` of a PID-augmented state ``[∫e, e, ė]``.

    Parameters
    ----------
    n_states, n_inputs : int
        ``n_states = 3 n_inputs`` (one ∫e, e, ė per joint).

    Returns
    -------
    ndarray, shape (n_inputs, n_states)

    Raises
    ------
    ArgumentValueError
        If the state is not PID-augmented (then pass ``output`` explicitly).
    """
    if n_states != 3 * n_inputs:
        raise ArgumentValueError("output", f"is needed: a state of {n_states} with {n_inputs} inputs is not "
                                           "[∫e, e, ė], so the tracking error cannot be inferred")
    C = np.zeros((n_inputs, n_states))
    C[:, n_inputs:2 * n_inputs] = np.eye(n_inputs)
    return C


def synthesize(
    model: ModelLike | tuple[ArrayLike, ArrayLike],
    *,
    objective: str = "decay",
    decay: float | None = None,
    gain_bound: float = GAIN_BOUND,
    output: ArrayLike | None = None,
    disturbance: ArrayLike | None = None,
    check: tuple[ArrayLike, ArrayLike] | None = None,
    nominal: ModelLike | None = None,
    tol: float = 1e-2,
    solver: str | None = None,
    input_limits: ArrayLike | None = None,
    initial_errors: ArrayLike | None = None,
    structure: str = "full",
    inputs: Sequence[Signal] | None = None,
) -> Synthesis:
    """Synthesize ``u = −Kx`` and its common Lyapunov matrix over an uncertainty set.

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel or tuple (A, B)
        The set: an interval box (its corners), a polytope (its vertices), or sampled
        pairs ``(A (k, n, n), B (k, n, m))`` (the robot's :func:`scara_robust.physical_samples`).
    objective : {'decay', 'l2', 'margin'}
        ``'decay'``: the largest decay rate α (or the one required by `decay`).
        ``'l2'``: the smallest bound γ on the worst-case L2 gain from the disturbance
        (entering through `disturbance`, default B: a torque added to the control torque)
        to `output` (default the tracking error e), with decay >= `decay` (default
        :data:`L2_DECAY`). ``'margin'``: the largest θ for which one gain certifies the
        model's set scaled by θ about its nominal (box or polytope only), with decay >=
        `decay` (default :data:`MARGIN_DECAY_RTOL` times the plants' largest ‖A_i‖₂).
        Every step of a bisection counts only what numpy verifies: any other answer
        lowers the upper end without being called infeasible, and
        :attr:`Synthesis.search` says what the answer there was.
    decay : float, optional
        Required decay rate α of V, 1/s (>= 0).
    gain_bound : float
        κ > 0 with ``‖K‖₂ <= κ``.
    output : array_like, shape (p, n), optional
        ``z = Cx`` of the L2 objective (default :func:`error_output`).
    disturbance : array_like, shape (n, q) or (k, n, q), optional
        ``B_w`` of the L2 objective, one for all or one per vertex/sample (default B).
    check : tuple (A, B), optional
        An independent set on which numpy re-verifies the answer (for the robot: a finer
        sampling of times and payloads).
    nominal : UncertainLTVModel or PolytopicModel, optional
        Supplies the nominal (A, B) and PID structure of the returned design (default:
        `model` itself; for sampled pairs, their average).
    tol : float
        Relative tolerance of the bisections on α or θ.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    input_limits : float or array_like, shape (m,), optional
        ``ū_i > 0`` per input, in its unit (``inf``: none; a plant's
        :attr:`~scara_robust.UncertainPlant.input_limits`): every objective is then
        constrained to keep ``|u_i(t)| <= ū_i`` for all t from every initial error in
        `initial_errors` (with :data:`LIMIT_MARGIN`), on every plant of the set. A decay or
        margin the limits do not allow is not reached: the bisection stops below it, and a
        set the limits make impossible is reported infeasible. Needs `initial_errors`.
    initial_errors : array_like, shape (n,) or (k, n), optional
        Half-widths of a box of initial errors (state units; zeros allowed) or its points
        (at most :data:`MAX_LIMIT_VERTICES`), as for
        :func:`~scara_robust.input_limit_certificate`. Needs `input_limits`.
    structure : {'full', 'decentralized'}
        ``'full'``: any K. ``'decentralized'``: a PID per joint, each torque from its own
        joint's ``∫e, e, ė`` only (the PID form, n = 3m, one torque per joint; what
        ros2_control's ``pid_controller`` runs). A convex restriction: Q and Y are
        block-diagonal per joint (state ``a`` belongs to joint ``a mod m``), so
        ``K = Y Q⁻¹`` is too; it gives up the coupled gain and a Lyapunov function that
        couples the joints, so its decay is at most the full synthesis's.
    inputs : sequence of Signal, optional
        The inputs' names and units in the input-limit certificate's message (default: the
        model's own, for a plant with named inputs).

    Returns
    -------
    Synthesis
        Never raises for an infeasible or inaccurate problem: those are results. With
        limits, :attr:`Synthesis.input_limit` is numpy's check of them, and the result is
        certified only if it passes.

    See Also
    --------
    design : the paper's gain from (ρ, η).
    certificate_table : every certificate of a gain.

    References
    ----------
    Boyd, El Ghaoui, Feron, Balakrishnan, *Linear Matrix Inequalities in System and
    Control Theory*, SIAM 1994: §7.2.1 (decay), §7.5.1 (L2 gain, state feedback), §5.2.2
    and §7.2.3 (invariant ellipsoids, input constraints).

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> box = sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
    ...                            (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))
    >>> sr.synthesize(box, objective="decay").certified
    True
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    check_choice("objective", objective, OBJECTIVES)
    named = inputs if inputs is not None else getattr(model, "inputs", None)  # a plant's, before its interval model
    model, A, B = _pairs(model, objective)
    n, m = A.shape[1], B.shape[2]
    check_choice("structure", structure, STRUCTURES)
    pattern = None if structure == "full" else decentralized_pattern(n, m)
    kappa = check_real("gain_bound", gain_bound, positive=True)
    tol = check_real("tol", tol, positive=True)
    alpha = None if decay is None else check_real("decay", decay, nonnegative=True)
    l2 = _l2_pairs(A, B, output, disturbance) if objective == "l2" else None
    A_chk, B_chk = _check_pairs(check, A, B)
    limits = _limits(input_limits, initial_errors, m, n)
    problem = _Problem(A, B, A_chk, B_chk, kappa, solver, l2, limits, pattern, objective, structure, start)
    if not cvxpy_available():
        return problem.empty(NOT_INSTALLED)
    status, Q, Y, gamma, alpha, theta, searched, A, B = _search(problem, model, alpha, tol)
    if Q is None or Y is None:
        return problem.empty("infeasible" if status == "infeasible" else status, searched)
    assert alpha is not None
    return _verified(problem, Q, Y, A, B, status, alpha, gamma, theta, searched, disturbance,
                     named if named is not None and len(named) == m else None,
                     nominal if nominal is not None else model)


@dataclass(frozen=True)
class _Limits:
    """Input limits from a box of initial errors, as :func:`synthesize` scales them."""

    u_lim: Array  # (m,) the limits
    points: Array  # (k, n) the initial errors' vertices
    s0: float  # their largest entry: the LMI is solved for x / s0
    lmi: tuple[Array, Array]  # (u_lim / s0, points (1 + margin) / s0)

    def hold(self, K: Array, P_scaled: Array) -> bool:
        """True when the limits hold from every point with ``P = P_scaled / s0²``."""
        return input_limit_certificate(K, P_scaled / self.s0**2, self.u_lim, self.points).certified


@dataclass(frozen=True)
class _Problem:
    """What :func:`synthesize` checked, shared by its search and its verification."""

    A: Array
    B: Array
    A_chk: Array | None
    B_chk: Array | None
    kappa: float
    solver: str
    l2: tuple[Array, Array] | None
    limits: _Limits | None
    pattern: tuple[Array, Array] | None
    objective: str
    structure: str
    start: float

    @property
    def n_chk(self) -> int:
        """Number of check plants."""
        return 0 if self.A_chk is None else int(self.A_chk.shape[0])

    @property
    def s0(self) -> float:
        """The scale of the state in the LMI (1 without limits)."""
        return 1.0 if self.limits is None else self.limits.s0

    @property
    def extra(self) -> dict[str, Any]:
        """The LMI's options beyond decay and gain bound (without limits, _solve is called exactly as before)."""
        extra: dict[str, Any] = {} if self.limits is None else {"limits": self.limits.lmi}
        if self.pattern is not None:
            extra["pattern"] = self.pattern
        return extra

    @property
    def accept(self) -> Callable[[Array, Array], bool] | None:
        """The extra check of a verified answer: the input limits, where given."""
        return None if self.limits is None else self.limits.hold

    def empty(self, status: str, search: str = "") -> Synthesis:
        """A result without a gain."""
        return Synthesis(status, None, None, math.nan, math.nan, math.nan, math.nan, self.kappa, len(self.A),
                         self.n_chk, time.perf_counter() - self.start, None, objective=self.objective, search=search,
                         input_limits=None if self.limits is None else self.limits.u_lim, structure=self.structure)


def _pairs(model: Any, objective: str) -> tuple[Any, Array, Array]:
    """The model (a set as a model) and its pairs ``(A (k, n, n), B (k, n, m))``."""
    if is_model(model):
        model = as_model("model", model)
        A, B = model.vertex_matrices()
        return model, A, B
    if objective == "margin":
        raise ArgumentValueError("model", "must be an UncertainLTVModel or a PolytopicModel for objective "
                                          "'margin' (a set of samples has no size to scale)")
    if not isinstance(model, tuple) or len(model) != 2:
        raise ArgumentValueError("model", "must be a model or a tuple (A, B) of sampled matrices")
    A = check_array("model[0]", model[0], ndim=3)
    B = check_array("model[1]", model[1], ndim=3)
    if A.shape[1] != A.shape[2] or B.shape[:2] != A.shape[:2]:
        raise ArgumentValueError("model", f"must hold A (k, n, n) and B (k, n, m), found {A.shape}, {B.shape}")
    return model, A, B


def _l2_pairs(A: Array, B: Array, output: ArrayLike | None, disturbance: ArrayLike | None) -> tuple[Array, Array]:
    """``(B_w (k, n, q), C)`` of the L2 objective."""
    n, m = A.shape[1], B.shape[2]
    C = error_output(n, m) if output is None else check_array("output", output, shape=(None, n))
    Bw = B if disturbance is None else check_array("disturbance", disturbance)
    if Bw.ndim == 2:
        Bw = np.broadcast_to(Bw, (A.shape[0], *Bw.shape))
    if Bw.ndim != 3 or Bw.shape[:2] != A.shape[:2]:
        raise ArgumentValueError("disturbance", f"must have shape ({n}, q) or ({A.shape[0]}, {n}, q), "
                                                f"found {Bw.shape}")
    return np.asarray(Bw, dtype=float), C


def _check_pairs(check: tuple[ArrayLike, ArrayLike] | None, A: Array,
                 B: Array) -> tuple[Array | None, Array | None]:
    """The pairs a gain is verified on besides the synthesis's own, or (None, None)."""
    if check is None:
        return None, None
    A_chk = check_array("check[0]", check[0], ndim=3)
    B_chk = check_array("check[1]", check[1], ndim=3)
    if A_chk.shape[1:] != A.shape[1:] or B_chk.shape[1:] != B.shape[1:]:
        raise ArgumentValueError("check", f"must hold matrices of the sizes of `model`, found {A_chk.shape}")
    return A_chk, B_chk


def _limits(input_limits: ArrayLike | None, initial_errors: ArrayLike | None, m: int, n: int) -> _Limits | None:
    """The input limits and the box of initial errors they hold from, scaled for the LMI; None without them."""
    if (input_limits is None) != (initial_errors is None):
        missing = "initial_errors" if initial_errors is None else "input_limits"
        raise ArgumentValueError(missing, "is needed with the other: input limits hold from a set of initial errors "
                                          "(input_limits per input, initial_errors in state units)")
    if input_limits is None or initial_errors is None:
        return None
    u_lim = input_limits_of("input_limits", input_limits, m)
    points = initial_error_vertices(initial_errors, n)
    s0 = float(np.abs(points).max())
    if s0 == 0.0:
        raise ArgumentValueError("initial_errors", "must hold a nonzero initial error (from the origin alone every "
                                                   "gain keeps u = 0)")
    if len(points) > MAX_LIMIT_VERTICES:
        raise ArgumentValueError("initial_errors", f"has {len(points)} points, more than {MAX_LIMIT_VERTICES} "
                                                   "(one LMI each): pass fewer")
    # the LMI is solved for x / s0 (points of size 1: Q, Y scale by s0², the limits by 1/s0)
    return _Limits(u_lim, points, s0, (u_lim / s0, points * (1 + LIMIT_MARGIN) / s0))


_Answer = tuple[str, "Array | None", "Array | None", float]


def _search(problem: _Problem, model: Any, alpha: float | None,
            tol: float) -> tuple[str, Array | None, Array | None, float, float | None, float, str, Array, Array]:
    """The objective's LMI or bisection: ``(status, Q, Y, γ, α, θ, search, A, B)`` (A, B scaled by θ for a margin)."""
    A, B, kappa, solver, extra, accept = problem.A, problem.B, problem.kappa, problem.solver, problem.extra, \
        problem.accept
    theta = gamma = math.nan
    searched = ""
    active: list[NDArray[np.int64]] = []  # the cutting planes' last active set, carried through the search
    if problem.objective == "l2":
        alpha = L2_DECAY if alpha is None else alpha
        # in x / s0 the disturbance enters through B_w / s0 and the output is s0·C (same L2 gain)
        assert problem.l2 is not None
        s0 = problem.s0
        l2_scaled = problem.l2 if problem.limits is None else (problem.l2[0] / s0, problem.l2[1] * s0)
        status, Q, Y, gamma = _solve(A, B, alpha, kappa, solver, l2_scaled, **extra)
    elif problem.objective == "margin":
        if alpha is None:  # a decay the numpy check can tell from zero (see MARGIN_DECAY_RTOL)
            alpha = MARGIN_DECAY_RTOL * float(np.linalg.norm(A, 2, axis=(1, 2)).max())
        floor = alpha
        found: dict[float, _Answer] = {}
        uncertain = as_model("model", model)

        def feasible(th: float) -> str:
            A_t, B_t = uncertain.scaled(th).vertex_matrices()
            found[th] = _solve_by_cuts(A_t, B_t, floor, kappa, solver, active, **extra)
            return _verdict(A_t, B_t, found[th], floor, accept)

        first = feasible(0.0)
        if first != "certified":
            status, Q, Y = found[0.0][0], None, None
            searched = f"not even the nominal (θ = 0) is certified: {first}"
        else:
            theta, theta_hi, searched = _largest(feasible, 1.0, tol, MARGIN_CAP, 1e-6)
            status, Q, Y, _ = found[theta]
            A, B = uncertain.scaled(theta).vertex_matrices()
    elif alpha is not None:
        status, Q, Y, _ = _solve_by_cuts(A, B, alpha, kappa, solver, active, **extra)
    else:
        by_alpha: dict[float, _Answer] = {}

        def decays(a: float) -> str:
            by_alpha[a] = _solve_by_cuts(A, B, a, kappa, solver, active, **extra)
            return _verdict(A, B, by_alpha[a], a, accept)

        first = decays(0.0)
        if first not in ("certified", "marginal"):
            status, Q, Y = by_alpha[0.0][0], None, None
            searched = f"no decaying gain: {first}"
        else:  # with α = 0 the solver's gain sits at the edge; search upwards for a decay numpy can see
            scale = float(np.linalg.norm(A, 2, axis=(1, 2)).max())
            alpha, _, searched = _largest(decays, 1.0, tol, 1e4, DECAY_FLOOR_RTOL * scale)
            status, Q, Y, _ = by_alpha[alpha]
    return status, Q, Y, gamma, alpha, theta, searched, A, B


def _verified(problem: _Problem, Q: Array, Y: Array, A: Array, B: Array, status: str, alpha: float, gamma: float,
              theta: float, searched: str, disturbance: ArrayLike | None, named: Sequence[Signal] | None,
              nominal: Any) -> Synthesis:
    """The gain ``K = YQ⁻¹`` and ``P = Q⁻¹`` of the LMI's answer, verified by numpy on every plant."""
    A_chk, B_chk, l2, limits = problem.A_chk, problem.B_chk, problem.l2, problem.limits
    s0 = problem.s0
    Q, Y = Q * s0**2, Y * s0**2  # back to the state's units (s0 = 1 without limits)
    K = Y @ np.linalg.inv(Q)
    P = np.linalg.inv(Q)
    P = 0.5 * (P + P.T)
    verified = decay_rate(A - B @ K, P)
    checked = math.nan if A_chk is None or B_chk is None else decay_rate(A_chk - B_chk @ K, P)
    floor_rate = decay_floor(A - B @ K)
    ok = verified > 0 and (math.isnan(checked) or checked > 0)
    verified_gamma = check_gamma = math.nan
    if l2 is not None:
        verified_gamma = _verified_gamma(A - B @ K, l2[0], l2[1], P, gamma)
        ok = ok and math.isfinite(verified_gamma)
        if A_chk is not None and B_chk is not None:
            Bw_chk = B_chk if disturbance is None else np.broadcast_to(l2[0][0], (len(A_chk), *l2[0].shape[1:]))
            check_gamma = _verified_gamma(A_chk - B_chk @ K, Bw_chk, l2[1], P, gamma)
    limit_cert = None
    if limits is not None:
        loops = A - B @ K if A_chk is None or B_chk is None else np.concatenate([A - B @ K, A_chk - B_chk @ K])
        limit_cert = input_limit_certificate(K, P, limits.u_lim, limits.points, closed_loops=loops, inputs=named)
        ok = ok and limit_cert.certified
    verdict = "not verified"
    if ok:
        verdict = "certified" if min(verified, checked if not math.isnan(checked) else math.inf) >= floor_rate \
            else "marginal"
    design = _as_design(K, P, nominal, A, B)
    return Synthesis(verdict, K, P, alpha, verified, checked,
                     float(np.linalg.norm(K, 2)), problem.kappa, len(A), problem.n_chk,
                     time.perf_counter() - problem.start, design, status,
                     objective=problem.objective, gamma=verified_gamma, check_gamma=check_gamma, theta=theta,
                     search=searched, decay_floor=floor_rate, input_limits=None if limits is None else limits.u_lim,
                     input_limit=limit_cert, structure=problem.structure)

def _as_design(K: Array, P: Array, model: object, A: Array, B: Array) -> Design:
    if is_model(model):
        model = as_model("model", model)
        A0, B0 = model.A, model.B
        joints = getattr(model, "n_joints", None)
    else:
        A0, B0 = A.mean(axis=0), B.mean(axis=0)
        joints = A.shape[1] // 3 if A.shape[1] % 3 == 0 and A.shape[1] // 3 == B.shape[2] else None
    return Design._of_gain(A0, B0, K, P, "lmi", joints)
