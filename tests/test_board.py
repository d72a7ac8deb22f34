"""Processor-in-the-loop: the exported C cross-compiled for a Cortex-M4F and run in QEMU (mps2-an386).

The board's outputs on 10⁴ random steps equal the Python step bit for bit in single precision
(the float32 step in the C's order) and within 1e-12 in double (soft-float on FPv4-SP). The
instruction count is checked independently on a step without branches: the traced count of
every call equals the number of instructions of its disassembly (objdump).
"""

from __future__ import annotations

import json
import os
import re
import subprocess

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main

pytestmark = pytest.mark.board
HERE = os.path.dirname(os.path.abspath(__file__))
ARM_FILE = os.path.join(os.path.dirname(HERE), "examples", "robot-arm6.toml")
N_STEPS = 10_000


@pytest.fixture(scope="module")
def scara_pid():
    return sr.design(sr.paper_model(), 3, 90).discretize(1e-3, torque_limit=8.0)


@pytest.fixture(scope="module")
def arm_pid():
    model = sr.load_arm(ARM_FILE).plant.interval_model()
    return sr.design(model, 1000, 3).discretize(1e-3)


def _check(run, n_steps=N_STEPS):
    assert run.n_steps == n_steps and run.u.shape == run.u_reference.shape
    assert run.agrees, run.message
    if run.precision == "single":
        assert run.max_abs_difference == 0.0 and run.tolerance == 0.0  # bit for bit
        assert np.array_equal(run.u.astype(np.float32), run.u_reference.astype(np.float32))
    else:
        assert run.max_abs_difference <= 1e-12 * max(1.0, np.abs(run.u_reference).max())
    assert run.instructions.min() > 0 and run.flash_bytes > 0 and run.ram_bytes >= run.stack_bytes
    assert run.share_of_ts == pytest.approx(run.instructions.max() / run.clock_hz / run.Ts)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_scara_pid_on_the_board_is_the_python_step(scara_pid, precision):
    inputs = sr.board_inputs(scara_pid, N_STEPS)
    run = sr.run_on_board(scara_pid, inputs, precision=precision)
    _check(run)
    saturated = np.mean(np.abs(run.u_reference) >= 8.0 * (1 - 1e-6))
    assert 0.01 < saturated < 0.99  # the limit and its anti-windup are exercised
    if precision == "double":  # soft-float: the compiler's double routines are called, and cost
        assert {"__aeabi_dmul", "__aeabi_dadd"} <= set(run.helpers)
        assert run.instructions.mean() > 10 * 96
    else:
        assert not any(h.startswith("__aeabi_d") for h in run.helpers)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_six_joint_arm_pid_on_the_board(arm_pid, precision):
    run = sr.run_on_board(arm_pid, sr.board_inputs(arm_pid, N_STEPS, seed=1), precision=precision, prefix="arm6_pid")
    _check(run)
    assert run.u.shape == (6, N_STEPS)


def test_six_joint_arm_with_its_gravity_feedforward_on_the_board():
    """The whole controller as certified: the RNEA feedforward in double, the limit on the total torque."""
    setup = sr.load_arm(ARM_FILE)
    pid = sr.design(setup.plant, 1000, 3).discretize(1e-3, torque_limit=list(setup.torque_limit),
                                                        feedforward=sr.arm_feedforward(setup))
    # 10 traced steps: a step of the RNEA in soft double is some 10⁵ instructions, each a line of
    # QEMU's log (0.3 s a step); the benchmark traces the default 100
    run = sr.run_on_board(pid, sr.board_inputs(pid, N_STEPS, seed=4), precision="double", prefix="arm6_pid",
                          trace_steps=10)
    _check(run)
    assert run.u.shape == (6, N_STEPS) and {"cos", "sin"} <= set(run.helpers) and run.instructions.size == 10
    assert np.mean(np.abs(run.u_reference) >= np.asarray(pid.torque_limit)[:, None]) > 0.01  # the limit acts
    with pytest.raises(sr.ArgumentValueError, match="precision"):
        sr.run_on_board(pid, sr.board_inputs(pid, 10), precision="single")


def test_state_feedback_and_schedule_on_the_board():
    feedback = sr.SampledStateFeedback([[3.75, 11.5], [-0.5, 2.0]], 1e-3)
    for precision in ("single", "double"):
        _check(sr.run_on_board(feedback, sr.board_inputs(feedback, 2000), precision=precision), 2000)
    gain = sr.ScheduledGain("m", "kg", [0.0, 1.0, 3.0], np.array([[[1.0, 2.0]], [[1.5, 2.5]], [[3.0, 2.0]]]))
    scheduled = sr.SampledScheduledGain(gain, 1e-3)
    inputs = sr.board_inputs(scheduled, 2000)
    assert (inputs[-1] < 0).any() and (inputs[-1] > 3).any()  # the edge gain is exercised
    for precision in ("single", "double"):
        _check(sr.run_on_board(scheduled, inputs, precision=precision, prefix="sched"), 2000)


