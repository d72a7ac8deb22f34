"""A fourth kind of plant: the user's own ``control.NonlinearIOSystem`` (UncertainPlant.from_nonlinear).

The example is a one-link arm hanging at q = 0 with a payload m_p at its tip,
``J(m_p) q̈ = u − b q̇ − k(m_p) g sin q`` with ``J = I + m_p L²`` and ``k = m lc + m_p L``.
Its linearization has a closed form, checked first (a residual); then the plant goes
through design, the certificates, the margins in kg, a nonlinear run and the C export, as
a plant file's does.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

import scara_robust as sr

G, I_LINK, M_LINK, LC, L, B_FRICTION = 9.81, 0.02, 1.0, 0.25, 0.5, 0.1
PAYLOAD = sr.Parameter("m_p", "kg", (0.0, 2.0), rate=1.0)


def _inertia(m_p: float) -> float:
    return I_LINK + M_LINK * LC**2 + m_p * L**2


def _gravity(m_p: float) -> float:
    return (M_LINK * LC + m_p * L) * G


def _arm(t, x, u, params):
    m_p = params["m_p"]
    return np.array([x[1], (u[0] - B_FRICTION * x[1] - _gravity(m_p) * math.sin(x[0])) / _inertia(m_p)])


SYSTEM = ct.nlsys(_arm, None, states=2, inputs=1, outputs=2, params={"m_p": 0.0}, name="one-link arm")
SIGNALS = {"inputs": [sr.Signal("tau", "N·m")], "outputs": [sr.Signal("q", "rad")]}


@pytest.fixture(scope="module")
def arm():
    return sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], **SIGNALS)


@pytest.fixture(scope="module")
def tracking():
    return sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], reference=([0.5], 1.0), n_times=7, **SIGNALS)


@pytest.mark.parametrize("m_p", [0.0, 0.7, 2.0])
def test_the_linearization_at_rest_is_the_closed_form(arm, m_p):
    A, B = arm.plant_matrices({"m_p": m_p})
    J = _inertia(m_p)
    assert np.allclose(A, [[0.0, 1.0], [-_gravity(m_p) / J, -B_FRICTION / J]], rtol=1e-9, atol=1e-9)
    assert np.allclose(B, [[0.0], [1.0 / J]], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("t", [0.0, 1.0, 2.5, 4.0])
def test_the_linearization_along_the_reference_is_the_closed_form(tracking, t):
    """Along q_r = 0.5 sin t: ∂q̈/∂q = −k g cos q_r / J at each payload, and u_r holds the reference at m_p = 0."""
    q_r, qd_r, qdd_r = 0.5 * math.sin(t), 0.5 * math.cos(t), -0.5 * math.sin(t)
    for m_p in (0.0, 2.0):
        A, B = tracking.plant_matrices({"t_ref": t, "m_p": m_p})
        J = _inertia(m_p)
        assert np.allclose(A, [[0.0, 1.0], [-_gravity(m_p) * math.cos(q_r) / J, -B_FRICTION / J]], atol=1e-8)
        assert np.allclose(B, [[0.0], [1.0 / J]], atol=1e-10)
    x_op, u_op = tracking.dynamics.operating_point(t)
    assert np.allclose(x_op, [q_r, qd_r])
    u_closed = _inertia(0.0) * qdd_r + B_FRICTION * qd_r + _gravity(0.0) * math.sin(q_r)
    assert u_op[0] == pytest.approx(u_closed, rel=1e-10, abs=1e-12)


def test_design_certify_and_margin_in_kg(arm):
    d = sr.design(arm, 1.0, 10.0)
    assert d.hurwitz
    table = sr.certificate_table(arm, d, methods=["lmi-physical", "vertex-box"])
    assert table["certified"].all(), table.to_string()
    margin = sr.parameter_margin(arm, d).set_index("method")
    high = margin["m_p high [kg]"]
    assert high["lmi"] >= 2.0  # the file's whole range, and beyond
    assert high["lmi"] <= high["frozen"]
    # the LMI's answer re-verified by numpy: a common P at the frozen plants of the range it certifies
    assert sr.lmi_certificate(arm.with_ranges({"m_p": (0.0, float(high["lmi"]))}).samples().closed_loops(d.K)).certified


def test_the_nonlinear_run_tracks_and_is_not_the_linear_one(arm):
    """A 1-rad step at m_p = 1 kg: the integral action holds the arm against gravity; the linear model's run differs."""
    d = sr.design(arm, 1.0, 10.0)
    run = sr.simulate_plant(arm, d.K, profiles={"m_p": lambda t: 1.0}, t_final=30.0)
    assert run.status == "tracking", run.reason
    # at rest at q = 1 rad the input holds gravity: u = k(m_p) g sin(1)
    assert run.u[0, -1] == pytest.approx(_gravity(1.0) * math.sin(1.0), rel=1e-3)
    linear = sr.UncertainPlant.from_function([PAYLOAD], arm.plant_matrices, **SIGNALS)
    lin_run = sr.simulate_plant(linear, d.K, profiles={"m_p": lambda t: 1.0}, t_final=30.0)
    assert lin_run.u[0, -1] == pytest.approx(_gravity(1.0) * 1.0, rel=1e-3)  # the linear model's "sin q = q"
    assert np.abs(run.e - lin_run.e).max() > 1e-2


@pytest.mark.parametrize("rho, eta, status", [(1.0, 10.0, "not-tracking"), (10.0, 100.0, "tracking")],
                         ids=["soft", "stiff"])
