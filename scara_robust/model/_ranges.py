"""The range of a plant file's entry over the parameter box: exact where it can be proven, else tight.

Natural interval arithmetic (:meth:`Expression.interval`) counts a parameter that appears
twice as two independent ones, so ``-(a + m*L)*g/(c + m*L**2)`` over ``m ∈ [0, 2]`` comes out
fifty times wider than its true range. :func:`entry_range` does better, and says how well:

1. **constant** — no parameter of the entry varies: its one value.
2. **monotone** — the interval enclosure of every partial derivative ``∂f/∂p_k`` over the
   box keeps one sign (``≥ 0`` or ``≤ 0``; the derivatives are taken symbolically from the
   entry's syntax tree, :func:`partial_derivative`): f is monotone in each parameter, so
   its range is spanned by the box's corners, where it is evaluated. Exact.
3. **single-use** — every varying parameter occurs once in the entry: natural interval
   arithmetic is then exact (each operation's interval is its exact range). Exact.
4. **refined** — otherwise the box is subdivided (branch and bound): the sub-box holding
   the enclosure's lowest or highest end is bisected along its widest parameter (relative
   to the box's own width of it). On a sub-box where monotonicity is proven, its corners
   give its exact range; elsewhere the natural interval enclosure intersected with the
   mean-value form ``f(c) + Σ_k ∂f/∂p_k(box)·[p_k − c_k]``. The union over the sub-boxes
   is an enclosure of the range; the values at every sub-box's corners and centre give a
   lower estimate (the *sampled range*). The refinement stops when the enclosure is within
   the tolerance of the sampled range::

       (enclosure width − sampled width) <= rtol · max(sampled width, |sampled ends|)

   with ``rtol =`` :data:`RANGE_RTOL` (so an entry that is 0 everywhere stops at width 0).
5. **enclosure** — the tolerance was not reached within :data:`RANGE_MAX_BOXES` sub-boxes:
   still an enclosure, ``gap`` says by how much it may exceed the true range.

Every answer contains every value of the entry over the box (up to the floating-point
rounding of the evaluations, as :meth:`Expression.interval`), and is never narrower than its
true range; where the entry is undefined on the box the error of
:meth:`Expression.interval` names it.
"""

from __future__ import annotations

import ast
import heapq
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..exceptions import ArgumentValueError
from ._expressions import CONSTANTS, Expression, evaluate_tree

__all__ = ["EntryRange", "entry_range", "matrix_ranges", "partial_derivative", "RANGE_RTOL", "RANGE_MAX_BOXES",
           "RANGE_HOWS"]

Array = NDArray[np.float64]
Interval = tuple[float, float]

#: Relative tolerance of a refined range: stop when (enclosure width − sampled width) <=
#: RANGE_RTOL · max(sampled width, largest |sampled end|).
RANGE_RTOL = 1e-6
#: Sub-boxes a refinement may evaluate (the whole box counts as one) before it stops with
#: ``how = 'enclosure'``.
RANGE_MAX_BOXES = 4096
#: What ``EntryRange.how`` may say, from the tightest down (see the module docstring).
RANGE_HOWS = ("constant", "monotone", "single-use", "refined", "enclosure")
#: Above this many varying parameters a sub-box is sampled at its centre and face centres
#: instead of its 2^k corners.
_MAX_CORNER_PARAMETERS = 10


@dataclass(frozen=True)
class EntryRange:
    """The range of one entry over a parameter box, and how it was obtained.

    Attributes
    ----------
    lower, upper : float
        An interval holding every value of the entry over the box, in the entry's unit;
        the exact range where `how` is ``'constant'``, ``'monotone'`` or ``'single-use'``.
    how : str
        One of :data:`RANGE_HOWS` (module docstring).
    gap : float
        How much wider than the true range ``[lower, upper]`` may be, in the entry's unit:
        0 where exact, else (enclosure width − sampled width), the sampled range being
        the values at the sub-boxes' corners and centres (a lower estimate of the range).
    boxes : int
        Sub-boxes evaluated (1 when the whole box sufficed, 0 for a constant).
    """

    lower: float
    upper: float
    how: str
    gap: float
    boxes: int = 1

    @property
    def exact(self) -> bool:
        """Whether ``[lower, upper]`` is the exact range (constant, monotone, single-use, or a zero gap)."""
        return self.how in RANGE_HOWS[:3] or self.gap == 0.0


