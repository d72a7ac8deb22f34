"""Physical bounds of parameters, and one number per question across the commands.

A parameter's physical interval stops every scaled range (a mass is never negative); the
frozen bound names the end that fails. A design's decay rate and its sample-time bracket
are the same number whichever command (certify, compare, export, the design page) asks.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import build_parser, main
from scara_robust.cli._app import explorer_of

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
MOTOR = str(EXAMPLES / "plant-dc-motor.toml")
ARM = str(EXAMPLES / "plant-arm-payload.toml")
ZOH = str(EXAMPLES / "plant-zoh-benchmark.toml")
ZOH_GAIN = str(EXAMPLES / "gain-zoh.json")


# ---------------------------------------------------------------- physical bounds


@pytest.mark.parametrize("unit, positive", [("kg", True), ("kg·m²", True), ("kg*m^2", True), ("kg m**2", True),
                                            ("m", True), ("N·m/A", False), ("1", False), ("s", False)])
def test_a_mass_a_length_and_an_inertia_are_positive_by_their_unit(unit, positive):
    p = sr.Parameter("p", unit, (1.0, 2.0))
    assert p.limits == ((0.0, math.inf) if positive else (-math.inf, math.inf))


def test_a_range_outside_the_physical_interval_is_refused_naming_it():
    with pytest.raises(sr.ArgumentValueError, match=r"`m.range` must lie in the physical limits \[0, inf\] kg"):
        sr.Parameter("m", "kg", (-1.0, 2.0))
    assert sr.Parameter("x", "kg", (-1.0, 2.0), limits=(-math.inf, math.inf)).varies  # the file says otherwise
    with pytest.raises(sr.ArgumentValueError, match="`k.limits` must have lower < upper"):
        sr.Parameter("k", "N/m", (1.0, 2.0), limits=(3.0, 1.0))


def test_the_scaled_range_stops_at_the_physical_limit():
    m = sr.Parameter("m", "kg", (0.0, 2.0), nominal=1.0)
    assert m.scaled_range(3.0) == (0.0, 4.0) and m.at_limit(3.0) == "lower" and m.at_limit(0.5) == ""


@pytest.mark.parametrize("physical, expected", [("[0, inf]", (0.0, math.inf)), ('["-inf", 5]', (-math.inf, 5.0))])
def test_a_plant_file_states_the_physical_interval(tmp_path, physical, expected):
    text = Path(ARM).read_text(encoding="utf-8").replace("physical = [0, inf]", f"physical = {physical}")
    path = tmp_path / "arm.toml"
    path.write_text(text, encoding="utf-8")
    assert sr.load_plant(path).parameter("m").limits == expected


@pytest.mark.parametrize("physical, message", [
    ("[1, inf]", "field `parameters.m.range` must lie in the physical limits [1, inf] kg, found [0, 2]"),
    ('[0, "x"]', "field `parameters.m.physical[1]` must be a finite number in kg"),
    ("0", "field `parameters.m.physical` must be [lower, upper] in kg"),
])
def test_a_bad_physical_interval_is_one_line_naming_the_field(tmp_path, capsys, physical, message):
    text = Path(ARM).read_text(encoding="utf-8").replace("physical = [0, inf]", f"physical = {physical}")
    path = tmp_path / "arm.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["certify", "--model", str(path), "--rho", "1", "--eta", "2"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err


def test_the_arm_margin_never_reaches_a_negative_mass():
    """Scaled about its nominal 1 kg the payload range would reach m = −0.45 kg, where J = 0; it stops at 0."""
    arm = sr.load_plant(ARM)
    for rho, eta in ((1.0, 2.0), (1.0, 10.0)):
        table = sr.parameter_margin(arm, sr.design(arm, rho, eta), ["physical", "frozen"])
        assert (table["m low [kg]"].dropna() >= 0).all()
        frozen = table.set_index("method").loc["frozen"]
        # every frozen plant with m in [0, 1e6] kg is stable: no limit, and the message says where it stopped
        assert frozen["end"] == "" and math.isinf(frozen["scale"])
        assert "m stops at its physical limit 0 kg" in frozen["message"]
        m = np.linspace(0.0, 100.0, 201)  # the frozen loops from no payload to 100 kg, checked directly
        A, B = arm.plant_matrices(np.column_stack([m if n == "m" else np.full_like(m, arm.nominal[n])
                                                   for n in arm.names]))
        Aa, Ba = arm.design_form(A, B)
        assert np.linalg.eigvals(Aa - Ba @ sr.design(arm, rho, eta).K).real.max() < 0


def test_margin_and_compare_on_the_arm_print_no_negative_mass(capsys):
    assert main(["margin", "--model", ARM, "--rho", "1", "--eta", "2", "--format", "json"]) == 0
    out = capsys.readouterr().out
    rows = json.loads(out)
    parameter_rows = [r for r in (rows if isinstance(rows, list) else rows.get("parameters", []))
                      if "m low [kg]" in r]
    assert parameter_rows and all(r["m low [kg]"] is None or r["m low [kg]"] >= 0 for r in parameter_rows)
    assert main(["compare", "--model", ARM, "--rho", "1", "--eta", "2", "--no-synthesis", "--t-final", "7"]) == 0
    out = capsys.readouterr().out
    line = next(s for s in out.splitlines() if s.startswith("m frozen end"))
    assert line.split()[-1] == "none"
    assert "-0.45" not in out


@pytest.mark.lmi
def test_a_lower_bound_that_fails_at_the_nominal_point_certifies_no_range(capsys):
    """At (1, 2) the arm's Theorem 1 fails even at the nominal payload: its row has no range (not [1, 1] kg),
    and compare's certified high is NaN, while the LMI's row certifies a range."""
    arm = sr.load_plant(ARM)
    table = sr.parameter_margin(arm, sr.design(arm, 1, 2), ["theorem1", "lmi-physical"]).set_index("method")
    assert table.loc["theorem1", ["scale", "m low [kg]", "m high [kg]"]].isna().all()
    assert "no range certified" in table.loc["theorem1", "message"]
    assert "not even at the nominal point" in table.loc["theorem1", "message"]
    assert table.loc["lmi-physical", "scale"] > 1 and table.loc["lmi-physical", "m high [kg]"] > 2.0
    assert main(["compare", "--model", ARM, "--rho", "1", "--eta", "2", "--no-synthesis", "--t-final", "7",
                 "--format", "json"]) == 0
    compared = json.loads(capsys.readouterr().out)
    records = compared if isinstance(compared, list) else compared["designs"]
    assert math.isnan(records[0]["m certified high [kg]"]) or records[0]["m certified high [kg]"] is None


def test_the_motor_frozen_bound_names_the_upper_end_and_its_routh_hurwitz_value():
    motor = sr.load_plant(MOTOR)
    d = sr.design(motor, 1, 10)
    frozen = sr.parameter_margin(motor, d, ["frozen"]).iloc[0]
    K_I, K_P, K_D = (-float(d.K[0, k]) for k in range(3))
    b, kt = motor.nominal["b"], motor.nominal["kt"]
    routh = (b + kt * K_D) * K_P / K_I  # J s³ + (b + kt K_D) s² + kt K_P s + kt K_I: stable iff J below this
    assert frozen["end"] == "J upper"
    assert frozen["J high [kg·m²]"] == pytest.approx(routh, rel=1e-6)
    assert f"the upper end: a frozen plant is unstable above J = {frozen['J high [kg·m²]']:.6g} kg·m²" \
        in frozen["message"]


def test_frozen_limit_reads_each_parameter_s_own_end():
    """Ends are matched by name, so a parameter `p` is not taken for the `m_p` beside it."""
    import pandas as pd

    table = pd.DataFrame([{"method": "frozen", "end": "m_p upper, p lower", "m_p low [kg]": 0.0,
                           "m_p high [kg]": 7.5, "p low [1]": 0.25, "p high [1]": 2.0}])
    assert sr.frozen_limit(table, sr.Parameter("m_p", "kg", (0.0, 1.0))) == (7.5, "upper")
    assert sr.frozen_limit(table, sr.Parameter("p", "1", (0.5, 1.0))) == (0.25, "lower")
    value, end = sr.frozen_limit(table.assign(end="interior"), sr.Parameter("p", "1", (0.5, 1.0)))
    assert end == "none" and math.isnan(value)
    motor = sr.load_plant(MOTOR)
    margins = sr.parameter_margin(motor, sr.design(motor, 1, 10), ["frozen"])
    assert sr.frozen_limit(margins, motor.parameter("J")) == (float(margins["J high [kg·m²]"].iloc[0]), "upper")


def test_a_frozen_bound_at_the_lower_end_is_named_as_such():
    """An input gain a ∈ [0.5, 1] scaled down about 1 crosses 0, where the loop's sign flips."""
    a = sr.Parameter("a", "1", (0.5, 1.0), nominal=1.0)
    plant = sr.UncertainPlant.from_expressions([a], [[0, 1], [0, -1]], [[0], ["a"]], form="pid")
    d = sr.design(plant, 1, 2)
    frozen = sr.parameter_margin(plant, d, ["frozen"]).iloc[0]
    assert frozen["end"] == "a lower"
    low = float(frozen["a low [1]"])
    assert "the lower end: a frozen plant is unstable below a = " in frozen["message"]
    # the closed loop at a just above the reported end is stable, at the end it is not
    for value, stable in ((low + 1e-3, True), (low, False)):
        A, B = plant.plant_matrices(np.array([[value]]))
        Aa, Ba = plant.design_form(A, B)
        assert (np.linalg.eigvals(Aa - Ba @ d.K).real.max() < 0) == stable


