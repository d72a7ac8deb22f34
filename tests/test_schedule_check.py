"""Self-tests of ``schedule_check`` on cases whose answers are known in closed form.

* Scalar loop ``ẋ = (p + q) x − K(p̂) x``, p ∈ [0, 2], q ∈ [−0.5, 0.5], breakpoints
  (0, 1, 2), ``K_j = b_j + 1`` (so ``K(p̂) = clamp(p̂) + 1``): ``a_cl = p + q − clamp(p̂) − 1``.
  With ``P = (1, 2, 1)`` (slopes ±1) the left side is ``2(a_cl + α)P(p) ± ν|D|``; its maximum
  is ``2(α − 1/2) + ν`` at the range ends, normalized by ``max P_j = 2``. With P = 1 and
  ``|p̂ − p| <= δ`` it is ``2(α − 1/2 + min(δ, 2))`` (the clamping caps ``p − p̂`` at p <= 2).
* Oscillator ``A(p) = [[−ε, 1], [−p/2, −ε]]``, ``B = [0, 1]ᵀ``, ``K(p̂) = [p̂/2, 0]``, p ∈ [1, 4],
  ``P(p) = diag(p, 1)``: ``L = [[−2(ε − α)p + ṗ, e], [e, −2(ε − α)]]`` with ``e = (p − p̂)/2``,
  worst at p = 1, ``ṗ = +ν``, ``|e| = δ/2``; normalized by ``max ‖P_j‖ = 4``.
* Oscillator with K = 0 and ``A(p) = [[−ε, 1], [−p, −ε]]``: every frozen loop has
  ``Re λ = −ε``; trace −2ε, so by Liouville the Floquet growth is >= −ε, equal to −ε away
  from parametric resonance and positive at it (a triangle wave at ṗ = 3).
"""

import numpy as np
import pytest
import scipy.linalg
from schedule_check import (
    frozen_spectral_abscissa,
    interpolate_gain,
    schedule_condition_margin,
    schedule_grid,
    scheduled_floquet_growth,
)
from scipy.integrate import solve_ivp

import scara_robust as sr

EPS = 0.1


@pytest.fixture(scope="module")
def scalar():
    """``ẋ = (p + q) x + u``, p ∈ [0, 2], q ∈ [−0.5, 0.5] (5 samples: a q-grid of 9)."""
    p = sr.Parameter("p", "1", (0.0, 2.0))
    q = sr.Parameter("q", "1", (-0.5, 0.5))
    return sr.UncertainPlant.from_expressions([p, q], [["p + q"]], [[1]], form="state")


SCALAR_B = np.array([0.0, 1.0, 2.0])
SCALAR_K = (SCALAR_B + 1.0).reshape(3, 1, 1)


@pytest.fixture(scope="module")
def oscillator():
    """``A(p) = [[−ε, 1], [−p/2, −ε]]``, ``B = [0, 1]ᵀ``, p ∈ [1, 4]."""
    p = sr.Parameter("p", "1", (1.0, 4.0))
    return sr.UncertainPlant.from_expressions([p], [[-EPS, 1], ["-p/2", -EPS]], [[0], [1]], form="state")


OSC_B = np.array([1.0, 2.0, 2.5, 4.0])        # uneven; K and P are affine in p, so exact on any breakpoints
OSC_K = np.array([[[x / 2, 0.0]] for x in OSC_B])
OSC_P = np.array([np.diag([x, 1.0]) for x in OSC_B])


@pytest.fixture(scope="module")
def free_oscillator():
    """``A(p) = [[−ε, 1], [−p, −ε]]``, ``B = [0, 1]ᵀ``, p ∈ [1, 4] (run with K = 0)."""
    p = sr.Parameter("p", "1", (1.0, 4.0))
    return sr.UncertainPlant.from_expressions([p], [[-EPS, 1], ["-p", -EPS]], [[0], [1]], form="state")


@pytest.fixture(scope="module")
def two_mass():
    return sr.load_plant("examples/plant-two-mass.toml")


# --- interpolation and grid --------------------------------------------------------------------------------------


