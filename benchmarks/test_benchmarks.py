"""Timing with pytest-benchmark; ``make bench`` enables it, ``make test`` runs each once."""

import numpy as np
import pytest

import scara_robust as sr


@pytest.fixture(scope="module")
def model():
    return sr.paper_model()


@pytest.mark.parametrize("method", ["structured", "reference"], ids=["structured", "reference"])
def test_surface_20x20(benchmark, model, method):
    rhos, etas = np.linspace(0.1, 10, 20), np.linspace(1, 200, 20)
    surface = benchmark(sr.design_surface, model, rhos, etas, "all", method=method)
    assert surface.max_eig.shape == (20, 20)


def test_surface_200x200_structured(benchmark, model):
    rhos, etas = np.linspace(0.1, 10, 200), np.linspace(1, 200, 200)
    surface = benchmark(sr.design_surface, model, rhos, etas)
    assert surface.max_eig.shape == (200, 200)


@pytest.mark.parametrize("method", ["fast", "interconnect"], ids=["fast", "interconnect"])
def test_simulation_pid_8s(benchmark, method):
    res = benchmark(sr.run_scenario, "pid", "large", t_final=8.0, method=method)
    assert res.success
