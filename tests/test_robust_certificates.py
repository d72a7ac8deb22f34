"""Beyond Theorem 1: vertex-exact and physical tests, the LMI, the falsifier, `certify`."""

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from conftest import random_model

import scara_robust as sr
from scara_robust import cli
from scara_robust.robustness import lmi
from scara_robust.robustness.polytope import box_closed_loops, box_vertices

needs_cvxpy = pytest.mark.lmi  # skipped without the extra, failed under `make test` (see conftest.py)

#: A classic pair of stable matrices whose switching is unstable (each has eigenvalues -0.1 ± 3.16j).
SWITCHED = np.array([[[-0.1, 1.0], [-10.0, -0.1]], [[-0.1, 10.0], [-1.0, -0.1]]])


def _random_design(seed):
    model = random_model(seed, n=4, m=2, n_elements=5)
    return model, sr.design(model, 2.0, 3.0)


# ---------------------------------------------------------------- vertex test


def test_box_vertices_are_the_corners(paper):
    H = box_vertices(paper)
    assert H.shape == (1024, 10)
    corners = {tuple(row) for row in itertools.product(*[(e.lower, e.upper) for e in paper.elements])}
    assert {tuple(row) for row in H} == corners


@pytest.mark.parametrize("seed", range(6), ids=[f"seed{s}" for s in range(6)])
def test_vertex_exact_never_above_theorem1(seed):
    model, d = _random_design(seed)
    exact = sr.vertex_certificate(model, d)
    bound = sr.certify(model, d).max_eig
    assert exact.max_eig <= bound + 1e-9 * max(1.0, abs(bound))


@pytest.mark.parametrize("seed", range(3), ids=[f"seed{s}" for s in range(3)])
def test_vertex_exact_matches_a_literal_loop_and_bounds_the_interior(seed):
    model, d = _random_design(seed)
    exact = sr.vertex_certificate(model, d)
    literal = []
    for corner in itertools.product(*[(e.lower, e.upper) for e in model.elements]):
        A_h, B_h = model.matrices_at(np.array(corner))
        A_cl = A_h - B_h @ d.K
        literal.append(np.linalg.eigvalsh(d.P @ A_cl + A_cl.T @ d.P)[-1])
    assert exact.max_eig == pytest.approx(max(literal), rel=1e-10)
    rng = np.random.default_rng(seed)
    lower, upper = model.lower_bounds(), model.upper_bounds()
    for h in rng.uniform(lower, upper, size=(200, model.n_elements)):
        A_h, B_h = model.matrices_at(h)
        A_cl = A_h - B_h @ d.K
        assert np.linalg.eigvalsh(d.P @ A_cl + A_cl.T @ d.P)[-1] <= exact.max_eig + 1e-9


def test_paper_box_has_unstable_vertices(paper, paper_design):
    cert = sr.vertex_certificate(paper, paper_design)
    assert (cert.n_vertices, cert.n_unstable) == (1024, 320)
    assert not cert.certifiable and not cert.certified
    assert "no certificate can exist" in cert.message
    A_worst = box_closed_loops(paper, paper_design.K)
    assert cert.max_real_pole == pytest.approx(np.linalg.eigvals(A_worst).real.max(), rel=1e-12)
    a_only = sr.vertex_certificate(paper, paper_design, "A")
    assert a_only.certified and a_only.n_vertices == 64
    assert a_only.max_eig <= sr.certify(paper, paper_design, "A").max_eig


def test_physical_verdict_survives_refinement(paper_design):
    coarse = sr.physical_certificate(paper_design, n_times=181, n_masses=6)
    fine = sr.physical_certificate(paper_design, n_times=721, n_masses=21)
    assert coarse.certified == fine.certified
    assert fine.n_unstable == 0
    assert fine.max_eig == pytest.approx(coarse.max_eig, rel=1e-2)
    assert fine.worst_point.shape == (2,)