def test_interpolate_gain_matches_breakpoints_midpoints_and_clamps():
    rng = np.random.default_rng(0)
    b = np.array([-1.0, 0.5, 0.75, 3.0])
    K = rng.normal(size=(4, 2, 3))
    for j, x in enumerate(b):
        assert np.array_equal(interpolate_gain(b, K, x), K[j])
    for j in range(3):
        mid = 0.5 * (b[j] + b[j + 1])
        np.testing.assert_allclose(interpolate_gain(b, K, mid), 0.5 * (K[j] + K[j + 1]), rtol=1e-14, atol=1e-14)
        quarter = 0.75 * b[j] + 0.25 * b[j + 1]
        np.testing.assert_allclose(interpolate_gain(b, K, quarter), 0.75 * K[j] + 0.25 * K[j + 1], atol=1e-14)
    assert np.array_equal(interpolate_gain(b, K, -7.0), K[0])
    assert np.array_equal(interpolate_gain(b, K, 1e9), K[-1])
    x = np.linspace(-3.0, 5.0, 41)
    out = interpolate_gain(b, K, x)
    assert out.shape == (41, 2, 3)
    for i in range(2):
        for k in range(3):
            np.testing.assert_allclose(out[:, i, k], np.interp(x, b, K[:, i, k]), rtol=1e-13, atol=1e-13)
    assert np.array_equal(interpolate_gain([2.0], K[:1], -5.0), K[0])


def test_interpolate_gain_rejects_bad_schedules():
    K = np.zeros((3, 1, 2))
    with pytest.raises(ValueError, match="increasing"):
        interpolate_gain([0.0, 2.0, 1.0], K, 0.5)
    with pytest.raises(ValueError, match="increasing"):
        interpolate_gain([0.0, 1.0, 1.0], K, 0.5)
    with pytest.raises(ValueError, match="shape"):
        interpolate_gain([0.0, 1.0], K, 0.5)


def test_schedule_grid_splits_each_segment_and_keeps_breakpoints():
    b = np.array([0.0, 0.3, 1.0])
    p, seg, s = schedule_grid(b, refine=2)
    assert p.shape == seg.shape == s.shape == (2 * 9,)
    np.testing.assert_array_equal(seg, [0] * 9 + [1] * 9)
    np.testing.assert_allclose(p[:9], np.linspace(0.0, 0.3, 9), rtol=1e-15)
    np.testing.assert_allclose(p[9:], np.linspace(0.3, 1.0, 9), rtol=1e-15)
    assert p[8] == p[9] == 0.3 and p[0] == 0.0 and p[-1] == 1.0
    np.testing.assert_allclose(s, np.tile(np.linspace(0, 1, 9), 2))


# --- the certificate's condition: hand-computed cases ----------------------------------------------------------


@pytest.mark.parametrize(("decay", "rate"), [(0.0, 0.9), (0.0, 1.1), (0.1, 0.75), (0.1, 0.85), (0.3, 0.35),
                                             (0.3, 0.45)])
def test_scalar_margin_flips_where_the_rate_term_says(scalar, decay, rate):
    P = np.array([1.0, 2.0, 1.0]).reshape(3, 1, 1)
    r = schedule_condition_margin(scalar, "p", SCALAR_B, SCALAR_K, P, rate=rate, delta=0.0, decay=decay)
    expected = (2.0 * (decay - 0.5) + rate) / 2.0
    assert r["max_eig"] == pytest.approx(expected, abs=1e-13)
    assert r["certified"] == (rate < 1.0 - 2.0 * decay)
    assert r["min_P_eig"] == pytest.approx(0.5, abs=1e-15)
    assert r["scale"] == pytest.approx(2.0)
    assert r["checks"] == 2 * 17 * 9 * 2                    # segments x (16 + 1) x q-grid x (±ν)
    w = r["worst"]
    assert w["q"] == {"q": 0.5}
    assert w["p"] in (0.0, 2.0)
    assert w["p_dot"] == (rate if w["p"] == 0.0 else -rate)  # the sign that makes ṗ D_j = +ν


@pytest.mark.parametrize(("delta", "decay", "expected"), [(0.0, 0.0, -1.0), (0.35, 0.1, -0.1), (0.45, 0.1, 0.1),
                                                          (2.5, 0.0, 3.0)])
