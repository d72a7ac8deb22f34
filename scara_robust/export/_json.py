"""The JSON target (``'json'``): ``<prefix>.json``, every gain, limit and matrix of the controller.

Private: the names of ``__all__`` are re-exported by :mod:`scara_robust.export`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._validation import check_choice
from ..controller.discrete import DiscretePID
from ..controller.kinds import check_controller
from ..controller.scheduled import SampledScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..model.plant import Signal
from ._common import PRECISIONS, per_second, signal_names, unit_of
from .registry import ExportTarget, register_target

__all__ = ["controller_record"]


def controller_record(pid: DiscretePID, *, outputs: Sequence[Signal] | None = None,
                      inputs: Sequence[Signal] | None = None, **metadata: Any) -> dict[str, Any]:
    """Every gain, limit and matrix of the controller, as JSON-ready data.

    Parameters
    ----------
    pid : DiscretePID
    outputs : sequence of Signal, optional
        The controlled outputs, one per error (default the SCARA's joint angles, rad).
    inputs : sequence of Signal, optional
        The plant inputs the controller drives (default the SCARA's torques, N·m).
    **metadata
        Extra keys to record (e.g. ``rho``, ``eta``, the model's name).

    Returns
    -------
    dict
        ``Ts`` (s), ``integrator``, ``derivative``, ``N`` (1/s), ``K_I``, ``K_P``, ``K_D``
        (m × p lists), ``torque_limit`` (the inputs' units, or None), ``tracking_time`` (s),
        ``anti_windup``, and the linear part ``A, B, C, D`` with the state and input
        names, plus ``signals`` (names and units), ``units`` and the `metadata`.
    """
    check_controller("pid", pid, ("pid",), "a DiscretePID (Design.discretize)")
    outs, ins = signal_names(pid, outputs, inputs)
    e_unit, u_unit = unit_of([s.unit for s in outs]), unit_of([s.unit for s in ins])
    eu = e_unit if isinstance(e_unit, str) else "/".join(e_unit)
    uu = u_unit if isinstance(u_unit, str) else "/".join(u_unit)
    A, B, C, D = pid.matrices()
    ss = pid.to_statespace()
    record: dict[str, Any] = {
        "kind": "scara_robust discrete PID",
        "law": "v = C z + D [e, edot]; u = clip(v, -torque_limit, torque_limit); "
        "z+ = A z + B [e, edot] + (Ts / tracking_time) (u - v) on the first n_torques states",
        "Ts": pid.Ts,
        "n_joints": pid.n_joints,
        "n_torques": pid.n_torques,
        "integrator": pid.integrator,
        "derivative": pid.derivative,
        "N": pid.N,
        "K_I": pid.K_I.tolist(),
        "K_P": pid.K_P.tolist(),
        "K_D": pid.K_D.tolist(),
        "torque_limit": None if pid.torque_limit is None else np.asarray(pid.torque_limit).tolist(),
        # without a limit u = v, so there is no windup to correct: neither anti-windup nor its time constant
        "tracking_time": np.asarray(pid.tracking_time).tolist() if pid.back_calculation else None,
        "anti_windup": pid.back_calculation,
        "error_deadband": pid.error_deadband,
        "back_calculation_gains": pid.back_calculation_gains.tolist() if pid.back_calculation else None,
        "A": A.tolist(),
        "B": B.tolist(),
        "C": C.tolist(),
        "D": D.tolist(),
        "states": list(ss.state_labels),
        "inputs": list(ss.input_labels),
        "outputs": list(ss.output_labels),
        "feedforward": None if pid.feedforward is None else {
            **pid.feedforward.record(), "law": "v = tau_ff(r, rd, rdd) + C z + D [e, edot]: the limit on the total "
            "torque; tau_ff by RNEA on the arm's bodies (tables: tree, body, parents, joint_body, gravity)",
            "tree": pid.feedforward.tree.tolist(), "body": pid.feedforward.body.tolist(),
            "parents": list(pid.feedforward.parents), "joint_body": list(pid.feedforward.joint_body),
            "gravity": pid.feedforward.gravity.tolist()},
        "signals": {"outputs": [{"name": s.name, "unit": s.unit} for s in outs],
                    "inputs": [{"name": s.name, "unit": s.unit} for s in ins]},
        "units": {"e": e_unit, "edot": unit_of([per_second(s.unit) for s in outs]), "u": u_unit, "Ts": "s",
                  "tracking_time": "s", "N": "1/s", "K_I": f"{uu}/({eu}·s)", "K_P": f"{uu}/{eu}",
                  "K_D": f"{uu}·s/{eu}", "z": u_unit},
    }
    record.update(metadata)
    return record


def _json_file(
    controller: DiscretePID | SampledStateFeedback | SampledScheduledGain,
    *,
    prefix: str,
    notes: Sequence[str],
    metadata: Mapping[str, Any] | None,
    outputs: Sequence[Signal] | None,
    inputs: Sequence[Signal] | None,
    precision: str,
) -> str:
    """``write`` of the JSON target: the text of ``<prefix>.json`` (the record, indented by 2)."""
    check_choice("precision", precision, PRECISIONS)
    given: Any = controller  # its kind says which record it has
    if given.kind == "scheduled":
        g = given.gain
        record = {"controller": "scheduled gain", "law": "u = -K(p_hat) x, K linear between the breakpoints, the "
                  "edge gain outside them; zero-order hold", "Ts": given.Ts, "parameter": g.parameter,
                  "unit": g.unit, "breakpoints": g.breakpoints.tolist(), "gains": g.gains.tolist(),
                  "certified": g.to_dict()["certified"], "precision": precision, **(metadata or {}),
                  **({"notes": list(notes)} if notes else {})}
    elif given.kind == "state feedback":
        record = {"controller": "static state feedback", "law": "u = -K x, zero-order hold", "Ts": given.Ts,
                  "K": given.K.tolist(), "precision": precision, **(metadata or {}),
                  **({"notes": list(notes)} if notes else {})}
    else:
        record = controller_record(given, outputs=outputs, inputs=inputs, **(metadata or {}),
                                   **({"notes": list(notes)} if notes else {}))
    return json.dumps(record, indent=2) + "\n"


register_target(ExportTarget(
    "json", ".json", "<prefix>.json: every gain, limit and matrix of the controller (controller_record), with the "
    "metadata and notes", _json_file,
))
