"""A compiled engine: the robot's closed loop integrated in machine code (numba, extra ``compiled``).

The Python engines call a right-hand side of about a hundred flops through the
interpreter some 30 000 times per 20-s run; here the whole run, right-hand side, control
law, signals and integrator, is one compiled function, and a batch of runs is one call.

What it integrates is the same loop as :class:`~scara_robust.simulation.loop.ClosedLoop`
for the package's own laws (:class:`~scara_robust.simulation.controllers.ControlLaw`):
the PID with any gain, the sliding-mode law with a boundary layer, the sampled sign law,
torque saturation, a constant or sinusoidal payload, the reference ``a (sin ωt, cos ωt)``
and square-wave disturbances. Anything else (a user's own controller, reference or
payload callable, the discrete PID) is refused with a message; the scipy engines take it.

Integrators. A continuous law is stiff in closed loop (the PID's fastest pole is near
-1500 1/s), so by default (``integrator='bdf'``) it runs the variable-order BDF method
of :class:`scipy.integrate.BDF` (numerical differentiation formulas of orders 1 to 5 with
a quasi-constant step, Shampine and Reichelt, "The MATLAB ODE suite", SIAM J. Sci.
Comput. 18, 1997), step for step, with a forward-difference Jacobian and scipy's dense
output at the output times. ``integrator='dopri5'`` runs Dormand–Prince 5(4) with its
embedded error estimate and scipy's quartic dense output instead: it is held to steps of
about 1 ms by its stability region, five times the right-hand-side calls. Either is
restarted at every switching instant of the disturbance, so no step straddles a
discontinuity, with the caller's tolerances. The peak torque's refinement and the shared
segment loop's :meth:`CompiledEngine.advance` step Dormand–Prince exactly onto their
times. For a sampled law, one classical RK4 step per sample with the torque held, the
disturbance taken at the step's midpoint: the ``rk4`` engine's scheme, step for step. A
run leaving the limits is frozen at the end of the disturbance segment where it left
them, as the shared segment loop does.

The integrators are not the SCARA's own: they reach the model only through hooks of
:mod:`scara_robust.simulation._kernels`, and a URDF arm runs on them too
(:mod:`scara_robust.simulation.compiled_arm`).

Compilation is cached on disk (numba ``cache=True``); :func:`compile_seconds` reports the
first call's cost separately.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import check_choice
from ..exceptions import ArgumentValueError
from ..model.robot import ConstantPayload, SinusoidalPayload
from .controllers import ControlLaw
from .engines import ENGINES, Engine, output_grid
from .loop import STATE_LIMIT, ClosedLoop

__all__ = ["numba_available", "compiled_run", "compiled_batch", "CompiledRun", "COMPILED_INTEGRATORS"]

Array = NDArray[np.float64]

#: Integrators of a continuous law: ``'bdf'`` (the default; stiff) and ``'dopri5'`` (explicit).
COMPILED_INTEGRATORS = ("bdf", "dopri5")

# Layout of the packed parameter vector θ of one run.
_ROBOT = 0  # m1, m2, L1, L2, Lc1, Lc2, I1, I2, cp
_PAYLOAD = 9  # offset, amplitude, omega, phase (a constant payload: amplitude 0)
_REF = 13  # a, ω
_DIST = 15  # amplitude, period, phase, sign1, sign2
_KIND = 20  # 0 pid, 1 smc boundary, 2 smc sign
_K = 21  # 12 entries, row-major
_SMC = 33  # lam, k_d, k_s, boundary
_SMC_ROBOT = 37  # the robot the sliding-mode law knows: m1, m2, L1, L2, Lc1, Lc2, I1, I2, cp
_LIMIT = 46  # limit1, limit2 (inf: none)
_TS = 48  # sample time (0: continuous)
#: Length of the packed parameter vector of one run.
N_THETA = 49
_KINDS = {"pid": 0, "smc-boundary": 1, "smc-sign": 2}

#: Exit codes of the compiled loop.
_COMPLETED, _DIVERGED, _FAILED = 0, 1, 2
#: Why ``method='compiled'`` cannot run without numba (the argument is ``method``).
NUMBA_MISSING = "'compiled' needs numba: pip install '.[compiled]', or use 'lsoda' (continuous) or 'rk4' (sampled)"


def numba_available() -> bool:
    """Whether numba can be imported (the extra ``compiled``).

    Returns
    -------
    bool
    """
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def compiled_support(loop: ClosedLoop) -> str | None:
    """Why the compiled engine cannot run `loop`, or None if it can.

    Parameters
    ----------
    loop : ClosedLoop

    Returns
    -------
    str or None
    """
    law = getattr(loop.controller, "law", None)
    if not isinstance(law, ControlLaw) or law.kind not in _KINDS:
        return "its controller is not one of the package's PID or sliding-mode laws"
    if law.reference.sinusoid is None or loop.reference.sinusoid != law.reference.sinusoid:
        return "its reference is not a (sin ωt, cos ωt) known to both the loop and the controller"
    if not isinstance(loop.payload, (ConstantPayload, SinusoidalPayload)):
        return "its payload is neither a ConstantPayload nor a SinusoidalPayload"
    if (law.kind == "smc-sign") != (loop.Ts is not None):
        return "the sign law runs sampled and the others continuous"
    return None


def pack_loop(loop: ClosedLoop) -> Array:
    """The packed parameters θ of one loop, shape (:data:`N_THETA`,).

    Parameters
    ----------
    loop : ClosedLoop

    Returns
    -------
    ndarray, shape (N_THETA,)

    Raises
    ------
    ArgumentValueError
        Naming ``method`` when the compiled engine cannot run this loop.
    """
    why = compiled_support(loop)
    if why is not None:
        raise ArgumentValueError("method", f"'compiled' cannot run this loop: {why}; use 'lsoda' or 'rk4'")
    law: ControlLaw = loop.controller.law
    th = np.zeros(N_THETA)
    p = loop.params
    th[_ROBOT:_ROBOT + 9] = (p.m1, p.m2, p.L1, p.L2, p.Lc1, p.Lc2, p.I1, p.I2, p.cp)
    if isinstance(loop.payload, ConstantPayload):
        th[_PAYLOAD:_PAYLOAD + 4] = (loop.payload.mass, 0.0, 1.0, 0.0)
    elif isinstance(loop.payload, SinusoidalPayload):
        pl = loop.payload
        th[_PAYLOAD:_PAYLOAD + 4] = (pl.offset, pl.amplitude, pl.omega, pl.phase)
    assert law.reference.sinusoid is not None
    th[_REF:_REF + 2] = law.reference.sinusoid
    d = loop.disturbance
    th[_DIST:_DIST + 5] = (d.amplitude, d.period, d.phase, d.signs[0], d.signs[1])
    th[_KIND] = _KINDS[law.kind]
    if law.K is not None:
        th[_K:_K + 12] = np.asarray(law.K, dtype=float).ravel()
    if law.gains is not None and law.params is not None:
        g, q = law.gains, law.params
        th[_SMC:_SMC + 4] = (g.lam, g.k_d, g.k_s, g.boundary)
        th[_SMC_ROBOT:_SMC_ROBOT + 9] = (q.m1, q.m2, q.L1, q.L2, q.Lc1, q.Lc2, q.I1, q.I2, q.cp)
    th[_LIMIT:_LIMIT + 2] = np.inf if law.torque_limit is None else law.torque_limit
    th[_TS] = 0.0 if loop.Ts is None else loop.Ts
    return th


_KERNELS: dict[str, Any] = {}
_COMPILE_SECONDS: list[float] = []


def _build() -> dict[str, Any]:
    """Compile (or load from numba's disk cache) the kernels; once per process."""
    if _KERNELS:
        return _KERNELS
    start = time.perf_counter()
    with quiet_compile():
        from ._kernels import batch, refine, rhs, run, segment, torque

        # compile (or load) now, on a tiny problem, so the first real run is not charged for it
        th = np.zeros(N_THETA)
        th[_ROBOT:_ROBOT + 9] = 1.0
        th[_DIST + 1] = 1.0
        th[_REF:_REF + 2] = 1.0
        th[_LIMIT:_LIMIT + 2] = np.inf
        x0 = np.zeros(6)
        t_out = np.array([0.0, 0.01])
        X, TC, ER = np.zeros((6, 2)), np.zeros((2, 2)), np.zeros((4, 2))
        for stiff in (True, False):
            run(th, x0, t_out, t_out, 1e-6, 1e-9, 50.0, X, TC, ER, stiff)
        refine(th, x0, 0.0, t_out[1:], np.ones(1, np.bool_), 1e-6, 1e-9)
        batch(th[None], x0[None], t_out, t_out[None], np.array([2]), 1e-6, 1e-9, 50.0, X[None], TC[None],
              ER[None], np.zeros((1, 4)), True)
        _COMPILE_SECONDS.append(time.perf_counter() - start)
        segment(th, x0, 0.0, t_out[1:], 1.0, 1e-6, 1e-9, X[:, :1])
    _KERNELS.update({"run": run, "refine": refine, "batch": batch, "torque": torque, "rhs": rhs, "segment": segment})
    return _KERNELS


@contextmanager
def quiet_compile() -> Iterator[None]:
    """Silence numba's pedantic ``NumbaIRAssumptionWarning`` while kernels compile.

    numba warns "variable ... is not in scope" when it inlines a model's hook whose body
    inlines further kernels (:mod:`scara_robust.simulation._kernels`): a check of its own
    bookkeeping of variable names, not of the code it compiles, which computes the same
    numbers as the kernels written for the SCARA alone.

    Yields
    ------
    None
    """
    from numba.core.errors import NumbaIRAssumptionWarning

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"variable .* is not in scope", category=NumbaIRAssumptionWarning)
        yield


