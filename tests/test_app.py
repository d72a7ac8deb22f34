"""The design page (``python -m scara_robust app``): what it computes, and the page in a real browser.

The browser test starts the page on a free local port for the DC motor of examples/plant-dc-motor.toml,
opens it in headless Debian Chromium (Playwright through ``executable_path``), clicks an
uncertified and then a certified point of the map, and checks what the page shows against the
library: K against ``sr.design``, the verdicts against ``sr.certificate_table``, the downloaded
C file against ``export``'s. Bad input typed into the page gets a message and the page keeps
serving. Screenshots and the click-to-answer times go to docs/_build/screenshots/.
"""

from __future__ import annotations

import json
import re
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from page_driver import click_grid_point, design_label, open_page, painted_after_release, response_label, watch

import scara_robust as sr
from scara_robust.app import MEASURES, PAYLOAD_MAP_TOL, Answer, RunSettings, envelope
from scara_robust.cli import build_parser, main
from scara_robust.cli._app import explorer_of

#: Needs the `app` extra (Bokeh): skipped without it, failed under SCARA_ROBUST_REQUIRE_EXTRAS=1.
pytestmark = pytest.mark.app

ROOT = Path(__file__).resolve().parents[1]
ROBOT = str(ROOT / "examples" / "robot-paper.toml")
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")
SCREENSHOTS = ROOT / "docs" / "_build" / "screenshots"
#: The browser test's map: cells of about 14 x 40 pixels, so a click at a grid point's centre is well inside its
#: cell and inside the plotting frame (the default 1:200:200 grid puts the η = 1 row 1 pixel above the frame's edge).
#: (1, 5) and (1, 1) are grid points.
GRID = ["--rho", "0.1:10:34", "--eta", "1:10:10"]


@pytest.fixture(scope="module")
def motor():
    explorer = explorer_of(build_parser().parse_args(["app", "--model", MOTOR, "--rho", "0.5:5:10",
                                                      "--eta", "1:50:10"]))
    yield explorer
    explorer.close()


def test_a_selection_shows_the_library_s_gain_and_theorem1_verdict(motor):
    answer = motor.quick(1.0, 2.0)
    d = sr.design(motor.model, 1.0, 2.0)
    assert np.array_equal(answer.design.K, d.K)
    cert = sr.certify(motor.model, d, "all")
    assert answer.max_eig == cert.max_eig and answer.certified == cert.certified
    surface = sr.design_surface(motor.model, motor.rhos, motor.etas, measure="margin")
    assert np.array_equal(motor.measure("max_eig"), surface.max_eig)
    assert np.array_equal(motor.measure("margin"), surface.margin)


def test_the_deployable_map_is_each_design_s_input_limit_certificate(motor):
    """log₁₀ s* of every certified grid design, each computed here with its own P and K; grey where not certified."""
    values = motor.measure("deployable")
    plant = sr.load_plant(MOTOR)
    assert motor.has_input_limits and values.shape == (motor.rhos.size, motor.etas.size)
    certified = sr.design_surface(motor.model, motor.rhos, motor.etas).certified
    assert np.array_equal(np.isnan(values), ~certified) and certified.any()
    for i, k in zip(*np.nonzero(certified)):
        d = sr.design(motor.model, float(motor.rhos[i]), float(motor.etas[k]))
        cert = sr.input_limit_certificate(d.K, d.P, plant.input_limits, [0.0, 1.0, 0.0])
        assert values[i, k] == pytest.approx(np.log10(cert.scale), rel=1e-9, abs=1e-12)
        assert (values[i, k] >= 0) == cert.certified


