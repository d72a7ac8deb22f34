"""Robust synthesis: a gain designed with its Lyapunov certificate, re-verified by numpy."""

import math
from pathlib import Path

import control as ct
import numpy as np
import pytest
import scipy.linalg

import scara_robust as sr
from scara_robust.robustness.synthesis import L2_DECAY, error_output, vertices_of
from scara_robust.simulation.controllers import PID_LMI_FILE

pytestmark = pytest.mark.lmi

TRIPLE = np.array([[[-1.0, 2.0], [1.0, -3.0]], [[-0.8, 1.5], [1.3, -2.7]], [[-1.4, 0.9], [0.7, -2.0]]])


def test_physical_set_full_payload_is_certified_and_verified_ten_times_finer():
    coarse = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 37), n_masses=5)  # 185 samples, 0 to 2.07 kg
    fine = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 361), n_masses=9)  # 3249 samples, never seen
    result = sr.synthesize((coarse.A, coarse.B), decay=1.0, check=(fine.A, fine.B), nominal=sr.paper_model())
    assert result.certified and result.status == "certified"
    assert result.verified_decay >= 1.0 * (1 - 1e-6) and result.check_decay > 0.9
    assert result.gain_norm <= sr.GAIN_BOUND
    # numpy, independently of decay_rate: AᵀP + PA + 2αP ≺ 0 at every fine sample, with α just below the check
    closed = fine.A - fine.B @ result.K
    lhs = np.swapaxes(closed, -1, -2) @ result.P + result.P @ closed + 2 * 0.9 * result.P
    assert np.linalg.eigvalsh(lhs).max() < 0
    # the gain splits into PID matrices (u = K_I ∫e + K_P e + K_D ė)
    K_I, K_P, K_D = result.design.pid_matrices()
    assert np.allclose(-np.hstack([K_I, K_P, K_D]), result.K)


def test_a_box_with_a_vertex_no_gain_can_stabilize_is_infeasible():
    # at one vertex the input has no effect (B = 0) and the state matrix is unstable
    model = sr.UncertainLTVModel([[0.5, 1.0], [0.0, 0.5]], [[0.0], [1.0]], (sr.UncertainElement("B", 1, 0, -1.0, 0.0),))
    result = sr.synthesize(model)
    assert result.status == "infeasible" and not result.certified and result.K is None
    assert "no gain" in result.message


def test_three_matrix_polytope_with_identity_input_succeeds():
    poly = sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1)))
    result = sr.synthesize(poly, tol=0.05)
    assert result.certified and result.decay > 0
    assert result.verified_decay == pytest.approx(sr.decay_rate(poly.closed_loops(result.K), result.P))
    assert sr.vertex_certificate(poly, result.design).certified


def test_the_gain_bound_holds():
    poly = sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1)))
    result = sr.synthesize(poly, decay=0.5, gain_bound=2.0)
    assert result.certified and result.gain_norm <= 2.0 * (1 + 1e-6)


def test_decay_rate_matches_its_definition():
    A = TRIPLE
    P = np.eye(2)
    expected = min(-np.linalg.eigvalsh(a.T + a).max() / 2 for a in A)
    assert sr.decay_rate(A, P) == pytest.approx(expected)
    assert sr.decay_rate(A, -np.eye(2)) == -np.inf


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"gain_bound": 0.0}, "`gain_bound` must be > 0"), ({"decay": -1.0}, "`decay` must be >= 0"),
     ({"solver": "MOSEK"}, "`solver` must be one of")],
    ids=["bound", "decay", "solver"],
)
def test_bad_options(kwargs, match):
    with pytest.raises(sr.ArgumentValueError, match=match):
        sr.synthesize(sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1))), **kwargs)


# ---------------------------------------------------------------- worst-case L2 gain


