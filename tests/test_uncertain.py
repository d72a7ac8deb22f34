import numpy as np
import pytest

import scara_robust as sr
from scara_robust.model.scara import pid_state_matrices
from scara_robust.paper import PAPER_TABLE1, PAPER_TABLE2


def test_paper_model_is_the_published_data(paper):
    assert paper.A[4, 3:].tolist() == [-0.30, -0.28, -0.42]
    assert paper.A[5, 3:].tolist() == [-2.56, -4.26, -2.49]
    assert paper.B[4:].tolist() == [[-2.18, 1.74], [1.74, -8.98]]
    assert np.array_equal(paper.A[:4, 2:], np.eye(4))
    assert np.all(paper.lower_bounds() == 0)
    assert paper.bounds_table("A", (4, 3)).loc["h_u"].tolist() == PAPER_TABLE1.ravel().tolist()
    assert list(paper.bounds_table("B", (4, 0)).columns) == ["[0, 0]", "[0, 1]", "[1, 0]", "[1, 1]"]
    assert paper.bounds_table("B", (4, 0)).loc["h_u"].tolist() == PAPER_TABLE2.ravel().tolist()


@pytest.fixture(scope="module")
def derived():
    return sr.derived_model()


def test_derived_model_finds_the_ten_elements(derived):
    labels = [el.label for el in derived.elements]
    assert labels == [
        "ΔA[4, 3]",
        "ΔA[4, 4]",
        "ΔA[4, 5]",
        "ΔA[5, 3]",
        "ΔA[5, 4]",
        "ΔA[5, 5]",
        "ΔB[4, 0]",
        "ΔB[4, 1]",
        "ΔB[5, 0]",
        "ΔB[5, 1]",
    ]
    assert np.all(derived.A[4:, 2] == 0)  # ∂f/∂e1 = 0: no dependence on q1


@pytest.mark.parametrize("seed", range(5), ids=[f"seed{s}" for s in range(5)])
def test_derived_bounds_contain_jacobians(derived, seed):
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, 50)
    mp = rng.uniform(0, 0.6 * 3.45)
    ref = sr.paper_reference()
    a_star, g_bar = sr.error_dynamics_jacobians(sr.ScaraParams(), ref.position(t), ref.velocity(t), mp)
    A, B = pid_state_matrices(a_star, g_bar)
    lo_A, hi_A = derived.A.copy(), derived.A.copy()
    lo_B, hi_B = derived.B.copy(), derived.B.copy()
    for el in derived.elements:
        (hi_A if el.matrix == "A" else hi_B)[el.row, el.col] += el.upper
        (lo_A if el.matrix == "A" else lo_B)[el.row, el.col] += el.lower
    tol = 2e-3 * np.abs(derived.A).max()  # the grid of 721 times x 21 masses is finite
    assert np.all(A >= lo_A - tol) and np.all(A <= hi_A + tol)
    assert np.all(B >= lo_B - tol) and np.all(B <= hi_B + tol)


def test_generic_model_and_perturbation_matrices():
    el = [sr.UncertainElement("A", 0, 1, -1.0, 1.0), sr.UncertainElement("B", 1, 0, 0.0, 2.0)]
    model = sr.UncertainLTVModel(np.zeros((3, 3)), np.ones((3, 2)), el)
    K = np.arange(6.0).reshape(2, 3)
    E = model.perturbation_matrices(K)
    assert E.shape == (2, 3, 3)
    assert E[0, 0, 1] == 1 and E[0].sum() == 1
    assert np.array_equal(E[1, 1], -K[0]) and np.abs(E[1]).sum() == np.abs(K[0]).sum()
    A, B = model.matrices_at([0.5, 1.5])
    assert A[0, 1] == 0.5 and B[1, 0] == 2.5
    assert model.subset("B").n_elements == 1


@pytest.mark.parametrize(
    "build, exc, match",
    [
        (lambda: sr.UncertainElement("A", 0, 0, 1.0, 0.0), ValueError, "`lower` must be <= `upper`"),
        (lambda: sr.UncertainElement("C", 0, 0, 0.0, 1.0), ValueError, "`matrix` must be one of"),
        (lambda: sr.UncertainElement("A", -1, 0, 0.0, 1.0), ValueError, "`row` must be an integer >= 0"),
        (lambda: sr.UncertainElement("A", 0, 0, float("nan"), 1.0), ValueError, "`lower` must be finite"),
        (lambda: sr.UncertainLTVModel(np.zeros((2, 3)), np.zeros((2, 1))), ValueError, "`A` must be square"),
        (lambda: sr.UncertainLTVModel(np.zeros((2, 2)), np.zeros((3, 1))), ValueError, "`B` must have shape"),
        (lambda: sr.UncertainLTVModel([[0, np.inf], [0, 0]], [[0], [1]]), ValueError, "`A` must contain only finite"),
        (
            lambda: sr.UncertainLTVModel(np.zeros((2, 2)), np.ones((2, 1)), [sr.UncertainElement("A", 2, 0, 0, 1)]),
            ValueError,
            "lies outside A",
        ),
        (
            lambda: sr.UncertainLTVModel(np.zeros((2, 2)), np.ones((2, 1)), [sr.UncertainElement("B", 0, 1, 0, 1)]),
            ValueError,
            "lies outside B",
        ),
        (lambda: sr.UncertainLTVModel(np.zeros((2, 2)), np.ones((2, 1)), ["x"]), TypeError, "UncertainElement"),
        (lambda: sr.derived_model(n_masses=0), ValueError, "`n_masses`"),
    ],
    ids=[
        "lower>upper",
        "bad-matrix",
        "neg-row",
        "nan-bound",
        "A-not-square",
        "B-rows",
        "inf-in-A",
        "outside-A",
        "outside-B",
        "not-element",
        "n-masses",
    ],
)
def test_bad_model_input(build, exc, match):
    with pytest.raises(exc, match=match):
        build()
