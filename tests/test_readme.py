"""The README runs: every ```python block, and every `python -m scara_robust` line of its ```sh blocks.

```text blocks (the command synopsis) are not run. Commands run in a scratch folder that
sees the repository's `examples/`, at reduced sizes where a flag allows (shorter
horizons, fewer campaign runs and falsifier tries), so the README cannot go stale.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import textwrap
from pathlib import Path

import pytest

from scara_robust.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
BLOCKS = [
    (lang, textwrap.dedent(code))
    for lang, code in re.findall(r"^[ \t]*```(\w*)\n(.*?)^[ \t]*```", README, flags=re.S | re.M)
]
PYTHON = [code for lang, code in BLOCKS if lang == "python"]
COMMANDS = [
    line.strip()
    for lang, code in BLOCKS
    if lang == "sh"
    for line in code.splitlines()
    if line.strip().startswith("python -m scara_robust")
]

#: Options set (added, or their value replaced) to keep each command short; the rest runs as written.
REDUCED = {
    "compare": ["--t-final", "6.5"],
    "simulate": ["--t-final", "6.5"],
    "certify": ["--tries", "2"],
    # two runs in this process on the scipy engine: worker processes would each compile the
    # numba engine (its disk cache is cold in a fresh clone); tests/test_campaign.py runs both
    "campaign": ["--runs", "2", "--workers", "1", "--engine", "scipy"],
    "margin": ["--tol", "0.3", "--tries", "2"],
}
#: Flags added for the same reason (the payload margin has its own tests), and the largest NUM of a range.
REDUCED_FLAGS = {"margin": ["--no-payload"]}  # not with --model: a plant file's margin in its units is quick
MAX_RANGE_NUM = 12
#: The 6-joint arm's file, and the copy on a coarse linearization grid the commands run on here.
ARM_FILE, ARM_TEST_FILE = "examples/robot-arm6.toml", "arm6-test.toml"


def argv_of(line: str) -> list[str]:
    words = shlex.split(line)
    module = words[2]
    argv = (["compare"] if module == "scara_robust.compare" else []) + words[3:]
    reduced = REDUCED.get(argv[0], [])
    for option, value in zip(reduced[::2], reduced[1::2]):
        if option in argv:
            argv[argv.index(option) + 1] = value
        else:
            argv += [option, value]
    if "--model" not in argv:
        argv += [flag for flag in REDUCED_FLAGS.get(argv[0], []) if flag not in argv]
    if ARM_FILE in argv:  # the arm on a coarse grid; its synthesis at one required decay, not bisected
        argv = [ARM_TEST_FILE if word == ARM_FILE else word for word in argv]
        if argv[0] == "synthesize" and "--decay" not in argv:
            argv += ["--decay", "1"]
    for i, word in enumerate(argv):
        parts = word.split(":")
        if len(parts) == 3 and parts[2].isdigit() and int(parts[2]) > MAX_RANGE_NUM:
            argv[i] = f"{parts[0]}:{parts[1]}:{MAX_RANGE_NUM}"
    return argv


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """One folder for the whole README, so a command can read what an earlier one wrote."""
    path = tmp_path_factory.mktemp("readme")
    (path / "examples").symlink_to(ROOT / "examples")
    text = (ROOT / ARM_FILE).read_text(encoding="utf-8").replace('urdf = "arm6.urdf"', 'urdf = "examples/arm6.urdf"')
    for key, value in (("reference_samples", 13), ("payload_samples", 3)):
        text = re.sub(rf"^{key} = \d+", f"{key} = {value}", text, flags=re.M)
    (path / ARM_TEST_FILE).write_text(text, encoding="utf-8")
    return path


@pytest.fixture
def scratch(folder, monkeypatch):
    monkeypatch.chdir(folder)
    return folder


def test_the_readme_has_code_to_run():
    assert len(PYTHON) >= 2 and len(COMMANDS) >= 10
    assert all(lang in {"python", "sh", "text"} for lang, _ in BLOCKS), "every block says what it is"


@pytest.mark.parametrize("index", range(len(PYTHON)), ids=[f"python-{i}" for i in range(len(PYTHON))])
def test_python_block_runs(scratch, index):
    exec(compile(PYTHON[index], f"README.md python block {index}", "exec"), {"__name__": "readme"})


#: The arm's LMI-heavy commands (a minute or more each even on the coarse grid) run in `make test-slow`;
#: tests/test_arm.py checks the same answers at test sizes in `make test`.
ARM_SLOW = ("certify", "margin", "synthesize", "compare", "export")


#: SCARA certificates the README shows twice over (each about 10 s: the LMI over 1024 corners):
#: the light robot's (tests/test_inputs.py runs that robot end to end) and the derived bounds'
#: (tests/test_arm.py and tests/test_robust_certificates.py check them); run in `make test-slow`.
SCARA_SLOW = ("certify --rho 3 --eta 90 --robot examples/robot-light.toml", "certify --rho 3 --eta 90 --bounds derived")


def _command_param(line: str) -> object:
    words = shlex.split(line)
    slow = (ARM_FILE in words and words[3] in ARM_SLOW) or " ".join(words[3:]).startswith(SCARA_SLOW)
    return pytest.param(line, id=" ".join(words[2:5]), marks=[pytest.mark.slow] if slow else [])


@pytest.mark.parametrize("line", [_command_param(c) for c in COMMANDS])
def test_command_runs(scratch, capsys, line):
    code = main(argv_of(line))
    err = capsys.readouterr().err
    assert code == 0, err
    assert "Traceback" not in err and not os.listdir(scratch) == []  # the examples link at least


CC = shutil.which("cc")


@pytest.mark.skipif(CC is None, reason="no C compiler `cc` on this machine: the exported C is not compiled")
def test_the_readme_export_of_your_own_plant_compiles(scratch):
    """The README's single-precision export (run above, in this folder) compiles with every warning an error."""
    source = scratch / "motor_pid.c"
    assert source.exists(), "the README's export command writes motor_pid.c"
    assert "float" in source.read_text() and "double" not in source.read_text()
    assert "u = current [A]" in (scratch / "motor_pid.h").read_text()
    subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", str(source), "-o",
                    str(scratch / "motor_pid.o")], check=True, capture_output=True, timeout=120)


def test_the_readme_simulation_of_your_own_plant_tracks_at_full_length(scratch, capsys):
    """The README's motor run, at its own 20-s horizon (the command test above shortens it)."""
    line = next(c for c in COMMANDS if "simulate" in c and "plant-dc-motor" in c)
    argv = [w for w in shlex.split(line)[3:] if w not in ("--plot", "motor-run.png")]
    assert main(argv) == 0
    assert "status: tracking" in capsys.readouterr().out