def test_instruction_count_is_the_disassembly_of_a_branch_free_step(tmp_path):
    """A 1x3 static state feedback compiles to straight-line code: every call executes each
    instruction of its disassembly once, which the trace must count."""
    feedback = sr.SampledStateFeedback([[1.25, -2.5, 0.75]], 1e-3)
    run = sr.run_on_board(feedback, sr.board_inputs(feedback, 50), precision="single", prefix="k3", workdir=tmp_path)
    dump = subprocess.run(["arm-none-eabi-objdump", "-d", "--no-show-raw-insn", str(tmp_path / "image.elf")],
                          capture_output=True, text=True, check=True).stdout
    body = dump.split("<k3_step>:\n", 1)[1].split("\n\n", 1)[0]
    instructions = [line for line in body.splitlines() if re.match(r"\s+[0-9a-f]+:\s+\S", line)]
    mnemonics = [line.split("\t")[1].split()[0] for line in instructions]
    code = mnemonics[:mnemonics.index("bx") + 1]  # then padding and the literal pool (.word)
    assert not any(m.startswith(("b", "cb", "it")) for m in code[:-1])  # no branch: straight-line
    assert run.instructions.tolist() == [len(code)] * 50 and len(code) > 10


def test_export_target_runs_the_board_and_records_it(tmp_path, capsys):
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--precision", "single",
                 "--target", "cortex-m4f", "--clock", "100e6", "--output", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "cortex-m4f (single precision): 10000 steps equal the Python step bit for bit" in out
    assert "at 100 MHz" in out
    header = (tmp_path / "scara_pid.h").read_text()
    assert "Run on an emulated board: cortex-m4f (single precision)" in header


def _files(folder):
    return sorted(os.listdir(folder))


@pytest.mark.parametrize("argv, words", [
    (["--target", "cortex-m0"], "`--target` must be one of 'cortex-m4f', found 'cortex-m0'"),
    (["--target", "cortex-m4f", "--format", "json"], "--format is 'json', not 'c'"),
    (["--clock", "1e8"], "give --target too"),
    (["--target", "cortex-m4f", "--ts", "0.01"], "nothing written"),  # a Ts the certificate refuses
])
def test_bad_board_input_is_one_line_and_writes_nothing(tmp_path, capsys, argv, words):
    base = ["export", "--rho", "3", "--eta", "90", "--output", str(tmp_path)]
    if "--ts" not in argv:
        base += ["--ts", "0.001"]
    assert main([*base, *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err
    assert _files(tmp_path) == []


def test_missing_toolchain_names_the_packages(tmp_path, capsys, monkeypatch):
    from scara_robust.export import board
    real = board.shutil.which
    monkeypatch.setattr(board.shutil, "which", lambda name: None if name.startswith("qemu") else real(name))
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--target", "cortex-m4f",
                 "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "qemu-system-arm" in err and "gcc-arm-none-eabi" in err and "libnewlib-arm-none-eabi" in err
    assert _files(tmp_path) == []
    with pytest.raises(sr.MissingToolError, match="apt-get install"):
        sr.check_toolchain()


def test_board_run_record_is_json(scara_pid):
    run = sr.run_on_board(scara_pid, sr.board_inputs(scara_pid, 200), trace_steps=20)
    record = json.loads(json.dumps(run.record()))
    assert record["steps"] == 200 and record["instructions per step"]["traced"] == 20
    with pytest.raises(sr.ArgumentValueError, match="`inputs` must have shape"):
        sr.run_on_board(scara_pid, np.zeros((3, 5)))
    with pytest.raises(sr.ArgumentValueError, match="`board`"):
        sr.run_on_board(scara_pid, np.zeros((4, 5)), board="avr")


def test_export_target_runs_a_schedule_and_state_feedback_of_plant_files(tmp_path, capsys):
    """Every kind the command exports goes on the board: a scheduled gain and static state feedback."""
    root = os.path.dirname(HERE)
    plant = sr.load_plant(os.path.join(root, "examples", "plant-arm-payload.toml"))
    schedule = tmp_path / "schedule.json"
    sr.schedule_riccati(plant, "m", np.linspace(0, 2, 3), 1.0, 10.0).save(schedule)
    assert main(["export", "--model", os.path.join(root, "examples", "plant-arm-payload.toml"), "--design",
                 str(schedule), "--ts", "0.001", "--allow-uncertified", "--precision", "single", "--target",
                 "cortex-m4f", "--output", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "cortex-m4f (single precision): 10000 steps equal the Python step bit for bit" in out
    assert main(["export", "--model", os.path.join(root, "examples", "plant-zoh-benchmark.toml"), "--rho", "1",
                 "--eta", "2", "--ts", "0.01", "--allow-uncertified", "--target", "cortex-m4f",
                 "--output", str(tmp_path)]) == 0
    assert "cortex-m4f (double precision): 10000 steps equal the Python step within" in capsys.readouterr().out