def test_the_scara_payload_bound_names_its_upper_end():
    d = sr.design(sr.paper_model(), 3, 90)
    table = sr.payload_margin(d, methods=["payload-frozen"], n_times=19, n_masses=3, tol=1e-2)
    row = table.iloc[0]
    assert f"the upper end: a frozen sample is unstable above a peak payload of {row['mass [kg]']:.6g} kg" \
        in row["message"]


# ---------------------------------------------------------------- one decay rate, one bracket


def _certify_json(capsys, argv):
    assert main(["certify", *argv, "--format", "json", "--tries", "2"]) == 0
    return {r["method"]: r for r in json.loads(capsys.readouterr().out)}


@pytest.mark.lmi
def test_certify_compare_export_and_the_page_report_one_decay_rate(capsys, tmp_path):
    setup = ["--model", MOTOR, "--rho", "1", "--eta", "10"]
    rows = _certify_json(capsys, setup)
    certified = rows["decay-rate"]["decay_rate [1/s]"]
    # the number itself: the exact rate of the P it comes from (the generalized eigenvalue), checked here,
    # and never below the design's own P's
    motor = sr.load_plant(MOTOR)
    d = sr.design(motor, 1, 10)
    loops = motor.interval_model().vertex_closed_loops(d.K)

    def exact(P):
        Li = np.linalg.inv(np.linalg.cholesky(P))
        return min(-np.linalg.eigvalsh(Li @ (A.T @ P + P @ A) @ Li.T).max() / 2 for A in loops)

    found = sr.design_decay_rate(motor, d)
    assert rows["decay-rate"]["from"] == found.source
    assert certified > 0 and certified == pytest.approx(exact(found.P), rel=1e-9)
    assert certified >= exact(d.P) * (1 - 1e-12)

    assert main(["compare", *setup, "--no-synthesis", "--t-final", "7", "--format", "json"]) == 0
    compared = json.loads(capsys.readouterr().out)
    records = compared if isinstance(compared, list) else compared["designs"]
    assert records[0]["decay rate [1/s]"] == pytest.approx(certified, rel=1e-12)
    # deployability beside it: the same input-limit certificate certify reports, and the run against the limit
    assert records[0]["unit step certified within limits s*"] == pytest.approx(rows["input-limits"]["scale"],
                                                                               rel=1e-12)
    assert records[0]["run within input limits"] is (records[0]["peak |u| [A]"] <= 2.0) is False

    out = tmp_path / "out"
    out.mkdir()
    assert main(["export", *setup, "--ts", "5e-4", "--format", "json", "--output", str(out)]) == 0
    capsys.readouterr()
    meta = json.loads(next(out.iterdir()).read_text(encoding="utf-8"))
    found = meta["metadata"]["decay_rate"] if "metadata" in meta else meta["decay_rate"]
    assert found["rate [1/s]"] == pytest.approx(certified, rel=1e-12)

    explorer = explorer_of(build_parser().parse_args(["app", *setup[:2], "--rho", "1:1:1", "--eta", "10:10:1"]))
    function, arguments = explorer.slow_answers(d)["decay"]
    assert function(*arguments).rate == pytest.approx(certified, rel=1e-12)


