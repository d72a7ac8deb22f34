"""The range of a plant file's entry over the parameter box: exact where proven monotone, else refined.

Independent checks: each range against a dense grid of the box (2001 points per parameter)
and, where there is one, the range in closed form; a proven-monotone range equals the true
one to 1e-9, any other range contains the dense samples and exceeds the true range by at
most the module's stated tolerance. The symbolic derivatives against central differences.
"""

from __future__ import annotations

import math
import zlib
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.exceptions import ArgumentValueError
from scara_robust.model._expressions import parse_expression
from scara_robust.model._ranges import (
    RANGE_HOWS,
    RANGE_MAX_BOXES,
    RANGE_RTOL,
    entry_range,
    partial_derivative,
)

ROOT = Path(__file__).resolve().parents[1]
ARM = ROOT / "examples" / "plant-arm-payload.toml"
MOTOR = ROOT / "examples" / "plant-dc-motor.toml"
#: The arm file's fixed parameters, and its payload's range (kg).
ARM_FIXED = {"J0": 0.05, "ml": 1.0, "lc": 0.25, "L": 0.5, "b": 0.1, "g": 9.81}
PAYLOAD = (0.0, 2.0)
GRID = 2001


def _arm_true(text: str) -> tuple[float, float]:
    """The arm's entries are monotone in m (closed form): the range is that of the two ends."""
    J0, ml, lc, L, b, g = (ARM_FIXED[k] for k in ("J0", "ml", "lc", "L", "b", "g"))
    f = {
        "A10": lambda m: -(ml * lc + m * L) * g / (J0 + ml * lc**2 + m * L**2),
        "A11": lambda m: -b / (J0 + ml * lc**2 + m * L**2),
        "B10": lambda m: 1 / (J0 + ml * lc**2 + m * L**2),
    }[text]
    ends = (f(PAYLOAD[0]), f(PAYLOAD[1]))
    return (min(ends), max(ends))


_SIN_MAX = math.sqrt(8.0) / 3.0 + math.acos(-1.0 / 3.0) / 3.0  # sin(3x) + x at cos(3x) = −1/3
CASES = [
    # (id, text, box, true range or None: the dense grid's)
    ("arm-A10", "-(ml*lc + m*L)*g/(J0 + ml*lc**2 + m*L**2)", {"m": PAYLOAD}, _arm_true("A10")),
    ("arm-A11", "-b/(J0 + ml*lc**2 + m*L**2)", {"m": PAYLOAD}, _arm_true("A11")),
    ("arm-B10", "1/(J0 + ml*lc**2 + m*L**2)", {"m": PAYLOAD}, _arm_true("B10")),
    ("num-and-den", "m/(1 + m)", {"m": (0.0, 3.0)}, (0.0, 0.75)),
    ("product-crossing-0", "a*b", {"a": (-1.0, 2.0), "b": (0.5, 3.0)}, (-3.0, 6.0)),
    ("product-twice", "a*b + a", {"a": (-1.0, 2.0), "b": (-2.0, 1.0)}, (-2.0, 4.0)),  # a(b + 1)
    ("square-over-0", "x**2", {"x": (-1.0, 2.0)}, (0.0, 4.0)),
    ("parabola", "x*(1 - x)", {"x": (0.0, 1.0)}, (0.0, 0.25)),
    ("sine-plus-line", "sin(3*x) + x", {"x": (0.0, 1.0)}, (0.0, _SIN_MAX)),
    ("root", "sqrt(x)*x - x", {"x": (0.0, 4.0)}, (-4.0 / 27.0, 4.0)),
    ("two-in-num-and-den", "(a + b)/(1 + a*b)", {"a": (0.0, 2.0), "b": (0.5, 3.0)}, None),
    ("lever", "m*L/(J + m*L**2)", {"m": (0.0, 2.0), "L": (0.2, 1.0), "J": (0.05, 0.05)}, None),
    ("two-bumps", "x*(1 - x) + y*(1 - y)", {"x": (0.0, 1.0), "y": (-0.5, 1.0)}, (-0.75, 0.5)),
]