def test_physical_samples_contained_in_derived_box():
    model = sr.derived_model(times=np.linspace(0, 2 * np.pi, 91), n_masses=5)
    samples = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 91), n_masses=5)
    assert samples.A.shape == (455, 6, 6) and samples.n_samples == 455
    A_hi, B_hi = model.matrices_at(model.upper_bounds())
    tol = 1e-12
    assert np.all(samples.A >= model.A - tol) and np.all(samples.A <= A_hi + tol)
    assert np.all(samples.B >= model.B - tol) and np.all(samples.B <= B_hi + tol)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda d: sr.polytope_certificate(np.zeros((0, 2, 2)), np.eye(2)), ValueError, "`closed_loops` must have"),
        (lambda d: sr.polytope_certificate(np.zeros((1, 2, 3)), np.eye(2)), ValueError, "`closed_loops` must have"),
        (lambda d: sr.polytope_certificate(-np.eye(2)[None], -np.eye(2)), ValueError, "`P` must be positive definite"),
        (lambda d: sr.polytope_certificate(-np.eye(2)[None], np.eye(2), np.zeros((2, 1))), ValueError, "`points`"),
        (lambda d: sr.vertex_certificate(sr.paper_model(), "K"), TypeError, "`design` must be a Design"),
        (lambda d: sr.vertex_certificate(sr.paper_model(), d, "C"), ValueError, "`elements` must be one of"),
        (lambda d: sr.physical_certificate(d, n_times=1), ValueError, "`n_times` must be an integer >= 2"),
        (lambda d: box_vertices(random_model(0, n=6, n_elements=17)), ValueError, "at most 16 uncertain elements"),
    ],
    ids=["empty", "not-square", "P-indefinite", "points-rows", "design-type", "elements", "n_times", "too-many"],
)
def test_bad_input(paper_design, call, error, match):
    with pytest.raises(error, match=match):
        call(paper_design)


# ---------------------------------------------------------------- LMI


@pytest.mark.lmi
def test_lmi_extra_is_installed():
    assert lmi.cvxpy_available()


@needs_cvxpy
def test_lmi_finds_and_numpy_confirms_a_common_p(paper, paper_design):
    vertices = box_closed_loops(paper.subset("A"), paper_design.K)
    result = sr.lmi_certificate(vertices)
    assert result.status == "optimal" and result.certified
    P = result.P
    # independent check: scipy's eigh on P and on every vertex's Lyapunov derivative
    assert np.allclose(P, P.T) and scipy.linalg.eigh(P, eigvals_only=True)[0] > 0
    worst = max(scipy.linalg.eigh(A.T @ P + P @ A, eigvals_only=True)[-1] for A in vertices)
    assert worst < 0
    # the decay rate α of V = xᵀPx, V̇ <= −2αV: the generalized eigenvalues of (ĀᵀP + PĀ, P), scipy's
    exact = min(-scipy.linalg.eigh(A.T @ P + P @ A, P, eigvals_only=True)[-1] / 2 for A in vertices)
    assert result.decay_rate == pytest.approx(exact, rel=1e-9)
    assert result.decay_rate >= -worst / (2 * scipy.linalg.eigh(P, eigvals_only=True)[-1])  # the cruder bound


@needs_cvxpy
def test_lmi_infeasible_when_a_vertex_is_unstable(paper, paper_design):
    result = sr.lmi_certificate(box_closed_loops(paper, paper_design.K))
    assert result.status == "infeasible" and result.P is None
    assert not result.certified and np.isnan(result.decay_rate)


@needs_cvxpy
def test_lmi_rejects_the_switched_pair():
    # no common quadratic Lyapunov function exists: the falsifier below finds growth
    assert not sr.lmi_certificate(SWITCHED).certified


def test_verify_lyapunov_rejects_bad_matrices():
    vertices = np.array([-np.eye(2), [[-1.0, 0.5], [0.0, -2.0]]])
    assert sr.verify_lyapunov(vertices, np.eye(2))[1] > 0
    assert sr.verify_lyapunov(vertices, -np.eye(2))[1] == -np.inf
    assert sr.verify_lyapunov(vertices, np.array([[1.0, 0.5], [0.0, 1.0]]))[1] == -np.inf