def test_l2_gain_of_one_lti_plant_is_its_hinf_norm():
    # for a single plant the bounded-real lemma is exact: upper = lower = ‖G‖∞
    A = np.array([[[-1.0, 2.0], [-2.0, -0.5]]])
    result = sr.l2_gain(A, [[0.0], [1.0]], [[1.0, 0.0]])
    assert result.lower == pytest.approx(result.upper, rel=1e-3) and result.upper >= result.lower


@pytest.mark.lmi
def test_l2_gain_with_feedthrough_matches_the_hinf_norm():
    """With D ≠ 0 and one plant: ‖G‖∞ (python-control, slycot) <= upper <= ‖G‖∞ (1 + L2_INFLATION), and a
    frequency sweep of σ_max(C(jωI − A)⁻¹B + D) in numpy reaches the same norm from below."""
    A = np.array([[-1.0, 2.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -3.0]])
    B = np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 1.0]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    D = np.array([[0.3, -0.2], [0.0, 0.8]])
    hinf = float(ct.norm(ct.ss(A, B, C, D), p="inf"))
    result = sr.l2_gain(A[None], B, C, D)
    assert result.inflation == sr.L2_INFLATION == 1e-3
    assert result.lower == pytest.approx(hinf, rel=1e-12)
    assert hinf <= result.upper <= hinf * (1 + sr.L2_INFLATION) * (1 + 1e-6)
    omegas = np.concatenate([[0.0], np.logspace(-3, 3, 20001)])
    sweep = max(np.linalg.norm(C @ np.linalg.solve(1j * w * np.eye(3) - A, B) + D, 2) for w in omegas)
    assert sweep <= hinf * (1 + 1e-9) and sweep == pytest.approx(hinf, rel=1e-4)
    assert hinf > np.linalg.norm(D, 2)  # the feedthrough alone would be a lower bound; D matters here
    without = sr.l2_gain(A[None], B, C)
    assert without.lower != pytest.approx(hinf, rel=1e-3)


@pytest.mark.lmi
def test_peak_gain_with_feedthrough_bounds_a_simulated_peak():
    """z = Cx + Dw: the bound is the ellipsoid's γ plus σmax(D); inputs with ‖w(t)‖ <= 1 simulated by
    python-control (the worst frozen sinusoid, held unit vectors switching every second) stay below it."""
    A = np.array([[-1.0, 2.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -3.0]])
    B = np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 1.0]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    D = np.array([[0.3, -0.2], [0.0, 0.8]])
    with_d, without = sr.peak_gain(A[None], B, C, D), sr.peak_gain(A[None], B, C)
    assert with_d.upper == pytest.approx(without.upper + np.linalg.norm(D, 2), rel=1e-12)
    assert np.linalg.norm(D, 2) <= with_d.lower <= with_d.upper and with_d.lower != without.lower
    sys = ct.ss(A, B, C, D)
    T = np.linspace(0.0, 40.0, 8001)
    angles = np.random.default_rng(0).uniform(0, 2 * np.pi, 41)[np.minimum(T.astype(int), 40)]
    _, omega = ct.linfnorm(sys)
    G = C @ np.linalg.solve(1j * omega * np.eye(3) - A, B) + D
    v = np.linalg.svd(G)[2][0].conj()
    for w in (np.array([np.cos(angles), np.sin(angles)]), np.real(np.outer(v, np.exp(1j * omega * T)))):
        assert np.linalg.norm(w, axis=0).max() <= 1 + 1e-12
        z = ct.forced_response(sys, T, w).outputs
        peak = float(np.linalg.norm(z, axis=0).max())
        assert peak <= with_d.upper
    assert peak >= 0.99 * with_d.lower  # the worst sinusoid reaches the lower bound in steady state


@pytest.mark.lmi
def test_l2_gain_refuses_a_feedthrough_of_the_wrong_shape():
    with pytest.raises(sr.ArgumentValueError, match="`D`"):
        sr.l2_gain(np.array([[[-1.0]]]), [[1.0]], [[1.0]], np.zeros((2, 1)))


