"""Campaigns on a URDF arm: drawn scenarios, torque limits and measurement noise, resume, both engines.

The arm's runs are :func:`scara_robust.simulate_arm`'s; a campaign's table must not depend
on the worker count, the chunking or a kill and resume, and its compiled runs must give
the statistics of the LSODA runs on Pinocchio's dynamics (the second, independent engine).
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
from test_arm_compiled import small_arm_file

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.exceptions import CampaignSpecError
from scara_robust.model.arm import JointSinusoids
from scara_robust.studies import campaign as cp
from scara_robust.studies.campaign.arm import arm_campaign_spec, draw_arm_scenario

pytestmark = [pytest.mark.robots, pytest.mark.compiled]

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLE = os.path.join(os.path.dirname(HERE), "examples", "campaign-arm6.toml")

#: A small arm campaign: short horizon, every arm field drawn, noise and torque limits included.
TINY = """
controllers = ["pid"]
t_final = 6.5
rho = 1000.0
eta = 3.0
runs = 4
seed = 11
payload_profiles = ["sinusoidal", "constant"]
payload_peak = { min = 0.5, max = 3.0 }
payload_omega = { min = 0.2, max = 0.6 }
disturbance_amplitude = { min = 0.0, max = 2.0 }
disturbance_phase = { min = 0.0, max = 6.283 }
reference_scale = { min = 0.8, max = 1.2 }
initial_error = { min = -0.05, max = 0.05 }
torque_limit = { min = 50.0, max = 150.0 }
measurement_noise = { min = 0.0, max = 1e-3 }
noise_bandwidth = 3.0
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("arm-campaign")
    (folder / "tiny.toml").write_text(TINY)
    return folder / "tiny.toml", small_arm_file(folder)


@pytest.fixture(scope="module")
def straight(files):
    """The tiny arm campaign run straight through in this process (compiled engine)."""
    spec_file, robot = files
    spec = arm_campaign_spec(cp.load_spec(spec_file), robot)
    out = spec_file.parent / "straight.csv"
    cp.run_campaign(spec, out, chunk_size=1, engine="compiled")
    return spec, cp.read_results(out)


def test_table_holds_each_drawn_input_and_a_tracking_run(straight):
    spec, table = straight
    assert table["scenario"].tolist() == [0, 1, 2, 3] and (table["controller"] == "pid").all()
    assert table["success"].all() and (table["method"] == "compiled").all()
    assert (table["spec"] == spec.digest()).all() and (table["seed"] == 11).all()
    for i in range(4):
        redraw = draw_arm_scenario(spec, 11, i, 6)
        row = table[table["scenario"] == i].iloc[0]
        for key, value in redraw.items():
            assert row[key] == value, key
    assert table["measurement_noise"].between(0, 1e-3).all() and table["measurement_noise"].nunique() == 4
    # the actuator limit holds in every run
    assert (table["peak_torque"] <= table["torque_limit"] + 1e-9).all()


def test_a_run_is_simulate_arm_of_its_row(straight):
    """A row's metrics are those of simulate_arm on its inputs, noise redrawn from [seed, scenario, 1]."""
    spec, table = straight
    row = table.iloc[2].to_dict()
    setup, K = cp.arm.arm_context(spec)
    n = setup.arm.n_joints
    scale = row["reference_scale"]
    ref = setup.reference
    scaled = JointSinusoids(ref.center, tuple(scale * a for a in ref.amplitude), ref.omega, ref.phase)
    peak = row["payload_peak"]
    payload = (sr.SinusoidalPayload(peak / 2, peak / 2, row["payload_omega"], row["payload_phase"])
               if row["payload_profile"] == "sinusoidal" else sr.ConstantPayload(peak))
    noise = None
    if row["measurement_noise"] > 0:
        noise = sr.MeasurementNoise.draw(row["measurement_noise"], row["noise_bandwidth"], n,
                                         np.random.default_rng([11, 2, 1]), 8)
    run = sr.simulate_arm(
        dataclasses.replace(setup, reference=scaled), K, payload, method="lsoda", t_final=6.5,
        e0=[row[f"e{k + 1}_0"] for k in range(n)], edot0=np.zeros(n),
        disturbance=sr.SquareWave(row["disturbance_amplitude"], row["disturbance_period"], row["disturbance_phase"],
                                  (1.0,) * n),
        torque_limit=None if np.isinf(row["torque_limit"]) else row["torque_limit"], noise=noise)
    assert run.status == row["status"]
    assert run.metrics().max_abs_error == pytest.approx(row["max_abs_error_after_6s"], rel=1e-5, abs=1e-9)