@pytest.mark.lmi
@pytest.mark.parametrize("model", [MOTOR, ARM, ZOH])
def test_the_lmi_row_gives_its_p_s_exact_rate_and_the_decay_line_is_never_below_it(capsys, model):
    """certify's ``lmi-box`` row reports the exact rate of its P (a generalized eigenvalue), not a cruder
    bound of it, and the decay line, whose P starts from the row's, is never below it."""
    setup = ["--model", model] + (["--design", ZOH_GAIN] if model == ZOH else ["--rho", "1", "--eta", "10"])
    rows = _certify_json(capsys, setup)
    line = rows["decay-rate"]
    assert line["set"].startswith("the interval box")  # the same loops as the lmi-box row
    # the row's P is the LMI's certificate; the line's is refined from it towards the decay-optimal P,
    # so the line is never below the row and names the row's P's rate where the search improved on it
    assert line["decay_rate [1/s]"] >= rows["lmi-box"]["decay_rate [1/s]"] * (1 - 1e-12)
    if line["from"] != "a common P by LMI":
        said = line["detail"].split("a common P by LMI: ")[1].split(" 1/s")[0]
        assert float(said) >= float(f"{rows['lmi-box']['decay_rate [1/s]']:.4g}")
    plant = sr.load_plant(model)
    K = sr.load_design(ZOH_GAIN).K if model == ZOH else sr.design(plant, 1, 10).K
    loops = plant.interval_model().vertex_closed_loops(K)
    found = sr.lmi_certificate(loops)
    Li = np.linalg.inv(np.linalg.cholesky(found.P))
    exact = min(-np.linalg.eigvalsh(Li @ (A.T @ found.P + found.P @ A) @ Li.T).max() / 2 for A in loops)
    assert found.decay_rate == pytest.approx(exact, rel=1e-9)
    assert rows["lmi-box"]["decay_rate [1/s]"] == pytest.approx(exact, rel=1e-9)