def test_a_new_selection_drops_the_pending_answers_of_the_previous(motor, monkeypatch):
    """A second selection cancels what the first has not started and drops what it was computing."""

    delivered: list[tuple[int, str]] = []
    monkeypatch.setattr(motor, "slow_answers", lambda d: {"margins": (time.sleep, (1.5,)),
                                                          "certificates": (abs, (-1.0,))})
    old = motor.submit(sr.design(motor.model, 1.0, 2.0), lambda a: delivered.append((a.generation, a.kind)))
    first = list(motor._pending)
    deadline = time.monotonic() + 60
    while not first[0].running() and time.monotonic() < deadline:  # the worker process starts, then runs it
        time.sleep(0.05)
    assert first[0].running()
    monkeypatch.setattr(motor, "slow_answers", lambda d: {"margins": (abs, (-2.0,))})
    done = threading.Event()
    new = motor.submit(sr.design(motor.model, 2.0, 3.0),
                       lambda a: (delivered.append((a.generation, a.kind, a.value)), done.set()))
    assert done.wait(60)
    for future in first:  # cancelled before it ran, or ran to its end: either way its answer is dropped
        assert future.cancelled() or future.result(60)[1] == ""
    assert new == old + 1 and delivered == [(new, "margins", 2.0)]


def test_the_scara_page_runs_the_compiled_engine():
    """The SCARA's response is run_scenario's 20-s run on the compiled engine, with its units."""
    explorer = explorer_of(build_parser().parse_args(["app", "--robot", ROBOT, "--rho", "1:5:5", "--eta", "10:90:5",
                                                      "--elements", "A"]))
    try:
        answer = explorer.quick(3.0, 90.0)
        assert answer.certified and answer.max_eig == sr.certify(explorer.model, answer.design, "A").max_eig
        resp = explorer.response(answer.design)
        ref = sr.run_scenario("pid", "large", K=answer.design.K, t_final=20.0, method="compiled")
        assert np.array_equal(resp.errors, ref.e) and resp.status == ref.status == "tracking"
        # the page's scenario choices: small initial error, no payload, a torque limit
        explorer.settings = RunSettings("small", False, (30.0, 10.0))
        resp = explorer.response(answer.design)
        ref = sr.run_scenario("pid", "small", payload_on=False, torque_limit=[30.0, 10.0], K=answer.design.K,
                              t_final=20.0, method="compiled")
        assert np.array_equal(resp.errors, ref.e) and np.array_equal(resp.inputs, ref.torque)
        assert np.abs(resp.inputs[1]).max() == 10.0  # the limit is reached
        error_labels, _, _, input_unit = explorer.signals
        assert error_labels == ("e₁ [rad]", "e₂ [rad]") and input_unit == "N·m"
    finally:
        explorer.close()


def test_a_new_run_replaces_the_response_only_and_figures_are_drawn(motor):
    """``rerun`` delivers the last run's response of the current selection; ``figures`` draws PNG files."""
    delivered: list[Answer] = []
    done = threading.Event()
    d = sr.design(motor.model, 1.0, 5.0)
    generation = motor.submit(d, lambda a: delivered.append(a) if a.kind == "response" else None)
    motor.rerun(d, RunSettings(), delivered.append)
    motor.rerun(d, RunSettings(), lambda a: (delivered.append(a), done.set()))
    assert done.wait(120)
    deadline = time.monotonic() + 60
    while len(delivered) < 2 and time.monotonic() < deadline:  # the first submit's response, in queue order
        time.sleep(0.05)
    assert [a.generation for a in delivered] == [generation, generation] and not any(a.error for a in delivered)
    assert np.array_equal(delivered[-1].value.errors, motor.response(d).errors)
    files, error, _ = motor.figures(d, "margin", (1.0, 5.0)).result(120)
    assert error == "" and set(files) == {"design-map.png", "response.png", "loops.png"}  # each loop, worst plant
    assert all(data.startswith(b"\x89PNG") and len(data) > 10_000 for data in files.values())


def test_the_payload_map_is_payload_margin_s_on_a_coarse_grid():
    """The SCARA's payload map: each point is payload_margin's design-P mass of the design there."""
    explorer = explorer_of(build_parser().parse_args(["app", "--robot", ROBOT, "--rho", "1:5:5", "--eta", "10:90:5",
                                                      "--elements", "A"]))
    try:
        done = threading.Event()
        columns: list[int] = []
        values = explorer.start_payload_map(lambda i, masses: (columns.append(i), len(columns) == 2 and done.set()),
                                            n=2)
        assert np.isnan(values).all() or not done.is_set()
        assert done.wait(120) and sorted(columns) == [0, 1] and np.isfinite(values).all()
        rhos, etas = explorer.payload_grid(2)
        assert np.array_equal(rhos, [1.0, 5.0]) and np.array_equal(etas, [10.0, 90.0])
        d = sr.design(explorer.model, 5.0, 90.0)
        signals = explorer.robot_signals
        table = sr.payload_margin(d, signals["params"], signals["reference"], tol=PAYLOAD_MAP_TOL,
                                  methods=("payload-design-P",))
        assert values[1, 1] == float(table["mass [kg]"].iloc[0]) > 0
        assert explorer.payload_level == pytest.approx(2 * 0.3 * signals["params"].m2)  # the paper's profile's peak
        explorer.compute_map(np.linspace(1, 5, 3), np.linspace(10, 90, 3))  # a new grid drops the payload map
        assert explorer.payload_values is None
    finally:
        explorer.close()


