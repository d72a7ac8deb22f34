"""Answers safe to act on: certified deployments, proven (not assumed) infeasibility, marginal decays,
anchored margins and one decay convention."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.robustness import margins as margins_module
from scara_robust.robustness.lmi import lmi_verdict
from scara_robust.robustness.polytope import box_closed_loops
from scara_robust.robustness.sampled import interior_grid
from scara_robust.robustness.synthesis import vertices_of
from scara_robust.simulation.controllers import PID_LMI_FILE

# A DC motor whose load inertia J varies in [1e-5, 5e-5] kg·m² (b = 1e-4 N·m·s/rad, k_t = 0.05 N·m/A):
# θ̈ = −(b/J)θ̇ + (k_t/J)u, nominal at J = 5e-5 (the lower corner of both elements).
MOTOR = """
name = "DC motor, J in [1e-5, 5e-5] kg m^2"
form = "pid"
A = [[0.0, 1.0], [0.0, -2.0]]
B = [[0.0], [1000.0]]
[[elements]]
matrix = "A"
row = 1
col = 1
lower = -8.0
upper = 0.0
[[elements]]
matrix = "B"
row = 1
col = 0
lower = 0.0
upper = 4000.0
"""


@pytest.fixture
def motor_file(tmp_path):
    path = tmp_path / "motor.toml"
    path.write_text(MOTOR)
    return path


# ---------------------------------------------------------------- export refuses what is not certified


@pytest.mark.lmi
def test_export_refuses_a_stable_looking_uncertified_ts_naming_both_limits(motor_file, tmp_path, capsys):
    """At Ts = 1 ms the nominal motor's sampled loop is stable, yet a corner of the box is not."""
    model = sr.load_model(motor_file)
    d = sr.design(model, 1, 2)
    pid = d.discretize(1e-3)
    nominal = sr.sampled_closed_loops(model.A[None], model.B[None], pid)
    assert np.abs(np.linalg.eigvals(nominal)).max() < 1  # stable-looking: the design plant is fine
    out = tmp_path / "out"
    out.mkdir()
    code = main(["export", "--model", str(motor_file), "--rho", "1", "--eta", "2", "--ts", "0.001",
                 "--torque-limit", "2", "--output", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert list(out.iterdir()) == []
    limit = sr.max_sample_time(model, d, check=interior_grid(model))  # the one search, whichever command runs it
    assert 0 < limit.certified_ts < 1e-3 and limit.unstable_ts < 1e-3
    assert f"the largest certified Ts is {limit.certified_ts:.4g} s" in err
    assert f"a frozen plant is unstable from Ts = {limit.unstable_ts:.4g} s" in err
    assert "`--ts`" in err and "--allow-uncertified" in err


@pytest.mark.lmi
def test_allow_uncertified_writes_the_warning_into_the_files(motor_file, tmp_path, capsys):
    argv = ["export", "--model", str(motor_file), "--rho", "1", "--eta", "2", "--ts", "0.001", "--allow-uncertified",
            "--output", str(tmp_path)]
    assert main(argv) == 0
    header = (tmp_path / "scara_pid.h").read_text()
    assert "WARNING: NOT CERTIFIED at this Ts" in header.splitlines()[1]
    assert "the largest certified Ts is" in header
    assert "WARNING: not certified" in capsys.readouterr().out
    assert main([*argv, "--format", "json"]) == 0
    record = json.loads((tmp_path / "scara_pid.json").read_text())
    assert record["certificate"]["certified"] is False and record["certificate"]["verdict"] == "infeasible"
    assert record["certificate"]["certified_ts"] < 1e-3 and record["plant_file"] == str(motor_file)
    assert any("NOT CERTIFIED" in note for note in record["notes"])


@pytest.mark.lmi
def test_a_certified_export_records_its_certificate(motor_file, tmp_path):
    assert main(["export", "--model", str(motor_file), "--rho", "1", "--eta", "2", "--ts", "1e-4", "--format", "json",
                 "--output", str(tmp_path)]) == 0
    cert = json.loads((tmp_path / "scara_pid.json").read_text())["certificate"]
    assert cert["certified"] is True and cert["Ts"] == cert["certified_ts"] == 1e-4
    assert cert["decay_rate"] > 0 and cert["spectral_radius"] < 1 and "25-plant grid" in cert["set"]
    # the record's P-free claims are re-verified here: every frozen sampled loop on the grid is Schur stable
    model = sr.load_model(motor_file)
    loops = sr.sampled_closed_loops(*interior_grid(model), sr.design(model, 1, 2).discretize(1e-4))
    assert np.abs(np.linalg.eigvals(loops)).max() < 1


@pytest.mark.lmi
def test_export_refuses_the_paper_gain_at_a_tenth_of_a_second(tmp_path, capsys):
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.1", "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "linearized along the reference at e = 0" in err and "the largest certified Ts is" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.lmi
def test_export_takes_any_design_file(tmp_path, capsys):
    design_file = tmp_path / "d.json"
    assert main(["design", "--rho", "3", "--eta", "90", "--format", "json", "--output", str(design_file)]) == 0
    assert main(["export", "--design", str(design_file), "--ts", "0.001", "--format", "json", "--prefix", "fromfile",
                 "--output", str(tmp_path)]) == 0
    record = json.loads((tmp_path / "fromfile.json").read_text())
    expected = sr.controller_record(sr.design(sr.paper_model(), 3, 90).discretize(0.001))
    for key in ("K_I", "K_P", "K_D", "A", "B", "C", "D"):
        assert np.allclose(record[key], expected[key], rtol=1e-12, atol=0), key
    assert record["design_file"] == str(design_file) and record["certificate"]["certified"] is True
    shipped = str(sr.__file__).replace("__init__.py", PID_LMI_FILE)
    assert main(["export", "--design", shipped, "--ts", "0.0005", "--output", str(tmp_path), "--prefix", "lmi"]) == 0
    capsys.readouterr()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--rho", "3", "--eta", "90", "--design", "d.json"], "cannot go with --rho/--eta"),
        (["--rho", "3"], "give the gain: --rho and --eta"),
    ],
    ids=["design-and-rho", "rho-alone"],
)
def test_export_needs_exactly_one_gain(tmp_path, capsys, argv, message):
    assert main(["export", *argv, "--ts", "0.001", "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and list(tmp_path.iterdir()) == []


def test_export_refuses_a_design_file_for_another_plant(motor_file, tmp_path, capsys):
    design_file = tmp_path / "d.json"
    assert main(["design", "--rho", "3", "--eta", "90", "--format", "json", "--output", str(design_file)]) == 0
    out = tmp_path / "out"
    out.mkdir()
    assert main(["export", "--design", str(design_file), "--model", str(motor_file), "--ts", "1e-4",
                 "--output", str(out)]) == 2
    assert "field `K` must have shape (1, 3)" in capsys.readouterr().err and list(out.iterdir()) == []


def test_check_sample_time_on_a_double_integrator():
    """q̈ = b u, b ∈ [1, 2]: certified at 10 ms; at 0.5 s not, with the limits bracketing it."""
    import control as ct

    plant = sr.pid_augment(ct.ss([[0, 1], [0, 0]], [[0], [1.0]], [[1, 0]], 0), [("B", 1, 0, 0.0, 1.0)])
    d = sr.design(plant, 1, 2)
    if not sr.cvxpy_available():
        pytest.skip("needs the lmi extra")
    ok = sr.check_sample_time(plant, d.discretize(0.01))
    assert ok.certified and ok.limit is None and ok.record()["certified_ts"] == 0.01
    bad = sr.check_sample_time(plant, d.discretize(0.5))
    assert not bad.certified and bad.limit is not None
    assert bad.limit.certified_ts < 0.5 and bad.limit.unstable_ts <= 0.5
    assert "the largest certified Ts is" in bad.message


# ---------------------------------------------------------------- inaccurate is not infeasible


@pytest.mark.parametrize(
    "status, verified, verdict",
    [
        ("optimal", True, "certified"),
        ("optimal_inaccurate", True, "certified"),
        ("optimal", False, "inaccurate"),
        ("optimal_inaccurate", False, "inaccurate"),
        ("infeasible", False, "infeasible"),
        ("infeasible_inaccurate", False, "inaccurate"),
        ("solver error: numerical trouble", False, "unknown"),
        ("not installed", False, "unknown"),
    ],
    ids=lambda v: str(v),
)
def test_lmi_verdicts(status, verified, verdict):
    assert lmi_verdict(status, verified) == verdict


@pytest.mark.lmi
def test_lmi_margin_never_counts_a_solver_failure_as_infeasibility(motor_file, monkeypatch):
    """Solver errors after the first two solves: the bracket's lower end is still a verified
    certificate, and the upper end is reported as unknown, never as infeasible."""
    model = sr.load_model(motor_file)
    d = sr.design(model, 1, 2)
    real = margins_module.lmi_search
    calls = {"n": 0}

    def flaky_search(**kwargs):
        test = real(**kwargs)

        def flaky(loops):
            calls["n"] += 1
            if calls["n"] > 2:
                return sr.LMICertificate("solver error: Solver 'CLARABEL' failed", "CLARABEL", None, math.nan,
                                         math.nan, len(loops))
            return test(loops)

        return flaky

    monkeypatch.setattr(margins_module, "lmi_search", flaky_search)
    m = sr.robustness_margin(model, d, "lmi", tol=1e-2)
    assert "the LMI is unknown (neither certified nor proven infeasible)" in m.message
    assert "infeasibility is proven nowhere searched" in m.message
    assert sr.lmi_certificate(margins_module._closed_loops(model, d, m.theta)).certified


@pytest.mark.lmi
def test_lmi_margin_reports_proven_infeasibility(motor_file):
    model = sr.load_model(motor_file)
    d = sr.design(model, 1, 2)
    m = sr.robustness_margin(model, d, "lmi", tol=1e-2)
    lo, hi = m.bracket
    assert sr.lmi_certificate(margins_module._closed_loops(model, d, lo)).verdict == "certified"
    verdict = sr.lmi_certificate(margins_module._closed_loops(model, d, hi)).verdict
    assert verdict != "certified" and f"the LMI is {verdict}" in m.message


@pytest.mark.lmi
def test_a_decay_within_the_solvers_tolerance_of_zero_is_marginal():
    """A mode at −1e-9 1/s that no input reaches: any gain leaves it, 1e-9 of the loop's norm: marginal."""
    A = np.array([[[-1e-9, 0.0], [0.0, -1.0]]])
    B = np.array([[[0.0], [1.0]]])
    result = sr.synthesize((A, B))
    assert result.status == "marginal" and not result.certified and result.verdict == "marginal"
    assert 0 < result.verified_decay < result.decay_floor and "marginal" in result.message


@pytest.mark.lmi
def test_synthesis_margin_objective_returns_a_theta_numpy_verified():
    model = sr.PolytopicModel(np.array([[[0.0, 1.0], [-1.0, -0.5]], [[0.0, 1.0], [-2.0, -0.2]]]),
                              np.array([[[0.0], [1.0]], [[0.0], [0.6]]]))
    result = sr.synthesize(model, objective="margin", tol=1e-2)
    assert result.certified and result.theta > 0 and result.search
    A, B = vertices_of(model.scaled(result.theta))
    assert sr.decay_rate(A - B @ result.K, result.P) >= result.decay_floor


# ---------------------------------------------------------------- margins: anchor and resolution


def test_center_anchored_theorem1_and_vertex_margins_agree_with_direct_certificates():
    model = sr.paper_model().subset("A")
    d = sr.design(sr.paper_model(), 3, 90)
    for method in ("theorem1", "vertex"):
        theta = sr.robustness_margin(model, d, method, anchor="center").theta
        assert 0 < theta < math.inf
        for factor, expected in ((1 - 1e-6, True), (1 + 1e-6, False)):
            scaled = model.scaled(theta * factor, "center")
            if method == "theorem1":
                assert sr.certify(scaled, d).certified is expected
            else:
                assert sr.polytope_certificate(box_closed_loops(scaled, d.K), d.P).certified is expected


def test_scaling_anchors_agree_at_one_and_differ_elsewhere():
    model = sr.paper_model()
    assert np.array_equal(model.scaled(1.0, "lower").lower_bounds(), model.lower_bounds())
    assert np.allclose(model.scaled(1.0, "center").upper_bounds(), model.upper_bounds(), rtol=1e-15, atol=0)
    centre = model.scaled(0.0, "center")
    assert np.allclose(centre.lower_bounds(), 0.5 * (model.lower_bounds() + model.upper_bounds()))
    with pytest.raises(ValueError, match="`anchor` must be one of"):
        model.scaled(1.0, "middle")


def test_frozen_margin_about_the_centre_and_its_stated_resolution():
    """About the box's centre the first frozen instability of the published box is at θ ≈ 0.285."""
    model, d = sr.paper_model(), sr.design(sr.paper_model(), 3, 90)
    m = sr.robustness_margin(model, d, "frozen", anchor="center", tol=1e-4)
    assert m.theta == pytest.approx(0.285, abs=5e-3)
    lo, hi = m.bracket
    loops = margins_module._closed_loops
    assert np.linalg.eigvals(loops(model, d, hi, "center")).real.max() > 0
    assert np.linalg.eigvals(loops(model, d, lo, "center")).real.max() < 0
    assert "steps of x1.02" in m.message and "could be missed" in m.message


def test_margin_command_prints_the_anchor_and_the_centre_bracket(motor_file, capsys):
    argv = ["margin", "--model", str(motor_file), "--rho", "1", "--eta", "2", "--tol", "0.05", "--tries", "1"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "theta (anchor lower)" in out and "scaled about the set's centre instead (--anchor center)" in out
    assert main(["margin", "--rho", "3", "--eta", "90", "--anchor", "center", "--elements", "A"]) == 2
    assert "--anchor center" in capsys.readouterr().err


# ---------------------------------------------------------------- one decay convention


def test_every_decay_rate_is_the_states_alpha():
    """ẋ = −a x with P = I: V = |x|² decays as e^{−2at}, the state as e^{−at}: every check says α = a."""
    a = 0.7
    A = np.array([-a * np.eye(2)])
    assert sr.decay_rate(A, np.eye(2)) == pytest.approx(a, rel=1e-12)
    assert sr.verify_lyapunov(A, np.eye(2))[1] == pytest.approx(a, rel=1e-12)
    # sampled: x_k+1 = e^{−a Ts} x_k; V shrinks by e^{−2a Ts} ≈ 1 − 2αTs with α → a as Ts → 0
    Ts = 1e-4
    Ad = np.array([np.exp(-a * Ts) * np.eye(2)])
    assert sr.discrete_lyapunov_check(Ad, np.eye(2), Ts)[1] == pytest.approx(a, rel=1e-3)


def test_certificate_table_names_its_columns_by_what_they_are():
    plant = sr.scara_uncertain_plant(bounds="paper")
    table = sr.certificate_table(plant, sr.design(plant, 3, 90), points={"t_ref": 9, "m_p": 3},
                                 lmi_points={"t_ref": 5, "m_p": 2}, falsifier_tries=1)
    assert {"max_eig", "decay_rate [1/s]", "growth_rate [1/s]"} <= set(table.columns)
    assert "margin" not in table.columns
    by = table.set_index("method")
    assert by.loc["theorem1-all", "max_eig"] == pytest.approx(713.90, abs=0.01)
    assert math.isnan(by.loc["theorem1-all", "decay_rate [1/s]"])


@pytest.mark.lmi
def test_motor_sample_time_limits_agree_with_an_independent_derivation(motor_file):
    """An independent ZOH computation (own code, the same discrete PID equations) puts the first
    frozen instability of the motor at Ts = 2.000267e-4 s: the k_t/J = 5000 corner, a real
    eigenvalue through z = −1 (K_D·(k_t/J)·Ts ≈ 2); spectral radius 8.998 at Ts = 1 ms."""
    model = sr.load_model(motor_file)
    d = sr.design(model, 1, 2)
    limit = sr.max_sample_time(model, d, check=interior_grid(model), rtol=1e-4)
    lo, hi = limit.unstable_bracket
    assert lo <= 2.000267e-4 <= hi and hi - lo <= 1e-4 * hi
    assert limit.certified_ts <= lo
    loops = sr.sampled_closed_loops(*vertices_of(model), d.discretize(1e-3))
    assert np.abs(np.linalg.eigvals(loops)).max() == pytest.approx(8.9976, abs=1e-3)


@pytest.mark.lmi
def test_synthesis_margin_counts_only_verified_steps(monkeypatch):
    """A solver that answers "optimal" with a gain numpy rejects never raises θ: the θ returned
    is re-verified here with numpy, and the search names the inaccurate step."""
    from scara_robust.robustness import synthesis as synthesis_module

    model = sr.PolytopicModel(np.array([[[0.0, 1.0], [-1.0, -0.5]], [[0.0, 1.0], [-2.0, -0.2]]]),
                              np.array([[[0.0], [1.0]], [[0.0], [0.6]]]))
    real = synthesis_module._solve
    calls = {"n": 0}

    def lying(A, B, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] >= 3:  # "optimal", but Y = 0 leaves the open loop, which numpy rejects
            return "optimal", np.eye(2), np.zeros((1, 2)), math.nan
        return real(A, B, *args, **kwargs)

    monkeypatch.setattr(synthesis_module, "_solve", lying)
    result = sr.synthesize(model, objective="margin", tol=1e-2)
    assert result.certified and "inaccurate" in result.search
    A, B = vertices_of(model.scaled(result.theta))
    assert sr.decay_rate(A - B @ result.K, result.P) >= result.decay_floor > 0
