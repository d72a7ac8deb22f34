"""A URDF arm on the compiled engine: its dynamics are Pinocchio's, its runs the lsoda runs.

The compiled arm (numba) runs RNEA and CRBA on the rigid bodies read from the Pinocchio
model, checked against Pinocchio's CRBA, RNEA and ABA when it is built; its closed loop
runs on the SCARA's compiled integrators and must give the ``lsoda`` engine's run (same
samples, statuses, metrics), refuse what it cannot evaluate, and agree with MuJoCo.
"""

from __future__ import annotations

import dataclasses
import os
import re

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.simulation import compiled_arm
from scara_robust.simulation.compiled import NUMBA_MISSING

pytestmark = [pytest.mark.robots, pytest.mark.compiled]  # skipped without the extras (tests/conftest.py)

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLES = os.path.join(os.path.dirname(HERE), "examples")
ROBOTS = {"arm6": "robot-arm6.toml", "scara-urdf": "robot-scara-urdf.toml"}
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint"]


def small_arm_file(tmp_path):
    """The example 6-joint arm on a coarse linearization grid (test sizes)."""
    text = open(os.path.join(EXAMPLES, ROBOTS["arm6"]), encoding="utf-8").read().replace(
        'urdf = "arm6.urdf"', f'urdf = "{os.path.join(EXAMPLES, "arm6.urdf")}"')
    text = re.sub(r"^reference_samples = \d+", "reference_samples = 13", text, flags=re.M)
    text = re.sub(r"^payload_samples = \d+", "payload_samples = 3", text, flags=re.M)
    path = tmp_path / "arm.toml"
    path.write_text(text, encoding="utf-8")
    return str(path)


@pytest.fixture(scope="module")
def arm_setup(tmp_path_factory):
    return sr.load_arm(small_arm_file(tmp_path_factory.mktemp("arm")))


@pytest.fixture(scope="module")
def arm_gain(arm_setup):
    return sr.design(arm_setup.plant, 1000, 10).K


def _kernels():
    from scara_robust.simulation import _kernels

    return _kernels


def _compiled(arm, q, v, a, tau, m):
    """The compiled mass matrix, RNEA torque and forward dynamics of `arm` at one state."""
    k, n = _kernels(), arm.n_joints
    model = compiled_arm._model(*compiled_arm.pack_bodies(arm.rigid_bodies()))
    M, tau_id, acc = np.zeros((n, n)), np.zeros(n), np.zeros(n)
    k.arm_mass_matrix(model, q, m, M)
    k.arm_inverse_dynamics(model, q, v, a, m, tau_id)
    k.arm_forward_dynamics(model, q, v, tau, m, acc)
    return M, tau_id, acc


# --- the dynamics: Pinocchio's to 1e-12 ---------------------------------------------------------


@pytest.mark.parametrize("robot", list(ROBOTS), ids=list(ROBOTS))
def test_compiled_dynamics_equal_pinocchio_on_random_states(robot):
    arm = sr.load_arm(os.path.join(EXAMPLES, ROBOTS[robot])).arm
    n = arm.n_joints
    rng = np.random.default_rng(7)
    for _ in range(25):
        q, v = rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n)
        a, tau = rng.uniform(-10, 10, n), rng.uniform(-50, 50, n)
        m = float(rng.uniform(0, 5))
        M_c, tau_c, acc_c = _compiled(arm, q, v, a, tau, m)
        M = arm.mass_matrix(q, m)
        bias = arm.inverse_dynamics(q, v, np.zeros(n), m)
        # each difference relative to the size of what it is made of
        assert np.abs(M_c - M).max() <= 1e-12 * np.abs(M).max()
        rnea_scale = np.abs(M).max() * np.abs(a).max() + np.abs(bias).max()
        assert np.abs(tau_c - arm.inverse_dynamics(q, v, a, m)).max() <= 1e-12 * rnea_scale
        aba_scale = np.abs(np.linalg.inv(M)).max() * (np.abs(tau).max() + np.abs(bias).max())
        assert np.abs(acc_c - arm.forward_dynamics(q, v, tau, m)).max() <= 1e-12 * aba_scale
    worst = compiled_arm.check_compiled_dynamics(arm)
    assert set(worst) == {"mass_matrix", "rnea", "aba"} and max(worst.values()) <= 1e-12


