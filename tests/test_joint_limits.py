"""An arm's joint limits from its URDF (or its robot file): references checked, efforts as torque limits.

The limits are read by Pinocchio; the tests read the URDF's ``<limit>`` tags with the standard
library's XML parser, a second reading. The effort-limited payload is checked against a
bisection on Pinocchio's inverse dynamics at each payload, a second computation.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.model.arm import effort_limited_payload

pytestmark = pytest.mark.robots  # skipped without the `robots` extra (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
ARM6, SO101 = str(EXAMPLES / "robot-arm6.toml"), str(EXAMPLES / "robot-so101.toml")


def _urdf_limits(path: Path, joints: list[str]) -> dict[str, dict[str, float]]:
    root = ET.parse(path).getroot()
    out = {}
    for joint in root.findall("joint"):  # the robot's joints, not a transmission's or ros2_control's
        name = joint.get("name")
        if name in joints:
            limit = joint.find("limit")
            out[name] = {k: float(limit.get(k)) if limit is not None and limit.get(k) is not None else math.nan
                         for k in ("lower", "upper", "velocity", "effort")}
            out[name]["continuous"] = joint.get("type") == "continuous"
    return out


def _robot_file(tmp_path: Path, source: str, extra: str = "", reference: dict[str, str] | None = None) -> str:
    text = Path(source).read_text()
    urdf = text.split('urdf = "')[1].split('"')[0]
    text = text.replace(f'urdf = "{urdf}"', f'urdf = "{EXAMPLES / urdf}"\n{extra}')
    for key, value in (reference or {}).items():
        lines = [f"{key} = {value}" if line.startswith(f"{key} = ") else line for line in text.splitlines()]
        text = "\n".join(lines) + "\n"
    path = tmp_path / "robot.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(("robot", "urdf"), [(ARM6, "arm6.urdf"), (SO101, "so101.urdf")])
def test_the_limits_are_the_urdfs(robot, urdf):
    arm = sr.load_arm(robot).arm
    tags = _urdf_limits(EXAMPLES / urdf, list(arm.joints))
    for k, joint in enumerate(arm.joints):
        tag = tags[joint]
        lo, hi = arm.position_limits[k]
        if tag["continuous"]:
            assert (lo, hi) == (-math.inf, math.inf)
        else:
            assert (lo, hi) == (tag["lower"], tag["upper"])
        assert arm.velocity_limits[k] == tag["velocity"] and arm.effort_limits[k] == tag["effort"]


def test_a_robot_file_overrides_them_in_si_units(tmp_path):
    path = _robot_file(tmp_path, SO101, "effort_limits = [1.0, 2.0, 3.0, 4.0, inf]\nvelocity_limits = [5.0, 5.0, 5.0, "
                       "5.0, 5.0]\nposition_limits = [[-1.0, 1.0], [-inf, inf], [-1.5, 1.5], [-1.5, 1.5], [-2.0, 2.0]]")
    arm = sr.load_arm(path).arm
    assert arm.effort_limits.tolist() == [1.0, 2.0, 3.0, 4.0, math.inf]
    assert arm.velocity_limits.tolist() == [5.0] * 5 and arm.position_limits[1].tolist() == [-math.inf, math.inf]


@pytest.mark.parametrize(("extra", "text"), [
    ("effort_limits = [1.0, 2.0]", "`robot.effort_limits` must be 5 numbers in N·m"),
    ("effort_limits = [1.0, 2.0, 3.0, 4.0, -1.0]", "field `robot.effort_limits [N·m]`: must be > 0 (inf: none)"),
    ("velocity_limits = [1.0, 2.0, 3.0, 4.0, 0.0]", "field `robot.velocity_limits [rad/s]`: must be > 0"),
    ("position_limits = [[1.0, -1.0], [-1, 1], [-1, 1], [-1, 1], [-1, 1]]", "lower < upper"),
    ("position_limits = [[1.0], [-1, 1], [-1, 1], [-1, 1], [-1, 1]]", "position_limits[0]` must be 2 numbers"),
])
def test_bad_limits_are_refused_naming_the_field(tmp_path, capsys, extra, text):
    path = _robot_file(tmp_path, SO101, extra)
    assert main(["design", "--rho", "3", "--eta", "90", "--robot", path]) == 2
    err = capsys.readouterr().err
    assert text in err, err
    assert err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize(("reference", "text"), [
    ({"amplitude": "[17.0, 0.3, 0.3, 0.3, 0.3]"},  # degrees written as radians
     "field `reference`: leaves the position limit [-1.91986, 1.91986] rad of joint 'shoulder_pan': center ± "
     "amplitude reaches -17 rad"),
    ({"omega": "[50.0, 50.0, 50.0, 50.0, 50.0]"},
     "field `reference`: leaves the velocity limit 10 rad/s of joint 'shoulder_pan': amplitude × omega reaches 15 "
     "rad/s"),
])
def test_a_reference_outside_a_joint_limit_exits_2_naming_joint_and_limit(tmp_path, capsys, reference, text):
    path = _robot_file(tmp_path, SO101, reference=reference)
    for command in (["design", "--rho", "3", "--eta", "90"], ["simulate", "--rho", "3", "--eta", "90"]):
        assert main([*command, "--robot", path]) == 2
        err = capsys.readouterr().err
        assert text in err and err.count("\n") == 1, err


def test_the_effort_limits_clip_the_total_torque_of_a_run(tmp_path, capsys):
    path = _robot_file(tmp_path, SO101, "effort_limits = [0.3, 0.3, 0.3, 0.3, 0.3]")
    setup = sr.load_arm(path)
    d = sr.design(setup.plant, 3.0, 90.0)
    run = sr.simulate_arm(setup, d.K, t_final=1.0, method="rk4", dt=1e-4)
    free = sr.simulate_arm(setup, d.K, t_final=1.0, method="rk4", dt=1e-4, torque_limit=math.inf)
    assert np.abs(free.torque).max() > 0.3  # the limit binds
    assert np.abs(run.torque).max() == pytest.approx(0.3, rel=0, abs=1e-12)
    assert not np.array_equal(run.e, free.e)
    # the command line: the arm's limits by default, --torque-limit when given (once refused for an arm)
    assert main(["simulate", "--rho", "3", "--eta", "90", "--robot", path, "--t-final", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "total torque clipped to ±[0.3, 0.3, 0.3, 0.3, 0.3] N·m (the arm's effort limits" in out
    assert main(["simulate", "--rho", "3", "--eta", "90", "--robot", SO101, "--t-final", "0.5",
                 "--torque-limit", "0.2"]) == 0
    out = capsys.readouterr().out
    assert "clipped to ±[0.2, 0.2, 0.2, 0.2, 0.2] N·m (--torque-limit)" in out
    assert "peak |τ| = 0.2 N·m" in out


def test_the_effort_limits_are_the_exports_torque_limit(tmp_path, capsys):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    assert main(["export", "--rho", "3", "--eta", "90", "--robot", SO101, "--ts", "0.0001", "--output",
                 str(out_dir), "--allow-uncertified"]) == 0
    text = capsys.readouterr().out
    assert "torque limit [10.0, 10.0, 10.0, 10.0, 10.0] N·m (the arm's effort limits)" in text
    header = (out_dir / "arm_pid.h").read_text() + (out_dir / "arm_pid.c").read_text()
    assert "10" in header and "limit" in header.lower()


def test_the_effort_limited_payload_agrees_with_a_bisection_on_the_inverse_dynamics():
    setup = sr.load_arm(ARM6)
    answer = effort_limited_payload(setup, n_times=721)
    assert answer.joint == "wrist_1_joint" and 10.0 < answer.mass < 20.0
    arm, ref = setup.arm, setup.reference
    times = np.linspace(0.0, ref.period, 721, endpoint=False)
    r, rd, rdd = ref.sample(times)

    def fits(m: float) -> bool:
        tau = np.array([arm.inverse_dynamics(r[k], rd[k], rdd[k], m) for k in range(times.size)])
        return bool(np.all(np.abs(tau) <= arm.effort_limits))

    lo, hi = 0.0, 100.0
    assert fits(lo) and not fits(hi)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    assert answer.mass == pytest.approx(lo, rel=1e-9)
    assert answer.torque[3] == pytest.approx(28.0, rel=1e-9)  # the binding joint at its limit


def test_margin_gives_the_effort_limited_payload_beside_the_stable_one(monkeypatch, capsys):
    from scara_robust.cli import _margin
    monkeypatch.setattr(_margin, "analysis_methods", lambda family, defaults=True: ["theorem1"])  # the cheap one
    assert main(["margin", "--rho", "3", "--eta", "90", "--robot", SO101]) == 0
    out = capsys.readouterr().out
    assert "payload margin of" in out
    assert ("effort: the effort limits carry a payload up to 2.80635 kg along the reference: joint 'shoulder_lift' "
            "reaches its limit") in out


def test_the_compiled_engine_clips_each_joint_at_its_own_limit(tmp_path):
    """Per-joint limits in machine code: the shoulder lift's 25 N·m binds; the held runs agree with rk4's."""
    pytest.importorskip("numba", reason="the compiled engine: pip install '.[compiled]'")
    from test_arm_compiled import small_arm_file

    path = Path(small_arm_file(tmp_path))
    path.write_text(path.read_text().replace(
        "payload_frame", "effort_limits = [150.0, 25.0, 150.0, 28.0, 28.0, 28.0]\npayload_frame", 1))
    setup = sr.load_arm(str(path))
    K = sr.design(setup.plant, 1000, 3).K
    fast, slow = (sr.simulate_arm(setup, K, t_final=3.0, method=m, Ts=1e-3) for m in ("compiled", "rk4"))
    assert np.abs(fast.torque - slow.torque).max() <= 1e-9
    assert np.mean(np.abs(slow.torque[1]) >= 25.0 - 1e-12) > 0.5 and np.abs(slow.torque[1]).max() == 25.0


def test_the_input_limit_certificate_bounds_the_total_torque_by_the_effort_limits(capsys):
    """The feedback's inputs are limited to the effort left over the torque that holds the reference."""
    setup = sr.load_arm(SO101)
    hold = sr.holding_torque(setup)
    ref = setup.reference
    times = np.linspace(0.0, ref.period, 721, endpoint=False)
    r, rd, rdd = ref.sample(times)
    direct = np.max([np.abs(setup.arm.inverse_dynamics(r[k], rd[k], rdd[k], m)) for k in range(times.size)
                     for m in setup.payload_mass], axis=0)
    assert np.allclose(hold, direct, rtol=1e-12, atol=1e-12)
    assert np.array_equal(setup.plant.input_limits, np.maximum(setup.arm.effort_limits - hold, 0.0))
    assert main(["certify", "--rho", "3", "--eta", "90", "--robot", SO101]) == 0
    out = capsys.readouterr().out
    # the joint whose bound binds depends on the Lyapunov matrix found; its limit is its effort left over
    binding = re.search(r"\|tau_(\w+)\| <= \S+ N·m > limit (\S+) N·m", out)
    assert "input limits:" in out and binding is not None
    k = list(setup.arm.joints).index(binding.group(1))
    assert float(binding.group(2)) == pytest.approx(setup.plant.input_limits[k], rel=1e-5)


def test_the_six_joint_example_s_effort_limits_are_its_torque_limits(capsys, tmp_path, monkeypatch):
    setup = sr.load_arm(ARM6)
    assert setup.torque_limit.tolist() == [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]
    assert np.all(setup.plant.input_limits > 0) and np.all(setup.plant.input_limits < setup.torque_limit)
    assert main(["simulate", "--rho", "1000", "--eta", "3", "--robot", ARM6, "--t-final", "0.2"]) == 0
    assert "total torque clipped to ±[150, 150, 150, 28, 28, 28] N·m" in capsys.readouterr().out
    # the page's export (export_pid) hands the certificate and the writer the arm's limits and feedforward
    from scara_robust.workflow import export as workflow_export

    seen = {}
    monkeypatch.setattr(workflow_export, "export_certified",
                        lambda system, controller, folder, **kw: seen.setdefault("controller", controller))
    system = sr.open_system("arm", command="app", robot=SO101)
    sr.export_pid(system, 3.0, 90.0, 1e-3, tmp_path)
    pid = seen["controller"]
    assert pid.torque_limit.tolist() == [10.0] * 5 and pid.feedforward.kind == "gravity"
    assert pid.feedforward.payload == 0.1  # the SO-101 file's nominal payload, kg
