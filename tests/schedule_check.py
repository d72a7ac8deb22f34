"""Independent numpy checks of gain-scheduled state feedback over one measured parameter.

Written from the mathematics alone (not from the package's synthesis code), so that tests can
hold a scheduled design and its certificate against it.

The schedule
    Breakpoints ``b_0 < ... < b_N`` of the measured parameter ``p`` and gains ``K_j`` (shape
    (N+1, m, n)). The controller applies ``u = −K(p̂) x`` on the plant's design form, with
    ``K(p̂)`` the linear interpolation of the ``K_j`` in ``p̂`` after clamping ``p̂`` to
    ``[b_0, b_N]``, and ``|p̂ − p| <= δ``.
The certificate
    ``P(p)`` piecewise linear on the same breakpoints (``P_j``, shape (N+1, n, n)), with slope
    ``D_j = (P_{j+1} − P_j)/(b_{j+1} − b_j)`` on segment j. It certifies decay α >= 0 under
    ``|ṗ| <= ν`` when, for every p in ``[b_0, b_N]``, every value q of the other (unmeasured)
    parameters, every admissible ``p̂`` and ``ṗ = ±ν``::

        P(p) ≻ 0   and   L = A_clᵀ P(p) + P(p) A_cl + ṗ D_j + 2α P(p) ≺ 0,
        A_cl = A(p, q) − B(p, q) K(p̂),

    j the segment holding p (both adjacent segments at an interior breakpoint). ``L`` is
    affine in ``K`` and ``K`` piecewise linear in ``p̂``, so ``p̂`` need only range over the
    ends of ``[p − δ, p + δ]`` clamped to ``[b_0, b_N]`` and the breakpoints strictly inside.

Conventions (shared by every function here)
    * p-grid: each segment ``[b_j, b_{j+1}]`` split into ``4·refine`` equal sub-intervals,
      both ends included, each point carrying its own segment's slope ``D_j``; so an interior
      breakpoint is checked twice, once with each adjacent slope.
    * q-grid: every other parameter that varies on ``np.linspace(lower, upper, c)`` with
      ``c = 2·samples − 1`` by default (its :class:`Parameter` ``samples`` refined once
      between points), or as `other_points` says; a fixed parameter at its value.
    * ``ṗ ∈ {−ν, +ν}`` (one value, 0, when ν = 0).
    * Normalization: eigenvalues are divided by ``max_j ‖P_j‖₂`` (spectral norm).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import scipy.linalg

__all__ = [
    "interpolate_gain",
    "schedule_grid",
    "schedule_condition_margin",
    "scheduled_floquet_growth",
    "frozen_spectral_abscissa",
]


# --- validation and grids ---------------------------------------------------------------------------------------


def _breakpoints(breakpoints: Any, minimum: int = 2) -> np.ndarray:
    b = np.asarray(breakpoints, dtype=float)
    if b.ndim != 1 or b.size < minimum:
        raise ValueError(f"breakpoints must be a 1-D array of at least {minimum} values, found shape {b.shape}")
    if not np.all(np.isfinite(b)):
        raise ValueError("breakpoints must be finite")
    if np.any(np.diff(b) <= 0):
        raise ValueError(f"breakpoints must be strictly increasing, found {b}")
    return b


def _gains(gains: Any, n_breakpoints: int) -> np.ndarray:
    K = np.asarray(gains, dtype=float)
    if K.ndim != 3 or K.shape[0] != n_breakpoints:
        raise ValueError(f"gains must have shape ({n_breakpoints}, m, n), found {K.shape}")
    if not np.all(np.isfinite(K)):
        raise ValueError("gains must be finite")
    return K


def _check_plant_schedule(plant: Any, parameter: str, breakpoints: Any, gains: Any,
                          minimum: int = 2) -> tuple[np.ndarray, np.ndarray, int]:
    """Breakpoints, gains (checked against the plant's design-form sizes) and the parameter's column."""
    names = tuple(plant.names)
    if parameter not in names:
        raise ValueError(f"parameter {parameter!r} is not one of the plant's parameters {names}")
    b = _breakpoints(breakpoints, minimum)
    K = _gains(gains, b.size)
    n, m = _design_sizes(plant)
    if K.shape[1:] != (m, n):
        raise ValueError(f"gains must have shape ({b.size}, {m}, {n}) for this plant, found {K.shape}")
    return b, K, names.index(parameter)


def _design_sizes(plant: Any) -> tuple[int, int]:
    """(n, m) of the design form, from one evaluation at the nominal."""
    row = np.array([[plant.nominal[name] for name in plant.names]], dtype=float).reshape(1, len(plant.names))
    A, B = plant.design_form(*plant.plant_matrices(row))
    return int(A.shape[-1]), int(B.shape[-1])


def _design_matrices(plant: Any, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Design-form (A, B) stacks at rows of parameter values (the plant's column order)."""
    A, B = plant.plant_matrices(np.asarray(values, dtype=float).reshape(-1, len(plant.names)))
    A_aug, B_aug = plant.design_form(np.asarray(A, dtype=float), np.asarray(B, dtype=float))
    return np.asarray(A_aug, dtype=float), np.asarray(B_aug, dtype=float)


def _interpolate(values: np.ndarray, breakpoints: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Clamped piecewise-linear interpolation of a stack ``values`` (N+1, ...) at points x (k,)."""
    x = np.clip(np.asarray(x, dtype=float), breakpoints[0], breakpoints[-1])
    if breakpoints.size == 1:
        return np.broadcast_to(values[0], x.shape + values.shape[1:]).copy()
    j = np.clip(np.searchsorted(breakpoints, x, side="right") - 1, 0, breakpoints.size - 2)
    s = (x - breakpoints[j]) / (breakpoints[j + 1] - breakpoints[j])
    s = s.reshape(s.shape + (1,) * (values.ndim - 1))
    return (1.0 - s) * values[j] + s * values[j + 1]


def interpolate_gain(breakpoints: Any, gains: Any, p_hat: Any) -> np.ndarray:
    """The scheduled gain ``K(p̂)``: linear interpolation of the ``K_j`` after clamping ``p̂``.

    Parameters
    ----------
    breakpoints : array_like, shape (N+1,)
        Strictly increasing ``b_0 < ... < b_N`` (a single breakpoint: a constant gain).
    gains : array_like, shape (N+1, m, n)
        ``K_j`` at each breakpoint.
    p_hat : float or array_like, shape (k,)
        The measured parameter value(s).

    Returns
    -------
    ndarray, shape (m, n), or (k, m, n) for an array of `p_hat`
        ``(1 − s) K_j + s K_{j+1}`` with ``s = (p̂_c − b_j)/(b_{j+1} − b_j)``, ``p̂_c`` the value
        clamped to ``[b_0, b_N]`` and j its segment; exactly ``K_j`` at ``b_j``.
    """
    b = _breakpoints(breakpoints, minimum=1)
    K = _gains(gains, b.size)
    x = np.asarray(p_hat, dtype=float)
    if x.ndim > 1:
        raise ValueError(f"p_hat must be a number or a 1-D array, found shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("p_hat must be finite")
    out = _interpolate(K, b, np.atleast_1d(x))
    return out[0] if x.ndim == 0 else out


def schedule_grid(breakpoints: Any, refine: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The p-grid of the checks: each segment split into ``4·refine`` equal sub-intervals, ends included.

    Parameters
    ----------
    breakpoints : array_like, shape (N+1,)
    refine : int
        >= 1.

    Returns
    -------
    p : ndarray, shape (N·(4·refine + 1),)
        Segment by segment; the ends are the breakpoints exactly, so an interior breakpoint
        appears twice (once per adjacent segment).
    segment : ndarray of int, same shape
        The segment j of each point.
    s : ndarray, same shape
        The position ``(p − b_j)/(b_{j+1} − b_j)`` in [0, 1].
    """
    b = _breakpoints(breakpoints)
    if isinstance(refine, bool) or not isinstance(refine, (int, np.integer)) or refine < 1:
        raise ValueError(f"refine must be an integer >= 1, found {refine!r}")
    count = 4 * int(refine)
    s_one = np.linspace(0.0, 1.0, count + 1)
    n_seg = b.size - 1
    segment = np.repeat(np.arange(n_seg), count + 1)
    s = np.tile(s_one, n_seg)
    p = (1.0 - s) * b[segment] + s * b[segment + 1]
    p[s == 0.0] = b[segment[s == 0.0]]
    p[s == 1.0] = b[segment[s == 1.0] + 1]
    return p, segment, s


def _other_grid(plant: Any, column: int, other_points: int | Mapping[str, int] | None) -> np.ndarray:
    """Rows of parameter values over the other parameters' grid; the scheduled column is left 0.

    A varying parameter gets ``np.linspace(lower, upper, c)`` with ``c`` from `other_points`
    (an int for all, or a mapping by name) or ``2·samples − 1``; ``c = 1`` means its nominal.
    A fixed parameter takes its one value.
    """
    if isinstance(other_points, Mapping):
        unknown = set(other_points) - set(plant.names)
        if unknown:
            raise ValueError(f"other_points names unknown parameters {sorted(unknown)}")
    axes = []
    for k, par in enumerate(plant.parameters):
        if k == column:
            axes.append(np.array([0.0]))
            continue
        lo, hi = (float(v) for v in par.range)
        if not lo < hi:
            axes.append(np.array([lo]))
            continue
        if other_points is None:
            count = 2 * int(par.samples) - 1
        elif isinstance(other_points, Mapping):
            count = int(other_points.get(par.name, 2 * int(par.samples) - 1))
        else:
            count = int(other_points)
        if count < 1:
            raise ValueError(f"other_points for {par.name!r} must be >= 1, found {count}")
        axes.append(np.linspace(lo, hi, count) if count > 1 else np.array([float(par.nominal)]))
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in mesh], axis=1).reshape(-1, len(axes))


