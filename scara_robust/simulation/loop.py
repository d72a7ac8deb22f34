"""The closed loop of robot, controller and disturbance: its equations and its python-control form.

:class:`ClosedLoop` holds everything one run integrates: the plant (with its payload),
the controller, the reference it tracks, the disturbance, and the controller's sample
time if it runs sampled. Engines (:mod:`scara_robust.simulation.engines`) integrate it;
:func:`closed_loop` is the same loop as a ``control.interconnect`` system.

Times in s, angles in rad, torques in N·m, masses in kg.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import control as ct
import numpy as np
from numpy.typing import NDArray

from .._deprecation import renamed_field
from ..model.robot import PayloadProfile, ScaraParams, forward_dynamics_scalar, paper_payload, scara_plant
from ..model.signals import Reference, SquareWave, paper_disturbance

__all__: list[str] = []

Array = NDArray[np.float64]

#: Plant states (rad, rad/s) beyond which a run counts as diverged and is frozen.
STATE_LIMIT = 1e3
#: Default tracking error (rad) beyond which a run counts as diverged and stops.
DIVERGENCE_LIMIT = 50.0
#: Outputs of the closed loop, in order: plant state, control torque, disturbance torque.
OUTPUT_LABELS = ("q1", "q2", "q1_dot", "q2_dot", "Tc1", "Tc2", "Td1", "Td2")


def _disturbance_source(wave: SquareWave) -> ct.NonlinearIOSystem:
    def outfcn(t: float, x: Array, u: Array, params: Any) -> Array:
        # The level is held per integration segment so an RK stage at a segment's end
        # never sees the next segment's value.
        return np.asarray(wave(params.get("segment_midpoint", t)), dtype=float)

    return ct.NonlinearIOSystem(None, outfcn, inputs=0, outputs=["Td1", "Td2"], name="disturbance")


def closed_loop(
    controller: ct.NonlinearIOSystem,
    params: ScaraParams | None = None,
    payload: PayloadProfile | None = None,
    disturbance: SquareWave | None = None,
) -> ct.InterconnectedSystem:
    """Plant, controller and disturbance joined with ``control.interconnect``.

    Parameters
    ----------
    controller : control.NonlinearIOSystem
        Inputs ``q1, q2, q1_dot, q2_dot``, outputs ``Tc1, Tc2``.
    params : ScaraParams, optional
    payload : callable, optional
        ``m_p(t)`` in kg (default: the paper's).
    disturbance : SquareWave, optional

    Returns
    -------
    control.InterconnectedSystem
        No inputs; outputs :data:`OUTPUT_LABELS`; states the plant's four followed by the
        controller's. The parameter ``segment_midpoint`` (s) holds the disturbance at its
        value there.
    """
    params = params or ScaraParams()
    plant = scara_plant(params, payload if payload is not None else paper_payload(params), state_limit=STATE_LIMIT)
    source = _disturbance_source(disturbance or paper_disturbance())
    labels = list(OUTPUT_LABELS)
    return ct.interconnect([plant, controller, source], inplist=[], outlist=labels, outputs=labels, name="closed_loop")


@dataclass(frozen=True)
class ClosedLoop:
    """One closed loop to integrate: state ``x = [q1, q2, q̇1, q̇2, controller states]``.

    Attributes
    ----------
    controller : control.NonlinearIOSystem
        Inputs ``q1, q2, q1_dot, q2_dot``, outputs ``Tc1, Tc2`` (N·m).
    params : ScaraParams
    payload : callable
        ``m_p(t)``, kg.
    reference : Reference
        The reference the controller tracks (for the error and the divergence test).
    disturbance : SquareWave
    Ts : float or None
        Period (s) of a sampled controller, held between samples; None if continuous.
    """

    controller: ct.NonlinearIOSystem
    params: ScaraParams
    payload: PayloadProfile
    reference: Reference
    disturbance: SquareWave
    Ts: float | None = None

    sample_time = renamed_field("sample_time", "Ts")

    @property
    def discrete(self) -> bool:
        """True when the controller is a discrete-time system: its states jump once per sample."""
        return bool(self.controller.isdtime(strict=True))

    #: The plant's states (q1, q2 and their rates), before the controller's.
    n_plant = 4

    @property
    def n_states(self) -> int:
        """Plant (4) plus controller states."""
        return 4 + int(self.controller.nstates)

    @property
    def state_labels(self) -> list[str]:
        """Names of the state, e.g. ``scara_q1, ..., pid_int_e1``."""
        plant = [f"scara_{n}" for n in ("q1", "q2", "q1_dot", "q2_dot")]
        return plant + [f"{self.controller.name}_{n}" for n in self.controller.state_labels]

    @cached_property
    def system(self) -> ct.InterconnectedSystem:
        """The loop as a python-control system (:func:`closed_loop`), built once."""
        return closed_loop(self.controller, self.params, self.payload, self.disturbance)

    @cached_property
    def torque(self) -> Callable[[float, Array], Array]:
        """``torque(t, x) -> T_c``, shape (2,), N·m: the controller's output at state `x`."""
        out = self.controller.outfcn
        cparams = dict(self.controller.params)

        def torque(t: float, x: Array) -> Array:
            return np.asarray(out(t, x[4:], x[:4], cparams), dtype=float)

        return torque

    @cached_property
    def rhs(self) -> Callable[[float, Array, Array, Array], Array]:
        """``rhs(t, x, tc, td) -> ẋ`` with the control torque `tc` and disturbance `td` given (N·m).

        A state whose plant part left :data:`STATE_LIMIT` is frozen (ẋ = 0), as
        :func:`~scara_robust.scara_plant` does, so an integrator never crawls on a
        diverging run. A discrete-time controller's states have zero derivative here:
        they change only at the samples (:meth:`jump`).
        """
        params, payload = self.params, self.payload
        upd = self.controller.updfcn
        cparams = dict(self.controller.params)
        n_c = 0 if self.discrete else int(self.controller.nstates)

        def rhs(t: float, x: Array, tc: Array, td: Array) -> Array:
            if not np.abs(x[:4]).max() <= STATE_LIMIT:
                return np.zeros_like(x)
            dx = np.empty_like(x)
            dx[:2] = x[2:4]
            dx[2:4] = forward_dynamics_scalar(params, x, tc[0] + td[0], tc[1] + td[1], float(payload(t)))
            if n_c:
                dx[4:] = upd(t, x[4:], x[:4], cparams)
            else:
                dx[4:] = 0.0
            return dx

        return rhs

    def jump(self, t: float, x: Array) -> Array:
        """A discrete-time controller's next state, from the loop state `x` sampled at `t`.

        Parameters
        ----------
        t : float
            Sample time instant, s.
        x : ndarray, shape (n_states,)

        Returns
        -------
        ndarray, shape (n_states - 4,)
        """
        return np.asarray(self.controller.updfcn(t, x[4:], x[:4], dict(self.controller.params)), dtype=float)

    def outputs(self, t: Array, X: Array) -> Array:
        """Outputs :data:`OUTPUT_LABELS` at times `t` (k,) for states `X` (n_states, k); shape (8, k)."""
        torque = self.torque
        tc = np.array([torque(ti, X[:, i]) for i, ti in enumerate(t)]).reshape(len(t), 2).T
        return np.vstack([X[:4], tc, np.asarray(self.disturbance(t), dtype=float).reshape(2, len(t))])

    def divergence(self, t: float, x: Array, limit: float) -> str | None:
        """Why the run at state `x`, time `t` counts as diverged, or None if it does not."""
        beyond = not np.all(np.isfinite(x[:4])) or np.abs(x[:4]).max() > STATE_LIMIT
        if beyond or np.abs(np.asarray(self.reference.position(t), dtype=float) - x[:2]).max() > limit:
            return f"diverged by t = {t:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
        return None
