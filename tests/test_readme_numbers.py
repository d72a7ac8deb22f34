"""The documentation's numbers are what the commands print: each is read from its page and compared with a fresh run.

Exact computations (Theorem 1, the vertex test, the frozen bisection) are compared to the
digits the page prints; optimizer outputs to the tolerance the page states for them.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import scara_robust as sr
from scara_robust.simulation.controllers import PID_LMI_FILE

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: The guide pages that print these numbers.
ROBUST, VARIATION, SYNTHESIS, GETTING_STARTED = (
    (DOCS / page).read_text(encoding="utf-8")
    for page in ("guide/robust.md", "guide/variation.md", "guide/synthesis.md", "getting-started.md")
)


def _row(label: str, page: str) -> list[str]:
    """The cells of the table row of `page` that starts with `label`."""
    line = next(line for line in page.splitlines() if line.startswith(f"| {label}"))
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def _number(text: str) -> float:
    return float(re.search(r"[-+]?\d+\.\d+(?:e[-+]?\d+)?", text.replace("−", "-")).group())


def _digits(text: str) -> int:
    return len(re.search(r"\d+\.(\d+)", text).group(1))


@pytest.mark.parametrize(
    ("label", "method", "column", "bounds"),
    [
        ("theorem1 (exact)", "theorem1", 2, "paper"),
        ("theorem1 (exact)", "theorem1", 3, "derived"),
        ("vertex: the design's P", "vertex", 2, "paper"),
        ("vertex: the design's P", "vertex", 3, "derived"),
        ("frozen: a frozen vertex unstable", "frozen", 2, "paper"),
        ("frozen: a frozen vertex unstable", "frozen", 3, "derived"),
    ],
    ids=["theorem1-paper", "theorem1-derived", "vertex-paper", "vertex-derived", "frozen-paper", "frozen-derived"],
)
def test_margin_table_of_the_guide(label, method, column, bounds):
    printed = _row(label, VARIATION)[column]
    model = sr.paper_model() if bounds == "paper" else sr.derived_model()
    design = sr.design(model, 3, 90)
    # the frozen bound is bisected from the best certified θ, as `margin` does (its lower bound)
    lower = 0.0 if method != "frozen" else sr.robustness_margin(model, design, "vertex").theta
    theta = sr.robustness_margin(model, design, method, lower=lower).theta
    assert round(theta, _digits(printed)) == pytest.approx(_number(printed), abs=1e-12), printed


@pytest.mark.parametrize(("column", "bounds"), [(2, "paper"), (3, "derived")], ids=["paper", "derived"])
def test_centre_scaled_margins_of_the_guide(column, bounds):
    vertex, frozen = (float(v) for v in _row("about the centre", VARIATION)[column].split(" / "))
    model = sr.paper_model() if bounds == "paper" else sr.derived_model()
    design = sr.design(model, 3, 90)
    assert round(sr.robustness_margin(model, design, "vertex", anchor="center").theta, 4) == vertex
    assert round(sr.robustness_margin(model, design, "frozen", anchor="center").theta, 4) == frozen


def test_synthesis_numbers_of_the_guide():
    """The guide's γ and ‖K‖ are the shipped gain's, and its tolerance is the one a fresh synthesis is held to.

    `tests/test_synthesis.py` runs a fresh synthesis and holds its γ at most GAMMA_RTOL above the
    shipped one (the page's `synthesize` command runs in `tests/test_readme.py`).
    """
    from test_synthesis import GAMMA_RTOL

    stated = re.search(r"a worst-case L2 gain γ ≤ (\d\.\d+) rad/\(N·m\)", SYNTHESIS)
    tolerance = re.search(r"whose γ is at most (\d+) % above (\d\.\d+)", SYNTHESIS)
    norm = re.search(r"the `l2` gain is certified with ‖K‖₂ = (\d+\.\d)", SYNTHESIS)
    assert stated and tolerance and norm and tolerance.group(2) == stated.group(1)
    assert int(tolerance.group(1)) / 100 == GAMMA_RTOL
    shipped = sr.load_design(Path(sr.__file__).parent / PID_LMI_FILE)
    assert round(shipped.info["gain_norm"], 1) == float(norm.group(1))
    assert round(shipped.info["gamma"], 5) == float(stated.group(1))


@pytest.mark.lmi
def test_lmi_physical_decay_of_the_guide():
    printed = _row("lmi-physical", ROBUST)[2]
    alpha = float(re.search(r"α ≥ (\d\.\d+) 1/s", printed).group(1))
    plant = sr.scara_uncertain_plant(bounds="paper")  # the robot's samples make the physical rows
    table = sr.certificate_table(plant, sr.design(plant, 3, 90), methods=["lmi-physical"])
    row = table.set_index("method").loc["lmi-physical"]
    assert row["certified"] and round(row["decay_rate [1/s]"], 3) == alpha


def test_first_design_numbers_of_getting_started():
    """The first design's Theorem 1 values, to the digits the getting-started page prints."""
    a_only = re.search(r"max λ\(Z\) = −(\d\.\d+) over the ΔA elements", GETTING_STARTED)
    all_ten = re.search(r"\+(\d+\.\d) over all ten", GETTING_STARTED)
    assert a_only and all_ten
    plant = sr.scara_uncertain_plant(bounds="paper")
    design = sr.design(plant, 3, 90)
    assert round(sr.certify(plant, design, elements="A").max_eig, 3) == -float(a_only.group(1))
    assert round(sr.certify(plant, design).max_eig, 1) == float(all_ten.group(1))
    error = re.search(r"max \|e\| = (\d\.\d+) rad after the 6-s transient", GETTING_STARTED)
    run = sr.run_scenario("pid", "large")
    assert error and run.status == "tracking" and round(run.metrics().max_abs_error, 4) == float(error.group(1))
