"""Worst-case loop margins of a gain over an uncertain set's frozen plants: disk margin and delay margin.

Each frozen plant ``(A_p, B_p)`` of the set is closed by the gain, ``u = −Kx``, and broken at
one plant input i at a time with the other loops closed. The loop transfer seen there is::

    L_i(s) = k_i (sI − A_p + B_{p,−i} K_{−i})⁻¹ b_{p,i}

(k_i the i-th row of K, b_{p,i} the i-th column of B_p, the other columns and rows in
``B_{p,−i}``, ``K_{−i}``): negative feedback, ``u_i = −L_i u_i``, so the frozen closed loop
``A_p − B_p K`` has its poles at the zeros of ``1 + L_i``. With the complementary sensitivity
``T_i(s) = k_i (sI − A_p + B_p K)⁻¹ b_{p,i} = L_i/(1 + L_i)`` (one eigendecomposition of the
closed loop gives it at every frequency) the two margins are:

**Disk margin** (symmetric, skew 0; Seiler, Packard and Gahinet 2020): the largest α such
that the loop stays stable for every gain (complex, simultaneous gain and phase) change of
input i in the disk of real-axis intercepts ``[(1 − α/2)/(1 + α/2), (1 + α/2)/(1 − α/2)]``,
``α = 1 / max_ω |S_i(jω) − ½|`` with ``S_i = 1 − T_i``. This is python-control's
``control.disk_margins(L_i, omega)`` for a loop of one input; its gain margin (±dB) and phase
margin (±degrees) follow from α.

**Delay margin**: the smallest delay τ in input i, ``L_i(s)e^{−sτ}``, at which a closed-loop
root reaches the imaginary axis: ``min`` over the gain crossovers ``|L_i(jω_c)| = 1`` of
``φ_c/ω_c``, with ``φ_c = arg L_i(jω_c) + π`` wrapped to (0, 2π]; infinite without a
crossover, 0 for a frozen closed loop that is already unstable. ``|L_i| = 1`` is
``Re T_i = ½``, found by a sign change on the frequency grid and refined by regula falsi
(Illinois) in ``log ω`` to rounding. (python-control's ``stability_margins(L_i,
returnall=True)`` lists the same crossovers, one loop at a time; the tests compare with it.)

Every frozen plant is handled at once with numpy (a call of ``control.disk_margins`` costs
about 60 ms per loop, and the SCARA has 59 081 frozen plants on its fine grid): the peak of
``|S_i − ½|`` is located on the grid and refined by golden-section search around it, the
crossovers are refined as above. The worst plant of each input is then evaluated again with
``control.disk_margins`` on the grid joined with its refined peak frequency, and that call's
α, gain and phase margins are the ones reported. A peak or a pair of crossovers narrower
than the grid's spacing (1/50 decade, 4.7 % in frequency, by default) can be missed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..lyapunov.gain import Design, design_or_none
from ..model.plant import as_model, require_plant
from ..results import AnalysisResult
from .polytope import MAX_BOX_ELEMENTS

__all__ = ["LoopMargins", "worst_loop_margins", "LoopView", "loop_view", "frozen_loop_views"]

Array = NDArray[np.float64]

#: Points per decade of the default frequency grid.
_PER_DECADE = 50
#: The default grid spans [min |λ| / _LOW, _HIGH · max(max |λ|, Σ|residues|)] over the closed loops.
_LOW, _HIGH = 100.0, 10.0
#: A closed loop whose eigenvector matrix is worse conditioned than this is evaluated by solves.
_COND_MAX = 1e8
#: Golden-section iterations: the bracket of two grid steps shrinks by 0.618³⁵ ≈ 5e-8 (the peak's
#: value, flat there, to rounding).
_GOLDEN = 35
#: Largest number of regula-falsi (Illinois) iterations; they stop when every bracket is at rounding.
_FALSI = 60
#: Bytes of the complex work arrays of one chunk of plants on the grid.
_CHUNK_BYTES = 8 * 2**20


@dataclass(frozen=True)
class LoopMargins(AnalysisResult):
    """Worst-case disk and delay margins, input by input, over an uncertain set's frozen plants.

    The loop is broken at one plant input at a time, the other loops closed (module
    docstring). These are margins of the frozen (time-invariant) plants: they say nothing
    of the set's time variation, which the certificates answer.

    Attributes
    ----------
    inputs : tuple of str
        The plant inputs (m), with their units: ``'current [A]'``.
    disk_margin : ndarray, shape (m,)
        The smallest symmetric disk margin α over the frozen plants (0 when a frozen closed
        loop is unstable), as ``control.disk_margins`` gives it at the worst plant:
        ``control.disk_margins(L_i, np.union1d(omega, [disk_frequency[i]]))``.
    gain_margin : ndarray, shape (m,)
        The disk-based gain margin, dB: the loop gain of the input may be multiplied by any
        factor in ``[10^(−g/20), 10^(g/20)]`` (``inf`` for α >= 2).
    gain_range : ndarray, shape (m, 2)
        The disk's real-axis intercepts ``[(1 − α/2)/(1 + α/2), (1 + α/2)/(1 − α/2)]``, as
        ratios (the gain interval; ``[0, inf]`` for α >= 2).
    phase_margin : ndarray, shape (m,)
        The disk-based phase margin, degrees (± that phase at unit gain).
    disk_frequency : ndarray, shape (m,)
        Where ``|S_i(jω) − ½|`` peaks at the worst plant, rad/s (NaN when it is unstable).
    disk_worst : ndarray of int, shape (m,)
        Index of the frozen plant of smallest disk margin (rows of `values`).
    delay_margin : ndarray, shape (m,)
        The smallest delay margin over the frozen plants, s (``inf``: no gain crossover at
        any; 0: a frozen closed loop is unstable).
    delay_frequency : ndarray, shape (m,)
        The gain crossover that sets it, rad/s (NaN when the margin is 0 or infinite).
    delay_worst : ndarray of int, shape (m,)
        Index of the frozen plant of smallest delay margin.
    names : tuple of str
        What identifies a frozen plant: the parameters (a plant), the interval elements
        (a box's corners, ``'ΔA[4, 3]'``), none (a polytope's vertices, by index).
    coordinate_units : tuple of str
        The unit of each of `names` (``''`` for an element of a box).
    values : ndarray, shape (N, len(names))
        The coordinates of each frozen plant, in their units.
    plant_disk_margins : ndarray, shape (N, m)
        Each frozen plant's disk margin α, by numpy (the formula above, the peak refined).
    plant_delay_margins : ndarray, shape (N, m)
        Each frozen plant's delay margin, s.
    max_real_pole : ndarray, shape (N,)
        Largest real part of each frozen closed loop's eigenvalues, 1/s.
    omega : ndarray, shape (F,)
        The frequency grid, rad/s.
    frozen_set : str
        Which frozen plants were used.
    seconds : float
        Wall time of the computation, s.
    """

    inputs: tuple[str, ...]
    disk_margin: Array
    gain_margin: Array
    gain_range: Array
    phase_margin: Array
    disk_frequency: Array
    disk_worst: NDArray[np.int_]
    delay_margin: Array
    delay_frequency: Array
    delay_worst: NDArray[np.int_]
    names: tuple[str, ...]
    coordinate_units: tuple[str, ...]
    values: Array
    plant_disk_margins: Array
    plant_delay_margins: Array
    max_real_pole: Array
    omega: Array
    frozen_set: str
    seconds: float

    units: ClassVar[dict[str, str]] = {"seconds": "s"}

    @property
    def n_plants(self) -> int:
        """N, the number of frozen plants."""
        return int(self.max_real_pole.shape[0])

    @property
    def certified(self) -> bool:
        """True when every frozen closed loop is stable (every delay margin > 0), else False.

        A frozen plant is a constant member of the set, so an unstable one disproves
        robust stability; stable frozen loops do not prove it for a time-varying set.
        """
        return bool(np.all(self.max_real_pole < 0))

    @property
    def verdict(self) -> str:
        """``'frozen loops stable'`` or ``'frozen loop unstable'``."""
        return "frozen loops stable" if self.certified else "frozen loop unstable"

    @property
    def status(self) -> str:
        """The verdict (no solver runs)."""
        return self.verdict

    @property
    def disk_worst_values(self) -> Array:
        """The coordinates of each input's worst plant for the disk margin, shape (m, len(names))."""
        return np.asarray(self.values[self.disk_worst], dtype=float)

    @property
    def delay_worst_values(self) -> Array:
        """The coordinates of each input's worst plant for the delay margin, shape (m, len(names))."""
        return np.asarray(self.values[self.delay_worst], dtype=float)

    def point(self, index: int) -> str:
        """Frozen plant `index` in words: its varying coordinates with units, or its index.

        Parameters
        ----------
        index : int
            A row of `values`.

        Returns
        -------
        str
        """
        varying = [k for k in range(len(self.names)) if np.ptp(self.values[:, k]) > 0]
        if not varying or len(varying) > 3:
            return f"frozen plant {index}"
        return ", ".join(f"{self.names[k]} = {self.values[index, k]:.4g}"
                         + (f" {self.coordinate_units[k]}" if self.coordinate_units[k] else "") for k in varying)

    @property
    def message(self) -> str:
        """One sentence: the worst disk margin and the worst delay margin, where they are attained."""
        where = f"over the {self.n_plants} frozen plants of {self.frozen_set}"
        if not self.certified:
            k = int(np.argmax(self.max_real_pole))
            return (f"a frozen closed loop is unstable (real part {self.max_real_pole[k]:.4g} 1/s at "
                    f"{self.point(k)}): disk and delay margins 0, {where}")
        i = int(np.argmin(self.disk_margin))
        j = int(np.argmin(self.delay_margin))
        disk = (f"worst disk margin α = {self.disk_margin[i]:.3g} (±{self.gain_margin[i]:.3g} dB, "
                f"±{self.phase_margin[i]:.3g}°) at input {self._name(i)!r} ({self.point(int(self.disk_worst[i]))})")
        if math.isinf(self.delay_margin[j]):
            return f"{disk}; no gain crossover, so no delay destabilizes, {where}"
        return (f"{disk}; delay margin {_duration(float(self.delay_margin[j]))} at input {self._name(j)!r} "
                f"({self.point(int(self.delay_worst[j]))}, crossover {self.delay_frequency[j]:.4g} rad/s), {where}")

    def _name(self, i: int) -> str:
        return self.inputs[i].split(" [")[0]

    def to_pandas(self) -> pd.DataFrame:
        """One row per input: its worst disk margin (with gain and phase margins) and worst delay margin.

        Unlike the one-row table of the other results, a row per plant input.

        Returns
        -------
        pandas.DataFrame
            Columns ``input``, ``disk_margin``, ``gain_margin [dB]``, ``gain_min``,
            ``gain_max`` (ratios), ``phase_margin [deg]``, ``disk_frequency [rad/s]``,
            ``disk_worst`` (plant index), ``disk_worst_at``, ``delay_margin [s]``,
            ``delay_frequency [rad/s]``, ``delay_worst``, ``delay_worst_at``, then
            ``certified`` and ``verdict`` (of the whole set).
        """
        rows = []
        for i, name in enumerate(self.inputs):
            rows.append({
                "input": name,
                "disk_margin": float(self.disk_margin[i]),
                "gain_margin [dB]": float(self.gain_margin[i]),
                "gain_min": float(self.gain_range[i, 0]),
                "gain_max": float(self.gain_range[i, 1]),
                "phase_margin [deg]": float(self.phase_margin[i]),
                "disk_frequency [rad/s]": float(self.disk_frequency[i]),
                "disk_worst": int(self.disk_worst[i]),
                "disk_worst_at": self.point(int(self.disk_worst[i])),
                "delay_margin [s]": float(self.delay_margin[i]),
                "delay_frequency [rad/s]": float(self.delay_frequency[i]),
                "delay_worst": int(self.delay_worst[i]),
                "delay_worst_at": self.point(int(self.delay_worst[i])),
                "certified": self.certified,
                "verdict": self.verdict,
            })
        return pd.DataFrame(rows)


