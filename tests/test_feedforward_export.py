"""What runs is what was certified: an arm's PID exported with the model feedforward of its loop.

The robot file's ``feedforward = "gravity"`` is in the certified loop; the export writes it into
the C (RNEA on the arm's bodies, checked against Pinocchio at export), the limit acts on the total
torque as in the simulation, and the JSON records it. Checked here: the feedforward against
Pinocchio; the compiled C against the Python controller on 10⁴ random states; a closed loop in
which the compiled C is called at every sample against ``simulate_arm`` with the same controller;
the refusals (ros2, single precision). The emulated Cortex-M4F run is in tests/test_board.py.
"""

from __future__ import annotations

import ctypes
import dataclasses
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main

pytestmark = pytest.mark.robots  # skipped without the `robots` extra (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[1]
ARM6 = str(ROOT / "examples" / "robot-arm6.toml")
CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler `cc` on this machine: the exported C is not compiled")


@pytest.fixture(scope="module")
def arm6():
    setup = sr.load_arm(ARM6)
    ff = sr.arm_feedforward(setup)
    pid = sr.design(setup.plant, 1000, 3).discretize(1e-3, torque_limit=list(setup.torque_limit), feedforward=ff)
    return setup, ff, pid


@pytest.mark.parametrize("kind", ["gravity", "computed-torque"])
def test_the_feedforward_is_pinocchios(arm6, kind):
    setup = dataclasses.replace(arm6[0], feedforward=kind)
    ff = sr.arm_feedforward(setup)
    assert ff.kind == kind and ff.payload == 1.5
    assert ff.check(setup.arm, n_states=300, seed=3) < 1e-12  # the export's bound is 1e-9


def test_a_feedforward_that_is_not_pinocchios_is_refused(arm6):
    setup, ff, _ = arm6
    wrong = dataclasses.replace(ff, payload=ff.payload, body=ff.body * (1 + 1e-6))
    with pytest.raises(sr.ArgumentValueError, match="differs from Pinocchio's by .* relative"):
        wrong.check(setup.arm)


@pytest.fixture(scope="module")
def compiled(arm6, tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler `cc` on this machine")
    folder = tmp_path_factory.mktemp("ffc")
    files = sr.export_controller(arm6[2], folder, prefix="arm6_pid")
    lib = folder / "libarm6.so"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off", "-shared",
                    "-fPIC", "-o", str(lib), str(files[1]), "-lm"], check=True, capture_output=True, text=True,
                   timeout=120)
    return files, ctypes.CDLL(str(lib))


def _c_steps(lib, pid, inputs):
    n, nz = pid.n_joints, pid.n_state_values
    state = (ctypes.c_double * nz)()
    lib.arm6_pid_init(state)
    vec = ctypes.c_double * n
    out = []
    for k in range(inputs.shape[1]):
        u = vec()
        lib.arm6_pid_step(state, *(vec(*inputs[i * n:(i + 1) * n, k]) for i in range(5)), u)
        out.append(list(u))
    return np.array(out).T


def test_the_compiled_c_is_the_python_controller_on_10k_random_states(arm6, compiled):
    _, ff, pid = arm6
    files, lib = compiled
    header = files[0].read_text()
    assert "gravity feedforward tau_ff = G(r)" in header and "1.5 kg" in header
    inputs = sr.board_inputs(pid, 10_000, seed=2)
    reference = pid.run_steps(inputs, "double")
    u_c = _c_steps(lib, pid, inputs)
    scale = np.abs(reference).max(axis=0)
    assert np.all(np.abs(u_c - reference).max(axis=0) <= 1e-9 * np.maximum(1.0, scale))
    assert np.mean(np.abs(reference) >= pid.torque_limit[:, None]) > 0.01  # the limit on the total acts
    tau = (ctypes.c_double * 6)()
    lib.arm6_pid_feedforward(*((ctypes.c_double * 6)(*inputs[i * 6:(i + 1) * 6, 0]) for i in range(3)), tau)
    assert list(tau) == ff.torque(*(list(inputs[i * 6:(i + 1) * 6, 0]) for i in range(3)))  # bit for bit