def test_scalar_margin_measurement_error_and_clamping(scalar, delta, decay, expected):
    """P = 1: ``max L = 2(α − 1/2 + min(δ, 2))``; δ = 2.5 would give 4 without clamping p̂."""
    P = np.ones((3, 1, 1))
    r = schedule_condition_margin(scalar, "p", SCALAR_B, SCALAR_K, P, rate=0.7, delta=delta, decay=decay)
    assert r["max_eig"] == pytest.approx(expected, abs=1e-13)
    assert r["certified"] == (expected < 0)
    w = r["worst"]
    assert w["q"] == {"q": 0.5}
    if 0 < delta < 2:
        assert w["p_hat"] == pytest.approx(w["p"] - delta)
    if delta == 2.5:
        assert w["p"] == 2.0 and w["p_hat"] == 0.0


def test_a_breakpoint_inside_the_measurement_interval_is_checked():
    """``ẋ = q x − K(p̂) x`` with a V-shaped schedule K = (3, 1, 3): the weakest gain is at p̂ = b_1 = 1.

    For every p within δ of 1 the worst p̂ is the breakpoint, strictly inside ``[p − δ, p + δ]``
    (p = 1 is on every grid), so ``max L = 2(1/2 − 1) = −1`` exactly; the ends alone give less.
    """
    p = sr.Parameter("p", "1", (0.0, 2.0))
    q = sr.Parameter("q", "1", (-0.5, 0.5))
    plant = sr.UncertainPlant.from_function([p, q], lambda v: ([[v["q"]]], [[1.0]]), form="state")
    K = np.array([3.0, 1.0, 3.0]).reshape(3, 1, 1)
    r = schedule_condition_margin(plant, "p", SCALAR_B, K, np.ones((3, 1, 1)), rate=0.0, delta=0.1)
    assert r["max_eig"] == pytest.approx(-1.0, abs=1e-13)
    assert r["worst"]["p_hat"] == 1.0 and abs(r["worst"]["p"] - 1.0) < 0.1
    assert frozen_spectral_abscissa(plant, "p", SCALAR_B, K, delta=0.1) == pytest.approx(-0.5)


@pytest.mark.parametrize("mirror", [False, True])
def test_interior_breakpoint_uses_the_adjacent_segments_slope(scalar, mirror):
    """P = (1, 1, 3): flat on segment 0, slope 2 on segment 1; the worst check is p = 1 with segment 1's slope.

    ``L = −P(p) + ṗ D_j`` (a_cl = −1/2): −1 on segment 0, ``−(1 + 2s) ± 2ν`` on segment 1, so the
    maximum ``−1 + 2ν`` (over 3) is at the breakpoint, only through the slope of the segment after
    it. Mirrored (P = (3, 1, 1)) it is segment 0's slope, at ṗ = −ν.
    """
    nu = 0.3
    P = np.array([3.0, 1.0, 1.0] if mirror else [1.0, 1.0, 3.0]).reshape(3, 1, 1)
    r = schedule_condition_margin(scalar, "p", SCALAR_B, SCALAR_K, P, rate=nu, delta=0.0)
    assert r["max_eig"] == pytest.approx((-1.0 + 2.0 * nu) / 3.0, abs=1e-13)
    w = r["worst"]
    assert w["p"] == 1.0
    assert w["segment"] == (0 if mirror else 1)
    assert w["p_dot"] == (-nu if mirror else nu)


@pytest.mark.parametrize(("rate", "delta", "decay"), [(0.14, 0.2, 0.0), (0.16, 0.2, 0.0), (0.1, 0.0, 0.02),
                                                      (0.1, 0.0, 0.06), (0.19, 0.0, 0.0), (0.21, 0.0, 0.0),
                                                      (0.0, 0.3, 0.03)])
