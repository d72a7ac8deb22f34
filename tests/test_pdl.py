"""Rate-bounded parameter-dependent Lyapunov test: a hand-derived case, numpy re-verification, the robot.

The hand-derived case is the oscillator ``Ā(p) = [[−ε, 1], [−p, −ε]]``, p ∈ [1, 4], ε = 0.1
(frozen eigenvalues ``−ε ± i√p``: stable for every p).

* No common P: with ``y = e^{εt}x``, ``ÿ₁ = −p y₁``. Hold p = 1 for a quarter period π/2
  (``(0, v) → (v, 0)``), then p = 4 for π/4 (``(u, 0) → (0, −2u)``): ‖x‖ grows by
  ``2e^{−3πε/4} = 1.58`` every 3π/4 s, so this switching diverges and no common quadratic
  Lyapunov function can exist.
* A parameter-dependent P certifies slow variation: ``P(p) = diag(p, 1)`` (P₀ = diag(0, 1),
  P₁ = diag(1, 0)) gives ``ĀᵀP + PĀ ± νP₁ = diag(−2εp ± ν, −2ε)``, negative definite for
  ``ν < 2εp_min = 0.2``. So the largest certified rate is at least 0.2 (per second), and on
  samples p_i the verified margin is ``min_i min(2εp_i − ν, 2ε)/p_i``. The dependence is
  affine with ``Ā₁ = [[0, 0], [−1, 0]]`` and ``Ā₁ᵀP₁ + P₁Ā₁ = 0``: multi-convexity holds, so
  the two end points suffice for this P.
"""

import numpy as np
import pytest
import scipy.linalg

import scara_robust as sr
from scara_robust.robustness.payload import payload_closed_loops

pytestmark = pytest.mark.lmi

EPS = 0.1
P_MIN, P_MAX = 1.0, 4.0
SLOPE = np.array([[0.0, 0.0], [-1.0, 0.0]])


def oscillator(p):
    p = np.atleast_1d(np.asarray(p, dtype=float))
    return np.array([[[-EPS, 1.0], [-x, -EPS]] for x in p]), p


GRID = oscillator(np.linspace(P_MIN, P_MAX, 7))
FINE = oscillator(np.linspace(P_MIN, P_MAX, 61))


def test_the_hand_switching_diverges_so_no_common_p():
    A, _ = oscillator([P_MIN, P_MAX])
    cycle = scipy.linalg.expm(A[1] * np.pi / 4) @ scipy.linalg.expm(A[0] * np.pi / 2)
    x = cycle @ np.array([0.0, 1.0])
    assert np.linalg.norm(x) == pytest.approx(2 * np.exp(-3 * np.pi * EPS / 4), rel=1e-9)
    assert np.linalg.norm(x) > 1.5
    common = sr.rate_bounded_certificate(*GRID, np.inf)
    assert common.status == "infeasible" and not common.certified and "common P" in common.message
    assert not sr.lmi_certificate(GRID[0]).certified
    assert sr.falsify(A, dwell=np.pi / 8, horizon=40.0).found


@pytest.mark.parametrize(("rate", "expected"), [(0.1, 0.025), (0.19, 0.005), (0.21, -0.005)],
                         ids=["slow", "near-bound", "beyond-bound"])
def test_verified_margin_of_the_hand_p_matches_its_formula(rate, expected):
    A, p = GRID
    margin = sr.verify_rate_bounded(A, p, np.diag([0.0, 1.0]), np.diag([1.0, 0.0]), rate)
    # V̇ <= −(2 EPS x − rate)/x · V at each sample, so the state decays at half that (V̇ <= −2αV)
    assert margin == pytest.approx(min(min(2 * EPS * x - rate, 2 * EPS) / (2 * x) for x in p), abs=1e-12)
    assert margin == pytest.approx(expected, abs=1e-12)


def test_bisection_certifies_at_least_the_hand_rate_and_the_common_p_fails():
    result = sr.max_certified_rate(*GRID, check=FINE, tol=1e-2)
    assert not result.common.certified
    assert 2 * EPS * P_MIN <= result.rate < np.inf
    lo, hi = result.bracket
    assert lo == result.rate and lo < hi <= lo * (1 + 1.1e-2)
    cert = result.certificate
    assert cert.certified and cert.decay_rate > 0 and cert.check_decay_rate > 0 and cert.rate == lo
    assert "certifies" in result.message


