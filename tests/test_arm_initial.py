"""A URDF arm's runs take an initial error and a disturbance: robot file and command line.

The paper's large-error run (``examples/scenario-paper.toml``: e(0) = (-1.5, 2.5) rad,
ė(0) = (1, 0) rad/s under ±5 N·m square waves of period π/5 s) through the URDF route:
the robot file's ``[initial]`` and ``[disturbance]`` (the scenario file's names, one value
per joint) or ``--e0``, ``--edot0`` and ``--disturbance``. Runs are short (the SCARA's URDF,
2 joints, a fraction of a second simulated).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import scara_robust as sr
from scara_robust.cli import main

pytestmark = pytest.mark.robots  # skipped without the `robots` extra (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[1]
SCARA_FILE = ROOT / "examples" / "robot-scara-urdf.toml"
E0, EDOT0 = [-1.5, 2.5], [1.0, 0.0]  # examples/scenario-paper.toml's [initial]
RUN = ["simulate", "--rho", "3", "--eta", "90", "--t-final", "0.3"]


def arm_file(tmp_path: Path, tables: str) -> str:
    """The SCARA's URDF robot file with `tables` appended."""
    text = SCARA_FILE.read_text(encoding="utf-8").replace('urdf = "scara.urdf"',
                                                          f'urdf = "{ROOT / "examples" / "scara.urdf"}"')
    path = tmp_path / "arm.toml"
    path.write_text(text + "\n" + tables, encoding="utf-8")
    return str(path)


def series(capsys, *argv: str) -> pd.DataFrame:
    assert main([*RUN, *argv, "--format", "csv"]) == 0
    return pd.read_csv(io.StringIO(capsys.readouterr().out))


def refused(capsys, argv: list[str], *texts: str) -> None:
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "Traceback" not in err, err
    for text in texts:
        assert text in err, err


def test_the_command_line_run_starts_from_the_papers_large_error(capsys):
    frame = series(capsys, "--robot", str(SCARA_FILE), f"--e0={E0[0]},{E0[1]}", "--edot0", "1,0")
    assert frame[["e_joint1 [rad]", "e_joint2 [rad]"]].iloc[0].tolist() == E0
    at_rest = series(capsys, "--robot", str(SCARA_FILE))
    assert at_rest[["e_joint1 [rad]", "e_joint2 [rad]"]].iloc[0].tolist() == [0.0, 0.0]
    # a disturbance torque moves the run (the torque column is the controller's, the error shows it)
    pushed = series(capsys, "--robot", str(SCARA_FILE), "--disturbance", "5")
    assert np.abs(pushed["e_joint1 [rad]"] - at_rest["e_joint1 [rad]"]).max() > 1e-3
    assert pushed["e_joint1 [rad]"].iloc[0] == 0.0
    # the summary names both
    assert main([*RUN, "--robot", str(SCARA_FILE), "--e0=-1.5,2.5", "--edot0", "1,0", "--disturbance", "5"]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert head.endswith(", from e0 = [-1.5, 2.5] rad, ė0 = [1, 0] rad/s, disturbance ±[5, 5] N·m square wave of "
                         "period 0.6283 s"), head


def test_the_robot_file_holds_the_initial_error_and_the_disturbance(tmp_path, capsys):
    path = arm_file(tmp_path, "[initial]\ne0 = [-1.5, 2.5]\nedot0 = [1.0, 0.0]\n\n"
                              "[disturbance]\namplitude = 5.0\nperiod = 0.6283185307179586\nphase = 0.0\n")
    setup = sr.load_arm(path)
    assert setup.e0 == tuple(E0) and setup.edot0 == tuple(EDOT0)
    assert setup.disturbance is not None and setup.disturbance(0.1).tolist() == [5.0, 5.0]
    assert math.isclose(setup.disturbance.period, math.pi / 5)
    K = sr.design(setup.plant, 3.0, 90.0).K
    run = sr.simulate_arm(setup, K, t_final=0.3)  # the file's, by default
    assert run.e[:, 0].tolist() == E0 and run.edot[:, 0].tolist() == EDOT0
    plain = sr.simulate_arm(sr.load_arm(SCARA_FILE), K, e0=E0, edot0=EDOT0, t_final=0.3,
                            disturbance=sr.SquareWave(5.0, math.pi / 5, 0.0, (1.0, 1.0)))
    assert np.allclose(run.e, plain.e, rtol=0, atol=1e-12)
    frame = series(capsys, "--robot", path)
    assert frame[["e_joint1 [rad]", "e_joint2 [rad]"]].iloc[0].tolist() == E0
    # the command line overrides the file: at rest, no disturbance
    off = series(capsys, "--robot", path, "--e0", "0", "--edot0", "0", "--disturbance", "0")
    at_rest = series(capsys, "--robot", str(SCARA_FILE))
    assert np.allclose(off["e_joint1 [rad]"], at_rest["e_joint1 [rad]"], rtol=0, atol=1e-12)


def test_bad_counts_and_misplaced_options_get_one_line(tmp_path, capsys):
    arm = ["--robot", str(SCARA_FILE)]
    refused(capsys, [*RUN, *arm, "--e0=-1.5,2.5,0"], "`--e0` takes 1 or 2 values in rad", "found 3")
    refused(capsys, [*RUN, *arm, "--edot0", "1,0,0,0"], "`--edot0` takes 1 or 2 values in rad/s", "found 4")
    refused(capsys, [*RUN, *arm, "--disturbance", "5,5,5"], "`--disturbance` takes 1 or 2 values in N·m", "found 3")
    refused(capsys, [*RUN, *arm, "--e0", "x"], "argument --e0: expected a number")
    refused(capsys, [*RUN, *arm, "--x0", "1,0"], "`--x0` is a plant file's initial state", "--e0")
    refused(capsys, [*RUN, "--e0", "1,2"], "`--e0` is the initial error of a URDF robot's run", "--scenario")
    refused(capsys, [*RUN, "--model", str(ROOT / "examples" / "plant-dc-motor.toml"), "--edot0", "1"],
            "`--edot0` is the initial error of a URDF robot's run", "--x0")
    bad = arm_file(tmp_path, "[initial]\ne0 = [-1.5, 2.5, 0.0]\n")
    refused(capsys, [*RUN, "--robot", bad], "field `initial.e0` must be 2 numbers in rad")
    bad = arm_file(tmp_path, "[disturbance]\nperiod = 1.0\n")
    refused(capsys, [*RUN, "--robot", bad], "missing field `disturbance.amplitude` [N·m]")
    bad = arm_file(tmp_path, "[disturbance]\namplitude = [5.0, 5.0, 5.0]\n")
    refused(capsys, [*RUN, "--robot", bad], "field `disturbance.amplitude` must be 2 numbers in N·m")
    bad = arm_file(tmp_path, "[initial]\ne1 = [0.0, 0.0]\n")
    refused(capsys, [*RUN, "--robot", bad], "`initial.e1`")
