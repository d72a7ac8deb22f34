"""Start-up: ``import scara_robust`` and the command line's ``--help`` without the numerical stack.

Each runs in a fresh interpreter (as a CLI call does) and reports which heavy modules it
imported; the API is bound on first use of a name, the command line imports only the command
given.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import scara_robust as sr

#: Modules that take most of the package's import time.
HEAVY = ("scipy", "pandas", "control", "matplotlib", "cvxpy", "numba", "pinocchio")

_REPORT = "import json, sys; print(json.dumps(sorted(m for m in {heavy} if m in sys.modules)))"


def _heavy_after(code: str) -> list[str]:
    script = f"{code}\n{_REPORT.format(heavy=HEAVY)}"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    return list(json.loads(done.stdout.strip().splitlines()[-1]))


HELP = ("import contextlib, io, runpy, sys\nsys.argv = {argv!r}\n"
        "with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):\n"
        "    try:\n        runpy.run_module('scara_robust', run_name='__main__')\n"
        "    except SystemExit:\n        pass")


@pytest.mark.parametrize(
    "code",
    ["import scara_robust",
     HELP.format(argv=["scara_robust", "--help"]),
     HELP.format(argv=["scara_robust", "--version"]),
     HELP.format(argv=["scara_robust", "desing", "--rho", "3"])],
    ids=["import", "help", "version", "unknown-command"],
)
def test_no_numerical_stack_before_it_is_needed(code):
    assert _heavy_after(code) == []


def test_the_first_name_used_binds_the_whole_api():
    heavy = _heavy_after("import scara_robust as sr\nsr.design")
    assert {"scipy", "control", "pandas"} <= set(heavy)


def test_the_api_is_every_subpackage_s_all():
    import importlib

    names = [name for sub in sr._SUBPACKAGES for name in importlib.import_module(f"scara_robust.{sub}").__all__]
    assert sr.__all__ == names and len(set(names)) == len(names)
    assert set(names) <= set(dir(sr))


def test_an_unknown_name_is_an_attribute_error_naming_it():
    with pytest.raises(AttributeError, match="has no attribute 'desing'"):
        sr.desing  # noqa: B018


def test_help_lists_every_command_with_its_one_line_help(capsys):
    from scara_robust.cli import main
    from scara_robust.cli._parser import COMMAND_HELP

    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    for name, text in COMMAND_HELP.items():
        assert name in out and " ".join(text.replace("%%", "%").split())[:30] in out
