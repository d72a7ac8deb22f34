"""Every run says whether it tracks: status tracking / not-tracking / diverged / failed / too-short, with a reason."""

import json
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.simulation.metrics import run_status

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_statuses_and_default_tolerance():
    assert sr.STATUSES == ("tracking", "not-tracking", "diverged", "failed", "too-short")
    assert sr.TRACKING_TOLERANCE == 0.05


def test_the_paper_runs_track():
    res = sr.run_scenario("pid", "small", t_final=7.0)
    assert res.status == "tracking" and res.status_reason.startswith("max |e| after 6 s = ")


def test_light_robot_sign_law_does_not_track_although_the_integrator_succeeds():
    light = sr.load_robot(EXAMPLES / "robot-light.toml")
    K = sr.design(sr.derived_model(light), 3, 90).K
    table = sr.compare_controllers(["pid", "smc-sign"], ["large"], params=light, K=K, t_final=10.0)
    sign = table[table["controller"] == "smc-sign"].iloc[0]
    # the table's success means "tracks"; the integrator itself finished (the run's own success)
    assert not bool(sign["success"]) and sign["status"] == "not-tracking"
    run = sr.run_scenario("smc-sign", "large", params=light, K=K, t_final=10.0)
    assert run.success and run.status == "not-tracking"
    assert sign["max_abs_error_after_6s"] > 1.0 and "> 0.05 rad" in sign["status_reason"]
    assert table[table["controller"] == "pid"].iloc[0]["status"] == "tracking"


def test_a_tiny_torque_limit_is_not_tracking():
    res = sr.run_scenario("pid", "large", t_final=8.0, torque_limit=1e-9)
    assert res.success and res.status == "not-tracking" and res.metrics().max_abs_error > 1.0


def test_tolerance_is_the_users():
    res = sr.run_scenario("pid", "small", t_final=7.0, tracking_tolerance=1e-4)
    assert res.status == "not-tracking" and res.tracking_tolerance == 1e-4
    with pytest.raises(sr.ArgumentValueError, match="`tracking_tolerance` must be > 0"):
        sr.run_scenario("pid", "small", t_final=7.0, tracking_tolerance=0.0)


def test_a_run_shorter_than_the_transient_is_too_short_not_tracking():
    res = sr.run_scenario("pid", "small", t_final=3.0)
    assert res.status == "too-short" and not res.has_metrics and "6-s transient" in res.status_reason
    # the user may take a shorter transient
    res = sr.run_scenario("pid", "small", t_final=3.0, t_transient=2.0)
    assert res.status == "tracking" and "max_abs_error_after_2s" in res.metrics().to_dict()


def test_a_diverging_run_is_diverged():
    K = sr.design(sr.paper_model(), 3, 90).K
    res = sr.simulate(sr.pid_controller(-K), "small", t_final=3.0)
    assert res.status == "diverged" and res.status_reason.startswith("diverged by t =")


def test_run_status_covers_failure():
    status = run_status(None, success=False, diverged=False, message="solver exploded")
    assert status == ("failed", "solver exploded")


def test_simulate_prints_a_summary_by_default(capsys, tmp_path):
    csv = tmp_path / "run.csv"
    assert main(["simulate", "--scenario", "small", "--t-final", "6.5", "--output", str(csv)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].startswith("status: tracking (max |e| after 6 s = ")
    assert any(line.startswith("  max_abs_error_after_6s = ") and line.endswith(" rad") for line in out)
    units = {line.split(" = ")[0].strip(): line.rsplit(" ", 1)[1] for line in out if line.startswith("  ")}
    assert units == {"max_abs_error_after_6s": "rad", "rms_error_after_6s": "rad", "peak_torque": "N·m",
                     "max_abs_torque_after_6s": "N·m", "chattering_index": "N·m/s", "control_energy": "N²·m²·s"}
    assert out[-1] == f"time series: {csv}" and csv.read_text().startswith("t,e1,e2")


@pytest.mark.parametrize(
    ("argv", "status"),
    [(["--t-final", "3"], "too-short"), (["--t-final", "7", "--torque-limit", "1e-9"], "not-tracking")],
    ids=["short", "saturated"],
)
def test_simulate_json_has_status_and_reason(capsys, argv, status):
    assert main(["simulate", "--format", "json", *argv]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["status"] == status and data["status_reason"]
    assert (data["metrics"] is None) == (status == "too-short")


def test_campaign_rows_and_report_count_statuses(tmp_path):
    spec = sr.spec_from_dict({"controllers": ["pid"], "t_final": 6.5, "runs": 2,
                              "torque_limit": {"min": 1e-9, "max": 1e-9}})
    table = sr.run_campaign(spec, tmp_path / "r.csv")
    assert list(table["status"]) == ["not-tracking", "not-tracking"]
    assert all("> 0.05 rad" in r for r in table["status_reason"])
    report = sr.campaign_report(sr.read_results(tmp_path / "r.csv"))
    assert report.loc["pid", "not-tracking"] == 2 and report.loc["pid", "tracking"] == 0
    assert report.loc["pid", "failure_rate"] == 1.0
    assert np.isfinite(report.loc["pid", "max_abs_error_after_6s q50"])


def test_an_integrator_s_complaint_is_in_the_status_not_on_stderr(capsys, tmp_path):
    """A gain far too stiff for LSODA (η = 1e12): the run stops; scipy's UserWarning goes into the reason."""
    import warnings

    design = tmp_path / "stiff.json"
    assert main(["design", "--rho", "3", "--eta", "1e12", "--format", "json", "--output", str(design)]) == 0
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning that leaks fails the test
        assert main(["simulate", "--design", str(design), "--t-final", "8"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    lines = out.splitlines()
    if "status: failed" in out:  # where LSODA gives up, the header says where, the reason says why
        assert "stopped at" in lines[0] and "integrator failed" in lines[1]
    else:
        assert lines[0].endswith("8 s (lsoda)")
