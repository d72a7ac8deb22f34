"""The package's LMI layer and its interior-point solver (``scara_robust.sdp``).

The Schur complement assembled from the terms' Kronecker structure is compared with its
definition ``tr(F_p W F_q W)`` on every kind of term; the solver's optimal values are
compared with Clarabel's (through cvxpy, on the same description) on the package's
problem kinds, and its answers are checked by the problems' own residuals.
"""

from __future__ import annotations

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.exceptions import ArgumentValueError
from scara_robust.robustness.l2gain import bounded_real_problem, frozen_hinf_norms, invariant_ellipsoid_problem
from scara_robust.robustness.l2rate import rate_bounded_l2_problem
from scara_robust.robustness.lmi import common_p_problem
from scara_robust.robustness.pdl import pdl_problem
from scara_robust.robustness.polytope import box_closed_loops
from scara_robust.robustness.sampled_synthesis import sampled_synthesis_problem
from scara_robust.robustness.scheduled import schedule_lyapunov_problem
from scara_robust.robustness.synthesis import performance_synthesis_problem, synthesis_problem
from scara_robust.robustness.tuning import tracking_synthesis_problem
from scara_robust.sdp import LMIProblem, LMIResult, dense_schur
from scara_robust.sdp import solve_lmi as solve


def _random_w(problem: LMIProblem, rng: np.random.Generator) -> list[np.ndarray]:
    out = []
    for fam in problem.families:
        X = rng.normal(size=(fam.count, fam.size, fam.size))
        out.append(X @ np.swapaxes(X, 1, 2) + 0.1 * np.eye(fam.size))
    return out


def _every_kind(rng: np.random.Generator, n: int = 4, m: int = 2, N: int = 5) -> LMIProblem:
    """Symmetric, full and patterned matrices, scalars, quadratic terms, two block sizes."""
    pb = LMIProblem()
    Q = pb.symmetric("Q", n)
    Y = pb.matrix("Y", m, n)
    R = pb.symmetric("R", n, pattern=(np.arange(n)[:, None] % 2 == np.arange(n)[None, :] % 2))
    Z = pb.matrix("Z", m, n, pattern=rng.random((m, n)) > 0.4)
    s1, s2 = pb.scalar("s1"), pb.scalar("s2")
    A, B = rng.normal(size=(N, n, n)), rng.normal(size=(N, n, m))
    pb.add_lmi(terms=[(Q, np.swapaxes(A, 1, 2), np.eye(n)), (Y, -np.swapaxes(B, 1, 2), np.eye(n)), (Q, A, A),
                      (R, rng.normal(size=(n, n)), A), (Z, np.swapaxes(B, 1, 2), A)],
               scalars=[(s1, np.eye(n)), (s2, rng.normal(size=(N, n, n)))], const=rng.normal(size=(N, n, n)))
    top, bottom = np.eye(m, m + n), np.eye(n, m + n, m)
    pb.add_lmi(terms=[(Y, top, bottom), (Q, 0.5 * bottom, bottom)], scalars=[(s1, np.diag([1.0] * m + [0.0] * n))])
    pb.add_lmi(scalars=[(s2, np.ones((1, 1)))], const=np.ones((1, 1)))
    return pb


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_structured_schur_complement_equals_its_definition(seed):
    rng = np.random.default_rng(seed)
    pb = _every_kind(rng)
    W = _random_w(pb, rng)
    M, D = pb.schur(W), dense_schur(pb, W)
    assert M.shape == (pb.n_free, pb.n_free)
    assert np.abs(M - D).max() <= 1e-12 * np.abs(D).max()
    assert np.allclose(M, M.T, rtol=0, atol=1e-13 * np.abs(M).max())


