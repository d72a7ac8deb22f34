"""The deployable discrete PID: its law, its python-control form, its sampled-data certificate."""

from __future__ import annotations

import dataclasses

import control as ct
import numpy as np
import pytest

import scara_robust as sr


@pytest.fixture(scope="module")
def design():
    return sr.design(sr.paper_model(), 3.0, 90.0)


def _double_integrator(ki: float, kp: float, kd: float) -> tuple[sr.UncertainLTVModel, sr.Design]:
    """ë = −u (a unit inertia in the error form of Eq. 4) and the PID u = ki ∫e + kp e + kd ė."""
    model = sr.pid_augment(ct.ss([[0, 1], [0, 0]], [[0], [1.0]], [[1, 0]], 0), [("B", 1, 0, 0.0, 0.0)])
    d = sr.design(model, 1.0, 2.0)
    return model, dataclasses.replace(d, K=-np.array([[ki, kp, kd]]))


# -- the law ------------------------------------------------------------------------------


@pytest.mark.parametrize("integrator", sr.INTEGRATOR_METHODS)
@pytest.mark.parametrize("derivative", sr.DERIVATIVE_MODES)
def test_step_is_the_python_control_system_without_limit(design, integrator, derivative):
    pid = design.discretize(2e-3, integrator=integrator, derivative=derivative)
    rng = np.random.default_rng(1)
    y = rng.normal(size=(4, 300))
    if derivative == "filtered":
        y[2:] = 0.0
    resp = ct.forced_response(pid.to_statespace(), T=np.arange(300) * 2e-3, U=y)
    pid.reset()
    u = np.array([pid.step(y[:2, k], y[2:, k]) for k in range(300)]).T
    np.testing.assert_allclose(u, resp.outputs, rtol=1e-10, atol=1e-9)


def test_tustin_integrator_matches_the_trapezoid(design):
    pid = design.discretize(1e-2, integrator="tustin")
    K_I, K_P, K_D = design.pid_matrices()
    t = np.arange(200) * 1e-2
    e = np.vstack([np.sin(t), np.cos(3 * t)])
    pid.reset(e0=e[:, 0])  # ∫e(0) = 0
    u = np.array([pid.step(e[:, k], np.zeros(2)) for k in range(t.size)]).T
    trapezoid = np.concatenate([np.zeros((2, 1)), np.cumsum(0.5 * 1e-2 * (e[:, 1:] + e[:, :-1]), axis=1)], axis=1)
    np.testing.assert_allclose(u, K_I @ trapezoid + K_P @ e, rtol=1e-9, atol=1e-9)


def test_filtered_derivative_approaches_the_measured_one(design):
    # A slow ramp: the filtered difference tends to K_D ė (first-order lag, N Ts = 0.1).
    K_D = design.pid_matrices()[2]
    pid = design.discretize(1e-3, derivative="filtered", N=100.0, integrator="forward")
    pid.reset(e0=[0.0, 0.0])
    rate = np.array([0.3, -0.2])
    for k in range(400):
        u = pid.step(rate * k * 1e-3)
    integral = design.pid_matrices()[0] @ (rate * (398 * 399 / 2) * 1e-6)  # forward Euler: samples 0..398
    proportional = design.pid_matrices()[1] @ (rate * 399e-3)
    np.testing.assert_allclose(u - integral - proportional, K_D @ rate, rtol=1e-6)


def test_bumpless_start_and_no_derivative_kick(design):
    e0, ed0, u0 = np.array([0.2, -0.1]), np.array([0.5, 0.3]), np.array([3.0, -4.0])
    for derivative in sr.DERIVATIVE_MODES:
        pid = design.discretize(1e-3, derivative=derivative, torque_limit=50.0)
        pid.reset(e0=e0, edot0=ed0, u0=u0)
        np.testing.assert_allclose(pid.step(e0, ed0), u0, atol=1e-12)
    pid = design.discretize(1e-3, derivative="filtered")
    pid.reset(e0=e0)
    K_I, K_P, _ = design.pid_matrices()
    np.testing.assert_allclose(pid.step(e0), K_P @ e0, rtol=1e-12)  # ∫e(0) = 0, and no N K_D e0 kick


def test_saturation_and_back_calculation(design):
    # With T_t = Ts the integral term is reset in one sample so that v = u at constant e.
    pid = design.discretize(1e-3, integrator="forward", torque_limit=10.0, tracking_time=1e-3)
    e, ed = np.array([0.5, 0.5]), np.zeros(2)
    u = [pid.step(e, ed) for _ in range(3)]
    assert np.all(np.abs(u) <= 10.0)
    z, y = list(pid.state), [*e, *ed]
    assert max(abs(a - b) for a, b in zip(*pid.output(z, y))) < 0.5 * abs(pid.K_I).sum()
    free = design.discretize(1e-3, integrator="forward", torque_limit=10.0, anti_windup=False)
    for _ in range(1000):
        free.step(e, ed)
    np.testing.assert_allclose(free.state, design.pid_matrices()[0] @ e * 1.0, rtol=1e-9)  # wound up for 1 s


