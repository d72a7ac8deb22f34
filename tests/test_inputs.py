"""Robot and scenario files, and a new user's robot end to end through the CLI."""

import json
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust import InputFileError, load_robot, load_scenario
from scara_robust.cli import main
from scara_robust.io import ROBOT_UNITS

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ROBOTS = ["robot-paper.toml", "robot-light.toml"]


def test_paper_robot_file_is_the_paper_robot():
    assert load_robot(EXAMPLES / "robot-paper.toml") == sr.ScaraParams()


def test_light_robot_file_values():
    p = load_robot(EXAMPLES / "robot-light.toml")
    assert (p.m1, p.m2, p.L1, p.L2) == (1.2, 0.8, 0.25, 0.2)
    assert p.I1 == pytest.approx(p.m1 * p.L1**2 / 12, rel=1e-3)


def test_paper_scenario_file_is_the_paper_scenario():
    scen = load_scenario(EXAMPLES / "scenario-paper.toml")
    t = np.linspace(0, 10, 37)
    assert np.allclose([scen.payload(ti) for ti in t], [sr.paper_payload()(ti) for ti in t])
    for name in ("position", "velocity", "acceleration"):
        assert np.allclose(getattr(scen.reference, name)(t), getattr(sr.paper_reference(), name)(t))
    assert scen.disturbance == sr.paper_disturbance()
    assert (scen.initial.e0, scen.initial.edot0) == (sr.SCENARIOS["large"].e0, sr.SCENARIOS["large"].edot0)


def test_json_robot_file(tmp_path):
    path = tmp_path / "robot.json"
    path.write_text(json.dumps({"robot": {k: getattr(sr.ScaraParams(), k) for k in ROBOT_UNITS}}))
    assert load_robot(path) == sr.ScaraParams()


def test_scenario_file_tables_are_optional(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[payload]\nprofile = "constant"\nmass = 1.5\n')
    scen = load_scenario(path)
    assert scen.payload(3.0) == 1.5 and scen.initial is None
    assert scen.disturbance == sr.paper_disturbance() and scen.name == "s"


#: Each command on both robot files; `compare` of the paper's robot (its file is the paper's robot, whose
#: comparison tests/test_cli.py runs) is in `make test-slow`.
END_TO_END = [
    ["design", "--rho", "3", "--eta", "90", "--format", "json"],
    ["surface", "--rho", "1:5:3", "--eta", "10:100:3", "--format", "json"],
    ["simulate", "--t-final", "6.5", "--format", "json"],
    ["compare", "--t-final", "6.5", "--format", "json"],
]


@pytest.mark.parametrize(("robot", "argv"), [
    pytest.param(robot, argv, id=f"{argv[0]}-{robot.split('-')[1].split('.')[0]}",
                 marks=[pytest.mark.slow] if (argv[0], robot) == ("compare", "robot-paper.toml") else [])
    for argv in END_TO_END for robot in ROBOTS])
def test_own_robot_end_to_end(capsys, robot, argv):
    assert main([*argv, "--robot", str(EXAMPLES / robot)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out


def test_robot_changes_the_result(capsys):
    outs = []
    for robot in ROBOTS:
        assert main(["design", "--rho", "3", "--eta", "90", "--format", "json", "--robot", str(EXAMPLES / robot)]) == 0
        outs.append(json.loads(capsys.readouterr().out))
    assert outs[0]["bounds"] == outs[1]["bounds"] == "derived"
    assert not np.allclose(outs[0]["K"], outs[1]["K"])
    # the paper's robot file gives the same K as the derived model of the default robot
    d = sr.design(sr.derived_model(), 3, 90)
    assert np.allclose(outs[0]["K"], d.K)


def test_scenario_file_on_simulate(capsys):
    scen = str(EXAMPLES / "scenario-light.toml")
    robot = str(EXAMPLES / "robot-light.toml")
    assert main(["simulate", "--robot", robot, "--scenario", scen, "--t-final", "6.5", "--format", "json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scenario"] == "light-pick-and-place"
    assert out["series"]["e1"][0] == pytest.approx(0.1) and out["series"]["e2"][0] == pytest.approx(-0.1)


@pytest.mark.slow  # the README runs the same certify command in make test
def test_scenario_file_on_certify(capsys):
    scen = str(EXAMPLES / "scenario-light.toml")
    robot = str(EXAMPLES / "robot-light.toml")
    assert main(["certify", "--rho", "3", "--eta", "90", "--robot", robot, "--scenario", scen, "--tries", "2"]) == 0
    assert "bounds: derived" in capsys.readouterr().out


def test_published_bounds_refused_with_files(capsys):
    argv = ["design", "--rho", "3", "--eta", "90", "--bounds", "paper", "--robot", str(EXAMPLES / "robot-light.toml")]
    assert main(argv) == 2
    assert "`--bounds paper` holds only for the paper's robot" in capsys.readouterr().err


def test_named_scenario_still_works(capsys):
    assert main(["simulate", "--scenario", "small", "--t-final", "0.5", "--format", "json"]) == 0
    assert json.loads(capsys.readouterr().out)["scenario"] == "small"


def test_loader_errors_are_input_file_errors(tmp_path):
    path = tmp_path / "r.toml"
    path.write_text("[robot]\nm1 = 1.0\n")
    with pytest.raises(InputFileError, match=r"missing field `robot.m2` \[kg\]"):
        load_robot(path)
