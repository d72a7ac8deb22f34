"""Robot and scenario files: your own SCARA, payload, reference and disturbance.

Two small TOML (or JSON, by extension) formats, validated on load with errors that name
the file, the field and its unit. ``examples/robot-paper.toml`` and
``examples/scenario-paper.toml`` are the paper's data and document every field.

Robot file (all fields required, SI units)::

    name = "..."              # optional
    [robot]
    m1 = 2.61                 # kg, mass of link 1
    m2 = 3.45                 # kg, mass of link 2
    L1 = 0.3                  # m, length of link 1
    L2 = 0.4                  # m, length of link 2 (payload at its tip)
    Lc1 = 0.178               # m, joint 1 to the centre of mass of link 1
    Lc2 = 0.2                 # m, joint 2 to the centre of mass of link 2
    I1 = 0.198                # kg·m², inertia of link 1 about its centre of mass
    I2 = 0.184                # kg·m², inertia of link 2 about its centre of mass
    cp = 0.005                # m², payload inertia I_p = cp · m_p

Scenario file (every table optional; a missing one is the paper's)::

    name = "..."
    [payload]                 # profile = "sinusoidal": offset, amplitude [kg], omega [rad/s], phase [rad]
    profile = "sinusoidal"    # profile = "constant": mass [kg]
    offset = 1.035
    amplitude = 1.035
    omega = 1.0
    phase = 0.0
    [reference]               # r = amplitude · (sin ωt, cos ωt)
    amplitude = 1.0           # rad
    omega = 1.0               # rad/s
    [disturbance]             # square waves on both joints, in phase
    amplitude = 5.0           # N·m
    period = 0.6283185307     # s
    phase = 0.0               # rad
    [initial]                 # initial tracking error; without it the named scenarios apply
    e0 = [-1.5, 2.5]          # rad
    edot0 = [1.0, 0.0]        # rad/s
"""

from __future__ import annotations

import errno
import importlib.metadata
import json
import math
import os
import sys
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import Any

import control as ct
import numpy as np
from numpy.typing import NDArray

from ._validation import describe, field_number, field_table
from .exceptions import ArgumentError, ArgumentValueError, InputFileError
from .model.arm import FEEDFORWARDS, ArmSetup, JointSinusoids, RobotArm
from .model.augment import integral_augment, pid_augment
from .model.initial import Scenario
from .model.plant import Parameter, Signal, UncertainPlant
from .model.polytopic import PolytopicModel
from .model.robot import (
    PARAM_UNITS,
    ConstantPayload,
    PayloadProfile,
    ScaraParams,
    SinusoidalPayload,
    paper_payload,
)
from .model.signals import Reference, SquareWave, paper_disturbance, paper_reference, sinusoidal_reference
from .model.uncertain import UncertainElement, UncertainLTVModel
from .paper import PAPER_DISTURBANCE_PERIOD

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "load_model",
    "load_plant",
    "MODEL_FORMS",
    "ScenarioFile",
    "load_robot",
    "load_arm",
    "is_arm_file",
    "controller_sample_time",
    "CONTROLLER_KEYS",
    "file_requirements",
    "REQUIREMENT_KEYS",
    "ARM_KEYS",
    "load_scenario",
    "DesignFile",
    "write_design",
    "load_design",
    "load_pid_controller",
    "PID_CONTROLLER_GAINS",
    "PidControllerGains",
    "PID_CONTROLLER_METHOD",
    "PID_CONTROLLER_KEYS",
    "PID_CONTROLLER_TYPE",
    "ros2_dof_name",
]

#: Fields of the ``[robot]`` table and their units (those of :class:`~scara_robust.ScaraParams`).
ROBOT_UNITS = PARAM_UNITS
_SCENARIO_FIELDS: dict[str, dict[str, str]] = {
    "payload": {"profile": "-", "offset": "kg", "amplitude": "kg", "omega": "rad/s", "phase": "rad", "mass": "kg"},
    "reference": {"amplitude": "rad", "omega": "rad/s"},
    "disturbance": {"amplitude": "N·m", "period": "s", "phase": "rad"},
    "initial": {"e0": "rad", "edot0": "rad/s"},
}
#: ``form`` of a model file: the matrices as they are, or augmented (see :func:`load_model`).
MODEL_FORMS = ("state", "pid", "integral")
_MODEL_KEYS = ("name", "form", "A", "B", "C", "elements", "vertices", "controller")
_PLANT_KEYS = ("name", "form", "A", "B", "C", "parameters", "inputs", "outputs", "prefix", "description", "controller")
#: A robot or plant file's ``[controller]`` table: the controller the design will run as.
CONTROLLER_KEYS: dict[str, str] = {"sample_time": "s"}
#: Fields of a SCARA robot file's ``[requirements]`` table (what ``tune`` asks of the loop), with their units.
REQUIREMENT_KEYS: dict[str, str] = {"error": "rad", "settling_time": "s", "sample_time": "s", "disturbance": "N·m",
                                    "torque_limit": "N·m", "disk_margin": "-", "delay_margin": "s",
                                    "decay": "1/s"}
_PARAMETER_KEYS = ("unit", "range", "value", "nominal", "rate", "samples", "physical", "description", "measured",
                   "measurement_error", "measurement_delay")
_ELEMENT_KEYS = {"matrix": "-", "row": "-", "col": "-", "lower": "matrix entry", "upper": "matrix entry"}
#: Results tables by file extension.
TABLE_FORMATS = {".csv": "csv", ".parquet": "parquet"}


@dataclass(frozen=True)
class ScenarioFile:
    """What a scenario file sets.

    Attributes
    ----------
    name : str
    payload : PayloadProfile
        ``m_p(t)``, kg.
    reference : Reference
    disturbance : SquareWave
    initial : Scenario or None
        The file's initial condition, or None to use the named scenarios.
    """

    name: str
    payload: PayloadProfile
    reference: Reference
    disturbance: SquareWave
    initial: Scenario | None


def read_mapping(
    path: str | os.PathLike[str],
    *,
    extensions: tuple[str, ...] = (".toml", ".json"),
    error: type[InputFileError] = InputFileError,
) -> dict[str, Any]:
    """Read a TOML or JSON file (by extension) whose top level is a table.

    Parameters
    ----------
    path : path-like
    extensions : tuple of str
        Accepted extensions, lower case with the dot.
    error : type
        The :class:`~scara_robust.exceptions.InputFileError` subclass to raise.

    Returns
    -------
    dict

    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        If the extension is not accepted, the path is a folder, or the text is not
        valid TOML/JSON with a table at the top level.
    """
    text_path = os.fspath(path)
    ext = os.path.splitext(text_path)[1].lower()
    if ext not in extensions:
        raise error(f"{text_path!r}: expected a {' or '.join(extensions)} file")
    if os.path.isdir(text_path):
        raise error(f"{text_path!r} is a directory, not a file")
    with open(text_path, "rb") as fh:
        raw = fh.read()
    try:
        text = raw.decode("utf-8")
        data = json.loads(text) if ext == ".json" else tomllib.loads(text)
    except (ValueError, UnicodeDecodeError) as err:
        raise error(f"{text_path!r} is not valid {ext[1:].upper()}: {err}") from err
    if not isinstance(data, dict):
        raise error(f"{text_path!r}: expected a table of fields at the top level")
    return data


def _top(path: str, data: Mapping[str, Any], tables: tuple[str, ...]) -> str:
    for key in data:
        if key not in ("name", *tables):
            raise InputFileError(f"{path!r}: unknown field `{key}`; valid: name, {', '.join(tables)}")
    name = data.get("name", os.path.splitext(os.path.basename(path))[0])
    if not isinstance(name, str):
        raise InputFileError(f"{path!r}: field `name` must be a string, found {describe(name)}")
    return name


