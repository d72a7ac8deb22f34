"""Worst-case L2 gain for a parameter that varies at a bounded rate: ``V = xᵀ(P₀ + pP₁)x``.

The common-P bound of :func:`scara_robust.l2_gain` holds for parameters that jump
arbitrarily fast. When ``|ṗ| <= ν``, a Lyapunov matrix that follows the parameter proves a
smaller gain. Along a trajectory ``V̇ + zᵀz − γ²wᵀw`` is affine in ṗ, so the gridded
bounded-real conditions (Wu, Yang, Packard and Becker, "Induced L2-norm control for LPV
systems with bounded parameter variation rates", Int. J. Robust Nonlinear Control 6(9-10),
1996; Gahinet, Apkarian and Chilali, IEEE TAC 41(3), 1996, for the affine P(p))::

    P(p_i) ≻ 0,
    [[Ā_iᵀP(p_i) + P(p_i)Ā_i ± νP₁ + CᵀC,  P(p_i)B_w + CᵀD],
     [B_wᵀP(p_i) + DᵀC,                    DᵀD − γ²I]] ≺ 0      at every sample (p_i, Ā_i)

bound ``‖z‖₂ <= γ‖w‖₂`` (zero initial state) for every variation with ``|ṗ| <= ν`` on the
samples' grid (other sampled directions varying arbitrarily). ``ν = ∞`` forces ``P₁ = 0``:
the common-P bound. The LMI's optimum γ* lies on the boundary of its feasible set, so the
reported bound is ``γ*(1 + L2_INFLATION)`` with the most interior ``P(p)`` there, and it
counts only when numpy verifies that ``P(p)`` at every sample (and on the check set).

Registered as the ``'l2-rate-bounded'`` method of the ``'certificate'`` family (run by name:
``certificate_table(..., methods=("l2-rate-bounded",))``), on a plant with a parameter that
has a rate bound.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_real
from ..results import AnalysisResult
from ..sdp import LMIProblem, LMIVariable, solve_lmi
from ..sdp.backends import resolve_lmi_solver
from .context import CertificateContext
from .l2gain import L2_INFLATION, GainBound, check_gain_inputs, frozen_hinf_norms
from .lmi import NOT_INSTALLED, cvxpy_available
from .registry import AnalysisMethod, register_method
from .synthesis import error_output

__all__ = ["RateL2Gain", "rate_bounded_l2_gain", "verify_rate_bounded_l2"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class RateL2Gain(GainBound, AnalysisResult):
    """Bounds on the worst-case L2 gain from w to z for a parameter varying at ``|ṗ| <= rate``.

    Attributes
    ----------
    upper : float
        A bound numpy verified (``γ*(1 + inflation)``), units of z per unit of w; ``inf``
        when the LMI is infeasible or its answer fails numpy's check, NaN without cvxpy.
    lower : float
        ``max_i`` of the frozen plants' H∞ norms (python-control's ``norm(sys, 'inf')``).
    rate : float
        The rate bound ν, unit of p per second (``inf``: a common P).
    status : str
        The solver's status, ``'not verified'`` (numpy rejects its answer) or ``'not installed'``.
    P0, P1 : ndarray, shape (n, n), or None
        ``P(p) = P0 + p·P1``, p in its own unit; P1 is zero for ``rate = inf``.
    n_samples : int
    seconds : float
    inflation : float
    parameter, unit : str
        The rate-bounded parameter's name and unit, for the message.
    """

    upper: float
    lower: float
    rate: float
    status: str
    P0: Array | None
    P1: Array | None
    n_samples: int
    seconds: float
    inflation: float = L2_INFLATION
    parameter: str = "p"
    unit: str = ""

    units: ClassVar[dict[str, str]] = {"rate": "unit of p/s", "seconds": "s"}

    @property
    def value(self) -> float:
        """The verified upper bound (the table's column)."""
        return self.upper

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.status == NOT_INSTALLED:
            return "cvxpy is not installed (pip install '.[lmi]')"
        unit = f" {self.unit}/s" if self.unit else "/s"
        rate = ("any rate (common P)" if math.isinf(self.rate)
                else f"|d{self.parameter}/dt| <= {self.rate:.4g}{unit}")
        if math.isfinite(self.upper):
            return (f"worst-case L2 gain in [{self.lower:.4g}, {self.upper:.4g}] for {rate} (P(p) = P0 + p·P1 "
                    f"verified with numpy on {self.n_samples} samples)")
        return f"worst-case L2 gain >= {self.lower:.4g}; no bound for {rate}: {self.status}"


def verify_rate_bounded_l2(
    closed_loops: ArrayLike, p: ArrayLike, Bw: ArrayLike, C: ArrayLike, P0: ArrayLike, P1: ArrayLike,
    rate: float, gamma: float, D: ArrayLike | None = None,
) -> bool:
    """numpy's check of the rate-bounded bounded-real inequalities at every sample and both signs of ṗ.

    Parameters
    ----------
    closed_loops : array_like, shape (N, n, n)
    p : array_like, shape (N,)
        The parameter at each sample, its unit.
    Bw : array_like, shape (n, q) or (N, n, q)
    C : array_like, shape (r, n)
    P0, P1 : array_like, shape (n, n)
    rate : float
        ν, unit of p per second (``inf``: P1 must be zero and is ignored).
    gamma : float
        The bound to check.
    D : array_like, shape (r, q), optional

    Returns
    -------
    bool
        True when every ``P(p_i)`` is positive definite and every block is negative definite.
    """
    A, p_, Bw_, C_, D_ = _inputs(closed_loops, p, Bw, C, D)
    P0_ = check_array("P0", P0, shape=(A.shape[1], A.shape[1]))
    P1_ = check_array("P1", P1, shape=(A.shape[1], A.shape[1]))
    nu = 0.0 if math.isinf(rate) else rate
    q = Bw_.shape[2]
    P = P0_ + p_[:, None, None] * P1_
    if np.linalg.eigvalsh(0.5 * (P + np.swapaxes(P, -1, -2)))[:, 0].min() <= 0:
        return False
    side = P @ Bw_ + C_.T @ D_
    corner = np.broadcast_to(D_.T @ D_ - gamma ** 2 * np.eye(q), (A.shape[0], q, q))
    for sign in (-1.0, 1.0):
        top = np.swapaxes(A, -1, -2) @ P + P @ A + sign * nu * P1_ + C_.T @ C_
        block = np.block([[top, side], [np.swapaxes(side, -1, -2), corner]])
        if np.linalg.eigvalsh(0.5 * (block + np.swapaxes(block, -1, -2)))[:, -1].max() >= 0:
            return False
    return True


def _inputs(closed_loops: ArrayLike, p: ArrayLike, Bw: ArrayLike, C: ArrayLike,
            D: ArrayLike | None) -> tuple[Array, Array, Array, Array, Array]:
    A, Bw_, C_, D_ = check_gain_inputs(closed_loops, Bw, C, D)
    return A, check_array("p", p, shape=(A.shape[0],)), Bw_, C_, D_


def rate_bounded_l2_problem(A: Array, s: Array, Bw: Array, C: Array, D: Array, nu: float,
                            gamma: float | None) -> tuple[LMIProblem, LMIVariable, LMIVariable | None, LMIVariable]:
    """The rate-bounded bounded-real LMI of :func:`rate_bounded_l2_gain` as an :class:`~scara_robust.LMIProblem`.

    ``P(s) = P0 + s P1`` (``P1`` absent for ν = inf). With ``E = [I 0]`` and
    ``N_i = [Ā_i B_w,i]``, each sample's block for each sign of ṡ is
    ``−(EᵀP(s_i)N_i + N_iᵀP(s_i)E) ∓ ν EᵀP1E − [C D]ᵀ[C D] + γ² diag(0, I) ⪰ 0``, and
    ``P(s_i) ⪰ 1e-9 I``. Without `gamma`: ``minimize γ²`` (blocks ⪰ 1e-9 I). With it:
    ``maximize t ≤ 1`` with ``P(s_i) ⪰ tI`` and every block ⪰ tI (the most interior P).

    Parameters
    ----------
    A : ndarray, shape (N, n, n)
    s : ndarray, shape (N,)
        The parameter scaled to [0, 1].
    Bw : ndarray, shape (N, n, q)
    C : ndarray, shape (r, n)
    D : ndarray, shape (r, q)
    nu : float
        The rate bound of s, 1/s (inf: a common P).
    gamma : float or None

    Returns
    -------
    problem : LMIProblem
    P0 : LMIVariable
    P1 : LMIVariable or None
    g : LMIVariable
        γ² (without `gamma`) or t.
    """
    n, q = A.shape[1], Bw.shape[2]
    eye = np.eye(n)
    E = np.hstack([eye, np.zeros((n, q))])
    N = np.concatenate([A, Bw], axis=2)
    CD = np.hstack([C, D])
    corner = np.zeros((n + q, n + q))
    corner[n:, n:] = np.eye(q)
    problem = LMIProblem()
    P0 = problem.symmetric("P0", n)
    P1 = problem.symmetric("P1", n) if math.isfinite(nu) else None
    g = problem.scalar("g2" if gamma is None else "t")
    at_s = s[:, None, None] * eye
    P_terms = [(P0, 0.5 * eye, eye)] + ([] if P1 is None else [(P1, 0.5 * at_s, np.broadcast_to(eye, at_s.shape))])
    slack = np.eye(n + q)
    if gamma is None:
        problem.add_lmi(terms=P_terms, const=np.broadcast_to(-1e-9 * eye, at_s.shape), name="P(s) >= 1e-9 I")
        scalars, const = [(g, corner)], -CD.T @ CD - 1e-9 * slack
        problem.minimize({g: 1.0})
    else:
        problem.add_lmi(terms=P_terms, scalars=[(g, -eye)], name="P(s) >= tI")
        problem.add_lmi(scalars=[(g, -np.ones((1, 1)))], const=np.ones((1, 1)), name="t <= 1")
        scalars, const = [(g, -slack)], -CD.T @ CD + gamma**2 * corner
        problem.maximize({g: 1.0})
    for sign in ((0.0,) if P1 is None else (-1.0, 1.0)):
        terms = [(P0, -E, N)]
        if P1 is not None:
            terms += [(P1, -s[:, None, None] * E, N), (P1, -0.5 * sign * nu * E, E)]
        problem.add_lmi(terms=terms, scalars=scalars, const=np.broadcast_to(const, (A.shape[0], n + q, n + q)),
                        name=f"bounded real, sign {sign:+g}")
    return problem, P0, P1, g


def _solve(A: Array, s: Array, Bw: Array, C: Array, D: Array, nu: float, solver: str,
           gamma: float | None) -> tuple[str, float, Array | None, Array | None]:
    """Minimize γ² (``gamma`` None), or at a given γ find the most interior P(s); s in [0, 1]."""
    problem, P0, P1, g = rate_bounded_l2_problem(A, s, Bw, C, D, nu, gamma)
    result = solve_lmi(problem, solver)
    if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
        return result.status, math.inf, None, None
    if gamma is not None and result.value(g) <= 0:
        return "not verified", math.inf, None, None
    value = math.sqrt(max(float(result.value(g)), 0.0)) if gamma is None else gamma
    n = A.shape[1]
    P1_value = np.zeros((n, n)) if P1 is None else np.asarray(result.value(P1), dtype=float)
    return result.status, value, np.asarray(result.value(P0), dtype=float), P1_value


def rate_bounded_l2_gain(
    closed_loops: ArrayLike,
    p: ArrayLike,
    Bw: ArrayLike,
    C: ArrayLike,
    D: ArrayLike | None = None,
    *,
    rate: float,
    check: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    solver: str | None = None,
    parameter: str = "p",
    unit: str = "",
) -> RateL2Gain:
    """Upper and lower bounds on the worst-case L2 gain from w to z when ``|ṗ| <= rate``.

    Parameters
    ----------
    closed_loops : array_like, shape (N, n, n)
        The closed loops ``Ā_i`` at the samples.
    p : array_like, shape (N,)
        The rate-bounded parameter at each sample, its unit.
    Bw : array_like, shape (n, q) or (N, n, q)
        How the disturbance w enters.
    C : array_like, shape (r, n)
        The output z.
    D : array_like, shape (r, q), optional
        Feedthrough (default 0).
    rate : float
        ν >= 0, unit of p per second; ``inf`` gives the common-P bound.
    check : tuple (closed_loops, p, Bw), optional
        A second (finer) set of samples on which the bound must also verify.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    parameter, unit : str
        The parameter's name and unit, for the message.

    Returns
    -------
    RateL2Gain

    Raises
    ------
    ArgumentValueError
        For shapes that do not match (naming the argument) or a negative rate.

    See Also
    --------
    l2_gain : the common-P bound (any rate).
    rate_bounded_certificate : stability alone for a bounded rate.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> p = np.linspace(1.0, 3.0, 5)      # ẍ = -(2/p) x - (0.4/p) ẋ + w, z = x
    >>> A = np.array([[[0.0, 1.0], [-2 / m, -0.4 / m]] for m in p])
    >>> g = sr.rate_bounded_l2_gain(A, p, [[0.0], [1.0]], [[1.0, 0.0]], rate=0.1)
    >>> g.verdict, bool(g.lower <= g.upper)
    ('certified', True)
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    A, p_, Bw_, C_, D_ = _inputs(closed_loops, p, Bw, C, D)
    nu = math.inf if rate == math.inf else check_real("rate", rate, nonnegative=True)
    lower = max(frozen_hinf_norms(A, Bw_, C_, D_))
    n_samples = A.shape[0]
    if not cvxpy_available():
        return RateL2Gain(math.nan, lower, nu, NOT_INSTALLED, None, None, n_samples, time.perf_counter() - start,
                          parameter=parameter, unit=unit)
    # P(s) with s = (p − lo)/width in [0, 1] (the same family of matrices, better conditioned)
    lo, width = float(p_.min()), float(np.ptp(p_)) or 1.0
    s = (p_ - lo) / width
    nu_s = nu / width
    status, gamma, _, _ = _solve(A, s, Bw_, C_, D_, nu_s, solver, None)
    if not math.isfinite(gamma):
        return RateL2Gain(math.inf, lower, nu, status, None, None, n_samples, time.perf_counter() - start,
                          parameter=parameter, unit=unit)
    bound = gamma * (1 + L2_INFLATION)
    status2, _, Q0, Q1 = _solve(A, s, Bw_, C_, D_, nu_s, solver, bound)
    if Q0 is None or Q1 is None:
        return RateL2Gain(math.inf, lower, nu, status2, None, None, n_samples, time.perf_counter() - start,
                          parameter=parameter, unit=unit)
    P1 = Q1 / width  # back to p in its unit: P(p) = Q0 + s·Q1 = P0 + p·P1
    P0 = Q0 - lo * P1
    ok = verify_rate_bounded_l2(A, p_, Bw_, C_, P0, P1, nu, bound, D_)
    if ok and check is not None:
        ok = verify_rate_bounded_l2(check[0], check[1], check[2], C_, P0, P1, nu, bound, D_)
        n_samples += len(np.asarray(check[1]))
    if not ok:
        return RateL2Gain(math.inf, lower, nu, "not verified", P0, P1, n_samples, time.perf_counter() - start,
                          parameter=parameter, unit=unit)
    return RateL2Gain(bound, lower, nu, status, P0, P1, n_samples, time.perf_counter() - start,
                          parameter=parameter, unit=unit)


def _certificate_row(context: CertificateContext) -> RateL2Gain:
    """The registered method: the plant's first rate-bounded parameter, w entering like u, z = e."""
    plant = context.plant
    assert plant is not None
    name = next(q.name for q in plant.parameters if q.rate is not None)
    rate = plant.parameter(name).rate
    assert rate is not None
    coarse = plant.samples(context.coarse)
    fine = plant.samples(context.grid)
    n, m = coarse.B.shape[1], coarse.B.shape[2]
    C = error_output(n, m) if n == 3 * m else np.eye(n)
    K = context.design.K
    return rate_bounded_l2_gain(coarse.closed_loops(K), coarse.column(name), coarse.B, C, rate=rate,
                                check=(fine.closed_loops(K), fine.column(name), fine.B), solver=context.lmi_solver,
                                parameter=name, unit=plant.parameter(name).unit)


register_method(AnalysisMethod(
    "l2-rate-bounded", "certificate", "certificate", _certificate_row,
    "worst-case L2 gain from a disturbance entering like the input to the tracking error, for the first "
    "parameter's rate bound (P(p) = P0 + p·P1)",
    frozenset({"parameters", "rates", "lmi"}), default=False, column="l2_gain [z/w]"))