def test_terms_of_one_variable_that_share_v_or_u_are_one_term():
    rng = np.random.default_rng(4)
    n, N = 3, 4
    pb = LMIProblem()
    P, Y = pb.symmetric("P", n), pb.matrix("Y", 2, n)
    A, U1, U2, V2 = (rng.normal(size=(N, n, n)) for _ in range(4))
    B = rng.normal(size=(N, 2, n))
    fam = pb.add_lmi(terms=[(P, U1, A), (Y, B, np.eye(n)), (P, U2, A), (P, V2, np.eye(n)), (P, V2, A)])
    # (P, U1, A) + (P, U2, A) share V; then (P, V2, I) and (P, V2, A) share U; Y stays apart
    assert [t[0].name for t in fam.terms] == ["P", "Y", "P"]
    y = rng.normal(size=pb.n_free)
    Pv, Yv = P.value(y), Y.value(y)

    def term(U, X, V):
        T = np.swapaxes(U, -1, -2) @ X @ V
        return T + np.swapaxes(T, -1, -2)

    expected = (term(U1, Pv, A) + term(U2, Pv, A) + term(V2, Pv, np.eye(n)) + term(V2, Pv, A)
                + term(B, Yv, np.eye(n)))
    assert np.allclose(pb.blocks(y, constant=False)[0], expected, rtol=0, atol=1e-12)
    W = _random_w(pb, rng)
    D = dense_schur(pb, W)
    assert np.abs(pb.schur(W) - D).max() <= 1e-12 * np.abs(D).max()


@pytest.mark.parametrize("at_once", [True, False])
def test_the_step_lengths_are_those_of_every_block_s_eigenvalues(at_once, monkeypatch):
    """Both ways to the lengths: a small stack's eigenvalues at once, a large one's blocks that fail Cholesky."""
    from scara_robust.sdp import ipm
    from scara_robust.sdp.ipm import _steps

    monkeypatch.setattr(ipm, "EIGENVALUES_AT_ONCE", ipm.EIGENVALUES_AT_ONCE if at_once else 0)
    rng = np.random.default_rng(5)
    for fraction in (1.0, 0.95):
        for size in (0.05, 0.5, 3.0):  # every block passes, some fail, most fail
            v = [rng.uniform(0.5, 2.0, size=(N, 4)) for N in (1, 30)]
            dZ = [size * _random_w_stack(rng, N) for N in (1, 30)]
            dS = [size * _random_w_stack(rng, N) for N in (1, 30)]
            expected = []
            for D in (dZ, dS):
                low = min(float(np.linalg.eigvalsh(d / np.sqrt(vf[:, :, None] * vf[:, None, :]))[:, 0].min())
                          for vf, d in zip(v, D))
                expected.append(min(1.0, fraction * (-1.0 / low if low < 0 else np.inf)))
            assert _steps(v, dZ, dS, fraction) == pytest.approx(tuple(expected), rel=1e-12)


def test_the_newton_solve_is_scipy_s_cholesky_solve_bit_for_bit():
    import scipy.linalg

    from scara_robust.sdp.ipm import _cho_solve, _factor

    rng = np.random.default_rng(2)
    for n in (1, 7, 22, 171):
        X = rng.normal(size=(n, n))
        factor = _factor(X @ X.T + n * np.eye(n))
        rhs = rng.normal(size=n)
        assert np.array_equal(_cho_solve(factor, rhs), scipy.linalg.cho_solve(factor, rhs))


def _random_w_stack(rng: np.random.Generator, N: int) -> np.ndarray:
    X = rng.normal(size=(N, 4, 4))
    return X + np.swapaxes(X, 1, 2)


def test_adjoint_is_the_transpose_of_the_linear_map():
    rng = np.random.default_rng(3)
    pb = _every_kind(rng)
    y = rng.normal(size=pb.n_free)
    Z = [0.5 * (z + np.swapaxes(z, 1, 2)) for z in _random_w(pb, rng)]
    lhs = sum(float(np.einsum("nst,nst->", f, z)) for f, z in zip(pb.blocks(y, constant=False), Z))
    assert lhs == pytest.approx(float(y @ pb.adjoint(Z)), rel=1e-12)


