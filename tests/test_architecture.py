"""The import graph of the package, read from its source (ast): no cycle, and nothing imports upward.

Every module is placed on a layer (``LAYERS``, bottom first). A module may import its own
subpackage and any layer below its own, never one above nor a sibling on its own layer
(robustness and simulation stay independent); front ends (the command line)
sit on top and no other module imports them or ``argparse``. Imports inside functions and
under ``TYPE_CHECKING`` count like module-level ones: a cycle hidden in a function is a
cycle all the same.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "scara_robust"
PACKAGE = "scara_robust"

#: Layers, bottom first. A module belongs to the first entry that is its name or a prefix of it.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("scara_robust.exceptions", "scara_robust.paper", "scara_robust.results", "scara_robust._deprecation"),
    ("scara_robust._validation", "scara_robust._resources", "scara_robust._progress"),
    ("scara_robust.sdp",),  # the LMI solver: numpy, scipy and the validation helpers only
    ("scara_robust.model",),
    ("scara_robust.controller",),
    ("scara_robust.lyapunov",),
    ("scara_robust.robustness", "scara_robust.simulation"),
    ("scara_robust.io",),
    ("scara_robust.export",),
    ("scara_robust.studies",),
    ("scara_robust.plotting",),
    ("scara_robust.workflow",),  # what the front ends share: the system of a user's files
    ("scara_robust",),  # the package's __init__: re-exports the library
    ("scara_robust.app",),  # the web page: a front end the command line serves
    ("scara_robust.cli", "scara_robust.compare", "scara_robust.__main__"),
)
FRONT_ENDS = LAYERS[-1]


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the package modules it imports (anywhere in its source)."""
    files = {module_name(p, root): p for p in root.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for module, path in files.items():
        targets: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(module, path.name == "__init__.py", node)
                targets.add(base)
                # `from . import x` imports the submodule x when there is one
                targets.update(f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in files)
        graph[module] = {t for t in targets if t in files and t != module}
    return graph


def imports_argparse(root: Path = ROOT) -> set[str]:
    found = set()
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module or ""]
            if any(n.split(".")[0] == "argparse" for n in names):
                found.add(module_name(path, root))
    return found


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def layer(module: str) -> tuple[int, str]:
    """(rank, group) of a module: the most specific entry of LAYERS that contains it."""
    best: tuple[int, str] | None = None
    for rank, group in enumerate(LAYERS):
        for prefix in group:
            # the package itself is its __init__ alone; every other entry covers its submodules
            if module == prefix or (prefix != PACKAGE and module.startswith(prefix + ".")):
                if best is None or len(prefix) > len(best[1]):
                    best = (rank, prefix)
    if best is None:
        raise AssertionError(f"module {module} is on no layer of LAYERS")
    return best


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    bad = []
    for module, targets in graph.items():
        rank, group = layer(module)
        for target in targets:
            t_rank, t_group = layer(target)
            if t_group == group:
                continue
            # a package __init__ may import its own children
            if target.startswith(module + "."):
                continue
            # siblings on one layer stay apart, except front ends, which may share the CLI
            if t_rank > rank or (t_rank == rank and rank != len(LAYERS) - 1):
                bad.append(f"{module} -> {target}")
    return sorted(bad)


def check(root: Path = ROOT) -> list[str]:
    """Every violation of the architecture's rules in the tree at `root`."""
    graph = import_graph(root)
    problems = [f"cycle: {' <-> '.join(c)}" for c in cycles(graph)]
    try:
        problems += [f"upward import: {edge}" for edge in upward_imports(graph)]
    except AssertionError as err:
        problems.append(str(err))
    front = {m for m in graph if layer(m)[1] in FRONT_ENDS} if not any("on no layer" in p for p in problems) else set()
    for module, targets in graph.items():
        if module in front:
            continue
        problems += [f"{module} imports the front end {t}" for t in sorted(targets) if t in front]
    problems += [f"{m} imports argparse" for m in sorted(imports_argparse(root) - front)]
    return problems


def test_no_cycle_no_upward_import_no_argparse_below_the_cli():
    assert check() == []


def test_every_module_is_on_a_layer():
    for module in import_graph():
        layer(module)


