"""The uncertain plant: a state-space family over named physical parameters.

A plant is ``ẋ = A(p) x + B(p) u`` (plant coordinates) with named parameters ``p``, each
with a unit, a range, a nominal value and optionally a bound on its rate of change. Every
analysis works on the plant's **design form**: the PID error model ``x = [∫e, e, ė]`` of a
second-order plant (``form='pid'``, the paper's Eq. 4; :func:`scara_robust.pid_augment`), the
integral-action model ``[∫(r − y), x]`` (``form='integral'``), or the state model itself
(``form='state'``). The plant gives every consumer what it needs:

* :meth:`UncertainPlant.frozen` — the design-form ``(A, B)`` at one parameter point;
* :meth:`UncertainPlant.samples` — the frozen plants on a grid of the parameter box;
* :meth:`UncertainPlant.interval_model` — the interval hull (the paper's Tables 1–2
  convention: nominal at the element-wise minima, each varying entry ``[0, max − min]``);
  for a plant written as expressions (a plant file) an **enclosure** by interval
  arithmetic, so it holds the whole family; for a plant given as a Python function, the
  hull of its samples;
* :meth:`UncertainPlant.polytope` — the polytope of the sampled frozen plants;
* :meth:`UncertainPlant.scaled` — the same plant with every parameter range scaled about
  its nominal (the physical margin's variable).

The SCARA with its payload is one instance (:func:`scara_robust.scara_uncertain_plant`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._resources import check_memory
from .._validation import check_array, check_choice, check_int, check_real, describe
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ._expressions import Expression, parse_expression
from ._ranges import matrix_ranges
from .polytopic import PolytopicModel
from .uncertain import ANCHORS, UncertainElement, UncertainLTVModel, state_space

__all__ = ["Parameter", "Signal", "UncertainPlant", "ParameterSamples", "NonlinearDynamics", "PLANT_FORMS",
           "POSITIVE_UNITS"]

Array = NDArray[np.float64]
#: Design forms of a plant (see the module docstring).
PLANT_FORMS = ("pid", "integral", "state")
#: An entry of a sampled hull varies when its range exceeds this times its matrix's largest
#: magnitude (rounding of the samples is not variation).
HULL_RTOL = 1e-9
_MAX_SAMPLES = 2_000_000
#: Units of a mass, a length or an inertia, as a plant file writes them: a parameter in one
#: of them is physically positive, ``limits = (0, inf)``, unless its file says otherwise
#: (compared with a space, ``*``, ``.`` and ``·`` alike and ``^2``/``**2`` as ``²``).
POSITIVE_UNITS = frozenset({
    "kg", "g", "mg", "t", "m", "mm", "cm", "km", "µm", "um",
    "kg·m²", "g·cm²", "g·mm²", "kg·mm²", "kg·cm²",
})


def positive_unit(unit: str) -> bool:
    """True when `unit` is one of :data:`POSITIVE_UNITS` (a mass, a length or an inertia)."""
    text = unit.strip().replace("**2", "²").replace("^2", "²")
    for sep in (" ", "*", "."):
        text = text.replace(sep, "·")
    while "··" in text:
        text = text.replace("··", "·")
    return text in POSITIVE_UNITS


def _extended_real(name: str, value: object) -> float:
    """A real number or ±inf (a physical limit), or raise naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ArgumentTypeError(name, f"must be a real number or ±inf, found {describe(value)}")
    if math.isnan(float(value)):
        raise ArgumentValueError(name, "must be a real number or ±inf, found nan")
    return float(value)


