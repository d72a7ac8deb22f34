"""Robustness margins: each is a certificate at its θ and fails just above it; brackets are consistent."""

import json
import math

import numpy as np
import pytest
from conftest import random_model

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.robustness.polytope import box_closed_loops

EPS = 1e-6


def _design(seed):
    model = random_model(seed, n=4, m=2, n_elements=5)
    return model, sr.design(model, 2.0, 3.0)


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_theorem1_margin_is_exact(paper, paper_design, elements):
    theta = sr.robustness_margin(paper, paper_design, "theorem1", elements=elements).theta
    assert sr.certify(paper.scaled(theta * (1 - EPS)), paper_design, elements).max_eig < 0
    assert sr.certify(paper.scaled(theta * (1 + 1e-3)), paper_design, elements).max_eig > 0


@pytest.mark.parametrize("elements", ["all", "A", "B"])
def test_vertex_margin_is_exact(paper, paper_design, elements):
    theta = sr.robustness_margin(paper, paper_design, "vertex", elements=elements).theta
    assert sr.vertex_certificate(paper.scaled(theta * (1 - EPS)), paper_design, elements).certified
    assert not sr.vertex_certificate(paper.scaled(theta * (1 + 1e-3)), paper_design, elements).certified


def test_published_box_at_the_paper_design(paper, paper_design):
    # Theorem 1 certifies 55 % of the published box; no certificate of any kind exists beyond ~64 %.
    t1 = sr.robustness_margin(paper, paper_design, "theorem1").theta
    vertex = sr.robustness_margin(paper, paper_design, "vertex").theta
    frozen = sr.robustness_margin(paper, paper_design, "frozen", lower=vertex)
    assert 0.5 < t1 <= vertex < frozen.theta < 1.0
    lo, hi = frozen.bracket
    assert (hi - lo) <= 1e-3 * hi
    loops = box_closed_loops(paper.scaled(hi), paper_design.K)
    assert np.linalg.eigvals(loops).real.max() > 0
    assert np.linalg.eigvals(box_closed_loops(paper.scaled(lo), paper_design.K)).real.max() < 0


@pytest.mark.lmi
@pytest.mark.parametrize("seed", range(6), ids=[f"seed{s}" for s in range(6)])
def test_lower_bounds_never_exceed_upper_bounds(seed):
    model, d = _design(seed)
    if not d.hurwitz:
        pytest.skip("nominal design not Hurwitz for this draw")
    table = sr.margin_table(model, d, tol=1e-2, falsifier_tries=3).set_index("method")
    lowers = table[table["kind"] == "lower"]["theta"].dropna()
    uppers = table[table["kind"] == "upper"]["theta"].dropna()
    assert lowers.max() <= uppers.min() * (1 + 1e-9)
    assert table.loc["theorem1", "theta"] <= table.loc["vertex", "theta"] * (1 + 1e-9)  # Z bounds every vertex
    assert table.loc["vertex", "theta"] <= table.loc["lmi", "theta"] * (1 + 1e-2) or math.isinf(
        table.loc["frozen", "theta"])


@pytest.mark.lmi
def test_the_table_runs_the_frozen_scan_once_before_the_searches_that_use_it(monkeypatch):
    """Cheap methods first: the frozen bound from the vertex bound, then the LMI and falsifier from both ends."""
    from scara_robust.robustness import margins

    model, d = _design(1)
    scans = []
    frozen = margins._frozen
    monkeypatch.setattr(margins, "_frozen", lambda *args: scans.append(args[2]) or frozen(*args))
    table = sr.margin_table(model, d, tol=1e-2, falsifier_tries=3).set_index("method")
    assert list(table.index) == ["theorem1", "vertex", "lmi", "frozen", "falsifier", "bracket"]  # the registry's order
    vertex, upper = table.loc["vertex", "theta"], table.loc["frozen", "theta"]
    assert scans == [max(table.loc["theorem1", "theta"], vertex)]  # one scan, from the best exact lower bound
    assert f"scanned from θ = {vertex:.4g}" in table.loc["frozen", "message"]
    # the LMI bisected below the frozen bound (given, not scanned again), the falsifier from both ends
    assert table.loc["lmi", "hi"] <= upper and table.loc["falsifier", "lo"] >= table.loc["lmi", "theta"]
    alone = sr.robustness_margin(model, d, "lmi", tol=1e-2, lower=vertex, upper=upper)
    assert (alone.theta, alone.bracket) == (table.loc["lmi", "theta"], (table.loc["lmi", "lo"], table.loc["lmi", "hi"]))


@pytest.mark.lmi
def test_lmi_margin_certifies_at_lo_and_not_at_hi():
    model, d = _design(3)
    m = sr.robustness_margin(model, d, "lmi", tol=1e-3)
    lo, hi = m.bracket
    assert (hi - lo) <= 1e-3 * hi and m.theta == lo
    at = sr.lmi_certificate(box_closed_loops(model.scaled(lo), d.K))
    assert at.certified
    assert not sr.lmi_certificate(box_closed_loops(model.scaled(hi), d.K)).certified


