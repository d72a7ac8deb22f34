import json
import subprocess
import sys

import pytest

import scara_robust as sr
import scara_robust.cli._surface as surface_command
from scara_robust.cli import main


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_design_json_keys(capsys):
    code, out, err = run(capsys, ["design", "--rho", "3", "--eta", "90", "--format", "json"])
    assert code == 0 and err == ""
    data = json.loads(out)
    assert {"rho", "eta", "K", "closed_loop_hurwitz", "max_eig_Z", "certified"} <= set(data)
    assert len(data["K"]) == 2 and len(data["K"][0]) == 6
    assert data["K"][0][0] == pytest.approx(-155.5, abs=0.05)
    assert data["closed_loop_hurwitz"] is True and data["certified"] is False


def test_design_text_elements_a(capsys):
    code, out, _ = run(capsys, ["design", "--rho", "3", "--eta", "90", "--elements", "A", "--bounds", "derived"])
    assert code == 0 and "certified: True" in out and "ΔA[4, 3]" in out


def test_surface_csv_and_plot(capsys, tmp_path):
    png = tmp_path / "s.png"
    code, out, _ = run(
        capsys,
        ["surface", "--rho", "1:5:3", "--eta", "1:100:4", "--format", "csv", "--elements", "A", "--plot", str(png)],
    )
    lines = out.strip().splitlines()
    assert code == 0 and lines[0] == "rho,eta,max_eig_Z,closed_loop_hurwitz,certified" and len(lines) == 13
    assert png.stat().st_size > 1000


def test_surface_json_to_file(capsys, tmp_path):
    target = tmp_path / "s.json"
    code, out, _ = run(
        capsys, ["surface", "--rho", "1:2:2", "--eta", "1:2:2", "--format", "json", "--output", str(target)]
    )
    assert code == 0 and out == f"wrote {target}\n"  # the table in the file, one line saying so
    rows = json.loads(target.read_text())
    assert len(rows) == 4 and {"rho", "eta", "max_eig_Z", "closed_loop_hurwitz"} <= set(rows[0])
    assert not list(tmp_path.glob(".tmp-*"))


def test_simulate_json(capsys):
    code, out, _ = run(
        capsys, ["simulate", "--controller", "pid", "--scenario", "small", "--t-final", "7", "--format", "json"]
    )
    data = json.loads(out)
    assert code == 0 and data["metrics"]["max_abs_error_after_6s"] < 0.05 and len(data["series"]["t"]) == 7001