def test_default_tracking_time_is_sqrt_ti_td(design):
    K_I, K_P, K_D = design.pid_matrices()
    pid = design.discretize(1e-3)
    ti, td = K_P[0, 0] / K_I[0, 0], K_D[0, 0] / K_P[0, 0]
    assert pid.tracking_time[0] == pytest.approx(np.sqrt(ti * td), rel=0.05)  # the coupling terms are small
    assert np.all(pid.tracking_time >= 1e-3)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"Ts": 0.0}, ValueError, r"`Ts` must be > 0"),
        ({"Ts": -1e-3}, ValueError, r"`Ts` must be > 0"),
        ({"tracking_time": 0.0, "torque_limit": 5.0}, ValueError, r"`tracking_time` must be > 0"),
        ({"tracking_time": -1e-4}, ValueError, r"`tracking_time` must be > 0"),  # below Ts is taken, as upstream
        ({"torque_limit": [5.0, 0.0]}, ValueError, r"`torque_limit` must be > 0"),
        ({"torque_limit": -5.0}, ValueError, r"`torque_limit` must be > 0"),
        ({"integrator": "euler"}, ValueError, r"`integrator` must be one of"),
        ({"N": 0.0}, ValueError, r"`N` must be > 0"),
        ({"Ts": "1ms"}, TypeError, r"`Ts` must be a real number"),
    ],
    ids=["ts-zero", "ts-negative", "tt-zero", "tt-negative", "limit-zero", "limit-negative", "integrator", "n-zero",
         "ts-string"],
)
def test_discretize_refuses_bad_options(design, kwargs, error, match):
    Ts = kwargs.pop("Ts", 1e-3)
    with pytest.raises(error, match=match):
        design.discretize(Ts, **kwargs)


def test_discretize_needs_the_pid_form():
    plain = sr.design(sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]), ()), 1, 2)
    with pytest.raises(ValueError, match=r"`design` is not for a model in the PID form"):
        plain.discretize(1e-3)


# -- sampled-data certificate -------------------------------------------------------------


def test_sampled_loops_match_python_control(design):
    """Cross-check: ZOH by ``control.c2d`` and the loop by ``control.feedback`` have the same poles."""
    s = sr.physical_samples(times=[0.0, 1.0], n_masses=2)
    pid = design.discretize(1e-3, derivative="filtered", N=200.0)
    loops = sr.sampled_closed_loops(s.A, s.B, pid)
    for A, B, Ad in zip(s.A, s.B, loops):
        plant = ct.c2d(ct.ss(A[2:, 2:], B[2:], np.eye(4), 0), 1e-3, method="zoh")
        loop = ct.feedback(plant, pid.to_statespace(), sign=+1)
        np.testing.assert_allclose(np.sort_complex(loop.poles()), np.sort_complex(np.linalg.eigvals(Ad)), atol=1e-9)


def test_frozen_limit_of_a_hand_derived_plant():
    r"""The sampled double integrator with a PID: the exact limit is Ts* = 2/k_d.

    Plant ë = −u held by a zero-order hold over T: Φ = [[1, T], [0, 1]], Γ = −[T²/2, T].
    Forward-Euler PID u_k = w_k + k_p e_k + k_d ė_k, w_{k+1} = w_k + T k_i e_k. On the
    state [e, ė, w] the loop matrix is

        [[1 − k_p T²/2, T − k_d T²/2, −T²/2], [−k_p T, 1 − k_d T, −T], [k_i T, 0, 1]],

    with characteristic polynomial p(z) = z³ + a₂z² + a₁z + a₀,
    a₂ = k_p T²/2 + k_d T − 3, a₁ = k_i T³/2 − 2k_d T + 3, a₀ = k_i T³/2 − k_p T²/2 + k_d T − 1.
    Jury's conditions: p(1) = k_i T³ > 0 always; −p(−1) = 4(2 − k_d T) > 0 iff T < 2/k_d;
    |a₀| < 1 and |a₀² − 1| > |a₀a₂ − a₁|. With (k_i, k_p, k_d) = (0.5, 2, 20),
    a₀ = 0.25T³ − T² + 20T − 1 increases from −1 (T = 0) to 0.99025 (T = 0.1), and the last
    condition holds on (0, 0.1] (checked below on a grid): the only one that fails first
    is −p(−1) > 0, at T* = 2/k_d = 0.1 s exactly, where a real root crosses z = −1.
    """
    ki, kp, kd = 0.5, 2.0, 20.0

    def coefficients(T):
        return kp * T**2 / 2 + kd * T - 3, ki * T**3 / 2 - 2 * kd * T + 3, ki * T**3 / 2 - kp * T**2 / 2 + kd * T - 1

    a2, a1, a0 = coefficients(np.linspace(1e-3, 0.1, 100))
    assert np.all(np.abs(a0) < 1) and np.all(np.abs(a0**2 - 1) > np.abs(a0 * a2 - a1))
    model, d = _double_integrator(ki, kp, kd)
    A = sr.sampled_closed_loops(model.A[None], model.B[None], d.discretize(0.05, integrator="forward"))[0]
    np.testing.assert_allclose(np.poly(A), [1.0, *coefficients(0.05)], atol=1e-12)  # the polynomial above
    lim = sr.max_sample_time(model, d, integrator="forward", rtol=1e-4, ts_max=1.0)
    lo, hi = lim.unstable_bracket
    assert lo < 2 / kd <= hi and hi - lo <= 1e-4 * hi