@pytest.mark.parametrize("c", [0.5, 2.0, 10.0])
@pytest.mark.parametrize("method", ["theorem1", "vertex", "frozen"])
def test_margin_scales_as_one_over_c(paper, paper_design, c, method):
    scaled = paper.scaled(c)  # every bound multiplied by c
    base = sr.robustness_margin(paper, paper_design, method, tol=1e-6).theta
    assert sr.robustness_margin(scaled, paper_design, method, tol=1e-6).theta == pytest.approx(base / c, rel=1e-5)


@pytest.mark.parametrize("method", ["theorem1", "vertex"])
@pytest.mark.parametrize("seed", range(3), ids=[f"seed{s}" for s in range(3)])
def test_margin_map_agrees_with_point_by_point(seed, method):
    model, _ = _design(seed)
    rhos, etas = np.array([0.5, 2.0]), np.array([1.0, 3.0, 10.0])
    for elements in ("all", "A", "B"):
        surface = sr.design_surface(model, rhos, etas, elements, measure="margin", margin_method=method)
        for i, rho in enumerate(rhos):
            for k, eta in enumerate(etas):
                point = sr.robustness_margin(model, sr.design(model, rho, eta), method, elements=elements).theta
                assert surface.margin[i, k] == pytest.approx(point, rel=1e-9), (elements, rho, eta)


def test_polytope_margin_scales_about_the_vertex_average():
    A = np.array([[[-1.0, 2.0], [1.0, -3.0]], [[-0.8, 1.5], [1.3, -2.7]], [[-1.4, 0.9], [0.7, -2.0]]])
    poly = sr.PolytopicModel(A, np.tile([[0.0], [1.0]], (3, 1, 1)))
    d = sr.design(poly, 1.0, 2.0)
    theta = sr.robustness_margin(poly, d, "vertex").theta
    assert sr.vertex_certificate(poly.scaled(theta * (1 - EPS)), d).certified
    assert not sr.vertex_certificate(poly.scaled(theta * (1 + 1e-3)), d).certified
    with pytest.raises(sr.ArgumentValueError, match="'theorem1' needs interval elements"):
        sr.robustness_margin(poly, d, "theorem1")


@pytest.mark.lmi
def test_payload_margin_brackets(paper_design):
    table = sr.payload_margin(paper_design, n_times=91, n_masses=6, lmi_times=19, lmi_masses=3, tol=1e-2)
    rows = table.set_index("method")["mass [kg]"]
    assert 0 < rows["payload-design-P"] <= rows["payload-lmi"] <= rows["payload-frozen"]
    # the paper's payload peaks at 2.07 kg: beyond the design P's reach, within the common P's
    assert rows["payload-design-P"] < 2.07 < rows["payload-lmi"]


@pytest.mark.lmi
def test_the_payload_s_frozen_row_is_its_scans_where_a_verified_p_answers_it(paper_design, monkeypatch):
    """The frozen row skips its scan at a mass a lower row verified on the same samples; its row is the same."""
    from scara_robust.robustness import _spectra

    scans = []
    all_stable = _spectra.StabilityScan.all_stable
    monkeypatch.setattr(_spectra.StabilityScan, "all_stable",
                        lambda self, matrices: scans.append(1) or all_stable(self, matrices))
    grid = {"n_times": 37, "n_masses": 4, "lmi_times": 13, "lmi_masses": 3, "tol": 1e-2}
    alone = sr.payload_margin(paper_design, methods=["payload-frozen"], **grid).iloc[0]
    n_alone = len(scans)
    by = sr.payload_margin(paper_design, **grid).set_index("method")
    assert by.loc["payload-frozen", "bracket [kg]"] == alone["bracket [kg]"]
    assert by.loc["payload-frozen", "mass [kg]"] == alone["mass [kg]"]
    # the doubling masses the lower rows certified (1e-9, 1, 2, 4, ...) were not scanned again
    certified = [m for m in [1e-9] + [2.0**k for k in range(12)] if m <= by.loc["payload-lmi", "mass [kg]"]]
    assert len(certified) >= 5 and n_alone - (len(scans) - n_alone) == len(certified)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [({"tol": 0.0}, sr.ArgumentValueError, "`tol` must be > 0"),
     ({"method": "mu"}, sr.ArgumentValueError, "`method` must be one of 'theorem1'")],
    ids=["tol", "method"],
)
def test_bad_margin_arguments(paper, paper_design, kwargs, error, match):
    with pytest.raises(error, match=match):
        sr.robustness_margin(paper, paper_design, **kwargs)


def test_a_model_without_elements_has_no_margin():
    model = sr.UncertainLTVModel([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]])
    with pytest.raises(sr.ArgumentValueError, match="`model` has no uncertain elements"):
        sr.robustness_margin(model, sr.design(model, 1, 2))