def test_compiled_dynamics_keep_the_file_joint_order(arm_setup):
    arm = arm_setup.arm
    order = [2, 0, 5, 1, 4, 3]
    swapped = sr.RobotArm(arm.urdf, [JOINTS[i] for i in order], locked=arm.locked, payload_frame="tool0",
                          payload_com=arm.payload_com, payload_inertia_per_kg=arm.payload_inertia_per_kg,
                          armature=[arm.armature[i] for i in order])
    q, v = np.linspace(-0.5, 0.7, 6), np.linspace(0.3, -0.2, 6)
    a, tau = np.linspace(1.0, -2.0, 6), np.linspace(-5.0, 4.0, 6)
    M, tau_id, acc = _compiled(arm, q, v, a, tau, 1.2)
    M_s, tau_s, acc_s = _compiled(swapped, q[order], v[order], a[order], tau[order], 1.2)
    np.testing.assert_allclose(M_s, M[np.ix_(order, order)], rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(tau_s, tau_id[order], rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(acc_s, acc[order], rtol=1e-12, atol=1e-12)
    assert max(compiled_arm.check_compiled_dynamics(swapped).values()) <= 1e-12


CORRUPTIONS = {
    "link-inertia": lambda b: b.inertias.__setitem__(3, b.inertias[3] * 1.001),
    "link-mass": lambda b: b.masses.__setitem__(1, b.masses[1] + 1e-6),
    "joint-axis": lambda b: b.axes.__setitem__(4, -b.axes[4]),
    "armature": lambda b: b.armature.__setitem__(0, b.armature[0] + 1e-3),
    "payload-com": lambda b: b.payload_com.__setitem__(2, b.payload_com[2] + 0.01),
}


@pytest.mark.parametrize("corruption", list(CORRUPTIONS), ids=list(CORRUPTIONS))
def test_a_corrupted_compiled_model_is_refused_by_the_load_check(tmp_path, monkeypatch, arm_gain, corruption):
    original = sr.RobotArm.rigid_bodies

    def corrupted(self):
        bodies = original(self)
        copy = dataclasses.replace(bodies, **{f.name: np.array(getattr(bodies, f.name), copy=True)
                                              for f in dataclasses.fields(bodies) if f.name != "payload_body"})
        CORRUPTIONS[corruption](copy)
        return copy

    monkeypatch.setattr(sr.RobotArm, "rigid_bodies", corrupted)
    setup = sr.load_arm(small_arm_file(tmp_path))  # a new arm: its compiled model is built (and checked) again
    with pytest.raises(sr.ArgumentValueError, match=r"`method` 'compiled' refuses arm .*do not reproduce "
                                                    r"Pinocchio's on random states"):
        sr.simulate_arm(setup, arm_gain, t_final=0.1, method="compiled")
    assert sr.simulate_arm(setup, arm_gain, t_final=0.1).status == "too-short"  # lsoda runs it still


# --- the closed loop: the lsoda run, on the SCARA's integrators -----------------------------------


def _agree(ref, run, *, e_tol=1e-6):
    assert run.method == "compiled" and ref.status == run.status and ref.message == run.message
    assert np.array_equal(ref.t, run.t)
    assert np.abs(ref.e - run.e).max() <= e_tol
    assert np.abs(ref.torque - run.torque).max() <= 1e-5 * max(np.abs(ref.torque).max(), 1.0)
    ff_scale = max(np.abs(ref.feedforward).max(), 1.0)
    np.testing.assert_allclose(run.feedforward, ref.feedforward, rtol=0, atol=1e-12 * ff_scale)  # RNEA's, N·m
    np.testing.assert_allclose(run.payload, ref.payload, rtol=1e-14, atol=1e-14)  # the same profile, kg
    if ref.has_metrics and not ref.diverged:
        assert abs(ref.metrics().max_abs_error - run.metrics().max_abs_error) <= 1e-6


@pytest.mark.parametrize("t_final", [4.0, pytest.param(20.0, marks=pytest.mark.slow)], ids=["4s", "20s"])
def test_compiled_run_equals_the_lsoda_run(arm_setup, arm_gain, t_final):
    profile = sr.parameter_profile(arm_setup.plant, "m_p", "sinusoid", t_final=t_final)
    t_transient = 2.0 if t_final < 6 else sr.PAPER_TRANSIENT  # a short run judged after a shorter transient
    ref = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=t_final, t_transient=t_transient)
    bdf = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=t_final, t_transient=t_transient, method="compiled")
    dopri = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=t_final, t_transient=t_transient,
                            method="compiled", integrator="dopri5")
    assert ref.status == bdf.status == dopri.status == "tracking"
    _agree(ref, bdf)
    _agree(ref, dopri)
    assert np.abs(bdf.e - dopri.e).max() <= 1e-6  # BDF and Dormand–Prince agree
    assert abs(bdf.metrics().max_abs_error - dopri.metrics().max_abs_error) <= 1e-7