def test_lmi_without_cvxpy(monkeypatch, paper, paper_design):
    monkeypatch.setattr(lmi, "cvxpy_available", lambda: False)
    result = sr.lmi_certificate(box_closed_loops(paper.subset("A"), paper_design.K))
    assert result.status == "not installed" and result.P is None and not result.certified
    assert "pip install '.[lmi]'" in result.message
    table = sr.certificate_table(paper, paper_design, plant=sr.scara_uncertain_plant(bounds="paper"),
                                 falsifier_tries=3).set_index("method")
    for method in ("lmi-box", "lmi-physical"):
        assert table.loc[method, "verdict"] == "not installed" and table.loc[method, "certified"] is None
    assert table.loc["theorem1-A", "certified"]


def test_package_imports_without_cvxpy():
    code = (
        "import sys; sys.modules['cvxpy'] = None\n"
        "import numpy as np, scara_robust as sr\n"
        "r = sr.lmi_certificate(-np.eye(2)[None])\n"
        "print(r.status)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "not installed"


# ---------------------------------------------------------------- falsifier


def test_falsifier_finds_the_unstable_switching():
    frozen = np.linalg.eigvals(SWITCHED).real.max()
    assert frozen < 0  # each mode alone is stable
    result = sr.falsify(SWITCHED, horizon=20.0, n_tries=6)
    assert result.found and result.growth_rate > 0.5 and result.late_rate > 0
    # replay the reported switching sequence exactly and compare the growth
    Phi = scipy.linalg.expm(SWITCHED * result.dwell)
    x = result.x0.copy()
    log_norm = 0.0
    for v in result.sequence:
        x = Phi[v] @ x
        log_norm += np.log(np.linalg.norm(x))
        x /= np.linalg.norm(x)
    assert log_norm / result.horizon == pytest.approx(result.growth_rate, rel=1e-9)


def _falsify_one_try_at_a_time(A_v, P, *, dwell=0.01, horizon=5.0, n_tries=30, seed=0):
    """The falsifier's definition, try after try: each step's vertex by its rule, the state renormalized."""
    n_v, n = A_v.shape[0], A_v.shape[1]
    rules = ["norm", "lyapunov", "random"] if P is not None else ["norm", "random"]
    steps = int(round(horizon / dwell))
    Phi = scipy.linalg.expm(A_v * dwell)
    rng = np.random.default_rng(seed)
    runs = []
    for trial in range(n_tries):
        rule = rules[trial % len(rules)]
        x = rng.normal(size=n)
        x0 = x / np.linalg.norm(x)
        x, log_norm, log_half, sequence = x0.copy(), 0.0, 0.0, []
        for k in range(steps):
            if rule == "random":
                v = int(rng.integers(n_v))
            else:
                weight = np.eye(n) if rule == "norm" else P
                v = int(np.argmax([(Phi[u] @ x) @ weight @ (Phi[u] @ x) for u in range(n_v)]))
            sequence.append(v)
            x = Phi[v] @ x
            log_norm += math.log(np.linalg.norm(x))
            x /= np.linalg.norm(x)
            if k + 1 == steps // 2:
                log_half = log_norm
        runs.append((log_norm, log_norm - log_half, rule, sequence, x0))
    return max(runs, key=lambda run: run[0])  # the first of the largest, as a loop keeping the best finds it


@pytest.mark.parametrize("case", ["paper-corners", "switched", "random-no-P"])
def test_the_falsifier_s_tries_side_by_side_are_the_tries_one_at_a_time(case, paper, paper_design):
    """Every try run side by side draws, chooses and grows as the same try run alone."""
    if case == "paper-corners":
        A_v, P, kwargs = box_closed_loops(paper.subset("A"), paper_design.K) * 0.02, paper_design.P, {"n_tries": 7}
    elif case == "switched":
        A_v, P, kwargs = SWITCHED, np.diag([1.0, 3.0]), {"n_tries": 5, "horizon": 2.0}
    else:
        rng = np.random.default_rng(11)
        A_v, P, kwargs = rng.normal(size=(9, 4, 4)) - 0.8 * np.eye(4), None, {"n_tries": 6, "seed": 3}
    result = sr.falsify(A_v, P, **kwargs)
    log_norm, late, rule, sequence, x0 = _falsify_one_try_at_a_time(A_v, P, **kwargs)
    assert result.rule == rule
    assert result.sequence.tolist() == sequence
    np.testing.assert_array_equal(result.x0, x0)
    assert result.growth_rate == pytest.approx(log_norm / result.horizon, rel=1e-9, abs=1e-12)
    assert result.late_rate == pytest.approx(late / (result.horizon - (kwargs.get("horizon", 5.0) / 2)),
                                             rel=1e-9, abs=1e-12)


def test_a_falsifier_try_whose_state_underflows_stops_there():
    """‖x‖² below the smallest double: the try ends with a log-norm of −inf, the others go on as alone."""
    fast = -40000.0 * np.eye(2)  # exp(−400) per dwell: ‖x‖² underflows to 0 at the first step
    alone = sr.falsify(np.array([fast]), None, horizon=1.0, n_tries=3)
    assert alone.growth_factor == 0.0 and alone.growth_rate == -np.inf and not alone.found
    assert alone.verdict == "no counterexample found"
    # the random tries that draw the fast vertex stop; the greedy ones never choose it, as without it
    mixed = sr.falsify(np.concatenate([[fast], SWITCHED]), np.eye(2), horizon=20.0)
    without = sr.falsify(SWITCHED, np.eye(2), horizon=20.0)
    assert mixed.found and without.found and mixed.rule == without.rule != "random"
    assert mixed.growth_rate == without.growth_rate
    assert mixed.sequence.tolist() == (without.sequence + 1).tolist()


def test_falsifier_finds_nothing_on_a_certified_set(paper, paper_design):
    assert sr.certify(paper, paper_design, "A").certified
    vertices = box_closed_loops(paper.subset("A"), paper_design.K)
    result = sr.falsify(vertices, paper_design.P, n_tries=9)
    assert not result.found and result.growth_factor < 1
    assert "no counterexample found in 9 tries" in result.message


def test_falsifier_rate_on_an_unstable_frozen_vertex(paper, paper_design):
    vertices = box_closed_loops(paper, paper_design.K)
    result = sr.falsify(vertices, paper_design.P, n_tries=3)
    assert result.found
    assert result.growth_rate == pytest.approx(np.linalg.eigvals(vertices).real.max(), rel=1e-2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dwell": 0.0}, "`dwell` must be"),
        ({"horizon": 0.01, "dwell": 0.01}, r"`horizon` must be at least 2 \* dwell"),
        ({"n_tries": 0}, "`n_tries` must be an integer >= 1"),
        ({"threshold": 0.5}, "`threshold`"),
        ({"P": np.eye(3)}, "`P`"),
    ],
    ids=["dwell", "horizon", "tries", "threshold", "P-shape"],
)
def test_falsifier_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        sr.falsify(SWITCHED, **kwargs)


