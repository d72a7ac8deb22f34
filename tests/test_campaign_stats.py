"""Statistics of a campaign for large N, and the replay of one of its runs.

Wilson intervals against the closed form written out here; bootstrap intervals against
explicit resampling, and their behaviour with N; the worst-runs table on a table built
by hand; a replayed row against the campaign's own metrics, bit for bit.
"""

import json
import math

import numpy as np
import pandas as pd
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.studies.campaign.inputs import DRAWN_COLUMNS, FIXED_COLUMNS
from scara_robust.studies.campaign.report import bootstrap_quantiles, wilson_interval

Z95 = 1.959963984540054  # standard normal quantile of 0.975

TINY = {
    "controllers": ["pid", "smc"],
    "t_final": 6.5,
    "seed": 11,
    "payload_profiles": ["sinusoidal", "constant"],
    "payload_peak": {"min": 1.0, "max": 3.0},
    "cp": {"min": 0.003, "max": 0.008},
    "disturbance_amplitude": {"min": 3.0, "max": 7.0},
    "disturbance_period": {"min": 0.4, "max": 1.0},
    "disturbance_phase": {"min": 0.0, "max": 6.283},
    "initial_error": {"min": -0.1, "max": 0.1},
    "torque_limit": {"min": 40.0, "max": 60.0},
}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Two scenarios of a small campaign, stored as CSV."""
    path = tmp_path_factory.mktemp("campaign") / "r.csv"
    spec = sr.spec_from_dict(TINY)
    sr.run_campaign(spec, path, runs=2)
    return path, sr.read_results(path)


def wilson_by_hand(k, n, z=Z95):
    p = k / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z / (1 + z**2 / n) * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    return centre - half, centre + half


@pytest.mark.parametrize(("k", "n"), [(0, 10), (3, 10), (10, 10), (1, 10_000)], ids=["0of10", "3of10", "10of10",
                                                                                      "1of10000"])
def test_wilson_interval_is_the_closed_form(k, n):
    low, high = wilson_interval(k, n)
    want_low, want_high = wilson_by_hand(k, n)
    assert float(low) == pytest.approx(max(want_low, 0.0), abs=1e-15)
    assert float(high) == pytest.approx(min(want_high, 1.0), abs=1e-15)
    assert 0.0 <= low <= k / n <= high <= 1.0


def test_wilson_interval_ends_and_known_values():
    low, high = wilson_interval([0, 3, 10], [10, 10, 10])
    assert low[0] == 0.0 and high[2] == 1.0  # no rounding residue at k = 0 and k = n
    # 3 of 10 at 95 %: [0.1078, 0.6032] (the closed form, to 4 digits)
    assert (round(float(low[1]), 4), round(float(high[1]), 4)) == (0.1078, 0.6032)
    narrow = wilson_interval(30, 100, confidence=0.5)
    wide = wilson_interval(30, 100, confidence=0.99)
    assert wide[0] < narrow[0] < 0.3 < narrow[1] < wide[1]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: wilson_interval(11, 10), "`successes` must be integers in"),
        (lambda: wilson_interval(1, 0), "`trials` must be integers >= 1"),
        (lambda: wilson_interval(1, 10, confidence=1.0), r"`confidence` must be in \(0, 1\)"),
        (lambda: bootstrap_quantiles([], [0.5]), "`values` must hold at least one value"),
        (lambda: bootstrap_quantiles([1.0, np.nan], [0.5]), "`values` must contain only finite"),
        (lambda: bootstrap_quantiles([1.0], [1.5]), r"`quantiles` must be numbers in \[0, 1\]"),
        (lambda: bootstrap_quantiles([1.0], [0.5], resamples=0), "`resamples` must be an integer >= 1"),
    ],
    ids=["k>n", "n=0", "confidence", "empty", "nan", "quantile", "resamples"],
)
def test_statistics_refuse_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_bootstrap_equals_explicit_resampling():
    # The counting algorithm against the textbook one: resample, sort, take np.quantile.
    x = np.random.default_rng(5).normal(size=37)
    qs = [0.0, 0.1, 0.5, 0.95, 1.0]
    low, high = bootstrap_quantiles(x, qs, resamples=300, seed=3)
    rng = np.random.default_rng(3)
    picks = np.vstack([rng.integers(0, 37, size=(250, 37)), rng.integers(0, 37, size=(50, 37))])
    estimates = np.quantile(np.sort(x)[picks], qs, axis=1)
    np.testing.assert_allclose(low, np.quantile(estimates, 0.025, axis=1), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(high, np.quantile(estimates, 0.975, axis=1), rtol=1e-12, atol=1e-15)


def test_bootstrap_contains_the_estimate_and_shrinks_with_n():
    rng = np.random.default_rng(0)
    qs = [0.05, 0.5, 0.95]
    widths = []
    for n in (100, 1_000, 10_000):
        x = rng.lognormal(size=n)
        low, high = bootstrap_quantiles(x, qs)
        estimate = np.quantile(x, qs)
        assert np.all(low <= estimate) and np.all(estimate <= high)
        widths.append(high - low)
    assert np.all(widths[1] < widths[0]) and np.all(widths[2] < widths[1])
    # roughly 1/sqrt(N): a hundredfold N narrows the median's interval about tenfold
    assert 4 < widths[0][1] / widths[2][1] < 25
    again = bootstrap_quantiles(x, qs)
    assert np.array_equal(again[0], low) and np.array_equal(again[1], high)  # seeded


def _table(statuses, errors):
    n = len(statuses)
    frame = pd.DataFrame({
        "scenario": list(range(n)) * 2,
        "controller": ["pid"] * n + ["smc"] * n,
        "status": list(statuses) * 2,
        "success": [s in ("tracking", "not-tracking") for s in statuses] * 2,
        "payload_peak": np.linspace(1.0, 2.0, n).tolist() * 2,
    })
    for metric in sr.METRIC_NAMES:
        frame[metric] = list(errors) * 2
    return frame


def test_worst_scenarios_put_non_tracking_first():
    statuses = ["tracking", "not-tracking", "tracking", "failed", "tracking", "diverged"]
    errors = [0.01, 0.2, 0.03, np.nan, 0.03, np.nan]
    worst = sr.worst_scenarios(_table(statuses, errors), n=4)
    pid = worst[worst["controller"] == "pid"]
    # failed and diverged have no metric: the largest error, lower index first; then not-tracking;
    # then the tracking runs by error, the tie at 0.03 going to the lower index
    assert pid["scenario"].tolist() == [3, 5, 1, 2] and pid["rank"].tolist() == [1, 2, 3, 4]
    assert pid["status"].tolist() == ["failed", "diverged", "not-tracking", "tracking"]
    assert worst["controller"].tolist() == ["pid"] * 4 + ["smc"] * 4
    assert pid["payload_peak"].tolist() == pytest.approx([1.6, 2.0, 1.2, 1.4])  # the drawn inputs of each run
    with pytest.raises(ValueError, match="`n` must be an integer >= 1"):
        sr.worst_scenarios(_table(statuses, errors), n=0)


def test_report_intervals(campaign):
    _, table = campaign
    report = sr.campaign_report(table)
    for _, row in report.iterrows():
        low, high = wilson_interval(row["failures"], row["runs"])
        assert row["failure_rate low"] == low and row["failure_rate high"] == high
        for metric in sr.METRIC_NAMES:
            for q in ("q5", "q50", "q95"):
                assert row[f"{metric} {q} low"] <= row[f"{metric} {q}"] <= row[f"{metric} {q} high"]
    worst = sr.worst_scenarios(table, n=1)
    assert set(DRAWN_COLUMNS) <= set(worst.columns) and len(worst) == 2


def test_replay_equals_the_campaign_row(campaign):
    _, table = campaign
    assert set(FIXED_COLUMNS) <= set(table.columns)
    # the default engine of a campaign is the compiled one when numba is there; the row says which ran
    assert set(table["method"]) == ({"compiled"} if sr.numba_available() else {"lsoda"})
    for _, row in table.iterrows():
        res = sr.replay_scenario(table, row["scenario"], row["controller"])
        assert res.metrics().to_dict() == {m: row[m] for m in sr.METRIC_NAMES}  # exactly
        assert res.status == row["status"] and res.scenario == f"mc-{row['scenario']}"


def test_replay_on_another_engine(campaign):
    _, table = campaign
    res = sr.replay_scenario(table, 1, "pid", method="rk4")
    row = table[(table["scenario"] == 1) & (table["controller"] == "pid")].iloc[0]
    assert res.method == "rk4" and res.status == row["status"]
    assert res.metrics().max_abs_error == pytest.approx(row["max_abs_error_after_6s"], rel=1e-3)


def test_replay_command_prints_the_row(campaign, capsys):
    path, table = campaign
    assert main(["simulate", "--from-campaign", str(path), "--index", "1", "--controller", "smc",
                 "--format", "json"]) == 0
    out = json.loads(capsys.readouterr().out)
    row = table[(table["scenario"] == 1) & (table["controller"] == "smc")].iloc[0]
    assert out["metrics"] == {m: row[m] for m in sr.METRIC_NAMES} and out["status"] == row["status"]
    assert out["controller"] == "smc" and out["scenario"] == "mc-1" and out["method"] == row["method"]


def test_report_command_shows_the_statistics(campaign, capsys):
    path, _ = campaign
    assert main(["campaign-report", str(path), "--worst", "1"]) == 0
    text = capsys.readouterr().out
    assert "failure_rate high" in text and "max_abs_error_after_6s q50 low [rad]" in text
    assert "pid #1" in text and "payload_peak [kg]" in text and "2000 resamples" in text
    assert main(["campaign-report", str(path), "--format", "json", "--worst", "2"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["bootstrap"] == {"method": "percentile", "resamples": 2000, "seed": 0}
    assert data["units"]["payload_peak"] == "kg" and len(data["worst"]) == 4
    assert {"failure_rate low", "max_abs_error_after_6s q95 high"} <= set(data["statistics"][0])
    assert main(["campaign-report", str(path), "--format", "csv"]) == 0
    stats, worst = capsys.readouterr().out.split("\n\n")
    assert stats.startswith("controller,runs,") and worst.startswith("controller,rank,scenario,status,")


def test_resume_refuses_a_table_without_the_inputs(campaign, tmp_path):
    _, table = campaign
    old = tmp_path / "old.csv"
    table.drop(columns=list(FIXED_COLUMNS)).to_csv(old, index=False)
    with pytest.raises(ValueError, match=r"`resume` cannot continue .* lacks the columns \['t_final'"):
        sr.run_campaign(sr.spec_from_dict(TINY), old, runs=2, resume=True)