@pytest.mark.parametrize("seed", range(4), ids=[f"seed{s}" for s in range(4)])
def test_l2_lower_bound_never_exceeds_upper_bound(seed):
    rng = np.random.default_rng(seed)
    base = np.array([[-2.0, 1.0, 0.0], [0.0, -3.0, 1.0], [0.5, 0.0, -1.5]])
    A = base + 0.3 * rng.normal(size=(4, 3, 3))
    result = sr.l2_gain(A, rng.normal(size=(3, 1)), rng.normal(size=(1, 3)))
    assert np.isfinite(result.lower) and result.lower <= result.upper
    assert "worst-case L2 gain in" in result.message


def test_l2_gain_of_an_unstable_frozen_plant_is_unbounded():
    A = np.array([[[-1.0, 0.0], [0.0, -1.0]], [[0.5, 0.0], [0.0, -1.0]]])
    result = sr.l2_gain(A, [[1.0], [0.0]], [[1.0, 0.0]])
    assert result.lower == np.inf and result.upper == np.inf and not np.isfinite(result.upper)


def test_paper_design_l2_gain_from_disturbance_torque_to_error():
    d = sr.design(sr.paper_model(), 3, 90)
    s = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 19), n_masses=3)
    C = np.zeros((2, 6))
    C[:, 2:4] = np.eye(2)  # z = e (rad), w = Td (N·m), entering through B like Tc
    result = sr.l2_gain(s.A - s.B @ d.K, s.B, C)
    assert 0 < result.lower <= result.upper < 0.01  # rad per N·m


# ---------------------------------------------------------------- objectives, the shipped gain, the front ends

C_ERROR = error_output(6, 2)


def _brl_max_eig(closed, Bw, C, P, gamma):
    """Largest eigenvalue of the bounded-real matrix, computed here without the package."""
    worst = -np.inf
    for A_i, B_i in zip(closed, Bw):
        top = A_i.T @ P + P @ A_i + C.T @ C
        block = np.block([[top, P @ B_i], [B_i.T @ P, -gamma**2 * np.eye(B_i.shape[1])]])
        worst = max(worst, np.linalg.eigvalsh(0.5 * (block + block.T)).max())
    return worst


def test_l2_objective_on_the_physical_set_is_verified_on_a_finer_set():
    coarse = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 19), n_masses=3)
    fine = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 181), n_masses=7)  # 10 times finer in time
    result = sr.synthesize((coarse.A, coarse.B), objective="l2", check=(fine.A, fine.B), nominal=sr.paper_model())
    assert result.certified and result.objective == "l2"
    assert result.verified_decay >= L2_DECAY * (1 - 1e-6) and result.check_decay > 0
    assert np.isfinite(result.gamma) and np.isfinite(result.check_gamma)
    # the certificate of γ is the bounded-real inequality for P̃ = γP (see the module)
    closed = fine.A - fine.B @ result.K
    assert _brl_max_eig(closed, fine.B, C_ERROR, result.gamma * result.P, result.check_gamma) < 0
    # every frozen plant's H∞ norm is a lower bound on the worst-case gain
    lower = max(ct.norm(ct.ss(A_i, B_i, C_ERROR, 0), p="inf") for A_i, B_i in zip(closed[::40], fine.B[::40]))
    assert lower <= result.check_gamma
    assert "worst-case L2 gain <=" in result.message


def test_margin_objective_stops_where_the_input_matrix_becomes_singular():
    """On the published box with only ΔB varying, no gain can certify past the θ* at which
    some B in the box is singular: there a joint cannot be driven and the chain ∫e → e → ė
    keeps an eigenvalue at 0. det(B₀ + θΔ) is multilinear in the ΔB entries, so its zero over
    the box is reached first at a corner; θ* is the smallest positive root of the quadratics
    det(B₀ + θΔ_v) over the corners v."""
    model = sr.paper_model().subset("B")
    B0 = model.B[4:6]
    roots = []
    for v in model.box_vertices():
        D = model.matrices_at(v[None])[1][0][4:6] - B0
        c1 = B0[0, 0] * D[1, 1] + D[0, 0] * B0[1, 1] - B0[0, 1] * D[1, 0] - D[0, 1] * B0[1, 0]
        quadratic = np.roots([np.linalg.det(D), c1, np.linalg.det(B0)])
        roots += [r.real for r in quadratic if abs(r.imag) < 1e-12 and r.real > 0]
    theta_star = min(roots)
    result = sr.synthesize(model, objective="margin", tol=1e-3)
    assert result.certified and result.objective == "margin"
    assert theta_star * (1 - 3e-3) <= result.theta <= theta_star
    assert sr.decay_rate(sr.PolytopicModel(*vertices_of(model.scaled(result.theta))).closed_loops(result.K),
                         result.P) > 0