# --- symbolic partial derivatives of the whitelisted syntax tree ---------------------------------


def _number(node: ast.AST) -> float | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    return None


def _num(value: float) -> ast.Constant:
    return ast.Constant(value=float(value))


def _neg(a: ast.expr) -> ast.expr:
    v = _number(a)
    if v is not None:
        return _num(-v)
    if isinstance(a, ast.UnaryOp) and isinstance(a.op, ast.USub):
        return a.operand
    return ast.UnaryOp(op=ast.USub(), operand=a)


def _add(a: ast.expr, b: ast.expr) -> ast.expr:
    va, vb = _number(a), _number(b)
    if va is not None and vb is not None:
        return _num(va + vb)
    if va == 0.0:
        return b
    if vb == 0.0:
        return a
    return ast.BinOp(left=a, op=ast.Add(), right=b)


def _sub(a: ast.expr, b: ast.expr) -> ast.expr:
    va, vb = _number(a), _number(b)
    if va is not None and vb is not None:
        return _num(va - vb)
    if vb == 0.0:
        return a
    if va == 0.0:
        return _neg(b)
    return ast.BinOp(left=a, op=ast.Sub(), right=b)


def _mul(a: ast.expr, b: ast.expr) -> ast.expr:
    va, vb = _number(a), _number(b)
    if va == 0.0 or vb == 0.0:
        return _num(0.0)
    if va is not None and vb is not None:
        return _num(va * vb)
    if va == 1.0:
        return b
    if vb == 1.0:
        return a
    if va == -1.0:
        return _neg(b)
    if vb == -1.0:
        return _neg(a)
    return ast.BinOp(left=a, op=ast.Mult(), right=b)


def _div(a: ast.expr, b: ast.expr) -> ast.expr:
    if _number(a) == 0.0:
        return _num(0.0)
    if _number(b) == 1.0:
        return a
    return ast.BinOp(left=a, op=ast.Div(), right=b)


def _pow(a: ast.expr, k: float) -> ast.expr:
    if k == 0.0:
        return _num(1.0)
    if k == 1.0:
        return a
    return ast.BinOp(left=a, op=ast.Pow(), right=_num(k))


def _call(fn: str, a: ast.expr) -> ast.expr:
    return ast.Call(func=ast.Name(id=fn, ctx=ast.Load()), args=[a], keywords=[])


def _derive(node: ast.AST, p: str) -> ast.expr:
    """∂node/∂p as a syntax tree of the same whitelist (zeros and ones folded)."""
    if isinstance(node, ast.Expression):
        return _derive(node.body, p)
    if isinstance(node, ast.Constant):
        return _num(0.0)
    if isinstance(node, ast.Name):
        return _num(1.0 if node.id == p and node.id not in CONSTANTS else 0.0)
    if isinstance(node, ast.UnaryOp):
        du = _derive(node.operand, p)
        return _neg(du) if isinstance(node.op, ast.USub) else du
    if isinstance(node, ast.BinOp):
        u, v = node.left, node.right
        du = _derive(u, p)
        if isinstance(node.op, ast.Pow):  # the exponent is a number (checked when parsed)
            k = float(evaluate_tree(v, {}))
            return _mul(_mul(_num(k), _pow(u, k - 1.0)), du)
        dv = _derive(v, p)
        if isinstance(node.op, ast.Add):
            return _add(du, dv)
        if isinstance(node.op, ast.Sub):
            return _sub(du, dv)
        if isinstance(node.op, ast.Mult):
            return _add(_mul(du, v), _mul(u, dv))
        assert isinstance(node.op, ast.Div)
        if _number(dv) == 0.0:
            return _div(du, v)
        # (u'v − uv')/v²: its sign is its numerator's, evaluated as one interval
        return _div(_sub(_mul(du, v), _mul(u, dv)), _pow(v, 2.0))
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    u = node.args[0]
    du = _derive(u, p)
    if _number(du) == 0.0:
        return _num(0.0)
    fn = node.func.id
    if fn == "sqrt":
        return _div(_mul(_num(0.5), du), _call("sqrt", u))
    if fn == "exp":
        return _mul(_call("exp", u), du)
    if fn == "log":
        return _div(du, u)
    if fn == "sin":
        return _mul(_call("cos", u), du)
    if fn == "cos":
        return _neg(_mul(_call("sin", u), du))
    if fn == "tanh":
        return _mul(_sub(_num(1.0), _pow(_call("tanh", u), 2.0)), du)
    assert fn == "abs"
    # sign(u)·u', written u/|u|: its enclosure is defined only where |u|'s does not hold 0
    return _mul(_div(u, _call("abs", u)), du)