# ---------------------------------------------------------------- table and CLI


@pytest.mark.slow  # the whole certify table (LMI over 1024 corners); the README runs the text form
def test_certify_json_rows(capsys):
    code = cli.main(["certify", "--rho", "3", "--eta", "90", "--format", "json", "--tries", "3"])
    rows = json.loads(capsys.readouterr().out)
    assert code == 0
    # the sampled certificate at the controller's Ts leads, then the certificates, the design's decay
    # rate and each input's loop margins
    assert rows[0]["method"] == "max-ts" and rows[0]["certified"] is True
    rows = rows[1:]
    n = len(sr.CERTIFICATE_METHODS)
    assert [r["method"] for r in rows[:n]] == list(sr.CERTIFICATE_METHODS)
    assert [r["method"] for r in rows[n:]] == ["decay-rate", "loop-margins", "loop-margins"]
    for r in rows[:n]:
        assert {"method", "certified", "max_eig", "decay_rate [1/s]", "growth_rate [1/s]", "seconds"} <= set(r)
        assert r["seconds"] >= 0
    by = {r["method"]: r for r in rows[:n]}
    assert by["theorem1-all"]["certified"] is False and by["theorem1-A"]["certified"] is True
    assert by["theorem1-all"]["max_eig"] == pytest.approx(713.90, abs=0.01)
    assert by["vertex-box"]["verdict"] == "no certificate can exist"
    assert by["falsifier-box"]["certified"] is False
    # the command builds the SCARA as an UncertainPlant; its rows are those of the element-level code
    reference = json.loads((Path(__file__).parent / "data" / "scara_reference.json").read_text())["certify"]
    for method, (verdict, max_eig) in reference.items():
        assert by[method]["verdict"] == verdict, method
        assert by[method]["max_eig"] == pytest.approx(max_eig, rel=1e-9), method
    if lmi.cvxpy_available():
        assert by["lmi-box"]["certified"] is False and by["lmi-physical"]["certified"] is True
        assert by["lmi-physical"]["decay_rate [1/s]"] > 0


