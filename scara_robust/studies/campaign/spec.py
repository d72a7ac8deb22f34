"""Campaign specs: what a Monte-Carlo campaign draws, validated field by field.

A campaign is described by a :class:`CampaignSpec`, usually read from a TOML file
(:func:`load_spec`; ``examples/campaign.toml`` documents every field). Scenario ``i`` of
a campaign with seed ``s`` is drawn from ``numpy.random.default_rng([s, i])`` alone
(:func:`draw_scenario`), so it is the same however the campaign is split, ordered,
interrupted or distributed.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..._validation import field_number
from ...exceptions import CampaignSpecError
from ...io import read_mapping
from ...model.robot import ScaraParams
from ...paper import (
    PAPER_CP,
    PAPER_DESIGN_POINT,
    PAPER_DISTURBANCE_AMPLITUDE,
    PAPER_DISTURBANCE_PERIOD,
    PAPER_PAYLOAD_FRACTION,
    PAPER_T_FINAL,
    PAPER_TRANSIENT,
)
from ...simulation.controllers import CONTROLLERS

__all__ = ["Range", "CampaignSpec", "PAYLOAD_PROFILES", "ARM_SPEC_FIELDS", "load_spec", "spec_from_dict",
           "draw_scenario"]

_WHERE = "campaign spec"

#: Payload mass profiles a campaign can draw.
PAYLOAD_PROFILES = ("sinusoidal", "constant")


@dataclass(frozen=True)
class Range:
    """A uniform distribution on ``[low, high]``; ``low == high`` is a constant."""

    low: float
    high: float

    def draw(self, rng: np.random.Generator) -> float:
        """One value (a constant consumes no randomness)."""
        return self.low if self.low == self.high else float(rng.uniform(self.low, self.high))


#: Drawn numeric fields: name -> (unit, lower limit, strict, paper's value). The limit
#: is inclusive unless ``strict``.
SPEC_FIELDS: dict[str, tuple[str, float, bool, float]] = {
    "payload_peak": ("kg", 0.0, False, 2 * PAPER_PAYLOAD_FRACTION * ScaraParams().m2),
    "payload_omega": ("rad/s", 0.0, True, 1.0),
    "payload_phase": ("rad", -math.inf, False, 0.0),
    "cp": ("m²", 0.0, False, PAPER_CP),
    "disturbance_amplitude": ("N·m", 0.0, False, PAPER_DISTURBANCE_AMPLITUDE),
    "disturbance_period": ("s", 0.0, True, PAPER_DISTURBANCE_PERIOD),
    "disturbance_phase": ("rad", -math.inf, False, 0.0),
    "reference_amplitude": ("rad", 0.0, False, 1.0),
    "reference_omega": ("rad/s", 0.0, True, 1.0),
    "initial_error": ("rad", -math.inf, False, 0.05),
    "torque_limit": ("N·m", 0.0, True, math.inf),
}


#: Drawn fields of an arm campaign only (``campaign --robot`` with a URDF robot file):
#: name -> (unit, lower limit, strict, default). ``reference_scale`` multiplies the robot
#: file's reference amplitudes; ``measurement_noise`` is the RMS of the noise on each
#: measured angle, ``noise_bandwidth`` its highest frequency (see
#: :class:`scara_robust.MeasurementNoise`).
ARM_SPEC_FIELDS: dict[str, tuple[str, float, bool, float]] = {
    "reference_scale": ("-", 0.0, False, 1.0),
    "measurement_noise": ("rad", 0.0, False, 0.0),
    "noise_bandwidth": ("Hz", 0.0, True, 5.0),
}
#: Fields that describe the SCARA alone: an arm's payload inertia and reference come from its robot file.
SCARA_ONLY_FIELDS = ("cp", "reference_amplitude", "reference_omega")


def _default_ranges() -> dict[str, Range]:
    return {name: Range(v[3], v[3]) for name, v in SPEC_FIELDS.items()}


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign draws and runs.

    Attributes
    ----------
    controllers : tuple of str
        Names from :data:`scara_robust.CONTROLLERS` (at least one, no repeats).
    t_final : float
        Horizon of every run, s (> 6, so the after-transient metrics exist).
    rho, eta : float
        The PID design K(ρ, η) on the published model (fixed for the campaign).
    payload_profiles : tuple of str
        Drawn uniformly: ``'sinusoidal'`` is ``m_p(t) = (peak/2)(1 + sin(ωt + φ))``,
        ``'constant'`` is ``m_p = peak``.
    ranges : dict of str to Range
        One :class:`Range` per entry of :data:`SPEC_FIELDS`. ``initial_error`` is drawn
        independently for each joint (``e(0)``; ``ė(0) = 0``); ``torque_limit = inf``
        means no saturation. The reference is ``r = a (sin ωt, cos ωt)``.
    runs : int
        Default number of scenarios.
    seed : int
        Default seed.
    robot : ScaraParams
        The robot (default: the paper's); its ``cp`` is replaced by the drawn one.
    arm_ranges : dict of str to Range
        The fields of :data:`ARM_SPEC_FIELDS` the spec gives (an arm campaign draws the
        others at their defaults; a SCARA campaign refuses them).
    robot_file : str or None
        A robot file naming a URDF: the campaign runs that arm (see
        ``scara_robust.studies.campaign.arm``); None: the SCARA.
    robot_digest : str
        Hash of the robot file and its URDF (part of :meth:`digest`, so a table is
        continued only on the same arm).
    """

    controllers: tuple[str, ...] = ("pid", "smc")
    t_final: float = PAPER_T_FINAL
    rho: float = PAPER_DESIGN_POINT[0]
    eta: float = PAPER_DESIGN_POINT[1]
    payload_profiles: tuple[str, ...] = ("sinusoidal",)
    ranges: Mapping[str, Range] = field(default_factory=_default_ranges)
    runs: int = 100
    seed: int = 0
    robot: ScaraParams = field(default_factory=ScaraParams)
    arm_ranges: Mapping[str, Range] = field(default_factory=dict)
    robot_file: str | None = None
    robot_digest: str = ""

    def digest(self) -> str:
        """Short hash of everything that determines the drawn scenarios and runs."""
        data = asdict(self)
        data.pop("runs")
        data.pop("robot_file")  # the arm is identified by its content, not where it is
        if self.robot_file is None and not self.arm_ranges:  # a SCARA campaign: the hash it always had
            data.pop("arm_ranges")
            data.pop("robot_digest")
        text = json.dumps(data, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:12]


