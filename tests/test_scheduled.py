"""A gain scheduled on a measured parameter: the table, its certificate, its synthesis, the command line.

Every certificate here is re-verified by ``tests/schedule_check.py``, written from the
mathematics apart from the package's code: on a grid four times finer per segment, at both
signs of the rate and at the measurement-error corners. Above a certified rate, a periodic
ramp of the parameter that makes the loop grow closes the bracket from the other side.
"""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import subprocess

import numpy as np
import pytest
from schedule_check import schedule_condition_margin, scheduled_floquet_growth

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.exceptions import InputFileError

pytestmark = pytest.mark.lmi

ARM = "examples/plant-arm-payload.toml"


@pytest.fixture(scope="module")
def arm():
    """The one-joint arm whose payload m (0-2 kg) is measured within 0.05 kg, changing at up to 1 kg/s."""
    plant = sr.load_plant(ARM)
    params = tuple(dataclasses.replace(p, rate=1.0) if p.name == "m" else p for p in plant.parameters)
    return dataclasses.replace(plant, parameters=params)


@pytest.fixture(scope="module")
def oscillator():
    """A spring of stiffness k in [1, 9] (rad/s)² with little damping: fast changes of k pump energy in."""
    k = sr.Parameter("k", "1/s²", (1.0, 9.0), measured=True)
    return sr.UncertainPlant.from_expressions([k], [[0, 1], ["-k", -0.05]], [[0], [1]], form="state",
                                              name="oscillator")


# --- the table ------------------------------------------------------------------------------


def test_gain_is_linear_between_breakpoints_and_clamped_outside():
    g = sr.ScheduledGain("m", "kg", [0.0, 1.0, 3.0], [[[0.0, 2.0]], [[2.0, 2.0]], [[6.0, -2.0]]])
    np.testing.assert_allclose(g(0.5), [[1.0, 2.0]])
    np.testing.assert_allclose(g(2.0), [[4.0, 0.0]])
    np.testing.assert_allclose(g(-1.0), g(0.0))
    np.testing.assert_allclose(g(7.0), g(3.0))
    assert g.clamped(-0.1) and g.clamped(3.1) and not g.clamped(3.0)
    np.testing.assert_allclose(g(np.array([0.5, 2.0])), np.stack([g(0.5), g(2.0)]))
    assert g.max_norm == pytest.approx(np.linalg.norm([6.0, -2.0]))


def test_schedule_file_round_trip(tmp_path):
    g = sr.ScheduledGain("m", "kg", [0.0, 2.0], np.arange(12.0).reshape(2, 2, 3), "lmi",
                         {"rate": math.inf, "decay": 0.5})
    path = tmp_path / "s.json"
    g.save(path)
    back = sr.load_schedule(path)
    np.testing.assert_array_equal(back.gains, g.gains)
    np.testing.assert_array_equal(back.breakpoints, g.breakpoints)
    assert back.certified == {"rate": "inf", "decay": 0.5} and back.method == "lmi"
    assert back.recorded("rate") == math.inf and back.recorded("decay") == 0.5 and back.recorded("range") is None


@pytest.mark.parametrize(("content", "message"), [
    ('{"kind": "design"}', "field `kind` must be 'scheduled-gain'"),
    ('{"kind": "scheduled-gain", "unit": "kg"}', "missing field `parameter`"),
    ('{"kind": "scheduled-gain", "parameter": "m", "unit": "kg", "breakpoints": [1, 0], "gains": [[[1]], [[2]]]}',
     "`breakpoints` must be at least 2 strictly increasing values"),
    ("{", "not valid JSON"),
])
def test_bad_schedule_files_are_named(tmp_path, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(InputFileError, match=message) as err:
        sr.load_schedule(path)
    assert "bad.json" in str(err.value)


def test_measured_parameters_in_a_plant_file(tmp_path):
    plant = sr.load_plant(ARM)
    m = plant.parameter("m")
    assert plant.measured == (m,) and m.measurement_error == 0.05 and m.effective_error == 0.05
    delayed = dataclasses.replace(m, rate=2.0, measurement_delay=0.1)
    assert delayed.effective_error == pytest.approx(0.05 + 2.0 * 0.1)
    text = open(ARM, encoding="utf-8").read()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("measured = true", "measured = false"))
    with pytest.raises(InputFileError, match=r"field `parameters.m.measurement_error` describes a measured"):
        sr.load_plant(bad)
    bad.write_text(text.replace("measurement_error = 0.05", "measurement_error = -1"))
    with pytest.raises(InputFileError, match=r"m.measurement_error"):
        sr.load_plant(bad)


# --- the certificate ------------------------------------------------------------------------


def test_riccati_schedule_is_certified_and_the_independent_check_agrees(arm):
    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 5), 1.0, 10.0)
    for K, m in zip(gain.gains, gain.breakpoints):  # each entry is the paper's design on the frozen plant
        frozen = sr.load_plant(ARM)
        frozen = dataclasses.replace(frozen, parameters=tuple(
            dataclasses.replace(p, range=(m, m), nominal=None, measured=False, measurement_error=0.0)
            if p.name == "m" else p for p in frozen.parameters))
        np.testing.assert_allclose(K, sr.design(frozen, 1.0, 10.0).K, rtol=1e-12)
    cert = sr.schedule_certificate(arm, gain, decay=0.3)
    assert cert.certified and cert.rate == 1.0 and cert.measurement_error == 0.05
    check = schedule_condition_margin(arm, "m", gain.breakpoints, gain.gains, cert.P, rate=1.0, delta=0.05,
                                      decay=0.3, refine=4)
    assert check["max_eig"] < 0 and check["min_P_eig"] > 0