def load_robot(path: str | os.PathLike[str]) -> ScaraParams:
    """Read a robot file into :class:`~scara_robust.ScaraParams`.

    Parameters
    ----------
    path : path-like
        A ``.toml`` or ``.json`` robot file.

    Returns
    -------
    ScaraParams


    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        If it is not valid TOML/JSON, a field is unknown, missing, not a number, or
        outside its physical range (the message names the field and its unit).
    """
    text_path = os.fspath(path)
    data = read_mapping(text_path)
    _top(text_path, data, ("robot", "controller", "requirements"))
    file_requirements(text_path)  # every command refuses a typo in what `tune` reads
    table = field_table(repr(text_path), data, "robot", ROBOT_UNITS)
    values = {}
    for f in fields(ScaraParams):
        unit = ROBOT_UNITS[f.name]
        if f.name not in table:
            raise InputFileError(f"{text_path!r}: missing field `robot.{f.name}` [{unit}]")
        values[f.name] = field_number(f"{text_path!r}:", f"robot.{f.name}", table[f.name], unit)
    try:
        return ScaraParams(**values)
    except ArgumentError as err:  # name the file's field: `robot.m1` [kg]
        field, _, unit = err.argument.partition(" ")
        raise InputFileError(f"{text_path!r}: field `robot.{field}` {unit} {err.problem}") from err


#: Keys of a URDF robot file's ``[robot]`` table, with their units.
ARM_KEYS: dict[str, str] = {
    "urdf": "path", "joints": "names", "locked": "rad or m", "payload_frame": "name", "payload_mass": "kg",
    "payload_rate": "kg/s", "payload_nominal": "kg", "payload_com": "m", "payload_inertia_per_kg": "m²",
    "gravity": "true/false", "armature": "kg·m²", "feedforward": "/".join(FEEDFORWARDS), "reference_samples": "count",
    "payload_samples": "count", "prefix": "identifier", "design_plant": "center/lower",
    "payload_measurement_error": "kg", "payload_measurement_delay": "s",
    "position_limits": "rad", "velocity_limits": "rad/s", "effort_limits": "N·m",
}
_REFERENCE_KEYS = {"center": "rad", "amplitude": "rad", "omega": "rad/s", "phase": "rad"}
#: An arm's ``[initial]`` and ``[disturbance]`` tables: the scenario file's fields, one value per joint.
_ARM_RUN_FIELDS: dict[str, dict[str, str]] = {
    "initial": {"e0": "rad", "edot0": "rad/s"},
    "disturbance": {"amplitude": "N·m", "period": "s", "phase": "rad"},
}


def _arm_run_tables(where: str, data: Mapping[str, Any],
                    n: int) -> tuple[tuple[float, ...] | None, tuple[float, ...] | None, SquareWave | None]:
    """An arm file's initial error ``(e0, edot0)`` and disturbance, from ``[initial]`` and ``[disturbance]``."""
    initial = field_table(where, data, "initial", _ARM_RUN_FIELDS["initial"])
    pair: dict[str, tuple[float, ...] | None] = {"e0": None, "edot0": None}
    for key, unit in _ARM_RUN_FIELDS["initial"].items():
        if key in initial:
            pair[key] = tuple(_numbers(where, f"initial.{key}", initial[key], unit, n))
        elif initial:
            pair[key] = (0.0,) * n
    table = field_table(where, data, "disturbance", _ARM_RUN_FIELDS["disturbance"])
    wave = None
    if table:
        if "amplitude" not in table:
            raise InputFileError(f"{where} missing field `disturbance.amplitude` [N·m]: one value for every joint or "
                                 f"one per joint ({n})")
        raw = table["amplitude"]
        amplitudes = (_numbers(where, "disturbance.amplitude", raw, "N·m", n) if isinstance(raw, list)
                      else [field_number(where, "disturbance.amplitude", raw, "N·m")] * n)
        period = field_number(where, "disturbance.period", table.get("period", PAPER_DISTURBANCE_PERIOD), "s")
        if period <= 0:
            raise InputFileError(f"{where} field `disturbance.period` [s] must be > 0, found {period:g}")
        phase = field_number(where, "disturbance.phase", table.get("phase", 0.0), "rad")
        wave = square_wave(amplitudes, period, phase)
    return pair["e0"], pair["edot0"], wave


def square_wave(amplitudes: list[float], period: float, phase: float = 0.0) -> SquareWave:
    """The square-wave torque with these amplitudes per joint (N·m; a negative one in antiphase).

    Parameters
    ----------
    amplitudes : list of float
        N·m, one per joint.
    period : float
        s (> 0).
    phase : float
        rad.

    Returns
    -------
    SquareWave
        Of amplitude ``max |amplitudes|``, the joints scaled by their share of it (all
        zero: amplitude 0).
    """
    peak = max(abs(a) for a in amplitudes)
    return SquareWave(peak, period, phase, tuple(a / peak if peak else 1.0 for a in amplitudes))


def controller_sample_time(path: str | os.PathLike[str]) -> float | None:
    """The sample time a robot or plant file gives its controller (``[controller] sample_time``, s), or None.

    Parameters
    ----------
    path : path-like
        A robot file (the SCARA's or one naming a URDF) or a plant file.

    Returns
    -------
    float or None

    Raises
    ------
    InputFileError
        Naming the file and the field, for a sample time that is not a number > 0 s or an
        unknown field of the table.
    """
    text_path = os.fspath(path)
    where = f"{text_path!r}:"
    table = field_table(where, read_mapping(text_path), "controller", CONTROLLER_KEYS)
    if "sample_time" not in table:
        return None
    ts = field_number(where, "controller.sample_time", table["sample_time"], "s")
    if not ts > 0:
        raise InputFileError(f"{where} field `controller.sample_time` [s] must be > 0, found {ts:g}")
    return ts


def file_requirements(path: str | os.PathLike[str]) -> dict[str, float]:
    """What a robot file's ``[requirements]`` table asks of the loop (:data:`REQUIREMENT_KEYS`), in SI units.

    Parameters
    ----------
    path : path-like
        A robot file: the SCARA's, or one naming a URDF.

    Returns
    -------
    dict of str to float
        The fields given (none: an empty dict); the values are checked by
        :class:`~scara_robust.Requirements`, which names the field.

    Raises
    ------
    InputFileError
        Naming the file and the field, for an unknown field or a value that is not a number.
    """
    text_path = os.fspath(path)
    where = f"{text_path!r}:"
    table = field_table(where, read_mapping(text_path), "requirements", REQUIREMENT_KEYS)
    return {key: field_number(where, f"requirements.{key}", value, REQUIREMENT_KEYS[key])
            for key, value in table.items()}


def is_arm_file(path: str | os.PathLike[str]) -> bool:
    """True when `path` is a robot file naming a URDF (``[robot] urdf = ...``), not a SCARA's data.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    bool
        False also for a file that cannot be read (its loader then says why).
    """
    try:
        data = read_mapping(path)
    except (OSError, InputFileError):
        return False
    robot = data.get("robot")
    return isinstance(robot, Mapping) and "urdf" in robot


def _numbers(where: str, field: str, value: Any, unit: str, length: int | None = None,
             infinite: bool = False) -> list[float]:
    """A list field of numbers (``infinite``: ``inf`` and ``-inf`` accepted, meaning no limit)."""
    if not isinstance(value, list) or (length is not None and len(value) != length):
        size = f"{length} numbers" if length is not None else "a list of numbers"
        raise InputFileError(f"{where} field `{field}` must be {size} in {unit}, found {describe(value)}")
    return [v if infinite and isinstance(v, float) and math.isinf(v) else
            field_number(where, f"{field}[{k}]", v, unit) for k, v in enumerate(value)]


def _resolve_urdf(where: str, folder: str, urdf: str) -> str:
    """A robot file's ``urdf``: relative to its folder, or ``package://NAME/PATH`` in an installed package's data.

    ``package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf`` is the UR5 of
    the ``example-robot-data`` package (the extra ``robot-data``), which installs its files
    under ``cmeel.prefix/share/example-robot-data``.
    """
    if not urdf.startswith("package://"):
        return os.path.join(folder, urdf)
    package, _, rest = urdf[len("package://"):].partition("/")
    try:
        dist = importlib.metadata.distribution(package)
    except importlib.metadata.PackageNotFoundError:
        hint = ' (pip install "scara_robust[robot-data]")' if package == "example-robot-data" else ""
        raise InputFileError(f"{where} field `robot.urdf` names {urdf!r}, but the package {package!r} is not "
                             f"installed{hint}") from None
    return os.path.join(str(dist.locate_file(f"cmeel.prefix/share/{package}")), rest)