def _csv_profile(plant, tmp_path):
    path = tmp_path / "payload.csv"
    path.write_text("t,m_p\n0,0.5\n0.7,2.5\n1.3,1.0\n1.8,3.0\n", encoding="utf-8")
    return sr.parameter_profile(plant, "m_p", "csv", path=path, column="m_p", t_final=2.0)


PAYLOADS = {
    "nominal": lambda plant, tmp: None,
    "constant": lambda plant, tmp: sr.parameter_profile(plant, "m_p", "constant", value=2.0, t_final=2.0),
    "sinusoid": lambda plant, tmp: sr.parameter_profile(plant, "m_p", "sinusoid", period=1.0, t_final=2.0),
    "ramp": lambda plant, tmp: sr.parameter_profile(plant, "m_p", "ramp", t_final=2.0),
    "random-walk": lambda plant, tmp: sr.parameter_profile(plant, "m_p", "random-walk", seed=3, t_final=2.0),
    "csv": _csv_profile,
    "ConstantPayload": lambda plant, tmp: sr.ConstantPayload(2.5),
    "SinusoidalPayload": lambda plant, tmp: sr.SinusoidalPayload(1.5, 1.2, 3.0, 0.4),
}


@pytest.mark.parametrize("payload", list(PAYLOADS), ids=list(PAYLOADS))
def test_every_payload_profile_runs_compiled(tmp_path, arm_setup, arm_gain, payload):
    profile = PAYLOADS[payload](arm_setup.plant, tmp_path)
    ref = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=2.0, t_transient=1.0)
    _agree(ref, sr.simulate_arm(arm_setup, arm_gain, profile, t_final=2.0, t_transient=1.0, method="compiled"))


@pytest.mark.parametrize("feedforward", ["none", "gravity", "computed-torque"])
def test_feedforward_disturbance_and_initial_error_run_compiled(arm_setup, arm_gain, feedforward):
    setup = dataclasses.replace(arm_setup, feedforward=feedforward)
    wave = sr.SquareWave(2.0, 0.7, 0.3, (1.0, -1.0, 0.5, 1.0, -0.5, 0.2))
    options = {"disturbance": wave, "e0": [0.1, -0.2, 0.05, 0.0, 0.1, -0.1], "edot0": [0.5] * 6, "t_final": 3.0,
               "t_transient": 1.5}
    profile = sr.parameter_profile(setup.plant, "m_p", "sinusoid", period=2.0, t_final=3.0)
    ref = sr.simulate_arm(setup, arm_gain, profile, **options)
    run = sr.simulate_arm(setup, arm_gain, profile, method="compiled", **options)
    _agree(ref, run)
    assert (np.abs(run.feedforward).max() > 1.0) == (feedforward != "none")


def test_sampled_pid_runs_the_rk4_scheme_compiled(arm_setup, arm_gain):
    profile = sr.parameter_profile(arm_setup.plant, "m_p", "sinusoid", t_final=1.0)
    ref = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=1.0, Ts=2e-4, t_transient=0.5)
    run = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=1.0, Ts=2e-4, t_transient=0.5, method="compiled")
    assert ref.method == "rk4" and run.method == "compiled" and np.array_equal(ref.t, run.t)
    assert np.abs(ref.e - run.e).max() <= 1e-12  # the same RK4 steps with the torque held
    assert ref.status == run.status


def test_a_diverging_run_stops_where_the_lsoda_run_stops(arm_setup, arm_gain):
    # no feedback: the disturbance swings the arm away; the run stops at the end of the first segment past 0.5 rad
    options = {"disturbance": sr.SquareWave(1.0, 1.0, 0.0, (1.0,) * 6), "t_final": 4.0, "divergence_limit": 0.5}
    ref = sr.simulate_arm(arm_setup, 0 * arm_gain, **options)
    run = sr.simulate_arm(arm_setup, 0 * arm_gain, method="compiled", **options)
    assert ref.diverged and run.diverged and ref.status == run.status == "diverged"
    assert run.message == ref.message and run.t[-1] == ref.t[-1] < 4.0
    assert np.array_equal(ref.t, run.t) and np.abs(ref.e - run.e).max() <= 1e-6