@dataclass(frozen=True)
class Parameter:
    """A named physical parameter: unit, range, nominal value and rate bound.

    Parameters
    ----------
    name : str
        A Python identifier (``"J"``, ``"m_p"``), as the plant's expressions use it.
    unit : str
        Its unit (``"kg·m²"``); required, ``"1"`` for a dimensionless one.
    range : (float, float)
        ``(lower, upper)`` with lower <= upper; equal ends for a fixed parameter.
    nominal : float, optional
        Where the margins scale the range about (default: the lower end, the paper's
        convention of a design plant at the box's lower corner). Inside the range.
    rate : float, optional
        Bound on ``|ṗ|`` in unit/s (>= 0), for rate-bounded analyses and simulated
        profiles; None for a parameter that may vary arbitrarily fast. Only for a
        parameter with a range.
    samples : int
        Grid points over the range for the sampled analyses (>= 2 when it varies).
    coarse : int, optional
        Grid points of the coarser grid on which LMIs are solved (their answer is then
        verified with numpy on ``samples``); default ``min(samples, 5)``.
    description : str
    limits : (float, float), optional
        The physical interval the parameter can never leave (a plant file's ``physical``):
        no scaled range crosses it, and the range must lie in it. Default: ``(0, inf)``
        for a unit of mass, length or inertia (:data:`POSITIVE_UNITS`: a mass, a length
        or an inertia is positive by its unit), otherwise ``(-inf, inf)``.
    scales : bool
        Whether margins scale its range (default True). False for a coordinate that is
        not an uncertainty, such as the reference time of a robot's linearization: its
        range stays whole at every scale.
    measured : bool
        The controller measures it (a payload weighed by a wrist sensor, told by the
        task): a gain may be scheduled on it (:class:`~scara_robust.ScheduledGain`).
    measurement_error : float
        Bound δ on ``|p̂ − p|``, in its unit (>= 0); only for a measured parameter.
    measurement_delay : float
        Delay of the measurement, s (>= 0); only for a measured parameter. A
        delay of τ at a rate bound ν adds ``ν τ`` to the error δ a certificate covers.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.Parameter("J", "kg·m²", (2e-4, 6e-4), rate=4e-4).varies
    True
    """

    name: str
    unit: str
    range: tuple[float, float]
    nominal: float | None = None
    rate: float | None = None
    samples: int = 5
    coarse: int | None = None
    description: str = ""
    limits: tuple[float, float] | None = None
    scales: bool = True
    measured: bool = False
    measurement_error: float = 0.0
    measurement_delay: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ArgumentValueError("name", f"must be an identifier such as 'J' or 'm_p', found {describe(self.name)}")
        if not isinstance(self.unit, str) or not self.unit.strip():
            raise ArgumentValueError(f"{self.name}.unit", "must name the unit (e.g. 'kg', '1' when dimensionless), "
                                                          f"found {describe(self.unit)}")
        try:
            lo, hi = self.range
        except (TypeError, ValueError):
            raise ArgumentValueError(f"{self.name}.range", f"must be (lower, upper), found {describe(self.range)}") \
                from None
        lo = check_real(f"{self.name}.range[0]", lo)
        hi = check_real(f"{self.name}.range[1]", hi)
        if lo > hi:
            raise ArgumentValueError(f"{self.name}.range", f"must have lower <= upper, found [{lo:g}, {hi:g}] "
                                                           f"{self.unit}")
        object.__setattr__(self, "range", (lo, hi))
        self._check_limits(lo, hi)
        nominal = lo if self.nominal is None else check_real(f"{self.name}.nominal", self.nominal)
        if not lo <= nominal <= hi:
            raise ArgumentValueError(f"{self.name}.nominal", f"must lie in the range [{lo:g}, {hi:g}] {self.unit}, "
                                                             f"found {nominal:g}")
        object.__setattr__(self, "nominal", nominal)
        if self.rate is not None:
            rate = check_real(f"{self.name}.rate", self.rate, nonnegative=True)
            if lo == hi:
                raise ArgumentValueError(f"{self.name}.rate", f"bounds the change of a parameter with a range; "
                                                              f"{self.name} is fixed at {lo:g} {self.unit}")
            object.__setattr__(self, "rate", rate)
        object.__setattr__(self, "samples", check_int(f"{self.name}.samples", self.samples, 2 if lo < hi else 1))
        coarse = min(self.samples, 5) if self.coarse is None else self.coarse
        object.__setattr__(self, "coarse", check_int(f"{self.name}.coarse", coarse, 2 if lo < hi else 1))
        self._check_measurement(lo, hi)

    def _check_measurement(self, lo: float, hi: float) -> None:
        if not isinstance(self.measured, bool):
            raise ArgumentValueError(f"{self.name}.measured", f"must be true or false, found {describe(self.measured)}")
        error = check_real(f"{self.name}.measurement_error", self.measurement_error, nonnegative=True)
        delay = check_real(f"{self.name}.measurement_delay", self.measurement_delay, nonnegative=True)
        if not self.measured and (error > 0 or delay > 0):
            which = "measurement_error" if error > 0 else "measurement_delay"
            raise ArgumentValueError(f"{self.name}.{which}", "describes a measured parameter; set "
                                                             f"{self.name}.measured = true")
        object.__setattr__(self, "measurement_error", error)
        object.__setattr__(self, "measurement_delay", delay)

    @property
    def effective_error(self) -> float:
        """The measurement error a certificate must cover: ``δ + ν τ`` (its unit; δ alone without a rate bound)."""
        rate = 0.0 if self.rate is None else float(self.rate)
        return float(self.measurement_error) + rate * float(self.measurement_delay)

    def motion_bounds(self, rate: float | None = None,
                      measurement_error: float | None = None) -> tuple[float, float]:
        """The rate ν and measurement error δ a scheduled gain's certificate covers.

        Parameters
        ----------
        rate : float, optional
            ν, the parameter's unit per second (default its ``rate``; ``inf`` without one).
        measurement_error : float, optional
            δ, its unit (default :attr:`effective_error`).

        Returns
        -------
        (float, float)
            ν and δ.

        Raises
        ------
        ArgumentValueError
            Naming ``rate`` or ``measurement_error`` for a negative or NaN value.
        """
        nu = (math.inf if self.rate is None else float(self.rate)) if rate is None else float(rate)
        if not nu >= 0:
            raise ArgumentValueError("rate", f"must be >= 0 {self.unit}/s, found {nu}")
        delta = self.effective_error if measurement_error is None else check_real(
            "measurement_error", measurement_error, nonnegative=True)
        return nu, delta

    def _check_limits(self, lo: float, hi: float) -> None:
        if self.limits is None:
            limits = (0.0, math.inf) if positive_unit(self.unit) else (-math.inf, math.inf)
        else:
            try:
                a, b = self.limits
            except (TypeError, ValueError):
                raise ArgumentValueError(f"{self.name}.limits", "must be (lower, upper), found "
                                                                f"{describe(self.limits)}") from None
            limits = (_extended_real(f"{self.name}.limits[0]", a), _extended_real(f"{self.name}.limits[1]", b))
            if not limits[0] < limits[1]:
                raise ArgumentValueError(f"{self.name}.limits", f"must have lower < upper, found "
                                                                f"[{limits[0]:g}, {limits[1]:g}] {self.unit}")
        if lo < limits[0] or hi > limits[1]:
            why = (f" ({self.unit} is a unit of mass, length or inertia: positive unless the limits say otherwise)"
                   if self.limits is None else "")
            raise ArgumentValueError(f"{self.name}.range", f"must lie in the physical limits [{limits[0]:g}, "
                                                           f"{limits[1]:g}] {self.unit}{why}, found [{lo:g}, {hi:g}]")
        object.__setattr__(self, "limits", limits)

    @property
    def physical(self) -> tuple[float, float]:
        """The physical interval the parameter can never leave, ``(lower, upper)`` in its unit."""
        return self.limits  # type: ignore[return-value]

    @property
    def varies(self) -> bool:
        """True when the range has width."""
        return self.range[0] < self.range[1]

    def scaled_range(self, theta: float) -> tuple[float, float]:
        """The range scaled by θ about the nominal: ``[p₀ − θ(p₀ − lower), p₀ + θ(upper − p₀)]``.

        A parameter that does not `scales` keeps its whole range; a scaled range stops at
        the `limits`.
        """
        lo, hi = self.range
        if not self.scales:
            return (lo, hi)
        p0 = float(self.nominal)  # type: ignore[arg-type]
        return (max(p0 - theta * (p0 - lo), self.physical[0]), min(p0 + theta * (hi - p0), self.physical[1]))

    def at_limit(self, theta: float) -> str:
        """Which ends of :meth:`scaled_range` sit on the physical limits at θ.

        Returns ``''``, ``'lower'``, ``'upper'`` or ``'both'``.
        """
        if not self.scales:
            return ""
        p0 = float(self.nominal)  # type: ignore[arg-type]
        lo, hi = self.range
        low = p0 - theta * (p0 - lo) <= self.physical[0] and lo < p0
        high = p0 + theta * (hi - p0) >= self.physical[1] and hi > p0
        return "both" if low and high else "lower" if low else "upper" if high else ""


@dataclass(frozen=True)
class Signal:
    """A named input or output with its unit (``Signal("i", "A")``), and an input's limit.

    Parameters
    ----------
    name : str
    unit : str
    limit : float, optional
        The largest magnitude ``|u|`` the actuator delivers, in `unit` (> 0): a motor's
        current limit. None (default) for none. Only the analyses that ask for it read it
        (:func:`~scara_robust.input_limit_certificate`, :func:`~scara_robust.synthesize`
        given ``input_limits``); no simulation saturates on it.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.Signal("current", "A", limit=2.0).limit
    2.0
    """

    name: str
    unit: str
    limit: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ArgumentValueError("name", f"must be a non-empty string, found {describe(self.name)}")
        if not isinstance(self.unit, str) or not self.unit.strip():
            raise ArgumentValueError(f"{self.name}.unit", f"must name the unit, found {describe(self.unit)}")
        if self.limit is not None:
            if isinstance(self.limit, bool) or not isinstance(self.limit, (int, float, np.integer, np.floating)):
                raise ArgumentTypeError(f"{self.name}.limit", f"must be a number > 0 in {self.unit}, found "
                                                              f"{type(self.limit).__name__} {describe(self.limit)}")
            if not (math.isfinite(float(self.limit)) and self.limit > 0):
                raise ArgumentValueError(f"{self.name}.limit", f"must be a finite number > 0 in {self.unit}, found "
                                                               f"{float(self.limit):g}")
            object.__setattr__(self, "limit", float(self.limit))


@dataclass(frozen=True)
class ParameterSamples:
    """Frozen design-form plants on a grid of the parameter box.

    Attributes
    ----------
    names : tuple of str
        The parameters, in the plant's order.
    values : ndarray, shape (k, n_parameters)
        The parameter values of each sample, in their units; the first parameter varies
        slowest.
    A : ndarray, shape (k, n, n)
    B : ndarray, shape (k, n, m)
    """

    names: tuple[str, ...]
    values: Array
    A: Array
    B: Array

    @property
    def n_samples(self) -> int:
        """k."""
        return int(self.values.shape[0])

    def column(self, name: str) -> Array:
        """The values of parameter `name`, shape (k,)."""
        check_choice("name", name, self.names)
        return np.asarray(self.values[:, self.names.index(name)])

    def closed_loops(self, K: ArrayLike) -> Array:
        """``A_i − B_i K`` for a gain of shape (m, n), shape (k, n, n)."""
        K = check_array("K", K, shape=(self.B.shape[2], self.A.shape[1]))
        loops = np.matmul(self.B, K)  # one array of k loops, not two: a frozen scan builds one per scale
        return np.subtract(self.A, loops, out=loops)


#: ``matrices(values) -> (A, B)``: values maps each parameter name to an array (all of one
#: shape S); A has shape S + (n_x, n_x) and B shape S + (n_x, m), in plant coordinates.
MatrixFunction = Callable[[Mapping[str, Array]], tuple[Array, Array]]


def _stack(A: Any, B: Any, shape: tuple[int, ...]) -> tuple[Array, Array]:
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    if A.ndim == 2:
        A = np.broadcast_to(A, shape + A.shape)
    if B.ndim == 2:
        B = np.broadcast_to(B, shape + B.shape)
    return np.asarray(A), np.asarray(B)