def test_certify_export_and_the_page_bracket_the_sample_time_alike(capsys, tmp_path):
    """The own-gain guide's ZOH benchmark: certify --max-ts and export beyond the limit give one bracket."""
    rows = _certify_json(capsys, ["--model", ZOH, "--design", ZOH_GAIN, "--max-ts"])
    bracket = rows["max-ts"]
    certified, unstable = bracket["certified_ts [s]"], bracket["unstable_ts [s]"]
    assert 0 < certified <= unstable
    out = tmp_path / "out"
    out.mkdir()
    assert main(["export", "--model", ZOH, "--design", ZOH_GAIN, "--ts", "1.8", "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"the largest certified Ts is {certified:.4g} s" in err
    assert f"a frozen plant is unstable from Ts = {unstable:.4g} s" in err
    assert list(out.iterdir()) == []


def test_a_comparison_succeeds_only_when_it_tracks():
    table = sr.compare_controllers(["pid"], ["large"], t_final=2.0)
    for row in table.itertuples():
        assert row.success == (row.status == "tracking")


# ---------------------------------------------------------------- input limits through the commands


def test_certify_reports_the_initial_errors_certified_within_the_current_limit(capsys):
    rows = _certify_json(capsys, ["--model", MOTOR, "--rho", "1", "--eta", "10", "--initial-error", "0,0.005,0"])
    within = rows["input-limits"]
    motor = sr.load_plant(MOTOR)
    d = sr.design(motor, 1, 10)
    # s* from the closed form with each P the decay rate verified, recomputed here: the largest answers
    decay = sr.design_decay_rate(motor, d)
    K = d.K
    v = np.array([0.0, 0.005, 0.0])

    def scale(P):
        return math.sqrt(2.0 ** 2 / float(K[0] @ np.linalg.solve(P, K[0])) / float(v @ P @ v))

    assert decay.P is decay.candidates[0] and len(decay.candidates) >= 1
    assert within["scale"] == pytest.approx(max(scale(P) for P in decay.candidates), rel=1e-9)
    assert within["scale"] >= scale(decay.P) * (1 - 1e-12)
    assert within["certified"] is True and "certified within the limits for these initial errors" in within["detail"]
    # the default: a unit step of the reference, which this gain cannot take within 2 A
    rows = _certify_json(capsys, ["--model", MOTOR, "--rho", "1", "--eta", "10"])
    assert rows["input-limits"]["certified"] is False and rows["input-limits"]["scale"] < 1


@pytest.mark.lmi
def test_synthesize_within_the_limits_writes_a_gain_certified_within_them(capsys, tmp_path):
    out = tmp_path / "limited.json"
    assert main(["synthesize", "--model", MOTOR, "--objective", "decay", "--within-limits", "--initial-error",
                 "0,0.1,0", "--output", str(out)]) == 0
    capsys.readouterr()
    loaded = sr.load_design(out)
    motor = sr.load_plant(MOTOR)
    loops = motor.interval_model().vertex_closed_loops(loaded.K)
    cert = sr.input_limit_certificate(loaded.K, loaded.P, motor.input_limits, [0.0, 0.1, 0.0], closed_loops=loops)
    assert cert.certified and cert.scale >= 1 and cert.lyapunov_checked


@pytest.mark.parametrize("argv, text", [
    (["synthesize", "--model", MOTOR, "--initial-error", "0,1,0"], "`--initial-error` goes with --within-limits"),
    (["certify", "--model", MOTOR, "--rho", "1", "--eta", "2", "--initial-error", "1,2"],
     "`--initial-error` must give 3"),
    (["certify", "--model", ZOH, "--design", ZOH_GAIN, "--initial-error", "1"], "this plant has none"),
])
def test_bad_initial_errors_are_one_line(capsys, argv, text):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and text in err


@pytest.mark.lmi
def test_the_readme_design_reports_one_decay_rate_in_certify_export_and_the_page(capsys, tmp_path):
    """The README's SCARA design (ρ, η) = (3, 90): certify, export and the page's answer agree."""
    rows = _certify_json(capsys, ["--rho", "3", "--eta", "90"])
    record = rows["decay-rate"]
    out = tmp_path / "out"
    out.mkdir()
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--format", "json",
                 "--output", str(out)]) == 0
    capsys.readouterr()
    meta = json.loads(next(out.iterdir()).read_text(encoding="utf-8"))
    exported = (meta["metadata"] if "metadata" in meta else meta)["decay_rate"]
    explorer = explorer_of(build_parser().parse_args(["app", "--rho", "3:3:1", "--eta", "90:90:1"]))
    d = sr.design(explorer.model, 3, 90)
    function, arguments = explorer.slow_answers(d)["decay"]
    page = function(*arguments)
    explorer.close()
    assert exported["from"] == record["from"] == page.source and exported["set"] == record["set"] == page.set_name
    # the paper's box certifies no rate for this design (its LMI is infeasible): the robot's own frozen plants do
    assert "frozen plants" in page.set_name and page.certified
    assert exported["rate [1/s]"] == pytest.approx(record["decay_rate [1/s]"], rel=1e-12)
    assert page.rate == pytest.approx(record["decay_rate [1/s]"], rel=1e-12)
    # the number, re-verified with numpy on the robot's samples it names (both grids)
    plant = sr.scara_uncertain_plant(bounds="paper")
    rates = [sr.decay_rate(plant.samples(points).closed_loops(d.K), page.P)
             for points in (plant.grid_points(), plant.fine_points())]
    assert min(rates) >= page.rate * (1 - 1e-9) and min(rates) > 0


