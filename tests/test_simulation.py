import numpy as np
import pytest
from scipy.integrate import solve_ivp

import scara_robust as sr
from scara_robust.simulation.engines import DEFAULT_ENGINE, SAMPLED_ENGINE

P = sr.ScaraParams()
K = sr.design(sr.paper_model(), 3, 90).K


def independent_pid_run(e0, ed0, t_final):
    """PID loop written from the paper's equations alone: numpy + scipy, no python-control."""
    m2, L1, L2, Lc2 = P.m2, P.L1, P.L2, P.Lc2

    def mp(t):
        return 0.3 * m2 * (np.sin(t) + 1)

    def rhs(t, z, td):
        q, qd, ie = z[:2], z[2:4], z[4:]
        r, rd = np.array([np.sin(t), np.cos(t)]), np.array([np.cos(t), -np.sin(t)])
        e, ed = r - q, rd - qd
        tc = -K @ np.concatenate([ie, e, ed])
        m = mp(t)
        a1 = P.m1 * P.Lc1**2 + (m2 + m) * L1**2 + P.I1
        a2 = m2 * Lc2**2 + m * L2**2 + P.I2 + P.cp * m
        a3 = L1 * (m2 * Lc2 + m * L2)
        M = np.array([[a1 + a2 + 2 * a3 * np.cos(q[1]), a2 + a3 * np.cos(q[1])], [a2 + a3 * np.cos(q[1]), a2]])
        C = np.array([-a3 * (2 * qd[0] * qd[1] + qd[1] ** 2) * np.sin(q[1]), a3 * qd[0] ** 2 * np.sin(q[1])])
        return np.concatenate([qd, np.linalg.solve(M, tc + td - C), e])

    half = np.pi / 10
    edges = np.append(np.arange(0, t_final, half), t_final)
    z = np.array([0 - e0[0], 1 - e0[1], 1 - ed0[0], 0 - ed0[1], 0, 0])
    worst = 0.0
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        td = np.full(2, 5.0 if k % 2 == 0 else -5.0)
        t_eval = np.arange(np.ceil(a / 1e-3), np.floor(b / 1e-3) + 1) * 1e-3
        sol = solve_ivp(rhs, (a, b), z, t_eval=t_eval[(t_eval >= a) & (t_eval <= b)], args=(td,), rtol=1e-9, atol=1e-11)
        z = solve_ivp(rhs, (a, b), z, args=(td,), rtol=1e-9, atol=1e-11).y[:, -1]
        after = sol.t >= 6
        if after.any():
            e = np.array([np.sin(sol.t), np.cos(sol.t)]) - sol.y[:2]
            worst = max(worst, np.abs(e[:, after]).max())
    return worst


#: the large initial error in make test-slow (the small one checks the same loop here)
@pytest.mark.parametrize("scenario", [pytest.param("large", marks=pytest.mark.slow), "small"], ids=["large", "small"])
def test_closed_loop_matches_independent_integration(scenario):
    sc = sr.SCENARIOS[scenario]
    ours = sr.run_scenario("pid", scenario, t_final=10.0).metrics().max_abs_error
    theirs = independent_pid_run(sc.e0, sc.edot0, 10.0)
    assert ours == pytest.approx(theirs, abs=1e-4)


@pytest.mark.parametrize(
    ("controller", "scenario"),
    [("pid", "large"), pytest.param("pid", "small", marks=pytest.mark.slow),
     pytest.param("smc", "large", marks=pytest.mark.slow)],
    ids=["pid-large", "pid-small", "smc-large"],
)
def test_fast_path_matches_interconnect(controller, scenario):
    # python-control's interconnect is the slow reference: one case in `make test` over the first 3 s (the
    # transient of the large initial error), all of them over 8 s in test-slow.
    # The fast path (LSODA, lean right-hand side) against python-control's interconnect (RK45).
    t_final = 3.0 if (controller, scenario) == ("pid", "large") else 8.0
    fast = sr.run_scenario(controller, scenario, t_final=t_final, method="lsoda")
    ref = sr.run_scenario(controller, scenario, t_final=t_final, method="interconnect")
    assert fast.t.shape == ref.t.shape
    assert np.abs(fast.e - ref.e).max() <= 1e-5
    frame = ref.response.to_pandas()
    assert {"Tc1", "Tc2", "Td1", "q1"} <= set(frame.columns)