def partial_derivative(expr: Expression, name: str) -> Expression:
    """The symbolic partial derivative of an entry with respect to one parameter.

    Parameters
    ----------
    expr : Expression
        The entry.
    name : str
        A parameter name (one that `expr` does not use gives the constant 0).

    Returns
    -------
    Expression
        ∂expr/∂name, in the entry's unit per the parameter's unit, over the same
        whitelist (``abs`` differentiates to ``u/abs(u)``, its sign where u ≠ 0).

    Examples
    --------
    >>> from scara_robust.model._expressions import parse_expression
    >>> partial_derivative(parse_expression("m/(1 + m)", {"m"}), "m").text
    '(1 + m - m) / (1 + m) ** 2.0'
    """
    return _partials(expr)[name] if name in expr.names else Expression("0.0", frozenset(), expr.label, ast.Expression(
        body=_num(0.0)))


@lru_cache(maxsize=512)
def _partials(expr: Expression) -> dict[str, Expression]:
    out = {}
    for name in sorted(expr.names):
        tree = ast.Expression(body=_derive(expr._tree, name))
        used = frozenset(n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id in expr.names)
        out[name] = Expression(ast.unparse(tree), used, f"∂{expr.label}/∂{name}", tree)
    return out


@lru_cache(maxsize=512)
def _occurrences(expr: Expression) -> dict[str, int]:
    called = {id(n.func) for n in ast.walk(expr._tree) if isinstance(n, ast.Call)}
    counts = dict.fromkeys(expr.names, 0)
    for n in ast.walk(expr._tree):
        if isinstance(n, ast.Name) and id(n) not in called and n.id in counts:
            counts[n.id] += 1
    return counts


# --- the range over a box ---------------------------------------------------------------------


def _slope(expr: Expression, box: Mapping[str, Interval]) -> Interval | None:
    """The enclosure of a derivative over the box, or None where it is undefined there."""
    try:
        return expr.interval(box)
    except (ArgumentValueError, OverflowError, ZeroDivisionError, ValueError):
        return None


