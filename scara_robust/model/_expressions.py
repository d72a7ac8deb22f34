"""Arithmetic in named parameters, parsed by whitelist: the matrix entries of a plant file.

A plant file writes an entry as ``"-b/J"`` or ``"kt/J"``. :func:`parse_expression` reads
such a string with Python's own parser (:mod:`ast`, ``mode='eval'``) and accepts only

* numbers (``2``, ``1e-4``), the constants ``pi`` and ``e``, and parameter names;
* ``+``, ``−`` (binary and unary), ``*``, ``/`` and ``**`` with a number as the exponent;
* calls of :data:`FUNCTIONS` (``sqrt``, ``exp``, ``log``, ``sin``, ``cos``, ``tanh``, ``abs``)
  with one positional argument.

Anything else — an attribute, a subscript, a call of any other name (``__import__``),
a comparison, a string, a lambda — is refused with a one-line error naming the construct.
Nothing is executed: the tree is evaluated by this module's own walker, on floats (so
``9**9**9`` overflows instead of computing a huge integer).

An :class:`Expression` evaluates on numpy arrays of parameter values (vectorized over a
grid) and on intervals (:meth:`Expression.interval`): natural interval arithmetic, so
the interval it returns **contains** every value the entry takes over the box (it may be
wider when a parameter appears more than once, e.g. ``J/(J + 1)``).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..exceptions import ArgumentValueError

__all__ = ["Expression", "parse_expression", "FUNCTIONS", "CONSTANTS", "MAX_EXPRESSION_LENGTH"]

Array = NDArray[np.float64]
Interval = tuple[float, float]

#: Functions a plant file may call: name -> numpy function.
FUNCTIONS: dict[str, Callable[[Array], Array]] = {
    "sqrt": np.sqrt, "exp": np.exp, "log": np.log, "sin": np.sin, "cos": np.cos, "tanh": np.tanh, "abs": np.abs,
}
#: Named constants a plant file may use.
CONSTANTS: dict[str, float] = {"pi": math.pi, "e": math.e}
#: Longest expression accepted, characters (deeper trees than any plant needs are refused).
MAX_EXPRESSION_LENGTH = 500

_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}


def _refuse(name: str, text: str, what: str) -> ArgumentValueError:
    return ArgumentValueError(
        name, f"= {text!r}: {what}; an entry may hold numbers, parameter names, + - * / **, and "
              f"calls of {', '.join(FUNCTIONS)}"
    )


def _check(node: ast.AST, name: str, text: str, parameters: frozenset[str]) -> None:
    """Refuse every node outside the whitelist (walked before anything is evaluated)."""
    if isinstance(node, ast.Expression):
        _check(node.body, name, text, parameters)
    elif isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise _refuse(name, text, f"the constant {node.value!r} is not a number")
    elif isinstance(node, ast.Name):
        if node.id not in parameters and node.id not in CONSTANTS:
            known = ", ".join(sorted(parameters)) or "none"
            raise ArgumentValueError(name, f"= {text!r} names `{node.id}`, which is not a parameter (parameters: "
                                           f"{known}; constants: {', '.join(CONSTANTS)})")
    elif isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, (ast.UAdd, ast.USub)):
            raise _refuse(name, text, f"the operator {type(node.op).__name__} is not allowed")
        _check(node.operand, name, text, parameters)
    elif isinstance(node, ast.BinOp):
        if type(node.op) not in _BINARY:
            raise _refuse(name, text, f"the operator {type(node.op).__name__} is not allowed")
        _check(node.left, name, text, parameters)
        _check(node.right, name, text, parameters)
        if isinstance(node.op, ast.Pow) and _names(node.right):
            raise _refuse(name, text, "an exponent must be a number, not depend on a parameter")
    elif isinstance(node, ast.Call):
        func = node.func.id if isinstance(node.func, ast.Name) else None
        if func not in FUNCTIONS:
            called = func if func is not None else ast.unparse(node.func)
            raise _refuse(name, text, f"calls `{called}`, which is not an allowed function")
        if node.keywords or len(node.args) != 1 or isinstance(node.args[0], ast.Starred):
            raise _refuse(name, text, f"`{func}` takes one positional argument")
        _check(node.args[0], name, text, parameters)
    else:
        raise _refuse(name, text, f"{type(node).__name__} is not allowed")


def _names(node: ast.AST) -> frozenset[str]:
    """The parameter names `node` uses (not the constants, not the functions it calls)."""
    called = {id(n.func) for n in ast.walk(node) if isinstance(n, ast.Call)}
    return frozenset(n.id for n in ast.walk(node)
                     if isinstance(n, ast.Name) and n.id not in CONSTANTS and id(n) not in called)


def evaluate_tree(node: ast.AST, values: Mapping[str, Array]) -> Array:
    """The value of a checked syntax tree at parameter values (arrays broadcast), by the whitelist's own walker."""
    if isinstance(node, ast.Expression):
        return evaluate_tree(node.body, values)
    if isinstance(node, ast.Constant):
        return np.asarray(float(node.value))  # type: ignore[arg-type]  # a number: checked when parsed
    if isinstance(node, ast.Name):
        return np.asarray(values[node.id], dtype=float) if node.id in values else np.asarray(CONSTANTS[node.id])
    if isinstance(node, ast.UnaryOp):
        operand = evaluate_tree(node.operand, values)
        return -operand if isinstance(node.op, ast.USub) else operand
    if isinstance(node, ast.BinOp):
        a, b = evaluate_tree(node.left, values), evaluate_tree(node.right, values)
        op = _BINARY[type(node.op)]
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            return a / b
        return np.power(a, b)
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    return FUNCTIONS[node.func.id](evaluate_tree(node.args[0], values))


