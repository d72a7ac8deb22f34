"""The README's numbers are what the commands print: each is read from the README and compared with a fresh run.

Exact computations (Theorem 1, the vertex test, the frozen bisection) are compared to the
digits the README prints; optimizer outputs to the tolerance the README states for them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.simulation.controllers import PID_LMI_FILE

README = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")


def _row(label: str) -> list[str]:
    """The cells of the README table row that starts with `label`."""
    line = next(line for line in README.splitlines() if line.startswith(f"| {label}"))
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
def test_margin_table_of_the_readme(label, method, column, bounds):
    printed = _row(label)[column]
    model = sr.paper_model() if bounds == "paper" else sr.derived_model()
    design = sr.design(model, 3, 90)
    # the frozen bound is bisected from the best certified θ, as `margin` does (its lower bound)
    lower = 0.0 if method != "frozen" else sr.robustness_margin(model, design, "vertex").theta
    theta = sr.robustness_margin(model, design, method, lower=lower).theta
    assert round(theta, _digits(printed)) == pytest.approx(_number(printed), abs=1e-12), printed


@pytest.mark.parametrize(("column", "bounds"), [(2, "paper"), (3, "derived")], ids=["paper", "derived"])
def test_centre_scaled_margins_of_the_readme(column, bounds):
    vertex, frozen = (float(v) for v in _row("about the centre")[column].split(" / "))
    model = sr.paper_model() if bounds == "paper" else sr.derived_model()
    design = sr.design(model, 3, 90)
    assert round(sr.robustness_margin(model, design, "vertex", anchor="center").theta, 4) == vertex
    assert round(sr.robustness_margin(model, design, "frozen", anchor="center").theta, 4) == frozen


@pytest.mark.lmi
def test_synthesis_numbers_of_the_readme(tmp_path, capsys):
    """``synthesize`` prints the README's γ to the 5 % the README states, and the shipped ‖K‖ to its digits."""
    stated = re.search(r"a worst-case L2 gain γ ≤ (\d\.\d+) rad/\(N·m\)", README)
    tolerance = re.search(r"whose γ is within (\d+) % of (\d\.\d+)", README)
    norm = re.search(r"the `l2` gain is certified with ‖K‖₂ = (\d+\.\d)", README)
    assert stated and tolerance and norm and tolerance.group(2) == stated.group(1)
    out = tmp_path / "k.json"
    assert main(["synthesize", "--output", str(out)]) == 0
    capsys.readouterr()
    fresh = json.loads(out.read_text())
    assert fresh["status"] == "certified"
    assert fresh["gamma"] == pytest.approx(float(stated.group(1)), rel=int(tolerance.group(1)) / 100)
    shipped = sr.load_design(Path(sr.__file__).parent / PID_LMI_FILE)
    assert round(shipped.info["gain_norm"], 1) == float(norm.group(1))
    assert round(shipped.info["gamma"], 5) == float(stated.group(1))


@pytest.mark.lmi
def test_lmi_physical_decay_of_the_readme():
    printed = _row("lmi-physical")[2]
    alpha = float(re.search(r"α ≥ (\d\.\d+) 1/s", printed).group(1))
    plant = sr.scara_uncertain_plant(bounds="paper")  # the robot's samples make the physical rows
    table = sr.certificate_table(plant, sr.design(plant, 3, 90), methods=["lmi-physical"])
    row = table.set_index("method").loc["lmi-physical"]
    assert row["certified"] and round(row["decay_rate [1/s]"], 3) == alpha