@pytest.mark.lmi
def test_certified_limit_of_a_hand_derived_plant():
    """One plant: a common P exists iff the loop is Schur stable, so the certified Ts approaches 2/k_d."""
    model, d = _double_integrator(0.5, 2.0, 20.0)
    lim = sr.max_sample_time(model, d, integrator="forward", rtol=1e-3)
    assert 0.09 < lim.certified_ts <= 0.1 <= lim.unstable_ts
    assert lim.certificate is not None and lim.certificate.certified
    Ad = sr.sampled_closed_loops(model.A[None], model.B[None], d.discretize(lim.certified_ts, integrator="forward"))
    P = lim.certificate.P
    assert np.linalg.eigvalsh(P)[0] > 0 and np.linalg.eigvalsh(Ad[0].T @ P @ Ad[0] - P)[-1] < 0


@pytest.mark.lmi
def test_paper_design_sample_time(design, paper_sample_time):
    """The paper's design on the robot's own sampled (A, B): the certified Ts and the frozen instability."""
    lim = paper_sample_time
    assert lim.certificate is not None and lim.certificate.certified and lim.certificate.n_plants == 305
    assert 5e-4 < lim.certified_ts <= lim.unstable_ts < 2e-3
    # the fast pole at −1489 1/s sets the scale: a forward-Euler-like limit 2/1489 s
    assert lim.unstable_ts < 2 / 1489
    s = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 61), n_masses=5)
    far = sr.sampled_certificate(s, design.discretize(3 * lim.unstable_ts))
    assert not far.frozen_stable and not far.certified and "unstable" in far.message


def test_sampled_certificate_refuses_bad_input(design):
    with pytest.raises(TypeError, match=r"`pid`"):
        sr.sampled_certificate(sr.paper_model(), design)
    with pytest.raises(ValueError, match=r"`ts_max` must be > ts_min"):
        sr.max_sample_time(sr.paper_model(), design, ts_min=1e-2, ts_max=1e-3)
    with pytest.raises(ValueError, match=r"`solver`"):
        sr.sampled_certificate(sr.paper_model(), design.discretize(1e-3), solver="MOSEK")


# ---------------------------------------------------------------- static feedback, marginal modes, the cap

#: A classic benchmark: q̈ = −0.1 q̇ + 0.1 u, u = −[3.75, 11.5] [q, q̇](t_k) under a zero-order hold.
ZOH_A = np.array([[0.0, 1.0], [0.0, -0.1]])
ZOH_B = np.array([[0.0], [0.1]])
ZOH_K = np.array([[3.75, 11.5]])


def _zoh_limit_by_eigenvalues() -> float:
    """The largest constant Ts: where the spectral radius of Φ − ΓK crosses 1 (scipy's expm, brentq)."""
    import scipy.linalg
    import scipy.optimize

    def excess(ts: float) -> float:
        held = scipy.linalg.expm(np.block([[ZOH_A, ZOH_B], [np.zeros((1, 3))]]) * ts)
        return float(np.abs(np.linalg.eigvals(held[:2, :2] - held[:2, 2:] @ ZOH_K)).max()) - 1.0

    assert excess(1.0) < 0 < excess(2.0)
    return float(scipy.optimize.brentq(excess, 1.0, 2.0, xtol=1e-12))