def test_replay_gives_the_row(straight):
    _, table = straight
    run = cp.replay_arm_scenario(table, 3)
    row = table[table["scenario"] == 3].iloc[0]
    assert run.method == "compiled" and run.status == row["status"]
    assert run.metrics().max_abs_error == row["max_abs_error_after_6s"]
    with pytest.raises(ValueError, match="replay its rows with scara_robust.replay_arm_scenario"):
        sr.replay_scenario(table, 3)


def test_same_table_with_a_process_pool(straight, tmp_path):
    spec, table = straight
    cp.run_campaign(spec, tmp_path / "pool.csv", workers=2, chunk_size=1, engine="compiled")
    pd.testing.assert_frame_equal(cp.read_results(tmp_path / "pool.csv"), table)


@pytest.mark.dask
@pytest.mark.parquet
def test_same_table_on_dask_in_parquet(straight, tmp_path):
    spec, table = straight
    cp.run_campaign(spec, tmp_path / "dask.parquet", workers=2, scheduler="dask", chunk_size=2, engine="compiled")
    pd.testing.assert_frame_equal(cp.read_results(tmp_path / "dask.parquet"), table)


def test_killed_process_resumes_to_the_same_table(straight, files, tmp_path):
    spec, table = straight
    spec_file, robot = files
    out = tmp_path / "killed.csv"
    args = ["campaign", str(spec_file), "--robot", robot, "--chunk-size", "1", "--checkpoint", "0",
            "--engine", "compiled", "--output", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "scara_robust", *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and cp.read_results(out)["scenario"].nunique() >= 1:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert 1 <= cp.read_results(out)["scenario"].nunique() <= 4
    assert main([*args, "--resume"]) == 0
    pd.testing.assert_frame_equal(cp.read_results(out), table)


@pytest.mark.parametrize("runs", [3, pytest.param(20, marks=pytest.mark.slow)])
def test_compiled_statistics_agree_with_lsoda_on_a_campaign(files, tmp_path, runs):
    """The campaign's statistics on the compiled engine equal those of LSODA on Pinocchio's ABA.

    3 scenarios in ``make test``; the 20 of the campaign's example in ``make test-slow``.
    """
    spec_file, robot = files
    spec = arm_campaign_spec(cp.load_spec(spec_file), robot)
    tables = {e: cp.run_campaign(spec, tmp_path / f"{e}.csv", runs=runs, engine=e) for e in ("compiled", "scipy")}
    fast, slow = tables["compiled"], tables["scipy"]
    assert (fast["method"] == "compiled").all() and (slow["method"] == "lsoda").all()
    assert fast["status"].tolist() == slow["status"].tolist()
    for metric in ("max_abs_error_after_6s", "rms_error_after_6s", "peak_torque"):
        np.testing.assert_allclose(fast[metric], slow[metric], rtol=1e-5, atol=1e-8, err_msg=metric)
    report = {e: cp.campaign_report(t) for e, t in tables.items()}
    columns = [c for c in report["compiled"].columns if c.startswith("max_abs_error_after_6s q")]
    assert columns
    np.testing.assert_allclose(report["compiled"][columns].to_numpy(float), report["scipy"][columns].to_numpy(float),
                               rtol=1e-5)
    assert report["compiled"].loc["pid", "failure_rate"] == report["scipy"].loc["pid", "failure_rate"]


def test_spec_fields_of_the_other_robot_are_refused(files):
    spec_file, robot = files
    with pytest.raises(CampaignSpecError, match="field `cp`: describes the SCARA"):
        arm_campaign_spec(cp.spec_from_dict({"controllers": ["pid"], "cp": 0.004}), robot)
    with pytest.raises(CampaignSpecError, match="field `controllers`: an arm campaign runs pid"):
        arm_campaign_spec(cp.spec_from_dict({"controllers": ["pid", "smc"]}), robot)
    with pytest.raises(CampaignSpecError, match="field `measurement_noise`: applies to an arm campaign"):
        cp.run_campaign(cp.spec_from_dict({"measurement_noise": 1e-3}), "never.csv")
    assert not os.path.exists("never.csv")
    with pytest.raises(CampaignSpecError, match=r"field `noise_bandwidth`: expected values > 0 Hz, found 0"):
        cp.spec_from_dict({"noise_bandwidth": 0.0})


def test_cli_refuses_a_scara_field_on_an_arm_in_one_line(files, tmp_path, capsys):
    _, robot = files
    spec_file = tmp_path / "bad.toml"
    spec_file.write_text('controllers = ["pid"]\nreference_omega = 2.0\n')
    out = tmp_path / "r.csv"
    assert main(["campaign", str(spec_file), "--robot", robot, "--output", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "`reference_omega`: describes the SCARA" in err[0]
    assert not out.exists()


def test_the_example_spec_loads_for_the_example_arm():
    spec = cp.load_spec(EXAMPLE)
    assert spec.controllers == ("pid",) and spec.runs == 1000
    assert spec.arm_ranges["measurement_noise"] == cp.Range(0.0, 1e-3)


def test_measurement_noise_has_its_rms_and_its_rate_is_its_derivative():
    noise = sr.MeasurementNoise.draw(2e-3, 5.0, 3, np.random.default_rng(0))
    t = np.linspace(0.0, 400.0, 400_001)
    rms = np.sqrt((noise(t) ** 2).mean(axis=1))
    np.testing.assert_allclose(rms, 2e-3, rtol=0.05)  # a long-run average of 8 sinusoids
    assert np.all(noise.omega > 0) and np.all(noise.omega <= 2 * np.pi * 5.0)
    h = 1e-6
    for tk in (0.3, 7.1):
        np.testing.assert_allclose(noise.rate(tk), (noise(tk + h) - noise(tk - h)) / (2 * h), atol=1e-9)
    np.testing.assert_allclose(noise(t[:5]).T[3], noise(t[3]))
    with pytest.raises(ValueError, match="bandwidth"):
        sr.MeasurementNoise.draw(1e-3, 0.0, 2, np.random.default_rng(0))
    with pytest.raises(ValueError, match="amplitude"):
        sr.MeasurementNoise(-np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)))


@pytest.mark.parametrize("what", ["torque_limit", "noise", "both"])
def test_engines_agree_under_a_torque_limit_and_noise(files, what):
    """The compiled kernel's clipped, noisy loop is the Python loop's (LSODA on Pinocchio's ABA)."""
    _, robot = files
    setup = sr.load_arm(robot)
    K = sr.design(setup.plant, 1000, 3).K
    options = {}
    if what in ("torque_limit", "both"):
        options["torque_limit"] = 20.0
    if what in ("noise", "both"):
        options["noise"] = sr.MeasurementNoise.draw(2e-3, 3.0, 6, np.random.default_rng(5))
    runs = {m: sr.simulate_arm(setup, K, method=m, t_final=2.0, t_transient=1.0, **options)
            for m in ("compiled", "lsoda")}
    fast, slow = runs["compiled"], runs["lsoda"]
    np.testing.assert_allclose(fast.e, slow.e, atol=1e-6)
    # the torque is K times the states: states 1e-6 apart move it by up to ‖K‖∞·1e-6 (4.7e-4 N·m here); the
    # runs are closer (1e-4 N·m with one BLAS thread, 1.04e-4 with two, where K's last bits differ)
    np.testing.assert_allclose(fast.torque, slow.torque, atol=1e-6 * np.abs(K).sum(axis=1).max())
    if "torque_limit" in options:
        assert np.abs(fast.torque).max() == pytest.approx(20.0)  # the limit bites (27 N·m without it)
    plain = sr.simulate_arm(setup, K, method="compiled", t_final=2.0, t_transient=1.0)
    assert np.abs(plain.e - fast.e).max() > 1e-6  # and it changes the run


def test_simulate_arm_refuses_bad_limits_and_noise(files):
    _, robot = files
    setup = sr.load_arm(robot)
    K = np.zeros((6, 18))
    with pytest.raises(ValueError, match=r"`torque_limit \[N·m\]` must be > 0"):
        sr.simulate_arm(setup, K, torque_limit=0.0)
    with pytest.raises(ValueError, match="`noise` must have one row per joint"):
        sr.simulate_arm(setup, K, noise=sr.MeasurementNoise.draw(1e-3, 1.0, 2, np.random.default_rng(0)))
    with pytest.raises(TypeError, match="`noise` must be a MeasurementNoise"):
        sr.simulate_arm(setup, K, noise=1e-3)
