"""Property-based tests (hypothesis, the fixed `ci` profile of conftest.py) of the mathematics."""

import numpy as np
import scipy.linalg
from conftest import random_model
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import scara_robust as sr
from scara_robust.lyapunov.theorem1 import positive_part, rank2_positive_part
from scara_robust.robustness.polytope import box_vertices

seeds = st.integers(min_value=0, max_value=10_000)
rhos = st.floats(min_value=0.05, max_value=20.0)
etas = st.floats(min_value=1.0, max_value=100.0)
finite = st.floats(min_value=-100.0, max_value=100.0, allow_nan=False)


def _model(seed, n_elements=4):
    model = random_model(seed, n_elements=n_elements)
    try:
        sr.design(model, 1.0, 1.0)
    except ValueError:  # not stabilizable or ill-conditioned: not a sample of this property
        assume(False)
    return model


@given(seeds, rhos, etas)
def test_riccati_and_lyapunov_residuals(seed, rho, eta):
    model = _model(seed)
    d = sr.design(model, rho, eta)
    cert = sr.certify(model, d)
    assert d.care_residual < 1e-9
    assert cert.lyapunov_residual < 1e-8 and cert.riccati_mismatch < 1e-7
    assert np.linalg.eigvalsh(d.P)[0] > 0
    assert d.hurwitz  # η >= 1 with the stabilizing P (Lyapunov argument of the design)


@given(arrays(float, (5, 5), elements=finite))
def test_positive_part_dominates(M):
    S = M + M.T
    plus = positive_part(S)
    tol = 1e-9 * max(1.0, np.abs(S).max())
    assert np.linalg.eigvalsh(plus)[0] >= -tol
    assert np.linalg.eigvalsh(plus - S)[0] >= -tol
    assert np.allclose(plus, plus.T)


@given(arrays(float, 6, elements=finite), arrays(float, 6, elements=finite))
def test_rank2_positive_part_closed_form(u, v):
    S = np.outer(u, v) + np.outer(v, u)
    assert np.allclose(rank2_positive_part(u, v), positive_part(S), atol=1e-9 * max(1.0, np.abs(S).max()))


@given(seeds, rhos, etas, st.data())
def test_z_bounds_every_vertex(seed, rho, eta, data):
    model = _model(seed, n_elements=5)
    d = sr.design(model, rho, eta)
    cert = sr.certify(model, d)
    H = box_vertices(model)
    v = data.draw(st.integers(min_value=0, max_value=len(H) - 1))
    A_h, B_h = model.matrices_at(H[v])
    A_v = A_h - B_h @ d.K
    gap = cert.Z - (d.P @ A_v + A_v.T @ d.P)
    assert np.linalg.eigvalsh(gap)[0] >= -1e-8 * max(1.0, np.abs(cert.Z).max())


@given(seeds, st.integers(min_value=0, max_value=2**32 - 1))
@settings(max_examples=15)
def test_certified_models_have_decreasing_v(seed, switch_seed):
    rng = np.random.default_rng(seed)
    n = 4
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, 2))
    elements = tuple(sr.UncertainElement("A", int(i), int(j), 0.0, 0.2) for i, j in rng.integers(0, n, size=(3, 2)))
    try:
        model = sr.UncertainLTVModel(A, B, elements)
        d = sr.design(model, 2.0, 2.0)
    except ValueError:
        assume(False)
    cert = sr.certify(model, d)
    assume(cert.certified)
    # a random admissible h(t): piecewise constant, each piece anywhere in the box
    switch = np.random.default_rng(switch_seed)
    x = switch.normal(size=n)
    V = [x @ d.P @ x]
    for _ in range(60):
        h = switch.uniform(model.lower_bounds(), model.upper_bounds())
        A_h, B_h = model.matrices_at(h)
        x = scipy.linalg.expm((A_h - B_h @ d.K) * 0.02) @ x
        V.append(x @ d.P @ x)
    V = np.array(V)
    assert np.all(np.diff(V) <= 1e-12 * V[0])


@given(st.floats(min_value=0.0, max_value=2 * np.pi), st.floats(min_value=0.0, max_value=1.0))
def test_derived_bounds_contain_the_jacobians(t, fraction):
    model = sr.derived_model()
    params = sr.ScaraParams()
    lo, hi = 0.0, 0.6 * params.m2
    m_p = lo + fraction * (hi - lo)
    r, rd, _ = sr.paper_reference().sample([t])
    a_star, g_bar = sr.error_dynamics_jacobians(params, r[0], rd[0], m_p)
    A_hi, B_hi = model.matrices_at(model.upper_bounds())
    tol = 1e-6
    assert np.all(a_star >= model.A[4:, 2:] - tol) and np.all(a_star <= A_hi[4:, 2:] + tol)
    assert np.all(g_bar >= model.B[4:] - tol) and np.all(g_bar <= B_hi[4:] + tol)


@given(seeds, st.lists(rhos, min_size=1, max_size=3), st.lists(etas, min_size=1, max_size=3))
@settings(max_examples=15)
def test_structured_surface_matches_reference(seed, rho_list, eta_list):
    model = _model(seed)
    fast = sr.design_surface(model, rho_list, eta_list)
    slow = sr.design_surface(model, rho_list, eta_list, formulation="reference")
    assert np.allclose(fast.max_eig, slow.max_eig, rtol=1e-9, atol=1e-9 * np.abs(slow.max_eig).max())
    assert np.array_equal(fast.hurwitz, slow.hurwitz)


@given(st.floats(min_value=-0.3, max_value=0.3), st.floats(min_value=-0.3, max_value=0.3))
@settings(max_examples=4)
def test_fast_and_reference_simulations_agree(e1, e2):
    scenario = sr.Scenario("random", (e1, e2), (0.0, 0.0))
    fast = sr.run_scenario("pid", scenario, t_final=1.0, method="lsoda")
    ref = sr.run_scenario("pid", scenario, t_final=1.0, method="interconnect")
    assert fast.t.shape == ref.t.shape
    assert np.abs(fast.e - ref.e).max() <= 1e-5


def test_hypothesis_profile_is_fixed():
    assert settings().derandomize and settings().deadline is None and settings().max_examples == 25