def load_arm(path: str | os.PathLike[str]) -> ArmSetup:
    """Read a robot file that names a URDF: the arm, its payload, reference and feedforward.

    The format (TOML or JSON; ``examples/robot-arm6.toml`` documents it): ``name``; a
    ``[robot]`` table with ``urdf`` (a path relative to the file, or
    ``package://NAME/PATH`` inside an installed package such as ``example-robot-data``), ``joints`` (the
    controlled revolute joints, in order), ``locked`` (joint name → position, rad or m;
    every other joint is locked at 0), ``payload_frame``, ``payload_mass = [lower,
    upper]`` (kg), optional ``payload_rate`` (kg/s), ``payload_nominal`` (kg, default the
    lower end), ``payload_com`` (m, in the frame), ``payload_inertia_per_kg`` (m², the
    diagonal about the payload's centre of mass), ``gravity`` (default true), ``armature``
    (kg·m², the reflected rotor inertia of each controlled joint, default 0),
    ``feedforward`` (``"none"``, ``"gravity"`` or ``"computed-torque"``),
    ``reference_samples`` and ``payload_samples`` (the linearization grid, default 721
    and 21), ``prefix`` (exported code), ``design_plant`` (``"center"``, the default, or
    ``"lower"``: the nominal of the interval model, see :func:`scara_robust.arm_uncertain_plant`),
    ``payload_measurement_error`` (kg: the robot measures its payload within this, so a gain
    may be scheduled on it; absent: not measured) and ``payload_measurement_delay`` (s);
    a ``[reference]`` table with ``center``,
    ``amplitude``, ``omega`` and ``phase``, one value per joint:
    ``r_i(t) = center_i + amplitude_i sin(omega_i t + phase_i)``. Optional, the runs'
    initial error and disturbance, with the scenario file's names: ``[initial]`` with
    ``e0`` (rad) and ``edot0`` (rad/s), one value per joint (a missing one is zero), and
    ``[disturbance]``, a square wave with ``amplitude`` (N·m, one value for every joint
    or one per joint, a negative one in antiphase), ``period`` (s, default the paper's
    π/5) and ``phase`` (rad, default 0).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    ArmSetup

    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        One line naming the file and the field: a URDF that does not parse, a joint or
        frame it does not have, a prismatic controlled joint, a floating base, a
        negative mass, a list of the wrong length, ...
    ModuleNotFoundError
        If Pinocchio (the extra ``robots``) is not installed.

    See Also
    --------
    RobotArm : the arm it builds.
    arm_uncertain_plant : its error dynamics as a plant.
    """
    text_path = os.fspath(path)
    where = f"{text_path!r}:"
    data = read_mapping(text_path)
    name = _top(text_path, data, ("robot", "reference", "controller", "requirements", *_ARM_RUN_FIELDS))
    file_requirements(text_path)  # what `tune` reads, checked by every command
    robot = field_table(where, data, "robot", ARM_KEYS)
    for key in ("urdf", "joints", "payload_frame", "payload_mass"):
        if key not in robot:
            raise InputFileError(f"{where} missing field `robot.{key}` [{ARM_KEYS[key]}]")
    urdf = robot["urdf"]
    if not isinstance(urdf, str) or not urdf:
        raise InputFileError(f"{where} field `robot.urdf` must be a path to a URDF file, found {describe(urdf)}")
    urdf_path = _resolve_urdf(where, os.path.dirname(os.path.abspath(text_path)), urdf)
    joints = robot["joints"]
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) for j in joints):
        raise InputFileError(f"{where} field `robot.joints` must be a list of joint names, found {describe(joints)}")
    n = len(joints)
    locked = robot.get("locked", {})
    if not isinstance(locked, Mapping):
        raise InputFileError(f"{where} field `robot.locked` must be a table of joint name = position, found "
                             f"{describe(locked)}")
    locked = {str(k): field_number(where, f"robot.locked.{k}", v, "rad or m") for k, v in locked.items()}
    frame = robot["payload_frame"]
    if not isinstance(frame, str):
        raise InputFileError(f"{where} field `robot.payload_frame` must be a frame name, found {describe(frame)}")
    mass = _numbers(where, "robot.payload_mass", robot["payload_mass"], "kg", 2)
    if min(mass) < 0 or mass[0] > mass[1]:
        raise InputFileError(f"{where} field `robot.payload_mass` [kg] must be [lower, upper] with 0 <= lower <= "
                             f"upper, found {mass}")
    rate = robot.get("payload_rate")
    if rate is not None:
        rate = field_number(where, "robot.payload_rate", rate, "kg/s")
        if rate < 0:
            raise InputFileError(f"{where} field `robot.payload_rate` [kg/s] must be >= 0, found {rate:g}")
        if mass[0] == mass[1]:
            raise InputFileError(f"{where} field `robot.payload_rate` bounds the change of a payload with a range; "
                                 f"the payload is fixed at {mass[0]:g} kg")
    measured = "payload_measurement_error" in robot
    delta = field_number(where, "robot.payload_measurement_error", robot.get("payload_measurement_error", 0.0), "kg")
    delay = field_number(where, "robot.payload_measurement_delay", robot.get("payload_measurement_delay", 0.0), "s")
    for key, value, unit in (("payload_measurement_error", delta, "kg"), ("payload_measurement_delay", delay, "s")):
        if value < 0:
            raise InputFileError(f"{where} field `robot.{key}` [{unit}] must be >= 0, found {value:g}")
    if delay > 0 and not measured:
        raise InputFileError(f"{where} field `robot.payload_measurement_delay` describes a measured payload; give "
                             "`robot.payload_measurement_error` too")
    nominal = field_number(where, "robot.payload_nominal", robot.get("payload_nominal", mass[0]), "kg")
    if not mass[0] <= nominal <= mass[1]:
        raise InputFileError(f"{where} field `robot.payload_nominal` [kg] must lie in payload_mass {mass}, found "
                             f"{nominal:g}")
    com = _numbers(where, "robot.payload_com", robot.get("payload_com", [0.0, 0.0, 0.0]), "m", 3)
    per_kg = _numbers(where, "robot.payload_inertia_per_kg", robot.get("payload_inertia_per_kg", [0.0, 0.0, 0.0]),
                      "m²", 3)
    if min(per_kg) < 0:
        raise InputFileError(f"{where} field `robot.payload_inertia_per_kg` [m²] must be >= 0, found {per_kg}")
    armature = _numbers(where, "robot.armature", robot["armature"], "kg·m²", n) if "armature" in robot else None
    if armature is not None and min(armature) < 0:
        raise InputFileError(f"{where} field `robot.armature` [kg·m²] must be >= 0, found {armature}")
    gravity = robot.get("gravity", True)
    if not isinstance(gravity, bool):
        raise InputFileError(f"{where} field `robot.gravity` must be true or false, found {describe(gravity)}")
    feedforward = robot.get("feedforward", "none")
    if feedforward not in FEEDFORWARDS:
        raise InputFileError(f"{where} field `robot.feedforward` must be one of {', '.join(FEEDFORWARDS)}, found "
                             f"{describe(feedforward)}")
    counts = []
    for key, default in (("reference_samples", 721), ("payload_samples", 21)):
        value = robot.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise InputFileError(f"{where} field `robot.{key}` must be a positive integer, found {describe(value)}")
        counts.append(value)
    prefix = robot.get("prefix", "arm_pid")
    if not isinstance(prefix, str) or not prefix.isidentifier():
        raise InputFileError(f"{where} field `robot.prefix` must be a C identifier, found {describe(prefix)}")
    design_plant = robot.get("design_plant", "center")
    if design_plant not in ("center", "lower"):
        raise InputFileError(f"{where} field `robot.design_plant` must be 'center' or 'lower', found "
                             f"{describe(design_plant)}")
    if "reference" not in data:
        raise InputFileError(f"{where} missing table `[reference]` (center, amplitude, omega, phase per joint)")
    ref_table = field_table(where, data, "reference", _REFERENCE_KEYS)
    values = {}
    for key, unit in _REFERENCE_KEYS.items():
        if key not in ref_table:
            raise InputFileError(f"{where} missing field `reference.{key}` [{unit}], one value per joint")
        values[key] = tuple(_numbers(where, f"reference.{key}", ref_table[key], unit, n))
    e0, edot0, disturbance = _arm_run_tables(where, data, n)
    limits = _limit_fields(where, robot, n)
    try:
        reference = JointSinusoids(values["center"], values["amplitude"], values["omega"], values["phase"])
        reference.period  # noqa: B018 - commensurate frequencies, checked here to name the file
        arm = RobotArm(urdf_path, joints, locked=locked, payload_frame=frame, payload_com=com,
                       payload_inertia_per_kg=per_kg, gravity=gravity, armature=armature, name=name, **limits)
        return ArmSetup(arm, reference, (mass[0], mass[1]), rate, nominal, feedforward, counts[0], counts[1], name,
                        prefix, design_plant, e0, edot0, disturbance, delta if measured else None, delay)
    except ArgumentError as err:
        raise InputFileError(f"{where} field `robot.{err.argument}`: {err.problem}"
                             if not err.argument.startswith("reference") else f"{where} field `{err.argument}`: "
                             f"{err.problem}") from err


