"""worst_loop_margins: each input's worst disk margin and delay margin over an uncertain set's frozen plants.

Every number is checked against something built here independently of the module: the loop
``L_i`` made with ``control.ss`` and ``control.feedback`` (the other inputs' loops closed),
python-control's ``disk_margins`` and ``stability_margins``, hand-derived margins of simple
loops, the characteristic matrix of the delayed loop, a chain of all-pass sections for the
delay, and a fixed-step simulation with an exact delay of an integer number of steps.
"""

from __future__ import annotations

from pathlib import Path

import control as ct
import numpy as np
import pytest

import scara_robust as sr

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def loop_at_input(A, B, K, i):
    """``L_i`` from python-control alone: u -> Kx, every loop but i closed by ``u = v − y``, the (i, i) entry."""
    m = B.shape[1]
    P = ct.ss(A, B, K, np.zeros((m, m)))
    others = np.diag([0.0 if j == i else 1.0 for j in range(m)])
    return ct.feedback(P, others)[i, i]


def frozen_plant(system, result, index):
    """The design-form (A, B) of frozen plant `index`, from the result's parameter values."""
    return system.frozen(dict(zip(result.names, result.values[index])))


def simulate_delay(A0, A1, tau, x0, t_final, per_delay=50):
    """``ẋ = A0 x(t) + A1 x(t − τ)``, ``x = x0`` for t <= 0: RK4 with the delay an integer number of steps.

    The delayed state at a half step is the cubic Hermite interpolant of the stored states
    and slopes (local error O(h⁴)). Returns the times and the states.
    """
    h = tau / per_delay
    n = A0.shape[0]
    steps = int(np.ceil(t_final / h))
    X, dX = np.empty((steps + 1, n)), np.empty((steps + 1, n))
    flat = np.zeros(n)

    def past(j):
        return (X[j], dX[j]) if j >= 0 else (x0, flat)

    X[0] = x0
    dX[0] = (A0 + A1) @ x0
    for k in range(steps):
        (y0, s0), (y1, s1) = past(k - per_delay), past(k - per_delay + 1)
        ym = 0.5 * (y0 + y1) + h / 8 * (s0 - s1)
        x = X[k]
        k1 = A0 @ x + A1 @ y0
        k2 = A0 @ (x + h / 2 * k1) + A1 @ ym
        k3 = A0 @ (x + h / 2 * k2) + A1 @ ym
        k4 = A0 @ (x + h * k3) + A1 @ y1
        X[k + 1] = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        dX[k + 1] = A0 @ X[k + 1] + A1 @ past(k + 1 - per_delay)[0]
    return np.arange(steps + 1) * h, X


def delayed_loop(A, B, K, i):
    """``(A0, A1)`` of the loop with input i delayed: ``u_i = −k_i x(t − τ)``, the other inputs undelayed."""
    b, k = B[:, i:i + 1], K[i:i + 1]
    return A - B @ K + b @ k, -b @ k


def growth(A, B, K, i, tau, omega_c, factor):
    """max ‖x‖ over periods 25-30 of the crossover over max ‖x‖ over periods 10-15, delay `factor`·τ.

    The run starts on the delayed loop's mode at jω_c (at τ), so the ratio shows that mode.
    """
    A0, A1 = delayed_loop(A, B, K, i)
    values, vectors = np.linalg.eig(A0 + A1 * np.exp(-1j * omega_c * tau))
    v = vectors[:, np.argmin(np.abs(values - 1j * omega_c))].real
    period = 2 * np.pi / omega_c
    t, X = simulate_delay(A0, A1, factor * tau, v / np.linalg.norm(v), 30 * period)
    norm = np.linalg.norm(X, axis=1)
    return norm[t >= 25 * period].max() / norm[(t >= 10 * period) & (t < 15 * period)].max()


def allpass_delay(tau, sections=60):
    """``((1 − sτ/2N)/(1 + sτ/2N))^N``: unit gain, phase within (ωτ)³/(12N²) rad of e^{−jωτ}."""
    a = tau / (2 * sections)
    section = ct.ss([[-1 / a]], [[1.0]], [[2 / a]], [[-1.0]])
    out = section
    for _ in range(sections - 1):
        out = ct.series(out, section)
    return out


# --- fixtures --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def motor():
    plant = sr.load_plant(EXAMPLES / "plant-dc-motor.toml")
    K = sr.design(plant, rho=1, eta=10).K
    return plant, K, sr.worst_loop_margins(plant, K)


@pytest.fixture(scope="module")
def scara():
    """The README's design (ρ, η) = (3, 90) on the SCARA with the paper's payload, on its default grid."""
    robot = sr.scara_uncertain_plant(bounds="paper")
    K = sr.design(robot, *sr.PAPER_DESIGN_POINT).K
    return robot, K, sr.worst_loop_margins(robot, K, points={"t_ref": 721, "m_p": 21})


# --- conventions ---------------------------------------------------------------------------------


