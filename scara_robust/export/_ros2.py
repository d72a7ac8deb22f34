"""The ros2_control target (``'ros2'``): a ``pid_controller`` parameter file, one PID per joint.

Private: the names of ``__all__`` are re-exported by :mod:`scara_robust.export`.

ros2_controllers' ``pid_controller`` runs control_toolbox's PID on each joint named in
``dof_names``, every update period dt = 1/``update_rate``: ``u = p e + I + d ė`` clamped to
``u_clamp``, then ``I += dt (i e + (u − v)/tracking_time_constant)`` (forward Euler, the
integral term of the previous update in the command; the back-calculation term with
``antiwindup_strategy: back_calculation``), with ė the difference of the reference's and the
state's velocity interfaces. That is :class:`~scara_robust.DiscretePID` with
``integrator='forward'`` and ``derivative='measured'`` and a diagonal gain, which is what this
target writes: the ``controller_manager``'s ``update_rate`` (1/Ts, Hz) and the controller's
``ros__parameters`` (keys and types of ``pid_controller``'s parameter definition, version
6.9.0). A coupled gain (a torque reading another joint's error) has no such file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..controller.discrete import DiscretePID
from ..controller.kinds import check_controller
from ..exceptions import ArgumentValueError
from ..io import ros2_dof_name
from ..model.plant import Signal
from ._common import signal_names
from .registry import ExportTarget, register_target

__all__ = ["pid_controller_parameters", "coupling_of", "update_rate_of", "ROS2_ERROR_DEADBAND"]

#: pid_controller's default ``error_deadband`` (rad; ``pid_controller.yaml`` of ros2_controllers 6.9.0): within
#: it control_toolbox leaves the integral term (``pid.cpp`` 6.3.0). ``export --format ros2`` runs and certifies
#: its PID with it, and a PID without a deadband is written with it.
ROS2_ERROR_DEADBAND = 1e-16


def update_rate_of(Ts: float) -> int:
    """pid_controller's ``update_rate`` for a sample time: 1/Ts, which must be a whole number of Hz.

    Parameters
    ----------
    Ts : float
        Sample time, s.

    Returns
    -------
    int
        Hz.

    Raises
    ------
    ArgumentValueError
        Naming ``Ts`` when 1/Ts is not a whole number of Hz (>= 1).
    """
    rate = 1.0 / Ts if Ts > 0 else 0.0
    if rate < 1 or abs(rate - round(rate)) > 1e-9 * rate:
        raise ArgumentValueError("Ts", f"must be 1/update_rate, a whole number of Hz; found Ts = {Ts:g} s "
                                       f"({rate:.6g} Hz)")
    return int(round(rate))


def coupling_of(pid: DiscretePID) -> str | None:
    """Where `pid` is coupled (a torque reads another joint's error), or None for one PID per joint.

    Parameters
    ----------
    pid : DiscretePID

    Returns
    -------
    str or None
        E.g. ``'K_P[0, 1] = 1.157'``: the largest off-diagonal entry, or None when every
        off-diagonal entry of K_I, K_P and K_D is zero and there is one torque per joint.
    """
    check_controller("pid", pid, ("pid",), "a DiscretePID")
    if pid.n_torques != pid.n_joints:
        return f"{pid.n_torques} torques for {pid.n_joints} joints"
    worst: tuple[float, str] = (0.0, "")
    for name, M in (("K_I", pid.K_I), ("K_P", pid.K_P), ("K_D", pid.K_D)):
        off = np.abs(M - np.diag(np.diag(M)))
        i, j = np.unravel_index(int(np.argmax(off)), off.shape)
        if off[i, j] > worst[0]:
            worst = (float(off[i, j]), f"{name}[{i}, {j}] = {M[i, j]:.4g}")
    return worst[1] or None


def pid_controller_parameters(pid: DiscretePID, controller: str = "scara_pid",
                              outputs: Sequence[Signal] | None = None) -> dict[str, Any]:
    """The ros2_control parameters of `pid` run by ``pid_controller``: a mapping ready for YAML.

    Parameters
    ----------
    pid : DiscretePID
        One PID per joint (diagonal K_I, K_P, K_D), ``integrator='forward'`` and
        ``derivative='measured'`` (what control_toolbox computes); Ts = 1/update_rate
        with an integer update rate in Hz.
    controller : str
        The controller's name in the file.
    outputs : sequence of Signal, optional
        The joints, in the order of the PID's rows (an arm's ``q_<joint>`` is written as
        ``<joint>``); default ``q1, q2, ...``.

    Returns
    -------
    dict
        ``{'controller_manager': {'ros__parameters': {'update_rate': Hz, controller:
        {'type': 'pid_controller/PidController'}}}, controller: {'ros__parameters':
        {...}}}``, gains in N·m/rad, N·m/(rad·s), N·m·s/rad, clamps in N·m, the tracking
        time constant in s.

    Raises
    ------
    ArgumentValueError
        For a coupled gain (naming its largest off-diagonal entry and the way to a
        decentralized one), another integrator or derivative, or a Ts whose rate is not
        a whole number of Hz (:func:`update_rate_of`).
    """
    check_controller("pid", pid, ("pid",), "a DiscretePID (Design.discretize)")
    coupled = coupling_of(pid)
    if coupled is not None:
        raise ArgumentValueError("pid", f"is coupled ({coupled}): pid_controller runs one PID per joint, on that "
                                        "joint's error alone; synthesize(..., structure='decentralized') gives one")
    if pid.integrator != "forward" or pid.derivative != "measured":
        raise ArgumentValueError("pid", f"must integrate by forward Euler with the measured error rate, as "
                                        f"control_toolbox does (discretize(Ts, integrator='forward')), found "
                                        f"integrator {pid.integrator!r}, derivative {pid.derivative!r}")
    rate = update_rate_of(pid.Ts)
    joints, _ = signal_names(pid, outputs, None)
    limit = None if pid.torque_limit is None else [float(v) for v in pid.torque_limit]
    windup = limit is not None and pid.anti_windup
    tracking = [float(v) for v in np.atleast_1d(np.asarray(pid.tracking_time, dtype=float))] if windup else None
    gains = {}
    for j, joint in enumerate(joints):
        entry: dict[str, Any] = {"p": float(pid.K_P[j, j]), "i": float(pid.K_I[j, j]), "d": float(pid.K_D[j, j]),
                                 "u_clamp_max": math.inf if limit is None else limit[j],
                                 "u_clamp_min": -math.inf if limit is None else -limit[j],
                                 "i_clamp_max": math.inf, "i_clamp_min": -math.inf,
                                 "antiwindup_strategy": "back_calculation" if windup else "none",
                                 "tracking_time_constant": tracking[j] if tracking is not None else 0.0,
                                 "feedforward_gain": 0.0,
                                 "error_deadband": ROS2_ERROR_DEADBAND if pid.error_deadband is None
                                 else float(pid.error_deadband)}
        gains[ros2_dof_name(joint.name)] = entry
    return {
        "controller_manager": {"ros__parameters": {"update_rate": rate,
                                                   controller: {"type": "pid_controller/PidController"}}},
        controller: {"ros__parameters": {"dof_names": list(gains), "command_interface": "effort",
                                         "reference_and_state_interfaces": ["position", "velocity"],
                                         "gains": gains}},
    }


def _ros2_file(controller: Any, *, prefix: str, notes: Sequence[str], metadata: Mapping[str, Any] | None,
               outputs: Sequence[Signal] | None, inputs: Sequence[Signal] | None, precision: str) -> str:
    """``write`` of the ros2 target: ``<prefix>.yaml`` (`metadata` and `precision` are not used)."""
    import yaml

    check_controller("controller", controller, ("pid",),
                   "a DiscretePID: pid_controller runs a PID per joint, not state feedback or a schedule")
    parameters = pid_controller_parameters(controller, prefix, outputs)
    errors, torques = signal_names(controller, outputs, inputs)
    e, u = errors[0].unit, torques[0].unit
    head = [f"{prefix}.yaml: ros2_control parameters of pid_controller (ros2_controllers), one PID per joint,",
            f"updated every dt = {controller.Ts:g} s (update_rate), forward Euler as control_toolbox integrates.",
            f"Units: p in {u}/{e}, i in {u}/({e}·s), d in {u}·s/{e}, u_clamp and i_clamp in {u}, "
            "tracking_time_constant in s.",
            *notes]
    comment = "".join(f"# {line}\n" for line in head)
    return comment + str(yaml.safe_dump(parameters, sort_keys=False, default_flow_style=False, allow_unicode=True))


register_target(ExportTarget(
    "ros2", ".yaml", "<prefix>.yaml: ros2_control parameters of pid_controller (a per-joint PID, forward Euler)",
    _ros2_file,
))