def _duration(tau: float) -> str:
    return f"{tau * 1e3:.3g} ms" if tau < 1.0 else f"{tau:.4g} s"


# --- the frozen plants -----------------------------------------------------------------------


@dataclass(frozen=True)
class _Frozen:
    A: Array
    B: Array
    values: Array
    names: tuple[str, ...]
    units: tuple[str, ...]
    inputs: tuple[str, ...]
    description: str


def _frozen_plants(system: Any, points: Mapping[str, int] | None) -> _Frozen:
    """The frozen plants of `system`: a plant's fine grid, a box's corners, a polytope's vertices."""
    capabilities = getattr(system, "capabilities", None)
    if not isinstance(capabilities, frozenset):
        raise ArgumentTypeError("system", f"must be an UncertainPlant, an UncertainLTVModel or a PolytopicModel, "
                                          f"found {type(system).__name__}")
    if "parameters" in capabilities:
        plant = require_plant("system", system)
        if points is not None and not isinstance(points, Mapping):
            raise ArgumentTypeError("points", f"must be a mapping of parameter name to int, found "
                                              f"{type(points).__name__}")
        grid = {**plant.fine_points(), **dict(points or {})}
        s = plant.samples(grid)
        counts = " × ".join(f"{len(np.unique(s.column(p.name)))} {p.name}" for p in plant.varying) or "1 point"
        which = "its fine grid, 2·samples − 1 per parameter" if points is None else "the grid given"
        return _Frozen(s.A, s.B, s.values, s.names, tuple(p.unit for p in plant.parameters),
                       tuple(f"{u.name} [{u.unit}]" for u in plant.inputs),
                       f"{plant.name!r} on {which} ({counts})")
    if points is not None:
        raise ArgumentValueError("points", "applies to a plant with parameters; a box's corners or a polytope's "
                                           "vertices are its frozen plants")
    model = as_model("system", system)
    inputs = tuple(f"u{i} [1]" for i in range(model.n_inputs))
    if "intervals" in model.capabilities:  # a box: its corners
        elements = model.elements  # type: ignore[union-attr]
        if len(elements) > MAX_BOX_ELEMENTS:
            raise ArgumentValueError("system", f"is a box of 2^{len(elements)} corners, more than the 2^"
                                               f"{MAX_BOX_ELEMENTS} enumerated; pass its plant or a polytope")
        A, B = model.vertex_matrices()
        labels = tuple(el.label for el in elements)
        return _Frozen(A, B, np.asarray(model.vertex_points(), dtype=float), labels, tuple("" for _ in labels),
                       inputs, f"the {A.shape[0]} corners of the box {model.name!r}")
    A, B = model.vertex_matrices()
    return _Frozen(A, B, np.zeros((A.shape[0], 0)), (), (), inputs,
                   f"the {A.shape[0]} vertices of the polytope {model.name!r}")


