"""ros2_control in and out: a pid_controller parameter file read as a gain, a decentralized gain written as one.

Independent checks: the files written are validated against a copy of pid_controller's own
parameter definition (``tests/data/pid_controller.yaml``, ros2_controllers 6.9.0: keys, types,
``one_of`` validators); control_toolbox's PID, re-implemented from its documentation in
``tests/control_toolbox_pid.py`` (which reproduces control_toolbox's own unit tests here), equals
the package's forward-Euler :class:`~scara_robust.DiscretePID` on the SCARA, clamp and
back-calculation included.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
import yaml
from control_toolbox_pid import CtPid

import scara_robust as sr
from scara_robust.cli import main

HERE = os.path.dirname(os.path.abspath(__file__))
DEFINITION = os.path.join(HERE, "data", "pid_controller.yaml")
HAND_WRITTEN = os.path.join(os.path.dirname(HERE), "examples", "scara-pid-controller.yaml")
_TYPES = {"double": float, "string": str, "bool": bool, "string_array": list}


@pytest.fixture(scope="module")
def definition():
    return yaml.safe_load(open(DEFINITION, encoding="utf-8"))["pid_controller"]


def validate(parameters: dict, definition: dict) -> None:
    """Every key of a written pid_controller section is declared by the definition, with its type and validators."""
    for key, value in parameters.items():
        if key == "gains":
            continue
        spec = definition[key]
        assert isinstance(value, _TYPES[spec["type"]]), key
        if spec["type"] == "string_array":
            assert all(isinstance(v, str) for v in value) and value, key
            if "size_lt<>" in spec.get("validation", {}):
                assert spec["validation"]["size_gt<>"] < len(value) < spec["validation"]["size_lt<>"]
        if "not_empty<>" in spec.get("validation", {}):
            assert value, key
    per_dof = definition["gains"]["__map_dof_names"]
    assert sorted(parameters["gains"]) == sorted(parameters["dof_names"])
    for joint, gains in parameters["gains"].items():
        for key, value in gains.items():
            spec = per_dof[key]  # KeyError: a key pid_controller does not declare (it would be ignored)
            kind = _TYPES[spec["type"]]
            assert isinstance(value, kind) and not (kind is float and isinstance(value, bool)), (joint, key)
            one_of = spec.get("validation", {}).get("one_of<>")
            if one_of:
                assert value in one_of[0], (joint, key)


def test_the_package_s_keys_are_the_definition_s(definition):
    per_dof = definition["gains"]["__map_dof_names"]
    declared = {key: _TYPES[spec["type"]] for key, spec in per_dof.items()}
    ours = dict(sr.PID_CONTROLLER_GAINS)
    assert ours.pop("saturation") is bool  # declared by control_toolbox's PidROS, not by the definition
    assert ours == declared


def test_control_toolbox_reimplementation_reproduces_its_unit_tests():
    """control_toolbox's test/pid_tests.cpp expected values (dt = 1 s): the one-sample lag of the integral."""
    pid = CtPid(0, 1, 0, u_clamp_max=5, u_clamp_min=-5)
    assert [pid.compute_command(e, 0.0, 1.0) for e in (-0.5, -0.5, 0.0, 0.0, 1.0, 0.0)] == \
        [0.0, -0.5, -1.0, -1.0, -1.0, 0.0]
    pid = CtPid(0, 1, 0, 10, -10, 5, -5, "back_calculation", tracking_time_constant=1.0)
    assert [pid.compute_command(e, 0.0, 1.0) for e in (1, 2, 3, 1, 2, -1, 1)] == [0, 1, 3, 5, 5, 5, 4]
    pid = CtPid(1, 1, 1, i_clamp_max=10, i_clamp_min=-10, u_clamp_max=5, u_clamp_min=-5)
    assert [pid.compute_command(e, None, 1.0) for e in (-0.5, -0.5, 0.0)] == [-1.0, -1.0, -0.5]