def test_margin_objective_needs_a_model():
    with pytest.raises(sr.ArgumentValueError, match="`model` must be an UncertainLTVModel or a PolytopicModel"):
        sr.synthesize((TRIPLE, np.tile(np.eye(2), (3, 1, 1))), objective="margin")


def test_l2_objective_needs_an_output_for_an_unstructured_state():
    with pytest.raises(sr.ArgumentValueError, match="`output` is needed"):
        sr.synthesize(sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1))), objective="l2")
    result = sr.synthesize(sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1))), objective="l2",
                           output=[[1.0, 0.0]], decay=0.1)
    assert result.certified and result.gamma > 0


#: How far a fresh L2 synthesis's γ may lie from the shipped one (the synthesis guide states it): the
#: solver stops short of a non-attained infimum at a point that depends on rounding; measured
#: 0.01081 to 0.01098 (1.6 %) across three OpenBLAS kernels.
GAMMA_RTOL = 0.05


def test_shipped_gain_is_certified_and_a_fresh_synthesis_reaches_the_same_objective():
    """The ``pid-lmi`` file against numpy, and against what ``synthesize`` gives on this machine.

    The LMI's minimizer is not unique (its infimum in γ is approached only as P grows along
    ∫e), so a fresh K differs from machine to machine. What holds everywhere: the shipped
    K and P pass numpy's checks with the numbers the file records, a fresh synthesis is
    certified by numpy too, both γ lie above the worst frozen plant's H∞ norm (a lower bound
    on any gain's worst-case L2 gain), and the fresh objective γ is within the tolerance the
    synthesis guide states (GAMMA_RTOL) of the shipped one.
    """
    from scara_robust.cli._synthesize import CHECK_GRID, PHYSICAL_GRID
    from scara_robust.robustness.l2gain import bounded_real_ok

    shipped = sr.load_design(Path(sr.__file__).parent / PID_LMI_FILE)
    assert np.array_equal(shipped.K, sr.pid_lmi_gain())
    assert shipped.info["certified"] is True and shipped.info["objective"] == "l2"
    coarse = sr.physical_samples(times=np.linspace(0, 2 * np.pi, PHYSICAL_GRID[0]), n_masses=PHYSICAL_GRID[1])
    fine = sr.physical_samples(times=np.linspace(0, 2 * np.pi, CHECK_GRID[0]), n_masses=CHECK_GRID[1])
    C = error_output(6, 2)
    K, P, gamma = shipped.K, shipped.P, shipped.info["gamma"]
    for samples, recorded in ((coarse, shipped.info["verified_decay"]), (fine, shipped.info["check_decay"])):
        loops = samples.A - samples.B @ K
        assert sr.decay_rate(loops, P) == pytest.approx(recorded, rel=1e-9)
        assert bounded_real_ok(loops, samples.B, C, gamma * P, gamma * (1 + 1e-9))
    assert shipped.info["verified_decay"] >= L2_DECAY * (1 - 1e-6)
    again = sr.synthesize((coarse.A, coarse.B), objective="l2", check=(fine.A, fine.B))
    assert again.certified and again.verified_decay >= L2_DECAY * (1 - 1e-6) and again.check_decay > 0
    assert math.isfinite(again.check_gamma) and again.check_gamma >= again.gamma
    for gain in (K, again.K):
        lower = sr.l2_gain(coarse.A - coarse.B @ gain, coarse.B, C).lower
        assert lower <= min(gamma, again.gamma)
    # the same or better: the infimum is not attained (P grows along the integral states as γ falls), and
    # the package's solver, which resolves γ* to 1e-8, ends nearer it than the shipped file's Clarabel run
    assert again.gamma <= gamma * (1 + GAMMA_RTOL)


