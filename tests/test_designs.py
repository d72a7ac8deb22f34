"""Design files and the ``pid-lmi`` controller: the synthesized gain, written, read and run."""

import json
import re

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.robustness.polytope import box_closed_loops
from scara_robust.simulation.controllers import PID_LMI_FILE


def test_design_file_round_trip(tmp_path):
    K = np.arange(12.0).reshape(2, 6)
    P = np.eye(6)
    path = tmp_path / "d.json"
    sr.write_design(path, K, P, objective="l2", gamma=0.01)
    loaded = sr.load_design(path)
    assert np.array_equal(loaded.K, K) and np.array_equal(loaded.P, P)
    assert loaded.info["objective"] == "l2" and loaded.info["gamma"] == 0.01
    # u = K_I ∫e + K_P e + K_D ė = −K x
    assert np.array_equal(np.hstack([loaded.info["K_I"], loaded.info["K_P"], loaded.info["K_D"]]), -K)


@pytest.mark.parametrize(
    ("content", "match"),
    [('{"K": [[1.0]]}', "field `format` must be"),
     ('{"format": "scara_robust design 1"}', "field `K` (the gain, a matrix) is missing"),
     ('{"format": "scara_robust design 1", "K": [[1.0, "x"]]}', "field `K` must be a table of numbers"),
     ('{"format": "scara_robust design 1", "K": [[1.0, 2.0]], "P": [[1.0]]}', "so P must be (2, 2)"),
     ('{"format": "scara_robust design 1", "K": [[NaN]]}', "finite numbers")],
    ids=["format", "missing-K", "text", "P-shape", "nan"],
)
def test_bad_design_files_name_file_and_field(tmp_path, content, match):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(sr.InputFileError, match=re.escape(match)) as info:
        sr.load_design(path)
    assert "bad.json" in str(info.value)


def test_pid_lmi_tracks_on_both_paper_scenarios():
    for scenario in ("large", "small"):
        res = sr.run_scenario("pid-lmi", scenario, t_final=7.0)
        assert res.status == "tracking", res.status_reason
        assert res.metrics().max_abs_error < 0.03


def test_pid_lmi_is_the_pid_law_with_the_shipped_gain():
    a = sr.run_scenario("pid-lmi", "small", t_final=1.0)
    b = sr.run_scenario("pid", "small", t_final=1.0, K=sr.pid_lmi_gain())
    assert np.array_equal(a.e, b.e) and np.array_equal(a.torque, b.torque)


def test_compare_adds_rows_for_design_files(capsys):
    shipped = str(sr.__file__).replace("__init__.py", PID_LMI_FILE)
    assert main(["compare", "--design", shipped, "--t-final", "6.3", "--scenario", "small", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    by_name = {r["controller"]: r for r in rows}
    assert set(by_name) == {"pid", "pid-lmi", "smc", "smc-sign", "pid:pid_lmi.json"}
    # the design file's row is the pid-lmi controller's run
    assert by_name["pid:pid_lmi.json"]["max_abs_error_after_6s"] == by_name["pid-lmi"]["max_abs_error_after_6s"]


def test_design_labels_must_not_hide_a_controller():
    with pytest.raises(sr.ArgumentValueError, match="`designs` labels must differ"):
        sr.compare_controllers(("pid",), ("small",), designs={"pid": sr.pid_lmi_gain()}, t_final=6.1)


@pytest.mark.lmi
@pytest.mark.parametrize("extra", [["--gain-bound", "1e-3"], []], ids=["tiny-bound", "default"])
def test_synthesize_writes_no_design_file_for_a_gain_it_does_not_certify(tmp_path, capsys, extra):
    """The two carts: no certified gain (here the solver's gain fails numpy's check at ‖K‖ <= 1e-3, and by
    default it decides nothing, infeasible_inaccurate): one line, exit 2, no file, no solver jargon alone."""
    out = tmp_path / "t.json"
    assert main(["synthesize", "--model", "examples/plant-two-mass.toml", *extra, "--output", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not written" in err[0], err
    honest = ("the gain is not certified", "neither an answer nor a proof that none exists", "no gain with")
    assert any(words in err[0] for words in honest) and "Try another solver" not in err[0], err
    assert not out.exists()


@pytest.mark.lmi
def test_synthesize_writes_a_design_file_that_simulate_reads(tmp_path, capsys):
    out = tmp_path / "box.json"
    assert main(["synthesize", "--model", "examples/plant-dc-motor-elements.toml", "--output", str(out)]) == 0
    text = capsys.readouterr().out
    assert "status: certified" in text and f"design file: {out}" in text and "margin" in text
    loaded = sr.load_design(out)
    assert loaded.info["set"] == "box" and loaded.info["certified"] is True
    model = sr.load_model("examples/plant-dc-motor-elements.toml")
    closed = box_closed_loops(model, loaded.K)
    lhs = np.swapaxes(closed, -1, -2) @ loaded.P + loaded.P @ closed
    assert np.linalg.eigvalsh(lhs).max() < 0  # V̇ < 0 at every corner of the box
    assert main(["simulate", "--design", str(out), "--t-final", "0.1"]) == 2  # a DC motor gain is not a SCARA gain
    assert "field `K` must have shape (2, 6)" in capsys.readouterr().err


def test_a_campaign_runs_pid_lmi(tmp_path):
    spec_file = tmp_path / "lmi.toml"
    spec_file.write_text('controllers = ["pid-lmi"]\nt_final = 6.2\nruns = 2\nseed = 3\n'
                         'payload_peak = { min = 1.0, max = 3.0 }\n')
    spec = sr.load_spec(spec_file)
    sr.run_campaign(spec, tmp_path / "r.csv")
    table = sr.read_results(tmp_path / "r.csv")
    assert list(table["controller"]) == ["pid-lmi", "pid-lmi"] and (table["status"] == "tracking").all()
    assert table["max_abs_error_after_6s"].max() < 0.05 and table["peak_torque"].min() > 0