def compile_seconds() -> float:
    """Seconds the kernels took to compile or load from the disk cache in this process (compiles if needed).

    Returns
    -------
    float
    """
    _build()
    return _COMPILE_SECONDS[0]


@dataclass(frozen=True)
class CompiledRun:
    """One run of the compiled engine.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Output times reached, s.
    x : ndarray, shape (n_states, k)
    torque : ndarray, shape (2, k)
        Control torque at `t`, N·m.
    success, diverged : bool
    message : str
    peak_torque : float
        ``max |T_c|``, N·m, refined between samples for a continuous law (see
        :class:`~scara_robust.SimulationResult`).
    rhs_calls : int
        Right-hand-side evaluations of the main run.
    error : ndarray, shape (4, k)
        ``r - q`` (rad) and ``ṙ - q̇`` (rad/s) at `t`, from the kernel's own reference.
    """

    t: Array
    x: Array
    torque: Array
    success: bool
    diverged: bool
    message: str
    peak_torque: float
    rhs_calls: int
    error: Array


def _edges(loop: ClosedLoop, t_out: Array, t_final: float) -> Array:
    if loop.Ts is not None:
        return t_out
    return np.concatenate([[0.0], loop.disturbance.switching_times(0.0, t_final), [t_final]])


def _grid(loop: ClosedLoop, t_final: float, dt: float) -> Array:
    if loop.Ts is not None:
        n = int(np.floor(t_final / loop.Ts + 1e-9))
        return np.asarray(loop.Ts * np.arange(n + 1), dtype=float)
    return output_grid(t_final, dt)