def test_solver_errors_and_inaccurate_answers_are_results(monkeypatch):
    import cvxpy as cp

    import scara_robust.robustness.synthesis as synthesis
    from scara_robust.sdp import LMIResult

    poly = sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1)))

    def broken(self, *args, **kwargs):
        raise cp.SolverError("numerical trouble")

    monkeypatch.setattr(cp.Problem, "solve", broken)
    result = sr.synthesize(poly, decay=0.1, solver="CLARABEL")
    assert result.status.startswith("solver error") and not result.certified and result.K is None
    assert "numerical trouble" in result.message

    def inaccurate(problem, solver=None, **options):
        # an "optimal_inaccurate" answer whose Q makes nothing decay: Y = 0, Q = I, μ = t = 1
        y = np.zeros(problem.n_free)
        for var in problem.variables:
            if var.name == "Q":
                y[var.slice] = np.linalg.lstsq(var.basis, np.eye(2).ravel(), rcond=None)[0]
            elif var.name in ("mu", "t"):
                y[var.offset] = 1.0
        return LMIResult("optimal_inaccurate", y, None, 1.0, 0.0, 1, solver=solver)

    monkeypatch.setattr(synthesis, "solve_lmi", inaccurate)
    unstable = sr.PolytopicModel(np.array([[[0.5, 0.0], [0.0, -1.0]]]), np.array([[[0.0], [1.0]]]))
    result = sr.synthesize(unstable, decay=0.1, solver="CLARABEL")
    assert result.status == "not verified" and result.solver_status == "optimal_inaccurate"
    assert not result.certified and "numpy does not certify" in result.message


def test_the_package_solvers_failures_are_results(monkeypatch):
    """The package's own solver: a numerical failure and an answer numpy rejects are reported, not raised."""
    import scara_robust.robustness.synthesis as synthesis
    import scara_robust.sdp.ipm as ipm

    poly = sr.PolytopicModel(TRIPLE, np.tile(np.eye(2), (3, 1, 1)))

    def singular(M):
        raise np.linalg.LinAlgError("Schur complement not positive definite")

    monkeypatch.setattr(ipm, "_factor", singular)
    result = sr.synthesize(poly, decay=0.1, solver="IPM")  # whatever the run's default solver
    assert result.status.startswith("solver error") and not result.certified and result.K is None
    assert "Schur complement" in result.message
    monkeypatch.undo()

    def lying(A_v, B_v, alpha, kappa, solver, l2=None, **options):
        return "optimal_inaccurate", np.eye(2), np.zeros((1, 2)), math.nan  # Q = I, Y = 0: K = 0

    monkeypatch.setattr(synthesis, "_solve", lying)
    unstable = sr.PolytopicModel(np.array([[[0.5, 0.0], [0.0, -1.0]]]), np.array([[[0.0], [1.0]]]))
    result = sr.synthesize(unstable, decay=0.1, solver="IPM")
    assert result.status == "not verified" and result.solver_status == "optimal_inaccurate"
    assert not result.certified and "numpy does not certify" in result.message


# ---------------------------------------------------------------- worst-case peak (invariant ellipsoid)


def test_peak_bound_of_a_first_order_lag_is_exact():
    """ẋ = −a x + w, |w| <= 1: the reachable set is |x| <= 1/a, so the bound and the
    worst sinusoid (ω = 0, the constant w = 1) both give 1/a; the ellipsoid LMI's optimum is
    P = α(2a − α), largest at α = a (so the α grid costs at most 1e-3 relative)."""
    a = 2.5
    result = sr.peak_gain(np.array([[[-a]]]), [[1.0]], [[1.0]])
    assert result.lower == pytest.approx(1 / a, rel=1e-6)
    assert result.upper == pytest.approx(1 / a, rel=1e-3) and result.upper >= result.lower


