"""Every example in a docstring runs and prints what it shows (doctest)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import scara_robust

#: Every module of the package but the entry points (importing `__main__` runs the command line).
MODULES = sorted(
    m.name for m in pkgutil.walk_packages(scara_robust.__path__, prefix="scara_robust.")
    if not m.name.endswith(("__main__", ".compare"))
)
FINDER = doctest.DocTestFinder(exclude_empty=True)
EXAMPLES = sorted(
    (test.name, module)
    for module in MODULES
    for test in FINDER.find(importlib.import_module(module))
    if test.examples and test.name.startswith(module)  # defined in this module, not re-exported
)


def test_the_docstrings_have_examples():
    assert len(EXAMPLES) >= 40


@pytest.mark.parametrize(("name", "module"), EXAMPLES, ids=[name for name, _ in EXAMPLES])
def test_docstring_example_runs(name, module):
    test = next(t for t in FINDER.find(importlib.import_module(module)) if t.name == name)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report: list[str] = []
    runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