def test_a_constant_table_at_any_rate_is_the_common_p_test(arm):
    K = sr.design(arm, 1.0, 10.0).K
    table = sr.ScheduledGain("m", "kg", [0.0, 2.0], np.stack([K, K]), "fixed")
    cert = sr.schedule_certificate(arm, table, rate=math.inf, measurement_error=0.0)
    samples = arm.samples()
    common = sr.lmi_certificate(samples.closed_loops(K))
    assert cert.certified == common.certified
    np.testing.assert_allclose(cert.P[0], cert.P[1])  # one P


def test_certified_rate_is_bracketed_by_a_growing_ramp(oscillator):
    """Above the largest certified rate, a periodic ramp of k makes the loop grow; at or below it, none does."""
    gain = sr.ScheduledGain("k", "1/s²", [1.0, 5.0, 9.0], np.array([[[0.0, 0.3]]] * 3), "fixed")
    rate, cert = sr.max_schedule_rate(oscillator, gain, measurement_error=0.0, tol=0.05)
    assert 0 < rate < math.inf and cert is not None and cert.certified
    check = schedule_condition_margin(oscillator, "k", gain.breakpoints, gain.gains, cert.P, rate=rate, delta=0.0)
    assert check["max_eig"] < 0 and check["min_P_eig"] > 0
    rates = np.geomspace(rate / 4, 100 * rate, 60)
    growth = np.array([scheduled_floquet_growth(oscillator, "k", gain.breakpoints, gain.gains, r) for r in rates])
    assert np.all(growth[rates <= rate] < 0)  # the certificate's promise, checked from outside
    assert growth.max() > 0  # and a growing signal above: the answer is a bracket
    assert rates[np.argmax(growth > 0)] > rate


def test_a_search_starts_each_certificate_from_the_last_active_conditions(arm):
    """A certificate started from another's active conditions is the same proof, verified as strictly."""
    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 5), 1.0, 10.0)
    first = sr.schedule_certificate(arm, gain, decay=0.3)
    assert first.certified and first.active_conditions is not None
    assert first.active_conditions.size == first.active <= first.conditions
    again = sr.schedule_certificate(arm, gain, decay=0.31, start_conditions=[*first.active_conditions, 10**6])
    assert again.certified and set(first.active_conditions) <= set(again.active_conditions)
    check = schedule_condition_margin(arm, "m", gain.breakpoints, gain.gains, again.P, rate=1.0, delta=0.05,
                                      decay=0.31, refine=4)
    assert check["max_eig"] < 0 and check["min_P_eig"] > 0


def test_a_search_takes_a_known_certificate_as_its_first_test(arm, monkeypatch):
    """certify computes the certificate at the plant's bounds first: the decay search's first test (α = 0) is it."""
    import scara_robust.robustness.scheduled as scheduled

    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 3), 1.0, 10.0)
    known = sr.schedule_certificate(arm, gain)
    assert known.certified and known.decay == 0.0 and known.rate == 1.0 and known.measurement_error == 0.05
    calls = []
    counted = scheduled.schedule_certificate

    def counting(*args, **kwargs):
        calls.append(kwargs.get("decay", 0.0))
        return counted(*args, **kwargs)

    monkeypatch.setattr(scheduled, "schedule_certificate", counting)
    alone = sr.schedule_decay(arm, gain, tol=0.1)
    n_alone = len(calls)
    calls.clear()
    reused = sr.schedule_decay(arm, gain, tol=0.1, known=known)
    assert reused[0] == alone[0] > 0 and len(calls) == n_alone - 1 and 0.0 not in calls
    assert reused[1] is not None and reused[1].certified and reused[1].decay == reused[0]
    # a certificate at another decay is not the first test; one that failed answers it
    other = sr.schedule_certificate(arm, gain, decay=0.1)
    calls.clear()
    assert sr.schedule_decay(arm, gain, tol=0.1, known=other)[0] == sr.schedule_decay(arm, gain, tol=0.1)[0]
    assert calls[0] == 0.0  # its first test was made, at α = 0
    failed = dataclasses.replace(known, status="not verified")
    calls.clear()
    assert sr.schedule_decay(arm, gain, tol=0.1, known=failed) == (0.0, None) and not calls


def test_a_certificate_s_p_holds_up_to_the_decay_its_check_gives_in_closed_form(arm):
    """The decay search answers tests below a P's reach without an LMI: that reach is the check's exact limit."""
    from scara_robust.robustness import scheduled
    from scara_robust.robustness.search import bisect

    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 3), 1.0, 10.0)
    cert = sr.schedule_certificate(arm, gain, decay=0.1)
    assert cert.certified
    fine = scheduled._conditions(scheduled._grid(arm, "m", gain.breakpoints, 9, scheduled._others(arm, "m", True)),
                                 gain, cert.measurement_error, True)
    reach = scheduled._decay_reach(fine, gain, cert)
    extended = reach(math.inf)
    assert extended is not None and extended.certified and extended.decay > cert.decay
    size = max(np.linalg.norm(Pj, 2) for Pj in cert.P)

    def margin(alpha):  # the certificate's own check, at another decay
        return scheduled._max_eigs(scheduled._lhs(fine, cert.P, gain.breakpoints, cert.rate, alpha), size).max()

    assert margin(extended.decay) < 0 < margin(extended.decay * (1 + 1e-4))  # the limit, to its 1e-6 back-off
    assert extended.margin == margin(extended.decay)
    # the search's answer is the plain bisection's, on fewer LMIs, and an independent finer check holds there
    calls = []
    counted = scheduled.schedule_certificate

    def counting(*args, **kwargs):
        calls.append(kwargs.get("decay", 0.0))
        return counted(*args, **kwargs)

    top = max(float(-np.linalg.eigvals(g.A - g.B @ gain.gain(g.p)).real.max()) for g in [scheduled._grid(
        arm, "m", gain.breakpoints, 2, scheduled._others(arm, "m", False))])
    plain_calls = []

    def plain(alpha):
        plain_calls.append(alpha)
        return sr.schedule_certificate(arm, gain, decay=alpha).certified

    expected, _ = bisect(plain, 0.0, top, 0.05)
    scheduled.schedule_certificate = counting
    try:
        decay, found = sr.schedule_decay(arm, gain, tol=0.05)
    finally:
        scheduled.schedule_certificate = counted
    assert decay == expected and found is not None and found.certified and found.decay == decay
    # its probe below the frozen bound failed here (one LMI more); a P's reach answered a test (one less)
    assert len(calls) <= len(plain_calls) + 1 and set(plain_calls) - set(calls)
    # an independent check on the certificate's own grid (9 points a segment, the other parameters' samples)
    others = {p.name: p.samples for p in arm.varying if p.name != "m"}
    check = schedule_condition_margin(arm, "m", gain.breakpoints, gain.gains, found.P, rate=1.0, delta=0.05,
                                      decay=decay, refine=2, other_points=others)
    assert check["max_eig"] < 0


