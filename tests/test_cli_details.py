"""Details of the command line: per-joint options, design files, figure formats, marks, typos.

Each bad input exits 2 with one line on stderr naming the option, and writes nothing.
"""

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
import scara_robust.cli._system as loader
from scara_robust.cli import build_parser, main
from scara_robust.cli._common import per_joint_values
from scara_robust.exceptions import ArgumentValueError
from scara_robust.io import load_design

EXPORT = ["export", "--rho", "3", "--eta", "90", "--ts", "0.001"]


def refused(capsys, argv, option):
    """Run `argv`; check exit 2 and one error line naming `option`; return that line."""
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("scara_robust: error: ")
    assert option in err
    return err


# -- 1. torque_limit and tracking_time: one value, or one per torque ------------------------


@pytest.mark.parametrize(
    "options",
    [{"torque_limit": [50.0, 50.0, 50.0]}, {"torque_limit": 50.0, "tracking_time": [1.0, 2.0, 3.0]}],
    ids=["torque-limit-3", "tracking-time-3"],
)
def test_discretize_refuses_a_count_that_is_not_one_per_torque(paper_design, options):
    name = list(options)[-1]
    match = rf"`{name}` must be one value or one per torque \(2\), found 3 values"
    with pytest.raises(ArgumentValueError, match=match):
        paper_design.discretize(1e-3, **options)


def test_discretize_refuses_a_matrix_of_limits(paper_design):
    with pytest.raises(ArgumentValueError, match=r"`torque_limit` must be one value or one per torque \(2\), found "
                                                  r"shape \(2, 2\)"):
        paper_design.discretize(1e-3, torque_limit=np.full((2, 2), 50.0))


@pytest.mark.parametrize(
    ("limit", "expected"), [(50.0, [50.0, 50.0]), ([40.0], [40.0, 40.0]), ([40.0, 30.0], [40.0, 30.0])],
    ids=["scalar", "one-value", "per-torque"],
)
def test_discretize_takes_one_limit_or_one_per_torque(paper_design, limit, expected):
    assert paper_design.discretize(1e-3, torque_limit=limit).torque_limit.tolist() == expected


@pytest.mark.parametrize(
    ("extra", "option"),
    [(["--torque-limit", "50,50,50"], "`--torque-limit` must be one value or one per torque (2), found 3 values"),
     (["--torque-limit", "50", "--tracking-time", "1,2,3"],
      "`--tracking-time` must be one value or one per torque (2), found 3 values")],
    ids=["torque-limit", "tracking-time"],
)
def test_export_refuses_a_count_that_is_not_one_per_joint(capsys, tmp_path, extra, option):
    refused(capsys, [*EXPORT, *extra, "--output", str(tmp_path)], option)
    assert list(tmp_path.iterdir()) == []


# -- 2. one parser for every per-joint option ------------------------------------------------


def _option_type(command, option):
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command]._option_string_actions[option].type


@pytest.mark.parametrize(
    ("command", "option"),
    [("simulate", "--torque-limit"), ("export", "--torque-limit"), ("export", "--tracking-time")],
    ids=["simulate-torque-limit", "export-torque-limit", "export-tracking-time"],
)
def test_per_joint_options_share_one_parser(command, option):
    assert _option_type(command, option) is per_joint_values


@pytest.mark.parametrize(("text", "values"), [("50", [50.0]), ("40,30", [40.0, 30.0])], ids=["one", "two"])
def test_per_joint_values_parses_a_list(text, values):
    assert per_joint_values(text) == values


def test_per_joint_values_refuses_text():
    with pytest.raises(argparse.ArgumentTypeError, match=r"expected a number, found 'x'"):
        per_joint_values("50,x")


def test_simulate_limits_each_joint(capsys, tmp_path):
    out = tmp_path / "run.json"
    assert main(["simulate", "--t-final", "0.2", "--torque-limit", "50,20", "--output", str(out)]) == 0
    assert capsys.readouterr().err == ""
    series = json.loads(out.read_text())["series"]
    peaks = [max(abs(v) for v in series[name]) for name in ("Tc1", "Tc2")]
    assert peaks == pytest.approx([50.0, 20.0])  # the large scenario saturates both joints at once


