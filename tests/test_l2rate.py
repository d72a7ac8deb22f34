"""The rate-bounded worst-case L2 gain, a method registered in one module, against an independent LMI.

The independent computation below was written apart from the package: the 3×3 Schur form of
the bounded-real lemma, linear in γ (the package solves the 2×2 form in γ² and reports
γ*(1 + L2_INFLATION) with the most interior P), with P(p) = P0 + p·P1 in p's own unit (the
package normalizes p to [0, 1]), and its own numpy check of the 2×2 inequalities.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

import scara_robust as sr

pytestmark = pytest.mark.lmi
cp = pytest.importorskip("cvxpy")  # the independent computation is written in cvxpy


def independent_l2(A, p, Bw, C, rate):
    """min γ s.t. [[AᵢᵀPᵢ + PᵢAᵢ ± νP1, PᵢB_wᵢ, Cᵀ], [B_wᵢᵀPᵢ, −γI, 0], [C, 0, −γI]] ≺ 0, Pᵢ ≻ 0 (inf if infeasible).

    `Bw` is one (n, m) matrix or one per sample, (N, n, m).
    """
    Bws = np.broadcast_to(Bw, (len(A), *np.shape(Bw)[-2:]))
    n, m, q = A.shape[1], Bws.shape[2], C.shape[0]
    eps = 1e-7 * max(1.0, max(np.linalg.norm(a, 2) for a in A), max(np.linalg.norm(b, 2) for b in Bws),
                     np.linalg.norm(C, 2))
    P0, P1, g = cp.Variable((n, n), symmetric=True), cp.Variable((n, n), symmetric=True), cp.Variable()
    finite = math.isfinite(rate)
    constraints = [] if finite else [P1 == 0]
    for Ai, Bw, pi in zip(A, Bws, p):
        P = P0 + pi * P1
        constraints.append(P >> eps * np.eye(n))
        for sign in ((-1.0, 1.0) if finite and rate > 0 else (0.0,)):
            X = Ai.T @ P + P @ Ai + (sign * rate * P1 if sign else 0)
            M = cp.bmat([[X, P @ Bw, C.T], [Bw.T @ P, -g * np.eye(m), np.zeros((m, q))],
                         [C, np.zeros((q, m)), -g * np.eye(q)]])
            constraints.append(0.5 * (M + M.T) << -eps * np.eye(n + m + q))
    problem = cp.Problem(cp.Minimize(g), constraints)
    problem.solve(solver=cp.CLARABEL)
    if problem.status in ("infeasible", "infeasible_inaccurate"):
        return math.inf
    assert problem.status == "optimal", problem.status
    return float(g.value)


def verify_2x2(A, p, Bw, C, P0, P1, rate, gamma):
    """The 2×2 inequalities by eigenvalues at every sample and both signs of ṗ."""
    nu = 0.0 if math.isinf(rate) else rate
    for Ai, pi in zip(A, p):
        P = P0 + pi * P1
        if np.linalg.eigvalsh(P).min() <= 0:
            return False
        for sign in (-1.0, 1.0):
            M = np.block([[Ai.T @ P + P @ Ai + sign * nu * P1 + C.T @ C, P @ Bw],
                          [Bw.T @ P, -gamma ** 2 * np.eye(Bw.shape[1])]])
            if np.linalg.eigvalsh(0.5 * (M + M.T)).max() >= 0:
                return False
    return True


@pytest.fixture(scope="module")
def spring():
    """ẍ = −(2/p)x − (0.4/p)ẋ + w, z = x, p ∈ [1, 3] (a mass): a common P cannot exist (A(1)A(3) has
    negative real eigenvalues, Shorten and Narendra's test), so only a bounded rate gives a bound."""
    p = np.linspace(1.0, 3.0, 9)
    A = np.array([[[0.0, 1.0], [-2.0 / m, -0.4 / m]] for m in p])
    return A, p, np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])


@pytest.mark.parametrize("rate", [0.0, 0.1, 0.5], ids=["frozen", "slow", "faster"])
def test_the_rate_bounded_gain_matches_an_independent_lmi(spring, rate):
    A, p, Bw, C = spring
    result = sr.rate_bounded_l2_gain(A, p, Bw, C, rate=rate)
    reference = independent_l2(A, p, Bw, C, rate)
    assert result.verdict == "certified" and result.certified
    # the package reports γ*(1 + L2_INFLATION); the independent γ carries its own ε margin (~1e-6)
    assert result.upper == pytest.approx(reference * (1 + sr.L2_INFLATION), rel=2e-5)
    # its P(p) passes a check written apart from it, at the bound it reports
    assert verify_2x2(A, p, Bw, C, result.P0, result.P1, rate, result.upper)
    assert result.lower <= result.upper
    assert result.to_pandas()["verdict"] == "certified"


