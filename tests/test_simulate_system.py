"""One run, whatever ran: sr.Run on every run kind, and sr.simulate_system over the three simulators.

simulate_system is checked against a direct call of the kind's own simulator with the same
inputs (the arrays must be identical: it adds no computation of its own), and its refusals
name the argument.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr

ROOT = Path(__file__).resolve().parents[1]
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")
ARM = str(ROOT / "examples" / "robot-scara-urdf.toml")


def _common(run: sr.Run) -> None:
    """The fields of Run, with their shapes and meaning."""
    assert isinstance(run, sr.Run)
    k = run.t.size
    assert run.e.shape[1] == k and run.u.shape[1] == k
    assert run.status in sr.STATUSES and isinstance(run.reason, str) and run.reason
    assert run.peak_input >= np.abs(run.u).max()  # a refined peak may lie between samples
    table = run.to_pandas()
    assert len(table) == k


def test_the_scara_through_simulate_system_is_simulate():
    system = sr.open_system("scara", command="simulate")
    d = sr.design(system.model, 1.0, 5.0)
    run = sr.simulate_system(system, d, t_final=1.0, scenario="small")
    direct = sr.simulate(sr.pid_controller(d.K, system.setup.reference), "small", params=system.setup.params,
                         payload=sr.paper_payload(system.setup.params), reference=system.setup.reference,
                         disturbance=system.setup.disturbance, t_final=1.0)
    assert np.array_equal(run.e, direct.e) and np.array_equal(run.u, direct.torque)
    _common(run)
    assert run.u is run.torque and run.reason == run.status_reason
    assert run.max_abs_error == run.metrics().max_abs_error if run.has_metrics else math.isnan(run.max_abs_error)
    assert run.peak_input == run.peak_torque  # refined between the samples where computed
    # A named controller and a DiscretePID run the SCARA as simulate runs them.
    named = sr.simulate_system(system, "pid", t_final=0.5, scenario="small")
    assert np.array_equal(named.e, sr.simulate("pid", "small", t_final=0.5).e)
    pid = d.discretize(1e-3)
    sampled = sr.simulate_system(system, pid, t_final=0.5, scenario="small")
    assert np.array_equal(sampled.e, sr.simulate(sr.sampled_pid_controller(pid), "small", t_final=0.5).e)


def test_a_plant_file_and_its_plant_run_as_simulate_plant_runs_them():
    system = sr.open_system("plant", command="simulate", model_file=MOTOR)
    plant = system.physical
    d = sr.design(plant, 1.0, 10.0)
    direct = sr.simulate_plant(plant, d.K, t_final=2.0)
    for who in (system, plant):
        run = sr.simulate_system(who, d, t_final=2.0)
        assert isinstance(run, sr.PlantRun) and np.array_equal(run.e, direct.e) and np.array_equal(run.u, direct.u)
        _common(run)
    held = sr.SampledStateFeedback(d.K, 1e-3)
    run = sr.simulate_system(plant, held, t_final=2.0)
    assert np.array_equal(run.e, sr.simulate_plant(plant, held, t_final=2.0).e)
    # 1 ms is beyond this gain's certified 0.8 ms: its frozen held loop has spectral radius > 1, and the run
    # stops where the state leaves 1e6 times its scale, diverged, without an overflow warning (warnings are errors).
    assert sr.check_sample_time(plant, held).certificate.spectral_radius > 1.4
    assert run.status == "diverged" and "stopped there" in run.reason and run.t[-1] < 0.1
    assert run.e.shape == (1, run.t.size) and run.u.shape == (1, run.t.size) and math.isinf(run.max_abs_error)
    slower = sr.simulate_system(plant, sr.SampledStateFeedback(d.K, 5e-4), t_final=1.0)  # within 0.8 ms
    assert slower.t[-1] == 1.0 and slower.status != "diverged" and slower.peak_input == np.abs(slower.u).max()


def test_an_arm_runs_a_held_gain_at_its_sample_time():
    system = sr.open_system("arm", command="simulate", robot=ARM)
    setup = system.arm()
    d = sr.design(system.model, 3.0, 90.0)
    held = sr.SampledStateFeedback(d.K, 1e-3)
    direct = sr.simulate_arm(setup, d.K, Ts=1e-3, t_final=0.2, method="rk4")
    for who in (system, setup):
        run = sr.simulate_system(who, held, t_final=0.2, method="rk4")
        assert isinstance(run, sr.ArmRun) and np.array_equal(run.e, direct.e)
        _common(run)
        assert run.u is run.torque and run.reason == run.status_reason
    with pytest.raises(sr.ArgumentValueError, match="held gain's Ts = 0.001 s"):
        sr.simulate_system(setup, held, Ts=2e-3, t_final=0.2)


@pytest.mark.parametrize(("who", "controller", "argument"), [
    ("plant", "pid", "controller"),
    ("plant", "pid-sampled", "controller"),
    ("arm", "discrete", "controller"),
    ("scara", "held", "controller"),
    ("nothing", "matrix", "system"),
])
def test_what_a_system_cannot_run_is_refused_naming_the_argument(who, controller, argument):
    scara = sr.open_system("scara", command="simulate")
    d = sr.design(scara.model, 1.0, 5.0)
    systems = {"plant": sr.load_plant(MOTOR), "arm": sr.open_system("arm", command="simulate", robot=ARM),
               "scara": scara, "nothing": 42}
    controllers = {"pid": "pid", "pid-sampled": d.discretize(1e-3), "discrete": d.discretize(1e-3),
                   "held": sr.SampledStateFeedback(d.K, 1e-3), "matrix": d.K}
    with pytest.raises(sr.ArgumentTypeError) as err:
        sr.simulate_system(systems[who], controllers[controller], t_final=0.1)
    assert err.value.argument == argument
    assert "found" in str(err.value) and ("runs)" in str(err.value) or argument == "system")