@pytest.mark.filterwarnings("error")
def test_peak_bound_holds_for_switching_and_bounded_disturbances():
    rng = np.random.default_rng(5)
    base = np.array([[-1.0, 2.0], [-2.0, -1.5]])
    A = base + 0.3 * rng.normal(size=(3, 2, 2))
    Bw, C = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    result = sr.peak_gain(A, Bw, C)
    assert np.isfinite(result.upper) and result.lower <= result.upper
    # simulate: the loop switches among the A_i every 0.05-0.5 s, |w| <= 1 switching sign too
    worst = 0.0
    for _ in range(20):
        x, t = np.zeros(2), 0.0
        while t < 20.0:
            dwell = rng.uniform(0.05, 0.5)
            A_i, w = A[rng.integers(3)], rng.choice([-1.0, 1.0])
            # exact step of ẋ = A_i x + B_w w over the dwell
            M = scipy.linalg.expm(np.block([[A_i, Bw * w], [np.zeros((1, 3))]]) * dwell)
            for s in np.linspace(0, dwell, 6)[1:]:
                worst = max(worst, abs((C @ (scipy.linalg.expm(np.block([[A_i, Bw * w], [np.zeros((1, 3))]]) * s)
                                             @ np.append(x, 1.0))[:2])[0]))
            x = (M @ np.append(x, 1.0))[:2]
            t += dwell
    assert worst <= result.upper


def test_peak_bound_of_an_unstable_frozen_loop_is_infinite():
    result = sr.peak_gain(np.array([[[0.1]]]), [[1.0]], [[1.0]])
    assert result.upper == np.inf and result.lower == np.inf and "not stable" in result.message


@pytest.mark.lmi
def test_margin_objective_reports_only_theta_that_numpy_verified(monkeypatch):
    """A solver that answers "optimal" with a gain numpy rejects never moves θ.

    The real solver runs up to θ = 0.3; beyond, the mock returns "optimal" with K = 0 (whose
    loops do not decay: A has an eigenvalue at +1). The reported θ is the largest the real
    solver gave and numpy verified, its status is certified, and the search names the
    disagreement ("inaccurate": the solver answered, numpy rejected).
    """
    import scara_robust.robustness.synthesis as synthesis

    A = np.array([[1.0, 0.0], [0.0, 1.0]])
    model = sr.UncertainLTVModel(A, np.eye(2), (sr.UncertainElement("B", 0, 0, -1.0, 1.0),
                                                 sr.UncertainElement("B", 1, 1, -1.0, 1.0)))
    real = synthesis._solve
    calls: list[float] = []

    def lying(A_v, B_v, alpha, kappa, solver, l2=None, **options):
        theta = float(np.abs(B_v[:, 0, 0] - 1.0).max())  # the vertices' ΔB, i.e. the θ being tried
        calls.append(theta)
        if theta <= 0.3:
            return real(A_v, B_v, alpha, kappa, solver, l2, **options)
        return "optimal", np.eye(2), np.zeros((2, 2)), math.nan  # Q = I, Y = 0: K = 0, not stabilizing

    monkeypatch.setattr(synthesis, "_solve", lying)
    result = sr.synthesize(model, objective="margin", tol=1e-2)
    assert result.status == "certified" and result.certified and result.design.P_source == "lmi"
    assert 0.3 * (1 - 2e-2) <= result.theta <= 0.3
    assert any(t > 0.3 for t in calls)  # the mock was asked, and its answer did not count
    assert "inaccurate" in result.search
    loops = sr.PolytopicModel(*vertices_of(model.scaled(result.theta))).closed_loops(result.K)
    assert sr.decay_rate(loops, result.P) > 0  # the reported gain and P, re-verified here
