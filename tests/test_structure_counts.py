"""Counts that keep the package's structure, read from the source (ast).

- The command line reads its parsed options by name in one place (``cli/_options.py``):
  nowhere else ``getattr(args, ...)``.
- Code outside the controller layer asks a controller for what it needs (its ``kind``,
  ``Ts``, closed loops, steps), never which class it is: no ``isinstance`` or
  ``check_instance`` on a controller class outside ``controller/``, and no ``isinstance`` on
  ``Design`` outside the module that defines it (``design_or_none`` asks).
- The design page never imports the command line.
- No function is longer than 150 lines.

Each test lists what it found, so a failure names the place.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "scara_robust"
SOURCES = sorted(ROOT.rglob("*.py"))

#: The controller layer's classes.
CONTROLLER_CLASSES = {"DiscretePID", "SampledStateFeedback", "SampledScheduledGain", "ScheduledGain"}
MAX_FUNCTION_LINES = 150


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _relative(path: Path) -> str:
    return path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else path.name


def _names(node: ast.expr) -> set[str]:
    """The class names in the second argument of isinstance: a name, an attribute or a tuple of them."""
    items = node.elts if isinstance(node, ast.Tuple) else [node]
    return {item.id if isinstance(item, ast.Name) else item.attr for item in items
            if isinstance(item, (ast.Name, ast.Attribute))}


def _calls(path: Path, name: str) -> list[ast.Call]:
    return [node for node in ast.walk(_tree(path)) if isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name) and node.func.id == name]


def getattr_on_args(paths: list[Path]) -> list[str]:
    """``file:line`` of every ``getattr(args, ...)``."""
    return [f"{_relative(p)}:{call.lineno}" for p in paths for call in _calls(p, "getattr")
            if call.args and isinstance(call.args[0], ast.Name) and call.args[0].id == "args"]


def class_checks(paths: list[Path], classes: set[str], functions: tuple[str, ...]) -> list[str]:
    """``file:line`` of every call of `functions` whose class argument names one of `classes`."""
    found = []
    for p in paths:
        for name in functions:
            index = 1 if name == "isinstance" else 2  # check_instance(name, value, cls, what)
            found += [f"{_relative(p)}:{call.lineno}" for call in _calls(p, name)
                      if len(call.args) > index and _names(call.args[index]) & classes]
    return found


def long_functions(paths: list[Path], limit: int = MAX_FUNCTION_LINES) -> list[str]:
    """``file:function (lines)`` of every function longer than `limit` lines."""
    return [f"{_relative(p)}:{node.name} ({node.end_lineno - node.lineno + 1})" for p in paths
            for node in ast.walk(_tree(p)) if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno is not None and node.end_lineno - node.lineno + 1 > limit]


def test_options_are_read_in_one_place():
    others = [p for p in SOURCES if _relative(p) != "cli/_options.py"]
    assert getattr_on_args(others) == []


def test_the_one_place_reads_options():
    assert getattr_on_args([ROOT / "cli" / "_options.py"]) != []


def test_no_controller_class_checks_outside_the_controller_layer():
    outside = [p for p in SOURCES if not _relative(p).startswith("controller/")]
    assert class_checks(outside, CONTROLLER_CLASSES, ("isinstance", "check_instance")) == []


def test_no_design_class_checks_outside_its_module():
    outside = [p for p in SOURCES if _relative(p) != "lyapunov/gain.py"]
    assert class_checks(outside, {"Design"}, ("isinstance",)) == []


def test_the_page_does_not_import_the_command_line():
    imports = []
    for p in (ROOT / "app").rglob("*.py"):
        for node in ast.walk(_tree(p)):
            if isinstance(node, ast.ImportFrom) and node.module and (
                    node.module == "cli" or node.module.startswith(("cli.", "scara_robust.cli"))):
                imports.append(f"{_relative(p)}:{node.lineno}")
    assert imports == []


def test_no_function_over_150_lines():
    assert long_functions(SOURCES) == []


@pytest.mark.parametrize("source, expected", [
    ("def f(args):\n    return getattr(args, 'x', None)\n", 1),
    ("def f(ns):\n    return getattr(ns, 'x', None)\n", 0),
], ids=["args", "other-name"])
def test_the_getattr_count_sees_what_it_counts(tmp_path, source, expected):
    probe = tmp_path / "probe.py"
    probe.write_text(source)
    assert len(getattr_on_args([probe])) == expected


@pytest.mark.parametrize("source, expected", [
    ("isinstance(x, DiscretePID)\n", 1),
    ("isinstance(x, (np.ndarray, sr.SampledStateFeedback))\n", 1),
    ("check_instance('pid', x, DiscretePID, 'a PID')\n", 1),
    ("isinstance(x, np.ndarray)\n", 0),
], ids=["name", "tuple-attribute", "check_instance", "other-class"])
def test_the_class_check_count_sees_what_it_counts(tmp_path, source, expected):
    probe = tmp_path / "probe.py"
    probe.write_text(source)
    assert len(class_checks([probe], CONTROLLER_CLASSES, ("isinstance", "check_instance"))) == expected


@pytest.mark.parametrize("n_lines, expected", [(150, 0), (151, 1)], ids=["150", "151"])
def test_the_length_count_sees_a_long_function(tmp_path, n_lines, expected):
    probe = tmp_path / "probe.py"
    probe.write_text("def f():\n" + "    x = 1\n" * (n_lines - 1))
    assert len(long_functions([probe])) == expected
