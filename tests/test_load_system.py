"""The command line builds one system from its arguments (``load_system``) and commands never ask its kind.

Each kind (the built-in SCARA, a URDF robot file, a plant file) loads into a system with
its plant, its header and its capabilities; options that do not go with a kind are
refused with the messages the command line has always printed; and a check of the
source (ast) keeps the choice of kind inside ``cli/_system.py``: no other module of the
command line reads ``args.model``, ``args.robot`` or ``args.arm_file``, nor writes to the
parsed arguments.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import scara_robust as sr
from scara_robust.cli import build_parser, main
from scara_robust.cli._common import CommandLineError
from scara_robust.cli._system import ArmSystem, LoadedSystem, PlantFileSystem, ScaraSystem, load_system
from scara_robust.model.plant import UncertainPlant
from scara_robust.model.polytopic import PolytopicModel

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PAPER_ROBOT = str(EXAMPLES / "robot-paper.toml")
ARM = str(EXAMPLES / "robot-scara-urdf.toml")  # the smallest URDF robot of the examples (2 joints)
MOTOR = str(EXAMPLES / "plant-dc-motor.toml")
POLYTOPE = str(EXAMPLES / "plant-polytope.toml")
CLI = ROOT / "scara_robust" / "cli"
GAIN = ["--rho", "3", "--eta", "90"]


def _system(*argv: str) -> LoadedSystem:
    return load_system(build_parser().parse_args(list(argv)))


def test_the_paper_scara():
    system = _system("design", *GAIN)
    assert isinstance(system, ScaraSystem)
    assert isinstance(system.plant, UncertainPlant)
    assert system.physical is system.plant
    assert system.model.kind == "box" and system.interval_elements
    assert system.bounds == "paper"
    assert system.source(system.model) == "bounds: paper"
    assert system.source(system.model, sep=" ") == "bounds paper"
    assert system.file is None
    assert system.title() == "the paper's SCARA"
    assert system.capabilities.run == "scara"
    assert system.capabilities.element_margins
    assert system.robot_signals() is not None
    assert not system.state_feedback
    assert "the paper's robot" in system.sampled()[2]


def test_a_scara_robot_file():
    system = _system("certify", *GAIN, "--robot", PAPER_ROBOT)
    assert isinstance(system, ScaraSystem)
    assert isinstance(system.plant, UncertainPlant)
    assert system.bounds == "derived"  # the default with a robot file
    assert system.source(system.model) == "bounds: derived"
    assert system.file == PAPER_ROBOT
    assert system.title() == f"SCARA of {PAPER_ROBOT!r}"
    assert system.options("robot", "model", "bounds") == [("--robot", PAPER_ROBOT)]
    assert system.capabilities.run == "scara"
    assert system.setup.robot_file
    assert _system("certify", *GAIN, "--robot", PAPER_ROBOT, "--bounds", "derived").bounds == "derived"


def test_a_urdf_robot_file():
    system = _system("design", *GAIN, "--robot", ARM)
    assert isinstance(system, ArmSystem)
    assert isinstance(system.plant, UncertainPlant)
    assert system.bounds is None
    assert system.source(system.model) == f"model: {system.model.name}"
    assert system.file == ARM
    assert system.capabilities.run == "arm"
    assert not system.capabilities.element_margins  # its margin is the payload range, in kg
    assert system.robot_signals() is None
    assert not system.setup.robot_file  # the robot file is the arm's, not the SCARA's data
    assert system.synthesis_set(None) == "physical"
    assert system.synthesis_set("box") == "box"
    assert system.arm().arm.n_joints == 2
    assert system.sampled()[2].startswith(f"the arm of {ARM!r}")


def test_a_plant_file_with_parameters():
    system = _system("certify", *GAIN, "--model", MOTOR)
    assert isinstance(system, PlantFileSystem)
    assert isinstance(system.plant, UncertainPlant)
    assert system.bounds is None
    assert system.source(system.model) == "model: DC motor with a varying load inertia"
    assert system.title() == "DC motor with a varying load inertia"
    assert system.file == MOTOR
    assert system.capabilities.run == "plant"
    assert system.capabilities.element_margins
    assert system.robot_signals() is None
    assert system.plant_prefix("scara_pid") == "motor_pid"
    assert system.synthesis_set(None) == "box"
    assert system.sampled()[2].startswith(f"the plant of {MOTOR!r} on its parameter grid")


def test_a_polytope_file():
    system = _system("certify", *GAIN, "--model", POLYTOPE)
    assert isinstance(system, PlantFileSystem)
    assert isinstance(system.plant, PolytopicModel)
    assert system.physical is None
    assert system.model.kind == "polytope" and not system.interval_elements
    assert system.plant_prefix("scara_pid") == "scara_pid"
    assert system.signal_names() == {}
    assert system.sampled()[2].startswith("the ")
    with pytest.raises(sr.OptionError, match="^no parameters$"):
        system.require_physical("no parameters")


def test_loading_leaves_the_arguments_alone_and_reads_files_when_asked():
    args = build_parser().parse_args(["design", *GAIN, "--model", "missing.toml"])
    before = dict(vars(args))
    system = load_system(args)  # the kind only: the file is read when the plant is asked for
    assert vars(args) == before
    with pytest.raises(sr.OptionError, match="^`--model` 'missing.toml': "):
        _ = system.plant


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["design", *GAIN, "--robot", ARM, "--model", MOTOR], "`--robot` and `--model` each name the plant; give one"),
        (["design", *GAIN, "--robot", ARM, "--bounds", "paper"],
         f"`--bounds` describes the built-in SCARA; a URDF robot's reference, payload and linearization are in its "
         f"file {ARM!r}"),
        (["certify", *GAIN, "--robot", ARM, "--scenario", "examples/scenario-paper.toml"],
         f"`--scenario` describes the built-in SCARA; a URDF robot's reference, payload and linearization are in its "
         f"file {ARM!r}"),
        (["app", "--robot", ARM],
         f"`--robot` {ARM!r} names a URDF; `app` runs on the built-in SCARA only (a URDF robot goes with design, "
         "certify, margin, synthesize, simulate, compare, export, surface, tune, campaign)"),
    ],
    ids=["robot-and-model", "bounds", "scenario", "app"],
)
def test_options_that_do_not_go_with_a_urdf_robot(argv, message, capsys):
    with pytest.raises(CommandLineError) as err:
        _system(*argv)
    assert str(err.value) == message
    assert main(argv) == 2
    assert capsys.readouterr().err == f"scara_robust: error: {message}\n"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["design", *GAIN, "--model", MOTOR, "--robot", PAPER_ROBOT],
         "`--model` is your own plant; --robot describe the SCARA and cannot go with it"),
        (["design", *GAIN, "--model", MOTOR, "--bounds", "paper", "--robot", PAPER_ROBOT],
         "`--model` is your own plant; --robot, --bounds describe the SCARA and cannot go with it"),
        (["design", *GAIN, "--robot", PAPER_ROBOT, "--bounds", "paper"],
         "`--bounds paper` holds only for the paper's robot (Tables 1-2); with --robot use --bounds derived"),
        (["margin", *GAIN, "--range", "J=1:2"],
         "`--range` changes a parameter of a plant file with [parameters] (--model)"),
    ],
    ids=["model-and-robot", "model-and-two", "paper-bounds", "range-on-scara"],
)
def test_options_that_do_not_go_with_the_plant(argv, message, capsys):
    assert main(argv) == 2
    assert capsys.readouterr().err == f"scara_robust: error: {message}\n"


#: What only ``cli/_system.py`` may read on the parsed arguments.
KIND_OPTIONS = frozenset({"model", "robot", "arm_file"})


def kind_probes(source: str) -> list[str]:
    """Reads of ``args.model``/``robot``/``arm_file`` (attribute or ``getattr``) and writes to ``args``.

    Parameters
    ----------
    source : str
        A module's source.

    Returns
    -------
    list of str
        ``LINE: what`` for each one found.
    """
    found = []
    for node in ast.walk(ast.parse(source)):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "args"):
            if isinstance(node.ctx, (ast.Store, ast.Del)):
                found.append(f"{node.lineno}: writes args.{node.attr}")
            elif node.attr in KIND_OPTIONS:
                found.append(f"{node.lineno}: reads args.{node.attr}")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.args:
            first = node.args[0]
            if not (isinstance(first, ast.Name) and first.id == "args"):
                continue
            if node.func.id in ("setattr", "delattr"):
                found.append(f"{node.lineno}: {node.func.id}(args, ...)")
            elif node.func.id == "getattr" and len(node.args) > 1:
                name = node.args[1]
                if isinstance(name, ast.Constant) and name.value in KIND_OPTIONS:
                    found.append(f"{node.lineno}: getattr(args, {name.value!r})")
                elif not isinstance(name, ast.Constant) and _names_a_kind_option(source, node):
                    found.append(f"{node.lineno}: getattr(args, NAME) over a kind option")
        elif isinstance(node, ast.Name) and node.id == "is_arm_file":
            found.append(f"{node.lineno}: is_arm_file")
        elif isinstance(node, ast.ImportFrom) and any(alias.name == "is_arm_file" for alias in node.names):
            found.append(f"{node.lineno}: imports is_arm_file")
    return found


def _names_a_kind_option(source: str, call: ast.Call) -> bool:
    """True if a computed ``getattr(args, name)`` sits on a line that also names a kind option as a string."""
    line = source.splitlines()[call.lineno - 1]
    return any(f'"{name}"' in line or f"'{name}'" in line for name in KIND_OPTIONS)


def test_only_the_system_module_asks_for_the_kind():
    modules = sorted(p for p in CLI.glob("*.py") if p.name != "_system.py")
    assert len(modules) >= 10
    problems = [f"{path.name}:{probe}" for path in modules for probe in kind_probes(path.read_text(encoding="utf-8"))]
    assert problems == []


@pytest.mark.parametrize(
    "source",
    ["x = args.model\n", "if args.robot is not None:\n    pass\n", "f(args.arm_file)\n",
     "args.controller = 'pid'\n", "args.a, args.b = 1, 2\n", "args.n += 1\n", "setattr(args, 'x', 1)\n",
     "getattr(args, 'model', None)\n", "[getattr(args, o, None) for o in ('robot', 'bounds')]\n",
     "from ..io import is_arm_file\n"],
    ids=["read-model", "read-robot", "read-arm", "write", "write-tuple", "augmented", "setattr", "getattr",
         "getattr-loop", "is-arm-file"],
)
def test_the_kind_checker_finds_each_form(source):
    assert kind_probes(source) != []


def test_the_kind_checker_passes_other_options():
    source = "x = args.rho\ny = getattr(args, 'design', None)\nz = [getattr(args, o) for o in ('ts', 'x0')]\n"
    assert kind_probes(source) == []


def test_the_system_module_is_where_the_kind_is_chosen():
    source = (CLI / "_system.py").read_text(encoding="utf-8")
    assert "is_arm_file" in source and kind_probes(source) != []


def test_an_unknown_field_of_an_arm_file_names_the_file_once(tmp_path, capsys):
    """The file is named once, with one colon (it read "'F.toml':: unknown field")."""
    text = (ROOT / "examples" / "robot-arm6.toml").read_text(encoding="utf-8")
    path = tmp_path / "arm.toml"
    path.write_text(text.replace("[robot]\n", "[robot]\narmatrue = 1\n", 1).replace(
        'urdf = "arm6.urdf"', f'urdf = "{ROOT / "examples" / "arm6.urdf"}"'), encoding="utf-8")
    with pytest.raises(sr.InputFileError, match=r"^'[^']*arm\.toml': unknown field `robot\.armatrue`; valid: "):
        sr.load_arm(str(path))
    assert main(["design", *GAIN, "--robot", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"`--robot` {str(path)!r}: unknown field `robot.armatrue`" in err and "::" not in err
