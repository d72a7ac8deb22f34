"""The designed PID as a deployable discrete-time controller: sampled, saturated, anti-windup.

:meth:`Design.discretize <scara_robust.Design.discretize>` returns a :class:`DiscretePID`
running the law ``u = K_I ∫e + K_P e + K_D ė`` of the design (the same law as ``u = −Kx``)
at the sample time ``Ts`` (s). With the state ``z = [w, x_f]``, ``w`` the integral term
in torque units (N·m, shape (m,)) and ``x_f`` the derivative filter's state (N·m, shape
(m,), present only with ``derivative='filtered'``), each sample ``k`` computes::

    v_k     = w_k + K_P' e_k + D_k                     unsaturated torque, N·m
    u_k     = clip(v_k, −u_max, u_max)                 applied torque, per joint
    w_{k+1} = w_k + Ts K_I e_k + (Ts / T_t) (u_k − v_k)    back-calculation anti-windup

with ``K_P' = K_P + c K_I``, ``c = 0`` (integrator ``'forward'``: forward Euler),
``Ts/2`` (``'tustin'``: trapezoidal) or ``Ts`` (``'backward'``). The derivative term is
``D_k = K_D ė_k`` with the measured ``ė`` (``derivative='measured'``, the paper's law,
q̇ measured) or, without q̇, the filter ``K_D s / (1 + s/N)`` discretized by backward
differences (stable for every ``N Ts``, Åström & Hägglund, *Advanced PID Control*, 2006,
§13.3)::

    D_k = a D_{k−1} + b (e_k − e_{k−1}),   a = 1/(1 + N Ts),   b = K_D N a,

realized as ``D_k = x_f,k + b e_k``, ``x_f,k+1 = a x_f,k − b (1 − a) e_k``.

Back-calculation (Åström & Hägglund 2006, §6.5) drives ``w`` so that the unsaturated
torque tracks the applied one with time constant ``T_t`` while the limit is active.
The default ``T_t`` per joint is ``sqrt(T_i T_d)`` with ``T_i = K_P/K_I`` and
``T_d = K_D/K_P`` (their rule of thumb: between ``T_d`` and ``T_i``), i.e.
``sqrt(‖K_D[j]‖/‖K_I[j]‖)`` for the coupled gain rows, at least ``Ts``, since in discrete
time the tracking loop ``w_{k+1} − w_k = (Ts/T_t)(u_k − v_k)`` overshoots for ``T_t < Ts``
(and diverges for ``T_t < Ts/2``); a shorter ``T_t`` given is taken, as control_toolbox takes
it. A torque without integral action (its row of ``K_I`` zero) has no back-calculation, and
with ``error_deadband`` a joint's ``w`` is not updated while ``|e_j| <= error_deadband``
(control_toolbox 6.3.0's ``pid.cpp``, which ros2_controllers' ``pid_controller`` runs). The
sampled-data certificates hold for the linear loop, where no limit acts; the deadband freezes
``w`` only where ``|e|`` is at most the deadband (1e-16 rad in ``pid_controller``).

Units: e in rad, ė in rad/s, torques in N·m, times in s, ``N`` in 1/s.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_instance, check_per_item, check_real
from ..exceptions import ArgumentValueError
from ._hold import expm_stack

__all__ = ["DiscretePID", "INTEGRATOR_METHODS", "DERIVATIVE_MODES", "default_tracking_time", "single_precision_step"]

Array = NDArray[np.float64]

#: Discretizations of the integrator: forward Euler, trapezoidal (Tustin), backward Euler.
INTEGRATOR_METHODS = ("forward", "tustin", "backward")
#: Derivative term: measured ė (q̇ measured), or a filtered difference of e (no q̇).
DERIVATIVE_MODES = ("measured", "filtered")


def default_tracking_time(K_I: ArrayLike, K_D: ArrayLike, Ts: float) -> Array:
    """Default back-calculation time constant per torque, ``sqrt(‖K_D[j]‖ / ‖K_I[j]‖)``, s.

    For a diagonal PID this is Åström and Hägglund's ``T_t = sqrt(T_i T_d)``; rows without
    integral action get ``T_t = 1 s`` (the anti-windup has nothing to do there). Each value
    is at least `Ts`.

    Parameters
    ----------
    K_I, K_D : array_like, shape (m, p)
        Integral (N·m/(rad·s)) and derivative (N·m·s/rad) gains.
    Ts : float
        Sample time, s.

    Returns
    -------
    ndarray, shape (m,)
    """
    ki = np.linalg.norm(np.asarray(K_I, dtype=float), axis=1)
    kd = np.linalg.norm(np.asarray(K_D, dtype=float), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        tt = np.where(ki > 0, np.sqrt(kd / np.where(ki > 0, ki, 1.0)), 1.0)
    return np.asarray(np.maximum(np.where(tt > 0, tt, 1.0), Ts), dtype=float)


def _rows(M: Array) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in M)


@dataclass
class DiscretePID:
    """A sampled PID with torque limits, back-calculation anti-windup and bumpless start.

    Build it with :meth:`scara_robust.Design.discretize`; see the module docstring for
    the equations. ``m`` is the number of torques, ``p`` of joints (e has shape (p,)).

    Parameters
    ----------
    Ts : float
        Sample time, s (> 0).
    K_I, K_P, K_D : array_like, shape (m, p)
        The design's PID matrices (``u = K_I ∫e + K_P e + K_D ė``), N·m/(rad·s),
        N·m/rad, N·m·s/rad.
    integrator : {'tustin', 'forward', 'backward'}
        Discretization of ``∫e`` (default Tustin: second-order accurate, and the
        integrator's pole stays at z = 1 whatever Ts).
    derivative : {'measured', 'filtered'}
        ``K_D ė`` with ė measured (default), or the filtered difference of e.
    N : float
        Derivative filter bandwidth, 1/s (> 0), used with ``derivative='filtered'``.
    torque_limit : None, float or array_like of shape (m,)
        Per-torque limit ``|u_j| ≤ u_max,j``, N·m (> 0); None for none.
    tracking_time : None, float or array_like of shape (m,)
        Back-calculation time constant T_t, s (> 0); default :func:`default_tracking_time`
        (≥ Ts). A T_t below Ts is taken, as control_toolbox takes it: the back-calculation
        then overshoots (``Ts/T_t > 1``) while the limit acts.
    anti_windup : bool
        False leaves the integrator free to wind up against the limit (for comparison).
    feedforward : ArmFeedforward, optional
        An arm's model feedforward (:func:`scara_robust.arm_feedforward`): the torque is then
        ``u = clip(τ_ff(r, ṙ, r̈) + v)``, the limit on the total torque as the arm's
        simulation applies it, and the back-calculation drives ``v`` by ``u − τ_ff − v``;
        :meth:`control` takes the reference and the measured state. Default none.
    error_deadband : float, optional
        rad (≥ 0): where ``|e_j| <= error_deadband`` the integral term of torque j is not
        updated at all (back-calculation included), control_toolbox's rule
        (``pid.cpp`` 6.3.0: ``is_zero(error, error_deadband)`` skips the update); for a PID
        with one torque per joint. Default none: always updated.

    Notes
    -----
    A torque whose row of ``K_I`` is zero (a PD) has no integral action, and its integral
    term is never updated: no back-calculation either, as control_toolbox skips the
    update for ``i = 0``. (A back-calculation state on a PD only stores the clamp's
    history, a permanent offset once the limit releases.)

    Attributes
    ----------
    state : ndarray, shape (n_z,)
        ``z = [w, x_f]`` (N·m), ``n_z = m`` or ``2m``; set by :meth:`reset`.

    Examples
    --------
    >>> import scara_robust as sr
    >>> pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3, torque_limit=50)
    >>> pid.reset(e0=[0.1, 0.0])
    >>> print(pid.step([0.1, 0.0], [0.0, 0.0]).round(2))
    [29.37 -1.48]
    """

    Ts: float
    K_I: Array
    K_P: Array
    K_D: Array
    integrator: str = "tustin"
    derivative: str = "measured"
    N: float = 100.0
    torque_limit: Array | None = None
    tracking_time: Array | None = None
    anti_windup: bool = True
    error_deadband: float | None = None
    feedforward: Any = None
    state: Array = field(init=False, repr=False)
    _cache: tuple[Any, Any, Any, Any] = field(init=False, repr=False)
    _limit: tuple[float, ...] | None = field(init=False, repr=False)
    _gain: tuple[float, ...] | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.Ts = check_real("Ts", self.Ts, positive=True)
        self.K_I = check_array("K_I", self.K_I, ndim=2)
        m, p = self.K_I.shape
        self.K_P = check_array("K_P", self.K_P, shape=(m, p))
        self.K_D = check_array("K_D", self.K_D, shape=(m, p))
        check_choice("integrator", self.integrator, INTEGRATOR_METHODS)
        check_choice("derivative", self.derivative, DERIVATIVE_MODES)
        self.N = check_real("N", self.N, positive=True)
        if self.torque_limit is not None:
            limit = check_per_item("torque_limit", self.torque_limit, m)
            if np.any(limit <= 0):
                raise ArgumentValueError("torque_limit", f"must be > 0 N·m, found {limit.tolist()}")
            self.torque_limit = limit
        if self.tracking_time is None:
            self.tracking_time = default_tracking_time(self.K_I, self.K_D, self.Ts)
        else:
            tt = check_per_item("tracking_time", self.tracking_time, m)
            if not np.all(tt > 0):
                raise ArgumentValueError("tracking_time", f"must be > 0 s, found {tt.tolist()}")
            self.tracking_time = tt
        if self.error_deadband is not None:
            self.error_deadband = check_real("error_deadband", self.error_deadband, nonnegative=True)
            if m != p:
                raise ArgumentValueError("error_deadband", f"applies to a PID with one torque per joint, found {m} "
                                                           f"torques for {p} joints")
        if self.feedforward is not None and (getattr(self.feedforward, "n_joints", None) != p or m != p):
            raise ArgumentValueError("feedforward", f"must be a feedforward of the PID's {p} joints with one torque "
                                                    f"each, found {self.feedforward!r}")
        if not isinstance(self.anti_windup, (bool, np.bool_)):
            raise ArgumentValueError("anti_windup", f"must be True or False, found {self.anti_windup!r}")
        A, B, C, D = self.matrices()
        # Plain-float copies for the per-sample loops (fields are not meant to change after construction).
        self._cache = (_rows(A), _rows(B), _rows(C), _rows(D))
        self._limit = None if self.torque_limit is None else tuple(float(v) for v in self.torque_limit)
        self._gain = tuple(float(g) for g in self.back_calculation_gains) if self.back_calculation else None
        self.reset()

    # -- the linear part --------------------------------------------------------------

    @property
    def back_calculation(self) -> bool:
        """True when the anti-windup acts: asked for, and with a torque limit (without one, u = v)."""
        return bool(self.anti_windup and self.torque_limit is not None)

    @property
    def back_calculation_gains(self) -> Array:
        """``Ts / T_t`` per torque, 0 for a torque without integral action (its row of K_I zero), shape (m,)."""
        integral = np.abs(self.K_I).max(axis=1) > np.finfo(float).eps
        tt = np.asarray(self.tracking_time, dtype=float)
        return np.asarray(np.where(integral, self.Ts / tt, 0.0), dtype=float)

    @property
    def n_joints(self) -> int:
        """p, the length of e."""
        return int(self.K_I.shape[1])

    @property
    def n_torques(self) -> int:
        """m, the length of u."""
        return int(self.K_I.shape[0])

    @property
    def filter_coefficients(self) -> tuple[float, Array]:
        """``(a, b)`` of the derivative filter: ``a = 1/(1 + N Ts)``, ``b = K_D N a`` (m, p)."""
        a = 1.0 / (1.0 + self.N * self.Ts)
        return a, np.asarray(self.K_D * self.N * a, dtype=float)

    def matrices(self) -> tuple[Array, Array, Array, Array]:
        """The linear part ``z_{k+1} = A z_k + B y_k``, ``v_k = C z_k + D y_k``, ``y = [e, ė]``.

        Returns
        -------
        A : ndarray, shape (n_z, n_z)
        B : ndarray, shape (n_z, 2p)
        C : ndarray, shape (m, n_z)
        D : ndarray, shape (m, 2p)
            With ``derivative='filtered'`` the ė columns of B and D are zero.
        """
        m, p = self.K_I.shape
        c = {"forward": 0.0, "tustin": 0.5 * self.Ts, "backward": self.Ts}[self.integrator]
        kp = self.K_P + c * self.K_I
        zero = np.zeros((m, p))
        if self.derivative == "measured":
            return np.eye(m), np.hstack([self.Ts * self.K_I, zero]), np.eye(m), np.hstack([kp, self.K_D])
        a, b = self.filter_coefficients
        A = np.block([[np.eye(m), np.zeros((m, m))], [np.zeros((m, m)), a * np.eye(m)]])
        B = np.block([[self.Ts * self.K_I, zero], [-(1.0 - a) * b, zero]])
        C = np.hstack([np.eye(m), np.eye(m)])
        D = np.hstack([kp + b, zero])
        return A, B, C, D

    def to_statespace(self) -> ct.StateSpace:
        """The linear part (no limit) as a python-control discrete-time system, ``dt = Ts``.

        Returns
        -------
        control.StateSpace
            Inputs ``e[0..p-1], edot[0..p-1]`` (rad, rad/s), states ``w[..]`` (and
            ``xf[..]``), outputs ``u[0..m-1]`` (N·m).
        """
        m, p = self.K_I.shape
        A, B, C, D = self.matrices()
        states = [f"w[{j}]" for j in range(m)] + ([f"xf[{j}]" for j in range(m)] if A.shape[0] > m else [])
        return ct.ss(
            A, B, C, D, dt=self.Ts,
            inputs=[f"e[{i}]" for i in range(p)] + [f"edot[{i}]" for i in range(p)],
            outputs=[f"u[{j}]" for j in range(m)], states=states, name="pid_discrete",
        )

    # -- the controller protocol (what certificates, the board and the export ask) --------

    #: The controller's kind, as export targets and the board name it.
    kind: ClassVar[str] = "pid"

    def linear_at(self, Ts: float) -> DiscretePID:
        """The same linear law at sample time `Ts`: no torque limit, no anti-windup (what a certificate covers).

        Parameters
        ----------
        Ts : float
            Sample time, s (> 0).

        Returns
        -------
        DiscretePID
        """
        return DiscretePID(Ts, self.K_I, self.K_P, self.K_D, integrator=self.integrator,
                           derivative=self.derivative, N=self.N)

    def closed_loops(self, A: Array, B: Array) -> Array:
        """The sampled loops ``A_d,i`` with each plant ``(A_i, B_i)`` of the PID form held by a zero-order hold.

        Parameters
        ----------
        A : ndarray, shape (V, 3p, 3p)
        B : ndarray, shape (V, 3p, m)
            Continuous-time plants in the PID form ``x = [∫e, e, ė]`` (the ∫e columns of
            the e and ė rows zero, as in Eq. 4).

        Returns
        -------
        ndarray, shape (V, 2p + n_z, 2p + n_z)
            On the state ``[e, ė, z]``.

        Raises
        ------
        ArgumentValueError
            Naming ``model``, for plants of another shape or form.
        """
        p, m = self.n_joints, self.n_torques
        if A.shape[1:] != (3 * p, 3 * p) or B.shape[1:] != (3 * p, m) or A.shape[0] != B.shape[0]:
            raise ArgumentValueError(
                "model", f"must hold plants of shapes ({3 * p}, {3 * p}) and ({3 * p}, {m}) for this PID, "
                f"found {A.shape[1:]} and {B.shape[1:]}"
            )
        scale = max(float(np.abs(A).max()), 1.0)
        if np.abs(A[:, p:, :p]).max(initial=0.0) > 1e-12 * scale:
            raise ArgumentValueError("model", "must not feed ∫e into the e, ė rows (the PID form of Eq. 4)")
        F, G = A[:, p:, p:], B[:, p:, :]
        n_p, V = 2 * p, A.shape[0]
        aug = np.zeros((V, n_p + m, n_p + m))
        aug[:, :n_p, :n_p] = F * self.Ts
        aug[:, :n_p, n_p:] = G * self.Ts
        E = expm_stack(aug)
        Phi, Gam = E[:, :n_p, :n_p], E[:, :n_p, n_p:]
        Ac, Bc, Cc, Dc = self.matrices()
        n_z = Ac.shape[0]
        out = np.zeros((V, n_p + n_z, n_p + n_z))
        out[:, :n_p, :n_p] = Phi + Gam @ Dc
        out[:, :n_p, n_p:] = Gam @ Cc
        out[:, n_p:, :n_p] = Bc
        out[:, n_p:, n_p:] = Ac
        return out

    def sampled_coordinates(self, P: ArrayLike, n: int) -> Array | None:
        """A P of the PID form ``x = [∫e, e, ė]`` in the sampled loop's state ``ξ = [e, ė, w]``, ``w = K_I ∫e``.

        ``ξ = T x`` gives ``P_ξ = T⁻ᵀ P T⁻¹``.

        Parameters
        ----------
        P : array_like, shape (3p, 3p)
        n : int
            The sampled loop's number of states.

        Returns
        -------
        ndarray, shape (n, n), or None
            None where the map does not exist (a filtered derivative, or K_I not square
            and invertible).
        """
        P = np.asarray(P, dtype=float)
        m, p = self.K_I.shape
        if self.derivative != "measured" or m != p or P.shape != (3 * p, 3 * p) or n != 3 * p:
            return None
        if np.linalg.matrix_rank(self.K_I) < p:
            return None
        T = np.zeros((3 * p, 3 * p))
        T[:2 * p, p:] = np.eye(2 * p)
        T[2 * p:, :p] = self.K_I
        T_inv = np.linalg.inv(T)
        out = T_inv.T @ P @ T_inv
        return np.asarray(0.5 * (out + out.T), dtype=float)

    @property
    def step_sizes(self) -> tuple[int, int]:
        """(inputs, outputs) of one step: ``[e, ė]`` (2p), with a feedforward ``[r, ṙ, r̈, q, q̇]`` (5p); u (m)."""
        return (5 if self.feedforward is not None else 2) * self.n_joints, self.n_torques

    @property
    def n_state_values(self) -> int:
        """Numbers the running controller keeps between steps (n_z)."""
        return int(self.matrices()[0].shape[0])

    def random_inputs(self, rng: np.random.Generator, n_steps: int) -> Array:
        """Random step inputs: e uniform in ±0.05 and ė in ±0.5 (the errors' units, per s).

        Parameters
        ----------
        rng : numpy.random.Generator
        n_steps : int

        Returns
        -------
        ndarray, shape (2p, n_steps)
        """
        p = self.n_joints
        if self.feedforward is not None:  # r, ṙ, r̈ anywhere, q and q̇ near them
            r, rd = rng.uniform(-np.pi, np.pi, (p, n_steps)), rng.uniform(-2.0, 2.0, (p, n_steps))
            return np.vstack([r, rd, rng.uniform(-5.0, 5.0, (p, n_steps)), r + rng.uniform(-0.05, 0.05, (p, n_steps)),
                              rd + rng.uniform(-0.5, 0.5, (p, n_steps))])
        return np.vstack([rng.uniform(-0.05, 0.05, (p, n_steps)), rng.uniform(-0.5, 0.5, (p, n_steps))])

    def run_steps(self, inputs: Array, precision: str) -> Array:
        """The steps on every column of `inputs` from a zero state (the controller's own state kept).

        Parameters
        ----------
        inputs : ndarray, shape (2p, n_steps)
            ``[e, ė]`` per column.
        precision : {'double', 'single'}
            Double: :meth:`step`; single: :func:`single_precision_step` (float32 in the C's order).

        Returns
        -------
        ndarray, shape (m, n_steps)
        """
        p = self.n_joints
        n_steps = inputs.shape[1]
        if self.feedforward is not None:
            if precision == "single":
                raise ArgumentValueError("precision", "of a PID with a model feedforward is 'double' (its RNEA is "
                                                      "checked against Pinocchio in double precision)")
            pid = copy.deepcopy(self)
            pid.reset()
            rows_ff = [pid.control(*(inputs[i * p:(i + 1) * p, k] for i in range(5))) for k in range(n_steps)]
            return np.asarray(np.array(rows_ff, dtype=float).T, dtype=float)
        if precision == "single":
            step32 = single_precision_step(self)
            rows: list[Any] = [step32(inputs[:p, k], inputs[p:, k]) for k in range(n_steps)]
        else:
            pid = copy.deepcopy(self)  # the caller's controller keeps its state
            pid.reset()
            rows = [pid.step(inputs[:p, k], inputs[p:, k]) for k in range(n_steps)]
        return np.asarray(np.array(rows, dtype=float).T, dtype=float)

    # -- running it ---------------------------------------------------------------------

    def _y(self, e: ArrayLike, edot: ArrayLike | None) -> list[float]:
        p = self.n_joints
        ev = check_array("e", e, shape=(p,))
        if edot is None:
            if self.derivative == "measured":
                raise ArgumentValueError("edot", "is required with derivative='measured', found None")
            dv = np.zeros(p)
        else:
            dv = check_array("edot", edot, shape=(p,))
        return [float(v) for v in ev] + [float(v) for v in dv]

    def initial_state(
        self, e0: ArrayLike | None = None, edot0: ArrayLike | None = None, u0: ArrayLike | None = None
    ) -> Array:
        """The state for a bumpless start at ``e0, ė0`` (see :meth:`reset`); shape (n_z,)."""
        m, p = self.K_I.shape
        e = np.zeros(p) if e0 is None else check_array("e0", e0, shape=(p,))
        ed = np.zeros(p) if edot0 is None else check_array("edot0", edot0, shape=(p,))
        _, _, _, D = self.matrices()
        if self.derivative == "measured":
            xf = np.zeros(0)
            rest = D[:, p:] @ ed  # K_D ė0
        else:
            _, b = self.filter_coefficients
            xf = self.K_D @ ed - b @ e  # so that D_0 = x_f + b e0 = K_D ė0
            rest = xf
        if u0 is None:  # the integral term c K_I e0 + w0 starts at 0: the paper's ∫e(0) = 0
            w = -(D[:, :p] - (self.K_P + (0.0 if self.derivative == "measured" else self.filter_coefficients[1]))) @ e
        else:
            w = np.broadcast_to(check_array("u0", u0), (m,)) - D[:, :p] @ e - rest
        return np.concatenate([w, xf]).astype(float)

    def reset(self, e0: ArrayLike | None = None, edot0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Set the state for a bumpless start.

        Parameters
        ----------
        e0 : array_like, shape (p,), optional
            Error at the first sample, rad. With the filtered derivative it seeds the
            difference, so the first sample has no derivative kick.
        edot0 : array_like, shape (p,), optional
            Error rate at start, rad/s: the filtered derivative starts at ``K_D ė0``
            (default 0).
        u0 : array_like, shape (m,), optional
            Torque applied before the switch, N·m: the integral term is set so that the
            first unsaturated output at ``e0, ė0`` equals it (bumpless transfer). Default:
            integral term 0 at the first sample, the paper's ``∫e(0) = 0`` (with Tustin and
            backward Euler, whose first sample already holds ``c K_I e0``, ``w`` starts at
            ``−c K_I e0``). ``reset()`` without arguments is the zero state, the ``_init``
            of the exported C code.
        """
        self.state = self.initial_state(e0, edot0, u0)

    def output(self, z: Sequence[float], y: Sequence[float],
               ff: Sequence[float] | None = None) -> tuple[list[float], list[float]]:
        """Applied and unsaturated torque ``(u, v)`` at state `z` and input ``y = [e, ė]``.

        With a feedforward `ff` (N·m, shape (m,)), ``v`` is the total ``ff + PID`` before the
        limit. Plain floats, in the operation order of the exported C code (so both agree to
        rounding); use :meth:`step` for the checked interface.
        """
        m, q = self.n_torques, len(y)
        _, _, C, D = self._cache
        v = []
        for i in range(m):
            acc = 0.0 if ff is None else ff[i]
            for j in range(len(z)):
                acc += C[i][j] * z[j]
            for j in range(q):
                acc += D[i][j] * y[j]
            v.append(acc)
        lim = self._limit
        u = v if lim is None else [min(max(v[i], -lim[i]), lim[i]) for i in range(m)]
        return u, v

    def update(self, z: Sequence[float], y: Sequence[float], u: Sequence[float], v: Sequence[float]) -> list[float]:
        """The next state from state `z`, input `y`, applied `u` and unsaturated `v` torques."""
        A, B, _, _ = self._cache
        nz, q, m = len(z), len(y), self.n_torques
        band = self.error_deadband
        out = []
        for i in range(nz):
            if band is not None and i < m and -band <= y[i] <= band:  # control_toolbox's deadband: not updated
                out.append(z[i])
                continue
            acc = 0.0
            for j in range(nz):
                acc += A[i][j] * z[j]
            for j in range(q):
                acc += B[i][j] * y[j]
            if i < m and self._gain is not None:
                acc += self._gain[i] * (u[i] - v[i])
            out.append(acc)
        return out

    def step(self, e: ArrayLike, edot: ArrayLike | None = None) -> Array:
        """One sample: the torque to hold until the next sample, and the state update.

        Parameters
        ----------
        e : array_like, shape (p,)
            ``r − q`` at this sample, rad.
        edot : array_like, shape (p,), optional
            ``ṙ − q̇``, rad/s; required with ``derivative='measured'``, ignored otherwise.

        Returns
        -------
        ndarray, shape (m,)
            Applied (saturated) torque, N·m.
        """
        y = self._y(e, edot)
        z = [float(v) for v in self.state]
        u, v = self.output(z, y)
        self.state = np.array(self.update(z, y, u, v), dtype=float)
        return np.array(u, dtype=float)

    def control(self, r: ArrayLike, rd: ArrayLike, rdd: ArrayLike, q: ArrayLike, qd: ArrayLike) -> Array:
        """One sample of the whole controller: ``u = clip(τ_ff(r, ṙ, r̈) + PID(r − q, ṙ − q̇))``.

        Parameters
        ----------
        r, rd, rdd : array_like, shape (p,)
            The reference and its derivatives at this sample, rad, rad/s, rad/s².
        q, qd : array_like, shape (p,)
            The measured joint angles (rad) and rates (rad/s).

        Returns
        -------
        ndarray, shape (m,)
            N·m, held until the next sample. Without a feedforward, :meth:`step` on the errors.
        """
        p = self.n_joints
        rv, rdv, rddv = (check_array(name, x, shape=(p,)) for name, x in (("r", r), ("rd", rd), ("rdd", rdd)))
        e = rv - check_array("q", q, shape=(p,))
        edot = rdv - check_array("qd", qd, shape=(p,))
        y = self._y(e, edot)
        ff = None if self.feedforward is None else self.feedforward.torque(list(rv), list(rdv), list(rddv))
        z = [float(v) for v in self.state]
        u, v = self.output(z, y, ff)
        self.state = np.array(self.update(z, y, u, v), dtype=float)
        return np.array(u, dtype=float)


def single_precision_step(pid: DiscretePID) -> Callable[[Any, Any], NDArray[np.float32]]:
    """The step of the single-precision C export, in Python: float32 operations in the C's order.

    Each product and sum is rounded to float32 as C evaluates ``float`` arithmetic
    (``FLT_EVAL_METHOD == 0``, no contraction), on the constants the C source holds.

    Parameters
    ----------
    pid : DiscretePID

    Returns
    -------
    callable
        ``step(e, edot) -> u``: e and edot array_like, shape (p,) (edot ignored with
        ``derivative='filtered'``), u float32, shape (m,); the state starts at zero.

    Examples
    --------
    >>> import scara_robust as sr
    >>> step = sr.single_precision_step(sr.design(sr.paper_model(), 3, 90).discretize(1e-3))
    >>> step([0.1, 0.0], [0.0, 0.0]).dtype
    dtype('float32')
    """
    check_instance("pid", pid, DiscretePID, "a DiscretePID (Design.discretize)")
    f32 = np.float32
    A, B, C, D = (np.asarray(M, dtype=f32) for M in pid.matrices())
    p, m, nz = pid.n_joints, pid.n_torques, A.shape[0]
    measured = pid.derivative == "measured"
    limit = None if pid.torque_limit is None else np.asarray(pid.torque_limit, dtype=f32)
    windup = pid.back_calculation
    aw = np.asarray(pid.back_calculation_gains, dtype=f32) if windup else None
    band = None if pid.error_deadband is None else f32(pid.error_deadband)
    state = [f32(0.0)] * nz

    def step(e: Any, edot: Any = None) -> NDArray[np.float32]:
        e32 = check_array("e", e, shape=(p,)).astype(f32)
        y = list(e32)
        if measured:
            y += list(check_array("edot", edot, shape=(p,)).astype(f32))
        v, u = [], []
        for i in range(m):
            acc = f32(0.0)
            for j in range(nz):
                acc = f32(acc + f32(C[i, j] * state[j]))
            for j in range(len(y)):
                acc = f32(acc + f32(D[i, j] * y[j]))
            v.append(acc)
        for i in range(m):
            x = v[i]
            if limit is not None:
                x = -limit[i] if x < -limit[i] else x
                x = limit[i] if x > limit[i] else x
            u.append(f32(x))
        new = []
        for i in range(nz):
            if band is not None and i < m and -band <= y[i] <= band:
                new.append(state[i])
                continue
            acc = f32(0.0)
            for j in range(nz):
                acc = f32(acc + f32(A[i, j] * state[j]))
            for j in range(len(y)):
                acc = f32(acc + f32(B[i, j] * y[j]))
            if aw is not None and i < m:
                acc = f32(acc + f32(aw[i] * f32(u[i] - v[i])))
            new.append(acc)
        state[:] = new
        return np.array(u, dtype=f32)

    return step