def _error(name: str, message: str) -> CampaignSpecError:
    return CampaignSpecError(f"{_WHERE} field `{name}`: {message}")


def _number(name: str, value: Any, unit: str, *, allow_inf: bool = False) -> float:
    return field_number(_WHERE, name, value, unit, error=CampaignSpecError, allow_inf=allow_inf)


def _range(name: str, value: Any) -> Range:
    unit, limit, strict, _ = SPEC_FIELDS[name] if name in SPEC_FIELDS else ARM_SPEC_FIELDS[name]
    if isinstance(value, Mapping):
        unknown = set(value) - {"min", "max"}
        if unknown or set(value) != {"min", "max"}:
            raise _error(name, f"expected a number or {{min = ..., max = ...}}, found keys {sorted(value)}")
        allow_inf = name == "torque_limit"
        low = _number(name, value["min"], unit, allow_inf=allow_inf)
        high = _number(name, value["max"], unit, allow_inf=allow_inf)
    else:
        low = high = _number(name, value, unit, allow_inf=name == "torque_limit")
    if low > high:
        raise _error(name, f"min {low:g} {unit} > max {high:g} {unit}")
    if low != high and math.isinf(high):  # a uniform draw needs finite ends
        raise _error(name, f"a range must have finite ends, found {{min = {low:g}, max = inf}} {unit}; "
                           "`inf` alone means no limit")
    for v in (low, high):
        if (v <= limit) if strict else (v < limit):
            op = ">" if strict else ">="
            raise _error(name, f"expected values {op} {limit:g} {unit}, found {v:g}")
    return Range(low, high)