def test_the_stacked_map_is_the_problem_s_map_grouped_by_block_size():
    """The dense maps of the families stacked by block size give the same blocks, adjoint and
    Schur complement as the terms, per family once split back."""
    from scara_robust.sdp._stacked import StackedProblem

    rng = np.random.default_rng(4)
    pb = _every_kind(rng)
    pb.add_lmi(terms=[(pb.variables[0], 0.5 * np.eye(4), np.eye(4))], scalars=[(pb.variables[-1], -np.eye(4))])
    stacked = StackedProblem(pb)
    assert sorted(g.size for g in stacked.families) == [1, 4, 6]  # the two families of size 4 in one group
    y = rng.normal(size=pb.n_free)
    for grouped, own in ((stacked.split(stacked.blocks(y)), pb.blocks(y)),
                         (stacked.split(stacked.blocks(y, constant=False)), pb.blocks(y, constant=False))):
        for a, b in zip(grouped, own):
            assert a.shape == b.shape and np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(b).max())
    W = _random_w(pb, rng)
    grouped_w = [np.concatenate([W[i] for i, _, _ in g.members]) for g in stacked.families]
    assert [w.shape for w in stacked.split(grouped_w)] == [w.shape for w in W]
    assert np.abs(stacked.adjoint(grouped_w) - pb.adjoint(W)).max() <= 1e-12 * np.abs(pb.adjoint(W)).max()
    D = dense_schur(pb, W)
    assert np.abs(stacked.schur(grouped_w) - D).max() <= 1e-12 * np.abs(D).max()


@pytest.mark.parametrize("kind", ["optimal", "infeasible"])
def test_the_solver_gives_the_same_answer_stacked_or_term_by_term(kind, monkeypatch):
    """Below :data:`DENSE_ENTRIES` the solver runs on the stacked maps; its answer and its dual
    blocks (per family, a Farkas certificate where infeasible) are those of the terms' maps."""
    import scara_robust.sdp.ipm as ipm

    if kind == "optimal":
        pb, _, _ = common_p_problem(_scara_loops(0.2))
    else:
        pb, _ = tracking_synthesis_problem(np.array([[[1.0]]]), np.zeros((1, 1, 1)), np.ones((1, 1, 1)),
                                           np.ones(1), np.eye(1), 1.0, 1.0)
    assert 0 < ipm.StackedProblem.entries(pb) <= ipm.DENSE_ENTRIES
    stacked = ipm.solve_ipm(pb)
    monkeypatch.setattr(ipm, "DENSE_ENTRIES", 0)
    terms = ipm.solve_ipm(pb)
    assert stacked.status == terms.status == kind
    assert [z.shape for z in stacked.duals] == [z.shape for z in terms.duals] == [f.const.shape for f in pb.families]
    if kind == "optimal":
        assert stacked.objective == pytest.approx(terms.objective, rel=1e-8)
    else:
        for duals in (stacked.duals, terms.duals):  # F*(Z) ≈ 0 and ⟨C, Z⟩ = −1: numpy's Farkas check
            assert np.linalg.norm(pb.adjoint(duals)) <= 1e-7
            assert sum(float(np.vdot(f.const, z)) for f, z in zip(pb.families, duals)) == pytest.approx(-1.0)


def test_an_unbounded_problem_is_reported_unbounded():
    """A ray (the objective growing on iterates whose blocks hold) is 'unbounded' with no y; a bounded
    problem is not, whatever the size of y on the way (the rule is on the objective, not on y)."""
    pb = LMIProblem()
    t = pb.scalar("t")
    pb.add_lmi(scalars=[(t, np.ones((1, 1)))])                                     # t >= 0
    pb.maximize({t: 1.0})
    ray = solve(pb, "IPM")
    assert ray.status == "unbounded" and ray.y is None
    pb = LMIProblem()
    P, t = pb.symmetric("P", 2), pb.scalar("t")
    pb.add_lmi(terms=[(P, 0.5 * np.eye(2), np.eye(2))], scalars=[(t, -np.eye(2))])  # P >= tI, P free above
    pb.maximize({t: 1.0})
    assert solve(pb, "IPM").status == "unbounded"
    pb.add_lmi(terms=[(P, -0.5 * np.eye(2), np.eye(2))], const=np.eye(2))             # P <= I: t* = 1
    assert solve(pb, "IPM").value(t) == pytest.approx(1.0, rel=1e-7)