def test_the_scara_urdf_runs_compiled_as_on_lsoda():
    setup = sr.load_arm(os.path.join(EXAMPLES, ROBOTS["scara-urdf"]))
    K = sr.design(sr.derived_model(), 3, 90).K
    options = {"e0": [-1.5, 2.5], "edot0": [1.0, 0.0], "disturbance": sr.paper_disturbance(), "t_final": 8.0}
    ref = sr.simulate_arm(setup, K, sr.paper_payload(), **options)
    run = sr.simulate_arm(setup, K, sr.paper_payload(), method="compiled", **options)
    assert run.status == "tracking"
    _agree(ref, run)


# --- what the compiled engine refuses -------------------------------------------------------------


def test_a_payload_callable_of_ones_own_is_refused(arm_setup, arm_gain):
    with pytest.raises(sr.ArgumentValueError, match=r"`payload` 'compiled' evaluates a ConstantPayload, a "
                                                    r"SinusoidalPayload or a profile of parameter_profile"):
        sr.simulate_arm(arm_setup, arm_gain, lambda t: 1.0, t_final=0.1, method="compiled")


def test_without_numba_the_error_is_the_scara_compiled_engine_s(monkeypatch, arm_setup, arm_gain):
    from scara_robust.simulation import arm, run

    monkeypatch.setattr(arm, "numba_available", lambda: False)
    monkeypatch.setattr(run, "numba_available", lambda: False)
    with pytest.raises(sr.ArgumentValueError, match=re.escape(NUMBA_MISSING)) as from_arm:
        sr.simulate_arm(arm_setup, arm_gain, t_final=0.1, method="compiled")
    with pytest.raises(sr.ArgumentValueError, match=re.escape(NUMBA_MISSING)) as from_scara:
        sr.run_scenario("pid", "large", t_final=0.1, method="compiled")
    assert str(from_arm.value) == str(from_scara.value)


@pytest.mark.parametrize(("option", "value", "needle"), [("integrator", "rk45", "integrator"),
                                                         ("method", "radau", "method")], ids=["integrator", "method"])
def test_bad_engine_options_name_the_argument(arm_setup, arm_gain, option, value, needle):
    with pytest.raises(sr.ArgumentValueError, match=f"`{needle}`"):
        sr.simulate_arm(arm_setup, arm_gain, t_final=0.1, **{option: value})


# --- an independent simulator: MuJoCo -------------------------------------------------------------


@pytest.mark.mujoco
def test_mujoco_reproduces_the_compiled_six_joint_run(arm_setup, arm_gain):
    from mujoco_arm import simulate_mujoco

    profile = sr.parameter_profile(arm_setup.plant, "m_p", "sinusoid", t_final=8.0)
    run = sr.simulate_arm(arm_setup, arm_gain, profile, t_final=8.0, method="compiled")
    arm, ref = arm_setup.arm, arm_setup.reference
    mj = simulate_mujoco(arm.urdf, arm.joints, arm.locked, arm.payload_frame, arm.payload_com,
                         arm.payload_inertia_per_kg, arm.gravity, arm_gain, ref.center, ref.amplitude, ref.omega,
                         ref.phase, profile, arm_setup.payload_nominal, arm_setup.feedforward, 8.0, 1e-3,
                         method="radau", rtol=1e-9, armature=arm.armature)
    after = mj["t"] >= 6.0
    assert run.metrics().max_abs_error == pytest.approx(float(np.abs(mj["e"][:, after]).max()), abs=1e-4)
    assert np.abs(run.e[:, run.t >= 6.0] - mj["e"][:, after]).max() <= 1e-4


# ---------------------------------------------------------------- the command line


def test_simulate_runs_an_arm_on_the_engine_asked(capsys):
    from scara_robust.cli import main

    printed = {}
    for method in ("lsoda", "compiled"):
        argv = ["simulate", "--rho", "1000", "--eta", "3", "--robot", "examples/robot-arm6.toml", "--profile",
                "sinusoid", "--t-final", "8", "--method", method]
        assert main(argv) == 0
        out = capsys.readouterr().out
        assert f"s simulated ({method})" in out
        printed[method] = re.findall(r"max \|e\| after (?:6 s )?= \S+ rad, peak \|τ\| = \S+ N·m|max \|e\| after 6 s = "
                                     r"\S+ rad; peak \|τ\| = \S+ N·m", out)
    # the two runs agree within 3e-9 rad: every joint's printed max |e| and peak torque alike
    assert len(printed["lsoda"]) == 7 and printed["compiled"] == printed["lsoda"]


def test_simulate_refuses_an_engine_arms_do_not_run_on(capsys):
    from scara_robust.cli import main

    argv = ["simulate", "--rho", "1000", "--eta", "3", "--robot", "examples/robot-arm6.toml", "--method",
            "interconnect"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "`--method` of an arm's run is one of lsoda, rk4, compiled" in err
