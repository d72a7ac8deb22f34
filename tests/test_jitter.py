"""A certificate for a jittering period (``--ts-jitter``): every period in [Ts − J, Ts + J], in any order.

On the SCARA's decentralized PID (synthesize --structure decentralized), run as pid_controller runs it
(forward Euler at 1 kHz): the certificate's own P decreases on every plant at every checked period; a
simulation of the frozen sampled loops with a random sequence of periods inside the interval decays,
and one with periods beyond the frozen limit grows. The command line writes the certificate into the
files, or refuses.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main

pytestmark = pytest.mark.lmi

pytest.importorskip("cvxpy", reason="the certificates are LMIs: pip install '.[lmi]'")


@pytest.fixture(scope="module")
def scara():
    system = sr.open_system("scara", command="export")
    plants, check, _ = system.sampled()
    physical = system.physical_set((37, 5), (361, 9))
    d = sr.synthesize(physical.plants, structure="decentralized", objective="decay").design
    return plants, check, d.discretize(1e-3, integrator="forward"), d


def _loops(plants, pid, h):
    A, B = plants
    return pid.linear_at(h).closed_loops(np.asarray(A), np.asarray(B))


def test_zero_jitter_is_the_sampled_certificate(scara):
    plants, check, pid, _ = scara
    cert = sr.jitter_certificate(plants, pid, 0.0)
    assert cert.certified == sr.sampled_certificate(plants, pid).certified is True


def test_twenty_microseconds_of_jitter_at_1_ms_is_certified_and_a_random_sequence_decays(scara):
    plants, check, pid, _ = scara
    J = 2e-5
    cert = sr.jitter_certificate(plants, pid, J, check=check)
    assert cert.certified and cert.n_periods == sr.JITTER_CHECK_PERIODS
    rng = np.random.default_rng(11)
    A, B = (np.asarray(x) for x in plants)
    pick = rng.choice(A.shape[0], 6, replace=False)
    periods = np.linspace(1e-3 - J, 1e-3 + J, 401)  # the sequence draws among 401 periods of the interval
    loops = np.stack([pid.linear_at(float(h)).closed_loops(A[pick], B[pick]) for h in periods])
    for k in range(pick.size):
        x = rng.standard_normal(6)
        start = float(np.linalg.norm(x))
        for j in rng.integers(0, periods.size, 40_000):  # 40 s of jittering samples
            x = loops[j, k] @ x
        assert np.linalg.norm(x) < 0.5 * start  # it decays (slowly: the certified rate is a worst case)


def test_periods_beyond_the_frozen_limit_grow(scara):
    plants, check, pid, d = scara
    limit = sr.max_sample_time(plants, d, integrator="forward")
    hi = limit.unstable_ts
    slow = d.discretize(0.8 * hi, integrator="forward")
    cert = sr.jitter_certificate(plants, slow, 0.3 * hi)  # out to 1.1 times the frozen instability
    assert not cert.certified
    A, B = (np.asarray(x) for x in plants)
    radius = [np.abs(np.linalg.eigvals(pid.linear_at(hi * 1.02).closed_loops(A, B))).max(axis=1)]
    worst = int(np.argmax(radius[0]))
    x = np.ones(6)
    rng = np.random.default_rng(2)
    periods = np.linspace(1.02 * hi, 1.05 * hi, 31)  # every period beyond the frozen instability
    loops = [pid.linear_at(float(h)).closed_loops(A[worst:worst + 1], B[worst:worst + 1])[0] for h in periods]
    for j in rng.integers(0, periods.size, 4000):
        x = loops[j] @ x
    assert np.linalg.norm(x) > 1e3


def test_export_ts_jitter_writes_the_certificate_or_refuses(scara, tmp_path, capsys):
    _, _, _, d = scara
    design = tmp_path / "pid-decentralized.json"
    sr.write_design(design, d.K, d.P)
    out = tmp_path / "out"
    out.mkdir()
    base = ["export", "--design", str(design), "--ts", "0.001", "--torque-limit", "50", "--format", "ros2",
            "--output", str(out)]
    assert main([*base, "--ts-jitter", "2e-5"]) == 0
    text = capsys.readouterr().out
    assert "every period in [0.00098, 0.00102] s (Ts = 0.001 s ± 2e-05 s) certified" in text
    yaml = next(out.glob("*.yaml")).read_text()
    assert "Jittering period: every period in [0.00098, 0.00102] s" in yaml
    for path in out.iterdir():
        path.unlink()
    assert main([*base, "--ts-jitter", "0.001"]) == 2
    assert "`--ts-jitter` must be in [0, --ts) s" in capsys.readouterr().err and not list(out.iterdir())
    limit = sr.max_sample_time(scara[0], d, integrator="forward")
    hz = round(1.0 / (0.8 * limit.unstable_ts))  # pid_controller's rate: a whole number of Hz
    slow = [*base[:4], f"{1.0 / hz:.9g}", *base[5:]]  # periods out to 1.1 times the frozen instability
    assert main([*slow, "--ts-jitter", f"{0.3 * limit.unstable_ts:.6g}"]) == 2
    err = capsys.readouterr().err
    assert "`--ts-jitter` every period in" in err and "not certified" in err and not list(out.iterdir())
    json_argv = ["export", "--design", str(design), "--ts", "0.001", "--torque-limit", "50", "--format", "json",
                 "--output", str(out), "--ts-jitter", "2e-5"]
    assert main(json_argv) == 0
    capsys.readouterr()
    record = json.loads(next(Path(out).glob("*.json")).read_text())
    found = json.dumps(record)
    assert '"jitter": 2e-05' in found and '"periods": [0.00098, 0.00102]' in found