def test_compare_json(capsys):
    code, out, _ = run(capsys, ["compare", "--t-final", "6.5", "--format", "json"])
    rows = json.loads(out)
    assert code == 0 and len(rows) == 8  # pid, pid-lmi, smc, smc-sign on both scenarios
    assert set(rows[0]) == {
        "controller",
        "scenario",
        "payload",
        "max_abs_error_after_6s",
        "rms_error_after_6s",
        "peak_torque",
        "max_abs_torque_after_6s",
        "chattering_index",
        "control_energy",
        "status",
        "status_reason",
    }
    assert {row["status"] for row in rows} == {"tracking"}


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["design", "--rho", "0", "--eta", "90"], "`--rho` must be > 0"),
        (["design", "--rho", "3", "--eta", "0.5"], "`--eta` must be >= 1"),
        (["design", "--rho", "nan", "--eta", "90"], "--rho"),
        (["design", "--rho", "3", "--eta", "inf"], "--eta"),
        (["design", "--rho", "abc", "--eta", "90"], "--rho"),
        (["design", "--rho", "3"], "--eta"),
        (["design", "--rho", "3", "--eta", "90", "--bounds", "mine"], "--bounds"),
        (["design", "--rho", "3", "--eta", "90", "--elements", "C"], "--elements"),
        (["surface", "--rho", "1:2", "--eta", "1:2:3"], "START:STOP:NUM"),
        (["surface", "--rho", "1:2:x", "--eta", "1:2:3"], "START:STOP:NUM"),
        (["surface", "--rho", "1:2:0", "--eta", "1:2:3"], "NUM must be >= 1"),
        (["surface", "--rho", "nan:2:3", "--eta", "1:2:3"], "finite"),
        (["surface", "--rho=-1:2:3", "--eta", "1:2:3"], "`--rho` must be > 0"),
        (["surface", "--rho", "1:2:3", "--eta", "0:2:3"], "`--eta` must be >= 1"),
        (["simulate", "--controller", "lqr"], "--controller"),
        (["simulate", "--scenario", "huge"], "--scenario"),
        (["simulate", "--t-final", "0"], "`--t-final` must be > 0"),
        (["simulate", "--t-final", "-3"], "`--t-final` must be > 0"),
        (["simulate", "--torque-limit", "0"], "`--torque-limit` must be > 0"),
        (["compare", "--t-final", "5"], "`--t-final` must be > 6"),
        (["compare", "--format", "xml"], "--format"),
        (["compare", "--payload", "maybe"], "--payload"),
        (["bogus"], "invalid choice"),
        ([], "required"),
    ],
    ids=[
        "rho0",
        "eta-small",
        "rho-nan",
        "eta-inf",
        "rho-text",
        "eta-missing",
        "bounds",
        "elements",
        "range-2",
        "range-text",
        "range-num0",
        "range-nan",
        "range-neg-rho",
        "range-eta",
        "controller",
        "scenario",
        "t-final-0",
        "t-final-neg",
        "torque-limit",
        "compare-t-final",
        "format",
        "payload",
        "command",
        "no-command",
    ],
)
def test_bad_cli_input_one_line_exit_2(capsys, argv, needle):
    code, out, err = run(capsys, argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("scara_robust: error:") and needle in err
    assert "Traceback" not in err


@pytest.mark.parametrize("kind", ["missing-dir", "is-dir"], ids=["missing-dir", "is-dir"])
def test_unwritable_output(capsys, tmp_path, kind):
    target = tmp_path / "nope" / "out.json" if kind == "missing-dir" else tmp_path
    code, out, err = run(capsys, ["design", "--rho", "3", "--eta", "90", "--output", str(target)])
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err


def test_python_dash_m_subprocess():
    done = subprocess.run(
        [sys.executable, "-m", "scara_robust", "design", "--rho", "-1", "--eta", "90"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "`--rho` must be > 0" in done.stderr
    done = subprocess.run(
        [sys.executable, "-m", "scara_robust.compare", "--help"], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0 and "--t-final" in done.stdout


def test_simulate_plot_and_csv(capsys, tmp_path):
    png, csv = tmp_path / "fig3.png", tmp_path / "run.csv"
    code, out, _ = run(capsys, ["simulate", "--scenario", "small", "--t-final", "1", "--plot", str(png),
                                "--output", str(csv)])
    assert code == 0 and png.stat().st_size > 5000
    header = csv.read_text().splitlines()[0]
    assert header == "t,e1,e2,e1_dot,e2_dot,Tc1,Tc2,Td1,Td2,m_p"


def test_surface_margin_plot_draws_the_margin(capsys, tmp_path, monkeypatch):
    """--measure margin --plot draws θ (plot_margin_map), marked at its largest; it drew max λ(Z)."""
    drawn = []

    def spy(surface, mark=None):
        drawn.append((surface.margin is not None, mark, surface.best_margin()[:2]))
        return sr.plot_margin_map(surface, mark=mark)

    monkeypatch.setattr(surface_command, "plot_margin_map", spy)
    png = tmp_path / "m.png"
    code, out, _ = run(capsys, ["surface", "--rho", "1:5:3", "--eta", "1:200:3", "--measure", "margin",
                                "--plot", str(png)])
    assert code == 0 and png.stat().st_size > 1000
    assert len(drawn) == 1 and drawn[0][0] and drawn[0][1] == drawn[0][2]  # θ, marked at its largest