# --- frequency responses of the closed loops ----------------------------------------------------


class _Loops:
    """``T_i(s) = k_i (sI − A_cl)⁻¹ b_i = Σ_k r_ki/(s − λ_k)`` of every closed loop, from its eigendecomposition.

    A closed loop whose eigenvector matrix V has ``‖V‖_F‖V⁻¹‖_F >= 1e8`` (near-defective)
    is evaluated by linear solves instead of its residues.
    """

    def __init__(self, A: Array, B: Array, K: Array) -> None:
        self.B, self.K = B, K
        self.Acl = A - B @ K
        lam, V = np.linalg.eig(self.Acl)
        self.lam = lam
        n = A.shape[1]
        try:
            Vinv = np.linalg.inv(V)
            cond = np.linalg.norm(V, axis=(1, 2)) * np.linalg.norm(Vinv, axis=(1, 2))
        except np.linalg.LinAlgError:  # an exactly singular V somewhere: one at a time
            Vinv = np.empty_like(V)
            cond = np.full(V.shape[0], np.inf)
            for p, V_p in enumerate(V):
                try:
                    Vinv[p] = np.linalg.inv(V_p)
                    cond[p] = np.linalg.norm(V_p) * np.linalg.norm(Vinv[p])
                except np.linalg.LinAlgError:
                    Vinv[p] = np.eye(n)
        self.solved = ~(np.isfinite(cond) & (cond < _COND_MAX))
        # residues: R[p, k, i] = (K V)[i, k] (V⁻¹ B)[k, i]
        self.R = np.swapaxes(K @ V, 1, 2) * (Vinv @ B)
        self.R[self.solved] = 0.0

    def _solve(self, p: int, s: NDArray[np.complex128]) -> NDArray[np.complex128]:
        """T of plant p at the points s (shape (F,)) by solves, shape (F, m)."""
        M = s[:, None, None] * np.eye(self.Acl.shape[1]) - self.Acl[p]
        X = np.linalg.solve(M, np.broadcast_to(self.B[p].astype(complex), (s.size, *self.B[p].shape)))
        return np.asarray(np.diagonal(self.K @ X, axis1=-2, axis2=-1))

    def grid(self, idx: NDArray[np.int_], s: NDArray[np.complex128], work: NDArray[np.complex128],
             out: NDArray[np.complex128]) -> NDArray[np.complex128]:
        """T of the plants `idx` at the points s (shape (F,)), shape (P, F, m), in the buffers given."""
        P = idx.size
        X, T = work[:P], out[:P]
        np.subtract(s[None, :, None], self.lam[idx][:, None, :], out=X)
        with np.errstate(all="ignore"):
            np.reciprocal(X, out=X)
        np.matmul(X, self.R[idx], out=T)
        for row in np.flatnonzero(self.solved[idx]):
            T[row] = self._solve(int(idx[row]), s)
        return T

    def each(self, idx: NDArray[np.int_], inputs: NDArray[np.int_]) -> Any:
        """``f(ω) -> T``: ``T_{inputs[k]}`` of plant ``idx[k]`` at ``jω_k``, shape (P,), for ω of shape (P,)."""
        lam, R = self.lam[idx], self.R[idx, :, inputs]
        solved = np.flatnonzero(self.solved[idx])

        def at(omega: Array) -> NDArray[np.complex128]:
            with np.errstate(all="ignore"):
                T = (R / (1j * omega[:, None] - lam)).sum(axis=1)
            for row in solved:
                T[row] = self._solve(int(idx[row]), np.array([1j * omega[row]]))[0, inputs[row]]
            return np.asarray(T)

        return at


