"""From design to robot: the sampled PID on the nonlinear SCARA, anti-windup, and the exported C code."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.studies.campaign.runner import run_draw

CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler `cc` on this machine: the exported C is not compiled")


@pytest.fixture(scope="module")
def design():
    return sr.design(sr.paper_model(), 3.0, 90.0)


@pytest.fixture(scope="module")
def limit(paper_sample_time):
    return paper_sample_time


@pytest.mark.lmi
@pytest.mark.parametrize("scenario", ["large", "small"])
def test_sampled_loop_tracks_at_the_certified_sample_time(design, limit, scenario):
    res = sr.simulate(sr.sampled_pid_controller(design.discretize(limit.certified_ts)), scenario)
    assert res.method == "rk4" and res.status == "tracking", res.status_reason
    assert np.diff(res.t).max() == pytest.approx(limit.certified_ts)


@pytest.mark.lmi
def test_sampled_loop_diverges_well_above_the_frozen_limit(design, limit):
    res = sr.simulate(sr.sampled_pid_controller(design.discretize(3 * limit.unstable_ts)), "small", t_final=8.0)
    assert res.status == "diverged" and res.diverged


def test_registry_entry_runs_sampled_with_its_sample_time():
    kind = sr.CONTROLLERS["pid-sampled"]
    assert kind.Ts == 1e-3
    res = sr.run_scenario("pid-sampled", "small", t_final=6.5, torque_limit=50.0)
    assert res.method == "rk4" and res.status == "tracking"
    with pytest.raises(ValueError, match=r"`Ts` must be the discrete-time controller's dt"):
        sr.simulate(sr.make_controller("pid-sampled"), "small", Ts=2e-3, t_final=1.0)


def test_simulation_runs_what_step_runs(design):
    """The simulated torques are those of DiscretePID.step on the recorded errors."""
    pid = design.discretize(1e-3, torque_limit=20.0)
    res = sr.simulate(sr.sampled_pid_controller(pid), "large", t_final=1.0)
    pid.state = pid.initial_state(res.e[:, 0])
    u = np.array([pid.step(res.e[:, k], res.edot[:, k]) for k in range(res.t.size)]).T
    np.testing.assert_allclose(u, res.torque, rtol=0, atol=1e-12)
    assert 0 < np.mean(np.abs(u) >= 20.0) < 1


def test_anti_windup_study_reduces_overshoot():
    study = sr.anti_windup_study([6.0], t_final=8.0)
    table = study.table
    assert list(table["torque_limit"].fillna(0)) == [0.0, 6.0, 6.0]
    assert list(table["anti_windup"]) == [None, False, True]
    off, on = table.iloc[1], table.iloc[2]
    assert on["overshoot_e1"] < off["overshoot_e1"] and on["overshoot_e2"] < off["overshoot_e2"]
    assert 0.1 < on["saturated_fraction"] < 1
    fig = sr.plot_anti_windup(study, 6.0)
    assert all(ax.get_xlabel().endswith("[s]") and "[" in ax.get_ylabel() for ax in fig.axes)
    with pytest.raises(ValueError, match=r"`torque_limit` must be a limit of the study"):
        sr.plot_anti_windup(study, 50.0)


# -- export -------------------------------------------------------------------------------

_MAIN = r"""#include <stdio.h>
#include "scara_pid.h"
int main(void)
{
    scara_pid_state s;
    double e[2], ed[2], u[2];
    scara_pid_init(&s);
    while (scanf("%lf %lf %lf %lf", &e[0], &e[1], &ed[0], &ed[1]) == 4) {
        scara_pid_step(&s, e, ed, u);
        printf("%.17g %.17g\n", u[0], u[1]);
    }
    return 0;
}
"""


@needs_cc
@pytest.mark.parametrize(
    "options",
    [{}, {"derivative": "filtered", "integrator": "forward", "N": 50.0}],
    ids=["default-measured-tustin", "filtered-forward"],
)
def test_exported_c_matches_python_step(design, tmp_path, options):
    """10 000 samples of a recorded closed-loop run, with the 8 N·m limit active part of the time."""
    recorded = sr.simulate(sr.sampled_pid_controller(design.discretize(1e-3, torque_limit=8.0)), "large",
                           t_final=10.0)
    e, edot = recorded.e[:, :10_000], recorded.edot[:, :10_000]
    assert e.shape == (2, 10_000)
    pid = design.discretize(1e-3, torque_limit=8.0, **options)
    files = sr.export_controller(pid, tmp_path)
    assert [f.name for f in files] == ["scara_pid.h", "scara_pid.c"]
    header = files[0].read_text()
    assert "typedef struct {" in header and "} scara_pid_state;" in header
    assert "void scara_pid_init(scara_pid_state *s);" in header
    assert "void scara_pid_step(scara_pid_state *s, const double e[2], const double edot[2], double u[2]);" in header
    assert "malloc" not in files[1].read_text()
    (tmp_path / "main.c").write_text(_MAIN)
    exe = tmp_path / "replay"
    subprocess.run(
        [CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off",
         "-o", str(exe), str(tmp_path / "main.c"), str(files[1])],
        check=True, capture_output=True, text=True, timeout=120,
    )
    lines = "\n".join(" ".join(repr(float(v)) for v in row) for row in np.vstack([e, edot]).T)
    out = subprocess.run([str(exe)], input=lines, check=True, capture_output=True, text=True, timeout=120).stdout
    u_c = np.array([[float(v) for v in line.split()] for line in out.splitlines()]).T
    pid.reset()
    u_py = np.array([pid.step(e[:, k], edot[:, k]) for k in range(e.shape[1])]).T
    assert u_c.shape == (2, 10_000)
    assert np.abs(u_c - u_py).max() <= 1e-12
    saturated = np.mean(np.abs(u_py) >= 8.0)
    assert 0.001 < saturated < 0.9


def test_export_command_writes_the_default_discretization(design, tmp_path, capsys):
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--format", "json",
                 "--output", str(tmp_path)]) == 0
    record = json.loads((tmp_path / "scara_pid.json").read_text())
    expected = sr.controller_record(design.discretize(0.001))
    for key in ("Ts", "integrator", "derivative", "K_I", "K_P", "K_D", "A", "B", "C", "D", "torque_limit",
                "tracking_time", "anti_windup"):
        assert record[key] == expected[key], key
    assert record["rho"] == 3.0 and "wrote" in capsys.readouterr().out
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.0005", "--torque-limit", "40,30", "--prefix",
                 "arm", "--output", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.c", "arm.h", "scara_pid.json"]
    assert "static const double LIMIT[2] = {40.0, 30.0};" in (tmp_path / "arm.c").read_text()


def test_failed_export_leaves_nothing(design, tmp_path, monkeypatch):
    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("scara_robust.export._write.os.replace", fail)
    with pytest.raises(OSError, match="No space"):
        sr.export_controller(design.discretize(1e-3), tmp_path)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match=r"`prefix` must be a C identifier"):
        sr.export_controller(design.discretize(1e-3), tmp_path, prefix="scara-pid")


def test_compare_and_campaigns_run_the_sampled_pid(monkeypatch):
    table = sr.compare_controllers(["pid-sampled"], ["small"], t_final=6.5)
    assert list(table["status"]) == ["tracking"]
    spec = sr.spec_from_dict({"controllers": ["pid-sampled"], "t_final": 6.5, "runs": 1, "rho": 2.0, "eta": 50.0})
    gains = []
    real = sr.simulation.controllers._sampled_pid_factory

    def spy(**kw):
        gains.append(kw.get("K"))
        return real(**kw)

    monkeypatch.setitem(sr.CONTROLLERS, "pid-sampled", dataclasses.replace(sr.CONTROLLERS["pid-sampled"], build=spy))
    (row,) = run_draw(spec, sr.draw_scenario(spec, 1, 0))
    assert row["controller"] == "pid-sampled" and row["status"] == "tracking"
    np.testing.assert_allclose(gains[0], sr.design(sr.paper_model(), 2.0, 50.0).K)  # the spec's (rho, eta)


_GAIN_MAIN = r"""
#include <stdio.h>
#include "benchmark_k.h"
int main(void) {
    double x[BENCHMARK_K_NX], u[BENCHMARK_K_NU];
    while (scanf("%lf %lf", &x[0], &x[1]) == 2) {
        benchmark_k_step(x, u);
        printf("%.17g\n", u[0]);
    }
    return 0;
}
"""


@needs_cc
def test_exported_static_state_feedback_matches_python(tmp_path):
    """u = −K x of a SampledStateFeedback in C99 equals `step` in Python on 1 000 random states, and
    the header names the signals with their units and the sample time."""
    ctrl = sr.SampledStateFeedback([[3.75, 11.5]], 1.5)
    files = sr.export_controller(ctrl, tmp_path, prefix="benchmark_k",
                                 inputs=[sr.Signal("q", "rad"), sr.Signal("qdot", "rad/s")],
                                 outputs=[sr.Signal("u", "N")])
    header = files[0].read_text()
    assert "x[1] = qdot [rad/s]" in header and "u[0] = u [N]" in header and "#define BENCHMARK_K_TS 1.5" in header
    (tmp_path / "main.c").write_text(_GAIN_MAIN)
    exe = tmp_path / "gain"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off",
                    "-o", str(exe), str(tmp_path / "main.c"), str(files[1])],
                   check=True, capture_output=True, text=True, timeout=120)
    x = np.random.default_rng(0).normal(size=(1000, 2))
    lines = "\n".join(" ".join(repr(float(v)) for v in row) for row in x)
    out = subprocess.run([str(exe)], input=lines, check=True, capture_output=True, text=True, timeout=120).stdout
    u_c = np.array([float(v) for v in out.split()])
    u_py = np.array([ctrl.step(row)[0] for row in x])
    assert u_c.shape == (1000,) and np.abs(u_c - u_py).max() <= 1e-14 * np.abs(u_py).max()
    json_file = sr.export_controller(ctrl, tmp_path, format="json", prefix="benchmark_k")[0]
    assert '"law": "u = -K x, zero-order hold"' in json_file.read_text()


def test_static_state_feedback_export_refuses_a_wrong_signal_count(tmp_path):
    with pytest.raises(sr.ArgumentValueError, match="`inputs` must name the 2 states fed back, found 1"):
        sr.export_controller(sr.SampledStateFeedback([[3.75, 11.5]], 1.5), tmp_path, inputs=[sr.Signal("q", "rad")])
    assert list(tmp_path.iterdir()) == []
