"""Integration engines for a :class:`~scara_robust.simulation.loop.ClosedLoop`, chosen by name.

Every engine runs inside one shared segment loop (:func:`integrate`): the horizon is cut
into segments within which the disturbance is constant, each segment is handed to the
engine, the pieces are stitched, and a diverging run is stopped and frozen at the end of
the segment where it left the limits. Every engine returns the same
:class:`Trajectory`.

==============  ================================================================  ==========
name            algorithm                                                         controller
==============  ================================================================  ==========
``lsoda``       ``scipy.integrate.solve_ivp(method='LSODA')`` on a lean right-     continuous
                hand side; the PID loop is stiff (poles near −1500 1/s at (3, 90))
                and LSODA switches to BDF there (the default)
``interconnect`` the ``control.interconnect`` system integrated by                 continuous
                ``control.input_output_response`` (RK45): the reference path
``rk4``         classical RK4 with a fixed step, one step per segment; with a      sampled or
                sampled controller the step is its sample time and its output is   continuous
                held over the step (zero-order hold), a discrete-time
                controller's state jumps once per step, the disturbance is taken
                at the step's midpoint
``compiled``    the package's own PID and sliding-mode laws in machine code        sampled or
                (numba, extra ``compiled``): scipy's variable-order BDF (or        continuous
                Dormand–Prince 5(4)) with dense output, RK4 per sample for a
                sampled law; it registers itself from
                :mod:`scara_robust.simulation.compiled`
==============  ================================================================  ==========
"""

from __future__ import annotations

import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import control as ct
import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from .loop import ClosedLoop

__all__ = ["ENGINES"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Trajectory:
    """What an engine returns: the state on the output grid and how the run ended.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Output times, s.
    x : ndarray, shape (n_states, k)
        State of the loop (plant, then controller) at `t`.
    success : bool
        False when the integrator failed or the run diverged.
    diverged : bool
        The run left the limits and stopped at ``t[-1]``.
    message : str
        ``'completed'``, or why the run stopped.
    """

    t: Array
    x: Array
    success: bool
    diverged: bool
    message: str


def output_grid(t_final: float, dt: float) -> Array:
    """Output times 0, dt, 2 dt, ... up to `t_final`, which is always included (s).

    Parameters
    ----------
    t_final, dt : float
        Horizon and spacing, s (> 0).

    Returns
    -------
    ndarray, shape (k,)
    """
    n_samples = int(np.floor(t_final / dt + 1e-9)) + 1
    t_out = np.linspace(0.0, dt * (n_samples - 1), n_samples)
    return t_out if t_out[-1] >= t_final - 1e-12 else np.append(t_out, t_final)


class Engine(ABC):
    """An integration algorithm for the shared segment loop of :func:`integrate`.

    Subclasses set ``name``, ``sampled`` (True if the engine can hold a sampled
    controller's output) and ``dense`` (True if :meth:`advance` returns the state at any
    times asked for, so a peak between output samples can be found), and implement
    :meth:`advance`.
    """

    name: ClassVar[str]
    sampled: ClassVar[bool] = False
    dense: ClassVar[bool] = True

    def grid(self, loop: ClosedLoop, t_final: float, dt: float) -> tuple[Array, Array]:
        """Segment edges and output times, s: by default the disturbance's switching instants and `dt`.

        Parameters
        ----------
        loop : ClosedLoop
        t_final, dt : float
            Horizon and output spacing, s.

        Returns
        -------
        edges : ndarray, shape (n_segments + 1,)
        t_out : ndarray, shape (k,)
        """
        edges = np.concatenate([[0.0], loop.disturbance.switching_times(0.0, t_final), [t_final]])
        return edges, output_grid(t_final, dt)

    @abstractmethod
    def advance(
        self, loop: ClosedLoop, x: Array, a: float, b: float, t_eval: Array, td: Array, rtol: float, atol: float
    ) -> tuple[Array | None, str]:
        """Integrate one segment ``[a, b]`` from state `x` with the disturbance held at `td`.

        Parameters
        ----------
        loop : ClosedLoop
        x : ndarray, shape (n_states,)
            State at `a`.
        a, b : float
            Segment, s.
        t_eval : ndarray, shape (j,)
            Times in ``(a, b]`` to return, ending with `b`.
        td : ndarray, shape (2,)
            Disturbance torque on the segment, N·m.
        rtol, atol : float
            Tolerances, for engines that adapt their step.

        Returns
        -------
        X : ndarray, shape (n_states, j), or None
            The state at `t_eval`; None if the integrator failed.
        message : str
            Why it failed (empty on success).
        """


class LSODAEngine(Engine):
    """``scipy.integrate.solve_ivp`` with LSODA on the lean right-hand side of the loop."""

    name = "lsoda"

    def advance(
        self, loop: ClosedLoop, x: Array, a: float, b: float, t_eval: Array, td: Array, rtol: float, atol: float
    ) -> tuple[Array | None, str]:
        """See :meth:`Engine.advance`."""
        rhs, torque = loop.rhs, loop.torque

        def segment_rhs(t: float, xx: Array) -> Array:
            return rhs(t, xx, torque(t, xx), td)

        with warnings.catch_warnings(record=True) as caught:  # LSODA's complaints go into the run's reason
            warnings.simplefilter("always", UserWarning)
            sol = solve_ivp(segment_rhs, (a, b), x, method="LSODA", t_eval=t_eval, rtol=rtol, atol=atol)
        if not sol.success:
            said = "".join(f" ({' '.join(str(w.message).split())})" for w in caught[:1])
            return None, f"integrator failed at t = {a:.3f} s: {sol.message}{said}"
        return np.asarray(sol.y, dtype=float), ""


class InterconnectEngine(Engine):
    """``control.input_output_response`` (RK45) on the ``control.interconnect`` system."""

    name = "interconnect"

    def advance(
        self, loop: ClosedLoop, x: Array, a: float, b: float, t_eval: Array, td: Array, rtol: float, atol: float
    ) -> tuple[Array | None, str]:
        """See :meth:`Engine.advance`; the interconnect's disturbance is held at the segment's midpoint."""
        resp = ct.input_output_response(
            loop.system,
            np.concatenate([[a], t_eval]),
            0,
            x,
            params={"segment_midpoint": 0.5 * (a + b)},
            solve_ivp_method="RK45",
            solve_ivp_kwargs={"rtol": rtol, "atol": atol},
        )
        return np.asarray(resp.states[:, 1:], dtype=float), ""


class RK4Engine(Engine):
    """Classical fixed-step RK4, one step per segment; a sampled controller is held over the step."""

    name = "rk4"
    sampled = True
    dense = False

    def grid(self, loop: ClosedLoop, t_final: float, dt: float) -> tuple[Array, Array]:
        """Steps of the sample time (or of `dt` for a continuous controller); outputs at every step.

        The grid stops at the last whole step at or before `t_final`.
        """
        h = loop.Ts or dt
        n = int(np.floor(t_final / h + 1e-9))
        edges = np.asarray(h * np.arange(n + 1), dtype=float)
        return edges, edges

    def advance(
        self, loop: ClosedLoop, x: Array, a: float, b: float, t_eval: Array, td: Array, rtol: float, atol: float
    ) -> tuple[Array | None, str]:
        """See :meth:`Engine.advance`."""
        rhs, torque = loop.rhs, loop.torque
        h = b - a
        if loop.Ts is not None:
            tc = torque(a, x)
            k1 = rhs(a, x, tc, td)
            k2 = rhs(a + h / 2, x + h / 2 * k1, tc, td)
            k3 = rhs(a + h / 2, x + h / 2 * k2, tc, td)
            k4 = rhs(b, x + h * k3, tc, td)
            x_next = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if loop.discrete:
                # the controller's state jumps with the sample taken at `a`, as its output did
                x_next[loop.n_plant:] = loop.jump(a, x)
            return x_next[:, None], ""
        else:
            k1 = rhs(a, x, torque(a, x), td)
            x2 = x + h / 2 * k1
            k2 = rhs(a + h / 2, x2, torque(a + h / 2, x2), td)
            x3 = x + h / 2 * k2
            k3 = rhs(a + h / 2, x3, torque(a + h / 2, x3), td)
            x4 = x + h * k3
            k4 = rhs(b, x4, torque(b, x4), td)
        return (x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))[:, None], ""


