import control as ct
import numpy as np
import pytest

import scara_robust as sr
from scara_robust.model.robot import forward_dynamics_scalar, inertia_coefficients

P = sr.ScaraParams()
RNG = np.random.default_rng(1)
STATES = [(RNG.uniform(-np.pi, np.pi, 2), RNG.uniform(-3, 3, 2), RNG.uniform(0, 2.07)) for _ in range(6)]


@pytest.mark.parametrize("q, qd, mp", STATES, ids=[f"state{k}" for k in range(len(STATES))])
def test_mass_matrix_symmetric_positive_definite(q, qd, mp):
    M = sr.mass_matrix(P, q, mp)
    assert np.allclose(M, M.T, rtol=1e-14, atol=0)
    assert np.all(np.linalg.eigvalsh(M) > 0)


@pytest.mark.parametrize("q, qd, mp", STATES, ids=[f"state{k}" for k in range(len(STATES))])
def test_forward_dynamics_matches_paper_closed_form(q, qd, mp):
    """The paper's rewritten Eq. (1) (a1, a2, a3 form) against M⁻¹(T - C)."""
    T = np.array([1.3, -0.7])
    a1, a2, a3 = inertia_coefficients(P, mp)
    s2, c2 = np.sin(q[1]), np.cos(q[1])
    den = a3**2 * (1 + np.cos(2 * q[1])) - 2 * a1 * a2
    w1, w2 = qd
    qdd1 = (
        -(
            2 * a2 * a3 * s2 * (w1 + w2) ** 2
            + a3**2 * w1**2 * np.sin(2 * q[1])
            + 2 * a2 * T[0]
            - 2 * (a2 + a3 * c2) * T[1]
        )
        / den
    )
    qdd2 = (
        2 * a2 * a3 * s2 * (w1 + w2) ** 2
        + a3**2 * np.sin(2 * q[1]) * (2 * w1**2 + 2 * w1 * w2 + w2**2)
        + 2 * a1 * a3 * s2 * w1**2
        + 2 * (a2 + a3 * c2) * T[0]
        - 2 * (a1 + a2 + 2 * a3 * c2) * T[1]
    ) / den
    ours = sr.forward_dynamics(P, q, qd, T, mp)
    assert np.allclose(ours, [qdd1, qdd2], rtol=1e-10, atol=1e-12)
    x = np.concatenate([q, qd])
    assert np.allclose(forward_dynamics_scalar(P, x, T[0], T[1], mp), ours, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("mp", [0.0, 1.5], ids=["empty", "loaded"])
def test_kinetic_energy_conserved_without_torque(mp):
    plant = sr.scara_plant(P, sr.ConstantPayload(mp))
    x0 = [0.3, -1.0, 2.0, -1.5]
    t = np.linspace(0, 5, 501)
    resp = ct.input_output_response(
        plant, t, np.zeros((4, t.size)), x0, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12}
    )
    energy = sr.kinetic_energy(P, resp.states[:2].T, resp.states[2:].T, mp)
    assert np.allclose(energy, energy[0], rtol=1e-7)
    assert np.ptp(resp.states[1]) > 0.5  # the arm really moved


@pytest.mark.parametrize("q, qd, mp", STATES[:3], ids=["s0", "s1", "s2"])
def test_error_jacobians_match_central_differences(q, qd, mp):
    a_star, g_bar = sr.error_dynamics_jacobians(P, q, qd, mp)

    def f(e, ed):  # f = r̈ + M⁻¹C at q = r - e (r̈ drops out of the Jacobian)
        qq, ww = q - e, qd - ed
        return np.linalg.solve(sr.mass_matrix(P, qq, mp), sr.coriolis(P, qq, ww, mp))

    num = np.zeros((2, 4))
    for k in range(4):
        step = 1e-6 * max(1.0, abs(np.concatenate([q, qd])[k]))
        d = np.zeros(4)
        d[k] = step
        num[:, k] = (f(d[:2], d[2:]) - f(-d[:2], -d[2:])) / (2 * step)
    assert np.allclose(a_star, num, rtol=1e-6, atol=1e-8)
    assert np.allclose(g_bar, -np.linalg.inv(sr.mass_matrix(P, q, mp)), rtol=1e-12)


def test_plant_signal_names():
    plant = sr.scara_plant()
    assert plant.input_labels == ["Tc1", "Tc2", "Td1", "Td2"]
    assert plant.state_labels == ["q1", "q2", "q1_dot", "q2_dot"]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"m1": -1.0}, r"`m1 \[kg\]` must be > 0"),
        ({"L2": 0.0}, r"`L2 \[m\]` must be > 0"),
        ({"I1": -0.1}, r"`I1 \[kg·m²\]` must be >= 0"),
        ({"Lc2": float("nan")}, "must be finite"),
        ({"m2": "heavy"}, "must be a real number"),
    ],
    ids=["neg-mass", "zero-length", "neg-inertia", "nan", "string"],
)
def test_bad_params(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        sr.ScaraParams(**kwargs)


def test_payload_validation_and_range():
    with pytest.raises(ValueError, match="amplitude"):
        sr.SinusoidalPayload(offset=0.5, amplitude=1.0)
    assert sr.paper_payload().bounds == pytest.approx((0.0, 0.6 * 3.45))
    assert sr.model.robot.payload_range(lambda t: 1.0 + 0.5 * np.cos(t)) == pytest.approx((0.5, 1.5), abs=1e-6)