def test_measurement_error_is_covered_at_its_corners(arm):
    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 3), 1.0, 10.0)
    cert = sr.schedule_certificate(arm, gain, measurement_error=0.4, decay=0.2)
    assert cert.certified
    check = schedule_condition_margin(arm, "m", gain.breakpoints, gain.gains, cert.P, rate=1.0, delta=0.4,
                                      decay=0.2)
    assert check["max_eig"] < 0


def test_bad_arguments_are_named(arm):
    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 3), 1.0, 10.0)
    short = sr.ScheduledGain("m", "kg", [0.0, 1.0], gain.gains[:2])
    with pytest.raises(ValueError, match="`gain` its breakpoints must span m's range"):
        sr.schedule_certificate(arm, short)
    with pytest.raises(ValueError, match="`parameter` must be one of"):
        sr.schedule_riccati(arm, "J0", [0.0, 2.0], 1.0, 10.0)
    with pytest.raises(ValueError, match="`measurement_error` must be >= 0"):
        sr.schedule_certificate(arm, gain, measurement_error=-0.1)
    with pytest.raises(ValueError, match="`breakpoints` must lie in m's range"):
        sr.synthesize_schedule(arm, [0.0, 3.0])


# --- the synthesis --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def synthesized(arm):
    return sr.synthesize_schedule(arm, np.linspace(0, 2, 5), gain_bound=20.0)


def test_synthesis_does_at_least_what_the_best_fixed_gain_does(arm, synthesized):
    """The scheduled LMI holds the fixed gain's solution, so its decay is no smaller, at the same ‖K‖ bound."""
    assert synthesized.certified and synthesized.gain.max_norm <= 20.0 * (1 + 1e-6)
    coarse, fine = arm.samples(arm.coarse_points()), arm.samples()
    fixed = sr.synthesize((coarse.A, coarse.B), objective="decay", gain_bound=20.0, check=(fine.A, fine.B))
    table = sr.ScheduledGain("m", "kg", [0.0, 2.0], np.stack([fixed.K, fixed.K]), "fixed")
    fixed_decay, _ = sr.schedule_decay(arm, table, tol=0.01)
    assert synthesized.decay >= fixed_decay * (1 - 0.03)  # both to their bisections' tolerances


def test_synthesized_table_is_verified_independently(arm, synthesized):
    g, cert = synthesized.gain, synthesized.certificate
    assert cert.decay == synthesized.decay and g.certified["rate"] == 1.0
    check = schedule_condition_margin(arm, "m", g.breakpoints, g.gains, cert.P, rate=1.0, delta=0.05,
                                      decay=synthesized.decay, refine=4)
    assert check["max_eig"] < 0 and check["min_P_eig"] > 0


# --- the command line -----------------------------------------------------------------------