def spec_from_dict(data: Mapping[str, Any]) -> CampaignSpec:
    """Validate a campaign description (as read from TOML) into a :class:`CampaignSpec`.

    Parameters
    ----------
    data : mapping
        Field names to values: a number, ``{min, max}``, or a list for
        ``controllers`` and ``payload_profiles``.

    Returns
    -------
    CampaignSpec


    Raises
    ------
    CampaignSpecError
        Naming the first bad field: unknown field, wrong type, min > max, a value
        outside its physical range (negative mass, period <= 0, ...), an unknown or
        empty controller list.
    """
    if not isinstance(data, Mapping):
        raise CampaignSpecError(f"campaign spec must be a table of fields, found {type(data).__name__}")
    known = {"controllers", "t_final", "rho", "eta", "payload_profiles", "runs", "seed", *SPEC_FIELDS,
             *ARM_SPEC_FIELDS}
    for name in data:
        if name not in known:
            raise _error(name, f"unknown field; valid fields are {', '.join(sorted(known))}")
    kwargs: dict[str, Any] = {}
    if "controllers" in data:
        names = data["controllers"]
        if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
            raise _error("controllers", f"expected a list of names, found {names!r}")
        if not names:
            raise _error("controllers", f"expected at least one of {', '.join(CONTROLLERS)}, found an empty list")
        for n in names:
            if n not in CONTROLLERS:
                raise _error("controllers", f"unknown controller {n!r}; valid: {', '.join(CONTROLLERS)}")
        if len(set(names)) != len(names):
            raise _error("controllers", f"expected no repeats, found {names!r}")
        kwargs["controllers"] = tuple(names)
    if "payload_profiles" in data:
        profiles = data["payload_profiles"]
        if not isinstance(profiles, (list, tuple)) or not profiles or not all(p in PAYLOAD_PROFILES for p in profiles):
            raise _error("payload_profiles", f"expected a non-empty list from {PAYLOAD_PROFILES}, found {profiles!r}")
        kwargs["payload_profiles"] = tuple(profiles)
    if "t_final" in data:
        kwargs["t_final"] = _number("t_final", data["t_final"], "s")
        if not PAPER_TRANSIENT < kwargs["t_final"]:
            raise _error("t_final", f"expected a horizon > {PAPER_TRANSIENT:g} s (metrics are taken after "
                         f"{PAPER_TRANSIENT:g} s), found {kwargs['t_final']:g}")
    if "rho" in data:
        kwargs["rho"] = _number("rho", data["rho"], "-")
        if not 0 < kwargs["rho"] < math.inf:
            raise _error("rho", f"expected a finite number > 0, found {kwargs['rho']:g}")
    if "eta" in data:
        kwargs["eta"] = _number("eta", data["eta"], "-")
        if not 1 <= kwargs["eta"] < math.inf:
            raise _error("eta", f"expected a finite number >= 1, found {kwargs['eta']:g}")
    for name, low in (("runs", 1), ("seed", 0)):
        if name in data:
            value = data[name]
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise _error(name, f"expected an integer >= {low}, found {value!r}")
            kwargs[name] = value
    ranges = _default_ranges()
    for name in SPEC_FIELDS:
        if name in data:
            ranges[name] = _range(name, data[name])
    arm_ranges = {name: _range(name, data[name]) for name in ARM_SPEC_FIELDS if name in data}
    return CampaignSpec(ranges=ranges, arm_ranges=arm_ranges, **kwargs)


def load_spec(path: str | os.PathLike[str]) -> CampaignSpec:
    """Read and validate a campaign TOML file.

    Parameters
    ----------
    path : path-like
        The spec file (see ``examples/campaign.toml``).

    Returns
    -------
    CampaignSpec


    Raises
    ------
    OSError
        If the file cannot be read.
    CampaignSpecError
        If it is not valid TOML or a field is bad (the message names it).
    """
    data = read_mapping(path, extensions=(".toml",), error=CampaignSpecError)
    if not data:
        raise CampaignSpecError(
            f"campaign spec {os.fspath(path)!r} is empty: give at least one field (examples/campaign.toml "
            "documents them all); a campaign never runs on defaults it did not ask for"
        )
    return spec_from_dict(data)


def draw_scenario(spec: CampaignSpec, seed: int, index: int) -> dict[str, Any]:
    """The inputs of scenario `index`, drawn from ``default_rng([seed, index])``.

    Parameters
    ----------
    spec : CampaignSpec
    seed : int
        Campaign seed (>= 0).
    index : int
        Scenario number (>= 0).


    Returns
    -------
    dict
        ``scenario`` (the index), ``payload_profile`` and one value per
        :data:`SPEC_FIELDS` entry, with ``initial_error`` split into ``e1_0``, ``e2_0``.
    """
    rng = np.random.default_rng([int(seed), int(index)])
    out: dict[str, Any] = {"scenario": int(index)}
    out["payload_profile"] = spec.payload_profiles[int(rng.integers(len(spec.payload_profiles)))]
    for name in SPEC_FIELDS:
        if name == "initial_error":
            out["e1_0"] = spec.ranges[name].draw(rng)
            out["e2_0"] = spec.ranges[name].draw(rng)
        else:
            out[name] = spec.ranges[name].draw(rng)
    return out