def test_oscillator_margin_has_the_closed_form(oscillator, rate, delta, decay):
    r = schedule_condition_margin(oscillator, "p", OSC_B, OSC_K, OSC_P, rate=rate, delta=delta, decay=decay)
    a1 = -2.0 * (EPS - decay) + rate
    c = -2.0 * (EPS - decay)
    e = delta / 2.0
    expected = ((a1 + c) / 2.0 + np.hypot((a1 - c) / 2.0, e)) / 4.0
    assert r["max_eig"] == pytest.approx(expected, abs=1e-14)
    # negative definite iff a1 < 0, c < 0 and a1 c > e²
    assert r["certified"] == (a1 < 0 and c < 0 and a1 * c > e * e)
    assert r["min_P_eig"] == pytest.approx(0.25)
    assert r["worst"]["p"] == 1.0
    if delta > 0:
        assert r["worst"]["p_hat"] == pytest.approx(1.0 + delta)


def _direct_common_test(plant, b, K, P_of_p, k_points=9):
    """max λ(A_clᵀP + PA_cl)/max‖P‖ by a plain loop over plant.frozen (no schedule_check code)."""
    worst = -np.inf
    for j in range(len(b) - 1):
        for p in np.linspace(b[j], b[j + 1], 17):
            Kp = np.array([[np.interp(p, b, K[:, i, k]) for k in range(K.shape[2])] for i in range(K.shape[1])])
            for k in np.linspace(50.0, 200.0, k_points):
                A, B = plant.frozen({"m2": p, "k": k})
                A_cl = A - B @ Kp
                Pp = P_of_p(p)
                worst = max(worst, np.linalg.eigvalsh(A_cl.T @ Pp + Pp @ A_cl)[-1])
    return worst


def _lqr_schedule(plant, b):
    gains, Ps = [], []
    for x in b:
        A, B = plant.frozen({"m2": x, "k": 125.0})
        X = scipy.linalg.solve_continuous_are(A, B, np.eye(A.shape[0]), np.eye(B.shape[1]))
        gains.append(B.T @ X)
        Ps.append(scipy.linalg.solve_continuous_lyapunov((A - B @ gains[-1]).T, -np.eye(A.shape[0])))
    return np.array(gains), np.array(Ps)


def test_reduces_to_common_lyapunov_test_without_rate_or_error(two_mass):
    b = np.array([1.0, 2.0, 3.0])
    K, Ps = _lqr_schedule(two_mass, b)
    P = np.array([Ps[1]] * 3)
    scale = np.linalg.norm(Ps[1], 2)
    r = schedule_condition_margin(two_mass, "m2", b, K, P, rate=0.0, delta=0.0)
    direct = _direct_common_test(two_mass, b, K, lambda p: Ps[1]) / scale
    assert r["max_eig"] == pytest.approx(direct, rel=1e-10, abs=1e-12)
    assert r["min_P_eig"] == pytest.approx(np.linalg.eigvalsh(Ps[1])[0] / scale, rel=1e-12)
    assert r["checks"] == 2 * 17 * 9 and r["q_points"] == 9
    # a constant P has no slope: any rate gives the same number
    assert schedule_condition_margin(two_mass, "m2", b, K, P, rate=5.0, delta=0.0)["max_eig"] == r["max_eig"]

    # constant gain, one segment: the plant's own sampler gives the same frozen family
    r1 = schedule_condition_margin(two_mass, "m2", b[[0, 2]], K[[1, 1]], P[:2], rate=0.0, delta=0.0)
    A_cl = two_mass.samples({"m2": 17, "k": 9}).closed_loops(K[1])
    sampled = np.linalg.eigvalsh(np.swapaxes(A_cl, 1, 2) @ Ps[1] + Ps[1] @ A_cl)[:, -1].max() / scale
    assert r1["max_eig"] == pytest.approx(sampled, rel=1e-10, abs=1e-12)


def test_piecewise_P_without_rate_is_the_pointwise_test(two_mass):
    b = np.array([1.0, 2.0, 3.0])
    K, Ps = _lqr_schedule(two_mass, b)

    def P_of_p(p):
        return np.stack([np.interp(p, b, Ps[:, i, k]) for i in range(6) for k in range(6)]).reshape(6, 6)

    r = schedule_condition_margin(two_mass, "m2", b, K, Ps, rate=0.0, delta=0.0)
    scale = max(np.linalg.norm(Pj, 2) for Pj in Ps)
    assert r["max_eig"] == pytest.approx(_direct_common_test(two_mass, b, K, P_of_p) / scale, rel=1e-10, abs=1e-12)


