"""A gain scheduled on a measured parameter: a table of gains over breakpoints, interpolated.

``u = −K(p̂) x`` with ``K(p̂)`` linear between the gains of the breakpoints ``b_0 < … < b_N``
of the measured parameter ``p̂``, and clamped to the edge gain outside ``[b_0, b_N]`` (where
:meth:`ScheduledGain.clamped` says so: the certificate does not cover it). What a schedule
was certified for (range, rate, measurement error, decay, sample time, plant) travels with
it in :attr:`ScheduledGain.certified` and its file (:meth:`ScheduledGain.save`, JSON).

Units: the parameter's own (breakpoints), the design form's (gains: input units per state
unit).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_real
from ..exceptions import ArgumentValueError, InputFileError

__all__ = ["ScheduledGain", "SampledScheduledGain", "load_schedule", "SCHEDULE_KIND"]

Array = NDArray[np.float64]

#: The ``kind`` of a schedule file.
SCHEDULE_KIND = "scheduled-gain"


@dataclass(frozen=True, eq=False)
class ScheduledGain:
    """Gains ``K_j`` at breakpoints ``b_j`` of a measured parameter, interpolated linearly.

    Parameters
    ----------
    parameter : str
        The measured parameter's name (a plant's :attr:`~scara_robust.Parameter.name`).
    unit : str
        Its unit.
    breakpoints : array_like, shape (N + 1,)
        Strictly increasing, in `unit` (N >= 1).
    gains : array_like, shape (N + 1, m, n)
        ``K_j`` of ``u = −K x`` on the plant's design form.
    method : str
        How the gains were found (``'riccati'``, ``'lmi'``, ``'fixed'``, ...).
    certified : dict
        What a certificate covered (filled by the synthesis and the certificate; empty
        when nothing was certified): e.g. ``range``, ``rate``, ``measurement_error``,
        ``decay``, ``plant``, ``checked_points``.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> g = sr.ScheduledGain("m", "kg", [0.0, 2.0], [[[1.0, 2.0]], [[3.0, 4.0]]])
    >>> g(1.0).tolist(), g.clamped(2.5)
    ([[2.0, 3.0]], True)
    """

    parameter: str
    unit: str
    breakpoints: Array
    gains: Array
    method: str = ""
    certified: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.parameter, str) or not self.parameter.isidentifier():
            raise ArgumentValueError("parameter", f"must be a parameter's name, found {self.parameter!r}")
        b = check_array("breakpoints", self.breakpoints, ndim=1)
        if b.size < 2 or not np.all(np.diff(b) > 0):
            raise ArgumentValueError("breakpoints", f"must be at least 2 strictly increasing values in {self.unit}, "
                                                    f"found {b.tolist()}")
        K = check_array("gains", self.gains, ndim=3)
        if K.shape[0] != b.size:
            raise ArgumentValueError("gains", f"must hold one gain per breakpoint ({b.size}), found {K.shape[0]}")
        object.__setattr__(self, "breakpoints", np.ascontiguousarray(b, dtype=float))
        object.__setattr__(self, "gains", np.ascontiguousarray(K, dtype=float))
        object.__setattr__(self, "certified", dict(self.certified))

    @property
    def shape(self) -> tuple[int, int]:
        """``(m, n)`` of each gain."""
        return int(self.gains.shape[1]), int(self.gains.shape[2])

    @property
    def range(self) -> tuple[float, float]:
        """``(b_0, b_N)``, in the parameter's unit."""
        return float(self.breakpoints[0]), float(self.breakpoints[-1])

    def clamped(self, p_hat: float) -> bool:
        """True when `p_hat` lies outside the breakpoints (the edge gain is used)."""
        lo, hi = self.range
        return not lo <= float(p_hat) <= hi

    def gain(self, p_hat: ArrayLike) -> Array:
        """``K(p̂)``: shape (m, n) for a number, (k, m, n) for shape (k,); clamped to the range."""
        p = np.clip(np.asarray(p_hat, dtype=float), *self.range)
        b = self.breakpoints
        j = np.clip(np.searchsorted(b, p, side="right") - 1, 0, b.size - 2)
        s = (p - b[j]) / (b[j + 1] - b[j])
        s = s[..., None, None]
        return np.asarray((1.0 - s) * self.gains[j] + s * self.gains[j + 1], dtype=float)

    def __call__(self, p_hat: ArrayLike) -> Array:
        """:meth:`gain`."""
        return self.gain(p_hat)

    @property
    def max_norm(self) -> float:
        """``max_j ‖K_j‖₂``, the largest gain of the table (the interpolated ones are no larger)."""
        return float(max(np.linalg.norm(K, 2) for K in self.gains))

    def with_certificate(self, **covered: Any) -> ScheduledGain:
        """The same gains with :attr:`certified` updated."""
        return ScheduledGain(self.parameter, self.unit, self.breakpoints, self.gains, self.method,
                             {**self.certified, **covered})

    def recorded(self, key: str) -> float | None:
        """A number of :attr:`certified` (its ``'inf'``, as a schedule file writes it, read as ``inf``), or None."""
        value = self.certified.get(key)
        return None if value is None else math.inf if value in ("inf", math.inf) else float(value)

    def to_dict(self) -> dict[str, Any]:
        """The schedule file's content (JSON-ready)."""
        return {"kind": SCHEDULE_KIND, "version": 1, "parameter": self.parameter, "unit": self.unit,
                "method": self.method, "breakpoints": self.breakpoints.tolist(), "gains": self.gains.tolist(),
                "certified": {k: _plain(v) for k, v in self.certified.items()}}

    def to_json(self) -> str:
        """The schedule file's text (:meth:`save` writes it)."""
        return json.dumps(self.to_dict(), indent=2, allow_nan=False, default=_plain)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the schedule as JSON (``K_j`` in the design form's units)."""
        with open(path, "w", encoding="utf-8") as handle:
            handle.write(self.to_json() + "\n")


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return value


def load_schedule(path: str | os.PathLike[str]) -> ScheduledGain:
    """Read a schedule file (:meth:`ScheduledGain.save`).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    ScheduledGain

    Raises
    ------
    InputFileError
        Naming the file and the field, when it is not a schedule or a field is bad.
    """
    where = f"schedule file {os.fspath(path)!r}:"
    try:
        with open(path, encoding="utf-8") as handle:
            data = json.load(handle)
    except json.JSONDecodeError as err:
        raise InputFileError(f"{where} not valid JSON ({err.msg}, line {err.lineno})") from None
    if not isinstance(data, dict) or data.get("kind") != SCHEDULE_KIND:
        raise InputFileError(f"{where} field `kind` must be {SCHEDULE_KIND!r} (a file of synthesize --schedule)")
    for key in ("parameter", "unit", "breakpoints", "gains"):
        if key not in data:
            raise InputFileError(f"{where} missing field `{key}`")
    try:
        return ScheduledGain(str(data["parameter"]), str(data["unit"]), data["breakpoints"], data["gains"],
                             str(data.get("method", "")), dict(data.get("certified", {})))
    except (ArgumentValueError, TypeError, ValueError) as err:
        raise InputFileError(f"{where} {err}") from None


@dataclass(frozen=True)
class SampledScheduledGain:
    """``u_k = −K(p̂_k) x(t_k)`` at sample time Ts, held: a scheduled gain as it runs on a board.

    :meth:`step` is the exported C step (:func:`scara_robust.export_controller`) operation
    for operation: p̂ clamped to the breakpoints (the flag says so), the segment found by
    a scan from the first breakpoint, ``K = (1 − s)K_j + sK_{j+1}`` entry by entry, and
    ``u_i = −Σ_k K_ik x_k`` summed in order; :meth:`step_single` the same in float32.

    Parameters
    ----------
    gain : ScheduledGain
    Ts : float
        Sample time, s (> 0).

    Examples
    --------
    >>> import scara_robust as sr
    >>> ctrl = sr.SampledScheduledGain(sr.ScheduledGain("m", "kg", [0, 2], [[[1.0, 2.0]], [[3.0, 4.0]]]), 1e-3)
    >>> u, clamped = ctrl.step([1.0, 1.0], 1.0)
    >>> u.tolist(), clamped
    ([-5.0], False)
    """

    gain: ScheduledGain
    Ts: float

    def __post_init__(self) -> None:
        if not isinstance(self.gain, ScheduledGain):
            raise ArgumentValueError("gain", f"must be a ScheduledGain, found {type(self.gain).__name__}")
        object.__setattr__(self, "Ts", check_real("Ts", self.Ts, positive=True))

    # -- the controller protocol (what certificates, the board and the export ask) --------

    #: The controller's kind, as export targets and the board name it.
    kind: ClassVar[str] = "scheduled"

    def linear_at(self, Ts: float) -> SampledScheduledGain:
        """The same schedule at another sample time."""
        return SampledScheduledGain(self.gain, Ts)

    @property
    def step_sizes(self) -> tuple[int, int]:
        """(inputs, outputs) of one step: x (n) then p̂ in, u (m) out."""
        m, n = self.gain.shape
        return n + 1, m

    @property
    def n_state_values(self) -> int:
        """Numbers kept between steps: none."""
        return 0

    def random_inputs(self, rng: np.random.Generator, n_steps: int) -> Array:
        """Random step inputs: standard normal x, then p̂ uniform over the breakpoints' range widened by 10 % a side.

        Parameters
        ----------
        rng : numpy.random.Generator
        n_steps : int

        Returns
        -------
        ndarray, shape (n + 1, n_steps)
        """
        n_in = self.step_sizes[0]
        lo, hi = self.gain.range
        widen = 0.1 * (hi - lo)
        return np.vstack([rng.standard_normal((n_in - 1, n_steps)),
                          rng.uniform(lo - widen, hi + widen, (1, n_steps))])

    def run_steps(self, inputs: Array, precision: str) -> Array:
        """:meth:`step` (double) or :meth:`step_single` on every column ``[x, p̂]`` of `inputs`, shape (m, n_steps)."""
        scheduled = self.step_single if precision == "single" else self.step
        rows: list[Any] = [scheduled(inputs[:-1, k], float(inputs[-1, k]))[0] for k in range(inputs.shape[1])]
        return np.asarray(np.array(rows, dtype=float).T, dtype=float)

    def _step(self, x: ArrayLike, p_hat: float, kind: Any) -> tuple[NDArray[Any], bool]:
        b = self.gain.breakpoints.astype(kind)
        G = self.gain.gains.astype(kind)
        m, n = self.gain.shape
        xs = np.asarray(x, dtype=kind).reshape(n)
        p = kind(p_hat)
        clamped = False
        if not p >= b[0]:  # below the range, or not a number: the first gain
            p, clamped = b[0], True
        elif p > b[-1]:
            p, clamped = b[-1], True
        j = 0
        while j < b.size - 2 and p >= b[j + 1]:
            j += 1
        s = (p - b[j]) / (b[j + 1] - b[j])
        one = kind(1.0)
        u = np.zeros(m, dtype=kind)
        for i in range(m):
            acc = kind(0.0)
            for k in range(n):
                gain_ik = (one - s) * G[j, i, k] + s * G[j + 1, i, k]
                acc = acc + gain_ik * xs[k]
            u[i] = -acc
        return u, clamped

    def step(self, x: ArrayLike, p_hat: float) -> tuple[Array, bool]:
        """``(u, clamped)``: u of shape (m,) in double precision; clamped when p̂ left the breakpoints."""
        u, clamped = self._step(x, p_hat, np.float64)
        return np.asarray(u, dtype=float), clamped

    def step_single(self, x: ArrayLike, p_hat: float) -> tuple[NDArray[np.float32], bool]:
        """:meth:`step` in float32, as the single-precision C computes it."""
        u, clamped = self._step(x, p_hat, np.float32)
        return np.asarray(u, dtype=np.float32), clamped