def test_a_varying_payload_needs_a_stiffer_gain(arm, rho, eta, status):
    """m_p = 1 + sin t kg at q = 1 rad moves gravity's torque by ±4.1 N·m: (1, 10) leaves 0.33 rad, (10, 100) 0.009."""
    d = sr.design(arm, rho, eta)
    run = sr.simulate_plant(arm, d.K, profiles={"m_p": lambda t: 1.0 + math.sin(t)}, t_final=30.0)
    assert run.status == status, run.reason


def test_small_motions_agree_with_the_linearization(arm):
    """A step of 1 mrad: the nonlinear run and the linearization's agree to the size of the neglected terms."""
    d = sr.design(arm, 1.0, 10.0)
    small = sr.simulate_plant(arm, d.K, reference=([1e-3], 0.0), profiles={"m_p": lambda t: 1.0}, t_final=10.0)
    linear = sr.UncertainPlant.from_function([PAYLOAD], arm.plant_matrices, **SIGNALS)
    ref = sr.simulate_plant(linear, d.K, reference=([1e-3], 0.0), profiles={"m_p": lambda t: 1.0}, t_final=10.0)
    assert np.abs(small.e - ref.e).max() < 1e-3 * 1e-4  # sin q − q ≈ q³/6 ≈ 2e-10 rad·(k g / J)


def test_along_a_reference_the_run_applies_the_model_feedforward(tracking):
    d = sr.design(tracking, 1.0, 10.0)
    run = sr.simulate_plant(tracking, d.K, reference=([0.5], 1.0), profiles={"m_p": lambda t: 0.0}, t_final=20.0)
    assert run.status == "tracking", run.reason
    # at the nominal payload the feedforward holds the reference alone: the error stays at the integrator's noise
    assert run.max_abs_error < 1e-4


def test_export_writes_the_pid_with_the_systems_signals(arm, tmp_path):
    d = sr.design(arm, 1.0, 10.0)
    limit = sr.check_sample_time(arm, d.discretize(1e-3))
    assert limit.certified, limit.message
    files = sr.export_controller(d.discretize(1e-3), tmp_path, prefix="arm_pid", **SIGNALS)
    header = files[0].read_text()
    assert "tau [N·m]" in header and "q [rad]" in header


@pytest.mark.parametrize("call, error, match", [
    (lambda: sr.UncertainPlant.from_nonlinear(_arm, [PAYLOAD]),
     sr.ArgumentTypeError, r"`sys` must be a control.NonlinearIOSystem, found function"),
    (lambda: sr.UncertainPlant.from_nonlinear(SYSTEM, [sr.Parameter("mass", "kg", (0.0, 1.0))]),
     sr.ArgumentValueError, r"`parameters` names 'mass', which is not a parameter of `sys` \(m_p\)"),
    (lambda: sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], x_eq=[0.0]),
     sr.ArgumentValueError, r"`x_eq`"),
    (lambda: sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], reference=([0.5], 0.0)),
     sr.ArgumentValueError, r"`reference\[1\]`"),
    (lambda: sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], reference=([0.5, 0.3], 1.0)),
     sr.ArgumentValueError, r"`reference\[0\]` must give one amplitude or one per output \(1\), found 2"),
    (lambda: sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], reference=[0.5, 1.0]),
     sr.ArgumentValueError, r"`reference` must be \(amplitudes, omega\)"),
    (lambda: sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], x_eq=[0.3, 0.0]),
     sr.ArgumentValueError, r"`x_eq` and `u_eq` must be an equilibrium of `sys` at the nominal parameters"),
    (lambda: sr.UncertainPlant.from_nonlinear(
        ct.nlsys(lambda t, x, u, p: [x[1], x[0], 0.0], None, states=3, inputs=1, outputs=3), []),
     sr.ArgumentValueError, r"must have the state \[q, q̇\] of 2p states, found 3"),
], ids=["a-function", "unknown-parameter", "x_eq-shape", "omega-zero", "amplitudes-size", "no-omega",
        "not-an-equilibrium", "odd-states"])
def test_bad_systems_are_refused_naming_the_argument(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_an_equilibrium_off_zero_is_the_origin_of_the_plant(arm):
    """At q = 0.3 rad the input that holds the arm is k g sin 0.3: with it, the plant regulates about there."""
    u_eq = [_gravity(0.0) * math.sin(0.3)]
    plant = sr.UncertainPlant.from_nonlinear(SYSTEM, [PAYLOAD], x_eq=[0.3, 0.0], u_eq=u_eq, **SIGNALS)
    A, _ = plant.plant_matrices({"m_p": 0.0})
    # control.linearize differentiates forward with a step of 1e-6: about 1.5e-7 relative here
    assert A[1, 0] == pytest.approx(-_gravity(0.0) * math.cos(0.3) / _inertia(0.0), rel=1e-5)


def test_a_plant_linearized_along_a_reference_runs_along_it(tracking):
    d = sr.design(tracking, 1.0, 10.0)
    run = sr.simulate_plant(tracking, d.K, profiles={"m_p": lambda t: 0.0}, t_final=20.0)  # its own by default
    assert run.status == "tracking" and run.max_abs_error < 1e-4, run.reason
    with pytest.raises(sr.ArgumentValueError, match=r"`reference` must be the one the plant was linearized along"):
        sr.simulate_plant(tracking, d.K, reference=([0.0], 0.0), t_final=5.0)