def _p_hat_corners(p: float, delta: float, breakpoints: np.ndarray) -> np.ndarray:
    """The ``p̂`` to check at p: ends of ``[p − δ, p + δ]`` clamped, and breakpoints strictly inside."""
    lo, hi = p - delta, p + delta
    ends = np.clip([lo, hi], breakpoints[0], breakpoints[-1])
    inside = breakpoints[(breakpoints > lo) & (breakpoints < hi)]
    return np.unique(np.concatenate([ends, inside]))


def _nonnegative(name: str, value: Any) -> float:
    v = float(value)
    if not (np.isfinite(v) and v >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0, found {value!r}")
    return v


# --- the certificate's condition --------------------------------------------------------------------------------


def schedule_condition_margin(plant: Any, parameter: str, breakpoints: Any, gains: Any, P: Any, *, rate: float,
                              delta: float, decay: float = 0.0, refine: int = 4,
                              other_points: int | Mapping[str, int] | None = None) -> dict[str, Any]:
    """Largest eigenvalue of the scheduled certificate's decay inequality over a grid (normalized).

    Parameters
    ----------
    plant : UncertainPlant
    parameter : str
        The measured, scheduled parameter p.
    breakpoints : array_like, shape (N+1,)
        ``b_0 < ... < b_N``, N >= 1.
    gains : array_like, shape (N+1, m, n)
        ``K_j`` (``u = −K(p̂) x`` on the design form).
    P : array_like, shape (N+1, n, n)
        ``P_j``; their symmetric parts are used (the asymmetry is reported).
    rate : float
        ν >= 0, the bound on ``|ṗ|`` (p's unit per second).
    delta : float
        δ >= 0, the bound on ``|p̂ − p|``.
    decay : float
        α >= 0 (1/s).
    refine : int
        Each segment is split into ``4·refine`` equal sub-intervals, ends included
        (:func:`schedule_grid`).
    other_points : int or mapping of str to int, optional
        Grid points of each other varying parameter (an int for all, or by name); default
        ``2·samples − 1`` each (``Parameter.samples``); 1 puts it at its nominal.

    Returns
    -------
    dict
        ``max_eig``
            ``max λ_max(A_clᵀP(p) + P(p)A_cl + ṗD_j + 2αP(p)) / max_j ‖P_j‖₂`` over every check.
        ``min_P_eig``
            ``min λ_min(P(p)) / max_j ‖P_j‖₂`` over the p-grid (exact: λ_min of a segment's
            P(p) is concave in p, so its minimum is at a breakpoint, which the grid holds).
        ``checks``
            The number of (p, q, p̂, ṗ) combinations evaluated; an interior breakpoint counts
            once per adjacent segment, ``ṗ`` takes 2 values (1 when ν = 0).
        ``worst``
            ``{'p', 'segment', 'q' (dict name -> value of the other parameters), 'p_hat',
            'p_dot'}`` where ``max_eig`` was attained.
        ``certified``
            ``max_eig < 0 and min_P_eig > 0``.
        ``scale``
            ``max_j ‖P_j‖₂``, the normalization.
        ``asymmetry``
            ``max_j ‖P_j − P_jᵀ‖₂ / scale``.
        ``p_points``, ``q_points``
            Sizes of the p-grid (with repeated interior breakpoints) and of the q-grid.

    Raises
    ------
    ValueError
        On shapes that do not match the plant, non-increasing breakpoints, a negative rate,
        δ or α, or P = 0.
    """
    b, K, column = _check_plant_schedule(plant, parameter, breakpoints, gains)
    rate = _nonnegative("rate", rate)
    delta = _nonnegative("delta", delta)
    decay = _nonnegative("decay", decay)
    n = K.shape[2]
    Pj = np.asarray(P, dtype=float)
    if Pj.shape != (b.size, n, n):
        raise ValueError(f"P must have shape ({b.size}, {n}, {n}), found {Pj.shape}")
    if not np.all(np.isfinite(Pj)):
        raise ValueError("P must be finite")
    P_sym = 0.5 * (Pj + np.swapaxes(Pj, 1, 2))
    scale = float(max(np.linalg.norm(P_sym[j], 2) for j in range(b.size)))
    if scale == 0.0:
        raise ValueError("P is zero: nothing to certify with")
    asymmetry = float(max(np.linalg.norm(Pj[j] - Pj[j].T, 2) for j in range(b.size))) / scale
    D = (P_sym[1:] - P_sym[:-1]) / np.diff(b)[:, None, None]

    p_grid, segment, s = schedule_grid(b, refine)
    P_grid = (1.0 - s)[:, None, None] * P_sym[segment] + s[:, None, None] * P_sym[segment + 1]
    min_P = float(np.linalg.eigvalsh(P_grid)[:, 0].min()) / scale

    q_rows = _other_grid(plant, column, other_points)
    n_q = q_rows.shape[0]
    p_dots = np.array([-rate, rate]) if rate > 0 else np.array([0.0])

    best = -np.inf
    worst: dict[str, Any] = {}
    checks = 0
    for i, p in enumerate(p_grid):
        rows = q_rows.copy()
        rows[:, column] = p
        A, B = _design_matrices(plant, rows)                  # (n_q, n, n), (n_q, n, m)
        p_hats = _p_hat_corners(float(p), delta, b)
        K_hat = _interpolate(K, b, p_hats)                    # (h, m, n)
        A_cl = A[None] - B[None] @ K_hat[:, None]             # (h, n_q, n, n)
        M = np.swapaxes(A_cl, -1, -2) @ P_grid[i]
        base = M + np.swapaxes(M, -1, -2) + 2.0 * decay * P_grid[i]
        for p_dot in p_dots:
            L = base + p_dot * D[segment[i]]
            lam = np.linalg.eigvalsh(L)[..., -1]              # (h, n_q)
            checks += lam.size
            k = int(np.argmax(lam))
            if lam.flat[k] > best:
                best = float(lam.flat[k])
                h, qi = np.unravel_index(k, lam.shape)
                worst = {"p": float(p), "segment": int(segment[i]),
                         "q": {name: float(q_rows[qi, c]) for c, name in enumerate(plant.names) if c != column},
                         "p_hat": float(p_hats[h]), "p_dot": float(p_dot)}
    max_eig = best / scale
    return {"max_eig": max_eig, "min_P_eig": min_P, "checks": int(checks), "worst": worst,
            "certified": bool(max_eig < 0.0 and min_P > 0.0), "scale": scale, "asymmetry": asymmetry,
            "p_points": int(p_grid.size), "q_points": int(n_q)}


# --- time-varying and frozen loops -------------------------------------------------------------------------------


def scheduled_floquet_growth(plant: Any, parameter: str, breakpoints: Any, gains: Any, rate: float, *,
                             bias: float = 0.0, at: Mapping[str, float] | None = None, n_ramp: int = 200) -> float:
    """Floquet growth rate of the scheduled loop while p sweeps its range as a triangle wave.

    ``p(t)`` rises from ``b_0`` to ``b_N`` at ``ṗ = +rate`` and falls back at ``−rate`` (no
    dwell): period ``T = 2 (b_N − b_0)/rate``. Each ramp is cut into `n_ramp` equal steps,
    p held at each step's midpoint; the loop ``ẋ = (A(p, q) − B(p, q) K(clamp(p + bias))) x``
    is integrated exactly per step (``scipy.linalg.expm``) and the monodromy matrix Φ is
    the ordered product over one period.

    Parameters
    ----------
    plant : UncertainPlant
    parameter : str
        The scheduled parameter.
    breakpoints : array_like, shape (N+1,)
    gains : array_like, shape (N+1, m, n)
    rate : float
        ``|ṗ|`` > 0 (p's unit per second).
    bias : float
        A constant measurement error: the gain is ``K(p + bias)`` (clamped).
    at : mapping of str to float, optional
        Values of the other parameters (missing ones: the plant's nominal).
    n_ramp : int
        Steps per ramp (>= 1).

    Returns
    -------
    float
        ``log ρ(Φ) / T`` in 1/s (−inf when Φ is nilpotent). Positive: the loop grows along this
        trajectory, so no Lyapunov certificate exists at this rate (and bias, if ``|bias| <= δ``).
        A product is renormalized at every step, so slow rates do not underflow.
    """
    b, K, column = _check_plant_schedule(plant, parameter, breakpoints, gains)
    rate = float(rate)
    if not (np.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be a finite number > 0, found {rate!r}")
    bias = float(bias)
    if not np.isfinite(bias):
        raise ValueError("bias must be finite")
    if isinstance(n_ramp, bool) or not isinstance(n_ramp, (int, np.integer)) or n_ramp < 1:
        raise ValueError(f"n_ramp must be an integer >= 1, found {n_ramp!r}")
    values = dict(plant.nominal)
    for name, v in (at or {}).items():
        if name not in values:
            raise ValueError(f"at names an unknown parameter {name!r}")
        if name == parameter:
            raise ValueError(f"at must not fix the scheduled parameter {parameter!r}")
        values[name] = float(v)
    width = float(b[-1] - b[0])
    t_ramp = width / rate
    h = t_ramp / n_ramp
    up = b[0] + (np.arange(n_ramp) + 0.5) * (width / n_ramp)
    p_seq = np.concatenate([up, up[::-1]])
    rows = np.tile(np.array([values[name] for name in plant.names], dtype=float), (p_seq.size, 1))
    rows[:, column] = p_seq
    A, B = _design_matrices(plant, rows)
    A_cl = A - B @ _interpolate(K, b, p_seq + bias)
    steps = scipy.linalg.expm(A_cl * h)                       # (2·n_ramp, n, n)
    phi = np.eye(A_cl.shape[-1])
    log_scale = 0.0
    for E in steps:
        phi = E @ phi
        c = float(np.linalg.norm(phi, np.inf))
        if c == 0.0:
            return -np.inf
        phi /= c
        log_scale += np.log(c)
    rho = float(np.max(np.abs(np.linalg.eigvals(phi))))
    if rho == 0.0:
        return -np.inf
    return (np.log(rho) + log_scale) / (2.0 * t_ramp)


def frozen_spectral_abscissa(plant: Any, parameter: str, breakpoints: Any, gains: Any, *, delta: float = 0.0,
                             points: int | None = None,
                             other_points: int | Mapping[str, int] | None = None) -> float:
    """Largest real part of the eigenvalues of the frozen scheduled loops (a necessary condition).

    Over p on a grid of ``[b_0, b_N]``, q on the other parameters' grid and ``p̂`` at the
    corners of the certificate's check (ends of ``[p − δ, p + δ]`` clamped, and breakpoints
    strictly inside), ``max Re λ(A(p, q) − B(p, q) K(p̂))``. A frozen loop with ``Re λ >= 0``
    rules out every certificate; the converse does not hold (and between the corners the
    eigenvalues are not affine in ``p̂``: this is a sample).

    Parameters
    ----------
    plant : UncertainPlant
    parameter : str
    breakpoints : array_like, shape (N+1,)
    gains : array_like, shape (N+1, m, n)
    delta : float
        δ >= 0.
    points : int, optional
        ``points`` equally spaced values of p over ``[b_0, b_N]`` plus every breakpoint;
        default the certificate's grid (:func:`schedule_grid` with refine = 4: 16
        sub-intervals per segment).
    other_points : int or mapping of str to int, optional
        As for :func:`schedule_condition_margin`.

    Returns
    -------
    float
        1/s.
    """
    b, K, column = _check_plant_schedule(plant, parameter, breakpoints, gains)
    delta = _nonnegative("delta", delta)
    if points is None:
        p_grid = np.unique(schedule_grid(b, 4)[0])
    else:
        if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 2:
            raise ValueError(f"points must be an integer >= 2, found {points!r}")
        p_grid = np.unique(np.concatenate([np.linspace(b[0], b[-1], int(points)), b]))
    q_rows = _other_grid(plant, column, other_points)
    worst = -np.inf
    for p in p_grid:
        rows = q_rows.copy()
        rows[:, column] = p
        A, B = _design_matrices(plant, rows)
        K_hat = _interpolate(K, b, _p_hat_corners(float(p), delta, b))
        A_cl = A[None] - B[None] @ K_hat[:, None]
        worst = max(worst, float(np.linalg.eigvals(A_cl).real.max()))
    return worst