@pytest.mark.slow  # the README's `certify --bounds derived` runs the same command in make test
def test_certify_text(capsys):
    assert cli.main(["certify", "--rho", "3", "--eta", "90", "--bounds", "derived", "--tries", "2"]) == 0
    first, out = capsys.readouterr().out.split("\n", 1)  # the sampled certificate leads, then the table
    assert first.startswith("continuous-time certificates below; sampled as export discretizes the controller")
    assert out.startswith("certificates of K(rho=3, eta=90), bounds: derived")
    assert all(method in out for method in sr.CERTIFICATE_METHODS)


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["certify", "--rho", "0", "--eta", "90"], "`--rho`"),
        (["certify", "--rho", "3", "--eta", "0.5"], "`--eta`"),
        (["certify", "--rho", "3", "--eta", "90", "--tries", "0"], "`--tries` must be an integer >= 1"),
        (["certify", "--rho", "3", "--eta", "90", "--bounds", "tables"], "invalid choice"),
        (["certify", "--rho", "nan", "--eta", "90"], "finite"),
    ],
    ids=["rho", "eta", "tries", "bounds", "nan"],
)
def test_certify_bad_input(capsys, argv, match):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("scara_robust: error:")
    assert match in err


def test_certificate_table_bad_input(paper, paper_design):
    with pytest.raises(TypeError, match="`model` must be an UncertainPlant, an UncertainLTVModel or a PolytopicModel"):
        sr.certificate_table("paper", paper_design)
    with pytest.raises(ValueError, match="`lmi_solver` must be one of"):
        sr.certificate_table(paper, paper_design, lmi_solver="MOSEK")
    with pytest.raises(ValueError, match=r"`lmi_points\['m_p'\]` must be an integer >= 1"):
        sr.certificate_table(sr.scara_uncertain_plant(bounds="paper"), paper_design, lmi_points={"m_p": 0})


def test_falsifier_reports_huge_growth_by_its_order_of_magnitude(paper, paper_design):
    result = sr.falsify(box_closed_loops(paper, paper_design.K), paper_design.P, n_tries=3)
    assert result.found and result.growth_factor == np.inf
    assert "grew by a factor of 10^" in result.message and "inf" not in result.message
    assert float(result.message.split("10^")[1].split()[0]) == pytest.approx(
        result.growth_rate * result.horizon / np.log(10), abs=0.5
    )


def test_the_fixed_p_verdict_is_the_polytope_certificate_s(paper, paper_design):
    """fixed_p_certifies: the certificate's `certified` (a Cholesky first), its argument checks too."""
    from scara_robust.robustness.polytope import fixed_p_certifies, polytope_certificate

    corners = box_closed_loops(paper, paper_design.K)
    answers = []
    for theta in np.linspace(0.3, 0.7, 41):  # across the design P's exact margin (0.558)
        loops = box_closed_loops(paper.scaled(theta), paper_design.K)
        answers.append(fixed_p_certifies(loops, paper_design.P))
        assert answers[-1] is polytope_certificate(loops, paper_design.P).certified
    assert True in answers and False in answers
    with pytest.raises(ValueError, match="`P` must be positive definite"):
        fixed_p_certifies(corners, -paper_design.P)
    with pytest.raises(ValueError, match="`P`"):
        fixed_p_certifies(corners, np.eye(3))
