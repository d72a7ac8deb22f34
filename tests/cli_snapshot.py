"""Snapshot of the command line's behaviour, for refactorings that must not change it.

``python tests/cli_snapshot.py record DIR`` runs every command line of the corpus below (the
guides' commands of every plant kind, and the bad-input corpus of ``tests/test_bad_input.py``)
through ``main(argv)`` in one working folder, in order (later lines read files earlier ones
wrote), and stores for each its exit code, stdout, stderr and the files it wrote (name and
SHA-256). ``python tests/cli_snapshot.py compare DIR_A DIR_B`` prints every difference and
exits 1 if there is one. Elapsed times are the only text masked (``TIMING``): they are
not the command's answer.

The working folder is always the same path, so messages naming a file compare equal.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WORK = Path("/tmp/scara_robust_cli_snapshot")

# what is not the command's answer: elapsed times ("in 1.23 s", "; 2.8 s" after synthesize's gain norm,
# "(10 LMI steps, 2.8 s)", a table's "seconds" column) and the memory this machine has free when a request
# is refused
TIMING = [
    (re.compile(r"\b\d+(\.\d+)? ?(s|ms|min)\b(?= (of solver|of computing|elapsed|wall))"), "<time>"),
    (re.compile(r"(\bin |took |elapsed |wall time |time: )\d+(\.\d+)?( ?(s|ms|min))"), r"\1<time>"),
    (re.compile(r'"(elapsed|seconds|wall_time|time_s|elapsed_s)": [0-9.e+-]+'), r'"\1": <time>'),
    (re.compile(r"(\(bound [^)]*\)); \d+(\.\d+)? s$", re.MULTILINE), r"\1; <time>"),
    (re.compile(r"(\d+ LMI steps, )\d+(\.\d+)? s\)"), r"\1<time>)"),
    (re.compile(r"more than the [0-9.]+ \w+ one request may use on this machine \(50% of the [0-9.]+ \w+ "
                r"available\)"), "more than <memory>"),
]
_NUMBER = re.compile(r"[-+]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?$")

# command lines of every kind, as the guides give them (fast ones; the arm's LMI commands aside)
GOOD = [
    "--help",
    "design --help",
    "design --rho 3 --eta 90",
    "design --rho 3 --eta 90 --bounds derived --elements A --format json",
    "design --rho 3 --eta 90 --format json --output k.json",
    "design --model examples/plant-dc-motor.toml --rho 1 --eta 10",
    "design --model examples/plant-two-mass.toml --rho 30 --eta 10",
    "design --rho 3 --eta 90 --robot examples/robot-light.toml",
    "design --rho 1000 --eta 3 --robot examples/robot-arm6.toml",
    "design --rho 3 --eta 90 --robot examples/robot-scara-urdf.toml",
    "design --model examples/plant-arm-payload.toml --rho 1 --eta 10 --schedule m --breakpoints 3 --rate 1"
    " --format json --output riccati-schedule.json",
    "surface --rho 0.1:10:8 --eta 1:200:8 --elements A",
    "surface --rho 0.1:10:8 --eta 1:200:8 --format csv --output surface-all.csv",
    "surface --rho 0.1:10:6 --eta 1:200:6 --elements A --plot surface.png --mark 3,90",
    "surface --rho 0.5:10:5 --eta 1:200:5 --measure margin --format csv --output margin-map.csv",
    "surface --rho 0.5:10:5 --eta 1:200:5 --robot examples/robot-light.toml",
    "certify --rho 3 --eta 90 --bounds paper",
    "certify --rho 3 --eta 90 --bounds derived",
    "certify --rho 3 --eta 90 --format json",
    "certify --rho 3 --eta 90 --robot examples/robot-light.toml --scenario examples/scenario-light.toml",
    "certify --model examples/plant-dc-motor.toml --rho 1 --eta 10 --max-ts",
    "certify --model examples/plant-two-mass.toml --rho 30 --eta 10",
    "certify --model examples/plant-arm-payload.toml --rho 1 --eta 10",
    "certify --model examples/plant-zoh-benchmark.toml --design examples/gain-zoh.json --max-ts",
    "certify --design examples/scara-pid-controller.yaml --methods lmi-physical",
    "certify --model examples/plant-polytope.toml --rho 1 --eta 10",
    "margin --rho 3 --eta 90 --bounds paper",
    "margin --rho 3 --eta 90 --bounds derived",
    "margin --model examples/plant-dc-motor.toml --rho 1 --eta 10 --rate",
    "margin --model examples/plant-dc-motor.toml --rho 1 --eta 10 --rate --range J=2e-4:0.5",
    "margin --model examples/plant-zoh-benchmark.toml --design examples/gain-zoh.json",
    "simulate --controller pid --scenario large --plot run.png",
    "simulate --controller smc --scenario small --output run.csv",
    "simulate --controller pid-sampled --scenario small --torque-limit 50",
    "simulate --design examples/scara-pid-controller.yaml --t-final 6.5",
    "simulate --robot examples/robot-light.toml --scenario examples/scenario-light.toml",
    "simulate --model examples/plant-dc-motor.toml --rho 1 --eta 10 --profile random-walk --disturbance 0.1"
    " --plot motor-run.png",
    "simulate --model examples/plant-zoh-benchmark.toml --design examples/gain-zoh.json --ts 1.5 --x0 1,0"
    " --t-final 60 --plot zoh-1.5s.png",
    "simulate --rho 1000 --eta 3 --robot examples/robot-arm6.toml --profile sinusoid --t-final 2 --plot arm6-run.png",
    "simulate --rho 1000 --eta 3 --robot examples/robot-arm6.toml --t-final 1 --output arm6.csv",
    "compare --robot examples/robot-light.toml",
    "compare --format markdown",
    "compare --model examples/plant-dc-motor.toml --rho 1 --eta 10 --profile sinusoid --no-synthesis",
    "synthesize --output pid-lmi.json",
    "synthesize --model examples/plant-dc-motor.toml --objective decay --output motor-design.json",
    "synthesize --structure decentralized --objective decay --output pid-decentralized.json",
    "synthesize --model examples/plant-arm-payload.toml --schedule m --breakpoints 3 --rate 1 --gain-bound 20"
    " --output arm-schedule.json",
    "certify --model examples/plant-arm-payload.toml --design arm-schedule.json --rate 1",
    "margin --model examples/plant-arm-payload.toml --design arm-schedule.json",
    "simulate --model examples/plant-arm-payload.toml --design arm-schedule.json --parameter m"
    " --profile constant:1.7 --measurement-bias 0.05",
    "export --model examples/plant-arm-payload.toml --design arm-schedule.json --rate 1 --ts 0.001 --output .",
    "compare --design pid-lmi.json --scenario small",
    "simulate --design pid-lmi.json --t-final 1",
    "export --design pid-lmi.json --ts 0.0005 --prefix pid_lmi --output .",
    "export --design pid-decentralized.json --ts 0.001 --torque-limit 50 --format ros2 --output .",
    "export --rho 3 --eta 90 --ts 0.001 --format json --output .",
    "export --rho 3 --eta 90 --ts 0.001 --torque-limit 50 --output .",
    "export --model examples/plant-dc-motor.toml --rho 1 --eta 10 --ts 5e-4 --precision single --output .",
    "export --model examples/plant-zoh-benchmark.toml --design examples/gain-zoh.json --ts 1.5 --output .",
    "campaign examples/campaign.toml --runs 4 --output results.csv",
    "campaign-report results.csv --worst 2",
    "simulate --from-campaign results.csv --index 1 --controller pid",
    "certify --rho 3 --eta 90 --max-ts",
    "margin --rho 3 --eta 90 --rate",
]


def corpus() -> list[tuple[str, list[str]]]:
    """Every (name, argv) of the snapshot, in the order they run."""
    sys.path.insert(0, str(ROOT / "tests"))
    from test_bad_input import _cli_cases  # noqa: PLC0415 (the test module is no package)

    bad_dir = WORK / "bad"
    bad_dir.mkdir()
    cases = [(f"good-{i:02d} {line}", line.split()) for i, line in enumerate(GOOD)]
    cases += [(f"bad {name}", argv) for name, argv, _ in _cli_cases(bad_dir)]
    return cases


def _files(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and "examples" not in p.parts}


def _mask(text: str) -> str:
    for pattern, replacement in TIMING:
        text = pattern.sub(replacement, text)
    lines, in_table = text.split("\n"), False
    for i, line in enumerate(lines):  # a text table whose last column is "seconds": its rows' last number
        tokens = line.split()  # (the column widths follow the times: spaces are not compared there)
        if tokens and tokens[-1] == "seconds":
            in_table = True
            lines[i] = " ".join(tokens)
        elif not line.strip() or re.match(r"^\s+[\w-]+: ", line):
            in_table = False
        elif in_table:
            lines[i] = " ".join(tokens[:-1] + ["<time>" if _NUMBER.match(tokens[-1]) else tokens[-1]])
    return "\n".join(lines)


def record(out: Path) -> None:
    """Run the corpus and write one JSON line per command line to ``out/snapshot.jsonl``."""
    from scara_robust.cli import main  # noqa: PLC0415

    shutil.rmtree(WORK, ignore_errors=True)
    WORK.mkdir(parents=True)
    (WORK / "examples").symlink_to(ROOT / "examples")
    os.chdir(WORK)
    out.mkdir(parents=True, exist_ok=True)
    with (out / "snapshot.jsonl").open("w") as log:
        for name, argv in corpus():
            before = _files(WORK)
            stdout, stderr = io.StringIO(), io.StringIO()
            start = time.perf_counter()
            with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
                try:
                    code = main(argv)
                except SystemExit as exit_:
                    code = exit_.code if isinstance(exit_.code, int) else 1
            elapsed = time.perf_counter() - start
            after = _files(WORK)
            written = {k: v for k, v in after.items() if before.get(k) != v}
            log.write(json.dumps({"name": name, "code": code, "stdout": _mask(stdout.getvalue()),
                                  "stderr": _mask(stderr.getvalue()), "files": written}) + "\n")
            log.flush()
            print(f"{elapsed:7.1f} s  {code}  {name}", file=sys.__stdout__, flush=True)


def compare(a: Path, b: Path) -> int:
    """Print the differences of two snapshots; 0 if there is none."""
    rows_a = [json.loads(line) for line in (a / "snapshot.jsonl").read_text().splitlines()]
    rows_b = [json.loads(line) for line in (b / "snapshot.jsonl").read_text().splitlines()]
    if [r["name"] for r in rows_a] != [r["name"] for r in rows_b]:
        print("the corpora differ")
        return 1
    differ = 0
    for ra, rb in zip(rows_a, rows_b, strict=True):
        for key in ("stdout", "stderr"):
            ra[key], rb[key] = _mask(ra[key]), _mask(rb[key])
        for key in ("code", "stdout", "stderr", "files"):
            if ra[key] != rb[key]:
                differ += 1
                print(f"--- {ra['name']}: {key}\n  before: {ra[key]!r}\n  after:  {rb[key]!r}")
    print(f"{len(rows_a)} command lines, {differ} differences")
    return 1 if differ else 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "record":
        record(Path(sys.argv[2]).resolve())
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        sys.exit("usage: cli_snapshot.py record DIR | compare DIR_A DIR_B")