def test_the_loop_is_negative_feedback_with_the_closed_loop_poles(motor):
    plant, K, _ = motor
    A, B = plant.frozen()
    L = loop_at_input(A, B, K, 0)
    closed = np.sort_complex(ct.poles(ct.feedback(L, 1)))  # 1 + L = 0
    assert np.allclose(closed, np.sort_complex(np.linalg.eigvals(A - B @ K)), rtol=1e-8)
    assert np.linalg.eigvals(A - B @ K).real.max() < 0


def test_an_integrator_loop_by_hand():
    """L(s) = k/s: crossover at k with 90° of phase, τ = π/(2k); |S − ½| = ½ at every ω, so α = 2."""
    k = 2.0
    res = sr.worst_loop_margins(sr.PolytopicModel([[[0.0]]], [[[1.0]]]), [[k]])
    assert res.delay_margin[0] == pytest.approx(np.pi / (2 * k), rel=1e-12)
    assert res.delay_frequency[0] == pytest.approx(k, rel=1e-12)
    assert res.disk_margin[0] == pytest.approx(2.0, rel=1e-9) and res.phase_margin[0] == pytest.approx(90.0)
    assert res.certified and res.inputs == ("u0 [1]",)


@pytest.mark.parametrize(("a", "k"), [(2.0, 5.0), (0.5, 30.0)])
def test_a_second_order_loop_by_hand(a, k):
    """L(s) = k/(s(s + a)): ω_c² = (−a² + √(a⁴ + 4k²))/2, φ = π/2 − atan(ω_c/a), τ = φ/ω_c."""
    loop = sr.PolytopicModel([[[0.0, 1.0], [0.0, -a]]], [[[0.0], [1.0]]])
    res = sr.worst_loop_margins(loop, [[k, 0.0]])
    w = np.sqrt((-a**2 + np.sqrt(a**4 + 4 * k**2)) / 2)
    assert res.delay_frequency[0] == pytest.approx(w, rel=1e-12)
    assert res.delay_margin[0] == pytest.approx((np.pi / 2 - np.arctan(w / a)) / w, rel=1e-12)
    L = ct.tf([k], [1, a, 0])
    pm = ct.stability_margins(L)[1]
    assert res.delay_margin[0] == pytest.approx(np.radians(pm) / w, rel=1e-8)
    coarse = ct.disk_margins(L, np.logspace(-3, 3, 601))[0]
    peak = res.disk_frequency[0]
    dense = ct.disk_margins(L, np.linspace(0.99 * peak, 1.01 * peak, 4001))[0]  # steps of 5e-6·ω around the peak
    assert res.disk_margin[0] == pytest.approx(dense, rel=1e-9)  # the refined peak, not the grid's
    assert res.disk_margin[0] <= min(dense, coarse) * (1 + 1e-12)


# --- the DC motor ---------------------------------------------------------------------------------


def test_the_motors_worst_disk_margin_is_python_controls(motor):
    plant, K, res = motor
    assert res.n_plants == 17 and res.names == ("J", "b", "kt") and "fine grid" in res.frozen_set
    worst = int(res.disk_worst[0])
    L = loop_at_input(*frozen_plant(plant, res, worst), K, 0)
    dm, dgm, dpm = ct.disk_margins(L, np.union1d(res.omega, [res.disk_frequency[0]]))
    assert res.disk_margin[0] == pytest.approx(dm, rel=1e-9)
    assert res.gain_margin[0] == pytest.approx(dgm, rel=1e-9) and res.phase_margin[0] == pytest.approx(dpm, rel=1e-9)
    alpha = res.disk_margin[0]
    assert res.gain_range[0] == pytest.approx([(1 - alpha / 2) / (1 + alpha / 2), (1 + alpha / 2) / (1 - alpha / 2)])
    assert 20 * np.log10(res.gain_range[0, 1]) == pytest.approx(res.gain_margin[0])
    for index in range(res.n_plants):  # no frozen plant has a smaller disk margin, even on the bare grid
        other = ct.disk_margins(loop_at_input(*frozen_plant(plant, res, index), K, 0), res.omega)[0]
        assert other >= res.disk_margin[0] * (1 - 1e-12)
        assert other >= res.plant_disk_margins[index, 0] * (1 - 1e-12)  # the refined peak is below the grid's


def test_the_motors_delay_margin_against_stability_margins_and_a_simulation(motor):
    plant, K, res = motor
    worst = int(res.delay_worst[0])
    tau, w = res.delay_margin[0], res.delay_frequency[0]
    assert tau == pytest.approx(res.plant_delay_margins[:, 0].min()) and np.all(res.plant_delay_margins > 0)
    A, B = frozen_plant(plant, res, worst)
    L = loop_at_input(A, B, K, 0)
    _, pm, _, _, wgc, _ = ct.stability_margins(L, returnall=True)
    phases = np.mod(np.radians(np.asarray(pm)), 2 * np.pi)
    assert tau == pytest.approx(float(np.min(phases / np.asarray(wgc))), rel=1e-7)
    # the delayed loop's characteristic matrix is singular at jω_c: a root sits on the axis at τ
    A0, A1 = delayed_loop(A, B, K, 0)
    assert np.abs(np.linalg.eigvals(A0 + A1 * np.exp(-1j * w * tau)) - 1j * w).min() < 1e-9 * w
    assert growth(A, B, K, 0, tau, w, 0.9) < 0.2
    assert growth(A, B, K, 0, tau, w, 1.1) > 5.0


