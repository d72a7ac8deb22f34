"""The decay-optimal common P of certified_decay_rate, against an independent bisection in cvxpy.

The search refines the LMI certificate's P towards the largest α with ``AᵢᵀP + PAᵢ + 2αP ≺ 0``
(the generalized eigenvalue problem, Boyd et al. 1994, §5.1.3). The reference below is written
from that definition alone: cvxpy + Clarabel on the well-conditioned form ``maximize t: tI ⪯ P
⪯ I, AᵢᵀP + PAᵢ + 2αP ⪯ −tI`` at each α of its own bisection, and numpy's exact rate of the P
it finds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.exceptions import ArgumentValueError

pytestmark = pytest.mark.lmi


def _exact_rate(loops, P):
    """min_i −λmax(L⁻¹(AᵢᵀP + PAᵢ)L⁻ᵀ)/2 with P = LLᵀ: the rate V = xᵀPx proves, by numpy alone."""
    Li = np.linalg.inv(np.linalg.cholesky(P))
    return min(-np.linalg.eigvalsh(Li @ (A.T @ P + P @ A) @ Li.T).max() / 2 for A in loops)


def _reference_bracket(loops, steps=30):
    """(a rate numpy verifies for a P Clarabel found, the smallest α where Clarabel found none)."""
    cp = pytest.importorskip("cvxpy")
    n = loops.shape[1]
    eye = np.eye(n)
    low, high, best = 0.0, float(-np.linalg.eigvals(loops).real.max()), 0.0
    for _ in range(steps):
        alpha = 0.5 * (low + high)
        P, t = cp.Variable((n, n), symmetric=True), cp.Variable()
        cons = [P << eye, P >> t * eye]
        for A in loops:
            lhs = A.T @ P + P @ A + 2 * alpha * P
            cons.append(0.5 * (lhs + lhs.T) << -t * eye)
        cp.Problem(cp.Maximize(t), cons).solve(solver="CLARABEL")
        if t.value is not None and t.value > 1e-9:
            rate = _exact_rate(loops, np.array(P.value))
            if rate > alpha:
                best = max(best, rate)
                low = max(alpha, rate)
                continue
        high = alpha
    return best, high


def _loops(seed, n=3, count=4):
    """Stable closed loops near a common one: a shared stable A plus random perturbations."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(n, n))
    base -= (np.linalg.eigvals(base).real.max() + 2.0) * np.eye(n)
    loops = np.array([base + 0.4 * rng.normal(size=(n, n)) for _ in range(count)])
    assert np.linalg.eigvals(loops).real.max() < 0
    return loops


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_decay_optimal_rate_is_the_reference_s_to_the_search_s_tolerance(seed):
    loops = _loops(seed)
    found = sr.certified_decay_rate(loops)
    assert found.certified and found.source == "a common P by LMI"
    # the rate is the exact rate of the P it reports, re-verified here
    assert found.rate == pytest.approx(_exact_rate(loops, found.P), rel=1e-9)
    lower, upper = _reference_bracket(loops)
    # no P proves more than the optimum; the search's bracket is sr.DECAY_RTOL wide around it
    assert found.rate <= upper * (1 + 1e-6)
    assert found.rate >= lower / (1 + sr.DECAY_RTOL) * (1 - 1e-9)
    assert found.rate <= found.lmi_upper and found.lmi_upper <= found.rate * (1 + sr.DECAY_RTOL) * (1 + 1e-12)
    assert found.rate >= found.lmi_certificate


def test_the_search_improves_on_the_lmi_certificate_s_own_p():
    """The LMI's own objective (P's condition number) is not the rate: on these loops it proves less."""
    improved = []
    for seed in range(4):
        found = sr.certified_decay_rate(_loops(seed))
        improved.append(found.rate > found.lmi_certificate * (1 + 1e-3))
        assert found.lmi_solves >= 0 and math.isfinite(found.lmi_upper)
        if improved[-1]:
            assert "decay-optimal search: from the LMI certificate's" in found.message
    assert any(improved)


def test_one_loop_s_optimal_common_p_decays_at_its_slowest_mode():
    A = np.array([[-0.5, 10.0, 0.0], [0.0, -2.0, 5.0], [0.0, 0.0, -3.0]])  # far from normal
    found = sr.certified_decay_rate(A[None])
    assert 0.5 / (1 + sr.DECAY_RTOL) <= found.rate <= 0.5
    assert found.lmi_upper == pytest.approx(0.5, rel=1e-12) or found.lmi_upper < 0.5