def test_numpy_reverifies_the_returned_p_on_a_finer_grid():
    rate = 0.3
    cert = sr.rate_bounded_certificate(*GRID, rate, check=FINE)
    assert cert.certified and cert.status == "certified"
    # independently: P(p) ≻ 0 and Ā(p)ᵀP(p) + P(p)Ā(p) + ṗP1 ≺ 0 for 401 values of p and ṗ ∈ {−ν, 0, ν}
    A, p = oscillator(np.linspace(P_MIN, P_MAX, 401))
    P = cert.P0 + p[:, None, None] * cert.P1
    assert np.allclose(cert.P0, cert.P0.T) and np.allclose(cert.P1, cert.P1.T)
    assert np.linalg.eigvalsh(P)[:, 0].min() > 0
    for pdot in (-rate, 0.0, rate):
        lhs = np.swapaxes(A, 1, 2) @ P + P @ A + pdot * cert.P1
        assert np.linalg.eigvalsh(lhs).max() < 0


def test_affine_end_points_with_multi_convexity_cover_the_interval():
    A, p = oscillator([P_MIN, P_MAX])
    result = sr.max_certified_rate(A, p, slopes=np.array([SLOPE, SLOPE]), check=FINE, tol=1e-2)
    cert = result.certificate
    assert result.rate >= 2 * EPS * P_MIN and cert.certified
    C = SLOPE.T @ cert.P1 + cert.P1 @ SLOPE
    assert np.linalg.eigvalsh(C).min() >= -1e-9 * np.abs(cert.P1).max()
    assert cert.convexity == pytest.approx(np.linalg.eigvalsh(C).min(), abs=1e-12)
    assert sr.verify_rate_bounded(*FINE, cert.P0, cert.P1, result.rate) > 0


def test_a_narrow_range_has_a_common_p_so_every_rate_is_certified():
    result = sr.max_certified_rate(*oscillator(np.linspace(1.0, 1.1, 3)))
    assert result.rate == np.inf and result.common.certified and result.certificate is result.common
    assert np.all(result.common.P1 == 0)
    assert "any rate" in result.message


def test_an_inaccurate_answer_is_never_certified():
    good = sr.rate_bounded_certificate(*GRID, 0.1)
    doubtful = sr.RateCertificate("optimal_inaccurate", good.P0, good.P1, 0.1, good.decay_rate, np.nan, np.nan,
                                  good.n_samples, 0, "optimal_inaccurate", 0.0)
    assert good.certified and good.decay_rate > 0
    assert not doubtful.certified and "optimal_inaccurate" in doubtful.message


@pytest.mark.parametrize("mass_max", [180.0, pytest.param(215.0, marks=pytest.mark.slow)], ids=["180kg", "215kg"])
def test_robot_certified_at_a_rate_beyond_the_common_p_payload_margin(paper_design, mass_max):
    # Both masses lie between the common-P payload margin (about 130 kg) and the frozen one
    # (about 271 kg) of `payload_margin`; coarse grids keep this quick, and the answer is
    # verified on a grid that holds the midpoints of both directions.
    closed, masses, times = payload_closed_loops(paper_design, mass_max, n_times=13, n_masses=5)
    assert closed.shape == (65, 6, 6) and masses.shape == times.shape == (65,)
    assert np.allclose(np.unique(masses), np.linspace(0.0, mass_max, 5))
    assert np.linalg.eigvals(closed).real.max() < 0  # every frozen sample is stable
    assert not sr.lmi_certificate(closed).certified
    assert sr.rate_bounded_certificate(closed, masses, np.inf).status == "infeasible"
    check = payload_closed_loops(paper_design, mass_max, n_times=25, n_masses=9)[:2]
    cert = sr.rate_bounded_certificate(closed, masses, 50.0, check=check)
    assert cert.certified and cert.decay_rate > 0 and cert.check_decay_rate > 0 and cert.n_checked == 225
    assert sr.verify_rate_bounded(*check, cert.P0, cert.P1, 50.0) == pytest.approx(cert.check_decay_rate)