def _finish(loop: ClosedLoop, th: Array, t_out: Array, X: Array, TC: Array, ER: Array, info: Array, limit: float,
            rtol: float, atol: float, peak_candidates: int, peak_points: int) -> CompiledRun:
    k, code, t_stop, calls = int(info[0]), int(info[1]), float(info[2]), int(info[3])
    t, x, tc, er = t_out[:k], X[:, :k], TC[:, :k], ER[:, :k]
    if code == _DIVERGED:
        message = f"diverged by t = {t_stop:.3f} s (|e| > {limit} rad or a state beyond {STATE_LIMIT:g})"
    elif code == _FAILED:
        message = f"integrator failed at t = {t_stop:.3f} s: step size too small"
    else:
        message = "completed"
    mag = np.abs(tc).max(axis=0) if k else np.zeros(0)
    peak = float(mag.max()) if k else math.nan
    if loop.Ts is None and k >= 2:
        refine = _build()["refine"]
        padded = np.concatenate([[-np.inf], mag, [-np.inf]])
        local = np.flatnonzero((padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:]))
        for i in local[np.argsort(mag[local])[-peak_candidates:]]:
            a, b = max(int(i) - 1, 0), min(int(i) + 1, k - 1)
            fine = np.linspace(t[a], t[b], peak_points)[1:]
            switches = loop.disturbance.switching_times(float(t[a]), float(t[b]))
            pts = np.concatenate([fine, switches])
            order = np.argsort(pts, kind="stable")
            counted = np.concatenate([np.ones(fine.size, bool), np.zeros(switches.size, bool)])[order]
            value = float(refine(th, np.ascontiguousarray(x[:, a]), float(t[a]), pts[order], counted, rtol, atol))
            if not math.isnan(value):
                peak = max(peak, value)
    return CompiledRun(t, x, tc, code == _COMPLETED, code == _DIVERGED, message, peak, calls, er)


def compiled_run(loop: ClosedLoop, x0: Array, t_final: float, *, dt: float = 1e-3, rtol: float = 1e-8,
                 atol: float = 1e-10, divergence_limit: float = 50.0, peak_candidates: int = 5,
                 peak_points: int = 41, integrator: str = "bdf") -> CompiledRun:
    """Integrate one loop with the compiled engine.

    Parameters
    ----------
    loop : ClosedLoop
        With one of the package's laws (:func:`compiled_support`).
    x0 : ndarray, shape (n_states,)
    t_final, dt : float
        Horizon and output spacing, s (a sampled law outputs at its samples).
    rtol, atol : float
        Tolerances of the adaptive steps.
    divergence_limit : float
        rad.
    peak_candidates, peak_points : int
        The peak torque's refinement (as the Python engines do it).
    integrator : {'bdf', 'dopri5'}
        For a continuous law (see :data:`COMPILED_INTEGRATORS`); a sampled law always steps RK4.

    Returns
    -------
    CompiledRun
    """
    stiff = check_choice("integrator", integrator, COMPILED_INTEGRATORS) == "bdf"
    th = pack_loop(loop)
    kernels = _build()
    t_out = _grid(loop, t_final, dt)
    edges = _edges(loop, t_out, t_final)
    x0 = np.ascontiguousarray(x0, dtype=float)
    X = np.zeros((x0.size, t_out.size))
    TC = np.zeros((2, t_out.size))
    ER = np.zeros((4, t_out.size))
    j, code, t_stop, calls = kernels["run"](th, x0, t_out, edges, rtol, atol, divergence_limit, X, TC, ER, stiff)
    return _finish(loop, th, t_out, X, TC, ER, np.array([j, code, t_stop, calls], dtype=float), divergence_limit,
                   rtol, atol, peak_candidates, peak_points)