@pytest.mark.parametrize(
    ("argv", "needle"),
    [(["--tol", "0"], "`--tol` must be a relative tolerance in (0, 1)"),
     (["--tries", "0"], "`--tries` must be an integer >= 1"),
     (["--method", "mu"], "argument --method: must be one of 'theorem1'")],
    ids=["tol", "tries", "method"],
)
def test_margin_cli_bad_options(capsys, argv, needle):
    assert main(["margin", "--rho", "3", "--eta", "90", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err


def test_margin_cli_refuses_a_model_file_without_elements(tmp_path, capsys):
    path = tmp_path / "plain.toml"
    path.write_text("A = [[0.0, 1.0], [0.0, 0.0]]\nB = [[0.0], [1.0]]\n")
    assert main(["margin", "--model", str(path), "--rho", "1", "--eta", "2"]) == 2
    assert "`model` has no uncertain elements" in capsys.readouterr().err


def test_margin_cli_json(capsys):
    model = "examples/plant-dc-motor-elements.toml"
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / model
    assert main(["margin", "--model", str(path), "--rho", "1", "--eta", "2", "--tol", "0.01", "--format", "json"]) == 0
    rows = {r["method"]: r for r in json.loads(capsys.readouterr().out)}
    assert {"theorem1", "vertex", "lmi", "frozen", "falsifier", "bracket"} <= set(rows)
    assert rows["theorem1"]["kind"] == "lower" and rows["frozen"]["kind"] == "upper"
    assert rows["theorem1"]["theta"] <= rows["vertex"]["theta"]


def test_margin_cli_one_method(capsys):
    assert main(["margin", "--rho", "3", "--eta", "90", "--method", "vertex", "--no-payload", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["method"] for r in rows] == ["vertex"] and 0.55 < rows[0]["theta"] < 0.56


# ---------------------------------------------------------------- a gain of your own

def _small_box() -> sr.UncertainLTVModel:
    """q̈ = a q̇ + b u with a ∈ [−0.15, −0.05] 1/s and b ∈ [0.05, 0.15]: two uncertain elements."""
    return sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
                                (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))


def test_a_plain_gain_gives_the_margins_of_the_equivalent_design():
    """Design.from_gain(model, d.K, P=d.P) is d for every margin; a plain K (its P from the Lyapunov
    equation) gives the same margins wherever the method does not use P."""
    model = _small_box()
    d = sr.design(model, 1.0, 2.0)
    same = sr.Design.from_gain(model, d.K, P=d.P)
    assert same.P_source == "given" and np.allclose(same.A_cl, d.A_cl, rtol=0, atol=1e-12)
    plain = sr.Design.from_gain(model, d.K)
    assert plain.P_source == "lyapunov"
    assert np.allclose(plain.P @ plain.A_cl + plain.A_cl.T @ plain.P, -2 * np.eye(2), atol=1e-9)
    for method in ("theorem1", "vertex", "frozen", "lmi"):
        reference = sr.robustness_margin(model, d, method, tol=1e-2).theta
        assert sr.robustness_margin(model, same, method, tol=1e-2).theta == pytest.approx(reference, rel=1e-9), method
        if method in ("frozen", "lmi"):  # these do not use P
            assert sr.robustness_margin(model, d.K, method, tol=1e-2).theta == pytest.approx(reference, rel=1e-9)


def test_a_gain_of_your_own_runs_the_certificate_table_and_refuses_what_has_no_p():
    model = _small_box()
    table = sr.certificate_table(model, [[3.75, 11.5]], methods=("theorem1-all", "vertex-box", "lmi-box"))
    assert list(table["method"]) == ["theorem1-all", "vertex-box", "lmi-box"]
    assert table.set_index("method").loc["lmi-box", "certified"]
    with pytest.raises(sr.ArgumentValueError, match="`K` gives a closed loop that is not Hurwitz"):
        sr.Design.from_gain(model, [[0.0, 0.0]])  # the open loop has a pole at 0
    with pytest.raises(sr.ArgumentValueError, match="`P` must be symmetric positive definite"):
        sr.Design.from_gain(model, [[3.75, 11.5]], P=-np.eye(2))
    with pytest.raises(sr.ArgumentValueError, match="`K`"):
        sr.Design.from_gain(model, [[3.75, 11.5, 1.0]])


def test_a_scara_plant_with_its_payload_range_replaced_gives_the_loops_of_one_built_for_it():
    """payload_margin keeps one plant per grid and replaces the payload range at each peak mass: the
    closed loops are those of the plant built for that mass, bit for bit (its reference kept)."""
    from scara_robust.model.robot import SinusoidalPayload, payload_range
    from scara_robust.model.scara import scara_uncertain_plant

    K = sr.design(sr.derived_model(), 3, 90).K
    base = scara_uncertain_plant(None, None, SinusoidalPayload(0.5, 0.5), n_times=37, n_masses=5)
    for mass in (1e-9, 2.0, 129.75, 271.25):
        profile = SinusoidalPayload(0.5 * mass, 0.5 * mass)
        fresh = scara_uncertain_plant(None, None, profile, n_times=37, n_masses=5)
        kept = base.with_ranges({"m_p": payload_range(profile, np.linspace(0.0, 2 * np.pi, 37))})
        grid = {"t_ref": 37, "m_p": 5}
        assert np.array_equal(kept.samples(grid).closed_loops(K), fresh.samples(grid).closed_loops(K))
