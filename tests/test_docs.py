"""Every public name is documented numpydoc-style, and every module declares __all__."""

import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import scara_robust

#: Every public module and subpackage, at any depth (``model.robot``, ``studies.campaign.spec``, ...).
MODULES = sorted(
    m.name.removeprefix("scara_robust.")
    for m in pkgutil.walk_packages(scara_robust.__path__, prefix="scara_robust.")
    if not any(part.startswith("_") for part in m.name.split("."))
)


def _public(module):
    return [(n, getattr(module, n)) for n in module.__all__]


@pytest.mark.parametrize("name", MODULES, ids=MODULES)
def test_module_declares_all_and_documents_it(name):
    module = importlib.import_module(f"scara_robust.{name}")
    assert module.__doc__ and hasattr(module, "__all__")
    problems = []
    for attr, obj in _public(module):
        if not (inspect.isfunction(obj) or inspect.isclass(obj)):
            continue
        doc = inspect.getdoc(obj) or ""
        if not doc:
            problems.append(f"{attr}: no docstring")
            continue
        if inspect.isfunction(obj):
            sig = inspect.signature(obj)
            if sig.parameters and "Parameters\n----------" not in doc:
                problems.append(f"{attr}: no Parameters section")
            if sig.return_annotation not in ("None", None, inspect.Signature.empty) and "Returns\n-------" not in doc:
                problems.append(f"{attr}: no Returns section")
    assert problems == []


def test_package_index_lists_every_export():
    for name in scara_robust.__all__:
        assert name in scara_robust.__doc__, f"{name} missing from the package docstring index"


def test_importing_submodules_shadows_no_export():
    # `import scara_robust.compare` (the `python -m` entry point) sets a package attribute;
    # a public name equal to a submodule the package does not import itself would be replaced.
    before = {name: getattr(scara_robust, name) for name in scara_robust.__all__}
    for name in MODULES:
        importlib.import_module(f"scara_robust.{name}")
    after = {n: getattr(scara_robust, n) for n in scara_robust.__all__}
    assert [n for n in before if after[n] is not before[n]] == []


def test_no_export_shares_a_module_name():
    # `import scara_robust.x.y` binds y on x; an export named y would be replaced by the module.
    for name in ["", *MODULES]:
        package = importlib.import_module(f"scara_robust.{name}".rstrip("."))
        children = {m.name for m in pkgutil.iter_modules(getattr(package, "__path__", []))}
        assert not children & set(getattr(package, "__all__", [])), name


def test_every_subpackage_reexports_its_modules():
    for name in MODULES:
        package = importlib.import_module(f"scara_robust.{name}")
        for child in pkgutil.iter_modules(getattr(package, "__path__", [])):
            if child.name.startswith("_"):
                continue
            module = importlib.import_module(f"scara_robust.{name}.{child.name}")
            assert set(module.__all__) <= set(package.__all__), f"{name}.{child.name}"
            assert set(module.__all__) <= set(scara_robust.__all__), f"{name}.{child.name}"


API_PAGES = sorted((Path(__file__).resolve().parents[1] / "docs" / "api").glob("*.md"))


def _api_reference_names() -> list[str]:
    listing = re.compile(r"\.\. autosummary::\n(?:   :[^\n]*\n)*\n((?:   \S+\n)+)")
    names = []
    for page in API_PAGES:
        for block in listing.findall(page.read_text(encoding="utf-8")):
            names += block.split()
    return names


def test_the_api_reference_lists_every_public_name_once():
    names = _api_reference_names()
    assert sorted(names) == sorted(scara_robust.__all__)
    assert len(names) == len(set(names))
