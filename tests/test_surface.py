import numpy as np
import pytest
from conftest import random_model

import scara_robust as sr
from scara_robust.lyapunov.theorem1 import positive_part, rank2_positive_part


@pytest.mark.parametrize("elements", ["all", "A", "B"], ids=["all", "A", "B"])
@pytest.mark.parametrize("seed", [0, 1, 2], ids=["m0", "m1", "m2"])
def test_structured_matches_reference(seed, elements):
    model = random_model(seed)
    rhos, etas = [0.3, 1.0, 4.0], [1.0, 7.5, 60.0]
    fast = sr.design_surface(model, rhos, etas, elements)
    slow = sr.design_surface(model, rhos, etas, elements, formulation="reference")
    assert np.allclose(fast.max_eig, slow.max_eig, rtol=1e-9, atol=1e-9 * np.abs(slow.max_eig).max())
    assert np.array_equal(fast.hurwitz, slow.hurwitz)


def test_paper_surface_structure(paper):
    s = sr.design_surface(paper, np.linspace(0.5, 10, 8), np.linspace(1, 200, 9), "A")
    frame = s.to_pandas()
    assert list(frame.columns) == ["rho", "eta", "max_eig_Z", "closed_loop_hurwitz", "certified"]
    assert len(frame) == 72
    assert s.hurwitz.all()
    rho, eta, best = s.best()
    assert best == s.max_eig.min() and (s.max_eig < 0).sum() == s.certified.sum() > 0
    point = sr.certify(paper, sr.design(paper, rho, eta), "A").max_eig
    assert point == pytest.approx(best, rel=1e-9)


def test_surface_plot_marks_point(paper):
    s = sr.design_surface(paper, np.linspace(1, 5, 5), np.linspace(10, 100, 5), "A")
    ax = sr.plot_surface(s, mark=(3, 90))
    assert "ρ" in ax.get_xlabel() and "η" in ax.get_ylabel()
    assert ax.get_legend() is not None
    ax2 = sr.plot_surface_contour(s, mark=(3, 90))
    assert "ρ" in ax2.get_xlabel()


@pytest.mark.parametrize("seed", range(5), ids=[f"seed{s}" for s in range(5)])
def test_rank2_positive_part_matches_eigendecomposition(seed):
    rng = np.random.default_rng(seed)
    u, v = rng.normal(size=(7, 6)), rng.normal(size=(7, 6))
    v[0] = -2.5 * u[0]  # S = -5 u uᵀ: positive part 0
    v[1] = 0.0
    S = u[:, :, None] * v[:, None, :]
    S = S + np.swapaxes(S, -1, -2)
    closed = rank2_positive_part(u, v)
    literal = positive_part(S)
    assert np.allclose(closed, literal, atol=1e-12 * np.abs(S).max())
    assert np.allclose(closed[:2], 0.0)


def test_perturbation_factors_rebuild_the_matrices(paper, paper_design):
    a, b = paper.perturbation_factors(paper_design.K)
    E = paper.perturbation_matrices(paper_design.K)
    assert np.array_equal(a[:, :, None] * b[:, None, :], E)
    stacked = np.stack([paper_design.K, 2 * paper_design.K])
    _, b2 = paper.perturbation_factors(stacked)
    assert b2.shape == (2, 10, 6) and np.array_equal(b2[0], b)
    with pytest.raises(ValueError, match=r"`K` must have shape \(\.\.\., 2, 6\)"):
        paper.perturbation_factors(np.zeros((6, 2)))


def test_hurwitz_falls_back_to_eigenvalues_when_lyapunov_proof_fails():
    from scara_robust.lyapunov.surface import _hurwitz

    model = random_model(1)
    rhos, etas = np.array([0.5, 2.0]), np.array([1.0, 3.0, 10.0])
    # N0 = +I makes the Lyapunov proof fail on every row, forcing the eigenvalue path.
    n = model.n_states
    N0 = np.repeat(np.eye(n)[None], 2, axis=0)
    N1 = np.zeros_like(N0)
    P = np.array([sr.design(model, r, 1.0).P for r in rhos])
    BK1 = np.array([model.B @ (r * model.B.T @ Pr) for r, Pr in zip(rhos, P)])
    flags = _hurwitz(model.A, etas, N0, N1, P, BK1)
    expected = np.array([[sr.design(model, r, e).hurwitz for e in etas] for r in rhos])
    assert np.array_equal(flags, expected) and flags.all()