def _limit_fields(where: str, robot: Mapping[str, Any], n: int) -> dict[str, Any]:
    """A robot file's overrides of the URDF's joint limits (``inf`` in TOML: none), as RobotArm's arguments."""
    out: dict[str, Any] = {}
    if "position_limits" in robot:
        pairs = robot["position_limits"]
        if not isinstance(pairs, list) or len(pairs) != n:
            raise InputFileError(f"{where} field `robot.position_limits` must be {n} pairs [lower, upper] in rad, "
                                 f"found {describe(pairs)}")
        out["position_limits"] = [_numbers(where, f"robot.position_limits[{k}]", pair, "rad", 2, infinite=True)
                                  for k, pair in enumerate(pairs)]
    for key, unit in (("velocity_limits", "rad/s"), ("effort_limits", "N·m")):
        if key in robot:
            out[key] = _numbers(where, f"robot.{key}", robot[key], unit, n, infinite=True)
    return out


def load_scenario(path: str | os.PathLike[str]) -> ScenarioFile:
    """Read a scenario file; tables it omits take the paper's values.

    Parameters
    ----------
    path : path-like
        A ``.toml`` or ``.json`` scenario file.

    Returns
    -------
    ScenarioFile


    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        Naming the field, as for :func:`load_robot`.
    """
    text_path = os.fspath(path)
    data = read_mapping(text_path)
    name = _top(text_path, data, tuple(_SCENARIO_FIELDS))
    tables = {key: field_table(repr(text_path), data, key, allowed) for key, allowed in _SCENARIO_FIELDS.items()}

    def num(key: str, field: str, default: float | None = None) -> float:
        table = tables[key]
        if field not in table:
            if default is None:
                unit = _SCENARIO_FIELDS[key][field]
                raise InputFileError(f"{text_path!r}: missing field `{key}.{field}` [{unit}]")
            return default
        return field_number(f"{text_path!r}:", f"{key}.{field}", table[field], _SCENARIO_FIELDS[key][field])

    try:
        payload: PayloadProfile = paper_payload()
        if tables["payload"]:
            profile = tables["payload"].get("profile", "sinusoidal")
            if profile == "sinusoidal":
                payload = SinusoidalPayload(
                    num("payload", "offset"),
                    num("payload", "amplitude"),
                    num("payload", "omega", 1.0),
                    num("payload", "phase", 0.0),
                )
            elif profile == "constant":
                payload = ConstantPayload(num("payload", "mass"))
            else:
                raise InputFileError(
                    f"{text_path!r}: field `payload.profile` must be 'sinusoidal' or 'constant', found {profile!r}"
                )
        reference = (
            sinusoidal_reference(num("reference", "amplitude", 1.0), num("reference", "omega", 1.0))
            if tables["reference"]
            else paper_reference()
        )
        default = paper_disturbance()
        disturbance = (
            SquareWave(
                num("disturbance", "amplitude", default.amplitude),
                num("disturbance", "period", default.period),
                num("disturbance", "phase", default.phase),
            )
            if tables["disturbance"]
            else default
        )
        initial = None
        if tables["initial"]:
            pair = {}
            for key in ("e0", "edot0"):
                value = tables["initial"].get(key, [0.0, 0.0])
                unit = _SCENARIO_FIELDS["initial"][key]
                if not isinstance(value, list) or len(value) != 2:
                    raise InputFileError(
                        f"{text_path!r}: field `initial.{key}` must be a pair of numbers in {unit}, found {value!r}"
                    )
                pair[key] = tuple(field_number(f"{text_path!r}:", f"initial.{key}", v, unit) for v in value)
            initial = Scenario(name, pair["e0"], pair["edot0"])  # type: ignore[arg-type]
    except InputFileError:
        raise
    except ValueError as err:
        raise InputFileError(f"{text_path!r}: {err}") from err
    return ScenarioFile(name, payload, reference, disturbance, initial)


def current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_atomic(path: str | os.PathLike[str], write: Callable[[str], None]) -> None:
    """Call ``write(tmp_path)`` then rename the temporary file onto `path`.

    The temporary file sits in the target folder, so the rename is atomic: an
    interrupted or failed write leaves an existing `path` as it was and no temporary
    behind. The file gets the mode a plain ``open()`` would give it (``0o666`` less the
    umask).

    Parameters
    ----------
    path : path-like
        Destination file.
    write : callable
        ``write(tmp_path) -> None`` writes the whole content to ``tmp_path``.

    Raises
    ------
    OSError
        If the folder does not exist or is not writable, or `path` is a folder.
    """
    text_path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(text_path))
    if os.path.isdir(text_path):
        raise IsADirectoryError(errno.EISDIR, "is a directory", text_path)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=os.path.splitext(text_path)[1])
    os.close(fd)
    try:
        write(tmp)
        # mkstemp creates 0600; give the file the mode a plain open() would (0644 under umask 022)
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, text_path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def table_format(name: str, path: str | os.PathLike[str]) -> str:
    """The format of a results table from its extension, checking that it can be read or written.

    Parameters
    ----------
    name : str
        The argument's name, for the error.
    path : path-like

    Returns
    -------
    {'csv', 'parquet'}

    Raises
    ------
    ArgumentValueError
        If the extension is not ``.csv`` or ``.parquet``, or parquet is asked for without pyarrow.
    """
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in TABLE_FORMATS:
        raise ArgumentValueError(name, f"must end in .csv or .parquet, found {os.fspath(path)!r}")
    if TABLE_FORMATS[ext] == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError as err:
            raise ArgumentValueError(
                name, f"{os.fspath(path)!r}: parquet files need pyarrow: pip install '.[parquet]', or use .csv"
            ) from err
    return TABLE_FORMATS[ext]


