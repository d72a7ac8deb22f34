"""Actuator limits: the invariant-ellipsoid certificate, the synthesis with limits, and plant files.

The DC motor of ``examples/plant-dc-motor.toml`` has a current limit of 2 A; the initial
errors are the box ``|e(0)| <= 0.1 rad`` with ``∫e(0) = 0`` and ``ė(0) = 0`` (a 0.1-rad step
of the reference from rest: the motor has no position stiffness, so the step is the initial
error).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.exceptions import ArgumentTypeError, ArgumentValueError, InputFileError

ROOT = Path(__file__).resolve().parents[1]
MOTOR = ROOT / "examples" / "plant-dc-motor.toml"
#: Half-widths of the initial errors on [∫e, e, ė] (rad·s, rad, rad/s).
X0 = np.array([0.0, 0.1, 0.0])
LIMIT = 2.0  # A


def _boundary(P: np.ndarray, c: float, count: int, seed: int = 0) -> np.ndarray:
    """`count` points on {xᵀPx = c}: x = sqrt(c) P^{-1/2} w/|w|, shape (count, n)."""
    w, V = np.linalg.eigh(P)
    root_inv = (V / np.sqrt(w)) @ V.T
    d = np.random.default_rng(seed).standard_normal((count, P.shape[0]))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return math.sqrt(c) * d @ root_inv


def _random_case(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n, m = 4, 2
    M = rng.standard_normal((n, n))
    P = M @ M.T + 0.3 * np.eye(n)
    K = rng.standard_normal((m, n))
    return K, P, np.array([1.5, 0.7]), np.array([0.2, 0.0, 0.3, 0.1])


# --- the closed form against independent computations --------------------------------


def test_a_hand_example():
    # |x1 + x2| <= 2 on {|x|² <= c}: max is sqrt(2c), so c* = 2; the corner (0.5, 0.5) has V = 0.5, s* = 2
    cert = sr.input_limit_certificate([[1.0, 1.0]], np.eye(2), 2.0, [0.5, 0.5])
    assert cert.certified and cert.verdict == "certified" and cert.binding_input == 0
    assert cert.level == pytest.approx(2.0) and cert.scale == pytest.approx(2.0)
    assert cert.peaks == pytest.approx([1.0])
    assert cert.n_vertices == 4 and math.isnan(cert.decay_rate) and not cert.lyapunov_checked
    assert "assuming V" in cert.message


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_peak_on_the_ellipsoid_matches_sampling(seed):
    K, P, u_max, box = _random_case(seed)
    cert = sr.input_limit_certificate(K, P, u_max, box)
    x = _boundary(P, cert.level, 200_000, seed)
    sampled = np.abs(x @ K.T).max(axis=0)
    bound = math.sqrt(cert.level) * cert.unit_level_peaks
    assert np.all(sampled <= bound * (1 + 1e-12))
    assert np.all(sampled >= 0.99 * bound)  # the sampling comes close to the closed form
    # at c*, the binding input reaches its limit; the others stay within theirs
    assert bound[cert.binding_input] == pytest.approx(u_max[cert.binding_input], rel=1e-12)
    assert np.all(bound <= u_max * (1 + 1e-12))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_peak_and_the_level_match_an_optimizer_and_a_bisection(seed):
    from scipy.optimize import minimize

    K, P, u_max, box = _random_case(seed)
    cert = sr.input_limit_certificate(K, P, u_max, box)
    n = P.shape[0]

    def max_input(i: int, c: float) -> float:
        # maximize K_i x on {xᵀPx <= c} with SLSQP from several starts
        best = 0.0
        for start in np.random.default_rng(i).standard_normal((4, n)):
            res = minimize(lambda x: -K[i] @ x, 0.1 * start, jac=lambda x: -K[i], method="SLSQP",
                           constraints=[{"type": "ineq", "fun": lambda x: c - x @ P @ x, "jac": lambda x: -2 * P @ x}],
                           options={"ftol": 1e-14, "maxiter": 500})
            if res.success and res.x @ P @ res.x <= c * (1 + 1e-9):
                best = max(best, -res.fun)
        return best

    for i in range(K.shape[0]):
        assert max_input(i, cert.level) == pytest.approx(math.sqrt(cert.level) * cert.unit_level_peaks[i], rel=1e-6)

    def within(c: float) -> bool:
        return all(max_input(i, c) <= u_max[i] for i in range(K.shape[0]))

    lo, hi = sr.bisect(within, 0.0, 10 * cert.level, 1e-6)
    assert lo <= cert.level * (1 + 1e-5) and hi >= cert.level * (1 - 1e-5)


def test_the_scale_puts_the_box_on_the_level():
    K, P, u_max, box = _random_case(3)
    cert = sr.input_limit_certificate(K, P, u_max, box)
    # max of xᵀPx over the box, on a dense grid of the box (not only its corners)
    axes = [np.linspace(-h, h, 9) if h else np.zeros(1) for h in box]
    grid = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    worst = np.einsum("ki,ij,kj->k", grid, P, grid).max()
    assert worst == pytest.approx(cert.initial_level, rel=1e-12)  # attained at a corner
    assert cert.scale == pytest.approx(math.sqrt(cert.level / worst), rel=1e-12)
    assert cert.certified == (cert.scale >= 1)
    assert np.all(cert.peaks == pytest.approx(cert.unit_level_peaks * math.sqrt(worst), rel=1e-12))
    # points given instead of a box: the same answer on its corners
    again = sr.input_limit_certificate(K, P, u_max, sr.initial_error_vertices(box, 4))
    assert again.scale == pytest.approx(cert.scale, rel=1e-12)


def test_unlimited_inputs_zero_rows_and_zero_sets():
    K = np.array([[1.0, 0.0], [0.0, 0.0]])
    cert = sr.input_limit_certificate(K, np.eye(2), [np.inf, 1.0], [1.0, 1.0])
    assert cert.binding_input is None and math.isinf(cert.level) and cert.certified
    cert = sr.input_limit_certificate(K, np.eye(2), [1.0, 1.0], [0.0, 0.0])
    assert math.isinf(cert.scale) and cert.certified and cert.peaks == pytest.approx([0.0, 0.0])


def test_a_lyapunov_function_is_checked_when_the_loops_are_given():
    K, P = np.array([[1.0, 1.0]]), np.eye(2)
    stable = np.array([[[-1.0, 0.0], [0.0, -2.0]]])
    unstable = np.array([[[0.5, 0.0], [0.0, -2.0]]])
    ok = sr.input_limit_certificate(K, P, 2.0, [0.5, 0.5], closed_loops=stable)
    assert ok.certified and ok.decay_rate == pytest.approx(1.0) and ok.lyapunov_checked
    bad = sr.input_limit_certificate(K, P, 2.0, [0.5, 0.5], closed_loops=unstable)
    assert not bad.certified and bad.status == "not a Lyapunov function" and "does not decrease" in bad.message
    indefinite = sr.input_limit_certificate(K, np.diag([1.0, -1.0]), 2.0, [0.5, 0.5])
    assert not indefinite.certified and indefinite.status == "P not positive definite"


def test_peak_inputs():
    u = np.array([[0.5, -2.0, 1.0], [0.1, 0.2, -0.3]])
    assert sr.peak_inputs(u).tolist() == [2.0, 0.3]
    assert sr.peak_inputs(np.array([[1.0, np.nan]])).tolist() == [math.inf]


# --- bad inputs ---------------------------------------------------------------------


@pytest.mark.parametrize(("kwargs", "argument"), [
    ({"u_max": -1.0}, "u_max"),
    ({"u_max": [1.0, 2.0]}, "u_max"),
    ({"initial_errors": [0.1, -0.1, 0.0]}, "initial_errors"),
    ({"initial_errors": [0.1, 0.1]}, "initial_errors"),
    ({"P": np.eye(3) + np.triu(np.ones((3, 3)))}, "P"),  # not symmetric
])
def test_bad_arguments_are_named(kwargs, argument):
    args = {"K": np.ones((1, 3)), "P": np.eye(3), "u_max": 1.0, "initial_errors": [0.0, 0.1, 0.0], **kwargs}
    with pytest.raises(ArgumentValueError) as err:
        sr.input_limit_certificate(**args)
    assert err.value.argument == argument


def test_a_signal_refuses_a_bad_limit():
    with pytest.raises(ArgumentValueError, match=r"`current.limit` must be a finite number > 0 in A, found -1"):
        sr.Signal("current", "A", limit=-1)
    with pytest.raises(ArgumentTypeError, match=r"`current.limit`"):
        sr.Signal("current", "A", limit="2")  # type: ignore[arg-type]
    assert sr.Signal("current", "A").limit is None


@pytest.mark.parametrize(("text", "expected"), [
    ("limit = -1", r"field `inputs\[0\].limit` must be > 0 A .*found -1 A"),
    ('limit = "2 A"', r"field `inputs\[0\].limit` must be a finite number in A, found '2 A'"),
    ("limit = 0", r"field `inputs\[0\].limit` must be > 0 A .*found 0 A"),
])
def test_a_plant_file_with_a_bad_limit_names_file_field_and_unit(tmp_path, text, expected):
    path = tmp_path / "motor.toml"
    path.write_text(MOTOR.read_text().replace("limit = 2.0", text))
    with pytest.raises(InputFileError, match=expected) as err:
        sr.load_plant(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_an_output_has_no_limit(tmp_path):
    path = tmp_path / "motor.toml"
    path.write_text(MOTOR.read_text().replace('unit = "rad"', 'unit = "rad"\nlimit = 1.0'))
    with pytest.raises(InputFileError, match=r"unknown field `outputs\[0\].limit`; valid: name, unit"):
        sr.load_plant(path)


def test_the_motor_file_states_its_current_limit():
    motor = sr.load_plant(MOTOR)
    assert motor.inputs[0].limit == LIMIT and motor.input_limits.tolist() == [LIMIT]
    assert sr.load_model(ROOT / "examples" / "plant-dc-motor-elements.toml") is not None
    plant = sr.UncertainPlant.from_expressions(list(motor.parameters), [[0, 1], [0, "-b/J"]], [[0], ["kt/J"]])
    assert plant.input_limits is None


# --- the DC motor -------------------------------------------------------------------


def _box_loops(motor: sr.UncertainPlant, K: np.ndarray) -> np.ndarray:
    A, B = motor.interval_model().vertex_matrices()
    return A - B @ K


def test_the_motor_design_needs_more_than_its_limit():
    motor = sr.load_plant(MOTOR)
    d = sr.design(motor, rho=1, eta=10)
    assert sr.vertex_certificate(motor.interval_model(), d).certified  # its Riccati P is the certificate
    cert = sr.input_limit_certificate(d.K, d.P, motor.input_limits, X0, closed_loops=_box_loops(motor, d.K),
                                      inputs=motor.inputs)
    assert cert.lyapunov_checked and cert.decay_rate > 0
    assert not cert.certified and cert.scale < 1 and cert.peaks[0] > LIMIT
    assert cert.peaks[0] == pytest.approx(29.5155, rel=1e-4) and cert.scale == pytest.approx(0.067761, rel=1e-4)
    assert "up to s* = 0.06776 × the given set" in cert.message and "29.52 A > limit 2 A" in cert.message
    assert cert.to_pandas()["peak current [A]"] == pytest.approx(cert.peaks[0])
    # the bound holds on a simulated run (it is a bound, larger than what this run needs)
    J = sr.parameter_profile(motor, "J", "sinusoid")
    run = sr.simulate_plant(motor, d.K, profiles={"J": J}, reference=(0.0, 0.0), x0=[-0.1, 0.0], t_final=3.0)
    peak = sr.peak_inputs(run)
    assert peak[0] == pytest.approx(run.peak_input) and peak[0] <= cert.peaks[0]


@pytest.fixture(scope="module")
def limited():
    motor = sr.load_plant(MOTOR)
    return motor, sr.synthesize(motor, input_limits=motor.input_limits, initial_errors=X0)


def _rk4_peaks(motor, K, P, x0, profile, t_final, dt):
    """Vectorized RK4 of ẋ = (A(J(t)) − B(J(t))K)x for every column of x0 (n, N).

    Returns each run's peak max_t max_i |u_i| (N,), the largest ratio V(t + dt)/V(t) over runs and
    steps, and the largest V at the end.
    """
    x = np.array(x0, dtype=float)
    peak = np.abs(K @ x).max(axis=0)
    V = np.einsum("in,ij,jn->n", x, P, x)
    worst_rise = -np.inf

    def loop(t):
        A, B = motor.frozen({"J": profile(t)})
        return A - B @ K

    t = 0.0
    for _ in range(int(round(t_final / dt))):
        A1, A2, A3 = loop(t), loop(t + dt / 2), loop(t + dt)
        k1 = A1 @ x
        k2 = A2 @ (x + dt / 2 * k1)
        k3 = A2 @ (x + dt / 2 * k2)
        k4 = A3 @ (x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += dt
        peak = np.maximum(peak, np.abs(K @ x).max(axis=0))
        V_next = np.einsum("in,ij,jn->n", x, P, x)
        worst_rise = max(worst_rise, float((V_next / V).max()))
        V = V_next
    return peak, worst_rise, float(V.max())


@pytest.mark.lmi
def test_the_synthesis_with_the_limit_keeps_the_current_within_it(limited):
    motor, syn = limited
    assert syn.certified and syn.input_limit is not None and syn.input_limit.certified
    assert syn.input_limits.tolist() == [LIMIT]
    cert = syn.input_limit
    assert cert.scale >= 1 and cert.peaks[0] <= LIMIT and cert.level == pytest.approx(1.0, rel=1e-3)
    assert "inputs within their limits" in syn.message
    # numpy again, independently: P on the plant's own frozen plants (a finer grid) and on the box corners
    fine = motor.samples(motor.fine_points()).closed_loops(syn.K)
    for loops in (fine, _box_loops(motor, syn.K)):
        again = sr.input_limit_certificate(syn.K, syn.P, LIMIT, X0, closed_loops=loops)
        assert again.certified and again.decay_rate > 0
    # 1000 initial states on the boundary of the certified set E(c*), the two where |u(0)| is the limit
    # among them; J varying within its range and rate bound (and held at each end)
    g = syn.K[0] @ np.linalg.solve(syn.P, syn.K[0])
    extreme = math.sqrt(cert.level / g) * np.linalg.solve(syn.P, syn.K[0])
    x0 = np.vstack([_boundary(syn.P, cert.level, 998, seed=1), extreme, -extreme]).T
    assert x0.shape == (3, 1000)
    assert np.einsum("in,ij,jn->n", x0, syn.P, x0) == pytest.approx(np.full(1000, cert.level), rel=1e-12)
    lo, hi = motor.parameter("J").range
    fastest = np.abs(np.linalg.eigvals(_box_loops(motor, syn.K))).max()
    dt = 0.1 / fastest
    profiles = {"lower": lambda t: lo, "upper": lambda t: hi,
                "sinusoid": sr.parameter_profile(motor, "J", "sinusoid"),
                "random-walk": sr.parameter_profile(motor, "J", "random-walk", t_final=1.0, seed=3)}
    peaks = {}
    for name, profile in profiles.items():
        peak, rise, V_end = _rk4_peaks(motor, syn.K, syn.P, x0, profile, 1.0, dt)
        peaks[name] = float(peak.max())
        assert peak.max() <= LIMIT * (1 + 1e-9), name
        assert rise <= 1.0, name  # V = xᵀPx never increases along any of the 1000 runs
        assert V_end < 1e-6 * cert.level, name
    assert max(peaks.values()) == pytest.approx(LIMIT, rel=1e-9)  # the extreme states start at the limit
    # the package's own simulator (integral state 0) agrees: the box's corners e(0) = ±0.1 rad
    for e0 in (0.1, -0.1):
        run = sr.simulate_plant(motor, syn.K, profiles={"J": profiles["sinusoid"]}, reference=(0.0, 0.0),
                                x0=[-e0, 0.0], t_final=1.0, n_points=4001)
        corner = np.array([[0.0], [e0], [0.0]])
        mine, _, _ = _rk4_peaks(motor, syn.K, syn.P, corner, profiles["sinusoid"], 1.0, dt)
        assert sr.peak_inputs(run)[0] <= LIMIT and sr.peak_inputs(run)[0] == pytest.approx(mine[0], rel=1e-3)


@pytest.mark.lmi
def test_an_impossible_decay_within_the_limit_is_reported_infeasible(limited):
    motor, syn = limited
    too_fast = sr.synthesize(motor, input_limits=LIMIT, initial_errors=X0, decay=10 * syn.decay)
    assert not too_fast.certified and too_fast.status == "infeasible" and too_fast.K is None
    assert "within its limit" in too_fast.message


@pytest.mark.lmi
def test_the_limits_need_initial_errors_and_leave_the_default_alone():
    motor = sr.load_plant(MOTOR)
    with pytest.raises(ArgumentValueError) as err:
        sr.synthesize(motor, input_limits=LIMIT)
    assert err.value.argument == "initial_errors"
    with pytest.raises(ArgumentValueError) as err:
        sr.synthesize(motor, input_limits=-2.0, initial_errors=X0)
    assert err.value.argument == "input_limits"
    with pytest.raises(ArgumentValueError) as err:
        sr.synthesize(motor, input_limits=LIMIT, initial_errors=[0.0, 0.0, 0.0])
    assert err.value.argument == "initial_errors"
    plain = sr.synthesize(motor, decay=1.0)
    assert plain.input_limits is None and plain.input_limit is None and plain.certified
