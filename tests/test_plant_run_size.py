"""A plant file's run resolves its closed loop's transient, or is refused with its size.

``simulate --model F --t-final 1e9`` once wrote 2001 rows 5e5 s apart and judged "max |e|
after 5e+08 s = 0 rad" on them; the SCARA's runs refuse such a request with the memory it
needs. A plant run now takes an output step no coarser than a tenth of its transient's time
scale (the default grids of the guides are already finer and stay as they are), and a run
whose resolved grid does not fit is refused in one line, with nothing written.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import _plant_run, main

ROOT = Path(__file__).resolve().parents[1]
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")


@pytest.fixture(scope="module")
def motor():
    plant = sr.load_plant(MOTOR)
    return plant, sr.design(plant, 1.0, 10.0).K


def test_a_run_too_long_to_resolve_is_refused_with_its_size(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out_file = tmp_path / "huge.csv"
    argv = ["simulate", "--model", MOTOR, "--rho", "1", "--eta", "10", "--t-final", "1e9", "--output", str(out_file)]
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert err.startswith("scara_robust: error: `--t-final` asks for 1e+10 output samples (1e+09 s every 0.1 s: "), err
    assert "of memory, more than the" in err and "ask for less" in err
    assert not out_file.exists() and list(tmp_path.iterdir()) == []


def test_the_default_grid_is_kept_where_it_resolves_the_transient(motor):
    plant, K = motor
    run = sr.simulate_plant(plant, K, t_final=20.0)  # the guides' run: 2001 samples, 10 ms apart
    assert run.t.size == 2001 and run.status == "tracking"


def test_a_long_run_takes_the_step_of_its_transient(motor):
    plant, K = motor
    run = sr.simulate_plant(plant, K, t_final=400.0)  # 2001 samples would be 0.2 s apart
    # the motor's slowest closed-loop pair is about -0.87 ± 0.5j 1/s: |λ| ≈ 1 1/s, a step of a tenth of 1 s
    assert 3990 < run.t.size < 4100
    assert np.diff(run.t).max() <= 0.1001
    assert run.status == "tracking" and math.isfinite(run.max_abs_error)
    # a reference of 100 rad/s is resolved at 20 samples per period (3.1 ms, finer than the 20 ms asked for)
    run = sr.simulate_plant(plant, K, t_final=2.0, n_points=101, reference=(1.0, 100.0))
    assert np.diff(run.t).max() <= 2 * math.pi / 100 / 20 * (1 + 1e-9) and run.t.size > 600


def test_a_metric_without_samples_is_not_resolved_not_zero(motor):
    plant, K = motor
    run = sr.simulate_plant(plant, K, t_final=2.0, t_transient=2.0)  # one sample after t_transient
    assert run.status == "too-short" and math.isnan(run.max_abs_error)
    assert "not resolved" in run.reason
    lines = _plant_run.summary(run, plant, "head")
    assert "  max |e| after the transient not resolved (fewer than 2 samples after it)" in lines