def test_scenarios_initial_errors():
    res = sr.run_scenario("pid", "large", t_final=0.5)
    assert res.e[:, 0] == pytest.approx([-1.5, 2.5]) and res.edot[:, 0] == pytest.approx([1.0, 0.0])
    res = sr.run_scenario("pid", "small", t_final=0.5)
    assert res.e[:, 0] == pytest.approx([0.05, 0.05]) and res.edot[:, 0] == pytest.approx([0.0, 0.0])
    assert res.e.shape == (2, 501) and res.torque.shape == (2, 501) and res.payload.shape == (501,)


@pytest.fixture(scope="module")
def chattering():
    return {c: sr.run_scenario(c, "small", t_final=9.0).metrics().chattering_index for c in sr.CONTROLLERS}


def test_sign_variant_chatters_most(chattering):
    assert chattering["smc-sign"] > 10 * chattering["smc"]
    assert chattering["smc-sign"] > 10 * chattering["pid"]


def test_destabilizing_controller_is_reported():
    ctrl = sr.pid_controller(-K)  # the wrong sign: positive feedback
    res = sr.simulate(ctrl, "small", t_final=5.0, method="lsoda")
    assert res.diverged and not res.success and "diverged" in res.message
    res = sr.simulate(ctrl, "small", t_final=5.0)
    assert res.diverged


def test_torque_limit_saturates():
    res = sr.run_scenario("pid", "large", t_final=1.0, torque_limit=20.0)
    assert np.abs(res.torque).max() <= 20.0 + 1e-12


def test_square_wave_switching_times():
    wave = sr.paper_disturbance()
    times = wave.switching_times(0.0, 1.0)
    assert times == pytest.approx(np.pi / 10 * np.arange(1, 4))
    assert wave(0.05).tolist() == [5.0, 5.0] and wave(0.4).tolist() == [-5.0, -5.0]