def test_the_gain_grows_with_the_rate_and_ends_where_the_lmi_is_infeasible(spring):
    A, p, Bw, C = spring
    uppers = [sr.rate_bounded_l2_gain(A, p, Bw, C, rate=r).upper for r in (0.0, 0.1, 0.5)]
    assert uppers == sorted(uppers)
    for rate in (2.0, math.inf):
        result = sr.rate_bounded_l2_gain(A, p, Bw, C, rate=rate)
        assert math.isinf(independent_l2(A, p, Bw, C, rate))
        assert math.isinf(result.upper) and result.verdict == "infeasible" and result.certified is None


def test_frozen_rate_on_one_sample_is_the_hinf_norm(spring):
    A, p, Bw, C = spring
    result = sr.rate_bounded_l2_gain(A[4:5], p[4:5], Bw, C, rate=0.0)
    hinf = float(ct.norm(ct.ss(A[4], Bw, C, 0), p="inf"))
    assert result.lower == pytest.approx(hinf, rel=1e-9)
    assert hinf <= result.upper <= hinf * (1 + sr.L2_INFLATION) * (1 + 1e-6)


def test_infinite_rate_agrees_with_the_common_p_bound():
    """ẋ = a x + w, a ∈ [−2, −1]: a common P exists; ν = ∞ gives l2_gain's bound."""
    p = np.linspace(-2.0, -1.0, 5)
    A = p[:, None, None] * np.ones((1, 1, 1))
    result = sr.rate_bounded_l2_gain(A, p, [[1.0]], [[1.0]], rate=math.inf)
    common = sr.l2_gain(A, [[1.0]], [[1.0]])
    assert result.upper == pytest.approx(common.upper, rel=1e-5)
    assert result.P1 is not None and not result.P1.any()


def test_a_registered_method_runs_by_name_in_the_certificate_table():
    motor = sr.load_plant("examples/plant-dc-motor.toml")
    d = sr.design(motor, 1.0, 2.0)
    table = sr.certificate_table(motor, d, methods=("l2-rate-bounded",))
    row = table.iloc[0]
    assert row["method"] == "l2-rate-bounded" and row["verdict"] == "certified"
    # the default table does not run it (it is asked for by name)
    assert "l2-rate-bounded" not in sr.certificate_table(motor, d, methods=("theorem1-all",))["method"].tolist()
    # its number, recomputed from the plant's own samples with the independent LMI
    J = motor.parameter("J")
    coarse = motor.samples(motor.coarse_points())
    C = np.zeros((1, 3))
    C[0, 1] = 1.0
    # J is ~1e-4 kg·m² and the loops' entries ~1e3 1/s: the independent LMI takes s = (J − J_lo)/width
    # in [0, 1] (the same family of P(J)) and time in units of 1/‖Ā‖ (A, B_w and the rate divided by
    # α = max |Ā|: the L2 gain does not change), so the solver answers 'optimal', not 'inaccurate'
    width = J.range[1] - J.range[0]
    s = (coarse.column("J") - J.range[0]) / width
    loops = coarse.closed_loops(d.K)
    alpha = float(np.abs(loops).max())
    reference = independent_l2(loops / alpha, s, coarse.B / alpha, C, J.rate / width / alpha)
    assert row["l2_gain [z/w]"] == pytest.approx(reference * (1 + sr.L2_INFLATION), rel=1e-4)


def test_it_is_skipped_with_the_reason_without_a_rate_bound():
    k = sr.Parameter("k", "1/s²", (1.0, 9.0))  # no `rate`: the stiffness may jump
    oscillator = sr.UncertainPlant.from_expressions([k], [[0, 1], ["-k", -0.5]], [[0], [1]], form="state")
    row = sr.certificate_table(oscillator, np.zeros((1, 2)), methods=("l2-rate-bounded",)).iloc[0]
    assert row["verdict"] == "skipped" and "rate bound" in row["detail"]


@pytest.mark.parametrize(
    "kwargs, match",
    [({"rate": -1.0}, "`rate` must be >= 0"), ({"p": np.zeros(3)}, "`p` must have shape"),
     ({"Bw": np.zeros((3, 1))}, "`Bw` must have shape")],
    ids=["negative-rate", "p-shape", "Bw-shape"],
)
def test_bad_input_names_the_argument(spring, kwargs, match):
    A, p, Bw, C = spring
    args = {"closed_loops": A, "p": p, "Bw": Bw, "C": C, "rate": 0.1, **kwargs}
    with pytest.raises(sr.ArgumentValueError, match=match):
        sr.rate_bounded_l2_gain(**args)