def _monotone(f: Callable[[float], float], x: Interval) -> Interval:
    return (f(x[0]), f(x[1]))


def _trig(fn: str, x: Interval) -> Interval:
    f = math.sin if fn == "sin" else math.cos
    lo, hi = min(f(x[0]), f(x[1])), max(f(x[0]), f(x[1]))
    shift = 0.5 * math.pi if fn == "sin" else 0.0  # where the function peaks: shift + 2kπ
    if math.floor((x[1] - shift) / (2 * math.pi)) > math.floor((x[0] - shift) / (2 * math.pi)) or (
            (x[0] - shift) % (2 * math.pi) == 0):
        hi = 1.0
    if math.floor((x[1] - shift - math.pi) / (2 * math.pi)) > math.floor((x[0] - shift - math.pi) / (2 * math.pi)) or (
            (x[0] - shift - math.pi) % (2 * math.pi) == 0):
        lo = -1.0
    return (lo, hi)


def _interval(node: ast.AST, box: Mapping[str, Interval], name: str, text: str) -> Interval:
    if isinstance(node, ast.Expression):
        return _interval(node.body, box, name, text)
    if isinstance(node, ast.Constant):
        value = float(node.value)  # type: ignore[arg-type]  # a number: checked when parsed
        return (value, value)
    if isinstance(node, ast.Name):
        return box[node.id] if node.id in box else (CONSTANTS[node.id], CONSTANTS[node.id])
    if isinstance(node, ast.UnaryOp):
        lo, hi = _interval(node.operand, box, name, text)
        return (-hi, -lo) if isinstance(node.op, ast.USub) else (lo, hi)
    if isinstance(node, ast.BinOp):
        a = _interval(node.left, box, name, text)
        b = _interval(node.right, box, name, text)
        op = _BINARY[type(node.op)]
        if op == "+":
            return (a[0] + b[0], a[1] + b[1])
        if op == "-":
            return (a[0] - b[1], a[1] - b[0])
        if op == "*":
            products = (a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1])
            return (min(products), max(products))
        if op == "/":
            if b[0] <= 0.0 <= b[1]:
                raise ArgumentValueError(
                    name, f"= {text!r} divides by {ast.unparse(node.right)}, whose range [{b[0]:g}, {b[1]:g}] "
                          "holds 0: the plant is undefined (singular) there")
            quotients = (a[0] / b[0], a[0] / b[1], a[1] / b[0], a[1] / b[1])
            return (min(quotients), max(quotients))
        k = b[0]  # the exponent is a number (checked when parsed)
        if float(k).is_integer():
            if k < 0 and a[0] <= 0.0 <= a[1]:
                raise ArgumentValueError(
                    name, f"= {text!r} raises {ast.unparse(node.left)}, whose range [{a[0]:g}, {a[1]:g}] holds 0, "
                          f"to the power {k:g}: the plant is undefined (singular) there")
            ends = (a[0] ** k, a[1] ** k)
            if k % 2 == 0 and a[0] < 0.0 < a[1]:
                return (0.0, max(ends)) if k > 0 else (min(ends), math.inf)
            return (min(ends), max(ends))
        if a[0] < 0.0 or (k < 0 and a[0] <= 0.0):
            raise ArgumentValueError(
                name, f"= {text!r} raises {ast.unparse(node.left)}, whose range [{a[0]:g}, {a[1]:g}] is not "
                      f"positive, to the non-integer power {k:g}")
        ends = (a[0] ** k, a[1] ** k)
        return (min(ends), max(ends))
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    fn = node.func.id
    x = _interval(node.args[0], box, name, text)
    if fn == "sqrt":
        if x[0] < 0.0:
            raise ArgumentValueError(name, f"= {text!r} takes sqrt of a range [{x[0]:g}, {x[1]:g}] below 0")
        return _monotone(math.sqrt, x)
    if fn == "log":
        if x[0] <= 0.0:
            raise ArgumentValueError(name, f"= {text!r} takes log of a range [{x[0]:g}, {x[1]:g}] not above 0")
        return _monotone(math.log, x)
    if fn == "exp":
        return _monotone(math.exp, x)
    if fn == "tanh":
        return _monotone(math.tanh, x)
    if fn == "abs":
        if x[0] <= 0.0 <= x[1]:
            return (0.0, max(-x[0], x[1]))
        return (min(abs(x[0]), abs(x[1])), max(abs(x[0]), abs(x[1])))
    return _trig(fn, x)