def _default_grid(loops: _Loops, stable: NDArray[np.bool_]) -> Array:
    lam = np.abs(loops.lam[stable])
    nonzero = lam[lam > 0]
    low = float(nonzero.min()) / _LOW if nonzero.size else 1e-3
    weight = np.abs(loops.R[stable]).sum(axis=1).max(initial=0.0)
    high = _HIGH * max(float(lam.max(initial=0.0)), float(weight), low * _LOW)
    decades = math.log10(high / low)
    return np.logspace(math.log10(low), math.log10(high), max(int(math.ceil(decades * _PER_DECADE)) + 1, 2))


def _golden_max(f: Any, a: Array, b: Array) -> tuple[Array, Array]:
    """Vectorized golden-section search for a maximum of ``f(u)`` on each ``[a, b]``."""
    r = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(_GOLDEN):
        left = fc > fd  # the maximum is in [a, d]: d becomes c; else in [c, b]: c becomes d
        a, b = np.where(left, a, c), np.where(left, d, b)
        x = np.where(left, b - r * (b - a), a + r * (b - a))  # the one new point
        fx = f(x)
        c, d, fc, fd = (np.where(left, x, d), np.where(left, c, x), np.where(left, fx, fd), np.where(left, fc, fx))
    u = 0.5 * (a + b)
    return u, f(u)