def test_the_library_does_not_import_the_front_end():
    graph = import_graph()
    library = [m for m in graph if layer(m)[1] not in FRONT_ENDS]
    assert library and not [m for m in library if any(layer(t)[1] in FRONT_ENDS for t in graph[m])]


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        ({"a.py": "from . import b\n", "b.py": "def f():\n    from . import a\n"}, "cycle"),
        ({"model/__init__.py": "", "model/x.py": "from ..lyapunov import y\n", "lyapunov/__init__.py": "",
          "lyapunov/y.py": ""}, "upward import: scara_robust.model.x -> scara_robust.lyapunov.y"),
        ({"io.py": "import argparse\n"}, "scara_robust.io imports argparse"),
        ({"io.py": "def f():\n    from .cli import main\n", "cli/__init__.py": ""}, "imports the front end"),
    ],
    ids=["hidden-cycle", "upward", "argparse", "front-end"],
)
def test_the_checker_finds_each_fault(tmp_path, files, expected):
    # The rules must be able to fail: plant each fault in a small fake package.
    root = tmp_path / PACKAGE
    for name, text in {"__init__.py": "", **files}.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    problems = check(root)
    assert any(expected in p for p in problems), problems


#: The uncertainty descriptions: only ``model/`` may ask which one it holds.
MODEL_TYPES = frozenset({"UncertainLTVModel", "PolytopicModel", "UncertainPlant", "PhysicalSamples", "RobotArm"})


def _type_names(node: ast.AST) -> set[str]:
    elements = node.elts if isinstance(node, ast.Tuple) else [node]
    names = set()
    for el in elements:
        if isinstance(el, ast.Name):
            names.add(el.id)
        elif isinstance(el, ast.Attribute):
            names.add(el.attr)
    return names


def model_type_tests(root: Path = ROOT) -> list[str]:
    """``isinstance(x, T)`` or ``check_instance(name, x, T, ...)`` with T a model type, outside ``model/``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        module = module_name(path, root)
        if module == f"{PACKAGE}.model" or module.startswith(f"{PACKAGE}.model."):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Call) or not isinstance(node.func, (ast.Name, ast.Attribute)):
                continue
            func = node.func.id if isinstance(node.func, ast.Name) else node.func.attr
            position = {"isinstance": 1, "check_instance": 2}.get(func)
            if position is None or len(node.args) <= position:
                continue
            hit = _type_names(node.args[position]) & MODEL_TYPES
            if hit:
                found.append(f"{module}:{node.lineno} {func}(..., {', '.join(sorted(hit))})")
    return found


def test_no_isinstance_on_a_model_type_outside_model():
    # every consumer uses the shared interface (kind, vertex_closed_loops, interval_hull, as_model...)
    assert model_type_tests() == []


@pytest.mark.parametrize(
    "source",
    ["isinstance(m, PolytopicModel)\n", "isinstance(m, (UncertainLTVModel, int))\n",
     "check_instance('model', m, sr.UncertainPlant, 'a plant')\n"],
    ids=["isinstance", "tuple", "check-instance"],
)
def test_the_model_type_checker_finds_each_form(tmp_path, source):
    root = tmp_path / PACKAGE
    (root / "robustness").mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "robustness" / "x.py").write_text(source)
    (root / "model").mkdir()
    (root / "model" / "y.py").write_text(source)  # allowed inside model/
    assert [p.split(":")[0] for p in model_type_tests(root)] == [f"{PACKAGE}.robustness.x"]


# --- one registry of methods, one place that knows the plant's kind -------------------------------

#: The one module of the command line that chooses the plant's kind from the arguments.
SYSTEM_LOADER = f"{PACKAGE}.cli._system"
#: The arguments that name the plant's kind: read by the loader alone.
KIND_ARGUMENTS = frozenset({"model", "robot", "arm_file"})
#: Method lists allowed outside the registry, and why.
METHOD_LIST_EXCEPTIONS = {
    f"{PACKAGE}.lyapunov.surface": "MARGIN_MAP_METHODS: the surface's own vectorized formulas of the two exact "
                                    "margins, a layer below the registry",
}


def registered_names() -> dict[str, frozenset[str]]:
    """Every registered method name, by family (the package's own registry)."""
    import scara_robust as sr

    return {family: frozenset(sr.analysis_methods(family)) for family in sr.METHOD_FAMILIES}


def method_lists(root: Path = ROOT, names: dict[str, frozenset[str]] | None = None) -> list[str]:
    """Literal lists of method names outside the registry: three or more of one family, or a ``*_METHODS`` constant."""
    names = registered_names() if names is None else names
    found = []
    for path in sorted(root.rglob("*.py")):
        module = module_name(path, root)
        if module in METHOD_LIST_EXCEPTIONS:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        constants = {id(node.value) for node in ast.walk(tree) if isinstance(node, (ast.Assign, ast.AnnAssign))
                     and any(isinstance(t, ast.Name) and t.id.endswith("_METHODS")
                             for t in (node.targets if isinstance(node, ast.Assign) else [node.target]))}
        for node in ast.walk(tree):
            if isinstance(node, ast.Dict):
                items = node.keys
            elif isinstance(node, (ast.Tuple, ast.List, ast.Set)):
                items = node.elts
            else:
                continue
            strings = {e.value for e in items if isinstance(e, ast.Constant) and isinstance(e.value, str)}
            for family, registered in names.items():
                count = len(strings & registered)
                if count >= 3 or (count >= 2 and id(node) in constants):
                    found.append(f"{module}:{node.lineno} lists {count} {family} methods")
                    break
    return found


def kind_branches(root: Path = ROOT) -> list[str]:
    """Branches on the plant's kind outside ``model/`` and the command line's loader."""
    found = []
    for path in sorted(root.rglob("*.py")):
        module = module_name(path, root)
        if module.startswith(f"{PACKAGE}.model.") or module in (f"{PACKAGE}.model", SYSTEM_LOADER, f"{PACKAGE}.io"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare) and isinstance(node.left, ast.Attribute) and node.left.attr == "kind":
                values = {c.value for c in node.comparators if isinstance(c, ast.Constant)}
                if values & {"box", "polytope"}:
                    found.append(f"{module}:{node.lineno} compares .kind with {sorted(values)}")
            elif (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "args"
                  and node.attr in KIND_ARGUMENTS):
                found.append(f"{module}:{node.lineno} reads args.{node.attr}")
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "getattr" \
                    and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant) \
                    and node.args[1].value in KIND_ARGUMENTS:
                found.append(f"{module}:{node.lineno} probes getattr(..., {node.args[1].value!r})")
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "is_arm_file":
                found.append(f"{module}:{node.lineno} calls is_arm_file")
    return found