@dataclass(frozen=True)
class UncertainPlant:
    """A plant ``ẋ = A(p)x + B(p)u`` over named physical parameters, with its design form.

    Build one with :meth:`from_expressions` (what a plant file holds),
    :meth:`from_function` (a Python callable ``p -> (A, B)`` or ``p -> StateSpace``),
    :meth:`from_system` (a fixed python-control system), :meth:`from_nonlinear` (a
    ``control.NonlinearIOSystem`` with named parameters, linearized at its operating point or
    along a reference), or :func:`scara_robust.scara_uncertain_plant`.

    Parameters
    ----------
    parameters : sequence of Parameter
    matrices : callable
        ``matrices(values) -> (A, B)``, vectorized: `values` maps every parameter name to
        an array, all of one shape S; returns A of shape S + (n_x, n_x) and B of shape
        S + (n_x, m) in plant coordinates (2-D results broadcast).
    n_states, n_inputs : int
        n_x and m of the plant.
    form : {'pid', 'integral', 'state'}
        The design form (module docstring).
    C : array_like, shape (q, n_x), optional
        Outputs for ``form='integral'``.
    name : str
    inputs : sequence of Signal, optional
        One per input, with units (default ``u0 [1]``, ...).
    outputs : sequence of Signal, optional
        The controlled outputs: q for the PID form, the rows of C for the integral form.
    entries : tuple, optional
        ``(A_entries, B_entries)``: the expressions of each entry, for the interval
        enclosure (set by :meth:`from_expressions`).
    hull : callable, optional
        ``hull(theta) -> UncertainLTVModel``: a published interval model to use instead of
        the computed one (the SCARA's Tables 1–2).
    prefix : str
        Identifier prefix of exported code.
    dynamics : NonlinearDynamics, optional
        The nonlinear system the matrices linearize (set by :meth:`from_nonlinear`):
        :func:`scara_robust.simulate_plant` then runs it instead of ``A(p)x + B(p)u``.
    design_plant : {'lower', 'center'}
        Where :meth:`interval_model` puts its nominal (the plant ``design`` uses): the
        lower corner of the box (the paper's convention) or its centre. The box is the
        same; for a plant of many coupled entries (an arm of six joints) the lower corner
        of every entry is far from any real plant, and a gain designed there can
        destabilize the real ones.

    See Also
    --------
    load_plant : a plant from a file.
    parameter_margin : margins in its parameters' units.
    simulate_plant : a closed-loop run with varying parameters.

    Examples
    --------
    >>> import scara_robust as sr
    >>> J = sr.Parameter("J", "kg·m²", (2e-4, 6e-4))
    >>> b = sr.Parameter("b", "N·m·s/rad", (1e-4, 1e-4))
    >>> kt = sr.Parameter("kt", "N·m/A", (0.05, 0.05))
    >>> motor = sr.UncertainPlant.from_expressions(
    ...     [J, b, kt], [[0, 1], [0, "-b/J"]], [[0], ["kt/J"]], form="pid")
    >>> motor.interval_model().n_elements
    2
    """

    parameters: tuple[Parameter, ...]
    matrices: MatrixFunction = field(repr=False)
    n_states: int = 0
    n_inputs: int = 0
    form: str = "pid"
    C: Array | None = None
    name: str = "plant"
    inputs: tuple[Signal, ...] = ()
    outputs: tuple[Signal, ...] = ()
    entries: tuple[tuple[tuple[Expression, ...], ...], tuple[tuple[Expression, ...], ...]] | None = field(
        default=None, repr=False)
    hull: Callable[[float], UncertainLTVModel] | None = field(default=None, repr=False)
    prefix: str = "plant_pid"
    design_plant: str = "lower"
    dynamics: NonlinearDynamics | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        check_choice("form", self.form, PLANT_FORMS)
        check_choice("design_plant", self.design_plant, ANCHORS)
        params = tuple(self.parameters)
        for k, p in enumerate(params):
            if not isinstance(p, Parameter):
                raise ArgumentTypeError(f"parameters[{k}]", f"must be a Parameter, found {type(p).__name__}")
        names = [p.name for p in params]
        if len(set(names)) != len(names):
            raise ArgumentValueError("parameters", f"must have distinct names, found {names}")
        object.__setattr__(self, "parameters", params)
        n = check_int("n_states", self.n_states, 1)
        m = check_int("n_inputs", self.n_inputs, 1)
        if not self.prefix.isidentifier():
            raise ArgumentValueError("prefix", f"must be a C identifier, found {describe(self.prefix)}")
        if self.form == "pid":
            if n % 2:
                raise ArgumentValueError("form", f"'pid' needs the state [q, q̇] of 2p states, found n = {n}")
            q = n // 2
        elif self.form == "integral":
            if self.C is None:
                raise ArgumentValueError("C", "is needed by form='integral' (the outputs to integrate)")
            C = check_array("C", self.C, ndim=2)
            if C.shape[1] != n or C.shape[0] == 0:
                raise ArgumentValueError("C", f"must have shape (q, {n}), found {C.shape}")
            C.setflags(write=False)
            object.__setattr__(self, "C", C)
            q = C.shape[0]
        else:
            q = n
        if self.form != "integral" and self.C is not None:
            raise ArgumentValueError("C", f"is used by form='integral' only, found it with form={self.form!r}")
        inputs = tuple(self.inputs) or tuple(Signal(f"u{i}", "1") for i in range(m))
        outputs = tuple(self.outputs) or tuple(Signal(f"y{i}", "1") for i in range(q))
        if len(inputs) != m:
            raise ArgumentValueError("inputs", f"must name the {m} inputs, found {len(inputs)}")
        if len(outputs) != q:
            raise ArgumentValueError("outputs", f"must name the {q} controlled outputs, found {len(outputs)}")
        object.__setattr__(self, "inputs", inputs)
        object.__setattr__(self, "outputs", outputs)
        # evaluate once, at the nominal and the box's corners (a cheap check; the samples are checked where
        # used): shapes, finiteness and the form's needs
        corners = self.grid_values({p.name: 2 for p in params if p.varies}) if len(self.varying) <= 10 else \
            np.zeros((0, len(params)))
        nominal_row = np.array([[p.nominal for p in params]], dtype=float).reshape(1, len(params))
        grid = np.vstack([nominal_row, corners])
        A, B = self._plant_matrices({name: grid[:, k] for k, name in enumerate(self.names)})
        if A.shape != (len(grid), n, n) or B.shape != (len(grid), n, m):
            raise ArgumentValueError("matrices", f"must give A of shape ({n}, {n}) and B of shape ({n}, {m}), found "
                                                 f"{A.shape[1:]} and {B.shape[1:]}")
        self._check_form(grid, A, B)

    # --- constructors -------------------------------------------------------------------

    @classmethod
    def from_expressions(
        cls,
        parameters: Sequence[Parameter],
        A: Sequence[Sequence[Any]],
        B: Sequence[Sequence[Any]],
        *,
        form: str = "pid",
        C: ArrayLike | None = None,
        name: str = "plant",
        inputs: Sequence[Signal] = (),
        outputs: Sequence[Signal] = (),
        prefix: str = "plant_pid",
    ) -> UncertainPlant:
        """A plant whose entries are numbers or arithmetic in the parameters (``"-b/J"``).

        Each string is parsed by whitelist (the whitelist parser of ``scara_robust.model._expressions``);
        nothing is executed.

        Parameters
        ----------
        parameters : sequence of Parameter
        A : list of rows, shape (n, n)
            Entries: numbers or expression strings.
        B : list of rows, shape (n, m)
        form, C, name, inputs, outputs, prefix
            As for the class.

        Returns
        -------
        UncertainPlant

        Raises
        ------
        ArgumentValueError
            Naming the entry (``A[1][1]``): an unknown name, a construct outside the
            whitelist, a ragged matrix, or an entry undefined on the parameter box.
        """
        names = {p.name for p in parameters}

        def parse(label: str, rows: Sequence[Sequence[Any]], n_cols: int | None) -> tuple[tuple[Expression, ...], ...]:
            if not isinstance(rows, (list, tuple)) or not rows or not all(isinstance(r, (list, tuple)) for r in rows):
                raise ArgumentValueError(label, f"must be a list of rows, found {describe(rows)}")
            width = len(rows[0]) if n_cols is None else n_cols
            for i, row in enumerate(rows):
                if len(row) != width or width == 0:
                    raise ArgumentValueError(label, f"row {i} has {len(row)} entries, expected {width}")
            return tuple(tuple(parse_expression(v, names, f"{label}[{i}][{j}]") for j, v in enumerate(row))
                         for i, row in enumerate(rows))

        a_entries = parse("A", A, None)
        if len(a_entries) != len(a_entries[0]):
            raise ArgumentValueError("A", f"must be square, found {len(a_entries)} x {len(a_entries[0])}")
        if not isinstance(B, (list, tuple)) or len(B) != len(a_entries):
            raise ArgumentValueError("B", f"must have {len(a_entries)} rows (one per state), found {describe(B)}")
        b_entries = parse("B", B, None)
        n, m = len(a_entries), len(b_entries[0])

        def matrices(values: Mapping[str, Array]) -> tuple[Array, Array]:
            shape = np.broadcast_shapes(*(np.shape(v) for v in values.values())) if values else ()
            out_A = np.empty(shape + (n, n))
            out_B = np.empty(shape + (n, m))
            for out, table in ((out_A, a_entries), (out_B, b_entries)):
                for i, row in enumerate(table):
                    for j, expr in enumerate(row):
                        out[..., i, j] = expr({k: values[k] for k in expr.names})
            return out_A, out_B

        return cls(tuple(parameters), matrices, n, m, form=form,
                   C=None if C is None else check_array("C", C, ndim=2), name=name,
                   inputs=tuple(inputs), outputs=tuple(outputs), entries=(a_entries, b_entries), prefix=prefix)

    @classmethod
    def from_function(
        cls,
        parameters: Sequence[Parameter],
        function: Callable[[dict[str, float]], Any],
        *,
        form: str = "pid",
        C: ArrayLike | None = None,
        name: str = "plant",
        inputs: Sequence[Signal] = (),
        outputs: Sequence[Signal] = (),
        prefix: str = "plant_pid",
    ) -> UncertainPlant:
        """A plant from a Python callable ``function(p) -> (A, B)`` or ``-> control.StateSpace``.

        Parameters
        ----------
        parameters : sequence of Parameter
        function : callable
            ``function(p)`` with ``p`` a dict of floats (one per parameter name, in its
            unit) returns ``(A, B)`` (array_like, shapes (n, n) and (n, m)) or a
            continuous-time ``control.StateSpace`` (its A and B are used).
        form, C, name, inputs, outputs, prefix
            As for the class.

        Returns
        -------
        UncertainPlant
            Its interval hull is that of its samples (:meth:`interval_model`).

        Examples
        --------
        >>> import control as ct, scara_robust as sr
        >>> k = sr.Parameter("k", "N/m", (1.0, 3.0))
        >>> msd = sr.UncertainPlant.from_function(
        ...     [k], lambda p: ct.ss([[0, 1], [-p["k"], -0.5]], [[0], [1]], [[1, 0]], 0))
        >>> msd.frozen({"k": 2.0})[0].shape
        (3, 3)
        """
        if not callable(function):
            raise ArgumentTypeError("function", f"must be callable, found {type(function).__name__}")
        params = tuple(parameters)

        def call(point: dict[str, float]) -> tuple[Array, Array]:
            out = function(point)
            if hasattr(out, "A") and hasattr(out, "B"):
                ss = state_space(out, "function(p)")
                return np.asarray(ss.A, dtype=float), np.asarray(ss.B, dtype=float)
            try:
                A, B = out
            except (TypeError, ValueError):
                raise ArgumentTypeError("function", f"must return (A, B) or a control.StateSpace, found "
                                                    f"{type(out).__name__}") from None
            return np.asarray(A, dtype=float), np.asarray(B, dtype=float)

        first = call({p.name: float(p.nominal) for p in params})  # type: ignore[arg-type]

        def matrices(values: Mapping[str, Array]) -> tuple[Array, Array]:
            shape = np.broadcast_shapes(*(np.shape(v) for v in values.values())) if values else ()
            flat = {k: np.broadcast_to(v, shape).ravel() for k, v in values.items()}
            size = int(np.prod(shape))
            out_A = np.empty((size,) + first[0].shape)
            out_B = np.empty((size,) + first[1].shape)
            for s in range(size):
                out_A[s], out_B[s] = call({k: float(v[s]) for k, v in flat.items()})
            return out_A.reshape(shape + first[0].shape), out_B.reshape(shape + first[1].shape)

        if first[0].ndim != 2 or first[1].ndim != 2:
            raise ArgumentValueError("function", f"must return 2-D A and B, found shapes {first[0].shape}, "
                                                 f"{first[1].shape}")
        return cls(params, matrices, first[0].shape[0], first[1].shape[1], form=form,
                   C=None if C is None else check_array("C", C, ndim=2), name=name, inputs=tuple(inputs),
                   outputs=tuple(outputs), prefix=prefix)

    @classmethod
    def from_nonlinear(
        cls,
        sys: ct.NonlinearIOSystem,
        parameters: Sequence[Parameter],
        *,
        x_eq: ArrayLike | None = None,
        u_eq: ArrayLike | None = None,
        reference: tuple[ArrayLike, float] | None = None,
        n_times: int = 9,
        name: str | None = None,
        inputs: Sequence[Signal] = (),
        outputs: Sequence[Signal] = (),
        prefix: str = "plant_pid",
    ) -> UncertainPlant:
        """A plant in the PID form from a ``control.NonlinearIOSystem`` with named parameters.

        The system's state is ``[q, q̇]`` (2p states, p controlled outputs q) and it has m
        inputs. Its matrices at a parameter value are ``control.linearize`` of `sys` at the
        operating point (forward differences with python-control's step, 1e-6: entries
        accurate to about 1e-6 relative where the dynamics curve), with ``params`` the system's
        own defaults updated by the value:

        - without `reference`: at the equilibrium ``(x_eq, u_eq)`` (default zeros);
        - with ``reference = (a, ω)``: along ``q_r(t) = a sin ωt`` (in coordinates relative
          to `x_eq`) over one period, the reference time ``t_ref`` (s) being one more
          parameter, at the input ``u_r(t)`` that holds the reference at the nominal
          parameters (:meth:`NonlinearDynamics.operating_point`: the model feedforward the
          run applies too).

        Parameters
        ----------
        sys : control.NonlinearIOSystem
            Continuous time; ``sys.dynamics(t, x, u, params)`` is ``ẋ``.
        parameters : sequence of Parameter
            The uncertain ones among the system's parameters (named as in ``params``).
        x_eq : array_like, shape (2p,), optional
            The equilibrium state (default 0), the origin of the plant's coordinates.
        u_eq : array_like, shape (m,), optional
            The input holding it at the nominal parameters (default 0).
        reference : (array_like of shape (p,), float), optional
            Amplitudes ``a`` (output units; one value for every output, or one per output)
            and ``ω`` (rad/s, > 0) of a sinusoidal reference. :func:`scara_robust.simulate_plant`
            runs the plant along this reference (its default for the plant), and refuses another.
        n_times : int
            Samples of ``t_ref`` over the period (with `reference`).
        name : str, optional
            Default: the system's name.
        inputs, outputs, prefix
            As for the class.

        Returns
        -------
        UncertainPlant
            With :attr:`dynamics` set: :func:`scara_robust.simulate_plant` runs `sys`.

        Raises
        ------
        ArgumentTypeError
            If `sys` is not a ``control.NonlinearIOSystem``.
        ArgumentValueError
            For a discrete-time system, an odd number of states, a parameter `sys` does not
            have, operating points of the wrong size, an operating point that is no
            equilibrium, a reference of the wrong size, or one the input cannot hold.

        Examples
        --------
        >>> import numpy as np, control as ct, scara_robust as sr
        >>> def arm(t, x, u, p):   # one link with a payload at its tip, hanging at q = 0
        ...     J = 0.05 + p["m_p"] * 0.25
        ...     return [x[1], (u[0] - 0.1 * x[1] - (0.25 + 0.5 * p["m_p"]) * 9.81 * np.sin(x[0])) / J]
        >>> sys = ct.nlsys(arm, None, states=2, inputs=1, outputs=2, params={"m_p": 0.0})
        >>> plant = sr.UncertainPlant.from_nonlinear(sys, [sr.Parameter("m_p", "kg", (0.0, 2.0))])
        >>> A, B = plant.plant_matrices({"m_p": 2.0})   # ∂q̈/∂q = −(0.25 + 1) 9.81 / 0.55 at rest
        >>> A.round(3).tolist(), B.round(3).tolist()
        ([[0.0, 1.0], [-22.295, -0.182]], [[0.0], [1.818]])
        """
        if not isinstance(sys, ct.NonlinearIOSystem):
            raise ArgumentTypeError("sys", f"must be a control.NonlinearIOSystem, found {type(sys).__name__}")
        if not sys.isctime():
            raise ArgumentValueError("sys", "must be continuous-time")
        n, m = int(sys.nstates), int(sys.ninputs)
        if n % 2:
            raise ArgumentValueError("sys", f"must have the state [q, q̇] of 2p states, found {n}")
        params = tuple(parameters)
        for prm in params:
            if prm.name not in sys.params:
                raise ArgumentValueError("parameters", f"names {prm.name!r}, which is not a parameter of `sys` "
                                                       f"({', '.join(sys.params) or 'none'})")
        x0 = np.zeros(n) if x_eq is None else check_array("x_eq", x_eq, shape=(n,))
        u0 = np.zeros(m) if u_eq is None else check_array("u_eq", u_eq, shape=(m,))
        wave = None
        if reference is not None:
            if not isinstance(reference, tuple) or len(reference) != 2:
                raise ArgumentValueError("reference", f"must be (amplitudes, omega): the amplitudes of the {n // 2} "
                                                      f"outputs and ω in rad/s, found {describe(reference)}")
            amp = check_array("reference[0]", np.atleast_1d(reference[0]))
            if amp.shape not in ((1,), (n // 2,)):
                raise ArgumentValueError("reference[0]", f"must give one amplitude or one per output ({n // 2}), "
                                                         f"found {amp.size}")
            amp = np.broadcast_to(amp, (n // 2,)).copy()
            omega = check_real("reference[1]", reference[1], positive=True)
            wave = (amp, omega)
            n_times = check_int("n_times", n_times, 2)
            params = (Parameter("t_ref", "s", (0.0, 2 * math.pi / omega), samples=n_times,
                                coarse=min(n_times, 9), scales=False,
                                description="reference time over one period (the linearization point)"), *params)
        nominal = {prm.name: float(prm.nominal) for prm in params if prm.name != "t_ref"}  # type: ignore[arg-type]
        if wave is None:  # an operating point that is not an equilibrium would be linearized all the same: refuse it
            rate = np.asarray(sys.dynamics(0.0, x0, u0, {**sys.params, **nominal}), dtype=float)
            scale = max(1.0, float(np.abs(x0).max(initial=0.0)))
            if not np.all(np.abs(rate) <= 1e-9 * scale):
                raise ArgumentValueError("x_eq", f"and `u_eq` must be an equilibrium of `sys` at the nominal "
                                                 f"parameters (ẋ = 0), found ẋ = {np.round(rate, 6).tolist()}")
        dynamics = NonlinearDynamics(sys, x0, u0, wave, nominal)

        def linearized(point: dict[str, float]) -> tuple[Array, Array]:
            values = {k: v for k, v in point.items() if k != "t_ref"}
            x_op, u_op = dynamics.operating_point(point.get("t_ref", 0.0))
            lin = ct.linearize(sys, x_op, u_op, params={**sys.params, **values})
            return np.asarray(lin.A, dtype=float), np.asarray(lin.B, dtype=float)

        plant = cls.from_function(params, linearized, form="pid", name=name or str(sys.name), inputs=inputs,
                                  outputs=outputs, prefix=prefix)
        return replace(plant, dynamics=dynamics)

    @classmethod
    def from_system(cls, sys: Any, *, form: str = "pid", name: str | None = None,
                    inputs: Sequence[Signal] = (), outputs: Sequence[Signal] = ()) -> UncertainPlant:
        """A fixed plant from a continuous-time ``control.StateSpace`` or ``TransferFunction``.

        For ``form='integral'`` the system's C is the output to integrate; for
        ``form='pid'`` the system must be in second-order form with outputs q.

        Parameters
        ----------
        sys : control.StateSpace, control.TransferFunction or what ``control.ss`` takes
        form : {'pid', 'integral', 'state'}
        name : str, optional
        inputs, outputs : sequence of Signal, optional

        Returns
        -------
        UncertainPlant
            With no parameters.
        """
        ss = state_space(sys, "sys")
        A, B = np.asarray(ss.A, dtype=float), np.asarray(ss.B, dtype=float)
        return cls((), lambda values: (A, B), A.shape[0], B.shape[1], form=form,
                   C=np.asarray(ss.C, dtype=float) if form == "integral" else None,
                   name=name or str(ss.name), inputs=tuple(inputs), outputs=tuple(outputs))

    # --- the parameter box --------------------------------------------------------------

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in order."""
        return tuple(p.name for p in self.parameters)

    @property
    def varying(self) -> tuple[Parameter, ...]:
        """The parameters with a range."""
        return tuple(p for p in self.parameters if p.varies)

    @property
    def measured(self) -> tuple[Parameter, ...]:
        """The parameters the controller measures (a gain may be scheduled on them)."""
        return tuple(p for p in self.parameters if p.measured)

    def parameter(self, name: str) -> Parameter:
        """The parameter called `name`."""
        check_choice("name", name, self.names)
        return self.parameters[self.names.index(name)]

    @property
    def nominal(self) -> dict[str, float]:
        """The nominal value of every parameter, in its unit."""
        return {p.name: float(p.nominal) for p in self.parameters}  # type: ignore[arg-type]

    @property
    def n_joints(self) -> int | None:
        """p for the PID form (the design-form state is 3p), else None."""
        return int(self.n_states) // 2 if self.form == "pid" else None

    @property
    def n_design_states(self) -> int:
        """States of the design form: 3p (PID), q + n_x (integral) or n_x."""
        if self.form == "pid":
            return 3 * (self.n_states // 2)
        if self.form == "integral":
            assert self.C is not None
            return int(self.C.shape[0]) + self.n_states
        return self.n_states

    @property
    def input_limits(self) -> Array | None:
        """Each input's limit (:attr:`Signal.limit`), shape (m,), in its unit; ``inf`` for an input without one.

        None when no input has a limit. What :func:`~scara_robust.input_limit_certificate`
        and :func:`~scara_robust.synthesize` take as their limits.
        """
        if all(s.limit is None for s in self.inputs):
            return None
        return np.array([math.inf if s.limit is None else s.limit for s in self.inputs], dtype=float)

    def box(self, theta: float = 1.0) -> dict[str, tuple[float, float]]:
        """Every parameter's range scaled by θ about its nominal (:meth:`Parameter.scaled_range`)."""
        theta = check_real("theta", theta, nonnegative=True)
        return {p.name: p.scaled_range(theta) for p in self.parameters}

    def scaled(self, theta: float) -> UncertainPlant:
        """The same plant with every range scaled by θ about its nominal (θ = 1: itself)."""
        box = self.box(theta)
        params = tuple(replace(p, range=box[p.name], rate=p.rate if box[p.name][0] < box[p.name][1] else None)
                       for p in self.parameters)
        hull = self.hull
        scaled_hull = None if hull is None else (lambda t: hull(t * theta))
        return replace(self, parameters=params, hull=scaled_hull)

    def with_ranges(self, ranges: Mapping[str, tuple[float, float]]) -> UncertainPlant:
        """The same plant with the ranges of some parameters replaced (units of each)."""
        for key in ranges:
            check_choice("ranges", key, self.names)
        params = tuple(replace(p, range=(float(ranges[p.name][0]), float(ranges[p.name][1])), nominal=None)
                       if p.name in ranges else p for p in self.parameters)
        return replace(self, parameters=params, hull=None)

    def coarse_points(self) -> dict[str, int]:
        """Each parameter's ``coarse`` count (the grid LMIs are solved on)."""
        return {p.name: int(p.coarse) for p in self.parameters}  # type: ignore[arg-type]

    def grid_points(self) -> dict[str, int]:
        """Each parameter's ``samples`` count: the default grid (of :meth:`samples` without points)."""
        return {p.name: p.samples for p in self.parameters}

    def fine_points(self) -> dict[str, int]:
        """``2·samples − 1`` per parameter: the default grid refined once between its points."""
        return {p.name: 2 * p.samples - 1 for p in self.parameters}

    def grid_values(self, points: Mapping[str, int] | None = None) -> Array:
        """The grid over the box, shape (k, n_parameters); the first parameter varies slowest.

        Parameters
        ----------
        points : mapping of str to int, optional
            Points per parameter (default each parameter's ``samples``); a fixed parameter
            has one.
        """
        points = dict(points or {})
        for key in points:
            check_choice("points", key, self.names)
        axes = []
        for p in self.parameters:
            count = check_int(f"points[{p.name!r}]", points.get(p.name, p.samples), 1) if p.varies else 1
            axes.append(np.linspace(p.range[0], p.range[1], count) if p.varies else np.array([p.range[0]]))
        size = math.prod(len(a) for a in axes)
        if size > _MAX_SAMPLES:
            raise ArgumentValueError("points", f"asks for {size:.3g} grid points, more than {_MAX_SAMPLES:.3g}")
        if not axes:
            return np.zeros((1, 0))
        mesh = np.meshgrid(*axes, indexing="ij")
        return np.stack([g.ravel() for g in mesh], axis=1)

    # --- frozen plants --------------------------------------------------------------------

    def _plant_matrices(self, values: Mapping[str, Array]) -> tuple[Array, Array]:
        shape = np.broadcast_shapes(*(np.shape(v) for v in values.values())) if values else ()
        A, B = self.matrices(values)
        return _stack(A, B, shape)

    def plant_matrices(self, values: ArrayLike | Mapping[str, Any]) -> tuple[Array, Array]:
        """``(A(p), B(p))`` in plant coordinates.

        Parameters
        ----------
        values : mapping of str to float or ndarray, or array_like, shape (k, n_parameters)
            A point (missing names take their nominal) or rows of points.

        Returns
        -------
        A : ndarray, shape (n_x, n_x) or (k, n_x, n_x)
        B : ndarray, shape (n_x, m) or (k, n_x, m)
        """
        vals = self._values(values)
        return self._plant_matrices(vals)

    def _values(self, values: ArrayLike | Mapping[str, Any]) -> dict[str, Array]:
        if isinstance(values, Mapping):
            for key in values:
                check_choice("values", key, self.names)
            return {name: np.asarray(values.get(name, self.nominal[name]), dtype=float) for name in self.names}
        arr = check_array("values", values, ndim=2)
        if arr.shape[1] != len(self.parameters):
            raise ArgumentValueError("values", f"must have {len(self.parameters)} columns ({', '.join(self.names)}), "
                                               f"found shape {arr.shape}")
        return {name: arr[:, k] for k, name in enumerate(self.names)}

    def design_form(self, A: Array, B: Array) -> tuple[Array, Array]:
        """The design form of plant matrices (stacks allowed).

        Parameters
        ----------
        A : ndarray, shape (..., n_x, n_x)
        B : ndarray, shape (..., n_x, m)

        Returns
        -------
        A, B : ndarray, shapes (..., n, n) and (..., n, m)
            n = :attr:`n_design_states`.
        """
        n, m = self.n_states, self.n_inputs
        lead = A.shape[:-2]
        if self.form == "state":
            return A, B
        if self.form == "pid":
            p = n // 2
            A_aug = np.zeros(lead + (3 * p, 3 * p))
            A_aug[..., :p, p:2 * p] = np.eye(p)
            A_aug[..., p:2 * p, 2 * p:] = np.eye(p)
            A_aug[..., 2 * p:, p:] = A[..., p:, :]
            B_aug = np.zeros(lead + (3 * p, m))
            B_aug[..., 2 * p:, :] = -B[..., p:, :]
            return A_aug, B_aug
        assert self.C is not None
        q = self.C.shape[0]
        A_aug = np.zeros(lead + (q + n, q + n))
        A_aug[..., :q, q:] = -self.C
        A_aug[..., q:, q:] = A
        B_aug = np.zeros(lead + (q + n, m))
        B_aug[..., q:, :] = B
        return A_aug, B_aug

    def _check_form(self, grid: Array, A: Array, B: Array) -> None:
        """Finite matrices ``A``, ``B`` (the plant's at the rows of `grid`), and what the design form needs of them."""
        bad = ~(np.isfinite(A).all(axis=(-2, -1)) & np.isfinite(B).all(axis=(-2, -1)))
        if bad.any():
            k = int(np.argmax(bad))
            label, M = ("A", A[k]) if not np.isfinite(A[k]).all() else ("B", B[k])
            i, j = (int(v) for v in np.argwhere(~np.isfinite(M))[0])
            raise ArgumentValueError(f"{label}[{i}][{j}]", f"is {M[i, j]} at {self._point(grid[k])}: the plant is "
                                                           "undefined (singular) there")
        n = self.n_states
        if self.form == "pid":
            p = n // 2
            kinematic = np.hstack([np.zeros((p, p)), np.eye(p)])
            if not (np.allclose(A[:, :p], kinematic) and np.allclose(B[:, :p], 0.0)):
                raise ArgumentValueError("A", "must be in second-order form for form='pid': A = [[0, I], [A_q, A_v]], "
                                              "B = [[0], [B_u]] (state [q, q̇])")
            # the integrators of ∫e need every joint actuated: B_u of full row rank p
            ranks = np.linalg.matrix_rank(B[:, p:, :])
            worst = int(np.argmin(ranks))
            if ranks[worst] < p:
                raise ArgumentValueError(
                    "B", f"input rows B_u (p = {p}) have rank {int(ranks[worst])} < {p} at "
                         f"{self._point(grid[worst])}: the PID form's integrators cannot be driven there (a plant zero "
                         "at s = 0)")
        elif self.form == "integral":
            assert self.C is not None
            q = self.C.shape[0]
            top = np.concatenate([A, B], axis=-1)
            bottom = np.broadcast_to(np.concatenate([self.C, np.zeros((q, self.n_inputs))], axis=1),
                                     (A.shape[0], q, n + self.n_inputs))
            ranks = np.linalg.matrix_rank(np.concatenate([top, bottom], axis=-2))
            worst = int(np.argmin(ranks))
            if ranks[worst] < n + q:
                raise ArgumentValueError(
                    "A", f"[[A, B], [C, 0]] is singular at {self._point(grid[worst])}: the plant has a zero at s = 0 "
                         "there, which cancels the integrator of form='integral'")

    def _point(self, row: Array) -> str:
        if not len(self.parameters):
            return "the nominal point"
        return ", ".join(f"{p.name} = {v:.6g} {p.unit}" for p, v in zip(self.parameters, row))

    def frozen(self, values: Mapping[str, Any] | None = None) -> tuple[Array, Array]:
        """The design-form ``(A, B)`` at one parameter point (missing names: nominal).

        Parameters
        ----------
        values : mapping of str to float, optional

        Returns
        -------
        A : ndarray, shape (n, n)
        B : ndarray, shape (n, m)
        """
        vals = self._values(values or {})
        for name, v in vals.items():
            if v.ndim != 0:
                raise ArgumentValueError(f"values[{name!r}]", f"must be a number, found shape {v.shape}")
        A, B = self._plant_matrices({k: v[None] for k, v in vals.items()})
        A_aug, B_aug = self.design_form(A, B)
        return np.asarray(A_aug[0]), np.asarray(B_aug[0])

    def samples(self, points: Mapping[str, int] | None = None, *, theta: float = 1.0) -> ParameterSamples:
        """The design-form plants on the grid of the (scaled) parameter box.

        Parameters
        ----------
        points : mapping of str to int, optional
            Points per parameter (default each parameter's ``samples``).
        theta : float
            Scaling of the box about the nominal (1: the plant's own).

        Returns
        -------
        ParameterSamples
        """
        plant = self if theta == 1.0 else self.scaled(theta)
        grid = plant.grid_values(points)
        n = self.n_design_states
        check_memory("points", grid.shape[0] * 8 * (n * n + n * self.n_inputs) * 3,
                     f"{grid.shape[0]} frozen plants of {n} states")
        A, B = plant._plant_matrices({name: grid[:, k] for k, name in enumerate(self.names)})
        A_aug, B_aug = self.design_form(A, B)
        return ParameterSamples(self.names, grid, np.asarray(A_aug), np.asarray(B_aug))

    @property
    def capabilities(self) -> frozenset[str]:
        """``{'intervals', 'vertices', 'parameters'}``, and ``'rates'`` when a parameter has a rate bound.

        Its interval hull (:meth:`interval_model`) gives the intervals and their corners.
        """
        rates = {"rates"} if any(p.rate is not None for p in self.parameters) else set()
        return frozenset({"intervals", "vertices", "parameters", *rates})

    def interval_hull(self) -> UncertainLTVModel:
        """The interval box holding the plant's frozen plants on its grid (:meth:`interval_model` at θ = 1)."""
        return self.interval_model()

    def interval_model(self, theta: float = 1.0) -> UncertainLTVModel:
        """The interval hull of the design-form family over the (scaled) box.

        For a plant built from expressions, each entry's range over the box is an
        enclosure (it holds every value over the box): exact where the entry is proven
        monotone in each parameter (the interval enclosure of each partial derivative
        keeps one sign; its corners) or uses each varying parameter once, otherwise
        refined by subdividing the box until it exceeds the sampled range by at most a
        relative 1e-6 (:meth:`entry_ranges` says which, entry by entry). For any other
        plant it is the range over :meth:`samples` (exact when the entries are monotone
        in each parameter, the grid holding the corners). Nominal at the element-wise
        minima, each varying entry ``[0, max − min]`` (the paper's convention, Tables 1–2).

        Parameters
        ----------
        theta : float
            Scaling of the parameter box about the nominal.

        Returns
        -------
        UncertainLTVModel

        Raises
        ------
        ArgumentValueError
            Naming the entry, where it is undefined on the box (division by a range
            holding 0, ...).
        """
        theta = check_real("theta", theta, nonnegative=True)
        if self.hull is not None:
            return self.hull(theta)
        box = self._interval_box(theta)
        return box.centered() if self.design_plant == "center" else box

    def _interval_box(self, theta: float) -> UncertainLTVModel:

        plant = self if theta == 1.0 else self.scaled(theta)
        if self.entries is not None:
            lows = [np.empty((self.n_states, self.n_states)), np.empty((self.n_states, self.n_inputs))]
            highs = [np.empty_like(lows[0]), np.empty_like(lows[1])]
            for label, i, j, _, r in matrix_ranges((("A", self.entries[0]), ("B", self.entries[1])), plant.box()):
                k = 0 if label == "A" else 1
                lows[k][i, j], highs[k][i, j] = r.lower, r.upper
            A_from_lo, B_from_lo = self.design_form(lows[0], lows[1])
            A_from_hi, B_from_hi = self.design_form(highs[0], highs[1])
            # the PID form's input matrix is −B_u: min and max over both ends give its bounds
            stack_A = np.stack([A_from_lo, A_from_hi])
            stack_B = np.stack([B_from_lo, B_from_hi])
            return hull_of_stacks(stack_A, stack_B, self.name, self.n_joints, rtol=0.0)
        s = plant.samples()
        return hull_of_stacks(s.A, s.B, self.name, self.n_joints)

    def entry_ranges(self, theta: float = 1.0) -> pd.DataFrame:
        """The range of every entry of A and B over the (scaled) box, and whether it is exact.

        The ranges :meth:`interval_model` builds its hull from, in plant coordinates (the
        PID form's ``A[2][1]`` is the plant's ``A[1][0]``, its input matrix ``−B``).

        Parameters
        ----------
        theta : float
            Scaling of the parameter box about the nominal (1: the plant's own).

        Returns
        -------
        pandas.DataFrame
            One row per entry, A's row by row then B's: ``matrix`` ('A' or 'B'), ``row``,
            ``col``, ``text`` (the entry as written), ``lower`` and ``upper`` (an interval
            holding every value over the box, in the entry's unit), ``how`` and ``gap``.
            ``how`` is ``'constant'`` (no varying parameter), ``'monotone'`` (the interval
            enclosure of every partial derivative keeps one sign: the range of the box's
            corners, exact), ``'single-use'`` (each varying parameter occurs once: interval
            arithmetic is exact), ``'refined'`` (the box subdivided until the enclosure
            exceeds the sampled range by at most a relative 1e-6) or ``'enclosure'`` (that
            tolerance not reached within 4096 sub-boxes). ``gap`` bounds how much wider
            than the true range ``[lower, upper]`` is (0 where exact), in the entry's unit.

        Raises
        ------
        ArgumentValueError
            For a plant not written as expressions (:meth:`from_function`,
            :meth:`from_system`: its hull is the range over :meth:`samples`), or naming
            the entry where it is undefined on the box.

        Examples
        --------
        >>> import scara_robust as sr
        >>> m = sr.Parameter("m", "kg", (0.0, 1.0))
        >>> plant = sr.UncertainPlant.from_expressions([m], [[0, 1], ["m/(1 + m) - 1", 0]], [[0], [1]])
        >>> plant.entry_ranges()[["matrix", "row", "col", "lower", "upper", "how"]].iloc[2]
        matrix           A
        row              1
        col              0
        lower         -1.0
        upper         -0.5
        how       monotone
        Name: 2, dtype: object
        """

        theta = check_real("theta", theta, nonnegative=True)
        if self.entries is None:
            raise ArgumentValueError("plant", f"{self.name!r} is not written as expressions (a plant file or "
                                              "UncertainPlant.from_expressions): its interval_model() is a "
                                              "published hull or the range over its samples()")
        plant = self if theta == 1.0 else self.scaled(theta)
        rows = [(label, i, j, expr.text, r.lower, r.upper, r.how, r.gap) for label, i, j, expr, r in
                matrix_ranges((("A", self.entries[0]), ("B", self.entries[1])), plant.box())]
        return pd.DataFrame(rows, columns=["matrix", "row", "col", "text", "lower", "upper", "how", "gap"])

    def polytope(self, theta: float = 1.0, points: Mapping[str, int] | None = None) -> PolytopicModel:
        """The polytope whose vertices are the sampled design-form plants (nominal: the hull's).

        Its convex hull holds the family when the entries are affine in the parameters;
        otherwise it is a gridding of it.
        """
        s = self.samples(points, theta=theta)
        hull = self.interval_model(theta)
        return PolytopicModel(s.A, s.B, nominal=(hull.A, hull.B), name=self.name)

    def to_pandas(self) -> pd.DataFrame:
        """One row per parameter: name, unit, lower, upper, nominal, rate [unit/s], samples."""
        rows = [(p.name, p.unit, p.range[0], p.range[1], p.nominal, p.rate, p.samples) for p in self.parameters]
        return pd.DataFrame(rows, columns=["name", "unit", "lower", "upper", "nominal", "rate [unit/s]", "samples"])


@dataclass(frozen=True, eq=False)
class NonlinearDynamics:
    """The nonlinear system behind a plant of :meth:`UncertainPlant.from_nonlinear`, and its operating point.

    The plant's coordinates are relative to ``x_eq``: the system's state is ``x_eq + x``,
    its input ``u_op(t) + u`` (the operating input: ``u_eq``, or the input holding the
    reference at the nominal parameters).

    Attributes
    ----------
    sys : control.NonlinearIOSystem
    x_eq : ndarray, shape (2p,)
    u_eq : ndarray, shape (m,)
    reference : (ndarray of shape (p,), float) or None
        Amplitudes and ω (rad/s) of the reference ``a sin ωt`` the plant is linearized along.
    nominal : dict of str to float
        The nominal parameters the operating input is computed at.
    """

    sys: Any
    x_eq: Array
    u_eq: Array
    reference: tuple[Array, float] | None
    nominal: dict[str, float]

    def operating_point(self, t: float) -> tuple[Array, Array]:
        """``(x_op, u_op)`` at time t: the equilibrium, or the reference's state and the input that holds it.

        Along a reference, ``u_op`` solves ``f₂(x_r, u) = q̈_r`` (the velocity rows of the
        dynamics) by Newton's method from ``u_eq``, with the linearization's B; one step for a
        system affine in u.

        Parameters
        ----------
        t : float
            Time, s.

        Returns
        -------
        x_op : ndarray, shape (2p,)
        u_op : ndarray, shape (m,)

        Raises
        ------
        ArgumentValueError
            Naming ``sys`` where the input cannot hold the reference (Newton's method fails).
        """
        if self.reference is None:
            return self.x_eq, self.u_eq
        amp, omega = self.reference
        p = amp.size
        x_op = self.x_eq + np.concatenate([amp * math.sin(omega * t), amp * omega * math.cos(omega * t)])
        qdd = -amp * omega**2 * math.sin(omega * t)
        params = {**self.sys.params, **self.nominal}
        u = self.u_eq.copy()
        for _ in range(20):
            residual = np.asarray(self.sys.dynamics(t, x_op, u, params), dtype=float)[p:] - qdd
            if np.abs(residual).max() <= 1e-12 * max(1.0, float(np.abs(qdd).max())):
                return x_op, u
            B = np.asarray(ct.linearize(self.sys, x_op, u, params=params).B, dtype=float)[p:]
            u = u - np.linalg.lstsq(B, residual, rcond=None)[0]
        raise ArgumentValueError("sys", f"cannot hold the reference at t = {t:g} s: Newton's method on the input "
                                        "did not converge (is q̈ controlled by u?)")

    def rhs(self, t: float, x: Array, u: Array, values: Mapping[str, float]) -> Array:
        """``ẋ`` in the plant's coordinates: the system at ``x_eq + x`` under ``u_op(t) + u``, parameters `values`.

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (2p,)
        u : ndarray, shape (m,)
            The controller's input (beside the operating input).
        values : mapping of str to float
            The parameters (``t_ref`` ignored).

        Returns
        -------
        ndarray, shape (2p,)
        """
        x_op, u_op = self.operating_point(t)
        params = {**self.sys.params, **{k: v for k, v in values.items() if k != "t_ref"}}
        return np.asarray(self.sys.dynamics(t, self.x_eq + x, u_op + u, params), dtype=float)



def hull_of_stacks(A: Array, B: Array, name: str, n_joints: int | None, rtol: float = HULL_RTOL) -> UncertainLTVModel:
    """The interval model of stacks of matrices: nominal at the element-wise minima, ``[0, max − min]``.

    Parameters
    ----------
    A : ndarray, shape (k, n, n)
    B : ndarray, shape (k, n, m)
    name : str
    n_joints : int or None
        As for :class:`UncertainLTVModel`.
    rtol : float
        An entry varies when its range exceeds `rtol` times its stack's largest magnitude
        (0: any difference; the stacks of an enclosure's two ends).

    Returns
    -------
    UncertainLTVModel
        Entries that do not vary keep the first matrix's value.
    """
    elements: list[UncertainElement] = []
    nominal = {}
    for label, stack in (("A", A), ("B", B)):
        low, high = stack.min(axis=0), stack.max(axis=0)
        scale = max(float(np.abs(stack).max()), 1e-300)
        varying = high - low > rtol * scale
        nominal[label] = np.where(varying, low, stack[0])
        for i, j in zip(*np.nonzero(varying)):
            elements.append(UncertainElement("A" if label == "A" else "B", int(i), int(j), 0.0,
                                             float(high[i, j] - low[i, j])))
    return UncertainLTVModel(nominal["A"], nominal["B"], tuple(elements), name=name, n_joints=n_joints)


#: What every analysis takes: a plant, an interval box or a polytope.
ModelLike = UncertainPlant | UncertainLTVModel | PolytopicModel


def is_model(value: object) -> bool:
    """Whether `value` is an uncertainty description every analysis takes.

    Parameters
    ----------
    value : object

    Returns
    -------
    bool
        True for an :class:`UncertainPlant`, an :class:`UncertainLTVModel` or a
        :class:`PolytopicModel`.
    """
    return isinstance(value, (UncertainPlant, UncertainLTVModel, PolytopicModel))


def as_model(name: str, value: object) -> UncertainLTVModel | PolytopicModel:
    """The uncertainty set an analysis works on: a plant's interval hull, or the set itself.

    Parameters
    ----------
    name : str
        The argument's name, for errors.
    value : UncertainPlant, UncertainLTVModel or PolytopicModel

    Returns
    -------
    UncertainLTVModel or PolytopicModel

    Raises
    ------
    ArgumentTypeError
        For anything else.
    """
    if isinstance(value, UncertainPlant):
        return value.interval_model()
    if isinstance(value, (UncertainLTVModel, PolytopicModel)):
        return value
    raise ArgumentTypeError(name, f"must be an UncertainPlant, an UncertainLTVModel or a PolytopicModel, found "
                                  f"{type(value).__name__}")


def require_plant(name: str, value: object) -> UncertainPlant:
    """`value`, which must be an :class:`UncertainPlant` (an analysis in the parameters' units).

    Parameters
    ----------
    name : str
        The argument's name, for errors.
    value : object

    Returns
    -------
    UncertainPlant

    Raises
    ------
    ArgumentTypeError
        For anything else (an interval box or a polytope has no physical parameters).
    """
    if not isinstance(value, UncertainPlant):
        raise ArgumentTypeError(name, f"must be an UncertainPlant (sr.load_plant, sr.UncertainPlant...), found "
                                      f"{type(value).__name__}")
    return value


def as_plant(name: str, value: object) -> UncertainPlant | None:
    """`value` if it is an :class:`UncertainPlant` (the physical analyses need one), else None.

    Parameters
    ----------
    name : str
        The argument's name (kept for symmetry with :func:`as_model`).
    value : object

    Returns
    -------
    UncertainPlant or None
    """
    return value if isinstance(value, UncertainPlant) else None


def as_box(name: str, value: object,
           hint: str = "this needs interval elements; model.box_hull() is the box around it") -> UncertainLTVModel:
    """The interval box of `value` (a plant's hull, or the box itself); a polytope is refused.

    Parameters
    ----------
    name : str
        The argument's name, for errors.
    value : UncertainPlant or UncertainLTVModel
    hint : str
        What to do instead, said when `value` is a polytope.

    Returns
    -------
    UncertainLTVModel

    Raises
    ------
    ArgumentTypeError
        For a polytope or anything else.
    """
    model = as_model(name, value)
    if not isinstance(model, UncertainLTVModel):
        raise ArgumentTypeError(name, f"is a PolytopicModel: {hint}")
    return model