def _illinois(f: Any, a: Array, b: Array, fa: Array, fb: Array) -> Array:
    """Vectorized regula falsi (Illinois) for a root of ``f`` in each ``[a, b]``, ``fa·fb <= 0``."""
    side = np.zeros(a.shape, dtype=int)
    best, f_best = np.where(np.abs(fa) <= np.abs(fb), a, b), np.minimum(np.abs(fa), np.abs(fb))
    for _ in range(_FALSI):
        with np.errstate(all="ignore"):
            c = np.where(fb != fa, (a * fb - b * fa) / (fb - fa), 0.5 * (a + b))
        c = np.where(np.isfinite(c) & (c > np.minimum(a, b)) & (c < np.maximum(a, b)), c, 0.5 * (a + b))
        fc = f(c)
        closer = np.abs(fc) < f_best
        best, f_best = np.where(closer, c, best), np.where(closer, np.abs(fc), f_best)
        left = np.sign(fc) == np.sign(fa)  # the root is in [c, b]
        fb = np.where(left & (side == 1), 0.5 * fb, fb)
        fa = np.where(~left & (side == -1), 0.5 * fa, fa)
        a, fa = np.where(left, c, a), np.where(left, fc, fa)
        b, fb = np.where(left, b, c), np.where(left, fb, fc)
        side = np.where(left, 1, -1)
        if np.all((f_best <= 1e-13) | (np.abs(b - a) <= 1e-14 * np.maximum(np.abs(a), 1.0))):
            break
    return np.asarray(best)


def _gain_range(alpha: float) -> tuple[float, float]:
    """The real-axis intercepts ``[γ_min, γ_max]`` of a symmetric disk margin α, as ratios."""
    if alpha <= 0:
        return 1.0, 1.0
    if alpha >= 2:
        return 0.0, math.inf
    return (1 - alpha / 2) / (1 + alpha / 2), (1 + alpha / 2) / (1 - alpha / 2)


def _check_omega(omega: ArrayLike) -> Array:
    grid = check_array("omega", omega, ndim=1)
    if grid.size < 2 or np.any(grid <= 0) or np.any(np.diff(grid) <= 0):
        raise ArgumentValueError("omega", f"must hold >= 2 frequencies > 0 (rad/s), increasing, found "
                                          f"{grid.size} from {grid.min(initial=math.nan):.3g}")
    return grid