def test_the_envelope_keeps_every_peak():
    t = np.linspace(0.0, 20.0, 20_001)
    y = np.sin(37 * t) * np.exp(-0.1 * t) + (t > 13.3) * 0.5
    y[12_345] = 3.0  # a one-sample spike
    te, ye = envelope(t, y, buckets=400)
    assert te.size == ye.size == 800 and np.all(np.diff(te) >= 0)
    assert ye.max() == y.max() == 3.0 and ye.min() == y.min()
    edges = np.linspace(0, t.size, 401).astype(int)  # every bucket's extremes are in it
    for b in (0, 7, 200, 399):
        part = y[edges[b]:edges[b + 1]] if b < 399 else y[edges[b]:]
        assert part.max() in ye and part.min() in ye
    assert envelope(t[:500], y[:500])[0] is t[:500] or np.array_equal(envelope(t[:500], y[:500])[1], y[:500])


def test_the_page_s_design_file_is_design_s(motor, capsys):
    text = motor.design_file(1.0, 5.0)
    assert main(["design", "--model", MOTOR, "--rho", "1.0", "--eta", "5.0", "--format", "json"]) == 0
    assert text == capsys.readouterr().out
    loaded = json.loads(text)
    assert np.array_equal(np.array(loaded["K"]), sr.design(motor.model, 1.0, 5.0).K) and loaded["certified"]


def test_the_page_s_export_is_export_s(motor, tmp_path):
    files = motor.export(1.0, 2.0, 1e-3, [2.0])  # the motor's input: a current, A
    assert main(["export", "--model", MOTOR, "--rho", "1.0", "--eta", "2.0", "--ts", "0.001", "--torque-limit",
                 "2.0", "--output", str(tmp_path)]) == 0
    assert files == {p.name: p.read_text(encoding="utf-8") for p in sorted(tmp_path.iterdir())}
    with pytest.raises(ValueError, match="not certified"):
        motor.export(1.0, 2.0, 0.5, None)
    with pytest.raises(ValueError, match="input limit must be > 0 A, found 0"):
        motor.export(1.0, 2.0, 1e-3, [0.0])


def test_bad_selections_and_grids_are_refused_with_the_argument(motor):
    with pytest.raises(sr.ArgumentValueError, match="`rho`"):
        motor.quick(-1.0, 2.0)
    with pytest.raises(sr.ArgumentValueError, match="`eta`"):
        motor.quick(1.0, 0.5)
    with pytest.raises(sr.ArgumentValueError, match="at most 1,000,000 points"):
        motor.compute_map(np.linspace(0.1, 10, 2000), np.linspace(1, 200, 1000))
    assert motor.rhos.size == 10  # the map is unchanged


@pytest.mark.parametrize(("argv", "text"), [
    (["app", "--port", "0"], "`--port` must be a TCP port in 1..65535"),
    (["app", "--model", str(ROOT / "examples" / "plant-polytope.toml")], "is a polytope"),
    (["app", "--rho", "0.1:10:1250", "--eta", "1:200:1000"], "a grid of 1,250,000 points"),
], ids=["port", "polytope", "huge-grid"])
def test_the_command_refuses_bad_input_in_one_line(capsys, argv, text):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and text in err, err


