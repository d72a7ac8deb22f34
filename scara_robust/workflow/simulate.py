"""One closed-loop run of any system under any controller: :func:`simulate_system`.

The three simulators stay what they are (:func:`~scara_robust.simulate` runs the SCARA's
engines, :func:`~scara_robust.simulate_arm` an arm from its URDF,
:func:`~scara_robust.simulate_plant` a plant with varying parameters); this is the one
entry point above them. It takes a system (a :class:`LoadedSystem` of any kind, an
:class:`~scara_robust.ArmSetup` or an :class:`~scara_robust.UncertainPlant`) and a
controller (a :class:`~scara_robust.Design`, a gain matrix, a held
:class:`~scara_robust.SampledStateFeedback`, a :class:`~scara_robust.ScheduledGain`, and on
the SCARA a :class:`~scara_robust.DiscretePID`, a named controller or a python-control
system), and returns a :class:`~scara_robust.Run`: the same field names whatever ran.
"""

from __future__ import annotations

from typing import Any

import control as ct

from ..controller.kinds import controller_kind, held_gain, schedule_of
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..lyapunov.gain import design_or_none
from ..model.arm import ArmSetup
from ..model.plant import UncertainPlant, as_plant
from ..model.robot import paper_payload
from ..simulation.arm import simulate_arm
from ..simulation.controllers import pid_controller, sampled_pid_controller, scheduled_pid_controller
from ..simulation.plants import simulate_plant
from ..simulation.result import Run
from ..simulation.run import simulate
from .system import ArmSystem, LoadedSystem, PlantFileSystem, ScaraSystem

__all__ = ["simulate_system"]

#: What each kind of system runs, for the messages.
_GAINS = "a Design, a gain matrix, a SampledStateFeedback (held) or a ScheduledGain"


def simulate_system(system: LoadedSystem | ArmSetup | UncertainPlant, controller: Any, **options: Any) -> Run:
    """Simulate `controller` on `system` in closed loop: one run, whatever the kinds.

    Parameters
    ----------
    system : LoadedSystem, ArmSetup or UncertainPlant
        The SCARA, an arm or a plant file as :func:`open_system` loads them (each with the
        reference, payload, disturbance and initial error its files give), an arm's
        :class:`~scara_robust.ArmSetup` (:func:`~scara_robust.load_arm`) or an
        :class:`~scara_robust.UncertainPlant` (a plant file's, or one of
        :meth:`~scara_robust.UncertainPlant.from_nonlinear`, whose own dynamics then run).
    controller : Design, array_like, SampledStateFeedback, ScheduledGain, DiscretePID, str or control.NonlinearIOSystem
        The gain on the system's design form: a :class:`~scara_robust.Design` (its ``K``),
        the matrix itself, the same gain sampled and held
        (:class:`~scara_robust.SampledStateFeedback`, run at its ``Ts``) or a gain scheduled
        on a parameter. On the SCARA also a :class:`~scara_robust.DiscretePID`
        (:meth:`~scara_robust.Design.discretize`), a name of
        :data:`~scara_robust.CONTROLLERS` or a controller system.
    **options
        The kind's simulator's keyword arguments: :func:`~scara_robust.simulate` on the
        SCARA (with ``torque_limit`` and, for a schedule, ``measurement_bias``),
        :func:`~scara_robust.simulate_arm` on an arm, :func:`~scara_robust.simulate_plant`
        on a plant. A loaded SCARA gives its robot file's parameters, payload, reference,
        disturbance and initial error unless `options` give them.

    Returns
    -------
    Run
        A :class:`~scara_robust.SimulationResult`, :class:`~scara_robust.ArmRun` or
        :class:`~scara_robust.PlantRun`; each has ``t``, ``e``, ``u``, ``status``,
        ``reason``, ``max_abs_error``, ``peak_input`` and ``to_pandas()``.

    Raises
    ------
    ArgumentTypeError
        Naming ``system`` or ``controller`` when the kind cannot run it, and what it takes.

    Examples
    --------
    >>> import scara_robust as sr
    >>> plant = sr.load_plant("examples/plant-dc-motor.toml")  # doctest: +SKIP
    >>> run = sr.simulate_system(plant, sr.design(plant, 1, 10), t_final=20)  # doctest: +SKIP
    >>> run.status, run.e.shape, f"{run.max_abs_error:.2g} rad"  # doctest: +SKIP
    ('tracking', (1, 2001), '0.00034 rad')
    """
    if isinstance(system, ScaraSystem):
        return _simulate_scara(system, controller, options)
    if isinstance(system, ArmSystem):
        return _simulate_arm(system.arm(), controller, options)
    if isinstance(system, PlantFileSystem):
        physical = system.require_physical("simulate_system needs a plant file with [parameters]")
        return simulate_plant(physical, _plant_gain(controller), **options)
    if isinstance(system, ArmSetup):
        return _simulate_arm(system, controller, options)
    plant = as_plant("system", system)
    if plant is not None:
        return simulate_plant(plant, _plant_gain(controller), **options)
    raise ArgumentTypeError("system", "must be a LoadedSystem (open_system), an ArmSetup or an UncertainPlant, "
                                      f"found {type(system).__name__}")