@pytest.mark.parametrize(
    ("limit", "message"),
    [("50,50,50", "`--torque-limit` must be one value or one per torque (2), found 3 values"),
     ("50,0", "`--torque-limit` must be > 0 N·m, found [50.0, 0.0]")],
    ids=["three-values", "zero"],
)
def test_simulate_refuses_a_bad_torque_limit(capsys, tmp_path, limit, message):
    out = tmp_path / "run.csv"
    refused(capsys, ["simulate", "--torque-limit", limit, "--output", str(out)], message)
    assert not out.exists()


# -- 3. design --format json writes a design file -----------------------------------------------


def test_design_json_is_a_design_file(capsys, tmp_path):
    path = tmp_path / "d.json"
    assert main(["design", "--rho", "3", "--eta", "90", "--format", "json", "--output", str(path)]) == 0
    loaded = load_design(path)
    d = sr.design(sr.paper_model(), 3.0, 90.0)
    assert np.allclose(loaded.K, d.K) and loaded.P is not None and np.allclose(loaded.P, d.P)
    assert loaded.info["method"] == "design" and loaded.info["rho"] == 3.0 and "certified" in loaded.info
    assert main(["simulate", "--design", str(path), "--t-final", "0.5"]) == 0
    out, err = capsys.readouterr()
    assert err == "" and f"gain: design file {path}" in out


# -- 4. figure format from the extension --------------------------------------------------------


@pytest.mark.parametrize("name", ["s.jpg", "s"], ids=["jpg", "no-extension"])
def test_plot_format_is_refused_before_computing(capsys, tmp_path, monkeypatch, name):
    ran = []
    monkeypatch.setattr("scara_robust.cli._simulate.run_scenario", lambda *a, **k: ran.append(1))
    path = tmp_path / name
    refused(capsys, ["simulate", "--plot", str(path)],
            f"`--plot` {str(path)!r}: the format follows the extension; use .png, .pdf or .svg")
    assert ran == [] and not path.exists()


@pytest.mark.parametrize(
    ("name", "magic"), [("s.png", (b"\x89PNG",)), ("s.pdf", (b"%PDF",)), ("s.svg", (b"<?xml", b"<svg"))],
    ids=["png", "pdf", "svg"],
)
def test_plot_is_written_in_the_format_of_its_extension(capsys, tmp_path, name, magic):
    path = tmp_path / name
    assert main(["simulate", "--scenario", "small", "--t-final", "0.2", "--plot", str(path)]) == 0
    assert capsys.readouterr().err == ""
    assert path.read_bytes().startswith(magic)


# -- 5. --mark inside the surface's grid ---------------------------------------------------------


@pytest.mark.parametrize(
    ("mark", "message"),
    [("50,90", "`--mark` rho = 50 is outside the --rho grid [1, 5]"),
     ("3,0.5", "`--mark` eta = 0.5 is outside the --eta grid [1, 100]")],
    ids=["rho-outside", "eta-outside"],
)
def test_surface_refuses_a_mark_outside_the_grid(capsys, tmp_path, monkeypatch, mark, message):
    ran = []
    monkeypatch.setattr("scara_robust.cli._surface.design_surface", lambda *a, **k: ran.append(1))
    png = tmp_path / "f.png"
    refused(capsys, ["surface", "--rho", "1:5:3", "--eta", "1:100:4", "--plot", str(png), "--mark", mark], message)
    assert ran == [] and not png.exists()


# -- 6. a typo is reported as such, before a missing option -------------------------------------


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["design", "--rho", "3", "--etta", "90"], "design: unrecognized arguments: --etta 90; did you mean --eta?"),
     (["design", "--rho", "3", "--etta=90"], "design: unrecognized arguments: --etta=90; did you mean --eta?"),
     (["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--outptu", "x"],
      "export: unrecognized arguments: --outptu x; did you mean --output?")],
    ids=["design-etta", "design-etta-equals", "export-outptu"],
)
def test_typo_is_reported_before_a_missing_option(capsys, argv, message):
    err = refused(capsys, argv, message)
    assert "required" not in err