def test_the_command_says_when_its_port_is_taken(capsys):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["app", "--model", MOTOR, "--rho", "0.5:5:3", "--eta", "1:5:3", "--port", str(port)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"`--port` {port}: is in use" in err


# -- the page in Chromium ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def page_of_motor(tmp_path_factory):
    """``python -m scara_robust app --model examples/plant-dc-motor.toml`` on a free port, opened in Chromium."""
    argv = ["--model", MOTOR, *GRID]
    explorer = explorer_of(build_parser().parse_args(["app", *argv]))  # the same grid and model, to check against
    with open_page(argv, tmp_path_factory.mktemp("app") / "stderr.txt") as (page, problems):
        yield page, explorer, problems
    explorer.close()


def _numbers(text: str) -> list[float]:
    return [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


def test_the_page_in_chromium(page_of_motor, tmp_path):
    page, explorer, problems = page_of_motor
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    values = explorer.measure("max_eig")
    certified = explorer.nearest(1.0, 5.0)  # certified, and its sampled loop at Ts = 1 ms too
    assert values[certified] < 0
    uncertified = explorer.nearest(1.0, 1.0)  # the motor's loop is certified from η of about 2.5 on
    assert values[uncertified] > 0
    times = {}
    for name, (i, k) in (("uncertified", uncertified), ("certified", certified)):
        rho, eta = float(explorer.rhos[i]), float(explorer.etas[k])
        watch(page, "design", design_label(rho, eta))
        watch(page, "response", response_label(rho, eta))
        click_grid_point(page, explorer.rhos, explorer.etas, int(i), int(k))
        times[f"{name}: click to K and Theorem 1 [ms]"] = painted_after_release(page, design_label(rho, eta), 10_000)
        verdict = page.locator("#thm1-verdict")
        d = sr.design(explorer.model, rho, eta)
        shown = np.array(_numbers(page.locator("#k-matrix").inner_text())).reshape(d.K.shape[0], -1)[:, 1:]
        assert np.allclose(shown, d.K, rtol=1e-5, atol=0), name
        expected = "not certified" if values[i, k] > 0 else "certified"
        assert f"Theorem 1: {expected}" in verdict.inner_text()
        if name == "uncertified":
            continue  # the next click cancels its slow answers
        times[f"{name}: click to response [ms]"] = painted_after_release(page, response_label(rho, eta), 120_000)
        times["response run on the server [ms]"] = float(page.locator("#response-ms").inner_text())
        page.locator("#certificate-table").wait_for(timeout=120_000)
        page.wait_for_selector("text=Sample time", timeout=120_000)
        page.screenshot(path=str(SCREENSHOTS / "app-certified.png"), full_page=True)
        rows = page.locator("#certificate-table tr").all_inner_texts()[1:]
        shown_verdicts = {r.split("\t")[0].strip(): r.split("\t")[1].strip() for r in rows}
        table = sr.certificate_table(explorer.model, d, plant=explorer.plant, falsifier_tries=5, seed=0)
        assert shown_verdicts == dict(zip(table["method"], table["verdict"]))
        # the controller file: the page's download equals export's
        page.get_by_label("Ts [s]").fill("0.001")
        page.get_by_role("button", name="Export C").click()
        link = page.locator("#download-motor_pid-c")
        link.wait_for(timeout=30_000)
        with page.expect_download() as download:
            link.click()
        downloaded = Path(download.value.path()).read_text(encoding="utf-8")
        out = tmp_path / "export"
        out.mkdir()
        assert main(["export", "--model", MOTOR, "--rho", repr(rho), "--eta", repr(eta), "--ts", "0.001",
                     "--output", str(out)]) == 0
        assert downloaded == (out / "motor_pid.c").read_text(encoding="utf-8")
        # the design file: the page's download equals `design --format json`
        page.get_by_role("button", name="Design file (JSON)").click()
        with page.expect_download() as download:
            page.locator(f"#download-design-rho{rho:g}-eta{eta:g}-json").click()
        assert Path(download.value.path()).read_text(encoding="utf-8") == explorer.design_file(rho, eta)
    # the same selection typed: button to K and Theorem 1
    page.get_by_label(LABELS["rho"]).fill("2")
    page.get_by_label(LABELS["eta"]).fill("50")
    watch(page, "design", design_label(2, 50))
    page.get_by_role("button", name="Select (ρ, η)").click()
    times["typed: Select to K and Theorem 1 [ms]"] = painted_after_release(page, design_label(2, 50), 10_000)
    (SCREENSHOTS / "app-timings.json").write_text(json.dumps(times, indent=2), encoding="utf-8")
    print(json.dumps(times, indent=2))
    assert not problems, problems


def test_the_page_marks_a_design_beyond_the_current_limit(page_of_motor):
    """The DC motor's file limits its current to 2 A; (ρ, η) = (10, 100) needs about 550 A for a unit step."""
    page, explorer, problems = page_of_motor
    motor = sr.load_plant(MOTOR)
    assert motor.input_limits is not None and float(motor.input_limits[0]) == 2.0
    d = sr.design(motor, 10, 100)
    peak = float(np.abs(sr.simulate_plant(motor, d.K, t_final=explorer.t_final).u).max())
    assert 500 < peak < 600  # the response the page runs: a unit step of the reference
    page.get_by_label(LABELS["rho"]).fill("10")
    page.get_by_label(LABELS["eta"]).fill("100")
    page.get_by_role("button", name="Select (ρ, η)").click()
    page.wait_for_selector(f"text={response_label(10, 100)}", timeout=120_000)
    mark = page.locator("#deployable")
    mark.wait_for(timeout=60_000)
    assert mark.inner_text() == "Outside the input limit"
    reason = page.locator("#deployable-reason").inner_text()
    assert f"current needs {peak:.4g} A, beyond its limit of 2 A" in reason
    # a design that stays within 2 A for the same step is marked so
    page.get_by_label(LABELS["rho"]).fill("0.1")
    page.get_by_label(LABELS["eta"]).fill("1")
    page.get_by_role("button", name="Select (ρ, η)").click()
    page.wait_for_selector(f"text={response_label(0.1, 1)}", timeout=120_000)
    page.wait_for_selector("#deployable >> text=Within the input limits", timeout=60_000)
    # the map coloured by certified-and-deployable: offered because the file limits the current
    choice = page.locator("select").first
    label = MEASURES["deployable"][0]
    assert label in choice.locator("option").evaluate_all("options => options.map(o => o.value)")
    choice.select_option(label=label)
    page.wait_for_timeout(1500)
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SCREENSHOTS / "app-deployable.png"), full_page=True)
    assert not problems, problems