class _Evaluator:
    """Evaluates one entry on sub-boxes of a box: its varying parameters in a fixed order."""

    def __init__(self, expr: Expression, box: Mapping[str, Interval], varying: Sequence[str]) -> None:
        self.expr = expr
        self.fixed = {k: box[k] for k in expr.names if k not in varying}
        self.varying = tuple(varying)
        self.partials = _partials(expr)
        n = len(self.varying)
        if n <= _MAX_CORNER_PARAMETERS:
            self.pattern = np.array(list(itertools.product((0.0, 1.0), repeat=n)) + [[0.5] * n], dtype=float)
        else:  # the centre and the centre of every face
            faces = np.full((2 * n + 1, n), 0.5)
            for k in range(n):
                faces[2 * k, k], faces[2 * k + 1, k] = 0.0, 1.0
            self.pattern = faces

    def sub_box(self, lo: Array, hi: Array) -> dict[str, Interval]:
        out = dict(self.fixed)
        out.update({k: (float(a), float(b)) for k, a, b in zip(self.varying, lo, hi)})
        return out

    def values(self, points: Array) -> Array:
        """The entry at rows of points (columns: the varying parameters)."""
        vals: dict[str, float | Array] = {k: v[0] for k, v in self.fixed.items()}
        vals.update({k: points[:, i] for i, k in enumerate(self.varying)})
        return np.broadcast_to(self.expr(vals), (points.shape[0],))

    def slopes(self, box: Mapping[str, Interval]) -> list[Interval | None]:
        return [_slope(self.partials[k], box) for k in self.varying]

    def evaluate(self, lo: Array, hi: Array,
                 natural: Interval | None = None) -> tuple[float, float, float, float, bool]:
        """(enclosure low, high, sampled low, high, exact) of the entry on one sub-box."""
        box = self.sub_box(lo, hi)
        slopes = self.slopes(box)
        monotone = all(s is not None and (s[0] >= 0.0 or s[1] <= 0.0) for s in slopes)
        points = lo + self.pattern * (hi - lo)
        if monotone and len(self.varying) > _MAX_CORNER_PARAMETERS:
            # the two corners where a monotone entry takes its least and its greatest value
            up = np.array([s is not None and s[0] >= 0.0 for s in slopes])
            points = np.vstack([points, np.where(up, lo, hi), np.where(up, hi, lo)])
        values = self.values(points)
        s_lo, s_hi = float(values.min()), float(values.max())
        if monotone:
            return s_lo, s_hi, s_lo, s_hi, True
        if natural is None:
            try:
                natural = self.expr.interval(box)
            except ArgumentValueError:  # not expected on a sub-box of a box where it is defined
                natural = (-math.inf, math.inf)
        e_lo, e_hi = natural
        known = [s for s in slopes if s is not None]
        if len(known) == len(slopes):  # the mean-value form about the centre (the pattern's last point)
            centre = float(values[len(self.pattern) - 1])
            radius = sum(max(abs(s[0]), abs(s[1])) * float(b - a) / 2.0 for s, a, b in zip(known, lo, hi))
            if math.isfinite(centre) and math.isfinite(radius):
                e_lo, e_hi = max(e_lo, centre - radius), min(e_hi, centre + radius)
        # the samples are values of the entry: the enclosure holds them whatever the rounding
        return min(e_lo, s_lo), max(e_hi, s_hi), s_lo, s_hi, False


def entry_range(expr: Expression, box: Mapping[str, tuple[float, float]], *, rtol: float = RANGE_RTOL,
                max_boxes: int = RANGE_MAX_BOXES) -> EntryRange:
    """The range of one entry over a box of its parameters: exact where provable, else refined.

    Parameters
    ----------
    expr : Expression
        The entry.
    box : mapping of str to (lower, upper)
        The range of each name of ``expr.names``, in its unit (equal ends: fixed).
    rtol : float
        Relative tolerance of a refined range (module docstring), default :data:`RANGE_RTOL`.
    max_boxes : int
        Sub-boxes a refinement may evaluate, default :data:`RANGE_MAX_BOXES`.

    Returns
    -------
    EntryRange

    Raises
    ------
    ArgumentValueError
        Naming the entry, where it is undefined on the box (as :meth:`Expression.interval`).

    Examples
    --------
    >>> from scara_robust.model._expressions import parse_expression
    >>> e = parse_expression("m/(1 + m)", {"m"})
    >>> e.interval({"m": (0.0, 1.0)}), entry_range(e, {"m": (0.0, 1.0)})
    ((0.0, 1.0), EntryRange(lower=0.0, upper=0.5, how='monotone', gap=0.0, boxes=1))
    """
    return _entry_range(expr, tuple(sorted((k, (float(box[k][0]), float(box[k][1]))) for k in expr.names)),
                        float(rtol), int(max_boxes))


