import numpy as np
import pytest
from conftest import random_model

import scara_robust as sr


@pytest.mark.parametrize("elements", ["all", "A", "B"], ids=["all", "A", "B"])
@pytest.mark.parametrize("seed", [0, 1, 2], ids=["m0", "m1", "m2"])
def test_structured_matches_reference(seed, elements):
    model = random_model(seed)
    rhos, etas = [0.3, 1.0, 4.0], [1.0, 7.5, 60.0]
    fast = sr.design_surface(model, rhos, etas, elements)
    slow = sr.design_surface(model, rhos, etas, elements, method="reference")
    assert np.allclose(fast.max_eig, slow.max_eig, rtol=1e-9, atol=1e-9 * np.abs(slow.max_eig).max())
    assert np.array_equal(fast.hurwitz, slow.hurwitz)


def test_paper_surface_structure(paper):
    s = sr.design_surface(paper, np.linspace(0.5, 10, 8), np.linspace(1, 200, 9), "A")
    frame = s.to_frame()
    assert list(frame.columns) == ["rho", "eta", "max_eig_Z", "closed_loop_hurwitz", "certified"]
    assert len(frame) == 72
    assert s.hurwitz.all()
    rho, eta, best = s.best()
    assert best == s.max_eig.min() and (s.max_eig < 0).sum() == s.certified.sum() > 0
    point = sr.certify(paper, sr.design(paper, rho, eta), "A").max_eig
    assert point == pytest.approx(best, rel=1e-9)


def test_surface_plot_marks_point(paper):
    s = sr.design_surface(paper, np.linspace(1, 5, 5), np.linspace(10, 100, 5), "A")
    ax = s.plot(mark=(3, 90))
    assert "ρ" in ax.get_xlabel() and "η" in ax.get_ylabel()
    assert ax.get_legend() is not None
    ax2 = sr.plot_surface_contour(s, mark=(3, 90))
    assert "ρ" in ax2.get_xlabel()