@pytest.mark.lmi
@pytest.mark.parametrize("setup, app_setup, rho, eta", [
    (["--model", MOTOR, "--rho", "1", "--eta", "10"], ["--model", MOTOR], 1.0, 10.0),  # the own-plant guide
    (["--rho", "3", "--eta", "90"], [], 3.0, 90.0),  # the README
], ids=["guide-motor", "readme-scara"])
def test_certify_export_and_the_page_bracket_the_sample_time_as_one(capsys, tmp_path, setup, app_setup, rho, eta):
    bracket = _certify_json(capsys, [*setup, "--max-ts"])["max-ts"]
    certified, unstable = bracket["certified_ts [s]"], bracket["unstable_ts [s]"]
    explorer = explorer_of(build_parser().parse_args(["app", *app_setup, "--rho", f"{rho}:{rho}:1",
                                                      "--eta", f"{eta}:{eta}:1"]))
    function, arguments = explorer.slow_answers(sr.design(explorer.model, rho, eta))["sample_time"]
    limit = function(*arguments)
    explorer.close()
    assert limit.certified_ts == certified and limit.unstable_ts == unstable
    if "--model" in setup:  # compare, on a plant file, sets its designs side by side with the same bracket
        assert main(["compare", *setup, "--no-synthesis", "--t-final", "7", "--format", "json"]) == 0
        record = json.loads(capsys.readouterr().out)[0]
        assert record["certified Ts [s]"] == certified and record["unstable Ts [s]"] == unstable
    # export at a Ts beyond the frozen instability refuses it, naming the same two limits
    out = tmp_path / "out"
    out.mkdir()
    assert main(["export", *setup, "--ts", repr(1.5 * unstable), "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"the largest certified Ts is {certified:.4g} s" in err
    assert f"a frozen plant is unstable from Ts = {unstable:.4g} s" in err
