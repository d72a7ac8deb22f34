"""A primal–dual interior-point method for :class:`~scara_robust.sdp.problem.LMIProblem`.

The problem ``maximize bᵀy subject to S_b = C_b + F_b(y) ⪰ 0`` and its dual ``minimize
Σ_b ⟨C_b, Z_b⟩ subject to F*(Z) = −b, Z_b ⪰ 0`` are solved together from an infeasible
start (Z = ζI, S = ξI, y = 0) by the Nesterov–Todd direction with Mehrotra's
predictor–corrector, as SDPT3 does (Toh, Todd and Tütüncü, "SDPT3 — a Matlab software
package for semidefinite programming", Optim. Methods Softw. 11 (1999); Todd, Toh and
Tütüncü, SIAM J. Optim. 8 (1998)). Each iteration:

1. the NT scaling ``W_b = G_b G_bᵀ`` with ``G_bᵀ S_b G_b = G_b⁻¹ Z_b G_b⁻ᵀ = diag(v_b)``,
   from the Cholesky factors of Z_b and S_b and one SVD per block;
2. the Schur complement ``M_pq = Σ_b tr(F_p W_b F_q W_b)`` assembled from the terms'
   Kronecker structure (:meth:`~scara_robust.sdp.problem.LMIProblem.schur`), factored by
   Cholesky, each solve refined by one step of iterative refinement;
3. a predictor (σ = 0) and a corrector (σ = (μ_aff/μ)³ and the second-order term), each
   ``M Δy = F*(R_c − W R_d W) − r_p``, ``ΔS = F(Δy) + R_d``, ``ΔZ = R_c − W ΔS W``;
4. steps to a fraction of the distance to the cone's boundary, separately in Z and (y, S).

A small problem (at most :data:`~scara_robust.sdp._stacked.DENSE_ENTRIES` entries of its dense
map) is solved on its blocks stacked by size, its map one dense matrix per size
(:mod:`scara_robust.sdp._stacked`): the same iterates, with fewer Python-level calls.

It stops on **absolute** and relative tests (:data:`TOLERANCE`): the residuals of both
problems relative to their data and the gap ``Σ⟨Z_b, S_b⟩`` either relative to the objectives
or below an absolute tolerance, so an optimal value of 1e-8 is resolved, not rounded to the
default tolerance of a solver; or as soon as the caller's ``accept(y)`` says the current y
answers its question (a bisection stops at the first certificate numpy verifies), or as soon
as the caller's ``reject(bound)`` takes the dual objective ``⟨C, Z⟩``, an upper bound on the
optimal value once the dual residual is at rounding's size, as an answer that no y will beat.
A y
whose blocks cannot be made positive definite is reported ``'infeasible'`` with the dual
blocks Z (a Farkas certificate: ``F*(Z) ≈ 0``, ``⟨C, Z⟩ < 0``), which the caller verifies.
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.linalg.lapack import dpotrs

from ..exceptions import ArgumentValueError
from ._linalg import positive_definite
from ._stacked import DENSE_ENTRIES, StackedProblem
from .problem import LMIProblem, LMIVariable

__all__ = ["LMIResult", "solve_ipm"]

Array = NDArray[np.float64]

#: Each iteration's gap, residuals, objective and steps at the DEBUG level.
_LOG = logging.getLogger(__name__)

#: Relative gap at which an answer is optimal (Clarabel's default ``tol_gap_rel``).
TOLERANCE = 1e-8
#: Relative residuals of both problems at which an answer is optimal (Clarabel's default
#: feasibility tolerance): the Z side's residual grows to about 1e-9 near the end, where W is
#: ill-conditioned; the answer y is verified by the caller, not taken on this test.
FEASIBILITY = 1e-8
#: An absolute gap ``Σ⟨Z, S⟩`` below this is optimal whatever the objectives' size (the
#: problems come scaled to entries of order one; a t* of 1e-8 is then resolved to 1e-6).
ABSOLUTE_GAP = 1e-14
#: Iterations before the solver gives up (an interior-point method needs 15–40 here).
MAX_ITERATIONS = 100
#: Steps of iterative refinement of each Newton direction.
REFINEMENT_STEPS = 2
#: Iterations over which a gap within 1e-6 of the objectives that has not shrunk by 10 % is a
#: stall (rounding's floor).
STALL = 5
#: A relative gap within which an iterate where rounding stops the progress is optimal (the
#: objective to seven digits; Clarabel calls 5e-5 "almost solved").
ROUNDING_GAP = 1e-7
#: An objective above which an iterate whose blocks hold to :data:`FEASIBILITY` relative to it is a ray of an
#: unbounded problem (the problems come scaled to entries of order one). Not the size of y: on the way to the
#: optimum of a bounded problem (a 21-state arm's tracking synthesis) y passes 1e12 while the objective is -6e6.
UNBOUNDED = 1e12
#: Residuals within which an answer stopped early is ``'optimal_inaccurate'``.
INACCURATE = 1e-6
#: The relative dual residual within which ``⟨C, Z⟩`` is taken as a bound on the optimal value for a
#: caller's ``reject`` (the common-P problems reach 1e-16 to 1e-10 after a few iterations).
REJECT_RESIDUAL = 1e-9
#: A gap this many times the smallest one of the run: the iterates diverge (an interior-point
#: method's gap shrinks; on an infeasible problem whose Farkas certificate it does not reach,
#: the iterates grow until their norms overflow).
DIVERGED = 1e12


@dataclass(frozen=True)
class LMIResult:
    """The answer of an LMI solver, in cvxpy's vocabulary of statuses.

    Attributes
    ----------
    status : str
        ``'optimal'``, ``'optimal_inaccurate'``, ``'infeasible'`` (the dual blocks are a
        Farkas certificate), ``'infeasible_inaccurate'``, ``'unbounded'``, ``'rejected'`` (the
        caller's ``reject`` took the dual bound) or ``'solver error: ...'``.
    y : ndarray, shape (n_free,), or None
    duals : list of ndarray, shape (N, s, s), or None
        Z per family (a certificate of infeasibility, normalized to ``⟨C, Z⟩ = −1``, when
        the status is ``'infeasible'``).
    objective : float
        ``bᵀy`` (NaN without y).
    gap : float
        ``Σ⟨Z_b, S_b⟩`` at the end.
    iterations : int
    accepted : bool
        The caller's ``accept(y)`` stopped the solver.
    solver : str
    """

    status: str
    y: Array | None
    duals: list[Array] | None
    objective: float
    gap: float
    iterations: int
    accepted: bool = False
    solver: str = "IPM"

    def value(self, var: LMIVariable) -> Array:
        """The variable's value: a float for a scalar, else an array of its shape."""
        if self.y is None:
            raise ArgumentValueError("var", f"has no value ({var.name!r}): the solver said {self.status}")
        value = var.value(self.y)
        return float(value[0, 0]) if var.scalar else value  # type: ignore[return-value]


#: Up to this many ``blocks × size³`` the step lengths take every block's eigenvalues when the
#: blocks do not all allow the full step (the SCARA's 20–60 blocks of 6 rows), instead of one
#: Cholesky factorization per block to find the few that do not (the arms' 190 blocks of 18).
EIGENVALUES_AT_ONCE = 64 * 6**3


def _sym(a: Array) -> Array:
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def _inner(a: Sequence[Array], b: Sequence[Array]) -> float:
    return float(sum(np.vdot(x, y) for x, y in zip(a, b)))


def _steps(v: Sequence[Array], dZ: Sequence[Array], dS: Sequence[Array], fraction: float = 1.0) -> tuple[float, float]:
    """``min(1, fraction α)`` for αz, αs, the largest α with ``diag(v) + α D ⪰ 0`` over every block (v > 0).

    D is the scaled ΔZ or ΔS; with ``D̃ = diag(v)^(-1/2) D diag(v)^(-1/2)``, α = −1/λmin(D̃). A
    block with ``D̃ + fraction I ≻ 0`` (one Cholesky factorization: λmin > −fraction) allows
    the full step, so the eigenvalues are computed only for the blocks that fail it, the
    ones the step's length comes from: the same lengths as every block's eigenvalues give.
    Both directions of a family are factored in one stack. On a small stack (at most
    :data:`EIGENVALUES_AT_ONCE`) every block's eigenvalues are computed at once instead: the
    same lengths (a block that factors gives ``fraction α > 1``), without the factorizations
    (on the SCARA's payload search seven in eight stacks had a block that shortens the step).
    """
    alphas = [math.inf, math.inf]
    for vf, Z, S in zip(v, dZ, dS):
        root = 1.0 / np.sqrt(vf)
        scale = root[:, :, None] * root[:, None, :]
        stack = _sym(np.concatenate([Z * scale, S * scale]))
        if len(stack) * stack.shape[-1] ** 3 <= EIGENVALUES_AT_ONCE and np.isfinite(stack).all():
            # a small stack: every block's eigenvalues at once, cheaper here than finding the blocks that fail
            # a factorization (a block with λmin > −fraction has α > 1/fraction: it does not shorten the step)
            low = np.linalg.eigvalsh(stack)[:, 0]
            parts = (low[:len(vf)], low[len(vf):])
        else:
            short = ~positive_definite(stack, np.full(len(stack), -fraction))
            if not short.any():
                continue
            low = np.linalg.eigvalsh(stack[short])[:, 0]
            parts = (low[np.flatnonzero(short) < len(vf)], low[np.flatnonzero(short) >= len(vf)])
        for k, part in enumerate(parts):
            if part.size and float(part.min()) < 0:
                alphas[k] = min(alphas[k], -1.0 / float(part.min()))
    return min(1.0, fraction * alphas[0]), min(1.0, fraction * alphas[1])


def _nt_scaling(Z: Sequence[Array], S: Sequence[Array]) -> tuple[list[Array], list[Array], list[Array]]:
    """G, G⁻¹ and v per family: ``Gᵀ S G = G⁻¹ Z G⁻ᵀ = diag(v)`` (Todd, Toh and Tütüncü 1998, §4)."""
    G, Ginv, v = [], [], []
    for Zf, Sf in zip(Z, S):
        LZ, LS = np.linalg.cholesky(Zf), np.linalg.cholesky(Sf)
        U, d, Vt = np.linalg.svd(np.swapaxes(LZ, 1, 2) @ LS)
        root = np.sqrt(d)
        G.append((LZ @ U) / root[:, None, :])
        # LZᵀLS = U diag(d) Vᵀ gives LZ⁻¹ = U diag(d)⁻¹ Vᵀ LSᵀ, so G⁻¹ = diag(d)^(-1/2) Vᵀ LSᵀ: no inverse
        Ginv.append((Vt / root[:, :, None]) @ np.swapaxes(LS, 1, 2))
        v.append(d)
    return G, Ginv, v


@functools.cache
def _blas() -> Any:
    """One controller of the BLAS thread pools (inspecting the loaded libraries costs milliseconds)."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def solve_ipm(problem: LMIProblem, *, accept: Callable[[Array], bool] | None = None,
              reject: Callable[[float], bool] | None = None, tolerance: float = TOLERANCE,
              max_iterations: int = MAX_ITERATIONS) -> LMIResult:
    """Solve `problem` by the primal–dual interior-point method of this module.

    Parameters
    ----------
    problem : LMIProblem
    accept : callable ``accept(y) -> bool``, optional
        Called on each iterate (a pure test of y); where it is True and the iterate's blocks
        are all positive semidefinite the solver stops there (status ``'optimal'``,
        ``accepted`` True).
    reject : callable ``reject(bound) -> bool``, optional
        Called with the dual objective ``⟨C, Z⟩`` on each iterate whose dual residual is within
        :data:`REJECT_RESIDUAL` (then ``bᵀy <= ⟨C, Z⟩`` for every feasible y, to that residual
        times ``‖y‖``); True stops the solver there (status ``'rejected'``, no y).
    tolerance : float
        Relative residuals and gap of an optimal answer.
    max_iterations : int

    Returns
    -------
    LMIResult

    Notes
    -----
    The matrices are small (blocks of tens of rows, a Schur complement of a few hundred):
    BLAS runs on one thread here, where a second thread costs more than it gives (the
    6-joint arm's sampled-data LMI: 1.7 s on one thread, 4.0 s on two).
    """
    with _blas().limit(limits=1, user_api="blas"):
        if StackedProblem.entries(problem) > DENSE_ENTRIES:
            return _solve(problem, accept, reject, tolerance, max_iterations)
        stacked = StackedProblem(problem)
        result = _solve(stacked, accept, reject, tolerance, max_iterations)
        return result if result.duals is None else replace(result, duals=stacked.split(result.duals))


def _solve(problem: LMIProblem | StackedProblem, accept: Callable[[Array], bool] | None,
           reject: Callable[[float], bool] | None, tolerance: float, max_iterations: int) -> LMIResult:
    fams = problem.families
    b = problem.b()
    C = [f.const for f in fams]
    dims = sum(f.count * f.size for f in fams)
    norm_C = math.sqrt(_inner(C, C))
    diag = np.sqrt(np.maximum(np.diag(problem.schur([np.broadcast_to(np.eye(f.size), f.const.shape) for f in fams])),
                              0.0))
    zeta = max(1.0, float(np.max((1.0 + np.abs(b)) / (1.0 + diag))) * math.sqrt(max(f.size for f in fams)))
    xi = max(1.0, float(diag.max()), norm_C / math.sqrt(dims))
    Z = [np.broadcast_to(zeta * np.eye(f.size), f.const.shape).copy() for f in fams]
    S = [np.broadcast_to(xi * np.eye(f.size), f.const.shape).copy() for f in fams]
    y = np.zeros(problem.n_free)
    gamma = 0.9
    status, gap, it = "solver error: iteration limit reached", math.nan, 0
    gaps: list[float] = []
    best: LMIResult | None = None  # the iterate with the smallest gap among those within INACCURATE
    for it in range(max_iterations + 1):
        lin = problem.blocks(y)
        Rd = [_sym(L - Sf) for L, Sf in zip(lin, S)]
        rp = -b - problem.adjoint(Z)
        gap = _inner(Z, S)
        mu = gap / dims
        obj_y, obj_z = float(b @ y), _inner(C, Z)
        rel_p = float(np.linalg.norm(rp)) / (1.0 + float(np.linalg.norm(b)))
        rel_d = math.sqrt(_inner(Rd, Rd)) / (1.0 + norm_C)
        rel_gap = gap / max(abs(obj_y), abs(obj_z), 1e-300)
        # accept first: a cheap test of y (the package's are, a loop check once t > 0) is false on most iterates,
        # where the blocks' eigenvalues are then not needed
        if accept is not None and accept(y) and _psd(lin):
            return LMIResult("optimal", y, Z, obj_y, gap, it, accepted=True)
        if reject is not None and rel_p < REJECT_RESIDUAL and reject(obj_z):
            return LMIResult("rejected", None, None, math.nan, gap, it)
        if rel_p < FEASIBILITY and rel_d < FEASIBILITY and (rel_gap < tolerance or gap < ABSOLUTE_GAP):
            return LMIResult("optimal", y, Z, obj_y, gap, it)
        if obj_z < 0:
            farkas = float(np.linalg.norm(problem.adjoint(Z))) / -obj_z
            if farkas < tolerance:
                return LMIResult("infeasible", None, [Zf / -obj_z for Zf in Z], math.nan, gap, it)
        if obj_y > UNBOUNDED and math.sqrt(_inner(Rd, Rd)) <= FEASIBILITY * obj_y:
            # a ray: the objective grows without bound on iterates whose blocks hold relative to it
            return LMIResult("unbounded", None, None, math.nan, gap, it)
        if gaps and not (gap <= DIVERGED * min(gaps)):
            status = "solver error: the iterates diverged"
            break
        gaps.append(gap)
        if rel_p < INACCURATE and rel_d < INACCURATE and rel_gap < INACCURATE and (best is None or gap < best.gap):
            near = rel_gap < ROUNDING_GAP or gap < ABSOLUTE_GAP
            best = LMIResult("optimal" if near else "optimal_inaccurate", y, Z, obj_y, gap, it)
        if len(gaps) > STALL and gap > 0.9 * gaps[-1 - STALL] and rel_gap < INACCURATE:
            # rounding stops the progress: the iterate is as good as it gets; optimal when its gap
            # is within ROUNDING_GAP of the objectives and its residuals within INACCURATE (the Z
            # side's residual grows as W loses its conditioning; y's blocks stay exactly ⪰ 0)
            near = rel_p < INACCURATE and rel_d < INACCURATE and (rel_gap < ROUNDING_GAP or gap < ABSOLUTE_GAP)
            return LMIResult("optimal" if near else "optimal_inaccurate", y, Z, obj_y, gap, it)
        if it == max_iterations:
            break
        try:
            G, Ginv, v = _nt_scaling(Z, S)
            W = [g @ np.swapaxes(g, 1, 2) for g in G]
            M = problem.schur(W)
            factor = _factor(M)
        except (np.linalg.LinAlgError, ValueError) as err:
            # rounding has broken Z or S's factorization: the best iterate before it is the answer,
            # judged as the stall rule judges one, where there is one within INACCURATE
            if best is not None:
                return best
            status = f"solver error: numerical failure ({err})"
            break

        system = _Newton(problem, W, Rd, rp, M, factor)
        dy, dS, dZ = system.direction([-Zf for Zf in Z])
        # in the scaled space both Z and S are diag(v): the steps' lengths and the corrector's
        # second-order term come from G⁻¹ΔZG⁻ᵀ and GᵀΔSG
        dZt = [gi @ z @ np.swapaxes(gi, 1, 2) for gi, z in zip(Ginv, dZ)]
        dSt = [np.swapaxes(g, 1, 2) @ s @ g for g, s in zip(G, dS)]
        ap, ad = _steps(v, dZt, dSt)
        mu_aff = _inner([Zf + ap * d for Zf, d in zip(Z, dZ)], [Sf + ad * d for Sf, d in zip(S, dS)]) / dims
        sigma = min(1.0, (max(mu_aff, 0.0) / mu) ** max(1.0, 3.0 * min(ap, ad) ** 2)) if mu > 0 else 0.0
        Rc = []
        for g, vf, zt, st in zip(G, v, dZt, dSt):
            R = -_sym(zt @ st)
            idx = np.arange(vf.shape[1])
            R[:, idx, idx] += sigma * mu - vf**2
            H = 2.0 * R / (vf[:, :, None] + vf[:, None, :])
            Rc.append(_sym(g @ H @ np.swapaxes(g, 1, 2)))
        dy, dS, dZ = system.direction(Rc)
        ap, ad = _steps(v, [gi @ z @ np.swapaxes(gi, 1, 2) for gi, z in zip(Ginv, dZ)],
                        [np.swapaxes(g, 1, 2) @ s @ g for g, s in zip(G, dS)], gamma)
        if max(ap, ad) < 1e-10:
            status = "solver error: the steps vanished"
            break
        Z = [Zf + ap * d for Zf, d in zip(Z, dZ)]
        S = [Sf + ad * d for Sf, d in zip(S, dS)]
        y = y + ad * dy
        gamma = 0.9 + 0.09 * min(ap, ad)
        _LOG.debug("%3d gap %.3e rel_p %.1e rel_d %.1e objective %.10e steps %.3f %.3f sigma %.2e",
                   it, gap, rel_p, rel_d, obj_y, ap, ad, sigma)
    if best is not None:  # the steps vanished or the iterations ran out after an iterate within INACCURATE
        return best
    lin = problem.blocks(y)
    rp = -b - problem.adjoint(Z)
    rel_p = float(np.linalg.norm(rp)) / (1.0 + float(np.linalg.norm(b)))
    rel_d = math.sqrt(_inner([L - Sf for L, Sf in zip(lin, S)], [L - Sf for L, Sf in zip(lin, S)])) / (1.0 + norm_C)
    if rel_p < INACCURATE and rel_d < INACCURATE:
        return LMIResult("optimal_inaccurate", y, Z, float(b @ y), gap, it)
    return LMIResult(status, None, None, math.nan, gap, it)


@dataclass(frozen=True)
class _Newton:
    """The Newton system of one iteration: ``M Δy = F*(R_c − W R_d W) − r_p``, then ΔS and ΔZ."""

    problem: LMIProblem | StackedProblem
    W: list[Array]
    Rd: list[Array]
    rp: Array
    M: Array
    factor: tuple[Array, bool]

    def direction(self, Rc: Sequence[Array]) -> tuple[Array, list[Array], list[Array]]:
        """(Δy, ΔS, ΔZ) for the centering right-hand side R_c."""
        rhs = self.problem.adjoint([_sym(r - w @ d @ w) for r, w, d in zip(Rc, self.W, self.Rd)]) - self.rp
        dy = _cho_solve(self.factor, rhs)
        for _ in range(REFINEMENT_STEPS):
            # iterative refinement on the operator itself, F*(W F(Δy) W), not on M: its residual is
            # the error of F*(ΔZ) = r_p, which would otherwise grow as W becomes ill-conditioned
            applied = self.problem.adjoint([w @ f @ w for w, f in zip(self.W, self.problem.blocks(dy, constant=False))])
            dy += _cho_solve(self.factor, rhs - applied)
        dS = [_sym(L + d) for L, d in zip(self.problem.blocks(dy, constant=False), self.Rd)]
        dZ = [_sym(r - w @ s @ w) for r, w, s in zip(Rc, self.W, dS)]
        return dy, dS, dZ


def _psd(blocks: Sequence[Array]) -> bool:
    """Every block positive semidefinite (numpy's eigenvalues, to rounding)."""
    for B in blocks:
        eig = np.linalg.eigvalsh(_sym(B))
        if float(eig[:, 0].min()) < -1e-14 * max(1.0, float(np.abs(eig).max())):
            return False
    return True


def _cho_solve(factor: tuple[Array, bool], rhs: Array) -> Array:
    """``M⁻¹ rhs`` from :func:`_factor`'s Cholesky factor: LAPACK's ``dpotrs``, as ``scipy.linalg.cho_solve``
    calls it, without its checks of the inputs (a tenth of the time on the SCARA's 22 × 22 systems)."""
    x, info = dpotrs(factor[0], rhs, lower=factor[1])
    if info != 0:  # pragma: no cover - only for an argument LAPACK refuses
        raise ValueError(f"dpotrs refused argument {-info}")
    return np.asarray(x)


def _factor(M: Array) -> tuple[Array, bool]:
    """Cholesky of M, with a diagonal shift of its rounding's size when M is numerically singular."""
    try:
        return scipy.linalg.cho_factor(M, check_finite=False)  # type: ignore[no-any-return]
    except np.linalg.LinAlgError:
        shift = 1e-14 * max(float(np.abs(np.diag(M)).max()), 1e-300)
        return scipy.linalg.cho_factor(M + shift * np.eye(M.shape[0]), check_finite=False)  # type: ignore[no-any-return]