def _matrix(controller: Any, where: str) -> Any:
    """The gain of a Design, a matrix or a schedule; a TypeError naming `controller` for anything else."""
    design = design_or_none(controller)
    if design is not None:
        return design.K
    if controller_kind(controller) is not None or isinstance(controller, (str, ct.InputOutputSystem)):
        raise ArgumentTypeError("controller", f"must be {_GAINS} (what {where} runs), found "
                                              f"{type(controller).__name__}")
    return controller


def _simulate_arm(setup: ArmSetup, controller: Any, options: dict[str, Any]) -> Run:
    """simulate_arm, a held gain run at its Ts."""
    K, Ts = held_gain(controller)
    if Ts is not None:
        if options.get("Ts") not in (None, Ts):
            raise ArgumentValueError("Ts", f"must be the held gain's Ts = {Ts:g} s or none, found {options['Ts']!r}")
        options = {**options, "Ts": Ts}
    return simulate_arm(setup, _matrix(K, "an arm"), **options)


def _plant_gain(controller: Any) -> Any:
    """simulate_plant's gain: a held gain as it is, else the matrix or schedule."""
    K, Ts = held_gain(controller)
    return controller if Ts is not None else _matrix(K, "a plant")


def _simulate_scara(system: ScaraSystem, controller: Any, options: dict[str, Any]) -> Run:
    """The SCARA's engines, with the robot file's signals unless `options` give them."""
    setup = system.setup
    options = dict(options)
    options.setdefault("params", setup.params)
    options.setdefault("reference", setup.reference)
    options.setdefault("disturbance", setup.disturbance)
    options.setdefault("payload", setup.payload or paper_payload(options["params"]))
    scenario = options.pop("scenario", setup.initial or "large")
    limit = options.pop("torque_limit", None)
    bias = options.pop("measurement_bias", 0.0)
    schedule = schedule_of(controller)
    design = design_or_none(controller)
    if schedule is not None:
        law: Any = scheduled_pid_controller(schedule, options["payload"], options["reference"],
                                            measurement_bias=bias, torque_limit=limit)
    elif controller_kind(controller) == "pid":
        law = sampled_pid_controller(controller, options["reference"])
    elif isinstance(controller, (str, ct.InputOutputSystem)):
        law = controller
    elif controller_kind(controller) is None:
        law = pid_controller(design.K if design is not None else controller, options["reference"],
                             torque_limit=limit)
    else:
        raise ArgumentTypeError("controller", f"must be {_GAINS}, a DiscretePID, a controller's name or a "
                                              "control.NonlinearIOSystem (what the SCARA runs), found "
                                              f"{type(controller).__name__}")
    return simulate(law, scenario, **options)