#: The page's text fields, by their labels.
LABELS = {"rho": "ρ [-] (> 0)", "eta": "η [-] (>= 1)", "torque-limit": "input limit [A] (blank: none)",
          "ts": "Ts [s]", "rho-grid": "ρ grid START:STOP:NUM", "eta-grid": "η grid START:STOP:NUM"}


@pytest.mark.parametrize(("field", "value", "button", "message"), [
    ("rho", "-1", "Select (ρ, η)", "ρ must be > 0"),
    ("eta", "abc", "Select (ρ, η)", "η must be a number (-), found 'abc'"),
    ("torque-limit", "0", "Export C", "the input limit must be > 0 A, found 0"),
    ("ts", "0.5", "Export C", "is not certified"),
    ("rho-grid", "0.1:10:1250", "Recompute map", "a grid of 1,250,000 points"),
], ids=["rho-negative", "eta-text", "torque-limit-zero", "ts-uncertified", "huge-grid"])
def test_bad_input_on_the_page_gets_a_message_and_the_page_keeps_serving(page_of_motor, field, value, button,
                                                                         message):
    page, explorer, problems = page_of_motor
    if field == "rho-grid":
        page.get_by_label(LABELS["eta-grid"]).fill("1:200:1000")
    page.get_by_label(LABELS[field]).fill(value)
    page.get_by_role("button", name=button).click()
    page.wait_for_selector(f"text={message}", timeout=30_000)
    page.get_by_label(LABELS[field]).fill({"rho": "3", "eta": "90", "torque-limit": "", "ts": "0.001",
                                           "rho-grid": "0.1:10:100"}[field])
    page.get_by_label(LABELS["eta-grid"]).fill("1:200:200")
    page.get_by_label(LABELS["rho"]).fill("3")
    page.get_by_label(LABELS["eta"]).fill("90")
    page.get_by_role("button", name="Select (ρ, η)").click()  # the page still answers
    page.wait_for_selector("text=Design at ρ = 3, η = 90", timeout=30_000)
    assert not problems, problems