def _scara_loops(scale: float) -> np.ndarray:
    model = sr.paper_model()
    d = sr.design(model, 3, 90)
    A = box_closed_loops(model, d.K)[::16]  # 64 of the 1024 vertices: cvxpy builds the reference slowly
    loops = d.A_cl + scale * (A - d.A_cl)
    return loops / np.abs(loops).max()


def _paper_disturbance_loops() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The paper's design on 9 of the SCARA's samples, w = T_d (N·m) to z = e (rad)."""
    d = sr.design(sr.paper_model(), 3, 90)
    s = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 3), n_masses=3)
    C = np.zeros((2, 6))
    C[:, 2:4] = np.eye(2)
    return s.A - s.B @ d.K, s.B, C, np.zeros((2, 2))


def _corpus() -> dict[str, LMIProblem]:
    """Problems of the package's kinds: continuous and sampled common P, synthesis, feasible or not."""
    problems = {}
    for scale in (0.1, 0.3):
        problems[f"common P, SCARA box x{scale}"] = common_p_problem(_scara_loops(scale))[0]
    problems["common P, SCARA box (infeasible)"] = common_p_problem(_scara_loops(1.0))[0]
    loops = _scara_loops(0.2)
    problems["sampled common P"] = common_p_problem(loops, quadratic=0.05)[0]
    rng = np.random.default_rng(7)
    A = np.array([[[0.0, 1.0], [-1.0, -0.5]]]) + 0.2 * rng.normal(size=(6, 2, 2))
    B = np.array([[[0.0], [1.0]]]) + 0.1 * rng.normal(size=(6, 2, 1))
    problems["synthesis, decay 0.5"] = synthesis_problem(A, B, 0.5, 10.0)[0]
    problems["synthesis, decay 50 (infeasible)"] = synthesis_problem(A, B, 50.0, 10.0)[0]
    pattern = (np.eye(2), np.ones((1, 2)))
    problems["synthesis, patterned Q"] = synthesis_problem(A, B, 0.2, 10.0, pattern)[0]
    problems["synthesis, decay 0.5, minimize trace Q"] = performance_synthesis_problem(A, B, 0.5, 10.0, None, None)[0]
    problems["synthesis, L2 objective"] = performance_synthesis_problem(A, B, 0.2, 10.0, (B, np.eye(1, 2)), None)[0]
    limits = (np.array([5.0]), np.array([[0.3, 0.0], [0.0, 0.3]]))
    problems["synthesis, input limits"] = performance_synthesis_problem(A, B, 0.2, 10.0, None, limits)[0]
    problems["sampled synthesis, Ts = 10 ms"] = sampled_synthesis_problem(A, B, 0.01, 10.0, 0.1)[0]
    # a spring whose stiffness changes with p in [−1, 1]: the rate-bounded and scheduled LMIs
    q = np.linspace(-1.0, 1.0, 9)
    spring = np.array([[[0.0, 1.0], [-(2.0 + 1.5 * qi), -0.3]] for qi in q])
    problems["rate-bounded P(p), rate 0.5"] = pdl_problem(spring, q, 0.5)[0]
    problems["rate-bounded P(p), rate 0.5, multi-convex"] = pdl_problem(
        spring, q, 0.5, np.array([[[0.0, 0.0], [-1.5, 0.0]]]))[0]
    problems["rate-bounded P(p), rate 50 (infeasible)"] = pdl_problem(spring, q, 50.0)[0]
    b = np.array([-1.0, 0.0, 1.0])
    segment = (q > 0).astype(np.int64)
    weight = np.where(q > 0, q, q + 1.0)
    for sign in (1.0, -1.0):
        problems[f"scheduled P, rate 0.5, sign {sign:+g}"] = schedule_lyapunov_problem(
            spring, segment, weight, np.full(q.size, sign), b, 0.5, 0.05)[0]
    # the L2 and peak gains from the disturbance torque to the tracking error of the paper's design
    A_cl, Bw, C, D = _paper_disturbance_loops()
    problems["L2 gain, minimize gamma^2"] = bounded_real_problem(A_cl, Bw, C, D)[0]
    lower = max(frozen_hinf_norms(A_cl, Bw, C, D))
    problems["L2 gain, most interior P at 2x the frozen bound"] = bounded_real_problem(A_cl, Bw, C, D,
                                                                                     gamma=2 * lower)[0]
    decay = -np.linalg.eigvals(A_cl).real.max()
    # z in mrad: in rad the optimum, γ² = 4.9e-5 rad², is within Clarabel's tolerances of zero
    # (test_a_small_peak_bound_is_resolved_without_scaling)
    problems["peak gain, alpha = decay, z in mrad"] = invariant_ellipsoid_problem(A_cl, Bw, 1e3 * C, decay)[0]
    # the rate-bounded L2 gain of the spring, w a force, z the position
    spring_w, spring_z = np.tile([[0.0], [1.0]], (q.size, 1, 1)), np.array([[1.0, 0.0]])
    s01 = (q - q.min()) / np.ptp(q)
    problems["rate-bounded L2 gain, rate 0.05"] = rate_bounded_l2_problem(spring, s01, spring_w, spring_z,
                                                                          np.zeros((1, 1)), 0.025, None)[0]
    damped = spring + np.array([[0.0, 0.0], [0.0, -1.7]])  # damping 2 N·s/m: one P for any rate
    problems["rate-bounded L2 gain, any rate"] = rate_bounded_l2_problem(damped, s01, spring_w, spring_z,
                                                                         np.zeros((1, 1)), np.inf, None)[0]
    problems["tracking synthesis, inputs held, error capped"] = _held_problem(None)[0]
    return problems