@pytest.mark.parametrize("form", ["gain", "pid-ki-0"])
def test_zoh_benchmark_brackets_the_eigenvalue_limit(form):
    """The static gain, given as K or as a PID with K_I = 0 on the PID form, brackets 1.7294 s to 1e-3.

    With K_I = 0 the PID's accumulator keeps its value and is fed by nothing: its eigenvalue
    is exactly 1 at every Ts. It is left out and named, not reported as unstable at ts_min.
    """
    exact = _zoh_limit_by_eigenvalues()
    assert exact == pytest.approx(1.7294, abs=1e-4)
    if form == "gain":
        limit = sr.max_sample_time((ZOH_A[None], ZOH_B[None]), ZOH_K, rtol=1e-4)
    else:
        plant = sr.pid_augment(ct.ss(ZOH_A, ZOH_B, [[1.0, 0.0]], 0), [])
        pid = sr.DiscretePID(0.1, [[0.0]], ZOH_K[:, :1], ZOH_K[:, 1:], integrator="forward")
        limit = sr.max_sample_time(plant, pid, rtol=1e-4)
        assert "fed by nothing" in limit.message and "K_I = 0" in limit.message
    low, high = limit.unstable_bracket
    assert low <= exact <= high and (high - low) <= 1e-3 * exact
    assert limit.certified_ts <= low and limit.certificate is not None and limit.certificate.certified


@pytest.mark.parametrize(("Ts", "status"), [(1.5, "tracking"), (1.9, "not-tracking")])
def test_sampled_state_feedback_simulation_steps_like_the_sampled_loop(Ts, status):
    """simulate_plant with the ZOH gain: at the samples, x_k+1 = (Φ − ΓK) x_k (scipy's expm), to LSODA's tolerance.

    Below the limit 1.7294 s the regulated state decays; above it grows, and the run says so.
    """
    import scipy.linalg

    a, b = sr.Parameter("a", "1/s", (0.1, 0.1)), sr.Parameter("b", "m/(N·s²)", (0.1, 0.1))
    plant = sr.UncertainPlant.from_expressions([a, b], [[0, 1], [0, "-a"]], [[0], ["b"]], form="state")
    run = sr.simulate_plant(plant, sr.SampledStateFeedback(ZOH_K, Ts), x0=[1.0, 0.0], t_final=60.0, n_points=1201)
    held = scipy.linalg.expm(np.block([[ZOH_A, ZOH_B], [np.zeros((1, 3))]]) * Ts)
    loop = held[:2, :2] - held[:2, 2:] @ ZOH_K
    x, scale = np.array([1.0, 0.0]), 1.0
    for k in range(int(60.0 / Ts) + 1):
        at = np.flatnonzero(np.isclose(run.t, k * Ts, rtol=0.0, atol=1e-9))
        if at.size:
            assert run.y[0, at[0]] == pytest.approx(x[0], abs=1e-6 * scale)
            assert run.u[0, at[0]] == pytest.approx(float((-ZOH_K @ x)[0]), abs=1e-5 * scale)
        x = loop @ x
        scale = max(scale, float(np.abs(x).max()))
    assert run.status == status
    changes = np.flatnonzero(np.diff(run.u[0]) != 0)  # u is held: it changes only where a sample falls between
    assert changes.size and np.all(np.floor(run.t[changes] / Ts + 1e-9) != np.floor(run.t[changes + 1] / Ts + 1e-9))


def test_sampled_certificate_leaves_out_and_counts_the_marginal_state():
    plant = sr.pid_augment(ct.ss(ZOH_A, ZOH_B, [[1.0, 0.0]], 0), [])
    pid = sr.DiscretePID(0.5, [[0.0]], ZOH_K[:, :1], ZOH_K[:, 1:], integrator="forward")
    loops = sr.sampled_closed_loops(plant.A[None], plant.B[None], pid)
    assert np.abs(np.linalg.eigvals(loops)).max() == 1.0  # the accumulator, exactly
    cert = sr.sampled_certificate(plant, pid)
    assert cert.n_marginal == 1 and cert.frozen_stable and cert.spectral_radius < 1
    static = sr.sampled_certificate((ZOH_A[None], ZOH_B[None]), sr.SampledStateFeedback(ZOH_K, 0.5))
    assert static.n_marginal == 0 and static.spectral_radius == pytest.approx(cert.spectral_radius, rel=1e-12)


def test_max_sample_time_says_when_it_reached_its_cap():
    """A loop stable at every Ts (a stable first-order plant, no feedback) is searched up to the cap, and says so."""
    A, B = np.array([[[-1.0]]]), np.array([[[1.0]]])
    limit = sr.max_sample_time((A, B), [[0.0]], ts_max=10.0, rtol=1e-2)
    assert limit.unstable_ts == np.inf and "no frozen instability up to the cap ts_max = 10 s" in limit.message
    assert sr.MAX_SAMPLE_TIME_CAP == 100.0


def test_max_sample_time_refuses_a_gain_that_is_not_a_matrix():
    with pytest.raises(sr.ArgumentTypeError, match="`design` must be a Design, a DiscretePID"):
        sr.max_sample_time((ZOH_A[None], ZOH_B[None]), "K")
