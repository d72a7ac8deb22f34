"""The design page with a scheduled gain (``app --design SCHEDULE.json``): its panel, in Chromium too.

Apart from tests/test_app.py: each module opens one Playwright session at a time, and that
module keeps its page open for all its tests.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from page_driver import click_grid_point, design_label, open_page, painted_after_release, watch

import scara_robust as sr
from scara_robust.cli import build_parser, main
from scara_robust.cli._app import explorer_of

#: Needs the `app` extra (Bokeh): skipped without it, failed under SCARA_ROBUST_REQUIRE_EXTRAS=1.
pytestmark = pytest.mark.app

ROOT = Path(__file__).resolve().parents[1]
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")
SCREENSHOTS = ROOT / "docs" / "_build" / "screenshots"
#: The map's grid (as tests/test_app.py's): (1, 5) is a grid point.
GRID = ["--rho", "0.1:10:34", "--eta", "1:10:10"]

ARM = str(ROOT / "examples" / "plant-arm-payload.toml")


@pytest.fixture(scope="module")
def arm_schedule(tmp_path_factory):
    """A schedule of the one-joint arm (payload measured within 0.05 kg, 1 kg/s), from synthesize --schedule."""
    pytest.importorskip("cvxpy", reason="a schedule is synthesized by LMIs: pip install '.[lmi]'")
    path = tmp_path_factory.mktemp("schedule") / "arm-schedule.json"
    assert main(["synthesize", "--model", ARM, "--schedule", "m", "--breakpoints", "3", "--rate", "1",
                 "--gain-bound", "20", "--output", str(path)]) == 0
    return str(path)


def test_the_page_takes_a_schedule_file_and_re_verifies_its_certificate(arm_schedule, capsys):
    explorer = explorer_of(build_parser().parse_args(["app", "--model", ARM, *GRID, "--design", arm_schedule]))
    try:
        gain = sr.load_schedule(arm_schedule)
        assert explorer.schedule is not None and np.array_equal(explorer.schedule.gains, gain.gains)
        cert, error, _ = explorer.schedule_check().result(timeout=300)
        direct = sr.schedule_certificate(explorer.plant, gain, rate=1.0, measurement_error=0.05)
        assert error == "" and cert.certified and direct.certified
        assert (cert.rate, cert.measurement_error) == (gain.certified["rate"], gain.certified["measurement_error"])
        assert explorer.schedule_check() is explorer.schedule_check()  # once per page
    finally:
        explorer.close()
    motor = str(ROOT / "examples" / "plant-dc-motor.toml")
    for argv, text in ((["--model", motor, "--design", arm_schedule], "schedules 'm' with gains of shape (1, 3), "
                        "not a gain of this plant"),
                       (["--model", ARM, "--design", MOTOR], "the page takes a schedule file")):
        assert main(["app", *argv]) == 2
        err = capsys.readouterr().err
        assert text in err and err.count("\n") == 1, err


def test_the_schedule_on_the_page_in_chromium(arm_schedule, tmp_path):
    """The gains against the payload, the selected design's beside them, the certificate re-verified."""
    gain = sr.load_schedule(arm_schedule)
    argv = ["--model", ARM, *GRID, "--design", arm_schedule]
    explorer = explorer_of(build_parser().parse_args(["app", *argv]))
    with open_page(argv, tmp_path / "stderr.txt") as (page, problems):
        page.wait_for_selector("#schedule-check >> text=certificate re-verified now", timeout=300_000)
        assert "certified, rate |dm/dt| <= 1 kg/s, measurement error <= 0.05 kg" in \
            page.locator("#schedule-check").inner_text()
        i, k = explorer.nearest(1.0, 5.0)
        rho, eta = float(explorer.rhos[i]), float(explorer.etas[k])
        watch(page, "design", design_label(rho, eta))
        click_grid_point(page, explorer.rhos, explorer.etas, int(i), int(k))
        painted_after_release(page, design_label(rho, eta), 10_000)
        fixed = "() => Bokeh.documents[0].get_model_by_name('schedule-fixed').data"
        page.wait_for_function(f"() => ({fixed})()['x'].length > 0", timeout=10_000)
        shown = page.evaluate(fixed)
        K = sr.design(explorer.model, rho, eta).K
        drawn = {float(v[0]) for key, v in shown.items() if key.startswith("k")}
        assert drawn == {float(v) for v in K.ravel() if v != 0} and shown["x"] == list(gain.range)
        assert page.locator(".bk-Canvas").count() >= 3  # the map, the runs and the schedule's panels drawn
        SCREENSHOTS.mkdir(parents=True, exist_ok=True)
        page.wait_for_timeout(500)
        page.screenshot(path=str(SCREENSHOTS / "app-schedule.png"), full_page=True)
        assert not problems, problems
    explorer.close()