def test_a_closed_loop_calling_the_compiled_c_every_sample_is_simulate_arms(arm6, compiled):
    """RK4 at the sample time with the C's torque held, against simulate_arm with the same DiscretePID."""
    setup, _, pid = arm6
    _, lib = compiled
    arm, n, Ts, steps = setup.arm, 6, pid.Ts, 1000
    run = sr.simulate_arm(setup, pid, t_final=steps * Ts)
    state = (ctypes.c_double * pid.n_state_values)()
    lib.arm6_pid_init(state)
    vec = ctypes.c_double * n
    r0, rd0, _ = setup.reference.at(0.0)
    q, qd = r0.copy(), rd0.copy()
    m = setup.payload_nominal

    def f(x, tau):
        return np.concatenate([x[n:], arm.forward_dynamics(x[:n], x[n:], tau, m)])

    x = np.concatenate([q, qd])
    worst = 0.0
    for k in range(steps):
        t = k * Ts
        r, rd, rdd = setup.reference.at(t)
        u = vec()
        lib.arm6_pid_step(state, vec(*r), vec(*rd), vec(*rdd), vec(*x[:n]), vec(*x[n:]), u)
        tau = np.array(list(u))
        worst = max(worst, float(np.abs(x[:n] - run.q[:, k]).max()))
        k1 = f(x, tau)
        k2 = f(x + Ts / 2 * k1, tau)
        k3 = f(x + Ts / 2 * k2, tau)
        k4 = f(x + Ts * k3, tau)
        x = x + Ts / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert run.t.size == steps + 1 and worst <= 1e-6
    assert run.status != "diverged"


def test_the_command_line_exports_the_whole_controller_and_refuses_what_cannot_carry_it(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    base = ["export", "--rho", "1000", "--eta", "3", "--robot", ARM6, "--ts", "0.001"]
    assert main([*base, "--format", "ros2", "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert "gravity feedforward, which a pid_controller file cannot carry" in err and 'feedforward = "none"' in err
    assert err.count("\n") == 1 and not list(out.iterdir())
    assert main([*base, "--precision", "single", "--output", str(out)]) == 2
    assert "exported in double precision" in capsys.readouterr().err and not list(out.iterdir())
    assert main([*base, "--format", "json", "--output", str(out)]) == 0
    text = capsys.readouterr().out
    assert "feedforward gravity at the nominal payload 1.5 kg" in text
    record = json.loads(next(out.glob("*.json")).read_text())
    assert record["feedforward"]["kind"] == "gravity" and record["feedforward"]["payload [kg]"] == 1.5
    assert record["torque_limit"] == [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]


def test_a_schedule_of_an_arm_with_a_feedforward_is_not_exported_without_it(tmp_path, capsys):
    """A schedule's export carries no model feedforward yet: it is refused rather than written without it."""
    schedule = str(ROOT / "examples" / "arm6-schedule.json")
    assert main(["export", "--robot", ARM6, "--design", schedule, "--ts", "0.001", "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "a schedule's export does not carry a model feedforward yet" in err and err.count("\n") == 1
    assert not list(tmp_path.iterdir())


def test_the_trace_s_instruction_count_is_the_line_by_line_count(monkeypatch):
    """The board's instruction count read from QEMU's log in chunks with numpy equals the count line by line."""
    import io
    import re as _re

    from scara_robust.export import board

    rng = np.random.default_rng(3)
    entry, main = 0x4A8, (0x100, 0x180)
    lines = []
    for _ in range(40):  # main's loop, a call to the step, its instructions, back to main
        lines += [f"Trace 0: 0x7f00 [00000000/{rng.integers(0x100, 0x180) & ~1:08x}/00000000/ff200000] main\n"
                  for _ in range(int(rng.integers(1, 4)))]
        lines.append(f"Trace 0: 0x7f00 [00000000/{entry:08x}/00000000/ff200000] k_step\n")
        for _ in range(int(rng.integers(0, 300))):
            pc = int(rng.choice([rng.integers(0x200, 0x900), 0x300])) & ~1
            lines.append(f"Trace 0: 0x7f00 [00000000/{pc:08x}/00000000/ff200000] f\n")
            if rng.random() < 0.05:
                lines.append("----------------\nIN: other output\n")  # not an instruction: not counted
    lines.append(f"Trace 0: 0x7f00 [00000000/{main[0]:08x}/00000000/ff200000] main\n")
    text = "".join(lines)

    def by_line():  # the definition: from the entry to the next instruction in main
        counts, inside, n = [], False, 0
        for line in text.splitlines():
            hit = _re.match(r"^Trace \d+: \S+ \[[0-9a-f]+/([0-9a-f]+)/", line)
            if hit is None:
                continue
            pc = int(hit.group(1), 16)
            if inside and main[0] <= pc < main[1]:
                counts.append(n)
                inside = False
            elif inside:
                n += 1
            elif pc == entry:
                inside, n = True, 1
        return counts

    expected = by_line()
    assert len(expected) == 40 and max(expected) > 100
    for chunk in (1 << 24, 1000, 97):  # the whole log at once, and chunks that cut lines and steps
        monkeypatch.setattr(board, "_TRACE_CHUNK", chunk)
        assert board._count_steps(io.BytesIO(text.encode()), entry, main) == expected
    # pcs of unequal widths are read one by one, to the same values
    assert board._pcs([b"4a8", b"10000"]).tolist() == [0x4A8, 0x10000]