def _matrix(where: str, field: str, value: Any, shape: tuple[int | None, int | None]) -> NDArray[np.float64]:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputFileError(f"{where} field `{field}` must be a table of numbers (a list of rows), found "
                             f"{describe(value)}") from err
    if arr.ndim != 2 or 0 in arr.shape:
        raise InputFileError(f"{where} field `{field}` must be a matrix (a list of equal rows), found "
                             f"{describe(value)}")
    if any(want is not None and want != got for want, got in zip(shape, arr.shape)):
        want = "(" + ", ".join("n" if w is None else str(w) for w in shape) + ")"
        raise InputFileError(f"{where} field `{field}` must have shape {want}, found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputFileError(f"{where} field `{field}` must hold finite numbers, found NaN or inf")
    return arr


def _load_polytope(where: str, vertices: Any, name: str) -> PolytopicModel:
    if not isinstance(vertices, list) or not vertices or not all(isinstance(v, Mapping) for v in vertices):
        raise InputFileError(f"{where} field `vertices` must be a list of tables with A and B, found "
                             f"{describe(vertices)}")
    As: list[NDArray[np.float64]] = []
    Bs: list[NDArray[np.float64]] = []
    for i, vertex in enumerate(vertices):
        for key in ("A", "B"):
            if key not in vertex:
                raise InputFileError(f"{where} missing field `vertices[{i}].{key}`")
        n = As[0].shape[0] if As else None
        m = Bs[0].shape[1] if Bs else None
        A = _matrix(where, f"vertices[{i}].A", vertex["A"], (n, n))
        if A.shape[0] != A.shape[1]:
            raise InputFileError(f"{where} field `vertices[{i}].A` must be square, found {A.shape}")
        As.append(A)
        Bs.append(_matrix(where, f"vertices[{i}].B", vertex["B"], (A.shape[0], m)))
    return PolytopicModel(np.array(As), np.array(Bs), name=name)


def _load_elements(
    where: str, raw: Any, shape_A: tuple[int, ...], shape_B: tuple[int, ...]
) -> list[UncertainElement]:
    if not isinstance(raw, list):
        raise InputFileError(f"{where} field `elements` must be a list of tables, found {describe(raw)}")
    elements = []
    for k, table in enumerate(raw):
        label = f"elements[{k}]"
        fields_ = field_table(where, {label: table}, label, _ELEMENT_KEYS)
        for key in _ELEMENT_KEYS:
            if key not in fields_:
                raise InputFileError(f"{where} missing field `{label}.{key}`")
        matrix, row, col = fields_["matrix"], fields_["row"], fields_["col"]
        if matrix not in ("A", "B"):
            raise InputFileError(f"{where} field `{label}.matrix` must be 'A' or 'B', found {describe(matrix)}")
        for key, value in (("row", row), ("col", col)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise InputFileError(f"{where} field `{label}.{key}` must be a 0-based index >= 0, found "
                                     f"{describe(value)}")
        shape = shape_A if matrix == "A" else shape_B
        if row >= shape[0] or col >= shape[1]:
            raise InputFileError(f"{where} field `{label}`: Δ{matrix}[{row}, {col}] lies outside {matrix} of "
                                 f"shape {shape}")
        lower = field_number(where, f"{label}.lower", fields_["lower"], "the units of the entry")
        upper = field_number(where, f"{label}.upper", fields_["upper"], "the units of the entry")
        if lower > upper:
            raise InputFileError(f"{where} field `{label}`: lower {lower:g} > upper {upper:g}")
        elements.append(UncertainElement(matrix, row, col, lower, upper))
    return elements


def load_model(path: str | os.PathLike[str]) -> UncertainPlant | UncertainLTVModel | PolytopicModel:
    """Read a plant file: physical parameters, an interval model (A, B and elements) or a polytope.

    A file with ``[parameters]`` is a plant with named physical parameters
    (:func:`load_plant`); a robot file naming a URDF is the arm's linearized error
    dynamics (:func:`load_arm`); the two formats below describe the uncertainty set directly.

    The format (TOML or JSON; ``examples/plant-dc-motor.toml`` and
    ``examples/plant-polytope.toml`` document it): ``name``; either ``A``, ``B`` (lists
    of rows, in the SI units of the plant's state and input) with ``[[elements]]``
    tables (``matrix`` = "A" or "B", 0-based ``row`` and ``col``, ``lower`` and ``upper``
    in the units of that entry), or ``[[vertices]]`` tables each with ``A`` and ``B``.
    ``form`` says what A and B are: ``"state"`` (default) the model as designed on,
    ``"pid"`` a second-order plant with state [q, q̇] turned into the PID form
    (:func:`scara_robust.pid_augment`; elements on the plant's own A and B), ``"integral"``
    a plant with outputs ``C`` given integral action (:func:`scara_robust.integral_augment`).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    UncertainPlant, UncertainLTVModel or PolytopicModel

    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        Naming the file and the field: missing ``B``, shapes that do not match, a vertex
        of another size, a non-finite entry, an element outside its matrix, ...

    See Also
    --------
    load_plant : a plant file only.
    """
    text_path = os.fspath(path)
    where = f"{text_path!r}:"
    data = read_mapping(text_path)
    if "parameters" in data:
        return _plant_from_mapping(where, text_path, data)
    if isinstance(data.get("robot"), Mapping) and "urdf" in data["robot"]:
        return load_arm(text_path).plant
    for key in data:
        if key not in _MODEL_KEYS:
            raise InputFileError(f"{where} unknown field `{key}`; valid: {', '.join(_MODEL_KEYS)}")
    name = data.get("name", os.path.splitext(os.path.basename(text_path))[0])
    if not isinstance(name, str):
        raise InputFileError(f"{where} field `name` must be a string, found {describe(name)}")
    form = data.get("form", "state")
    if form not in MODEL_FORMS:
        raise InputFileError(f"{where} field `form` must be one of {', '.join(MODEL_FORMS)}, found {describe(form)}")
    if "vertices" in data:
        if any(key in data for key in ("A", "B", "elements")) or form != "state":
            raise InputFileError(f"{where} a polytope gives `vertices` only (no `A`, `B`, `elements` or `form`)")
        return _load_polytope(where, data["vertices"], name)
    for key in ("A", "B"):
        if key not in data:
            raise InputFileError(f"{where} missing field `{key}` (or give `vertices` for a polytope)")
    A = _matrix(where, "A", data["A"], (None, None))
    if A.shape[0] != A.shape[1]:
        raise InputFileError(f"{where} field `A` must be square, found {A.shape}")
    B = _matrix(where, "B", data["B"], (A.shape[0], None))
    elements = _load_elements(where, data.get("elements", []), A.shape, B.shape)
    if "C" in data and form != "integral":
        raise InputFileError(f"{where} field `C` is used by form = 'integral' only")
    try:
        if form == "state":
            return UncertainLTVModel(A, B, tuple(elements), name=name)
        if form == "pid":
            p = A.shape[0] // 2
            C = np.hstack([np.eye(p), np.zeros((p, A.shape[0] - p))])
            return pid_augment(ct.ss(A, B, C, 0), elements, name=name)
        if "C" not in data:
            raise InputFileError(f"{where} missing field `C` (the outputs to integrate, form = 'integral')")
        C = _matrix(where, "C", data["C"], (None, A.shape[0]))
        return integral_augment(ct.ss(A, B, C, 0), elements, name=name)
    except ArgumentError as err:
        raise InputFileError(f"{where} {err}") from err


def _signals(where: str, key: str, raw: Any) -> tuple[Signal, ...]:
    if raw is None:
        return ()
    if not isinstance(raw, list) or not all(isinstance(r, Mapping) for r in raw):
        raise InputFileError(f"{where} field `{key}` must be a list of tables with `name` and `unit`, found "
                             f"{describe(raw)}")
    out = []
    for k, table in enumerate(raw):
        for field in ("name", "unit"):
            if not isinstance(table.get(field), str) or not table[field].strip():
                raise InputFileError(f"{where} field `{key}[{k}].{field}` must be a non-empty string, found "
                                     f"{describe(table.get(field))}")
        valid = ("name", "unit", "limit") if key == "inputs" else ("name", "unit")
        unknown = set(table) - set(valid)
        if unknown:
            raise InputFileError(f"{where} unknown field `{key}[{k}].{sorted(unknown)[0]}`; valid: {', '.join(valid)}")
        limit = None
        if "limit" in table:  # the actuator's largest |u|, in the input's unit
            limit = field_number(where, f"{key}[{k}].limit", table["limit"], table["unit"])
            if limit <= 0:
                raise InputFileError(f"{where} field `{key}[{k}].limit` must be > 0 {table['unit']} (the largest "
                                     f"|{table['name']}| the actuator delivers), found {limit:g} {table['unit']}")
        out.append(Signal(table["name"], table["unit"], limit))
    return tuple(out)


def _limit(where: str, field: str, value: Any, unit: str) -> float:
    """A physical limit: a number, or ±inf (TOML's ``inf``; JSON's ``"inf"``)."""
    if isinstance(value, str) and value.strip().lower() in ("inf", "+inf", "-inf"):
        return -math.inf if value.strip().startswith("-") else math.inf
    if isinstance(value, float) and math.isinf(value):
        return value
    return field_number(where, field, value, unit)


def _parameter(where: str, name: str, raw: Any) -> Parameter:
    field = f"parameters.{name}"
    if not isinstance(raw, Mapping):
        raise InputFileError(f"{where} field `{field}` must be a table (unit, and range or value), found "
                             f"{describe(raw)}")
    for key in raw:
        if key not in _PARAMETER_KEYS:
            raise InputFileError(f"{where} unknown field `{field}.{key}`; valid: {', '.join(_PARAMETER_KEYS)}")
    if "unit" not in raw:
        raise InputFileError(f"{where} missing field `{field}.unit` (the parameter's unit, e.g. 'kg·m²'; '1' when "
                             "dimensionless)")
    if ("range" in raw) == ("value" in raw):
        raise InputFileError(f"{where} field `{field}` needs exactly one of `range` = [lower, upper] (a varying "
                             "parameter) and `value` (a fixed one)")
    if "value" in raw:
        value = field_number(where, f"{field}.value", raw["value"], raw["unit"] if isinstance(raw["unit"], str) else "")
        if "rate" in raw:
            raise InputFileError(f"{where} field `{field}.rate` bounds the change of a parameter with a `range`; "
                                 f"{name} has a fixed `value`")
        bounds: Any = (value, value)
    else:
        bounds = raw["range"]
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise InputFileError(f"{where} field `{field}.range` must be [lower, upper], found {describe(bounds)}")
        bounds = tuple(field_number(where, f"{field}.range[{k}]", v, str(raw["unit"])) for k, v in enumerate(bounds))
    samples = raw.get("samples", 5)
    if isinstance(samples, bool) or not isinstance(samples, int):
        raise InputFileError(f"{where} field `{field}.samples` must be an integer, found {describe(samples)}")
    limits = None
    if "physical" in raw:
        limits = raw["physical"]
        if not isinstance(limits, list) or len(limits) != 2:
            raise InputFileError(f"{where} field `{field}.physical` must be [lower, upper] in {raw['unit']} (inf "
                                 f"for no bound, e.g. [0, inf]), found {describe(limits)}")
        limits = tuple(_limit(where, f"{field}.physical[{k}]", v, str(raw["unit"])) for k, v in enumerate(limits))
    measured = raw.get("measured", False)
    if not isinstance(measured, bool):
        raise InputFileError(f"{where} field `{field}.measured` must be true or false, found {describe(measured)}")
    error = field_number(where, f"{field}.measurement_error", raw.get("measurement_error", 0.0), str(raw["unit"]))
    delay = field_number(where, f"{field}.measurement_delay", raw.get("measurement_delay", 0.0), "s")
    try:
        return Parameter(name, raw["unit"], bounds, nominal=raw.get("nominal"), rate=raw.get("rate"),
                         samples=samples, description=str(raw.get("description", "")), limits=limits,
                         measured=measured, measurement_error=error, measurement_delay=delay)
    except ArgumentError as err:
        raise InputFileError(f"{where} field `parameters.{err.argument}` {err.problem}") from err


def load_plant(path: str | os.PathLike[str]) -> UncertainPlant:
    """Read a plant file with named physical parameters (TOML or JSON).

    The format (``examples/plant-dc-motor.toml`` documents it): ``name``; ``form``
    (``"pid"``, ``"integral"`` or ``"state"``, see :class:`~scara_robust.UncertainPlant`);
    ``[parameters.NAME]`` tables with ``unit`` and either ``range = [lower, upper]``
    (optional ``nominal``, ``rate`` in unit/s, ``samples``) or ``value``; ``A`` and ``B``
    as lists of rows whose entries are numbers or arithmetic in the parameters
    (``"-b/J"``), parsed by whitelist and never executed; ``C`` for the integral form;
    ``[[inputs]]`` and ``[[outputs]]`` with ``name`` and ``unit``; ``prefix`` for exported
    code.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    UncertainPlant

    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        One line naming the file and the field: a range with lower > upper, a missing
        unit, an unknown name in an entry, a call or an import, a rate on a fixed
        parameter, a plant undefined or singular where its form needs it, ...

    See Also
    --------
    UncertainPlant : what it returns.
    load_model : any model file (box, polytope or plant).
    """
    text_path = os.fspath(path)
    where = f"{text_path!r}:"
    data = read_mapping(text_path)
    return _plant_from_mapping(where, text_path, data)


def _plant_from_mapping(where: str, text_path: str, data: Mapping[str, Any]) -> UncertainPlant:
    for key in data:
        if key not in _PLANT_KEYS:
            raise InputFileError(f"{where} unknown field `{key}`; valid: {', '.join(_PLANT_KEYS)}")
    name = data.get("name", os.path.splitext(os.path.basename(text_path))[0])
    if not isinstance(name, str):
        raise InputFileError(f"{where} field `name` must be a string, found {describe(name)}")
    form = data.get("form", "pid")
    if form not in MODEL_FORMS:
        raise InputFileError(f"{where} field `form` must be one of {', '.join(MODEL_FORMS)}, found {describe(form)}")
    raw = data["parameters"]
    if not isinstance(raw, Mapping) or not raw:
        raise InputFileError(f"{where} field `parameters` must hold one table per parameter, found {describe(raw)}")
    parameters = [_parameter(where, key, value) for key, value in raw.items()]
    for key in ("A", "B"):
        if key not in data:
            raise InputFileError(f"{where} missing field `{key}` (a list of rows of numbers or expressions)")
    if "C" in data and form != "integral":
        raise InputFileError(f"{where} field `C` is used by form = 'integral' only")
    if form == "integral" and "C" not in data:
        raise InputFileError(f"{where} missing field `C` (the outputs to integrate, form = 'integral')")
    prefix = data.get("prefix", "plant_pid")
    if not isinstance(prefix, str) or not prefix.isidentifier():
        raise InputFileError(f"{where} field `prefix` must be a C identifier, found {describe(prefix)}")
    inputs = _signals(where, "inputs", data.get("inputs"))
    outputs = _signals(where, "outputs", data.get("outputs"))
    C = _matrix(where, "C", data["C"], (None, None)) if "C" in data else None
    try:
        plant = UncertainPlant.from_expressions(parameters, data["A"], data["B"], form=form, C=C, name=name,
                                                inputs=inputs, outputs=outputs, prefix=prefix)
        plant.interval_model()  # every entry defined on the whole box
    except ArgumentError as err:
        raise InputFileError(f"{where} field `{err.argument}` {err.problem}") from err
    return plant


#: ``format`` field of a design file.
DESIGN_FORMAT = "scara_robust design 1"


@dataclass(frozen=True)
class DesignFile:
    """A gain read from a design file (:func:`write_design`).

    Attributes
    ----------
    path : str
    K : ndarray, shape (m, n)
        Gain of ``u = −Kx``; for the SCARA, (2, 6) on ``x = [∫e, e, ė]`` (N·m per rad·s,
        rad, rad/s).
    P : ndarray, shape (n, n), or None
        Its Lyapunov matrix, if the file has one.
    info : dict
        Everything else the file records (how the gain was made, its certificate).
    """

    path: str
    K: NDArray[np.float64]
    P: NDArray[np.float64] | None
    info: dict[str, Any]


def design_record(K: Any, P: Any = None, **info: Any) -> dict[str, Any]:
    """The JSON-ready content of a design file.

    Parameters
    ----------
    K : array_like, shape (m, n)
    P : array_like, shape (n, n), optional
    **info
        JSON-serializable facts about the design (its method, decay rate, bounds...).

    Returns
    -------
    dict
        ``format``, ``K``, ``P`` (or None), and for a PID-structured gain (n = 3m) the
        matrices ``K_I``, ``K_P``, ``K_D`` of ``u = K_I ∫e + K_P e + K_D ė``, then `info`.
    """
    K = np.asarray(K, dtype=float)
    record: dict[str, Any] = {"format": DESIGN_FORMAT, "K": K.tolist(),
                              "P": None if P is None else np.asarray(P, dtype=float).tolist()}
    m, n = K.shape
    if n == 3 * m:
        record.update({"K_I": (-K[:, :m]).tolist(), "K_P": (-K[:, m:2 * m]).tolist(), "K_D": (-K[:, 2 * m:]).tolist()})
    record.update(info)
    return record


def write_design(path: str | os.PathLike[str], K: Any, P: Any = None, **info: Any) -> None:
    """Write a design file (JSON) atomically.

    Parameters
    ----------
    path : path-like
        ``.json`` file.
    K, P, **info
        See :func:`design_record`.

    Raises
    ------
    InputFileError
        If the extension is not ``.json``.
    OSError
        If the folder is not writable.
    """
    text_path = os.fspath(path)
    if not text_path.lower().endswith(".json"):
        raise InputFileError(f"{text_path!r}: a design file is .json")
    text = json.dumps(design_record(K, P, **info), indent=2) + "\n"

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    write_atomic(text_path, write)


def load_design(path: str | os.PathLike[str]) -> DesignFile:
    """Read a design file written by :func:`write_design` (``synthesize --output``), or a
    ros2_control ``pid_controller`` parameter file (``.yaml``, :func:`load_pid_controller`).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    DesignFile

    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        Naming the file and the field: not a design file, ``K`` missing, not a finite
        matrix, or ``P`` of the wrong size.
    """
    text_path = os.fspath(path)
    ext = os.path.splitext(text_path)[1].lower()
    if ext in (".yaml", ".yml"):
        return load_pid_controller(text_path).design_file()
    if ext != ".json":
        raise InputFileError(f"{text_path!r}: expected a design file (.json) or a pid_controller parameter "
                             "file (.yaml)")
    data = read_mapping(text_path, extensions=(".json",))
    if data.get("format") != DESIGN_FORMAT:
        raise InputFileError(f"{text_path!r}: field `format` must be {DESIGN_FORMAT!r}, found "
                             f"{describe(data.get('format'))}")
    if "K" not in data:
        raise InputFileError(f"{text_path!r}: field `K` (the gain, a matrix) is missing")
    where = f"{text_path!r}:"
    K = _matrix(where, "K", data["K"], (None, None))
    P = None
    if data.get("P") is not None:
        P = _matrix(where, "P", data["P"], (None, None))
        if P.shape != (K.shape[1], K.shape[1]):  # the two fields disagree: name both
            raise InputFileError(f"{where} fields `K` and `P` disagree: K has shape {K.shape}, so P must be "
                                 f"{(K.shape[1], K.shape[1])}, found {P.shape}")
    info = {k: v for k, v in data.items() if k not in ("format", "K", "P")}
    return DesignFile(text_path, K, P, info)


# --- ros2_control's pid_controller parameter files ------------------------------------------------

#: The per-joint keys of ros2_controllers' ``pid_controller`` (``gains.<dof>.<key>``, version 6.9.0
#: of its parameter definition, ``pid_controller/src/pid_controller.yaml``) and control_toolbox's
#: ``saturation`` (declared by ``PidROS``), with their types.
PID_CONTROLLER_GAINS: dict[str, type] = {
    "p": float, "i": float, "d": float, "u_clamp_max": float, "u_clamp_min": float, "i_clamp_max": float,
    "i_clamp_min": float, "antiwindup_strategy": str, "tracking_time_constant": float, "error_deadband": float,
    "feedforward_gain": float, "angle_wraparound": bool, "save_i_term": bool, "activate_state_publisher": bool,
    "saturation": bool,
}
_ANTIWINDUP = ("none", "back_calculation", "conditional_integration")

#: The controller-level keys of ``pid_controller``'s ``ros__parameters`` (version 6.9.0).
PID_CONTROLLER_KEYS = ("dof_names", "reference_and_state_dof_names", "command_interface",
                       "reference_and_state_interfaces", "set_current_state_as_first_setpoint",
                       "use_external_measured_states", "gains")
PID_CONTROLLER_TYPE = "pid_controller/PidController"

#: The ``method`` a :class:`DesignFile` read from a pid_controller file records.
PID_CONTROLLER_METHOD = "ros2_control pid_controller"


@dataclass(frozen=True)
class PidControllerGains:
    """The per-joint PIDs of a ros2_control ``pid_controller`` parameter file.

    control_toolbox's PID computes, per joint and update period dt (forward Euler, the
    integral term of the previous update in the command)::

        u_k = clamp(p e_k + I_k + d ė_k, u_clamp_min, u_clamp_max)
        I_{k+1} = clamp(I_k + dt (i e_k + (u_k − v_k)/tracking_time_constant), i_clamp_min, i_clamp_max)

    (the back-calculation term with ``antiwindup_strategy: back_calculation``), with
    ``e = reference − state`` and ė the difference of the two velocity interfaces.

    Attributes
    ----------
    path : str
    controller : str
        The controller's name (the key above ``ros__parameters``).
    joints : tuple of str
        ``dof_names``, in the file's order.
    p, i, d : ndarray, shape (n_joints,)
        N·m/rad, N·m/(rad·s), N·m·s/rad for an effort command.
    u_clamp : ndarray, shape (n_joints,)
        The symmetric output clamp ``|u| <= u_clamp``, N·m (inf: none).
    i_clamp : ndarray, shape (n_joints,)
        The symmetric integral-term clamp, N·m (inf: none).
    antiwindup_strategy : tuple of str
        Per joint.
    tracking_time_constant : ndarray, shape (n_joints,)
        s (0: control_toolbox's default, ``sqrt(d/i)``, or ``p/i`` when d = 0).
    parameters : dict
        Every key the file gives per joint, as read.
    update_rate : int or None
        The ``controller_manager``'s ``update_rate``, Hz (dt = 1/update_rate), when the file
        has one.
    """

    path: str
    controller: str
    joints: tuple[str, ...]
    p: NDArray[np.float64]
    i: NDArray[np.float64]
    d: NDArray[np.float64]
    u_clamp: NDArray[np.float64]
    i_clamp: NDArray[np.float64]
    antiwindup_strategy: tuple[str, ...]
    tracking_time_constant: NDArray[np.float64]
    parameters: dict[str, dict[str, Any]]
    update_rate: int | None = None

    @property
    def K(self) -> NDArray[np.float64]:
        """The gain of ``u = −K x`` on ``x = [∫e, e, ė]``: ``−[diag(i), diag(p), diag(d)]``, shape (n, 3n)."""
        K = -np.hstack([np.diag(self.i), np.diag(self.p), np.diag(self.d)])
        K[K == 0.0] = 0.0  # no -0.0 off the diagonal
        return K

    def tracking_time(self) -> NDArray[np.float64]:
        """The back-calculation time constant control_toolbox uses, s, shape (n_joints,)."""
        tt = self.tracking_time_constant.copy()
        zero = tt == 0.0
        default = np.where(self.d != 0.0, np.sqrt(np.abs(self.d / np.where(self.i == 0.0, 1.0, self.i))),
                           self.p / np.where(self.i == 0.0, 1.0, self.i))
        tt[zero] = default[zero]
        return tt

    def design_file(self) -> DesignFile:
        """As a :class:`DesignFile` (K, no P), the file's figures in ``info``."""
        info = {"method": PID_CONTROLLER_METHOD, "controller": self.controller, "joints": list(self.joints),
                "u_clamp": [float(v) for v in self.u_clamp], "i_clamp": [float(v) for v in self.i_clamp],
                "antiwindup_strategy": list(self.antiwindup_strategy),
                "tracking_time_constant": [float(v) for v in self.tracking_time_constant],
                "tracking_time": [float(v) for v in self.tracking_time()],
                "error_deadband": [float(self.parameters[j].get("error_deadband", 1e-16)) for j in self.joints],
                "feedforward_gain": [float(self.parameters[j].get("feedforward_gain", 0.0)) for j in self.joints],
                "angle_wraparound": [bool(self.parameters[j].get("angle_wraparound", False)) for j in self.joints],
                "update_rate": self.update_rate}
        return DesignFile(self.path, self.K, None, info)


def ros2_dof_name(output: str) -> str:
    """The ros2_control joint of a plant's output: an arm's ``q_<joint>`` is ``<joint>``, others as named.

    Parameters
    ----------
    output : str
        A plant output's name (``'q1'``, ``'q_shoulder_pan_joint'``).

    Returns
    -------
    str
    """
    return output.removeprefix("q_")


def load_pid_controller(path: str | os.PathLike[str]) -> PidControllerGains:
    """Read the per-joint PIDs of a ros2_control ``pid_controller`` parameter file.

    The file holds ``<controller>: ros__parameters:`` with ``dof_names``,
    ``command_interface: effort``, ``reference_and_state_interfaces: [position, velocity]``
    and ``gains.<dof>`` (:data:`PID_CONTROLLER_GAINS`); other controllers in the same file
    are ignored. The package's PID is symmetric in its limit and commands a torque from
    the measured error rate, so the clamps must be symmetric, the command an effort and
    the interfaces position and velocity.

    Parameters
    ----------
    path : path-like
        A ``.yaml`` or ``.yml`` file.

    Returns
    -------
    PidControllerGains

    Raises
    ------
    OSError
        If the file cannot be read.
    InputFileError
        Naming the file and the field: not YAML, no or several ``pid_controller``
        sections, a missing or unknown key, a value of the wrong type (ROS 2 parameters
        are typed: ``1.0``, not ``1``), asymmetric clamps, an interface the package's PID
        does not run.
    """
    import yaml

    text_path = os.fspath(path)
    if os.path.isdir(text_path):
        raise InputFileError(f"{text_path!r} is a directory, not a file")
    with open(text_path, "rb") as fh:
        raw = fh.read()
    try:
        data = yaml.safe_load(raw.decode("utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise InputFileError(f"{text_path!r} is not valid YAML: {err}".replace("\n", " ")) from err
    where = f"{text_path!r}:"
    sections = {name: body["ros__parameters"] for name, body in (data or {}).items()
                if isinstance(body, dict) and isinstance(body.get("ros__parameters"), dict)
                and "gains" in body["ros__parameters"]} if isinstance(data, dict) else {}
    if len(sections) != 1:
        found = "none" if not sections else ", ".join(repr(n) for n in sections)
        raise InputFileError(f"{where} expected one controller with `ros__parameters` holding `dof_names` and "
                             f"`gains` (a pid_controller), found {found}")
    (controller, params), = sections.items()
    base = f"{controller}.ros__parameters"
    unknown = [key for key in params if key not in PID_CONTROLLER_KEYS]
    if unknown:
        raise InputFileError(f"{where} field `{base}.{unknown[0]}` is not a parameter of pid_controller (it would be "
                             f"ignored); expected one of {', '.join(PID_CONTROLLER_KEYS)}")
    update_rate = _update_rate(where, data, str(controller))
    joints = params.get("dof_names")
    if (not isinstance(joints, list) or not joints or not all(isinstance(j, str) and j for j in joints)
            or len(set(joints)) != len(joints)):
        raise InputFileError(f"{where} field `{base}.dof_names` must be a list of distinct joint names, found "
                             f"{describe(joints)}")
    command = params.get("command_interface")
    if command != "effort":
        raise InputFileError(f"{where} field `{base}.command_interface` must be 'effort' (the PID's output is a "
                             f"torque), found {describe(command)}")
    interfaces = params.get("reference_and_state_interfaces")
    if interfaces != ["position", "velocity"]:
        raise InputFileError(f"{where} field `{base}.reference_and_state_interfaces` must be ['position', "
                             f"'velocity'] (the PID reads the measured error rate), found {describe(interfaces)}")
    gains = params["gains"]
    if not isinstance(gains, dict):
        raise InputFileError(f"{where} field `{base}.gains` must be a table per joint, found {describe(gains)}")
    extra = [name for name in gains if name not in joints]
    if extra:
        raise InputFileError(f"{where} field `{base}.gains` names {extra[0]!r}, which `dof_names` does not")
    read: dict[str, dict[str, Any]] = {}
    for joint in joints:
        entry = gains.get(joint)
        field = f"{base}.gains.{joint}"
        if not isinstance(entry, dict):
            raise InputFileError(f"{where} field `{field}` (p, i, d...) is missing")
        for key, value in entry.items():
            kind = PID_CONTROLLER_GAINS.get(key)
            if kind is None:
                raise InputFileError(f"{where} field `{field}.{key}` is not a key of pid_controller's gains (it "
                                     f"would be ignored); expected one of {', '.join(PID_CONTROLLER_GAINS)}")
            if kind is float and (isinstance(value, bool) or not isinstance(value, float)):
                raise InputFileError(f"{where} field `{field}.{key}` must be a float (ROS 2 parameters are typed: "
                                     f"write 1.0, not 1), found {describe(value)}")
            if kind is not float and not isinstance(value, kind):
                raise InputFileError(f"{where} field `{field}.{key}` must be a {kind.__name__}, found "
                                     f"{describe(value)}")
        for key in ("p", "i", "d"):
            if key not in entry:
                raise InputFileError(f"{where} field `{field}.{key}` is missing")
            if not math.isfinite(entry[key]):
                raise InputFileError(f"{where} field `{field}.{key}` must be finite, found {entry[key]}")
        u_max, u_min = entry.get("u_clamp_max", math.inf), entry.get("u_clamp_min", -math.inf)
        if entry.get("saturation") is False:
            u_max, u_min = math.inf, -math.inf
        if not (u_max > 0 and u_min == -u_max):
            raise InputFileError(f"{where} fields `{field}.u_clamp_min`, `u_clamp_max` must be -L and L with L > 0 "
                                 f"(a symmetric torque limit, N·m), found {u_min}, {u_max}")
        i_max, i_min = entry.get("i_clamp_max", math.inf), entry.get("i_clamp_min", -math.inf)
        if not (i_max > 0 and i_min == -i_max):
            raise InputFileError(f"{where} fields `{field}.i_clamp_min`, `i_clamp_max` must be -L and L with L > 0, "
                                 f"N·m, found {i_min}, {i_max}")
        strategy = entry.get("antiwindup_strategy", "none")
        if strategy not in _ANTIWINDUP:
            raise InputFileError(f"{where} field `{field}.antiwindup_strategy` must be one of "
                                 f"{', '.join(repr(a) for a in _ANTIWINDUP)}, found {describe(strategy)}")
        tt = entry.get("tracking_time_constant", 0.0)
        if not (math.isfinite(tt) and tt >= 0):
            raise InputFileError(f"{where} field `{field}.tracking_time_constant` must be >= 0 s, found {tt}")
        read[joint] = dict(entry, u_clamp_max=u_max, u_clamp_min=u_min, i_clamp_max=i_max, i_clamp_min=i_min,
                           antiwindup_strategy=strategy, tracking_time_constant=tt)

    def column(key: str) -> NDArray[np.float64]:
        return np.array([read[j][key] for j in joints], dtype=float)

    return PidControllerGains(text_path, str(controller), tuple(joints), column("p"), column("i"), column("d"),
                              column("u_clamp_max"), column("i_clamp_max"),
                              tuple(read[j]["antiwindup_strategy"] for j in joints),
                              column("tracking_time_constant"), read, update_rate)


def _update_rate(where: str, data: dict[str, Any], controller: str) -> int | None:
    """The ``controller_manager``'s ``update_rate`` (Hz) when the file has one, its entry for `controller` checked."""
    manager = data.get("controller_manager")
    if manager is None:
        return None
    params = manager.get("ros__parameters") if isinstance(manager, dict) else None
    if not isinstance(params, dict):
        raise InputFileError(f"{where} field `controller_manager.ros__parameters` must be a table, found "
                             f"{describe(params)}")
    entry = params.get(controller)
    if entry is not None and (not isinstance(entry, dict) or entry.get("type") != PID_CONTROLLER_TYPE):
        found = entry.get("type") if isinstance(entry, dict) else entry
        raise InputFileError(f"{where} field `controller_manager.ros__parameters.{controller}.type` must be "
                             f"{PID_CONTROLLER_TYPE!r}, found {describe(found)}")
    rate = params.get("update_rate")
    if rate is None:
        return None
    if isinstance(rate, bool) or not isinstance(rate, int) or rate < 1:
        raise InputFileError(f"{where} field `controller_manager.ros__parameters.update_rate` must be a whole number "
                             f"of Hz >= 1, found {describe(rate)}")
    return rate