#: Engines by name (the ``method`` of :func:`scara_robust.simulate`).
ENGINES: dict[str, Engine] = {engine.name: engine for engine in (LSODAEngine(), InterconnectEngine(), RK4Engine())}
#: Engine of a continuous-time controller when none is named.
DEFAULT_ENGINE = "lsoda"
#: Engine of a sampled controller when none is named.
SAMPLED_ENGINE = "rk4"


def integrate(
    engine: Engine,
    loop: ClosedLoop,
    x0: Array,
    t_final: float,
    *,
    dt: float,
    rtol: float,
    atol: float,
    divergence_limit: float,
    t0: float = 0.0,
    t_out: Array | None = None,
) -> Trajectory:
    """The shared segment loop: integrate `loop` from `x0` over ``[t0, t_final]`` with `engine`.

    Parameters
    ----------
    engine : Engine
    loop : ClosedLoop
    x0 : ndarray, shape (n_states,)
        Initial state.
    t_final : float
        Horizon, s.
    dt : float
        Output spacing, s (the engine may use its own grid, see :meth:`Engine.grid`).
    rtol, atol : float
        Tolerances of adaptive engines.
    divergence_limit : float
        Tracking error (rad) beyond which the run stops, checked at every segment's end.
    t0 : float
        Start time, s (default 0).
    t_out : ndarray, shape (k,), optional
        Output times in ``[t0, t_final]`` for a dense engine (default: its own grid).

    Returns
    -------
    Trajectory
        On the output grid, up to where the run stopped.
    """
    if t_out is None:
        edges, t_out = engine.grid(loop, t_final, dt)
    else:
        if not engine.dense:
            raise ValueError(f"engine {engine.name!r} gives the state on its own grid only; `t_out` needs a dense one")
        edges = np.concatenate([[t0], loop.disturbance.switching_times(t0, t_final), [t_final]])
    first = np.searchsorted(t_out, edges, side="right")
    times: list[Array] = [np.full(1, t0)]
    states: list[Array] = [np.asarray(x0, dtype=float)[:, None]]
    x = states[0][:, 0]
    success, diverged, message = True, False, "completed"
    for k in range(len(edges) - 1):
        a, b = float(edges[k]), float(edges[k + 1])
        inside = t_out[first[k] : first[k + 1]]
        t_eval = inside if inside.size and inside[-1] == b else np.append(inside, b)
        td = np.asarray(loop.disturbance(0.5 * (a + b)), dtype=float)
        X, failure = engine.advance(loop, x, a, b, t_eval, td, rtol, atol)
        if X is None:
            success, message = False, failure
            break
        times.append(t_eval)
        states.append(X)
        x = X[:, -1]
        why = loop.divergence(b, x, divergence_limit)
        if why is not None:
            success, diverged, message = False, True, why
            break
    t = np.concatenate(times)
    X_all = np.concatenate(states, axis=1)
    on_grid = np.isin(t, t_out)
    return Trajectory(t=t[on_grid], x=X_all[:, on_grid], success=success, diverged=diverged, message=message)