def _scan(loops: _Loops, stable: NDArray[np.bool_], grid: Array) -> tuple[Array, Array, NDArray[np.int_], Any]:
    """Every stable loop on the grid: the peak of ``|S − ½|`` (value, frequency, grid index) and the crossovers.

    Returns
    -------
    peak, peak_at : ndarray, shape (N, m)
    peak_k : ndarray of int, shape (N, m)
    crossings : tuple of three int arrays
        Plant, grid index k (a sign change of ``Re T − ½`` between k and k + 1) and input.
    """
    N, n, m = loops.B.shape
    F = grid.size
    peak, peak_at, peak_k = np.zeros((N, m)), np.full((N, m), np.nan), np.zeros((N, m), dtype=int)
    found: list[tuple[NDArray[np.int_], ...]] = []
    stable_idx = np.flatnonzero(stable)
    chunk = max(1, min(stable_idx.size, _CHUNK_BYTES // (16 * F * max(n, m))))
    s_grid = np.asarray(1j * grid, dtype=np.complex128)
    work, out = np.empty((chunk, F, n), dtype=complex), np.empty((chunk, F, m), dtype=complex)
    for lo in range(0, stable_idx.size, chunk):
        idx = stable_idx[lo:lo + chunk]
        T = loops.grid(idx, s_grid, work, out)  # (P, F, m)
        dist = np.abs(0.5 - T)
        k = np.argmax(dist, axis=1)
        peak_k[idx] = k
        peak[idx] = np.take_along_axis(dist, k[:, None, :], axis=1)[:, 0, :]
        peak_at[idx] = grid[k]
        above = T.real > 0.5
        rows, ks, inputs = np.nonzero(above[:, :-1, :] != above[:, 1:, :])
        found.append((idx[rows], ks, inputs))
    crossings = tuple(np.concatenate([f[j] for f in found]) if found else np.zeros(0, dtype=int) for j in range(3))
    return peak, peak_at, peak_k, crossings


def _refine_peaks(loops: _Loops, stable: NDArray[np.bool_], grid: Array, peak: Array, peak_at: Array,
                  peak_k: NDArray[np.int_]) -> None:
    """Golden-section search in log ω on the two grid intervals around each peak (in place)."""
    m = peak.shape[1]
    rows, cols = np.nonzero(np.repeat(stable[:, None], m, axis=1))
    if not rows.size:
        return
    log_grid = np.log(grid)
    k = peak_k[rows, cols]
    T_each = loops.each(rows, cols)

    def distance(u: Array) -> Array:
        return np.asarray(np.abs(0.5 - T_each(np.exp(u))), dtype=float)

    u, value = _golden_max(distance, log_grid[np.maximum(k - 1, 0)], log_grid[np.minimum(k + 1, grid.size - 1)])
    better = value > peak[rows, cols]
    peak[rows[better], cols[better]] = value[better]
    peak_at[rows[better], cols[better]] = np.exp(u[better])


def _delays(loops: _Loops, stable: NDArray[np.bool_], grid: Array, crossings: Any) -> tuple[Array, Array]:
    """Each loop's delay margin (s) and the crossover that sets it (rad/s), shapes (N, m).

    Each crossover ``Re T = ½`` is refined in log ω; ``τ = φ/ω_c`` with ``φ = arg L + π`` in
    (0, 2π], ``L = T/(1 − T)``; the least τ of each loop is kept (``inf`` without a
    crossover, 0 for an unstable loop).
    """
    N, _, m = loops.B.shape
    delay = np.repeat(np.where(stable, math.inf, 0.0)[:, None], m, axis=1)
    delay_at = np.full((N, m), np.nan)
    plants, ks, inputs = crossings
    if not plants.size:
        return delay, delay_at
    log_grid = np.log(grid)
    T_cross = loops.each(plants, inputs)

    def excess(u: Array) -> Array:
        return np.asarray(T_cross(np.exp(u)).real - 0.5)

    a, b = log_grid[ks], log_grid[ks + 1]
    w = np.exp(_illinois(excess, a, b, excess(a), excess(b)))
    T = T_cross(w)
    phase = np.mod(np.angle(T / (1.0 - T)) + np.pi, 2 * np.pi)
    tau = np.where(phase <= 0, 2 * np.pi, phase) / w
    order = np.lexsort((tau, inputs, plants))  # per (plant, input), the least τ first
    plants, inputs, tau, w = plants[order], inputs[order], tau[order], w[order]
    first = np.ones(plants.size, dtype=bool)
    first[1:] = (plants[1:] != plants[:-1]) | (inputs[1:] != inputs[:-1])
    delay[plants[first], inputs[first]] = tau[first]
    delay_at[plants[first], inputs[first]] = w[first]
    return delay, delay_at


def worst_loop_margins(
    system: Any,
    K: Design | ArrayLike,
    *,
    omega: ArrayLike | None = None,
    points: Mapping[str, int] | None = None,
) -> LoopMargins:
    """Each input's smallest disk margin and delay margin over the frozen plants of an uncertain set.

    The frozen plants are those the package's frozen analyses use: for a plant with
    physical parameters (a plant file, :func:`~scara_robust.scara_uncertain_plant`) its
    design-form plants on the fine grid of its parameters (``2·samples − 1`` points each,
    which holds the default grid; the grid the ``physical`` certificate rows refine to); for
    an interval box (:class:`~scara_robust.UncertainLTVModel`, e.g. the paper's
    :func:`~scara_robust.paper_model`) its 2^N corners, as the ``frozen`` margin and the
    ``vertex`` tests; for a :class:`~scara_robust.PolytopicModel` its vertices. At each, the
    loop is broken at one input with the others closed (see the module docstring for
    ``L_i``, the disk margin and the delay margin).

    Parameters
    ----------
    system : UncertainPlant, UncertainLTVModel or PolytopicModel
        The uncertain set (design form: the PID error model ``x = [∫e, e, ė]`` for a PID).
    K : Design or array_like, shape (m, n)
        The gain of ``u = −Kx`` (a design's ``K`` is used).
    omega : array_like, shape (F,), optional
        Frequency grid, rad/s, positive and increasing (default: 50 points per decade
        from ``min|λ|/100`` to ``10·max(max|λ|, Σ|r_k|)`` over the closed loops'
        eigenvalues λ and the residues r_k of ``T_i``; above its top ``|T_i| < ½``, so no
        gain crossover lies there).
    points : mapping of str to int, optional
        For a plant: points per parameter of the frozen grid (default its fine grid).

    Returns
    -------
    LoopMargins

    Raises
    ------
    ArgumentTypeError
        For a `system` that is no uncertain set, or a `K` that is not numbers.
    ArgumentValueError
        For a `K` of the wrong shape, a bad `omega`, or `points` for a box or polytope.

    See Also
    --------
    certificate_table : robust stability of the time-varying set.
    robustness_margin : how much the set can grow.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> loop = sr.PolytopicModel([[[0.0]]], [[[1.0]]])       # ẋ = u, u = −2x: L(s) = 2/s
    >>> m = sr.worst_loop_margins(loop, [[2.0]])
    >>> round(float(m.delay_margin[0]), 6), round(np.pi / 4, 6)  # 90° at 2 rad/s: τ = (π/2)/2
    (0.785398, 0.785398)
    """
    start = time.perf_counter()
    frozen = _frozen_plants(system, points)
    N, n, m = frozen.B.shape
    found = design_or_none(K)
    if found is not None:
        K = found.K
    if isinstance(K, (str, bytes)) or K is None:
        raise ArgumentTypeError("K", f"must be a gain matrix of shape ({m}, {n}) or a Design, found "
                                     f"{type(K).__name__}")
    gain = check_array("K", K, shape=(m, n))
    loops = _Loops(frozen.A, frozen.B, gain)
    max_real = np.asarray(loops.lam.real.max(axis=1), dtype=float)
    stable = max_real < 0
    if omega is not None:
        grid = _check_omega(omega)
    else:
        grid = _default_grid(loops, stable) if stable.any() else np.logspace(-3, 3, 6 * _PER_DECADE + 1)
    peak, peak_at, peak_k, crossings = _scan(loops, stable, grid)
    _refine_peaks(loops, stable, grid, peak, peak_at, peak_k)
    with np.errstate(divide="ignore"):
        plant_disk = np.where(stable[:, None], 1.0 / peak, 0.0)
    plant_delay, delay_at = _delays(loops, stable, grid, crossings)

    # each input's worst plant; with an unstable frozen loop, the most unstable one is the worst of both
    if stable.all():
        disk_worst, delay_worst = np.argmin(plant_disk, axis=0), np.argmin(plant_delay, axis=0)
    else:
        disk_worst = delay_worst = np.full(m, int(np.argmax(max_real)))
    disk, gain_db, phase_deg = np.zeros(m), np.zeros(m), np.zeros(m)
    gain_range, disk_frequency = np.ones((m, 2)), np.full(m, np.nan)
    for i, worst in enumerate(disk_worst):
        if not stable[worst]:
            continue
        b_i, k_i = frozen.B[worst][:, i:i + 1], gain[i:i + 1]
        L = ct.ss(loops.Acl[worst] + b_i @ k_i, b_i, k_i, 0)  # the other loops closed
        disk_frequency[i] = peak_at[worst, i]
        DM, DGM, DPM = ct.disk_margins(L, np.union1d(grid, [disk_frequency[i]]))
        disk[i], gain_db[i], phase_deg[i] = float(DM), float(DGM), float(DPM)
        gain_range[i] = _gain_range(float(DM))
    columns = np.arange(m)
    delay = plant_delay[delay_worst, columns]
    delay_frequency = np.where(np.isfinite(delay) & (delay > 0), delay_at[delay_worst, columns], np.nan)
    return LoopMargins(frozen.inputs, disk, gain_db, gain_range, phase_deg, disk_frequency,
                       np.asarray(disk_worst, dtype=int), np.asarray(delay, dtype=float),
                       np.asarray(delay_frequency, dtype=float), np.asarray(delay_worst, dtype=int), frozen.names,
                       frozen.units, np.asarray(frozen.values, dtype=float), plant_disk, plant_delay, max_real, grid,
                       frozen.description, time.perf_counter() - start)


@dataclass(frozen=True)
class LoopView:
    """What an engineer reads of one loop of one frozen plant: its step response and its Bode plot.

    Attributes
    ----------
    input : int
        The loop (plant input i, broken there, the others closed).
    t : ndarray, shape (k,)
        s.
    step : ndarray, shape (m, k)
        The outputs ``y_j = r_j − e_j`` of the PID form after a unit step of reference i from
        rest (``e_i(0) = 1``, every other state 0): row i is the loop's own step response, the
        others its coupling into the other joints (output units per unit step).
    omega : ndarray, shape (F,)
        rad/s.
    L : ndarray of complex, shape (F,)
        ``L_i(jω)`` (module docstring).
    disk_margin : float
        ``control.disk_margins`` of L_i on `omega` (symmetric α).
    delay_margin : float
        s (inf without a gain crossover).
    crossover : float
        The gain crossover of the delay margin, rad/s (NaN without one).
    """

    input: int
    t: Array
    step: Array
    omega: Array
    L: NDArray[np.complex128]
    disk_margin: float
    delay_margin: float
    crossover: float


def loop_view(A: ArrayLike, B: ArrayLike, K: ArrayLike, loop: int, *, omega: ArrayLike | None = None,
              t_final: float = 6.0) -> LoopView:
    """Step response and Bode data of loop `loop` of the frozen plant ``(A, B)`` under ``u = −Kx`` (PID form).

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m)
        A design-form plant of the PID form, ``x = [∫e, e, ė]`` (n = 3m).
    K : array_like, shape (m, n)
    loop : int
        The input i broken.
    omega : array_like, optional
        rad/s (default 400 points log-spaced over [10⁻², 10⁴]).
    t_final : float
        Horizon of the step response, s.

    Returns
    -------
    LoopView
    """
    A_, B_, K_ = (check_array(name, v) for name, v in (("A", A), ("B", B), ("K", K)))
    n, m = B_.shape
    if A_.shape != (n, n) or K_.shape != (m, n) or n != 3 * m:
        raise ArgumentValueError("K", f"must be (m, 3m) for a PID-form plant A (3m, 3m), B (3m, m); found A "
                                      f"{A_.shape}, B {B_.shape}, K {K_.shape}")
    if not 0 <= loop < m:
        raise ArgumentValueError("loop", f"must be an input index in [0, {m}), found {loop}")
    w = np.logspace(-2, 4, 400) if omega is None else _check_omega(omega)
    others = [j for j in range(m) if j != loop]
    A_open = A_ - B_[:, others] @ K_[others]
    L_sys = ct.ss(A_open, B_[:, [loop]], K_[[loop]], 0)
    L = np.asarray(L_sys(1j * w), dtype=complex).reshape(-1)
    disk = float(np.min(ct.disk_margins(L_sys, w)[0]))
    _, pm, _, _, wgc, _ = ct.stability_margins(L_sys, returnall=True)
    crossings = np.atleast_1d(np.asarray(wgc, dtype=float))
    phases = np.atleast_1d(np.asarray(pm, dtype=float))
    delay, crossover = math.inf, math.nan
    for wc, phase in zip(crossings, phases):
        if wc > 0 and np.isfinite(phase):
            tau = (math.radians(phase) % (2 * math.pi)) / wc
            if tau < delay:
                delay, crossover = tau, float(wc)
    t = np.linspace(0.0, t_final, 2001)
    C = np.zeros((m, n))
    C[:, m:2 * m] = np.eye(m)
    x0 = np.zeros(n)
    x0[m + loop] = 1.0
    response = ct.initial_response(ct.ss(A_ - B_ @ K_, np.zeros((n, 1)), C, 0), T=t, X0=x0)
    e = np.asarray(response.outputs, dtype=float).reshape(m, -1)
    step = -e
    step[loop] += 1.0
    return LoopView(loop, t, step, w, L, disk, delay, crossover)


def frozen_loop_views(plant: Any, K: ArrayLike, margins: LoopMargins, *, t_final: float = 6.0) -> tuple[LoopView, ...]:
    """Each loop's :func:`loop_view` at the frozen plant where `margins` found its smallest delay margin.

    Parameters
    ----------
    plant : UncertainPlant
        A plant with physical parameters (its ``plant_matrices`` and ``design_form``).
    K : array_like, shape (m, n)
    margins : LoopMargins
        :func:`worst_loop_margins` of `K` on `plant` (its frozen plants and their values).
    t_final : float
        Horizon of the step responses, s.

    Returns
    -------
    tuple of LoopView
        One per input, in order.
    """
    K = np.asarray(K, dtype=float)
    views = []
    for i in range(K.shape[0]):
        point = dict(zip(margins.names, margins.values[int(margins.delay_worst[i])]))
        A, B = plant.design_form(*plant.plant_matrices(point))
        views.append(loop_view(A, B, K, i, t_final=t_final))
    return tuple(views)