def test_no_method_list_outside_the_registry():
    # the tables, the command line and the page iterate the registry (scara_robust.analysis_methods)
    assert method_lists() == []


def test_no_branch_on_the_plant_kind_outside_the_model_and_the_loader():
    # code above the model asks what a system can do (capabilities); the command line loads it once
    assert kind_branches() == []


@pytest.mark.parametrize(
    ("source", "expected"),
    [("choices = ('all', 'theorem1', 'vertex', 'lmi')\n", "lists 3 margin methods"),
     ("MY_METHODS = ('lmi-box', 'lmi-physical')\n", "lists 2 certificate methods"),
     ("rows = {'theorem1': 1, 'vertex': 2, 'frozen': 3}\n", "lists 3 margin methods")],
    ids=["choices", "constant", "dict"],
)
def test_the_method_list_checker_finds_each_form(tmp_path, source, expected):
    root = tmp_path / PACKAGE
    (root / "cli").mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "cli" / "x.py").write_text(source)
    (root / "cli" / "y.py").write_text("pick = ('vertex', 'frozen')\n")  # two chosen by name: a choice, not a list
    names = {"margin": frozenset({"theorem1", "vertex", "lmi", "frozen"}),
             "certificate": frozenset({"lmi-box", "lmi-physical"})}
    found = method_lists(root, names)
    assert len(found) == 1 and found[0].startswith(f"{PACKAGE}.cli.x:1 {expected}"), found


@pytest.mark.parametrize(
    ("source", "expected"),
    [("if model.kind == 'box':\n    pass\n", "compares .kind"), ("x = args.arm_file\n", "reads args.arm_file"),
     ("x = getattr(args, 'model', None)\n", "probes getattr"), ("is_arm_file(path)\n", "calls is_arm_file")],
    ids=["kind", "args", "getattr", "arm-file"],
)
def test_the_kind_checker_finds_each_form(tmp_path, source, expected):
    root = tmp_path / PACKAGE
    for folder in ("cli", "model"):
        (root / folder).mkdir(parents=True)
        (root / folder / "x.py").write_text(source)
    (root / "__init__.py").write_text("")
    (root / "cli" / "_system.py").write_text(source)  # the loader may
    found = kind_branches(root)
    assert len(found) == 1 and found[0].startswith(f"{PACKAGE}.cli.x:") and expected in found[0], found
