"""The system a command runs on, chosen once from its arguments: :func:`load_system`.

The kinds of system and everything they answer are the workflow layer's
(:mod:`scara_robust.workflow.system`); here the arguments name the kind and the files:
a ``--robot`` file naming a URDF is an arm, ``--model`` a plant file, else the built-in
SCARA. No command asks which kind it holds.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from functools import partial
from typing import Any

from ..io import is_arm_file
from ..model.plant import UncertainPlant
from ..workflow.system import (
    CERTIFICATE_CHECK_GRID,
    CERTIFICATE_GRID,
    ArmSystem,
    Capabilities,
    LoadedSystem,
    PhysicalSet,
    PlantFileSystem,
    ScaraSystem,
    Setup,
    open_system,
)
from ._options import option
from ._parser import CommandLineError

__all__ = [
    "ARM_COMMANDS",
    "CERTIFICATE_GRID",
    "CERTIFICATE_CHECK_GRID",
    "ArmSystem",
    "Capabilities",
    "LoadedSystem",
    "PhysicalSet",
    "PlantFileSystem",
    "ScaraSystem",
    "Setup",
    "load_system",
]

#: Commands that run on a robot file naming a URDF (through its linearized error dynamics).
ARM_COMMANDS = ("design", "certify", "margin", "synthesize", "simulate", "compare", "export", "surface", "tune",
                "campaign")

def _check_arm(args: argparse.Namespace, robot: str) -> None:
    """Refuse what cannot go with a URDF robot: a command without arms, ``--model``, the SCARA's options."""
    if args.command not in ARM_COMMANDS:
        raise CommandLineError(f"`--robot` {robot!r} names a URDF; `{args.command}` runs on the built-in SCARA only "
                               f"(a URDF robot goes with {', '.join(ARM_COMMANDS)})")
    if option(args, "model") is not None:
        raise CommandLineError("`--robot` and `--model` each name the plant; give one")
    for name in ("bounds", "scenario"):
        if option(args, name) is not None:
            runs = (" (its runs' initial error and disturbance too, [initial] and [disturbance], or --e0, --edot0 "
                    "and --disturbance)" if args.command in ("simulate", "compare") else "")
            raise CommandLineError(f"`--{name}` describes the built-in SCARA; a URDF robot's reference, payload "
                                   f"and linearization are in its file {robot!r}{runs}")


def _kind(args: argparse.Namespace) -> str:
    """Which system the arguments name: ``'arm'``, ``'plant'`` or ``'scara'``."""
    robot = option(args, "robot")
    if robot is not None and is_arm_file(robot):
        _check_arm(args, robot)
        return "arm"
    return "plant" if option(args, "model") is not None else "scara"



def load_system(args: argparse.Namespace) -> LoadedSystem:
    """The system a command runs on, from its arguments (``--robot``, ``--model``, ``--scenario``, ``--bounds``).

    Only the kind is decided here (a robot file naming a URDF is read to tell); the files
    are read when the command first asks for them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments (not modified).

    Returns
    -------
    LoadedSystem

    Raises
    ------
    CommandLineError
        For a URDF robot on a command that does not take arms, or with ``--model``,
        ``--bounds`` or ``--scenario``.
    """
    kind = _kind(args)
    return open_system(
        kind,
        command=args.command,
        robot=option(args, "robot"),
        model_file=option(args, "model"),
        scenario=option(args, "scenario"),
        scenario_kind=option(args, "scenario_kind", "run"),
        bounds_option=option(args, "bounds"),
    )


def physical_plant_of(args: argparse.Namespace) -> UncertainPlant | None:
    """The plant with physical parameters of `args` (None for an interval or polytope file).

    Module-level, so that ``partial(physical_plant_of, args)`` goes to a worker process.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    UncertainPlant or None
    """
    return load_system(args).physical


def plant_source(args: argparse.Namespace, system: LoadedSystem) -> Callable[[], Any] | None:
    """A picklable callable that rebuilds `system`'s physical plant (None without one).

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem
        Loaded from `args`.

    Returns
    -------
    callable or None
    """
    return None if system.physical is None else partial(physical_plant_of, argparse.Namespace(**vars(args)))