def test_margin_rejects_bad_arguments(scalar):
    P = np.ones((3, 1, 1))
    with pytest.raises(ValueError, match="shape"):
        schedule_condition_margin(scalar, "p", SCALAR_B, SCALAR_K, np.ones((2, 1, 1)), rate=0, delta=0)
    with pytest.raises(ValueError, match="shape"):
        schedule_condition_margin(scalar, "p", SCALAR_B, np.ones((3, 1, 2)), P, rate=0, delta=0)
    with pytest.raises(ValueError, match="rate"):
        schedule_condition_margin(scalar, "p", SCALAR_B, SCALAR_K, P, rate=-1, delta=0)
    with pytest.raises(ValueError, match="not one of"):
        schedule_condition_margin(scalar, "x", SCALAR_B, SCALAR_K, P, rate=0, delta=0)
    with pytest.raises(ValueError, match="zero"):
        schedule_condition_margin(scalar, "p", SCALAR_B, SCALAR_K, 0 * P, rate=0, delta=0)


# --- frozen loops and Floquet growth ------------------------------------------------------------------------------


@pytest.mark.parametrize(("delta", "expected"), [(0.0, -0.5), (0.3, -0.2), (2.5, 1.5)])
def test_frozen_spectral_abscissa_scalar(scalar, delta, expected):
    """``max a_cl = 1/2 − 1 + min(δ, 2)`` (q = 1/2, p̂ = p − δ clamped)."""
    assert frozen_spectral_abscissa(scalar, "p", SCALAR_B, SCALAR_K, delta=delta) == pytest.approx(expected)
    assert frozen_spectral_abscissa(scalar, "p", SCALAR_B, SCALAR_K, delta=delta, points=51) == pytest.approx(expected)


@pytest.mark.parametrize("rate", [0.05, 1.0, 40.0])
def test_floquet_of_a_constant_loop_is_its_spectral_abscissa(rate):
    A = np.array([[-0.2, 3.0, 0.0], [-1.0, -0.4, 5.0], [0.0, 0.0, -0.7]])   # non-normal
    Bm = np.array([[0.0], [1.0], [0.5]])
    p = sr.Parameter("p", "1", (0.0, 1.0))
    plant = sr.UncertainPlant.from_function([p], lambda v: (A, Bm), form="state")
    K = np.array([[[0.3, -0.2, 0.1]]] * 2)
    expected = np.linalg.eigvals(A - Bm @ K[0]).real.max()
    assert scheduled_floquet_growth(plant, "p", [0.0, 1.0], K, rate, n_ramp=20) == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("bias", [0.0, 0.4, -0.7])
def test_floquet_of_a_scalar_loop_is_the_mean_over_the_midpoints(scalar, bias):
    """Scalar loops commute: the growth is the mean of ``a_cl`` over the held midpoints, at any rate."""
    K = np.array([1.0, 3.0, 2.0]).reshape(3, 1, 1)
    n = 50
    mid = (np.arange(n) + 0.5) * (2.0 / n)
    expected = np.mean(mid + 0.2 - np.interp(mid + bias, SCALAR_B, K[:, 0, 0]))
    for rate in (0.01, 3.0):
        got = scheduled_floquet_growth(scalar, "p", SCALAR_B, K, rate, bias=bias, at={"q": 0.2}, n_ramp=n)
        assert got == pytest.approx(expected, abs=1e-11)


