"""The README and the guide run: every ```python block, every `python -m scara_robust` line of a ```sh block.

```text blocks (synopses, install lines) are not run. Commands run in one scratch folder that
sees the repository's `examples/`, page after page in the order of `PAGES`, at reduced sizes
where a flag allows (shorter horizons, fewer campaign runs and falsifier tries), so neither
the README nor the guide can go stale.
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
#: The pages whose code runs, in the order their commands may read what earlier ones wrote.
PAGES = (
    "README.md",
    "docs/guide/conventions.md",
    "docs/guide/own-robot.md",
    "docs/guide/own-plant.md",
    "docs/guide/own-gain.md",
    "docs/guide/robust.md",
    "docs/guide/variation.md",
    "docs/guide/synthesis.md",
    "docs/guide/which-gain.md",
    "docs/guide/scheduled.md",
    "docs/performance.md",
    "docs/guide/deployment.md",
    "docs/guide/campaigns.md",
    "docs/reproduction.md",
    "docs/development.md",
    "docs/api/registry.md",
)
#: The pages that carry no code of their own (they include the README's, or only link).
PROSE = ("docs/index.md", "docs/getting-started.md", "docs/guide/index.md", "docs/gallery.md", "docs/cli.md",
         "docs/architecture.md", "docs/guide/app.md")
FENCE = re.compile(r"^[ \t]*```(\{[^}\n]*\}|\w*)\n(.*?)^[ \t]*```", flags=re.S | re.M)
BLOCKS = [
    (page, lang, textwrap.dedent(code))
    for page in PAGES
    for lang, code in FENCE.findall((ROOT / page).read_text(encoding="utf-8"))
]
PYTHON = [(page, code) for page, lang, code in BLOCKS if lang == "python"]
#: Each command once, on the first page that shows it.
COMMANDS: list[tuple[str, str]] = []
for _page, _lang, _code in BLOCKS:
    for _line in _code.splitlines() if _lang == "sh" else []:
        if _line.strip().startswith("python -m scara_robust") and _line.strip() not in {c for _, c in COMMANDS}:
            COMMANDS.append((_page, _line.strip()))
#: Calls of the python blocks run at a shorter horizon: tests/test_reproduction.py checks the same
#: table, tests/test_deploy.py the sampled loop at the certified Ts over the whole 20 s.
REDUCED_PYTHON = {
    "sr.error_sensitivity()": "sr.error_sensitivity(t_final=8.0)",
    "d.discretize(ts, torque_limit=50)), scenario)": "d.discretize(ts, torque_limit=50)), scenario, t_final=6.5)",
}


def test_every_page_with_code_is_run():
    """A page of the site with a ```python or ```sh block is in PAGES; the others are in PROSE."""
    def has_code(p: Path) -> bool:
        return bool({lang for lang, _ in FENCE.findall(p.read_text(encoding="utf-8"))} & {"python", "sh"})

    # the API reference is generated; an API page with code of its own (docs/api/registry.md) runs too
    pages = {str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md")
             if "_build" not in p.parts and ("api" not in p.parts or has_code(p)) and p.parent.name != "gallery"}
    assert pages | {"README.md"} == set(PAGES) | set(PROSE)
    for page in PROSE:
        langs = {lang for lang, _ in FENCE.findall((ROOT / page).read_text(encoding="utf-8"))}
        assert not langs & {"python", "sh"}, f"{page} has code to run: list it in PAGES"


#: Options set (added, or their value replaced) to keep each command short; the rest runs as written.
REDUCED = {
    "compare": ["--t-final", "6.5"],
    "simulate": ["--t-final", "6.5"],
    "certify": ["--tries", "2"],
    # two runs in this process on the compiled engine, from the disk cache `make test` fills at its start
    # (tests/conftest.py); worker processes are not started. tests/test_campaign.py runs both engines
    "campaign": ["--runs", "2", "--workers", "1", "--engine", "compiled"],
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
    """One folder for every page, so a command can read what an earlier one wrote."""
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


def test_the_pages_have_code_to_run():
    assert len(PYTHON) >= 2 and len(COMMANDS) >= 10
    assert all(lang in {"python", "sh", "text", "toml", "json", "c", "csv"} or lang.startswith("{")
               for _, lang, _ in BLOCKS), "every block says what it is"


def test_every_reduced_call_is_on_a_page():
    assert all(any(call in code for _, code in PYTHON) for call in (*REDUCED_PYTHON, *PYTHON_SLOW))


def _page_id(page: str) -> str:
    return Path(page).stem


#: Python blocks that run in `make test-slow`: the scheduled guide's table (schedule synthesis, decay and rate
#: bisections for two gains: about 40 s alone); tests/test_scheduled.py runs the same calls at test sizes.
PYTHON_SLOW = ("sr.synthesize_schedule(plant, breakpoints, gain_bound=20.0)",)


def _python_param(index: int) -> object:
    """A block that runs the C on the emulated board needs the board's tools (the ``board`` marker)."""
    page, code = PYTHON[index]
    marks = [pytest.mark.board] if "run_on_board(" in code else []
    if any(call in code for call in PYTHON_SLOW):
        marks.append(pytest.mark.slow)
    return pytest.param(index, id=f"{_page_id(page)}-python-{index}", marks=marks)