def _held_problem(unit: float | None):
    """The tracking synthesis that holds input bounds with the error capped (robustness.tuning), s in `unit`:
    two double integrators in the PID state with uncertain input gains."""
    A0 = np.kron(np.eye(2), np.diag([1.0, 1.0], 1))
    Bt = np.zeros((2, 6, 2))
    Bt[0, 2, 0], Bt[0, 5, 1], Bt[1, 2, 0], Bt[1, 5, 1] = -1.0, -1.0, -2.0, -1.5
    Bw_t, Ct, X0 = np.zeros((6, 2)), np.zeros((2, 6)), np.zeros((1, 6))
    Bw_t[2, 0], Bw_t[5, 1], Ct[0, 1], Ct[1, 4], X0[0, 1], X0[0, 4] = 1.0, 0.2, 1.0, 1.0, 0.3, 0.3
    return tracking_synthesis_problem(np.stack([A0, A0]), Bt, np.stack([Bw_t, Bw_t]), np.ones(2), Ct, 1.0, 1e3,
                                      np.array([50.0, 20.0]), X0, 5.0, 0.3**2, unit)


CORPUS = _corpus()


@pytest.mark.parametrize("rate", [0.5, 0.0, np.inf])
def test_the_scheduled_lmi_s_blocks_are_its_conditions(rate):
    """Each block of schedule_lyapunov_problem at any y is −(AᵀP + PA + 2dP ± (ν/h)(P_{j+1} − P_j)) − tI,
    P = (1 − s)P_j + sP_{j+1}, computed here from the matrices (its terms merged per variable)."""
    rng = np.random.default_rng(4)
    q = np.linspace(-1.0, 1.0, 9)
    A = rng.normal(size=(q.size, 3, 3))
    b = np.array([-1.0, 0.0, 1.0])
    segment, weight = (q > 0).astype(np.int64), np.where(q > 0, q, q + 1.0)
    sign = np.where(np.arange(q.size) % 2, 1.0, -1.0)
    pb, P, t = schedule_lyapunov_problem(A, segment, weight, sign, b, rate, 0.3)
    y = rng.normal(size=pb.n_free)
    Pv = [P[0 if np.isinf(rate) else j].value(y) for j in range(b.size)]
    blocks = np.concatenate([blk for blk in pb.blocks(y) if blk.shape[1] == 3])[-q.size:]
    for i, (j, s, sg) in enumerate(zip(segment, weight, sign)):
        Pi = (1.0 - s) * Pv[j] + s * Pv[j + 1]
        slope = 0.0 if np.isinf(rate) else sg * rate / np.diff(b)[j] * (Pv[j + 1] - Pv[j])
        want = -(A[i].T @ Pi + Pi @ A[i] + 0.6 * Pi + slope) - t.value(y) * np.eye(3)
        np.testing.assert_allclose(blocks[i], want, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", list(CORPUS))
def test_optimal_value_equals_clarabels(name):
    pytest.importorskip("cvxpy")
    pb = CORPUS[name]
    own, ref = solve(pb, "IPM"), solve(pb, "CLARABEL")
    assert own.status == "optimal", own.status
    assert ref.status in ("optimal", "optimal_inaccurate"), ref.status
    assert own.objective == pytest.approx(ref.objective, rel=1e-6, abs=1e-8)
    # the answer is feasible: every block positive semidefinite to rounding
    for block in pb.blocks(own.y):
        assert np.linalg.eigvalsh(block)[:, 0].min() >= -1e-9 * max(1.0, np.abs(block).max())
    # and the dual bound closes the gap: bᵀy <= ⟨C, Z⟩ = bᵀy + Σ⟨Z, S⟩
    dual = sum(float(np.einsum("nst,nst->", f.const, z)) for f, z in zip(pb.families, own.duals))
    assert dual - own.objective == pytest.approx(own.gap, abs=1e-8)
    assert own.gap <= 1e-8 * max(1.0, abs(own.objective))  # the stopping rule: 1e-8 relative


def test_an_infeasible_l2_problem_is_infeasible_on_both_solvers():
    """No common P on the whole SCARA box: both solvers say infeasible, and l2_gain reports no bound."""
    pytest.importorskip("cvxpy")
    loops = _scara_loops(1.0)
    Bw, C, D = np.tile(np.eye(6)[:, 3:5], (64, 1, 1)), np.eye(6)[:2], np.zeros((2, 2))  # any w and z
    pb = bounded_real_problem(loops, Bw, C, D)[0]
    assert solve(pb, "IPM").status == "infeasible"
    assert solve(pb, "CLARABEL").status == "infeasible"
    gain = sr.l2_gain(loops, Bw, C, D)
    assert gain.upper == np.inf and gain.verdict == "infeasible"


def test_a_small_peak_bound_is_resolved_without_scaling():
    """The peak LMI with z in rad: γ*² = 4.88e-5 rad². Clarabel stops at 1.08e-4 (its tolerances
    are about the optimum's size) and reaches 4.88e-5 only with z in mrad; the package's solver
    reaches it in rad, and its dual bound proves it."""
    pytest.importorskip("cvxpy")
    A_cl, Bw, C, _ = _paper_disturbance_loops()
    decay = -np.linalg.eigvals(A_cl).real.max()
    in_rad = invariant_ellipsoid_problem(A_cl, Bw, C, decay)[0]
    in_mrad = invariant_ellipsoid_problem(A_cl, Bw, 1e3 * C, decay)[0]
    own, scaled = solve(in_rad, "IPM"), solve(in_mrad, "CLARABEL")
    assert own.status == "optimal" and scaled.status == "optimal"
    assert own.objective == pytest.approx(scaled.objective * 1e-6, rel=1e-6)
    dual = sum(float(np.einsum("nst,nst->", f.const, z)) for f, z in zip(in_rad.families, own.duals))
    assert dual - own.objective <= 1e-8 * abs(own.objective)  # the dual bound: no γ² below, to 1e-8 relative
    assert solve(in_rad, "CLARABEL").objective < own.objective  # maximize −γ²: Clarabel's unscaled γ² is larger


def test_the_accept_callback_stops_at_the_first_accepted_iterate():
    pb, P, t = common_p_problem(_scara_loops(0.2))
    full = solve(pb)
    seen = []

    def accept(y):
        seen.append(y[t.offset])
        return y[t.offset] > 0

    early = solve(pb, accept=accept)
    assert early.accepted and not full.accepted
    assert early.iterations < full.iterations
    assert early.value(t) > 0 and seen[-1] == early.value(t)
    assert early.value(t) <= full.value(t) * (1 + 1e-9)


def test_a_tiny_optimum_is_resolved_absolutely():
    """t* of 1e-8 (the 6-joint arm's sampled LMI is 6.5e-8) comes out to its own relative accuracy."""
    eps = 1e-8
    # one loop ẋ = −eps x with P ⪯ 1: t* = min(P, 2 eps P) = 2 eps
    pb, P, t = common_p_problem(np.array([[[-eps]]]))
    result = solve(pb)
    assert result.status == "optimal"
    assert result.value(t) == pytest.approx(2 * eps, rel=1e-6)


def test_the_held_scale_is_the_same_whatever_its_unit():
    """``'scale2'`` is ``(s / scale_unit)²``: the smallest scale s of the input bounds does not depend on the unit
    (the default: √(γ / max ū²)), and numpy's input check on the answer gives it back."""
    scales = []
    for unit in (None, 0.1, 3.0):
        pb, var = _held_problem(unit)
        found = solve(pb)
        assert found.status == "optimal"
        s2 = found.value(var["scale2"]) * (5.0 / 50.0**2 if unit is None else unit**2)
        Q, Y = found.value(var["Q"]), found.value(var["Y"])
        K, P = Y @ np.linalg.inv(Q), np.linalg.inv(Q)
        peaks = sr.input_peaks(K, P, 5.0)  # on {xᵀPx <= γ}, γ = 5
        assert np.max(peaks / np.array([50.0, 20.0])) == pytest.approx(np.sqrt(s2), rel=1e-5)
        scales.append(np.sqrt(s2))
    assert scales[1] == pytest.approx(scales[0], rel=1e-6) and scales[2] == pytest.approx(scales[0], rel=1e-6)


@pytest.mark.parametrize("where", ["factorization", "iteration limit"])
def test_an_iterate_within_tolerance_is_kept_when_rounding_stops_the_solver(where, monkeypatch):
    """Z or S losing its Cholesky factor to rounding (or the iterations running out) after an
    iterate within the residual and gap tolerances returns that iterate, judged as a stall is."""
    import scara_robust.sdp.ipm as ipm

    pb, P, t = common_p_problem(_scara_loops(0.2))
    optimum = ipm.solve_ipm(pb)
    assert optimum.status == "optimal"
    last = optimum.iterations - 1  # the scaling before the optimal iterate: the one before it is nearly there
    if where == "factorization":
        real, calls = ipm._nt_scaling, []

        def breaks(Z, S):
            calls.append(1)
            if len(calls) > last:
                raise np.linalg.LinAlgError("Matrix is not positive definite")
            return real(Z, S)

        monkeypatch.setattr(ipm, "_nt_scaling", breaks)
        found = ipm.solve_ipm(pb)
    else:
        found = ipm.solve_ipm(pb, max_iterations=last)
    assert found.status in ("optimal", "optimal_inaccurate") and found.iterations <= last
    assert found.value(t) == pytest.approx(optimum.value(t), rel=1e-6)
    for block in pb.blocks(found.y):
        assert np.linalg.eigvalsh(block)[:, 0].min() >= -1e-12
    # broken at the first iteration, there is no such iterate: the failure is reported
    monkeypatch.setattr(ipm, "_nt_scaling", lambda Z, S: (_ for _ in ()).throw(np.linalg.LinAlgError("broken")))
    failed = ipm.solve_ipm(pb)
    assert failed.status == "solver error: numerical failure (broken)" and failed.y is None


def test_a_bad_description_names_the_argument():
    pb = LMIProblem()
    P = pb.symmetric("P", 2)
    with pytest.raises(ArgumentValueError, match="`terms`"):
        pb.add_lmi(terms=[(P, np.eye(2), np.eye(3))])
    with pytest.raises(ArgumentValueError, match="`U`"):
        pb.add_lmi(terms=[(P, np.eye(3), np.eye(2, 3))])  # U has 3 rows for a 2 x 2 P
    with pytest.raises(ArgumentValueError, match="`name`"):
        pb.symmetric("P", 3)
    with pytest.raises(ArgumentValueError, match="`solver`"):
        solve(pb, "MOSEK")
    with pytest.raises(ArgumentValueError, match="`var`.*solver error"):
        LMIResult("solver error: numerical failure", None, None, float("nan"), float("nan"), 0).value(P)


def test_a_stalled_margin_form_is_asked_for_half_its_margin(monkeypatch):
    """Where rounding stops the solver short ('optimal_inaccurate'), the strictly interior t*/2 is returned."""
    import dataclasses

    import scara_robust.sdp.backends as backends
    from scara_robust.sdp import solve_lmi_interior

    pb, P, t = common_p_problem(_scara_loops(0.2))
    real = backends.solve_ipm
    optimum = real(pb)
    calls = []

    def stalled_first(problem, **options):
        calls.append(options)
        result = real(problem, **options)
        return dataclasses.replace(result, status="optimal_inaccurate") if len(calls) == 1 else result

    monkeypatch.setattr(backends, "solve_ipm", stalled_first)
    found = solve_lmi_interior(pb, t)
    assert len(calls) == 2 and found.accepted and found.status == "optimal"
    assert 0.5 * optimum.value(t) <= found.value(t) <= optimum.value(t) * (1 + 1e-9)
    for block in pb.blocks(found.y):  # an interior point: every block positive definite
        assert np.linalg.eigvalsh(block)[:, 0].min() > 0


def test_use_lmi_solver_sets_the_default_of_every_analysis():
    """``solver=None`` is the default; ``sr.use_lmi_solver`` changes it inside a block; a bad name is refused."""
    pytest.importorskip("cvxpy")
    loops = _scara_loops(0.1)
    before = sr.default_lmi_solver()  # 'IPM', or the one `--lmi-solver` gave the whole run
    other = "CLARABEL" if before == "IPM" else "IPM"
    assert sr.lmi_certificate(loops).solver == before
    with sr.use_lmi_solver(other) as chosen:
        assert chosen == other and sr.default_lmi_solver() == other
        inside = sr.lmi_certificate(loops)
        assert inside.solver == other and inside.certified
        assert sr.lmi_certificate(loops, solver=before).solver == before  # an explicit argument wins
    assert sr.default_lmi_solver() == before
    with pytest.raises(ArgumentValueError, match="`solver`"):
        with sr.use_lmi_solver("MOSEK"):
            pass
    with pytest.raises(ArgumentValueError, match="`solver`"):
        sr.resolve_lmi_solver("mosek")


def test_iterates_that_diverge_stop_before_any_norm_overflows():
    """The peak LMI at twice the loops' decay has no solution, and no Farkas certificate is reached either
    (Clarabel fails on it too): the iterates grow without bound. The solver stops once its gap has grown
    ``DIVERGED``-fold from its smallest, long before a norm overflows (which numpy warned of, 100 iterations
    in, before this test), and names it; the same problem at half the decay is solved as before."""
    import warnings

    from scara_robust.sdp.ipm import MAX_ITERATIONS

    rng = np.random.default_rng(5)
    A = np.array([[-1.0, 2.0], [-2.0, -1.5]]) + 0.3 * rng.normal(size=(3, 2, 2))
    Bw, C = np.broadcast_to(np.array([[0.0], [1.0]]), (3, 2, 1)), np.array([[1.0, 0.0]])
    decay = -float(np.linalg.eigvals(A).real.max())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        diverged = solve(invariant_ellipsoid_problem(A, Bw, C, 2.0 * decay)[0], "IPM")
        solved = solve(invariant_ellipsoid_problem(A, Bw, C, 0.5 * decay)[0], "IPM")
    assert diverged.status == "solver error: the iterates diverged" and diverged.y is None
    assert diverged.iterations < MAX_ITERATIONS
    assert solved.status == "optimal"
