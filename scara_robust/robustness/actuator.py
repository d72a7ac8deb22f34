"""Actuator limits: the initial errors from which a certified design keeps every input within its limit.

A design certified by a common quadratic Lyapunov function ``V = xᵀPx`` (``V̇ <= 0`` on every
closed loop ``Ā_v = A_v − B_vK`` of the uncertainty set, hence along every trajectory of the
time-varying plant inside it) makes every ellipsoid ``E(c) = {x : xᵀPx <= c}`` invariant: a
state that starts in ``E(c)`` never leaves it. On ``E(c)`` the input ``u_i = −K_i x`` is at
most ``max_{x ∈ E(c)} |K_i x| = sqrt(c · K_i P⁻¹ K_iᵀ)`` in magnitude, so every input stays
within its limit ``|u_i| <= ū_i`` for all time from every initial state in ``E(c*)``,

    c* = min_i ū_i² / (K_i P⁻¹ K_iᵀ),

and a set of initial errors ``X₀`` (a box, or the convex hull of given points) is certified
within the limits up to the scale ``s* = sqrt(c* / max_{v} vᵀPv)`` (``s·X₀ ⊂ E(c*)``; the
maximum of the convex ``vᵀPv`` over a box is at one of its corners). This is the invariant
ellipsoid argument of Boyd, El Ghaoui, Feron and Balakrishnan (1994), *Linear Matrix
Inequalities in System and Control Theory*, SIAM, §5.2.2 (invariant ellipsoids) and §7.2.3
(input constraints); Hu and Lin (2001), *Control Systems with Actuator Saturation*,
Birkhäuser, ch. 1. The synthesis with the limits as constraints is
:func:`~scara_robust.synthesize` with ``input_limits`` and ``initial_errors``.

The certificate is a sufficient condition: "not certified" does not say the limit is
exceeded, only that this P cannot prove it is not.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_closed_loops, check_real, check_symmetric, describe
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..model.plant import Signal, UncertainPlant
from ..results import AnalysisResult
from .lmi import decay_floor, decay_rate

__all__ = ["InputLimitCertificate", "input_limit_certificate", "initial_error_vertices", "peak_inputs",
           "step_initial_errors", "MAX_BOX_CORNERS"]

Array = NDArray[np.float64]

#: Largest number of nonzero half-widths of a box of initial errors (its 2^k corners are
#: enumerated: ``max vᵀPv`` over a box is attained at a corner).
MAX_BOX_CORNERS = 16


def step_initial_errors(plant: UncertainPlant, size: float = 1.0) -> Array:
    """The initial errors of a step of every reference from rest, on the PID form's state.

    ``x = [∫e, e, ė]`` with ``e(0) = size`` (output unit), ``∫e = ė = 0``: the box of
    half-widths that :func:`input_limit_certificate` takes for "a step of `size`".

    Parameters
    ----------
    plant : UncertainPlant
        A plant in the PID form (``form = 'pid'``).
    size : float
        The step, in the outputs' unit (> 0).

    Returns
    -------
    ndarray, shape (n,)
    """
    if plant.form != "pid":
        raise ArgumentValueError("plant", f"must be in the PID form for a reference step, found form {plant.form!r}")
    size = check_real("size", size, positive=True)
    q = plant.n_states // 2
    return np.concatenate([np.zeros(q), np.full(q, size), np.zeros(q)])


def initial_error_vertices(initial_errors: ArrayLike, n: int) -> Array:
    """The points whose convex hull is a set of initial errors.

    Parameters
    ----------
    initial_errors : array_like, shape (n,) or (k, n)
        Shape (n,): the half-widths of the box ``{x : |x_j| <= h_j}`` in each state's unit
        (``x = [∫e, e, ė]``: rad·s, rad, rad/s for a joint), >= 0, zeros allowed (that
        state starts at 0). Shape (k, n): the points themselves (k >= 1).
    n : int
        States of the design form.

    Returns
    -------
    ndarray, shape (k, n)
        For a box, its corners over the nonzero half-widths (``2^(nonzero)``; the origin
        alone for an all-zero box).

    Raises
    ------
    ArgumentValueError
        For a negative half-width, a wrong shape, or a box of more than
        :data:`MAX_BOX_CORNERS` nonzero half-widths (pass its points instead).

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.initial_error_vertices([0.0, 0.1, 0.0], 3).tolist()
    [[0.0, -0.1, 0.0], [0.0, 0.1, 0.0]]
    """
    arr = check_array("initial_errors", initial_errors)
    if arr.ndim == 2:
        if arr.shape[1] != n or arr.shape[0] == 0:
            raise ArgumentValueError("initial_errors", f"must have shape ({n},) (half-widths of a box) or (k, {n}) "
                                                       f"(points), found shape {arr.shape}")
        return np.array(arr, dtype=float)
    if arr.shape != (n,):
        raise ArgumentValueError("initial_errors", f"must have shape ({n},) (half-widths of a box) or (k, {n}) "
                                                   f"(points), found shape {arr.shape}")
    if np.any(arr < 0):
        j = int(np.argmax(arr < 0))
        raise ArgumentValueError("initial_errors", f"half-widths must be >= 0 (in each state's unit), found "
                                                   f"initial_errors[{j}] = {arr[j]:g}")
    nonzero = np.flatnonzero(arr)
    if nonzero.size > MAX_BOX_CORNERS:
        raise ArgumentValueError("initial_errors", f"a box of {nonzero.size} nonzero half-widths has 2^{nonzero.size} "
                                                   f"corners, more than 2^{MAX_BOX_CORNERS}: pass the points (k, {n})")
    k = int(nonzero.size)
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=k)), dtype=float).reshape(2**k, k)
    out = np.zeros((signs.shape[0], n))
    out[:, nonzero] = signs * arr[nonzero]
    return out


def input_limits_of(name: str, u_max: ArrayLike, m: int) -> Array:
    """`u_max` as one limit per input, shape (m,), each > 0 (``inf``: none), or raise naming `name`."""
    arr = check_array(name, u_max, finite=False)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size not in (1, m)):
        raise ArgumentValueError(name, f"must be one limit or one per input ({m}), in the inputs' units, found "
                                       f"shape {arr.shape}")
    arr = np.broadcast_to(arr, (m,)).astype(float)
    bad = np.isnan(arr) | (arr <= 0)
    if bad.any():
        j = int(np.argmax(bad))
        raise ArgumentValueError(name, f"must be > 0 (inf: no limit) in the input's unit, found {name}[{j}] = "
                                       f"{arr[j]:g}")
    return arr


@dataclass(frozen=True)
class InputLimitCertificate(AnalysisResult):
    """The initial errors a design's Lyapunov function certifies within the input limits.

    Attributes
    ----------
    status : str
        ``'certified'`` (the initial-error set lies in ``E(c*)``), ``'not certified'``
        (only ``s*`` times it does, ``s* < 1``), ``'not a Lyapunov function'`` (the closed
        loops given do not verify ``V̇ < 0``: no ellipsoid is proven invariant) or
        ``'P not positive definite'``.
    limits : ndarray, shape (m,)
        ``ū_i`` of each input, in its unit (``inf``: no limit).
    level : float
        ``c* = min_i ū_i² / (K_i P⁻¹ K_iᵀ)``: the largest invariant ellipsoid
        ``{xᵀPx <= c*}`` on which every ``|u_i| <= ū_i``, in V's unit (``inf`` if no
        limited input moves; NaN when P is not positive definite).
    initial_level : float
        ``max_v vᵀPv`` over the initial-error set: the smallest invariant ellipsoid holding it.
    scale : float
        ``s* = sqrt(c* / initial_level)``: the set scaled by any ``s <= s*`` is certified
        within the limits (``inf`` for the zero set).
    binding_input : int or None
        The input that sets ``c*`` (None when no limited input moves).
    peaks : ndarray, shape (m,)
        The certified bound on ``|u_i(t)|`` for all t >= 0 from the given set,
        ``sqrt(initial_level · K_i P⁻¹ K_iᵀ)``, in each input's unit. A bound: the real
        peak can be lower.
    unit_level_peaks : ndarray, shape (m,)
        ``sqrt(K_i P⁻¹ K_iᵀ)``: the largest ``|u_i|`` on ``E(1)``, in the input's unit per
        square root of V's unit.
    decay_rate : float
        numpy's verified decay rate of V on the closed loops given, 1/s (``V̇ <= −2αV``);
        NaN when none were given (then the certificate assumes V is a Lyapunov function).
    n_vertices : int
        Points of the initial-error set checked (a box's corners).
    input_names, input_units : tuple of str
        The inputs' names and units, for the message and :meth:`to_pandas`.
    """

    status: str
    limits: Array
    level: float
    initial_level: float
    scale: float
    binding_input: int | None
    peaks: Array
    unit_level_peaks: Array
    decay_rate: float
    n_vertices: int
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]

    units: ClassVar[dict[str, str]] = {"decay_rate": "1/s"}

    @property
    def certified(self) -> bool:
        """True when the whole initial-error set is certified within the limits (``scale >= 1``)."""
        return bool(self.status == "certified")

    @property
    def lyapunov_checked(self) -> bool:
        """True when the decrease of V was verified on closed loops (not assumed)."""
        return not math.isnan(self.decay_rate)

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not certified'``."""
        return "certified" if self.certified else "not certified"

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.status == "P not positive definite":
            return "P is not positive definite: xᵀPx is no Lyapunov function, nothing is certified"
        if self.status == "not a Lyapunov function":
            return (f"V = xᵀPx does not decrease on every closed loop given (decay rate {self.decay_rate:.3g} 1/s): "
                    "no ellipsoid is proven invariant, so no input bound is certified")
        assumed = "" if self.lyapunov_checked else (
            " (assuming V = xᵀPx decreases along the closed loop: pass closed_loops to check it)")
        if self.binding_input is None:
            return f"certified within the limits for any initial error: no limited input moves{assumed}"
        b = self.binding_input
        name, unit = self.input_names[b], (f" {self.input_units[b]}" if self.input_units[b] else "")
        bound = f"|{name}| <= {self.peaks[b]:.4g}{unit} (limit {self.limits[b]:g}{unit})"
        if self.certified:
            return (f"certified within the limits for these initial errors: {bound} for all t on the invariant "
                    f"ellipsoid through the worst initial error; the set may grow by s* = {self.scale:.4g}{assumed}")
        return (f"certified within the limits for initial errors up to s* = {self.scale:.4g} × the given set: from "
                f"the whole set the certified bound is only |{name}| <= {self.peaks[b]:.4g}{unit} > limit "
                f"{self.limits[b]:g}{unit} (a bound from this P, not a proof that the limit is exceeded){assumed}")

    def to_pandas(self) -> pd.Series:
        """The result as one row, with each input's limit and certified peak (``peak current [A]``).

        Returns
        -------
        pandas.Series
        """
        row = super().to_pandas()
        if self.binding_input is not None:
            row["binding_input"] = self.input_names[self.binding_input]
        for k, (name, unit) in enumerate(zip(self.input_names, self.input_units)):
            label = f"{name} [{unit}]" if unit else name
            row[f"limit {label}"] = float(self.limits[k])
            row[f"peak {label}"] = float(self.peaks[k])
        return row


def input_limit_certificate(
    K: ArrayLike,
    P: ArrayLike,
    u_max: ArrayLike,
    initial_errors: ArrayLike,
    *,
    closed_loops: ArrayLike | None = None,
    inputs: Sequence[Signal] | None = None,
) -> InputLimitCertificate:
    """The initial errors from which ``V = xᵀPx`` certifies every input within its limit.

    With V a Lyapunov function of the closed loop (decreasing along every trajectory of the
    uncertain set), each ellipsoid ``E(c) = {x : xᵀPx <= c}`` is invariant and on it
    ``max |K_i x| = sqrt(c · K_i P⁻¹ K_iᵀ)``. The largest level on which every input stays
    within its limit is::

        c* = min_i ū_i² / (K_i P⁻¹ K_iᵀ),

    in LMI form the largest c with ``[[ū_i², K_i X], [X K_iᵀ, X]] ⪰ 0`` for ``X = c P⁻¹``
    (a Schur complement; Boyd et al. 1994, §7.2.3), which for a fixed P this closed form
    solves exactly. The set ``s·X₀`` lies in ``E(c*)`` iff ``s² max_v vᵀPv <= c*`` (the
    maximum of a convex quadratic over the hull of the points v is at one of them), so
    ``s* = sqrt(c* / max_v vᵀPv)``. For a plant without position stiffness (the DC motor,
    ``A_q = 0``), a step r of the reference from rest is the initial error ``e(0) = r``.

    Parameters
    ----------
    K : array_like, shape (m, n)
        Gain of ``u = −Kx`` (a :class:`~scara_robust.Design`'s ``K``), input unit per state unit.
    P : array_like, shape (n, n)
        The Lyapunov matrix of the certificate (a design's ``P`` that
        :func:`~scara_robust.vertex_certificate` certifies, a :class:`~scara_robust.Synthesis`'s
        ``P``, an :class:`~scara_robust.LMICertificate`'s ``P``); symmetric.
    u_max : float or array_like, shape (m,)
        ``ū_i > 0`` per input, in its unit (``inf``: no limit; a plant's
        :attr:`~scara_robust.UncertainPlant.input_limits`).
    initial_errors : array_like, shape (n,) or (k, n)
        Half-widths of a box of initial errors, or its points (:func:`initial_error_vertices`).
    closed_loops : array_like, shape (V, n, n), optional
        ``A_v − B_vK`` at the vertices of the uncertainty set: numpy verifies ``V̇ < 0`` on
        them (decay rate above the LMI module's ``decay_floor``) and the
        certificate holds only then. Without them, V is assumed to be a Lyapunov function.
    inputs : sequence of Signal, optional
        Names and units of the inputs for the message (a plant's ``inputs``).

    Returns
    -------
    InputLimitCertificate

    Raises
    ------
    ArgumentValueError
        Naming the argument: a limit <= 0, shapes that do not agree, a P that is not
        symmetric.

    References
    ----------
    Boyd, El Ghaoui, Feron, Balakrishnan, *Linear Matrix Inequalities in System and Control
    Theory*, SIAM 1994, §5.2.2 and §7.2.3. Hu and Lin, *Control Systems with Actuator
    Saturation: Analysis and Design*, Birkhäuser 2001.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> cert = sr.input_limit_certificate([[1.0, 1.0]], np.eye(2), 2.0, [0.5, 0.5])
    >>> round(cert.level, 6), round(cert.scale, 6), cert.certified   # c* = 4/2, s* = sqrt(2/0.5)
    (2.0, 2.0, True)
    """
    K = check_array("K", K, ndim=2)
    m, n = K.shape
    if m == 0 or n == 0:
        raise ArgumentValueError("K", f"must have shape (m, n) with m, n >= 1, found {K.shape}")
    P = check_array("P", P, shape=(n, n))
    P = check_symmetric("P", P)
    limits = input_limits_of("u_max", u_max, m)
    vertices = initial_error_vertices(initial_errors, n)
    if inputs is None:
        names, units = tuple(f"u{i}" for i in range(m)), ("",) * m
    else:
        signals = tuple(inputs)
        if len(signals) != m or not all(isinstance(s, Signal) for s in signals):
            raise ArgumentTypeError("inputs", f"must be {m} Signal(name, unit), found {describe(signals)}")
        names, units = tuple(s.name for s in signals), tuple(s.unit for s in signals)
    decay = math.nan
    loops = None
    if closed_loops is not None:
        loops = check_closed_loops("closed_loops", closed_loops)
        if loops.shape[1] != n:
            raise ArgumentValueError("closed_loops", f"must have shape (V, {n}, {n}), found {loops.shape}")
    nan_m = np.full(m, math.nan)
    w, V = np.linalg.eigh(P)
    # positive definite beyond rounding: a symmetric eigensolver is backward stable to ~n·eps·‖P‖
    if w[0] <= 10 * n * np.finfo(float).eps * max(abs(w[-1]), 1e-300):
        return InputLimitCertificate("P not positive definite", limits, math.nan, math.nan, math.nan, None, nan_m,
                                     nan_m, decay, len(vertices), names, units)
    if loops is not None:
        decay = decay_rate(loops, P)
    # sqrt(K_i P⁻¹ K_iᵀ) = ‖K_i V Λ^{-1/2}‖
    unit_peaks = np.linalg.norm((K @ V) / np.sqrt(w), axis=1)
    initial = float(max(np.einsum("ki,ij,kj->k", vertices, P, vertices).max(), 0.0))
    limited = np.isfinite(limits) & (unit_peaks > 0)
    with np.errstate(divide="ignore"):
        levels = np.where(limited, limits**2 / np.where(unit_peaks > 0, unit_peaks**2, 1.0), math.inf)
    binding = int(np.argmin(levels)) if limited.any() else None
    level = float(levels.min())
    scale = math.inf if initial == 0.0 or math.isinf(level) else math.sqrt(level / initial)
    peaks = math.sqrt(initial) * unit_peaks
    if loops is not None and not decay >= decay_floor(loops):
        status = "not a Lyapunov function"
    else:
        status = "certified" if scale >= 1.0 else "not certified"
    return InputLimitCertificate(status, limits, level, initial, scale, binding, peaks, unit_peaks, decay,
                                 len(vertices), names, units)


def peak_inputs(run: Any) -> Array:
    """Each input's peak ``max_t |u_i(t)|`` of a simulated run.

    Parameters
    ----------
    run : PlantRun or array_like, shape (m, k)
        A run of :func:`~scara_robust.simulate_plant` (its ``u``, the controller outputs in
        the inputs' units, shape (m, k)), or such an array.

    Returns
    -------
    ndarray, shape (m,)
        In the inputs' units; ``inf`` for an input with a non-finite sample (a diverged run).

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> sr.peak_inputs(np.array([[0.5, -2.0, 1.0]])).tolist()
    [2.0]
    """
    u = check_array("run", getattr(run, "u", run), finite=False)
    if u.ndim == 1:
        u = u[None]
    if u.ndim != 2 or u.shape[1] == 0:
        raise ArgumentValueError("run", f"must be a run (its u) or an array of shape (m, k), found shape {u.shape}")
    finite = np.isfinite(u).all(axis=1)
    return np.where(finite, np.abs(np.where(np.isfinite(u), u, 0.0)).max(axis=1), math.inf)