@dataclass(frozen=True)
class Expression:
    """A parsed entry: its text, the parameters it uses, and its checked syntax tree.

    Build with :func:`parse_expression`.

    Attributes
    ----------
    text : str
        The entry as written.
    names : frozenset of str
        The parameters it uses.
    """

    text: str
    names: frozenset[str]
    label: str
    _tree: ast.Expression = field(repr=False, compare=False)

    def __call__(self, values: Mapping[str, float | Array]) -> Array:
        """The entry at parameter values (arrays broadcast), as a float array.

        Parameters
        ----------
        values : mapping of str to float or ndarray
            Every name of :attr:`names`, in its unit.

        Returns
        -------
        ndarray
            Broadcast shape of the values used; may hold inf or nan where the entry is
            undefined (the caller checks).
        """
        with np.errstate(all="ignore"):
            try:
                return np.asarray(evaluate_tree(self._tree, {k: np.asarray(v, dtype=float) for k, v in values.items()}),
                                  dtype=float)
            except OverflowError:
                return np.asarray(math.inf)

    def interval(self, box: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        """An interval holding every value of the entry over the parameter box.

        Parameters
        ----------
        box : mapping of str to (lower, upper)
            The range of each name of :attr:`names`, in its unit.

        Returns
        -------
        (lower, upper) : tuple of float

        Raises
        ------
        ArgumentValueError
            Naming the entry, where it is undefined on the box (a division by a range
            holding 0, log or sqrt outside their domain).
        """
        try:
            lo, hi = _interval(self._tree, box, self.label, self.text)
        except (OverflowError, ZeroDivisionError) as err:
            raise ArgumentValueError(self.label, f"= {self.text!r} overflows or divides by 0 on the parameter box") \
                from err
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ArgumentValueError(self.label, f"= {self.text!r} is unbounded on the parameter box")
        return (lo, hi)


def parse_expression(text: object, parameters: frozenset[str] | set[str], name: str = "expression") -> Expression:
    """Parse an entry of a plant file by whitelist; nothing in it is executed.

    Parameters
    ----------
    text : str or float
        The entry (``"-b/J"``, ``"kt/J"``, ``2.5``).
    parameters : set of str
        The parameter names it may use.
    name : str
        The entry's name for errors (``"A[1][1]"``).

    Returns
    -------
    Expression

    Raises
    ------
    ArgumentValueError
        On anything outside the whitelist, an unknown name, a syntax error or a text
        longer than :data:`MAX_EXPRESSION_LENGTH`.

    Examples
    --------
    >>> from scara_robust.model._expressions import parse_expression
    >>> e = parse_expression("-b/J", {"b", "J"})
    >>> float(e({"b": 1e-4, "J": 2e-4})), e.interval({"b": (1e-4, 1e-4), "J": (2e-4, 6e-4)})
    (-0.5, (-0.5, -0.16666666666666669))
    """
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise ArgumentValueError(name, f"must be a number or an expression string, found {type(text).__name__}")
    source = text if isinstance(text, str) else repr(float(text))
    if len(source) > MAX_EXPRESSION_LENGTH:
        raise ArgumentValueError(name, f"is {len(source)} characters long, more than {MAX_EXPRESSION_LENGTH}")
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as err:
        raise ArgumentValueError(name, f"= {source!r} is not an arithmetic expression ({err.msg})") from None
    params = frozenset(parameters)
    _check(tree, name, source, params)
    return Expression(source, _names(tree), name, tree)