def test_synthesize_writes_a_schedule_that_certify_reads(tmp_path, capsys):
    out = tmp_path / "schedule.json"
    assert main(["synthesize", "--model", ARM, "--schedule", "m", "--breakpoints", "3", "--rate", "1",
                 "--gain-bound", "20", "--output", str(out)]) == 0
    text = capsys.readouterr().out
    assert "status: certified" in text and f"schedule file: {out}" in text
    saved = json.loads(out.read_text())
    assert saved["kind"] == "scheduled-gain" and saved["breakpoints"] == [0.0, 1.0, 2.0]
    assert main(["certify", "--model", ARM, "--design", str(out), "--rate", "1", "--format", "json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["certified"] and record["rate"] == 1.0 and record["measurement_error"] == 0.05
    assert record["decay"] >= 0.99 * saved["certified"]["decay"]


@pytest.mark.parametrize(("argv", "message"), [
    (["synthesize", "--model", ARM, "--schedule", "J0"], "`--schedule` must be one of"),
    (["synthesize", "--model", ARM, "--schedule", "m", "--breakpoints", "0,x"], "`--breakpoints` must be a count"),
    (["synthesize", "--model", ARM, "--schedule", "m", "--rate", "-1"], "`--rate` must be >= 0"),
    (["synthesize", "--model", ARM, "--rate", "1"], "`--rate` describes a scheduled gain"),
])
def test_bad_schedule_options_exit_2_in_one_line(argv, message, capsys, tmp_path):
    assert main([*argv, "--output", str(tmp_path / "never.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "never.json").exists()


# --- the export -----------------------------------------------------------------------------

CC = shutil.which("cc")

_MAIN = r"""
#include <stdio.h>
#include <stdlib.h>
#include "sched.h"

int main(void)
{
    double v[SCHED_NX + 1];
    REAL x[SCHED_NX], u[SCHED_NU];
    int i, flag;
    for (;;) {
        for (i = 0; i < SCHED_NX + 1; ++i) {
            if (scanf("%lf", &v[i]) != 1) {
                return 0;
            }
        }
        for (i = 0; i < SCHED_NX; ++i) {
            x[i] = (REAL)v[i];
        }
        flag = sched_step(x, (REAL)v[SCHED_NX], u);
        for (i = 0; i < SCHED_NU; ++i) {
            printf("%.17g ", (double)u[i]);
        }
        printf("%d\n", flag);
    }
}
"""


@pytest.mark.skipif(CC is None, reason="no C compiler `cc` on this machine: the exported C is not compiled")
@pytest.mark.parametrize("precision", ["double", "single"])
def test_exported_schedule_equals_the_python_step(tmp_path, precision):
    """10⁴ random (state, p̂) pairs, p̂ also outside the breakpoints and NaN: to 1e-12 in double, bitwise in float32."""
    rng = np.random.default_rng(1)
    gain = sr.ScheduledGain("m_p", "kg", [0.0, 0.4, 1.1, 2.07], rng.normal(scale=50.0, size=(4, 2, 6)), "lmi",
                            {"rate": 1.0, "measurement_error": 0.05})
    ctrl = sr.SampledScheduledGain(gain, 1e-3)
    files = sr.export_controller(ctrl, tmp_path, prefix="sched", precision=precision,
                                 outputs=[sr.Signal("tau1", "N·m"), sr.Signal("tau2", "N·m")])
    header = files[0].read_text()
    ctype = "float" if precision == "single" else "double"
    assert f"int sched_step(const {ctype} x[SCHED_NX], {ctype} p_hat, {ctype} u[SCHED_NU]);" in header
    assert "rate = 1.0" in header and "measurement_error = 0.05" in header and "u[1] = tau2 [N·m]" in header
    (tmp_path / "main.c").write_text(_MAIN.replace("REAL", ctype))
    exe = tmp_path / "sched"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off", "-o",
                    str(exe), str(tmp_path / "main.c"), str(files[1])], check=True, capture_output=True, text=True,
                   timeout=120)
    x = rng.normal(size=(10_000, 6))
    p_hat = rng.uniform(-0.5, 2.6, size=10_000)
    p_hat[::97] = np.nan
    p_hat[::101] = gain.breakpoints[rng.integers(0, 4, size=p_hat[::101].size)]  # exactly on a breakpoint
    if precision == "single":
        x, p_hat = x.astype(np.float32).astype(float), p_hat.astype(np.float32).astype(float)
    lines = "\n".join(" ".join(repr(float(v)) for v in (*row, p)) for row, p in zip(x, p_hat))
    out = subprocess.run([str(exe)], input=lines, check=True, capture_output=True, text=True, timeout=120).stdout
    result = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    u_c, flags = result[:, :2], result[:, 2].astype(bool)
    step = ctrl.step_single if precision == "single" else ctrl.step
    expected = [step(row, p) for row, p in zip(x, p_hat)]
    u_py = np.array([u for u, _ in expected], dtype=float)
    assert result.shape == (10_000, 3)
    assert flags.tolist() == [c for _, c in expected] and flags.sum() > 1000
    if precision == "single":
        assert np.array_equal(u_c.astype(np.float32), u_py.astype(np.float32))
    else:
        assert np.abs(u_c - u_py).max() <= 1e-12 * np.abs(u_py).max()
    # and the table is the ScheduledGain's: the Python step is K(p̂) x, clamped
    inside = ~np.isnan(p_hat)
    reference = -np.einsum("kij,kj->ki", gain.gain(p_hat[inside]), x[inside])
    np.testing.assert_allclose(u_py[inside], reference, rtol=1e-5 if precision == "single" else 1e-12,
                               atol=1e-3 if precision == "single" else 1e-9)


def test_sampled_certificate_of_the_schedule_brackets_ts(arm):
    """Certified at a small Ts with one discrete P (re-verified on a finer grid); refused where a frozen loop fails."""
    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 3), 1.0, 10.0)
    fast = sr.schedule_sampled_certificate(arm, gain, 1e-3)
    assert fast.certified and fast.P is not None
    # the frozen sampled loops at the grid's p and p̂ corners, computed here directly: all Schur stable
    plant_A, plant_B = arm.design_form(*arm.plant_matrices(np.array([[m if n == "m" else arm.nominal[n]
                                                                      for n in arm.names] for m in (0.0, 0.95, 2.0)])))
    for A, B, p_hat in zip(plant_A, plant_B, (0.05, 0.9, 1.95)):
        closed = sr.sampled_closed_loops(A[None], (B @ gain(p_hat))[None], sr.SampledStateFeedback(np.eye(3), 1e-3))
        assert np.abs(np.linalg.eigvals(closed[0])).max() < 1
    slow = sr.schedule_sampled_certificate(arm, gain, 1.0)
    assert not slow.certified


def test_export_of_a_schedule_is_refused_beyond_its_certificate(tmp_path, capsys, arm):
    schedule = tmp_path / "s.json"
    assert main(["synthesize", "--model", ARM, "--schedule", "m", "--breakpoints", "3", "--rate", "1",
                 "--gain-bound", "20", "--output", str(schedule)]) == 0
    capsys.readouterr()
    out = tmp_path / "c"
    out.mkdir()
    base = ["export", "--model", ARM, "--design", str(schedule), "--ts", "0.001", "--output", str(out)]
    # a Ts the sampled-data certificate refuses
    assert main([*base[:-4], "--rate", "1", "--ts", "1.0", "--output", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a frozen sampled loop is unstable" in err[0] and "nothing written" in err[0], err
    assert list(out.iterdir()) == []
    assert main([*base, "--rate", "1"]) == 0  # what the file's certificate covers
    header = (out / "arm_pid_scheduled.h").read_text()
    assert "int arm_pid_scheduled_step(const double x[ARM_PID_SCHEDULED_NX], double p_hat" in header
    assert "WARNING" not in header and "measurement_error = 0.05" in header and "x[1] = angle error [rad]" in header
    # beyond the file's record (rate 1 kg/s, 0.05 kg) the certificate certify gives is computed: here it holds
    gain = sr.load_schedule(schedule)
    for rate, error in ((2.0, 0.05), (1.0, 0.1)):
        assert sr.schedule_certificate(arm, gain, rate=rate, measurement_error=error).certified
        assert main([*base, "--rate", f"{rate:g}", "--measurement-error", f"{error:g}"]) == 0
        said = capsys.readouterr().out
        assert f"certified for rate {rate:g} kg/s and measurement error {error:g} kg" in said
        assert "WARNING" not in (out / "arm_pid_scheduled.h").read_text()
    # a schedule no P certifies (positive feedback at the heavy end): refused, or written with a warning
    bad = sr.ScheduledGain("m", "kg", gain.breakpoints, np.concatenate([gain.gains[:-1], -gain.gains[-1:]]))
    bad_file = tmp_path / "bad.json"
    bad.save(bad_file)
    empty = tmp_path / "e"
    empty.mkdir()
    argv = ["export", "--model", ARM, "--design", str(bad_file), "--ts", "0.001", "--rate", "1", "--output", str(empty)]
    assert not sr.schedule_certificate(arm, bad, rate=1.0, measurement_error=0.05).certified
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "at rate 1 kg/s and measurement error 0.05 kg" in err[0] and "nothing written" in err[0]
    assert list(empty.iterdir()) == []
    assert main([*argv, "--allow-uncertified", "--precision", "single"]) == 0
    header = (empty / "arm_pid_scheduled.h").read_text()
    assert "WARNING: NOT CERTIFIED as asked (at rate 1 kg/s" in header and "float p_hat" in header


def test_simulate_runs_a_schedule_file_with_a_measurement_bias(tmp_path, capsys, arm):
    schedule = tmp_path / "s.json"
    gain = sr.schedule_riccati(arm, "m", np.linspace(0, 2, 3), 1.0, 10.0)
    gain.save(schedule)
    argv = ["simulate", "--model", ARM, "--design", str(schedule), "--parameter", "m", "--profile", "constant:1.7",
            "--t-final", "12", "--format", "json"]
    runs = {}
    for bias in ("0", "0.05"):
        assert main([*argv, "--measurement-bias", bias]) == 0
        runs[bias] = json.loads(capsys.readouterr().out)
    # the same run in Python: the controller sees 1.75 kg where the payload is 1.7 kg
    plant = sr.load_plant(ARM)
    direct = sr.simulate_plant(plant, gain, profiles={"m": sr.parameter_profile(plant, "m", "constant", value=1.7)},
                               t_final=12.0, measurement_bias=0.05)
    assert runs["0.05"]["max_abs_error"] == pytest.approx(direct.max_abs_error, rel=1e-9)
    assert runs["0.05"]["max_abs_error"] != runs["0"]["max_abs_error"]
    assert main(["simulate", "--model", ARM, "--rho", "1", "--eta", "10", "--measurement-bias", "0.05"]) == 2
    assert "`--measurement-bias` is the error of a scheduled gain's measurement" in capsys.readouterr().err


def test_compare_puts_the_schedule_beside_the_best_fixed_gain(tmp_path, capsys):
    schedule = tmp_path / "s.json"
    assert main(["synthesize", "--model", ARM, "--schedule", "m", "--breakpoints", "3", "--rate", "1",
                 "--gain-bound", "20", "--output", str(schedule)]) == 0
    capsys.readouterr()
    assert main(["compare", "--model", ARM, "--design", str(schedule), "--rate", "1", "--t-final", "12",
                 "--format", "json"]) == 0
    rows = {row["gain"]: row for row in json.loads(capsys.readouterr().out)}
    fixed, scheduled = rows["best fixed gain (synthesize, ||K|| <= 20)"], rows["schedule s.json"]
    assert fixed["max ‖K_j‖"] <= 20 * (1 + 1e-6) and scheduled["max ‖K_j‖"] <= 20 * (1 + 1e-6)
    assert scheduled["decay [1/s]"] > fixed["decay [1/s]"]  # under the same bound, rate and error
    for row in (fixed, scheduled):
        assert row["certified range [kg]"] == "0-2" and row["ramp: status"] in sr.STATUSES
        assert row["ramp: peak |u| [N·m]"] > 0


def test_a_profile_evaluates_a_time_array_as_its_samples(arm):
    """The SCARA's runs call the payload on the whole output grid at once."""
    t = np.linspace(-1.0, 5.0, 13)
    for kind in ("constant", "ramp", "sinusoid", "random-walk"):
        profile = sr.parameter_profile(arm, "m", kind, t_final=5.0)
        np.testing.assert_array_equal(profile(t), [profile(float(tk)) for tk in t])
        assert isinstance(profile(1.0), float)


def test_the_scara_compare_runs_read_the_gain_at_the_measured_payload():
    """scara_schedule_run: the scheduled PID on the nonlinear SCARA, its measurement `bias` off."""
    K = sr.design(sr.paper_model(), 3, 90).K
    table = sr.ScheduledGain("m_p", "kg", [0.0, 2.07], np.stack([K, 0.5 * K]))
    ramp = sr.parameter_profile(sr.scara_uncertain_plant(n_times=5, n_masses=2, payload_rate=1.0), "m_p", "ramp")
    run = sr.scara_schedule_run("small", 8.0)
    row = run(table, ramp, 0.05)
    direct = sr.simulate(sr.scheduled_pid_controller(table, ramp, measurement_bias=0.05), "small", payload=ramp,
                         t_final=8.0)
    assert row == {"status": direct.status, "max |e| after 6 s [rad]": direct.metrics().max_abs_error,
                   "peak |τ| [N·m]": direct.peak_torque}
    assert run(table, ramp, 0.0)["max |e| after 6 s [rad]"] != row["max |e| after 6 s [rad]"]


@pytest.mark.robots
def test_an_arm_runs_a_scheduled_gain(tmp_path, capsys):
    """simulate_arm with a ScheduledGain: a constant table is the fixed gain; the law reads K(m_p(t) + bias)."""
    from test_arm_compiled import small_arm_file

    setup = sr.load_arm(small_arm_file(tmp_path))
    K = sr.design(setup.plant, 1000, 10).K
    ramp = sr.parameter_profile(setup.plant, "m_p", "ramp", t_final=8.0)
    fixed = sr.simulate_arm(setup, K, ramp, t_final=8.0)
    constant = sr.simulate_arm(setup, sr.ScheduledGain("m_p", "kg", [0.0, 3.0], np.stack([K, K])), ramp, t_final=8.0)
    # (1 − s)K + sK rounds differently from K in the last bit; the adaptive steps carry it to ~1e-8 rad
    np.testing.assert_allclose(constant.e, fixed.e, rtol=0, atol=1e-6)
    table = sr.ScheduledGain("m_p", "kg", [0.0, 3.0], np.stack([K, 0.6 * K]))
    # a payload held at 1.2 kg measured 0.05 kg off: the law is the fixed gain K(1.25 kg)
    held = sr.parameter_profile(setup.plant, "m_p", "constant", value=1.2)
    run = sr.simulate_arm(setup, table, held, t_final=8.0, measurement_bias=0.05)
    at = sr.simulate_arm(setup, table.gain(1.25), held, t_final=8.0)
    np.testing.assert_allclose(run.e, at.e, rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.torque, at.torque, rtol=0, atol=1e-9)
    # K(1.2 kg), the gain at the true payload, runs measurably apart (7.9e-6 rad here)
    assert np.abs(run.e - sr.simulate_arm(setup, table.gain(1.2), held, t_final=8.0).e).max() > 1e-6
    run = sr.simulate_arm(setup, table, ramp, t_final=8.0, measurement_bias=0.05)
    row = sr.arm_schedule_run(setup, 8.0)(table, ramp, 0.05)
    assert row["max |e| after 6 s [rad]"] == run.metrics().max_abs_error
    # the command line: simulate --robot F --design SCHEDULE.json --measurement-bias
    schedule = tmp_path / "arm-schedule.json"
    table.save(schedule)
    argv = ["simulate", "--robot", str(tmp_path / "arm.toml"), "--design", str(schedule), "--profile", "ramp",
            "--t-final", "8", "--format", "json"]
    assert main([*argv, "--measurement-bias", "0.05"]) == 0
    assert json.loads(capsys.readouterr().out)["max_abs_error"] == run.metrics().max_abs_error
    assert main([*argv, "--measurement-bias", "0.05", "--method", "compiled"]) == 0
    assert json.loads(capsys.readouterr().out)["max_abs_error"] == pytest.approx(run.metrics().max_abs_error,
                                                                                rel=1e-5)
    # the compiled engine interpolates the same table in machine code: continuous and held
    pytest.importorskip("numba", reason="the compiled engine: pip install '.[compiled]'")
    fast = sr.simulate_arm(setup, table, ramp, t_final=8.0, measurement_bias=0.05, method="compiled")
    np.testing.assert_allclose(fast.e, run.e, rtol=0, atol=1e-6)
    held = [sr.simulate_arm(setup, table, ramp, t_final=3.0, measurement_bias=0.05, method=m, Ts=1e-3,
                         torque_limit=np.inf)  # (this held loop diverges: no limit, as the engines are compared)
            for m in ("compiled", "rk4")]
    np.testing.assert_allclose(held[0].torque, held[1].torque, rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="`measurement_bias` goes with a scheduled gain"):
        sr.simulate_arm(setup, K, ramp, measurement_bias=0.1)
    with pytest.raises(ValueError, match=r"`K` must schedule gains of shape \(6, 18\)"):
        sr.simulate_arm(setup, sr.ScheduledGain("m_p", "kg", [0.0, 3.0], np.zeros((2, 1, 3))), ramp)
    with pytest.raises(ValueError, match=r"on its payload m_p, found \(6, 18\) on 'm'"):
        sr.simulate_arm(setup, sr.ScheduledGain("m", "kg", [0.0, 3.0], np.stack([K, K])), ramp)


@pytest.mark.robots
def test_a_robot_file_measures_its_payload(tmp_path):
    from test_arm_compiled import small_arm_file

    path = small_arm_file(tmp_path)
    m_p = sr.load_arm(path).plant.parameter("m_p")
    assert m_p.measured and m_p.measurement_error == 0.05 and m_p.rate == 1.0
    text = open(path, encoding="utf-8").read()
    unmeasured = tmp_path / "unmeasured.toml"
    unmeasured.write_text(text.replace("payload_measurement_error = 0.05", ""))
    assert not sr.load_arm(unmeasured).plant.parameter("m_p").measured
    unmeasured.write_text(text.replace("payload_measurement_error = 0.05", "payload_measurement_delay = 0.1"))
    with pytest.raises(InputFileError, match="`robot.payload_measurement_delay` describes a measured payload"):
        sr.load_arm(unmeasured)
    unmeasured.write_text(text.replace("payload_measurement_error = 0.05", "payload_measurement_error = -1"))
    with pytest.raises(InputFileError, match=r"`robot.payload_measurement_error` \[kg\] must be >= 0"):
        sr.load_arm(unmeasured)


def test_the_scara_pid_scheduled_on_its_payload():
    """A constant table runs exactly as the fixed PID; the law reads K at the measured payload m_p(t) + bias."""
    K = sr.design(sr.paper_model(), 3, 90).K
    pay = sr.SinusoidalPayload(1.0, 1.0, 0.5, 0.0)
    constant = sr.ScheduledGain("m_p", "kg", [0.0, 2.07], np.stack([K, K]))
    runs = [sr.simulate(c, "small", payload=pay, t_final=7.0)
            for c in (sr.pid_controller(K), sr.scheduled_pid_controller(constant, pay))]
    # (1 − s)K + sK rounds differently from K in the last bit; the adaptive steps carry it to ~1e-11 rad
    np.testing.assert_allclose(runs[1].e, runs[0].e, rtol=0, atol=1e-8)
    ramp = sr.ScheduledGain("m_p", "kg", [0.0, 2.07], np.stack([K, 2 * K]))
    ctrl = sr.scheduled_pid_controller(ramp, pay, measurement_bias=0.1)
    x, u = np.array([0.1, -0.2]), np.array([0.3, 0.1, -0.5, 0.2])
    t = 1.3
    ref = sr.paper_reference()
    state = np.concatenate([x, ref.position(t) - u[:2], ref.velocity(t) - u[2:]])
    np.testing.assert_allclose(ctrl.output(t, x, u), -ramp.gain(pay(t) + 0.1) @ state, rtol=1e-14)
    with pytest.raises(ValueError, match="`gain` must be a ScheduledGain of \\(2, 6\\) gains"):
        sr.scheduled_pid_controller(sr.ScheduledGain("m", "kg", [0, 1], np.zeros((2, 1, 3))), pay)


def test_compare_on_a_robot_refuses_what_a_schedule_comparison_cannot_mean(tmp_path, capsys):
    """One line and exit 2, before any certificate is computed."""
    K = sr.design(sr.paper_model(), 3, 90).K
    scara = tmp_path / "scara.json"
    sr.ScheduledGain("m_p", "kg", [0.0, 2.07], np.stack([K, K])).save(scara)
    one_joint = tmp_path / "one.json"
    sr.ScheduledGain("m", "kg", [0.0, 2.0], np.zeros((2, 1, 3))).save(one_joint)
    cases = {
        ("--design", str(scara), "--profile", "ramp"): "`--profile`: a schedule is compared with the payload ramping",
        ("--design", str(scara), "--payload", "off"): "`--payload`: a schedule is compared with the payload moving",
        ("--design", str(scara), "--design", str(scara)): "`--design`: give one schedule file, and at most one",
        ("--design", str(one_joint)): "schedules 'm' with gains of shape (1, 3), not a gain of",
        ("--rate", "1"): "`--rate` describes a scheduled gain; it goes with --design SCHEDULE.json",
    }
    for argv, message in cases.items():
        assert main(["compare", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1 and "Traceback" not in err, err


def test_simulate_runs_the_scara_on_a_schedule_file(tmp_path, capsys):
    """simulate --design SCHEDULE.json on the SCARA: the same run as scheduled_pid_controller in Python."""
    K = sr.design(sr.paper_model(), 3, 90).K
    path = tmp_path / "scara.json"
    table = sr.ScheduledGain("m_p", "kg", [0.0, 2.07], np.stack([K, 0.5 * K]))
    table.save(path)
    argv = ["simulate", "--design", str(path), "--scenario", "small", "--t-final", "8", "--format", "json"]
    assert main([*argv, "--measurement-bias", "0.1"]) == 0
    record = json.loads(capsys.readouterr().out)
    pay = sr.paper_payload()
    direct = sr.simulate(sr.scheduled_pid_controller(table, pay, measurement_bias=0.1), "small", payload=pay,
                         t_final=8.0)
    assert record["controller"] == "pid-scheduled" and record["measurement_bias"] == 0.1
    assert record["metrics"]["max_abs_error_after_6s"] == direct.metrics().max_abs_error
    assert main([*argv, "--payload", "off"]) == 0
    off = json.loads(capsys.readouterr().out)
    assert off["series"]["m_p"][-1] == 0.0 and off["status"] in sr.STATUSES
    for extra, message in ((["--controller", "smc"], "it goes with --controller pid, found 'smc'"),
                           (["--measurement-bias", "nan"], "`--measurement-bias`")):
        assert main([*argv, *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err
    assert main(["simulate", "--measurement-bias", "0.05"]) == 2
    assert "it goes with --design SCHEDULE.json" in capsys.readouterr().err


@pytest.mark.robots
def test_the_example_schedule_is_the_six_joint_arm_s():
    """examples/arm6-schedule.json: the guide's 6-joint arm schedule, on the arm of examples/robot-arm6.toml."""
    gain = sr.load_schedule("examples/arm6-schedule.json")
    plant = sr.load_arm("examples/robot-arm6.toml").plant
    assert gain.parameter == "m_p" and gain.shape == (plant.n_inputs, plant.n_design_states) == (6, 18)
    assert gain.range == plant.parameter("m_p").range == (0.0, 3.0)
    record = gain.certified
    assert (record["rate"], record["measurement_error"], record["plant"]) == (1.0, 0.05, plant.name)
    assert gain.max_norm <= record["gain_bound"]


@pytest.mark.slow
@pytest.mark.robots
def test_the_example_schedule_s_certificate_holds():
    """Its recorded certificate re-verified (about a minute): rate 1 kg/s, error 0.05 kg, the recorded decay."""
    gain = sr.load_schedule("examples/arm6-schedule.json")
    plant = sr.load_arm("examples/robot-arm6.toml").plant
    cert = sr.schedule_certificate(plant, gain, rate=1.0, measurement_error=0.05, decay=gain.certified["decay"])
    assert cert.certified, cert.message
    check = schedule_condition_margin(plant, "m_p", gain.breakpoints, gain.gains, cert.P, rate=1.0, delta=0.05,
                                      decay=gain.certified["decay"])
    assert check["certified"], check


def test_design_schedules_the_paper_s_design_on_the_command_line(tmp_path, capsys, arm):
    """design --schedule: schedule_riccati's table, certified as it runs, written as a schedule file."""
    path = tmp_path / "riccati.json"
    argv = ["design", "--model", ARM, "--rho", "1", "--eta", "10", "--schedule", "m", "--breakpoints", "3",
            "--rate", "1"]
    assert main([*argv, "--format", "json", "--output", str(path)]) == 0
    assert main(argv) == 0
    out = capsys.readouterr().out
    gain = sr.load_schedule(path)
    expected = sr.schedule_riccati(arm, "m", [0.0, 1.0, 2.0], 1.0, 10.0)
    np.testing.assert_array_equal(gain.gains, expected.gains)
    assert gain.method == "riccati" and gain.certified["rate"] == 1.0 and gain.certified["measurement_error"] == 0.05
    cert = sr.schedule_certificate(arm, gain, rate=1.0, measurement_error=0.05)
    check = schedule_condition_margin(arm, "m", gain.breakpoints, gain.gains, cert.P, rate=1.0, delta=0.05)
    assert cert.certified and check["certified"] and "certificate: certified" in out
    decay = float(out.split("guaranteed decay rate: ")[1].split()[0])
    assert decay == pytest.approx(gain.certified["decay"], rel=1e-3)
    for extra, message in ((["--schedule", "nope"], "`--schedule`"),
                           (["--breakpoints", "5,1"], "`--breakpoints` must be at least 2 strictly increasing")):
        assert main([*argv, *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err
    assert main(["design", "--model", ARM, "--rho", "1", "--eta", "10", "--rate", "1"]) == 2
    assert "it goes with --schedule NAME" in capsys.readouterr().err


def test_margin_of_a_schedule_file_is_certify_s_searches(tmp_path, capsys, arm):
    """margin --design SCHEDULE.json: the largest rate, error and decay, as certify --design finds them."""
    path = tmp_path / "riccati.json"
    sr.schedule_riccati(arm, "m", [0.0, 1.0, 2.0], 1.0, 10.0).save(path)
    assert main(["margin", "--model", ARM, "--design", str(path), "--format", "json"]) == 0
    margins = json.loads(capsys.readouterr().out)
    assert main(["certify", "--model", ARM, "--design", str(path), "--format", "json"]) == 0
    certified = json.loads(capsys.readouterr().out)
    for key in ("largest_rate", "largest_measurement_error", "decay", "rate", "measurement_error"):
        assert margins[key] == certified[key], key
    plant = sr.load_plant(ARM)  # no rate bound in the file: any rate
    assert margins["rate"] is None and margins["decay"] == sr.schedule_decay(plant, sr.load_schedule(path))[0]
    assert main(["margin", "--model", ARM, "--design", str(path), "--rho", "1"]) == 2
    assert "`--rho` goes with a fixed gain" in capsys.readouterr().err


def test_the_rate_objective_synthesizes_the_table_certified_for_the_fastest_parameter(oscillator, tmp_path, capsys):
    """synthesize_schedule_rate: its ν is certified (re-verified apart), and the table's own search agrees."""
    result = sr.synthesize_schedule_rate(oscillator, np.linspace(1.0, 9.0, 3), decay=0.2, gain_bound=2.0)
    gain, nu = result.gain, result.rate
    assert result.status == "certified" and 0 < nu < math.inf and gain.certified["rate"] == nu
    cert = sr.schedule_certificate(oscillator, gain, rate=nu, decay=0.2)
    check = schedule_condition_margin(oscillator, "k", gain.breakpoints, gain.gains, cert.P, rate=nu, delta=0.0,
                                      decay=0.2)
    assert cert.certified and check["certified"] and gain.max_norm <= 2.0 * (1 + 1e-6)
    found, _ = sr.max_schedule_rate(oscillator, gain, decay=0.2)
    assert found >= nu * (1 - 0.05)  # the table's certificate search reaches at least the synthesis' rate
    # the largest decay of a table certified at that rate is at least 0.2
    assert sr.schedule_decay(oscillator, gain, rate=nu)[0] >= 0.2 * (1 - 0.02)
    plant = sr.load_plant(ARM)
    assert main(["synthesize", "--model", ARM, "--schedule", "m", "--breakpoints", "3", "--objective", "rate",
                 "--decay", "0.9", "--gain-bound", "20", "--output", str(tmp_path / "r.json")]) == 0
    assert "any rate certified at decay 0.9 1/s" in capsys.readouterr().out
    assert sr.load_schedule(tmp_path / "r.json").certified["rate"] == "inf"
    assert sr.schedule_certificate(plant, sr.load_schedule(tmp_path / "r.json"), rate=math.inf, decay=0.9).certified
    for argv, message in ((["--schedule", "m", "--objective", "l2"], "`--objective l2` is not there for a scheduled"),
                          (["--schedule", "m", "--objective", "rate", "--rate", "1"], "`--objective rate` searches"),
                          (["--objective", "rate"], "it goes with --schedule NAME")):
        assert main(["synthesize", "--model", ARM, *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err


@pytest.mark.lmi
def test_what_one_p_certifies_at_any_rate_is_certified_at_every_rate_bound(arm):
    """A fixed gain at the edge of its decay: the rate-0 LMI's P(p) fails numpy's check on the finer grid,
    yet one P for all p holds, so the certificate at ν = 0 (a frozen payload) and at ν = 1 kg/s says certified,
    as it does at any rate."""
    coarse, fine = arm.samples(arm.coarse_points()), arm.samples()
    best = sr.synthesize((coarse.A, coarse.B), objective="decay", gain_bound=20.0, check=(fine.A, fine.B))
    fixed = sr.ScheduledGain("m", "kg", np.linspace(0.0, 2.0, 5), np.stack([best.K] * 5), "fixed")
    anyrate = sr.schedule_certificate(arm, fixed, rate=math.inf, decay=0.9)
    assert anyrate.certified and anyrate.margin < 0
    for rate in (0.0, 1.0):
        cert = sr.schedule_certificate(arm, fixed, rate=rate, decay=0.9)
        assert cert.certified, (rate, cert.message)
        assert cert.margin < 0 and min(np.linalg.eigvalsh(Pj)[0] for Pj in cert.P) > 0
    assert sr.max_schedule_rate(arm, fixed, decay=0.9)[0] == math.inf
