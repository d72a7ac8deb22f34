"""Monte-Carlo campaigns: spec validation, reproducibility, resume, local and Dask runs."""

import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.studies import campaign as cp
from scara_robust.studies.campaign.runner import run_draw

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "campaign.toml"

#: A tiny campaign: short horizon, a little of everything drawn.
TINY = """
controllers = ["pid", "smc"]
t_final = 6.5
runs = 4
seed = 7
payload_profiles = ["sinusoidal", "constant"]
payload_peak = { min = 1.0, max = 3.0 }
disturbance_amplitude = { min = 3.0, max = 7.0 }
disturbance_phase = { min = 0.0, max = 6.283 }
initial_error = { min = -0.1, max = 0.1 }
torque_limit = { min = 40.0, max = 60.0 }
"""


@pytest.fixture
def tiny_spec(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    """The tiny campaign run straight through in this process."""
    folder = tmp_path_factory.mktemp("straight")
    (folder / "tiny.toml").write_text(TINY)
    spec = cp.load_spec(folder / "tiny.toml")
    cp.run_campaign(spec, folder / "r.csv", chunk_size=1)
    return spec, cp.read_results(folder / "r.csv")


def test_example_spec_loads():
    spec = cp.load_spec(EXAMPLE)
    assert spec.controllers == ("pid", "smc") and spec.runs == 200
    assert spec.ranges["payload_peak"] == cp.Range(1.0, 3.0)
    assert math.isinf(spec.ranges["torque_limit"].low)


def test_straight_table_shape(straight):
    spec, table = straight
    assert len(table) == 8 and table["scenario"].tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    assert table["success"].all() and (table["error"] == "").all()
    assert (table["max_abs_error_after_6s"] > 0).all()
    assert set(table["payload_profile"]) <= {"sinusoidal", "constant"}
    assert table["payload_peak"].between(1.0, 3.0).all() and table["torque_limit"].between(40, 60).all()
    assert (table["seed"] == 7).all() and (table["spec"] == spec.digest()).all()
    # rows of one scenario share its drawn inputs, and they match an independent redraw
    for i in range(4):
        redraw = cp.draw_scenario(spec, 7, i)
        rows = table[table["scenario"] == i]
        for key in ("payload_peak", "cp", "e1_0", "e2_0", "disturbance_phase"):
            assert (rows[key] == redraw[key]).all()


def test_draw_depends_only_on_seed_and_index(tiny_spec):
    spec = cp.load_spec(tiny_spec)
    a = cp.draw_scenario(spec, 7, 3)
    assert a == cp.draw_scenario(spec, 7, 3)
    assert a != cp.draw_scenario(spec, 7, 2) and a != cp.draw_scenario(spec, 8, 3)
    assert a["cp"] == 0.005  # a constant field stays at the paper's value


def test_same_seed_same_table_with_a_process_pool(straight, tmp_path):
    spec, table = straight
    cp.run_campaign(spec, tmp_path / "pool.csv", workers=2, chunk_size=1)
    pd.testing.assert_frame_equal(cp.read_results(tmp_path / "pool.csv"), table)


@pytest.mark.dask
@pytest.mark.parquet
def test_same_seed_same_table_with_dask(straight, tmp_path):
    spec, table = straight
    cp.run_campaign(spec, tmp_path / "dask.parquet", workers=2, scheduler="dask", chunk_size=1)
    pd.testing.assert_frame_equal(cp.read_results(tmp_path / "dask.parquet"), table)


@pytest.mark.dask
def test_same_table_on_a_running_dask_cluster_by_address(straight, tmp_path):
    from dask.distributed import LocalCluster

    spec, table = straight
    # a cluster started elsewhere (threads here: the compiled kernels release the GIL)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster:
        cp.run_campaign(spec, tmp_path / "remote.csv", scheduler="dask", address=cluster.scheduler_address,
                        chunk_size=1)
        assert len(cluster.scheduler.workers) == 1  # the campaign used this cluster and left it running
    pd.testing.assert_frame_equal(cp.read_results(tmp_path / "remote.csv"), table)


def test_interrupted_and_resumed_equals_straight(straight, tmp_path):
    spec, table = straight
    out = tmp_path / "r.csv"

    def stop_after_two(n_done):
        if n_done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cp.run_campaign(spec, out, chunk_size=1, checkpoint=0.0, on_chunk=stop_after_two)
    partial = cp.read_results(out)
    assert partial["scenario"].nunique() == 2  # the finished chunks were kept
    seen = []
    cp.run_campaign(spec, out, chunk_size=1, checkpoint=0.0, resume=True, on_chunk=seen.append)
    assert seen == [3, 4]  # only the two missing scenarios ran
    pd.testing.assert_frame_equal(cp.read_results(out), table)


@pytest.mark.parametrize("digest", ["8869e4053699", "123456789012", "00000000001e"])
def test_a_digest_that_reads_as_a_number_stays_the_spec_s_text(straight, tmp_path, digest):
    """The spec column is the digest's 12 hexadecimal digits, whatever a number parser makes of them."""
    _, table = straight
    out = tmp_path / "r.csv"
    table.assign(spec=digest).to_csv(out, index=False)
    read = cp.read_results(out)
    assert read["spec"].tolist() == [digest] * len(table)
    pd.testing.assert_frame_equal(read.drop(columns="spec"), table.drop(columns="spec"))


def test_killed_process_resumes_to_the_same_table(straight, tmp_path, tiny_spec):
    spec, table = straight
    out = tmp_path / "killed.csv"
    cmd = [sys.executable, "-m", "scara_robust", "campaign", str(tiny_spec), "--chunk-size", "1", "--output", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and cp.read_results(out)["scenario"].nunique() >= 1:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = cp.read_results(out)["scenario"].nunique()
    assert 1 <= done <= 4
    assert main(["campaign", str(tiny_spec), "--chunk-size", "1", "--output", str(out), "--resume"]) == 0
    pd.testing.assert_frame_equal(cp.read_results(out), table)


@pytest.mark.parametrize("flag, drawn", [([], False), (["--progress"], True)], ids=["redirected", "asked"])
def test_the_progress_bar_is_drawn_on_a_terminal_or_when_asked(tmp_path, capsys, tiny_spec, flag, drawn):
    """stderr is captured here, as in a redirected log: no bar unless --progress asks for one."""
    out = tmp_path / "r.csv"
    assert main(["campaign", str(tiny_spec), "--runs", "1", "--output", str(out), *flag]) == 0
    assert ("campaign:" in capsys.readouterr().err) is drawn


def test_failed_run_is_a_row_not_a_crash(monkeypatch, tiny_spec, tmp_path):
    spec = cp.load_spec(tiny_spec)
    real = cp.runner.run_scenarios

    def flaky(requests, errors="raise"):
        assert errors == "return"  # a campaign never lets one run stop it
        results = real(requests, errors=errors)
        return [RuntimeError("solver exploded") if r["controller"].startswith("smc") else res
                for r, res in zip(requests, results)]

    monkeypatch.setattr(cp.runner, "run_scenarios", flaky)
    table = cp.run_campaign(spec, tmp_path / "r.csv", runs=2)
    smc = table[table["controller"] == "smc"]
    assert len(table) == 4 and not smc["success"].any()
    assert (smc["error"] == "RuntimeError: solver exploded").all() and smc["max_abs_error_after_6s"].isna().all()
    report = cp.campaign_report(table)
    assert report.loc["smc", "failure_rate"] == 1.0 and report.loc["pid", "failure_rate"] == 0.0


def test_report_statistics(straight):
    _, table = straight
    report = cp.campaign_report(table, quantiles=(0.5,))
    pid = table[table["controller"] == "pid"]["max_abs_error_after_6s"]
    assert report.loc["pid", "runs"] == 4
    assert report.loc["pid", "max_abs_error_after_6s q50"] == pytest.approx(pid.median())
    assert report.loc["pid", "max_abs_error_after_6s max"] == pytest.approx(pid.max())
    with pytest.raises(ValueError, match="`quantiles` must be numbers in"):
        cp.campaign_report(table, quantiles=(1.5,))


def test_existing_output_is_never_overwritten(straight, tmp_path):
    spec, _ = straight
    out = tmp_path / "r.csv"
    out.write_text("precious\n")
    with pytest.raises(FileExistsError, match="pass resume=True"):
        cp.run_campaign(spec, out)
    assert out.read_text() == "precious\n"


def test_resume_refuses_another_seed(straight, tmp_path):
    spec, table = straight
    out = tmp_path / "r.csv"
    table.to_csv(out, index=False)
    with pytest.raises(ValueError, match="another spec or seed"):
        cp.run_campaign(spec, out, seed=8, resume=True)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("colour = 3", "colour"),
        ("payload_peak = { min = 3.0, max = 1.0 }", "payload_peak"),
        ("payload_peak = -1.0", "payload_peak"),
        ("controllers = []", "controllers"),
        ('controllers = ["pid", "lqr"]', "controllers"),
        ('controllers = ["pid", "pid"]', "controllers"),
        ('cp = "small"', "cp"),
        ("disturbance_period = 0.0", "disturbance_period"),
        ("t_final = 5.0", "t_final"),
        ("runs = 0", "runs"),
        ("eta = 0.5", "eta"),
        ("payload_omega = { min = 1.0 }", "payload_omega"),
        ('payload_profiles = ["square"]', "payload_profiles"),
        ("initial_error = nan", "initial_error"),
        ("reference_omega = inf", "reference_omega"),
    ],
    ids=[
        "unknown", "min>max", "negative-mass", "no-controllers", "unknown-controller", "repeat", "type",
        "period", "t_final", "runs", "eta", "half-range", "profile", "nan", "inf",
    ],
)
def test_bad_specs_name_the_field(tmp_path, capsys, text, field):
    path = tmp_path / "bad.toml"
    path.write_text(text + "\n")
    with pytest.raises(cp.CampaignSpecError, match=f"campaign spec field `{field}`"):
        cp.load_spec(path)
    assert main(["campaign", str(path), "--output", str(tmp_path / "r.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"`{field}`" in err
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--runs", "0"], "`--runs` must be an integer >= 1"),
        (["--workers", "0"], "`--workers` must be an integer >= 1"),
        (["--output", "r.xlsx"], "`--output` must end in .csv or .parquet"),
        (["--scheduler", "slurm"], "invalid choice"),
    ],
    ids=["runs", "workers", "format", "scheduler"],
)
def test_campaign_cli_bad_options(tmp_path, capsys, tiny_spec, argv, match):
    args = ["campaign", str(tiny_spec), *argv]
    if "--output" not in argv:
        args += ["--output", str(tmp_path / "r.csv")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and match in err


def test_campaign_cli_missing_spec_and_bad_toml(tmp_path, capsys):
    assert main(["campaign", str(tmp_path / "missing.toml")]) == 2
    assert "No such file" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text("controllers = [\n")
    assert main(["campaign", str(bad)]) == 2
    assert "is not valid TOML" in capsys.readouterr().err


@pytest.mark.parquet
def test_campaign_and_report_cli(tmp_path, capsys, tiny_spec):
    out = tmp_path / "r.parquet"
    assert main(["campaign", str(tiny_spec), "--runs", "2", "--output", str(out)]) == 0
    assert "2 scenarios x 2 controllers = 4 rows" in capsys.readouterr().out
    png = tmp_path / "r-report.png"
    assert main(["campaign-report", str(out), "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert "max_abs_error_after_6s q50" in text and "failure_rate" in text and "tracking" in text
    assert png.exists() and png.stat().st_size > 10_000
    png.unlink()
    assert main(["campaign-report", str(out), "--format", "json"]) == 0
    assert '"controller":"pid"' in capsys.readouterr().out.replace(" ", "")
    assert not png.exists()  # the figure is written only when --plot asks for it
    assert main(["campaign-report", str(tmp_path / "nothing.csv")]) == 2
    assert capsys.readouterr().err.startswith("scara_robust: error:")


def test_sinusoidal_reference_matches_paper():
    ref, paper = sr.sinusoidal_reference(1.0, 1.0), sr.paper_reference()
    for t in (0.0, 0.7, 3.0):
        for name in ("position", "velocity", "acceleration"):
            assert getattr(ref, name)(t) == pytest.approx(getattr(paper, name)(t))
    with pytest.raises(ValueError, match="omega"):
        sr.sinusoidal_reference(1.0, 0.0)


def test_parquet_without_pyarrow_is_a_clear_error(monkeypatch, tmp_path, tiny_spec, capsys):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    assert main(["campaign", str(tiny_spec), "--output", str(tmp_path / "r.parquet")]) == 2
    assert "parquet files need pyarrow: pip install '.[parquet]'" in capsys.readouterr().err
    assert not (tmp_path / "r.parquet").exists()


def test_a_campaign_row_is_run_scenario_on_the_drawn_inputs(tiny_spec):
    # One code path: the row's metrics are those of sr.run_scenario on the same inputs, exactly.
    spec = cp.load_spec(tiny_spec)
    draw = cp.draw_scenario(spec, 7, 1)
    rows = {r["controller"]: r for r in run_draw(spec, draw)}
    peak = draw["payload_peak"]
    payload = (
        sr.SinusoidalPayload(0.5 * peak, 0.5 * peak, draw["payload_omega"], draw["payload_phase"])
        if draw["payload_profile"] == "sinusoidal"
        else sr.ConstantPayload(peak)
    )
    for name in spec.controllers:
        res = sr.run_scenario(
            name,
            sr.Scenario("x", (draw["e1_0"], draw["e2_0"]), (0.0, 0.0)),
            t_final=spec.t_final,
            params=sr.ScaraParams(cp=draw["cp"]),
            reference=sr.sinusoidal_reference(draw["reference_amplitude"], draw["reference_omega"]),
            payload=payload,
            disturbance=sr.SquareWave(draw["disturbance_amplitude"], draw["disturbance_period"],
                                      draw["disturbance_phase"]),
        )
        assert {k: rows[name][k] for k in sr.METRIC_NAMES} == res.metrics().to_dict()


def test_checkpoints_bound_the_rewrites_and_lose_nothing(straight, tmp_path):
    spec, table = straight
    out = tmp_path / "r.csv"
    seen: list[int] = []
    cp.run_campaign(spec, out, chunk_size=1, checkpoint=1e9, on_chunk=seen.append)
    assert seen == [1, 4]  # the first chunk, then only the end: no checkpoint fell due
    pd.testing.assert_frame_equal(cp.read_results(out), table)
    with pytest.raises(ValueError, match="`checkpoint` must be >= 0"):
        cp.run_campaign(spec, tmp_path / "bad.csv", checkpoint=-1.0)


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to find the worker processes")
def test_worker_processes_exit_when_the_campaign_is_killed(tmp_path):
    spec = tmp_path / "long.toml"
    spec.write_text('controllers = ["pid"]\nt_final = 20.0\nruns = 400\n')
    out = tmp_path / "r.csv"
    cmd = [sys.executable, "-m", "scara_robust", "campaign", str(spec), "--workers", "2", "--chunk-size", "1",
           "--output", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    workers: list[int] = []
    while time.monotonic() < deadline and proc.poll() is None and not out.exists():
        time.sleep(0.05)
    workers = _children(proc.pid)
    assert len(workers) >= 2 and proc.poll() is None
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.1)
    assert not any(_alive(w) for w in workers)  # none left computing, or blocked on a dead queue
