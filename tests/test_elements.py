"""`elements='A'|'B'`: the elements left out stay at their lower bounds, in every function that takes it.

Checked on models whose lower bounds are far from 0, where holding an element at 0 instead
of its lower bound changes the answer by orders of magnitude.
"""

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.lyapunov.theorem1 import theorem1_z

#: A 3-state plant, one input, ΔA(3, 3) ∈ [-0.5, 0.5] and ΔB(3, 1) ∈ [0.8, 1.0] (0-based rows/cols).
A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -2.0, -1.5]])
B = np.array([[0.0], [0.0], [1.0]])
MODEL = sr.UncertainLTVModel(
    A, B, (sr.UncertainElement("A", 2, 2, -0.5, 0.5), sr.UncertainElement("B", 2, 0, 0.8, 1.0)), name="lower-bounds"
)
DESIGN = sr.design(MODEL, 1.0, 2.0)


def literal_closed_loops(elements):
    """Frozen closed loops, varying only `elements`, the others held at their lower bounds, by hand."""
    a_values = [-0.5, 0.5] if elements in ("all", "A") else [-0.5]
    b_values = [0.8, 1.0] if elements in ("all", "B") else [0.8]
    loops = []
    for da in a_values:
        for db in b_values:
            A_v, B_v = A.copy(), B.copy()
            A_v[2, 2] += da
            B_v[2, 0] += db
            loops.append(A_v - B_v @ DESIGN.K)
    return np.array(loops)


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_subset_folds_left_out_lower_bounds_into_the_nominal(elements):
    sub = MODEL.subset(elements)
    expected_A, expected_B = A.copy(), B.copy()
    if elements == "B":
        expected_A[2, 2] += -0.5
    if elements == "A":
        expected_B[2, 0] += 0.8
    assert np.array_equal(sub.A, expected_A) and np.array_equal(sub.B, expected_B)
    assert all(el.matrix == elements for el in sub.elements) or elements == "all"


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_vertex_certificate_matches_the_literal_vertices(elements):
    cert = sr.vertex_certificate(MODEL, DESIGN, elements)
    literal = sr.polytope_certificate(literal_closed_loops(elements), DESIGN.P)
    assert cert.max_eig == pytest.approx(literal.max_eig, rel=1e-12)
    assert cert.max_real_pole == pytest.approx(literal.max_real_pole, rel=1e-12)


def test_holding_delta_b_at_zero_would_change_the_answer():
    # The fault this file guards against: ΔB at 0 instead of 0.8 is a different plant.
    held_at_zero = A - B @ DESIGN.K
    at_lower = literal_closed_loops("A")[0]
    assert not np.allclose(held_at_zero, at_lower)


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_theorem1_bounds_the_literal_vertices(elements):
    # Z ⪰ PĀ_v + Ā_vᵀP at every vertex of the varying elements (Theorem 1's construction).
    cert = sr.certify(MODEL, DESIGN, elements)
    P = cert.P
    for A_v in literal_closed_loops(elements):
        gap = np.linalg.eigvalsh(cert.Z - (P @ A_v + A_v.T @ P))[0]
        assert gap >= -1e-9 * np.abs(cert.Z).max()


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_theorem1_on_the_subset_equals_a_model_built_by_hand(elements):
    sub = MODEL.subset(elements)
    by_hand = sr.UncertainLTVModel(sub.A, sub.B, sub.elements)
    # the same design (K, P, Q) certified against the hand-built model
    ours = sr.certify(MODEL, DESIGN, elements)
    Z_hand = theorem1_z(ours.P, by_hand.A - by_hand.B @ DESIGN.K, by_hand.perturbation_matrices(DESIGN.K),
                           by_hand.lower_bounds(), by_hand.upper_bounds())[0]
    assert np.allclose(ours.Z, Z_hand, rtol=1e-12, atol=1e-12 * np.abs(Z_hand).max())


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_surface_uses_the_same_lower_bounds(elements):
    rhos, etas = np.array([0.5, 1.0, 2.0]), np.array([1.0, 2.0, 5.0])
    structured = sr.design_surface(MODEL, rhos, etas, elements)
    reference = sr.design_surface(MODEL, rhos, etas, elements, formulation="reference")
    assert np.allclose(structured.max_eig, reference.max_eig, rtol=1e-9)
    i, k = 1, 1
    assert reference.max_eig[i, k] == pytest.approx(sr.certify(MODEL, sr.design(MODEL, 1.0, 2.0), elements).max_eig)