def test_without_refinement_the_lmi_certificate_s_p_answers():
    loops = _loops(0)
    plain = sr.certified_decay_rate(loops, rtol=math.inf)
    assert plain.lmi_solves == 0 and math.isnan(plain.lmi_upper)
    assert plain.rate == pytest.approx(plain.lmi_certificate, rel=1e-12)
    assert plain.rate <= sr.certified_decay_rate(loops).rate


@pytest.mark.parametrize("rtol", [0, -1e-2, math.nan, "0.01", True])
def test_a_bad_rtol_is_refused_by_name(rtol):
    with pytest.raises(ArgumentValueError, match="rtol"):
        sr.certified_decay_rate(_loops(0), rtol=rtol)


def test_a_probe_reaches_a_whole_solve_s_verdict_sooner():
    """``stop='probe'`` ends a solve without a P once the dual bound puts t* at or below the bound a
    finished solve reads as no P: the same verdict, in fewer iterations; with a P it is 'verified'."""
    from scara_robust.robustness.lmi import MARGIN_FEASIBILITY_TOL, PROBE_MARGIN, common_p_problem
    from scara_robust.sdp.ipm import solve_ipm

    loops = _loops(1)
    best = sr.certified_decay_rate(loops)
    eye = np.eye(loops.shape[1])
    above = loops + 1.05 * best.lmi_upper * eye  # no common P: above the search's upper end
    scaled = above / np.abs(above).max()
    problem, _, t = common_p_problem(scaled)
    whole = solve_ipm(problem)
    probe = solve_ipm(problem, reject=lambda bound: bound <= PROBE_MARGIN)
    assert whole.status in ("optimal", "optimal_inaccurate") and whole.value(t) <= MARGIN_FEASIBILITY_TOL
    assert probe.status == "rejected" and probe.y is None and probe.iterations < whole.iterations
    assert not sr.lmi_certificate(above, stop="probe").certified
    below = loops + 0.9 * best.rate * eye
    for stop in ("probe", "verified"):
        found = sr.lmi_certificate(below, stop=stop)
        assert found.certified and sr.decay_rate(below, found.P) > 0


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_without_the_certificate_the_search_closes_its_bracket_or_answers_as_with_it(seed, monkeypatch):
    """``certificate=False`` (compare on an arm): the certificate is solved only where the search needs
    a lower end; where it is not, the rate is the exact rate of its P, within DECAY_RTOL of the upper
    end and of the rate found with the certificate; where it is, the answer is the same one."""
    from scara_robust.robustness import decay

    loops = _loops(seed)
    with_it = sr.certified_decay_rate(loops)
    solved = []
    real = decay.lmi_certificate
    monkeypatch.setattr(decay, "lmi_certificate", lambda *a, **k: solved.append(1) or real(*a, **k))
    without = sr.certified_decay_rate(loops, certificate=False)
    assert without.certified and without.rate == pytest.approx(_exact_rate(loops, without.P), rel=1e-9)
    if solved:  # the search needed the certificate: the same search, the same answer
        assert without.rate == with_it.rate and without.lmi_upper == with_it.lmi_upper
    else:
        assert math.isnan(without.lmi_certificate) and without.lmi_solves == 1
        assert without.lmi_upper - without.rate <= sr.DECAY_RTOL * without.rate * (1 + 1e-12)
        assert with_it.rate / (1 + sr.DECAY_RTOL) <= without.rate <= with_it.lmi_upper * (1 + 1e-12)


def test_a_design_s_p_within_the_tolerance_of_the_eigenvalue_bound_needs_no_lmi(monkeypatch):
    from scara_robust.robustness import decay

    A = np.array([[-0.5, 10.0, 0.0], [0.0, -2.0, 5.0], [0.0, 0.0, -3.0]])
    best = sr.certified_decay_rate(A[None])  # within DECAY_RTOL of the slowest mode, 0.5 1/s
    monkeypatch.setattr(decay, "lmi_search", None)  # neither a certificate nor a probe is solved
    monkeypatch.setattr(decay, "lmi_certificate", None)
    own = sr.certified_decay_rate(A[None], best.P, certificate=False)
    assert own.source == "the design's P" and own.rate == best.rate and own.lmi_solves == 0
    assert own.lmi_status.startswith("not needed") and own.lmi_upper == pytest.approx(0.5, rel=1e-12)


@pytest.mark.parametrize("value", [0, 1, "no", None])
def test_a_bad_certificate_flag_is_refused_by_name(value):
    with pytest.raises(ArgumentValueError, match="certificate"):
        sr.certified_decay_rate(_loops(0), certificate=value)
