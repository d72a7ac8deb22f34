"""The package's forward-Euler PID against control_toolbox's own rules, as upstream's pid.cpp computes them.

``tests/upstream_pid.py`` is a line-by-line port of control_toolbox's ``Pid`` (tag 6.3.0, commit
36230f3f32379b0e200694459fc639571dda7b2f, the ``pid.cpp`` that ros2_controllers' ``pid_controller``
6.9.0 calls), written from that source alone and checked bit for bit against the compiled C++ when it
was written. Each joint of a :class:`~scara_robust.DiscretePID` (diagonal gains, ``integrator='forward'``,
measured ė) must give upstream's command to 1e-12 N·m in the cases that once differed: PD only (i = 0)
under saturation, PI only, an error within ``error_deadband``, back-calculation under saturation, and a
tracking time constant below the period.
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
import upstream_pid as up
from test_deploy import _MAIN, CC, needs_cc

import scara_robust as sr

TS = 1e-3


def _upstream(p, i, d, u_max, tt, deadband):
    strategy = up.AntiWindupStrategy(up.AntiWindupStrategy.BACK_CALCULATION if math.isfinite(u_max)
                                     else up.AntiWindupStrategy.NONE, tracking_time_constant=tt,
                                     error_deadband=deadband)
    return up.Pid(p, i, d, u_max, -u_max, strategy)


CASES = {  # name: (p, i, d, u_max [N·m], T_t [s], deadband [rad])
    "pd-saturated": ([400.0, 150.0], [0.0, 0.0], [20.0, 8.0], 30.0, 0.05, 1e-16),
    "pd-free": ([40.0, 15.0], [0.0, 0.0], [2.0, 0.8], math.inf, 0.05, 1e-16),
    "pi-only": ([150.0, 120.0], [300.0, 200.0], [0.0, 0.0], 25.0, 0.1, 1e-16),
    "pid-saturated": ([300.0, 120.0], [200.0, 90.0], [15.0, 6.0], 40.0, 0.03, 1e-16),
    "deadband": ([60.0, 25.0], [100.0, 40.0], [3.0, 1.0], 20.0, 0.05, 0.02),
    "tracking-below-period": ([300.0, 120.0], [200.0, 90.0], [15.0, 6.0], 40.0, 4e-4, 1e-16),
}


def _errors(rng, n_steps):
    """Errors that saturate, cross zero, sit exactly at 0 and within a 0.02-rad band."""
    t = np.arange(n_steps) * TS
    e = np.vstack([0.3 * np.sin(2 * np.pi * 1.3 * t) + 0.05 * rng.standard_normal(n_steps),
                   0.2 * np.cos(2 * np.pi * 0.7 * t) + 0.01 * rng.standard_normal(n_steps)])
    e[:, 100:140] = 0.0  # an encoder's exact zero
    e[:, 200:260] *= 0.05  # inside the 0.02-rad deadband for part of it
    edot = np.gradient(e, TS, axis=1)
    return e, edot


@pytest.mark.parametrize("case", list(CASES))
def test_each_joint_gives_upstreams_command(case):
    p, i, d, u_max, tt, deadband = CASES[case]
    limited = math.isfinite(u_max)
    pid = sr.DiscretePID(TS, np.diag(i), np.diag(p), np.diag(d), integrator="forward",
                         torque_limit=u_max if limited else None, tracking_time=tt if limited else None,
                         error_deadband=deadband)
    upstream = [_upstream(p[j], i[j], d[j], u_max, tt, deadband) for j in range(2)]
    e, edot = _errors(np.random.default_rng(7), 1500)
    worst, saturated = 0.0, 0
    for k in range(e.shape[1]):
        u = pid.step(e[:, k], edot[:, k])
        ref = [upstream[j].compute_command(float(e[j, k]), float(edot[j, k]), TS) for j in range(2)]
        worst = max(worst, float(np.abs(u - ref).max()))
        saturated += int(limited and np.any(np.abs(u) >= u_max))
    assert worst <= 1e-12, f"{case}: {worst:.3g} N·m from upstream"
    if limited:
        assert saturated > 50  # the cases exercise the clamp


def test_the_old_pd_offset_is_gone():
    """A saturated PD keeps no back-calculation state: after the clamp releases, u = p e + d ė exactly."""
    p, d = np.diag([400.0]), np.diag([20.0])
    pid = sr.DiscretePID(TS, np.zeros((1, 1)), p, d, integrator="forward", torque_limit=30.0, tracking_time=0.05)
    for _ in range(200):
        pid.step([0.5], [0.0])  # saturated: v = 200 N·m against a 30-N·m clamp
    assert float(pid.step([0.01], [0.0])[0]) == pytest.approx(4.0, abs=1e-12)
    assert np.all(pid.state == 0.0)


def test_the_single_precision_step_and_the_c_follow_the_same_rules():
    pid = sr.DiscretePID(TS, np.diag([100.0, 0.0]), np.diag([60.0, 50.0]), np.diag([3.0, 2.0]),
                         integrator="forward", torque_limit=20.0, tracking_time=0.05, error_deadband=0.02)
    step32 = sr.single_precision_step(pid)
    e, edot = _errors(np.random.default_rng(3), 600)
    pid.reset()
    worst = 0.0
    for k in range(e.shape[1]):
        u = pid.step(e[:, k], edot[:, k])
        worst = max(worst, float(np.abs(step32(e[:, k], edot[:, k]) - u).max()))
    assert worst < 1e-3  # float32 against double: rounding only, no rule differs


@needs_cc
def test_the_exported_c_follows_the_same_rules(tmp_path):
    """The deadband and the PD row without back-calculation, compiled: the C's torque equals step's to 1e-12."""
    pid = sr.DiscretePID(TS, np.diag([100.0, 0.0]), np.diag([60.0, 50.0]), np.diag([3.0, 2.0]),
                         integrator="forward", torque_limit=20.0, tracking_time=0.05, error_deadband=0.02)
    files = sr.export_controller(pid, tmp_path)
    source = files[1].read_text()
    assert "DEADBAND" in source and "0 without integral action" in source
    (tmp_path / "main.c").write_text(_MAIN)
    exe = tmp_path / "replay"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off", "-o",
                    str(exe), str(tmp_path / "main.c"), str(files[1])], check=True, capture_output=True, text=True,
                   timeout=120)
    e, edot = _errors(np.random.default_rng(5), 1500)
    lines = "\n".join(" ".join(repr(float(v)) for v in row) for row in np.vstack([e, edot]).T)
    out = subprocess.run([str(exe)], input=lines, check=True, capture_output=True, text=True, timeout=120).stdout
    u_c = np.array([[float(v) for v in line.split()] for line in out.splitlines()]).T
    pid.reset()
    u_py = np.array([pid.step(e[:, k], edot[:, k]) for k in range(e.shape[1])]).T
    assert u_c.shape == u_py.shape and np.abs(u_c - u_py).max() <= 1e-12


def test_a_tracking_time_below_the_period_is_taken_and_a_deadband_needs_one_torque_per_joint():
    pid = sr.DiscretePID(TS, np.diag([1.0]), np.diag([1.0]), np.diag([0.0]), torque_limit=1.0, tracking_time=1e-4)
    assert pid.back_calculation_gains[0] == pytest.approx(10.0)
    with pytest.raises(sr.ArgumentValueError, match="one torque per joint"):
        sr.DiscretePID(TS, np.ones((1, 2)), np.ones((1, 2)), np.ones((1, 2)), error_deadband=1e-3)
    with pytest.raises(sr.ArgumentValueError, match="error_deadband"):
        sr.DiscretePID(TS, np.eye(1), np.eye(1), np.eye(1), error_deadband=-1.0)