def test_the_motors_table_and_message(motor):
    _, _, res = motor
    table = res.to_pandas()
    assert list(table["input"]) == ["current [A]"] and len(table) == 1
    row = table.iloc[0]
    assert row["delay_margin [s]"] == res.delay_margin[0] and row["disk_worst_at"].startswith("J = ")
    assert res.verdict == res.status == "frozen loops stable" and res.certified is True
    assert "delay margin" in res.message and "'current'" in res.message and "17 frozen plants" in res.message
    assert res.disk_worst_values.shape == (1, 3) and res.delay_worst_values[0, 0] == pytest.approx(2e-4)


# --- the SCARA ---------------------------------------------------------------------------------------


def test_the_scaras_worst_disk_margins_are_python_controls(scara):
    robot, K, res = scara
    assert res.n_plants == 721 * 21 and res.inputs == ("T1 [N·m]", "T2 [N·m]") and res.certified
    rng = np.random.default_rng(1)
    for i in range(2):
        worst = int(res.disk_worst[i])
        L = loop_at_input(*frozen_plant(robot, res, worst), K, i)
        dm, dgm, dpm = ct.disk_margins(L, np.union1d(res.omega, [res.disk_frequency[i]]))
        assert res.disk_margin[i] == pytest.approx(dm, rel=1e-9)
        assert res.gain_margin[i] == pytest.approx(dgm, rel=1e-9)
        assert res.phase_margin[i] == pytest.approx(dpm, rel=1e-9)
        assert res.disk_margin[i] <= res.plant_disk_margins[:, i].min() * (1 + 1e-9)
        for index in [*rng.choice(res.n_plants, 4, replace=False), int(res.delay_worst[i]), int(res.disk_worst[1 - i])]:
            other = ct.disk_margins(loop_at_input(*frozen_plant(robot, res, index), K, i), res.omega)[0]
            assert other >= res.disk_margin[i] * (1 - 1e-12)


@pytest.mark.parametrize("i", [0, 1], ids=["T1", "T2"])
def test_the_scaras_delay_margins_against_a_simulation(scara, i):
    robot, K, res = scara
    tau, w = res.delay_margin[i], res.delay_frequency[i]
    assert 0 < tau < np.inf and tau == pytest.approx(res.plant_delay_margins[:, i].min())
    A, B = frozen_plant(robot, res, int(res.delay_worst[i]))
    A0, A1 = delayed_loop(A, B, K, i)
    assert np.abs(np.linalg.eigvals(A0 + A1 * np.exp(-1j * w * tau)) - 1j * w).min() < 1e-9 * w
    assert growth(A, B, K, i, tau, w, 0.9) < 0.2
    assert growth(A, B, K, i, tau, w, 1.1) > 5.0
    # every mode, the slow ones too: the loop with a chain of all-pass sections for the delay
    L = loop_at_input(A, B, K, i)
    for factor, stable in ((0.9, True), (1.1, False)):
        poles = ct.poles(ct.feedback(ct.series(allpass_delay(factor * tau), L), 1))
        assert (poles.real.max() < 0) == stable


def test_an_unstable_frozen_corner_has_zero_margins():
    """The published box reverses the control direction at some corners (README): its paper gain fails there."""
    box = sr.paper_model()
    res = sr.worst_loop_margins(box, sr.design(box, *sr.PAPER_DESIGN_POINT))
    assert res.n_plants == 1024 and "corners of the box" in res.frozen_set and len(res.names) == 10
    assert not res.certified and res.verdict == "frozen loop unstable"
    assert np.all(res.disk_margin == 0) and np.all(res.delay_margin == 0)
    worst = int(res.delay_worst[0])
    assert res.max_real_pole[worst] == res.max_real_pole.max() > 0 and "is unstable" in res.message
    unstable = res.max_real_pole > 0
    assert np.all(res.plant_delay_margins[unstable] == 0) and np.all(res.plant_delay_margins[~unstable] > 0)


# --- bad input -------------------------------------------------------------------------------------


def test_bad_input_names_the_argument(motor):
    plant, K, _ = motor
    with pytest.raises(sr.ArgumentValueError, match=r"`K` must have shape \(1, 3\), found shape \(2, 6\)"):
        sr.worst_loop_margins(plant, np.zeros((2, 6)))
    with pytest.raises(sr.ArgumentTypeError, match="`K` must be a gain matrix"):
        sr.worst_loop_margins(plant, None)
    with pytest.raises(sr.ArgumentValueError, match="`omega` must hold >= 2 frequencies > 0"):
        sr.worst_loop_margins(plant, K, omega=[-1.0, 1.0])
    with pytest.raises(sr.ArgumentValueError, match="`points` applies to a plant with parameters"):
        sr.worst_loop_margins(sr.paper_model(), np.zeros((2, 6)), points={"t_ref": 3})
    with pytest.raises(sr.ArgumentTypeError, match="`system` must be an UncertainPlant"):
        sr.worst_loop_margins(np.eye(3), K)