def test_missing_option_is_still_reported(capsys):
    refused(capsys, ["design", "--rho", "3"], "design: the following arguments are required: --eta")


def test_a_long_table_prints_its_head_on_the_screen_and_all_of_it_into_a_file(tmp_path, capsys):
    from scara_robust.cli._common import SCREEN_ROWS

    argv = ["surface", "--rho", "0.1:10:20", "--eta", "1:200:20"]
    assert main(argv) == 0
    screen = capsys.readouterr().out.rstrip("\n").splitlines()
    assert screen[-1] == f"... {400 - SCREEN_ROWS} more rows, --output F for all"
    out = tmp_path / "surface.txt"
    assert main([*argv, "--output", str(out)]) == 0
    whole = out.read_text(encoding="utf-8").rstrip("\n").splitlines()
    assert len(whole) == 1 + 1 + 400 and not whole[-1].startswith("...")  # header, column names, every point
    assert screen[:-1] == whole[: len(screen) - 1]


@pytest.mark.parametrize("argv, said", [
    (["design", "--rho", "3", "--eta", "90"], "scara_robust: interrupted; nothing was written\n"),
    (["campaign", "examples/campaign.toml", "--runs", "2", "--output", "never.csv"],
     "scara_robust: interrupted; the runs finished so far are kept in --output (continue with --resume)\n"),
], ids=["design", "campaign"])
def test_an_interrupt_says_what_is_kept(monkeypatch, capsys, argv, said):
    """Ctrl-C: exit 130 and one line; only a campaign keeps finished work (it said so for every command)."""
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    monkeypatch.setattr(loader, "open_system", lambda *a, **k: interrupted(a))
    assert main(argv) == 130
    assert capsys.readouterr().err == said


_FROM_THE_HEAP = """
import ctypes, sys
from scara_robust.cli._allocator import keep_freed_memory
libc = ctypes.CDLL(None)


class Info(ctypes.Structure):  # glibc's struct mallinfo2
    _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                      "fsmblks", "uordblks", "fordblks", "keepcost")]


libc.mallinfo2.restype = Info
libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
libc.free.argtypes = [ctypes.c_void_p]
done = keep_freed_memory() if sys.argv[1] == "set" else None
mapped = libc.mallinfo2().hblkhd
block = libc.malloc(24 << 20)
print(done, libc.mallinfo2().hblkhd - mapped < (24 << 20))  # a 24-MB block from the heap, not a mapping of its own
libc.free(block)
"""


@pytest.mark.parametrize("case", ["set", "default", "the user's own"])
def test_a_command_keeps_freed_arrays_in_the_heap_unless_the_user_set_the_allocator(case):
    """glibc: after keep_freed_memory a 24-MB array comes from the heap; the environment's settings stand."""
    import os
    import subprocess
    import sys

    if not (getattr(os, "confstr", None) and (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc")):
        pytest.skip("the allocator's thresholds are glibc's")
    if tuple(int(v) for v in os.confstr("CS_GNU_LIBC_VERSION").split()[1].split(".")[:2]) < (2, 33):
        pytest.skip("mallinfo2 is glibc 2.33's")
    env = {k: v for k, v in os.environ.items() if k not in ("GLIBC_TUNABLES", "MALLOC_MMAP_THRESHOLD_",
                                                              "MALLOC_TRIM_THRESHOLD_")}
    if case == "the user's own":
        env["MALLOC_TRIM_THRESHOLD_"] = str(1 << 30)
    done = subprocess.run([sys.executable, "-c", _FROM_THE_HEAP, "default" if case == "default" else "set"],
                          capture_output=True, text=True, env=env, check=True)
    assert done.stdout.split() == {"set": ["True", "True"], "default": ["None", "False"],
                                   "the user's own": ["False", "False"]}[case], done.stderr