def test_floquet_finds_parametric_resonance_that_frozen_loops_miss(free_oscillator):
    b, K = np.array([1.0, 4.0]), np.zeros((2, 1, 2))
    assert frozen_spectral_abscissa(free_oscillator, "p", b, K) == pytest.approx(-EPS)
    growth = {rate: scheduled_floquet_growth(free_oscillator, "p", b, K, rate) for rate in (0.2, 1.8, 3.0, 8.0)}
    for g in growth.values():
        assert g >= -EPS - 1e-9                  # Liouville: the exponents sum to the mean trace −2ε
    for rate in (0.2, 1.8, 8.0):
        assert growth[rate] == pytest.approx(-EPS, abs=1e-9)   # elliptic monodromy: |multipliers| = e^{−εT}
    assert growth[3.0] > 0.05                    # resonance: the switching destabilizes stable frozen loops
    # P(p) = diag(p, 1) gives L = diag(−2εp ± ν, −2ε): certified for ν < 2ε, and no P can be at ṗ = 3
    P = np.array([np.diag([x, 1.0]) for x in b])
    assert not schedule_condition_margin(free_oscillator, "p", b, K, P, rate=3.0, delta=0.0)["certified"]
    assert schedule_condition_margin(free_oscillator, "p", b, K, P, rate=0.1, delta=0.0)["certified"]


def test_floquet_matches_the_continuous_triangle_wave(free_oscillator):
    """The held-midpoint product converges to the monodromy of the continuous p(t) (second order in the step)."""
    rate, lo, hi = 3.0, 1.0, 4.0
    T = (hi - lo) / rate

    def rhs(t, y):
        p = lo + rate * t if t <= T else hi - rate * (t - T)
        A = np.array([[-EPS, 1.0], [-p, -EPS]])
        return (A @ y.reshape(2, 2)).ravel()

    phi = np.eye(2).ravel()
    for span in ((0.0, T), (T, 2 * T)):
        phi = solve_ivp(rhs, span, phi, method="DOP853", rtol=1e-11, atol=1e-13).y[:, -1]
    exact = np.log(np.abs(np.linalg.eigvals(phi.reshape(2, 2))).max()) / (2 * T)
    coarse = scheduled_floquet_growth(free_oscillator, "p", [lo, hi], np.zeros((2, 1, 2)), rate, n_ramp=100)
    fine = scheduled_floquet_growth(free_oscillator, "p", [lo, hi], np.zeros((2, 1, 2)), rate, n_ramp=400)
    assert abs(fine - exact) < 1e-5
    assert abs(fine - exact) < abs(coarse - exact) / 8     # O(h²): 4x finer, ~16x closer


def test_certified_decay_bounds_the_floquet_growth(oscillator):
    """Where the margin certifies α at (ν, δ), every triangle wave at ṗ <= ν with |bias| <= δ decays at >= α."""
    rate, delta, decay = 0.1, 0.2, 0.015
    r = schedule_condition_margin(oscillator, "p", OSC_B, OSC_K, OSC_P, rate=rate, delta=delta, decay=decay)
    assert r["certified"]
    for speed in (0.02, rate):
        for bias in (-delta, 0.0, delta):
            assert scheduled_floquet_growth(oscillator, "p", OSC_B, OSC_K, speed, bias=bias, n_ramp=50) <= -decay


def test_dc_motor_example_schedule():
    """The DC motor of examples/: an LQR schedule in J, certified at the file's rate; its loops decay accordingly."""
    motor = sr.load_plant("examples/plant-dc-motor.toml")
    rate = motor.parameter("J").rate
    b = np.linspace(2e-4, 6e-4, 3)
    gains, Ps = [], []
    for x in b:
        A, B = motor.frozen({"J": x})
        K = B.T @ scipy.linalg.solve_continuous_are(A, B, np.diag([100.0, 10.0, 1.0]), np.eye(1))
        gains.append(K)
        Ps.append(scipy.linalg.solve_continuous_lyapunov((A - B @ K).T, -np.eye(3)))
    gains, Ps = np.array(gains), np.array(Ps)
    r = schedule_condition_margin(motor, "J", b, gains, Ps, rate=rate, delta=2e-5, decay=0.02)
    assert r["certified"] and r["q_points"] == 1
    assert not schedule_condition_margin(motor, "J", b, gains, Ps, rate=10 * rate, delta=2e-5)["certified"]
    assert frozen_spectral_abscissa(motor, "J", b, gains, delta=2e-5) < -0.02
    for bias in (-2e-5, 2e-5):
        assert scheduled_floquet_growth(motor, "J", b, gains, rate, bias=bias, n_ramp=40) < -0.02