@pytest.mark.parametrize("index", [_python_param(i) for i in range(len(PYTHON))])
def test_python_block_runs(scratch, index):
    page, code = PYTHON[index]
    for call, reduced in REDUCED_PYTHON.items():
        code = code.replace(call, reduced)
    exec(compile(code, f"{page} python block {index}", "exec"), {"__name__": "readme"})


#: The arm's LMI-heavy commands (a minute or more each even on the coarse grid) run in `make test-slow`;
#: tests/test_arm.py checks the same answers at test sizes in `make test`.
ARM_SLOW = ("certify", "margin", "synthesize", "compare", "export")


#: SCARA certificates and margins the guide shows (each about 10 s: the LMI over 1024 corners):
#: the light robot's (tests/test_inputs.py runs that robot end to end) and the derived bounds'
#: (tests/test_arm.py and tests/test_robust_certificates.py check them); run in `make test-slow`.
SCARA_SLOW = ("certify --rho 3 --eta 90 --robot examples/robot-light.toml", "certify --rho 3 --eta 90 --bounds derived",
              # the published bounds' certificate table and both margin tables (10 to 13 s each):
              # tests/test_robust_certificates.py and tests/test_margins.py check the same tables
              "certify --rho 3 --eta 90 --bounds paper", "margin --rho 3 --eta 90 --bounds",
              # the light robot's comparison: tests/test_inputs.py runs it end to end
              "compare --robot examples/robot-light.toml",
              # tuning at full size (2 to 3 min each) and the comparison of its design file:
              # tests/test_tracking.py runs the same workflow at test sizes and checks its answers
              "tune --ts", "tune --robot", "compare --design tuned.json",
              # the SCARA's schedule (1.5 to 2 min each): tests/test_scheduled.py synthesizes, certifies and
              # compares schedules at test sizes; the plant file's schedule above runs here in full
              "synthesize --schedule m_p", "compare --design scara-schedule.json",
              "simulate --design scara-schedule.json",
              # the arm's campaign in full (about 2 min, mostly compiling the arm's kernels) and its report:
              # tests/test_campaign_arm.py runs the same command on a reduced spec and checks its table
              "campaign examples/campaign-arm6.toml", "campaign-report arm6.parquet")


#: The scheduled guide's schedule of the plant file (synthesized, then certified, simulated, exported, compared
#: and margined from its file, 15 to 25 s each): tests/test_scheduled.py synthesizes, certifies, compares,
#: simulates and exports schedules at test sizes; the guide's own block runs in `make test-slow`.
SCHEDULE_SLOW = ("arm-schedule.json", "fastest-schedule.json")


def _command_param(page: str, line: str) -> object:
    words = shlex.split(line)
    slow = ((ARM_FILE in words and words[3] in ARM_SLOW) or " ".join(words[3:]).startswith(SCARA_SLOW)
            or any(w in SCHEDULE_SLOW for w in words))
    marks = ([pytest.mark.slow] if slow else []) + ([pytest.mark.board] if "--target" in words else [])
    if any(w.endswith(("robot-panda.toml", "robot-ur5.toml")) for w in words):  # example-robot-data's URDFs
        marks.append(pytest.mark.robot_data)
    return pytest.param(line, id=f"{_page_id(page)}: " + " ".join(words[2:5]), marks=marks)


@pytest.mark.parametrize("line", [_command_param(page, c) for page, c in COMMANDS])
def test_command_runs(scratch, capsys, line):
    code = main(argv_of(line))
    err = capsys.readouterr().err
    assert code == 0, err
    assert "Traceback" not in err and not os.listdir(scratch) == []  # the examples link at least


CC = shutil.which("cc")


@pytest.mark.skipif(CC is None, reason="no C compiler `cc` on this machine: the exported C is not compiled")
def test_the_readme_export_of_your_own_plant_compiles(scratch):
    """The own-plant guide's single-precision export (run above, here) compiles with every warning an error."""
    source = scratch / "motor_pid.c"
    assert source.exists(), "the guide's export command writes motor_pid.c"
    assert "float" in source.read_text() and "double" not in source.read_text()
    assert "u = current [A]" in (scratch / "motor_pid.h").read_text()
    subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", str(source), "-o",
                    str(scratch / "motor_pid.o")], check=True, capture_output=True, timeout=120)


def test_the_readme_simulation_of_your_own_plant_tracks_at_full_length(scratch, capsys):
    """The guide's motor run, at its own 20-s horizon (the command test above shortens it)."""
    line = next(c for _, c in COMMANDS if "simulate" in c and "plant-dc-motor" in c)
    argv = [w for w in shlex.split(line)[3:] if w not in ("--plot", "motor-run.png")]
    assert main(argv) == 0
    assert "status: tracking" in capsys.readouterr().out