@lru_cache(maxsize=2048)
def _entry_range(expr: Expression, items: tuple[tuple[str, Interval], ...], rtol: float,
                 max_boxes: int) -> EntryRange:
    box = dict(items)
    varying = [k for k, (a, b) in items if a < b]
    if not varying:
        value = float(expr({k: a for k, (a, _) in items}))
        return EntryRange(value, value, "constant", 0.0, 0)
    natural = expr.interval(box)  # raises, naming the entry, where it is undefined on the box
    ev = _Evaluator(expr, box, varying)
    lo0 = np.array([box[k][0] for k in varying], dtype=float)
    hi0 = np.array([box[k][1] for k in varying], dtype=float)
    e_lo, e_hi, s_lo, s_hi, exact = ev.evaluate(lo0, hi0, natural)
    if exact:
        return EntryRange(e_lo, e_hi, "monotone", 0.0)
    if all(_occurrences(expr)[k] == 1 for k in varying):
        return EntryRange(min(natural[0], s_lo), max(natural[1], s_hi), "single-use", 0.0)
    width0 = hi0 - lo0
    # the non-exact leaves, on two heaps: by their enclosure's low end and by its high end
    leaves: dict[int, tuple[Array, Array, float, float]] = {0: (lo0, hi0, e_lo, e_hi)}
    by_low: list[tuple[float, int]] = [(e_lo, 0)]
    by_high: list[tuple[float, int]] = [(-e_hi, 0)]
    count, boxes = itertools.count(1), 1
    while True:
        while by_low and by_low[0][1] not in leaves:
            heapq.heappop(by_low)
        while by_high and by_high[0][1] not in leaves:
            heapq.heappop(by_high)
        low = min(s_lo, by_low[0][0]) if by_low else s_lo
        high = max(s_hi, -by_high[0][0]) if by_high else s_hi
        gap = max((high - low) - (s_hi - s_lo), 0.0)
        if gap <= rtol * max(s_hi - s_lo, abs(s_lo), abs(s_hi)):
            return EntryRange(low, high, "refined", gap, boxes)
        if boxes + 2 > max_boxes:
            return EntryRange(low, high, "enclosure", gap, boxes)
        # bisect the leaf that holds the end further outside the sampled range
        key = by_low[0][1] if s_lo - low >= high - s_hi else by_high[0][1]
        lo, hi, _, _ = leaves.pop(key)
        k = int(np.argmax((hi - lo) / width0))
        mid = 0.5 * (lo[k] + hi[k])
        left_hi, right_lo = hi.copy(), lo.copy()
        left_hi[k] = right_lo[k] = mid
        for a, b in ((lo, left_hi), (right_lo, hi)):
            c_lo, c_hi, t_lo, t_hi, c_exact = ev.evaluate(a, b)
            boxes += 1
            s_lo, s_hi = min(s_lo, t_lo), max(s_hi, t_hi)
            if not c_exact:
                key = next(count)
                leaves[key] = (a, b, c_lo, c_hi)
                heapq.heappush(by_low, (c_lo, key))
                heapq.heappush(by_high, (-c_hi, key))


def matrix_ranges(tables: Sequence[tuple[str, Sequence[Sequence[Expression]]]], box: Mapping[str, Interval], *,
                  rtol: float = RANGE_RTOL, max_boxes: int = RANGE_MAX_BOXES
                  ) -> list[tuple[str, int, int, Expression, EntryRange]]:
    """:func:`entry_range` of every entry of some matrices of expressions.

    Parameters
    ----------
    tables : sequence of (str, rows of Expression)
        ``[("A", A_entries), ("B", B_entries)]``: a label and the matrix's rows.
    box : mapping of str to (lower, upper)
        Every parameter's range, in its unit.
    rtol, max_boxes
        As for :func:`entry_range`.

    Returns
    -------
    list of (label, row, col, Expression, EntryRange)
        Row by row, matrix by matrix.
    """
    return [(label, i, j, expr, entry_range(expr, {k: box[k] for k in expr.names}, rtol=rtol, max_boxes=max_boxes))
            for label, table in tables for i, row in enumerate(table) for j, expr in enumerate(row)]
