"""Robust synthesis: a gain designed with its Lyapunov certificate, re-verified by numpy."""

import numpy as np
import pytest

import scara_robust as sr

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