def _dense(text: str, box: dict[str, tuple[float, float]]) -> tuple[float, float]:
    names = set(box) | set(ARM_FIXED)
    expr = parse_expression(text, names, "e")
    varying = [k for k in sorted(expr.names) if k in box and box[k][0] < box[k][1]]
    axes = np.meshgrid(*(np.linspace(*box[k], GRID) for k in varying), indexing="ij")
    values = {k: v for k, v in ARM_FIXED.items() if k in expr.names and k not in box}
    values.update({k: a.ravel() for k, a in zip(varying, axes)})
    values.update({k: box[k][0] for k in expr.names if k in box and k not in varying})
    out = expr(values)
    return float(out.min()), float(out.max())


def _full_box(box: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    return {**{k: (v, v) for k, v in ARM_FIXED.items()}, **box}


def _tolerance(lo: float, hi: float) -> float:
    return RANGE_RTOL * max(hi - lo, abs(lo), abs(hi))


def _slack(*values: float) -> float:
    """A few units in the last place: the ends and the samples are rounded evaluations."""
    return 8 * max(np.spacing(abs(v)) for v in values)


@pytest.mark.parametrize(("text", "box", "truth"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_range_against_the_dense_grid_and_the_closed_form(text, box, truth):
    full = _full_box(box)
    expr = parse_expression(text, set(full), "e")
    r = entry_range(expr, {k: full[k] for k in expr.names})
    d_lo, d_hi = _dense(text, box)
    t_lo, t_hi = truth if truth is not None else (d_lo, d_hi)
    assert r.how in RANGE_HOWS and r.lower <= r.upper
    if r.how == "monotone":
        assert r.gap == 0.0
        assert r.lower == pytest.approx(t_lo, rel=1e-9, abs=1e-12)
        assert r.upper == pytest.approx(t_hi, rel=1e-9, abs=1e-12)
    else:
        assert r.how in ("single-use", "refined"), r  # none of these exhausts the budget
    # an enclosure of every sample, never narrower than the true range ...
    assert r.lower <= d_lo + _slack(d_lo) and d_hi - _slack(d_hi) <= r.upper
    assert r.lower <= t_lo + _slack(t_lo) and t_hi - _slack(t_hi) <= r.upper
    # ... and wider by at most the stated tolerance (the dense grid may miss an interior extremum
    # by its spacing squared: compared with the closed form where there is one)
    assert (r.upper - r.lower) - (t_hi - t_lo) <= _tolerance(t_lo, t_hi) + _slack(r.lower, r.upper)
    assert 0.0 <= r.gap <= _tolerance(t_lo, t_hi) + _slack(r.lower, r.upper)


def test_natural_interval_arithmetic_was_wider_on_these_entries():
    """The cases where a parameter occurs twice: interval arithmetic alone overestimates, the range does not."""
    for key in ("arm-A10", "product-twice", "parabola", "two-in-num-and-den"):
        _, text, box, _ = next(c for c in CASES if c[0] == key)
        full = _full_box(box)
        expr = parse_expression(text, set(full), "e")
        sub = {k: full[k] for k in expr.names}
        lo, hi = expr.interval(sub)
        r = entry_range(expr, sub)
        assert hi - lo > 1.3 * (r.upper - r.lower), key


def test_single_occurrence_entries_keep_the_interval_arithmetic_answer():
    """Every parameter once ("-b/J", "kt/J"): natural interval arithmetic was exact, and is kept."""
    motor = sr.load_plant(MOTOR)
    box = motor.box()
    for table in motor.entries:
        for row in table:
            for expr in row:
                sub = {k: box[k] for k in expr.names}
                r = entry_range(expr, sub)
                if any(a < b for a, b in sub.values()):
                    assert (r.lower, r.upper) == expr.interval(sub) and r.how == "monotone"
                else:
                    assert r.how == "constant" and r.lower == r.upper
    ranges = motor.entry_ranges()
    assert set(ranges.how) == {"constant", "monotone"} and (ranges.gap == 0.0).all()


@pytest.mark.parametrize(
    "text",
    ["x*(1 - x)", "(a + b)/(1 + a*b)", "sin(3*x) + x", "a*b + a", "exp(-a*b)*cos(a)", "tanh(a - b)*a",
     "abs(a - 0.3)*b - a*b**2", "log(1 + a)/(1 + a) - sqrt(b)*b", "(a - b)**3 - a*(b - 0.2)**2"],
)
def test_the_range_holds_every_random_sample_of_random_boxes(text):
    """Property: on 25 random boxes the range holds 500 random points and two opposite corners."""
    rng = np.random.default_rng(zlib.crc32(text.encode()))
    expr = parse_expression(text, {"a", "b", "x"}, "e")
    names = sorted(expr.names)
    for _ in range(25):
        ends = np.sort(rng.uniform(0.0, 2.0, size=(len(names), 2)), axis=1)
        box = {k: (float(e[0]), float(e[1])) for k, e in zip(names, ends)}
        r = entry_range(expr, box)
        points = {k: np.concatenate([rng.uniform(*box[k], 500), box[k]]) for k in names}
        values = expr(points)
        assert r.lower - _slack(r.lower) <= values.min() and values.max() <= r.upper + _slack(r.upper), (box, r)
        # within the tolerance, which the refinement measures on its own samples (inside [lower, upper])
        assert r.how != "enclosure" and r.gap <= _tolerance(r.lower, r.upper) + _slack(r.lower, r.upper)


def test_budget_spent_says_enclosure_and_stays_an_enclosure():
    expr = parse_expression("x*(1 - x) + y*(1 - y) + x*y", {"x", "y"}, "e")
    box = {"x": (-1.0, 1.0), "y": (-1.0, 1.0)}
    r = entry_range(expr, box, max_boxes=5)
    assert r.how == "enclosure" and r.gap > _tolerance(r.lower, r.upper) and r.boxes <= 5
    d_lo, d_hi = _dense("x*(1 - x) + y*(1 - y) + x*y", box)
    assert r.lower <= d_lo and d_hi <= r.upper
    full = entry_range(expr, box)
    assert full.how == "refined" and full.boxes <= RANGE_MAX_BOXES
    assert r.lower <= full.lower and full.upper <= r.upper


@pytest.mark.parametrize(
    ("text", "match"),
    [("1/(m - 1)", r"`e` = '1/\(m - 1\)' divides by m - 1"), ("log(m - 1)", "log of a range"),
     ("sqrt(m - 1)*m", "sqrt of a range")],
)
def test_an_entry_undefined_on_the_box_is_named(text, match):
    expr = parse_expression(text, {"m"}, "e")
    with pytest.raises(ArgumentValueError, match=match):
        entry_range(expr, {"m": (0.0, 2.0)})


def test_a_fixed_box_gives_the_constant():
    expr = parse_expression("m/(1 + m)", {"m"}, "e")
    r = entry_range(expr, {"m": (1.0, 1.0)})
    assert (r.lower, r.upper, r.how, r.gap) == (0.5, 0.5, "constant", 0.0) and r.exact


@pytest.mark.parametrize(
    "text",
    ["a*b/(1 + a)", "sqrt(a)*exp(-b)", "log(a + b)*sin(a)", "cos(a*b) - tanh(b)", "abs(a - 3)*b",
     "(a + 1)**-2 + a**0.5", "-(a*b)**3/(b + 2)"],
)
def test_symbolic_derivatives_match_central_differences(text):
    expr = parse_expression(text, {"a", "b"}, "e")
    rng = np.random.default_rng(7)
    a, b = rng.uniform(0.5, 2.5, 50), rng.uniform(0.5, 2.5, 50)
    for name in ("a", "b"):
        d = partial_derivative(expr, name)
        h = 1e-6
        plus = expr({"a": a + h * (name == "a"), "b": b + h * (name == "b")})
        minus = expr({"a": a - h * (name == "a"), "b": b - h * (name == "b")})
        numeric = (plus - minus) / (2 * h)
        values = np.broadcast_to(d({"a": a, "b": b}), a.shape)
        assert np.allclose(values, numeric, rtol=1e-6, atol=1e-7), (name, d.text)


def test_monotone_is_proven_only_where_the_derivative_keeps_its_sign():
    expr = parse_expression("abs(a - 1)*2", {"a"}, "e")
    assert entry_range(expr, {"a": (1.5, 3.0)}).how == "monotone"
    assert entry_range(expr, {"a": (0.0, 3.0)}).how == "single-use"  # |a − 1| turns: not monotone
    expr = parse_expression("a**3 - a", {"a"}, "e")
    assert entry_range(expr, {"a": (1.0, 2.0)}).how == "monotone"
    r = entry_range(expr, {"a": (-2.0, 2.0)})
    assert r.how == "refined" and r.lower == pytest.approx(-6.0) and r.upper == pytest.approx(6.0)


# --- the plant: its hull and its table ------------------------------------------------------


def test_the_arm_hull_has_the_true_width_of_its_gravity_entry():
    arm = sr.load_plant(ARM)
    hull = arm.interval_model()
    (element,) = [e for e in hull.elements if (e.matrix, e.row, e.col) == ("A", 2, 1)]
    assert element.upper - element.lower == pytest.approx(1.78, abs=0.01)  # natural interval arithmetic: 105
    true_lo, true_hi = _arm_true("A10")
    assert hull.A[2, 1] == pytest.approx(true_lo, rel=1e-9)
    assert element.upper - element.lower == pytest.approx(true_hi - true_lo, rel=1e-6)
    # the hull still holds every frozen plant of the fine grid
    s = arm.samples({"m": 401})
    lower, upper = hull.A[2, 1], hull.A[2, 1] + element.upper
    assert lower - _slack(lower) <= s.A[:, 2, 1].min() and s.A[:, 2, 1].max() <= upper + _slack(upper)


def test_entry_ranges_table_of_the_arm():
    arm = sr.load_plant(ARM)
    table = arm.entry_ranges()
    assert list(table.columns) == ["matrix", "row", "col", "text", "lower", "upper", "how", "gap"]
    assert len(table) == 2 * 2 + 2 * 1
    rows = table.set_index(["matrix", "row", "col"])
    assert rows.loc[("A", 1, 1), "how"] == "monotone" and rows.loc[("B", 1, 0), "how"] == "monotone"
    gravity = rows.loc[("A", 1, 0)]
    assert gravity.how == "refined" and gravity.gap <= _tolerance(gravity.lower, gravity.upper)
    assert (gravity.lower, gravity.upper) == pytest.approx(_arm_true("A10"), rel=1e-9)
    for key in (("A", 1, 1), ("B", 1, 0)):
        assert (rows.loc[key, "lower"], rows.loc[key, "upper"]) == pytest.approx(_arm_true(f"{key[0]}{key[1]}{key[2]}"),
                                                                                  rel=1e-12)
    # a scaled box: half the payload range about its nominal 1 kg
    half = arm.entry_ranges(theta=0.5).set_index(["matrix", "row", "col"])
    assert half.loc[("B", 1, 0), "upper"] < rows.loc[("B", 1, 0), "upper"]


def test_entry_ranges_needs_expressions():
    plant = sr.UncertainPlant.from_function(
        [sr.Parameter("m", "kg", (1.0, 2.0))], lambda p: ([[0, 1], [-1 / p["m"], 0]], [[0], [1 / p["m"]]]))
    with pytest.raises(ArgumentValueError, match="not written as expressions"):
        plant.entry_ranges()