def test_robot_fast_payload_ramps_diverge_where_slow_ones_are_certified(paper_design):
    # At 215 kg a payload held at M for 2 s and dropped to 0 for 0.05 s, with the reference
    # phase held at 5π/3 rad (a pattern found by searching phases and hold times), grows
    # when it ramps at 10⁴ kg/s; at the 50 kg/s certified above the same pattern decays.
    pattern = {"phase": 5 * np.pi / 3, "hold_high": 2.0, "hold_low": 0.05}
    assert sr.payload_switching_growth(paper_design, 215.0, 1e4, **pattern) > 0
    assert sr.payload_switching_growth(paper_design, 215.0, 50.0, **pattern) < 0
    # the growth rate is a Floquet exponent: check it against stepping the period by hand
    growth = sr.payload_switching_growth(paper_design, 215.0, 1e4, n_ramp=4, **pattern)
    samples = sr.physical_samples(payload=sr.SinusoidalPayload(107.5, 107.5), times=[5 * np.pi / 3], n_masses=9)
    at_phase = samples.A - samples.B @ paper_design.K  # masses 0, M/8, ..., M: the ramps' midpoints are odd
    dt = 215.0 / 4 / 1e4
    phi = scipy.linalg.expm(at_phase[8] * 2.0)
    for k in (7, 5, 3, 1):
        phi = scipy.linalg.expm(at_phase[k] * dt) @ phi
    phi = scipy.linalg.expm(at_phase[0] * 0.05) @ phi
    for k in (1, 3, 5, 7):
        phi = scipy.linalg.expm(at_phase[k] * dt) @ phi
    period = 2.0 + 0.05 + 2 * 215.0 / 1e4
    assert growth == pytest.approx(np.log(np.abs(np.linalg.eigvals(phi)).max()) / period, rel=1e-9)


@pytest.mark.parametrize(
    ("call", "argument"),
    [
        (lambda: sr.rate_bounded_certificate(np.zeros((2, 2)), [1.0, 2.0], 0.1), "closed_loops"),
        (lambda: sr.rate_bounded_certificate(GRID[0], [1.0, 2.0], 0.1), "p"),
        (lambda: sr.rate_bounded_certificate(*GRID, -1.0), "rate"),
        (lambda: sr.rate_bounded_certificate(*GRID, 0.1, slopes=np.zeros((2, 2, 2))), "slopes"),
        (lambda: sr.rate_bounded_certificate(*GRID, 0.1, check=GRID[0]), "check"),
        (lambda: sr.rate_bounded_certificate(*GRID, 0.1, check=(np.zeros((3, 3, 3)), np.ones(3))), "check\\[0\\]"),
        (lambda: sr.rate_bounded_certificate(*GRID, 0.1, solver="MOSEK"), "solver"),
        (lambda: sr.verify_rate_bounded(*GRID, np.eye(3), np.eye(2), 0.1), "P0"),
        (lambda: sr.max_certified_rate(*GRID, rate_max=0.0), "rate_max"),
        (lambda: sr.max_certified_rate(*GRID, tol=-1.0), "tol"),
        (lambda: payload_closed_loops(sr.design(sr.paper_model(), 3.0, 90.0), 0.0), "mass_max"),
        (lambda: payload_closed_loops(sr.design(sr.paper_model(), 3.0, 90.0), 10.0, n_masses=1), "n_masses"),
        (lambda: payload_closed_loops("design", 10.0), "design"),
        (lambda: sr.payload_switching_growth(sr.design(sr.paper_model(), 3.0, 90.0), 10.0, 0.0, phase=0.0,
                                             hold_high=1.0, hold_low=0.0), "rate"),
        (lambda: sr.payload_switching_growth(sr.design(sr.paper_model(), 3.0, 90.0), 10.0, 1.0, phase=0.0,
                                             hold_high=-1.0, hold_low=0.0), "hold_high"),
    ],
    ids=["loops-ndim", "p-length", "rate-negative", "slopes-shape", "check-not-tuple", "check-size", "solver",
         "P0-shape", "rate-max", "tol", "mass-max", "n-masses", "design-type", "growth-rate", "hold-high"],
)
def test_bad_inputs_name_the_argument(call, argument):
    with pytest.raises(sr.ArgumentError, match=f"`{argument}`"):
        call()