def compiled_batch(loops: list[ClosedLoop], x0s: list[Array], t_final: float, *, dt: float = 1e-3,
                   rtol: float = 1e-8, atol: float = 1e-10, divergence_limit: float = 50.0,
                   peak_candidates: int = 5, peak_points: int = 41, integrator: str = "bdf") -> list[CompiledRun]:
    """Integrate many loops in one compiled call (same horizon, state size and sample time).

    Parameters
    ----------
    loops : list of ClosedLoop
    x0s : list of ndarray, shape (n_states,)
    t_final, dt, rtol, atol, divergence_limit, peak_candidates, peak_points, integrator
        As :func:`compiled_run`.

    Returns
    -------
    list of CompiledRun
        One per loop, equal to :func:`compiled_run` of each.
    """
    stiff = check_choice("integrator", integrator, COMPILED_INTEGRATORS) == "bdf"
    if not loops:
        return []
    if len(x0s) != len(loops):
        raise ArgumentValueError("x0s", f"must hold one state per loop ({len(loops)}), found {len(x0s)}")
    sizes = {np.asarray(x).size for x in x0s}
    samples = {lp.Ts for lp in loops}
    if len(sizes) != 1 or len(samples) != 1:
        raise ArgumentValueError("loops", "must share the state size and the sample time (batch them by controller)")
    TH = np.stack([pack_loop(lp) for lp in loops])
    kernels = _build()
    t_out = _grid(loops[0], t_final, dt)
    edge_list = [_edges(lp, t_out, t_final) for lp in loops]
    n_edges = np.array([e.size for e in edge_list], dtype=np.int64)
    edges_all = np.zeros((len(loops), int(n_edges.max())))
    for r, e in enumerate(edge_list):
        edges_all[r, :e.size] = e
    X0 = np.ascontiguousarray(np.stack([np.asarray(x, dtype=float) for x in x0s]))
    X = np.zeros((len(loops), X0.shape[1], t_out.size))
    TC = np.zeros((len(loops), 2, t_out.size))
    ER = np.zeros((len(loops), 4, t_out.size))
    info = np.zeros((len(loops), 4))
    kernels["batch"](TH, X0, t_out, edges_all, n_edges, rtol, atol, divergence_limit, X, TC, ER, info, stiff)
    return [_finish(lp, TH[r], t_out, X[r], TC[r], ER[r], info[r], divergence_limit, rtol, atol,
                    peak_candidates, peak_points)
            for r, lp in enumerate(loops)]


class CompiledEngine(Engine):
    """The compiled engine in the registry (``method='compiled'``).

    :func:`scara_robust.simulate` runs it whole through :func:`compiled_run`;
    :meth:`advance` integrates one segment with the same compiled Dormand–Prince steps
    (or one RK4 step for a sampled law), so the shared segment loop can use it too.
    """

    name = "compiled"
    sampled = True
    dense = True

    def grid(self, loop: ClosedLoop, t_final: float, dt: float) -> tuple[Array, Array]:
        """The sampled law's steps, or the disturbance's switching instants and `dt` (see :class:`Engine`)."""
        t_out = _grid(loop, t_final, dt)
        return _edges(loop, t_out, t_final), t_out

    def advance(
        self, loop: ClosedLoop, x: Array, a: float, b: float, t_eval: Array, td: Array, rtol: float, atol: float
    ) -> tuple[Array | None, str]:
        """See :meth:`Engine.advance`."""
        th = pack_loop(loop)
        X = np.zeros((x.size, t_eval.size))
        # the square wave's level on the segment, as the shared loop holds it
        td_level = float(td[0]) if th[_DIST + 3] == 0 else float(td[0]) / th[_DIST + 3]
        ok = _build()["segment"](th, np.ascontiguousarray(x, dtype=float), a, t_eval, td_level, rtol, atol, X)
        if not ok:
            return None, f"integrator failed at t = {a:.3f} s: step size too small"
        return X, ""


ENGINES[CompiledEngine.name] = CompiledEngine()