def test_metrics_known_answers():
    t = np.linspace(0, 10, 10001)
    e = np.vstack([0.1 * np.sin(t), np.where(t >= 6, 0.02, 1.0)])
    tc = np.vstack([np.where(t < 6, 10.0, 2.0), 3.0 * np.ones_like(t)])
    m = sr.tracking_metrics(t, e, tc)
    after = t >= 6
    assert m.max_abs_error == pytest.approx(0.1)
    expected_rms = np.sqrt(np.trapezoid(0.5 * (e[0, after] ** 2 + 0.02**2), t[after]) / 4)
    assert m.rms_error == pytest.approx(expected_rms)
    assert m.peak_torque == 10.0 and m.max_abs_torque == 3.0
    assert m.chattering_index == pytest.approx(0.0)
    assert m.control_energy == pytest.approx(6 * 109 + 4 * 13, rel=1e-3)
    square = np.vstack([np.sign(np.sin(2 * np.pi * t)), np.zeros_like(t)])
    # a ±1 square wave of period 1 s varies by 2 twice a second
    assert sr.tracking_metrics(t, e, square).chattering_index == pytest.approx(4.0, rel=0.01)


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: sr.simulate("lqr"), ValueError, "`controller` must be one of"),
        (lambda: sr.simulate("pid", "medium"), ValueError, "`scenario` must be one of"),
        (lambda: sr.simulate("pid", t_final=0), ValueError, "`t_final` must be > 0"),
        (lambda: sr.simulate("pid", x0=[np.nan, 0, 0, 0, 0, 0]), ValueError, "`x0` must contain only finite"),
        (lambda: sr.simulate("pid", x0=[0, 0, 0]), ValueError, "`x0` must have shape"),
        (lambda: sr.pid_controller(K, torque_limit=0), ValueError, "`torque_limit` must be > 0"),
        (lambda: sr.sliding_mode_controller(torque_limit=-5), ValueError, "`torque_limit` must be > 0"),
        (lambda: sr.sliding_mode_controller(variant="tanh"), ValueError, "`variant` must be one of"),
        (lambda: sr.SlidingModeGains(boundary=0), ValueError, r"`boundary \[rad/s\]` must be > 0"),
        (lambda: sr.pid_controller(np.ones((2, 5))), ValueError, "`K` must have shape"),
        (lambda: sr.tracking_metrics([0, 1], [[0, 0], [0, 0]], [[0, 0], [0, 0]]), ValueError, "at least 2 samples"),
        (lambda: sr.SquareWave(period=0), ValueError, r"`period \[s\]` must be > 0"),
    ],
    ids=[
        "controller",
        "scenario",
        "t-final",
        "x0-nan",
        "x0-shape",
        "pid-limit",
        "smc-limit",
        "variant",
        "boundary",
        "K-shape",
        "metrics-short",
        "wave-period",
    ],
)
def test_bad_simulation_input(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


# ------------------------------------------------------------------ engine registry


@pytest.fixture(scope="module")
def by_engine():
    return {name: sr.simulate("pid", "small", t_final=1.0, method=name) for name in sr.ENGINES}


def test_registry_names_algorithms():
    assert set(sr.ENGINES) == {"lsoda", "interconnect", "rk4", "compiled"}
    assert DEFAULT_ENGINE == "lsoda" and sr.ENGINES[SAMPLED_ENGINE].sampled


@pytest.mark.parametrize(("method", "tolerance"), [("interconnect", 1e-5), ("rk4", 1e-4)], ids=["interconnect", "rk4"])
def test_every_engine_returns_the_same_result_type(by_engine, method, tolerance):
    # rk4 holds the square wave at each 1-ms step's midpoint, so it is first order at the 13
    # switching instants of this run: 2.4e-5 rad measured against LSODA.
    lsoda, other = by_engine["lsoda"], by_engine[method]
    assert type(other) is sr.SimulationResult and other.method == method and lsoda.method == "lsoda"
    assert other.t.shape == lsoda.t.shape and other.response.states.shape == lsoda.response.states.shape
    assert list(other.response.output_labels) == list(lsoda.response.output_labels)
    assert np.abs(other.e - lsoda.e).max() <= tolerance


def test_default_engine_follows_the_controller():
    assert sr.simulate("pid", "small", t_final=0.2).method == "lsoda"
    sampled = sr.simulate("smc-sign", "small", t_final=0.2)
    assert sampled.method == "rk4" and sr.CONTROLLERS["smc-sign"].Ts == 1e-3
    assert np.allclose(np.diff(sampled.t), 1e-3)


def test_a_sampled_controller_needs_a_sampled_engine():
    with pytest.raises(sr.ArgumentValueError, match="`method` must be 'rk4', 'compiled' for a sampled controller"):
        sr.simulate("smc-sign", "small", t_final=0.2, method="lsoda")


def test_method_fast_is_a_deprecated_alias_of_the_default():
    with pytest.warns(DeprecationWarning, match=r"method='fast'\) is deprecated"):
        old = sr.run_scenario("pid", "small", t_final=0.3, method="fast")
    new = sr.run_scenario("pid", "small", t_final=0.3)
    assert old.method == new.method == "lsoda" and np.array_equal(old.e, new.e)


def test_divergence_is_flagged_and_frozen_by_every_engine():
    K = sr.design(sr.paper_model(), 3, 90).K
    for method in sr.ENGINES:
        res = sr.simulate(sr.pid_controller(-K), "small", t_final=3.0, method=method)
        assert res.diverged and not res.success and res.message.startswith("diverged by t =")
        assert res.t[-1] < 3.0


@pytest.mark.parametrize("method", ["lsoda", "interconnect"])
def test_peak_torque_is_the_trajectorys_not_the_samples(method):
    # Small IC: the PID torque peaks near t = 0.5 ms, between the 1-ms samples (15.02 N·m at t = 0).
    res = sr.run_scenario("pid", "small", t_final=0.01, method=method)
    fine = sr.simulate("pid", "small", t_final=0.01, dt=1e-6)  # a 1-µs output grid, independently
    sampled, truth = float(np.abs(res.torque).max()), float(np.abs(fine.torque).max())
    assert sampled == pytest.approx(15.016, abs=1e-3) and truth == pytest.approx(15.214, abs=1e-3)
    assert res.peak_torque == pytest.approx(truth, abs=1e-3)
    assert res.metrics(t_transient=0.0).peak_torque == res.peak_torque


def test_a_sampled_controller_peaks_at_its_samples():
    res = sr.run_scenario("smc-sign", "small", t_final=0.05)
    assert res.peak_torque == float(np.abs(res.torque).max())
