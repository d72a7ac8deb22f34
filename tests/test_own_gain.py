"""Your own gain on the command line: certify, margin, simulate (sampled) and export take ``--design FILE.json``.

The plant is the zero-order-hold benchmark ``q̈ = −a q̇ + b u`` in the state form, with the
textbook gain ``u = −[3.75, 11.5] x(t_k)`` (examples/plant-zoh-benchmark.toml, gain-zoh.json).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main

ROOT = Path(__file__).resolve().parents[1]
PLANT = str(ROOT / "examples" / "plant-zoh-benchmark.toml")
GAIN = str(ROOT / "examples" / "gain-zoh.json")
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")


def run(capsys, *argv):
    assert main(list(argv)) == 0, capsys.readouterr().err
    return capsys.readouterr().out


def refused(capsys, argv, text):
    assert main(list(argv)) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and text in err, err
    return err


def test_a_design_file_gives_the_margins_of_the_design_it_holds(tmp_path, capsys):
    """--design with the K and P of K(rho=1, eta=2) gives that design's margins; without P, the P-free methods agree."""
    d = sr.design(sr.load_model(MOTOR), 1.0, 2.0)
    with_p, without_p = tmp_path / "with-p.json", tmp_path / "without-p.json"
    sr.write_design(with_p, d.K, d.P)
    sr.write_design(without_p, d.K)
    common = ["margin", "--model", MOTOR, "--format", "json", "--no-payload", "--tol", "1e-4", "--tries", "2"]
    theta = {}
    for name, gain in (("design", ["--rho", "1", "--eta", "2"]), ("with-p", ["--design", str(with_p)]),
                       ("without-p", ["--design", str(without_p)])):
        rows = json.loads(run(capsys, *common, *gain))
        theta[name] = {r["method"]: r["theta"] for r in rows if r.get("anchor") == "lower"}
        theta[name + "-bracket"] = {r["method"]: (r["lo"], r["hi"]) for r in rows if r.get("anchor") == "lower"}
    for method in ("theorem1", "vertex", "lmi", "frozen"):
        assert theta["with-p"][method] == pytest.approx(theta["design"][method], rel=1e-9), method
    # the frozen scan does not use the design's P; the LMI finds its own, so the two bisections (tol 1e-4)
    # bracket the same margin
    assert theta["without-p"]["frozen"] == pytest.approx(theta["design"]["frozen"], rel=1e-9)
    (lo, hi), (lo_d, hi_d) = theta["without-p-bracket"]["lmi"], theta["design-bracket"]["lmi"]
    assert max(lo, lo_d) <= min(hi, hi_d) and hi - lo <= 1e-3 * hi


def test_certify_your_own_gain_and_its_sample_time(capsys):
    rows = json.loads(run(capsys, "certify", "--model", PLANT, "--design", GAIN, "--tries", "2", "--max-ts",
                          "--format", "json"))
    verdicts = {r["method"]: r["certified"] for r in rows if "certified" in r}
    assert verdicts["theorem1-all"] and verdicts["lmi-physical"] and verdicts["physical-polytope"]
    limit = next(r for r in rows if r["method"] == "max-ts")
    # the textbook plant (a = 0.1) loses stability at 1.7294 s; the file's damping range moves it a little
    assert 1.6 < limit["certified_ts [s]"] < limit["unstable_ts [s]"] < 1.8
    text = run(capsys, "certify", "--model", PLANT, "--design", GAIN, "--tries", "2")
    assert text.splitlines()[1].startswith(f"certificates of the gain of {GAIN!r} (P from the nominal loop's "
                                           "Lyapunov equation)")  # after the headline: its sampled-data certificate


@pytest.mark.parametrize(("ts", "status"), [("1.5", "tracking"), ("1.9", "not-tracking")])
def test_simulate_your_gain_sampled(capsys, ts, status):
    record = json.loads(run(capsys, "simulate", "--model", PLANT, "--design", GAIN, "--ts", ts, "--x0", "1,0",
                            "--t-final", "60", "--format", "json"))
    assert record["status"] == status
    force = np.array(record["series"]["force [N]"])
    assert len(np.unique(force)) <= 60 / float(ts) + 2  # held between samples


def test_export_your_static_state_feedback(tmp_path, capsys):
    out = run(capsys, "export", "--model", PLANT, "--design", GAIN, "--ts", "1.5", "--output", str(tmp_path))
    assert "static state feedback" in out and "Ts = 1.5 s is certified" in out
    header = (tmp_path / "zoh_state_feedback.h").read_text(encoding="utf-8")
    source = (tmp_path / "zoh_state_feedback.c").read_text(encoding="utf-8")
    assert "void zoh_state_feedback_step(const double x[ZOH_STATE_FEEDBACK_NX]" in header
    assert "u[0] = force [N]" in header and "3.75" in source and "11.5" in source
    # the plant's outputs are its state (no C): the controller reads them by name and unit
    assert "x[0] = position [m]" in header and "x[1] = velocity [m/s]" in header
    refused(capsys, ["export", "--model", PLANT, "--design", GAIN, "--ts", "1.8", "--output", str(tmp_path / "x")],
            "`--output`")
    (tmp_path / "x").mkdir()
    refused(capsys, ["export", "--model", PLANT, "--design", GAIN, "--ts", "1.8", "--output", str(tmp_path / "x")],
            "`--ts` Ts = 1.8 s is not certified")
    assert list((tmp_path / "x").iterdir()) == []


@pytest.mark.parametrize(("argv", "text"), [
    (["certify", "--model", PLANT, "--design", GAIN, "--rho", "1", "--eta", "2"], "`--design` gives the gain"),
    (["margin", "--model", PLANT], "give the gain: --rho and --eta"),
    (["certify", "--model", MOTOR, "--design", GAIN], "`--design` "),
    (["simulate", "--model", PLANT, "--design", GAIN], "give --x0"),
    (["simulate", "--model", PLANT, "--design", GAIN, "--x0", "1"], "`--x0` takes 2 values"),
    (["simulate", "--model", PLANT, "--design", GAIN, "--x0", "1,0", "--ts", "0"], "`--ts` must be a sample time > 0"),
    (["simulate", "--design", GAIN, "--ts", "0.1"], "`--ts` describes a run of --model's plant"),
    (["export", "--model", PLANT, "--design", GAIN, "--ts", "1", "--torque-limit", "5", "--output", "."],
     "`--torque-limit` is an option of the PID"),
], ids=["design-and-rho", "no-gain", "wrong-shape", "at-rest", "x0-count", "ts-zero", "ts-robot", "pid-option"])
def test_bad_gain_input_is_one_line(capsys, argv, text):
    refused(capsys, argv, text)
