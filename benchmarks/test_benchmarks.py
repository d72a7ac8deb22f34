"""Timing with pytest-benchmark.

``make bench`` enables timing and writes ``benchmark.json``; ``python benchmarks/report.py
benchmark.json`` turns it into the README's table of ratios. ``make test`` runs each
benchmark once with ``--benchmark-disable`` so none of them can rot. Slow references run
a fixed, small number of rounds (``benchmark.pedantic``).
"""

import numpy as np
import pytest

import scara_robust as sr

GRIDS = {"50x50": 50, "200x200": 200}


@pytest.fixture(scope="module")
def model():
    return sr.paper_model()


@pytest.mark.parametrize("method", ["structured", "reference"], ids=["structured", "reference"])
@pytest.mark.parametrize("grid", list(GRIDS), ids=list(GRIDS))
def test_surface(benchmark, model, grid, method):
    benchmark.group = f"surface {grid}"
    benchmark.extra_info["points"] = GRIDS[grid] ** 2
    n = GRIDS[grid]
    rhos, etas = np.linspace(0.1, 10, n), np.linspace(1, 200, n)
    if method == "reference":
        surface = benchmark.pedantic(
            sr.design_surface, (model, rhos, etas, "all"), {"method": method}, rounds=3 if n <= 50 else 1
        )
    else:
        surface = benchmark(sr.design_surface, model, rhos, etas, "all", method=method)
    assert surface.max_eig.shape == (n, n) and surface.hurwitz.all()


@pytest.mark.parametrize("method", ["lsoda", "interconnect"], ids=["lsoda", "interconnect"])
def test_simulation_pid_20s(benchmark, method):
    benchmark.group = "simulation: PID, large IC, 20 s"
    res = benchmark.pedantic(sr.run_scenario, ("pid", "large"), {"t_final": 20.0, "method": method}, rounds=3)
    assert res.success and res.t[-1] == pytest.approx(20.0)


def test_compare(benchmark):
    benchmark.group = "compare: 3 controllers x 2 scenarios, 20 s"
    table = benchmark.pedantic(sr.compare_controllers, rounds=2)
    assert table["success"].all() and len(table) == 6