def test_hand_written_file_is_read_and_certified(capsys):
    gains = sr.load_pid_controller(HAND_WRITTEN)
    assert gains.joints == ("q1", "q2") and gains.controller == "scara_pid_controller"
    np.testing.assert_array_equal(gains.K, -np.array([[400, 0, 200, 0, 30, 0], [0, 300, 0, 150, 0, 20]], float))
    np.testing.assert_allclose(gains.tracking_time(), np.sqrt([30 / 400, 20 / 300]))  # control_toolbox's default
    assert main(["certify", "--design", HAND_WRITTEN, "--format", "json"]) == 0
    rows = {row["method"]: row for row in json.loads(capsys.readouterr().out)}
    assert rows["lmi-physical"]["certified"] is True and rows["lmi-physical"]["decay_rate [1/s]"] > 0
    assert rows["falsifier-box"]["certified"] is False  # the published box is not: the robot's own set is


def test_the_file_s_clamp_is_the_run_s_torque_limit(capsys):
    assert main(["simulate", "--design", HAND_WRITTEN, "--t-final", "6.5", "--format", "json"]) == 0
    run = json.loads(capsys.readouterr().out)
    assert run["status"] == "tracking" and run["metrics"]["peak_torque"] == pytest.approx(50.0)


def test_joints_are_matched_by_name(tmp_path, capsys):
    text = open(HAND_WRITTEN, encoding="utf-8").read().replace("dof_names: [q1, q2]", "dof_names: [q2, q1]")
    swapped = tmp_path / "swapped.yaml"
    swapped.write_text(text)
    assert main(["certify", "--design", HAND_WRITTEN, "--method", "lmi-physical", "--format", "json"]) == 0
    first = json.loads(capsys.readouterr().out)
    assert main(["certify", "--design", str(swapped), "--method", "lmi-physical", "--format", "json"]) == 0
    second = json.loads(capsys.readouterr().out)
    # the file's gains belong to the joints they are under: q2's are under q2 whatever dof_names' order
    lmi = [next(r for r in rows if r["method"] == "lmi-physical") for rows in (first, second)]
    assert lmi[0]["decay_rate [1/s]"] == pytest.approx(lmi[1]["decay_rate [1/s]"], rel=1e-6)
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text(text.replace("dof_names: [q2, q1]", "dof_names: [q1, elbow]").replace("q2: {", "elbow: {"))
    assert main(["certify", "--design", str(wrong)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "['q1', 'elbow']" in err and "['q1', 'q2']" in err


@pytest.mark.lmi
def test_decentralized_synthesis_round_trips_through_ros2(tmp_path, capsys, definition):
    design = tmp_path / "decentralized.json"
    assert main(["synthesize", "--structure", "decentralized", "--objective", "decay", "--output", str(design)]) == 0
    text = capsys.readouterr().out
    assert "structure decentralized" in text and "status: certified" in text
    K = np.array(json.loads(design.read_text())["K"])
    off = K.copy()
    for block in range(3):
        off[:, 2 * block:2 * block + 2] -= np.diag(np.diag(K[:, 2 * block:2 * block + 2]))
    assert np.count_nonzero(off) == 0  # each torque reads its own joint only
    assert main(["export", "--design", str(design), "--ts", "0.001", "--torque-limit", "50", "--format", "ros2",
                 "--output", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "pid_controller (forward Euler): Ts = 0.001 s is certified" in out
    assert "the package's Tustin PID at the same Ts: Ts = 0.001 s is certified" in out
    written = yaml.safe_load((tmp_path / "scara_pid.yaml").read_text())
    assert written["controller_manager"]["ros__parameters"]["update_rate"] == 1000
    validate(written["scara_pid"]["ros__parameters"], definition)
    back = sr.load_pid_controller(tmp_path / "scara_pid.yaml")  # YAML out, YAML in: the same gain
    np.testing.assert_array_equal(back.K, K)
    np.testing.assert_array_equal(back.u_clamp, [50.0, 50.0])
    # the file is an analysis command's gain again
    assert main(["certify", "--design", str(tmp_path / "scara_pid.yaml"), "--method", "lmi-physical"]) == 0
    assert "certified" in capsys.readouterr().out


def test_full_synthesis_certifies_at_least_the_decentralized_decay():
    """The restriction gives up decay, never gains it: full >= decentralized, on the robot's own set."""
    samples = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 13), n_masses=3)
    plants = (samples.A, samples.B)
    full = sr.synthesize(plants, objective="decay")
    per_joint = sr.synthesize(plants, objective="decay", structure="decentralized")
    assert full.certified and per_joint.certified and per_joint.structure == "decentralized"
    assert per_joint.verified_decay <= full.verified_decay * (1 + 1e-6) + 1e-9
    sq, sy = sr.decentralized_pattern(6, 2)
    assert np.all(per_joint.K[sy == 0] == 0)  # the pattern holds exactly
    assert np.all(per_joint.P[sq == 0] == 0) or np.abs(per_joint.P[sq == 0]).max() < 1e-12 * np.abs(per_joint.P).max()


def test_coupled_gain_is_refused_on_format_ros2(tmp_path, capsys, monkeypatch):
    def no_lmi(*args, **kwargs):
        raise AssertionError("the refusal comes before any certificate is computed")

    monkeypatch.setattr(sr.LoadedSystem, "decay_rate", no_lmi)
    monkeypatch.setattr("scara_robust.workflow.export.check_sample_time", no_lmi)
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--format", "ros2",
                 "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "coupled (K_" in err and "synthesize --structure decentralized" in err
    assert os.listdir(tmp_path) == []
    pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3, integrator="forward")
    with pytest.raises(sr.ArgumentValueError, match="structure='decentralized'"):
        sr.export_controller(pid, tmp_path, format="ros2")


def test_control_toolbox_pid_is_the_forward_euler_discrete_pid():
    """control_toolbox's equations, run joint by joint, against DiscretePID(integrator='forward') on the SCARA's
    hand-written gains, with the 8 N·m clamp active part of the time and back-calculation."""
    gains = sr.load_pid_controller(HAND_WRITTEN)
    dt, limit = 1e-3, 8.0
    pid = sr.DiscretePID(dt, np.diag(gains.i), np.diag(gains.p), np.diag(gains.d), integrator="forward",
                         torque_limit=limit, tracking_time=gains.tracking_time())
    pid.reset()
    ours = [CtPid(gains.p[j], gains.i[j], gains.d[j], u_clamp_max=limit, u_clamp_min=-limit,
                  antiwindup_strategy="back_calculation", tracking_time_constant=0.0) for j in range(2)]
    assert [c.tracking_time_constant for c in ours] == pytest.approx(list(gains.tracking_time()), rel=1e-15)
    rng = np.random.default_rng(3)
    e = np.cumsum(rng.normal(0, 2e-3, (5000, 2)), axis=0)
    edot = rng.normal(0, 0.05, (5000, 2))
    u_pkg = np.array([pid.step(e[k], edot[k]) for k in range(len(e))])
    u_ct = np.array([[ours[j].compute_command(e[k, j], edot[k, j], dt) for j in range(2)] for k in range(len(e))])
    assert 0.05 < np.mean(np.abs(u_ct) >= limit) < 0.95  # the clamp and its anti-windup are exercised
    assert np.abs(u_pkg - u_ct).max() <= 1e-12 * limit


@pytest.mark.parametrize("change, words", [
    (("p: 200.0", "p: 200"), "must be a float (ROS 2 parameters are typed"),
    (("u_clamp_min: -50.0", "u_clamp_min: -40.0"), "symmetric torque limit"),
    (('antiwindup_strategy: "back_calculation", tracking_time_constant: 0.0}\n      q2',
      'antiwindup_strategy: "clamp", tracking_time_constant: 0.0}\n      q2'), "must be one of"),
    (("command_interface: effort", "command_interface: velocity"), "must be 'effort'"),
    (("d: 30.0,", "d: 30.0, kd: 1.0,"), "not a key of pid_controller's gains"),
    (("command_interface: effort", "command_interface: effort\n    enable_feedforward: true"),
     "`scara_pid_controller.ros__parameters.enable_feedforward` is not a parameter of pid_controller"),
    (("type: pid_controller/PidController", "type: pid_controller/PidControler"),
     "must be 'pid_controller/PidController'"),
    (("update_rate: 1000  # Hz", "update_rate: 1000.0  # Hz"), "update_rate` must be a whole number of Hz"),
])
def test_bad_pid_controller_file_is_one_line(tmp_path, capsys, change, words):
    old, new = change
    text = open(HAND_WRITTEN, encoding="utf-8").read()
    assert old in text
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace(old, new, 1))
    assert main(["certify", "--design", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err and "bad.yaml" in err


def test_what_the_package_s_pid_would_drop_is_refused_on_export(tmp_path, capsys):
    text = open(HAND_WRITTEN, encoding="utf-8").read()
    for old, new, name in (("d: 30.0,", "d: 30.0, i_clamp_max: 10.0, i_clamp_min: -10.0,", "i_clamp"),
                           ("d: 20.0,", "d: 20.0, feedforward_gain: 1.0,", "feedforward_gain"),
                           ("d: 20.0,", "d: 20.0, angle_wraparound: true,", "angle_wraparound")):
        path = tmp_path / f"{name}.yaml"
        path.write_text(text.replace(old, new))
        assert sr.load_pid_controller(path).K.shape == (2, 6)  # read for analysis ...
        out = tmp_path / name
        out.mkdir()
        assert main(["export", "--design", str(path), "--ts", "0.001", "--format", "ros2", "--output", str(out)]) == 2
        err = capsys.readouterr().err.strip()  # ... but not written back without it
        assert len(err.splitlines()) == 1 and f"{name} is set" in err and os.listdir(out) == []


@pytest.mark.parametrize("d", [(30.0, 20.0), (0.0, 0.0)])
def test_export_uses_control_toolbox_s_tracking_time_where_the_file_says_0(tmp_path, capsys, d):
    """tracking_time_constant 0 is control_toolbox's default, sqrt(d/i) or, for a PI, p/i: the C exported
    from the file has that back-calculation, not the package's own default (1 s for a PI)."""
    text = open(HAND_WRITTEN, encoding="utf-8").read().replace("p: 150.0", "p: 120.0")
    text = text.replace("d: 30.0", f"d: {d[0]}").replace("d: 20.0", f"d: {d[1]}")
    path = tmp_path / "pid.yaml"
    path.write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["export", "--design", str(path), "--ts", "0.001", "--allow-uncertified", "--prefix", "pid",
                 "--output", str(out)]) == 0
    capsys.readouterr()
    code = (out / "pid.c").read_text()
    written = [float(v) for v in code.split("AW[2] = {")[1].split("}")[0].split(",")]
    expected = [0.001 / CtPid(p, i, dj, u_clamp_max=50.0, u_clamp_min=-50.0, antiwindup_strategy="back_calculation",
                              tracking_time_constant=0.0).tracking_time_constant
                for p, i, dj in ((200.0, 400.0, d[0]), (120.0, 300.0, d[1]))]
    assert written == pytest.approx(expected, rel=1e-15)
    assert expected[0] != pytest.approx(expected[1])  # per joint, not one value


def test_ros2_options_are_refused_in_one_line_writing_nothing(tmp_path, capsys):
    for extra, words in ((["--integrator", "tustin"], "integrates by forward Euler"),
                         (["--derivative", "filtered"], "velocity interfaces"),
                         (["--precision", "single"], "writes YAML"),
                         (["--ts", "0.0015"], "a whole number of Hz")):
        argv = ["export", "--design", HAND_WRITTEN, "--format", "ros2", "--output", str(tmp_path)]
        argv += extra if "--ts" in extra else ["--ts", "0.001", *extra]
        assert main(argv) == 2, extra
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and words in err, (extra, err)
        assert os.listdir(tmp_path) == []
    assert math.isfinite(sr.load_pid_controller(HAND_WRITTEN).tracking_time()[0])


@pytest.mark.lmi
@pytest.mark.robots
def test_an_arm_s_per_joint_pid_goes_out_with_its_urdf_joint_names(tmp_path, capsys):
    """The 6-joint arm on a coarse grid: a decentralized synthesis at a required decay, written for
    pid_controller under the URDF's joint names, read back (in another dof order) as the same gain."""
    import re

    root = os.path.dirname(HERE)
    text = open(os.path.join(root, "examples", "robot-arm6.toml"), encoding="utf-8").read()
    text = text.replace('urdf = "arm6.urdf"', f'urdf = "{os.path.join(root, "examples", "arm6.urdf")}"')
    text = re.sub(r"^reference_samples = \d+", "reference_samples = 13", text, flags=re.M)
    text = re.sub(r"^payload_samples = \d+", "payload_samples = 3", text, flags=re.M)
    # pid_controller carries no model feedforward: the loop it runs is certified with none (gravity a disturbance)
    text = text.replace('feedforward = "gravity"', 'feedforward = "none"')
    robot = tmp_path / "arm.toml"
    robot.write_text(text, encoding="utf-8")
    design = tmp_path / "arm-pid.json"
    assert main(["synthesize", "--robot", str(robot), "--structure", "decentralized", "--gain-bound", "300",
                 "--decay", "0.5", "--output", str(design)]) == 0
    assert "status: certified" in capsys.readouterr().out
    K = np.array(json.loads(design.read_text())["K"])
    assert main(["export", "--design", str(design), "--robot", str(robot), "--ts", "0.0005", "--torque-limit", "150",
                 "--format", "ros2", "--prefix", "arm6_pid", "--output", str(tmp_path)]) == 0
    assert "pid_controller (forward Euler): Ts = 0.0005 s is certified" in capsys.readouterr().out
    written = yaml.safe_load((tmp_path / "arm6_pid.yaml").read_text())
    assert written["controller_manager"]["ros__parameters"]["update_rate"] == 2000
    joints = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint"]
    assert written["arm6_pid"]["ros__parameters"]["dof_names"] == joints
    back = sr.load_pid_controller(tmp_path / "arm6_pid.yaml")
    np.testing.assert_array_equal(back.K, K)
    # another order of dof_names: the gains follow their joints' names into the arm's order
    params = written["arm6_pid"]["ros__parameters"]
    params["dof_names"] = joints[::-1]
    shuffled = tmp_path / "shuffled.yaml"
    shuffled.write_text(yaml.safe_dump(written, sort_keys=False))
    assert main(["certify", "--design", str(shuffled), "--robot", str(robot), "--methods", "lmi-physical",
                 "--format", "json"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    assert row["certified"] is True


def test_certify_answers_not_certified_for_a_file_whose_nominal_loop_is_unstable(tmp_path, capsys):
    """A pid_controller file cannot carry P; a gain that destabilizes the nominal plant gets a verdict, not an error."""
    path = tmp_path / "unstable.yaml"
    path.write_text(open(HAND_WRITTEN, encoding="utf-8").read().replace("p: 200.0", "p: -200.0"))
    assert main(["certify", "--design", str(path), "--format", "json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["certified"] is False and row["verdict"] == "not certified"
    assert "nominal closed loop is unstable" in row["detail"]
    # numpy, independently: the nominal closed loop has an eigenvalue in the right half-plane
    K = sr.load_pid_controller(path).K
    model = sr.paper_model()
    assert np.linalg.eigvals(model.A - model.B @ K).real.max() > 0
