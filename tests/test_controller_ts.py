"""Certified at the rate it runs: a robot or plant file's ``[controller] sample_time`` leads every certificate.

The light SCARA of examples/robot-light.toml runs its controller at 1 kHz; its (3, 90) design is
certified in continuous time by lmi-physical, yet its sampled loop is unstable at any Ts above
38 µs. certify and the page now lead with that; without a sample time in the file, certify leads
with the largest certified Ts. The verdicts are checked against check_sample_time and
max_sample_time called directly.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import scara_robust as sr
from scara_robust.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
LIGHT = str(ROOT / "examples" / "robot-light.toml")
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")


def test_the_file_gives_the_controller_s_sample_time(tmp_path):
    assert sr.controller_sample_time(LIGHT) == 0.001
    assert sr.controller_sample_time(MOTOR) is None
    bad = tmp_path / "robot.toml"
    bad.write_text(Path(LIGHT).read_text().replace("sample_time = 0.001", "sample_time = -1"))
    with pytest.raises(sr.InputFileError, match=r"field `controller.sample_time` \[s\] must be > 0, found -1"):
        sr.controller_sample_time(bad)
    bad.write_text(Path(LIGHT).read_text().replace("sample_time = 0.001", "period = 0.001"))
    assert main(["certify", "--rho", "3", "--eta", "90", "--robot", str(bad)]) == 2


def test_certify_leads_with_the_certificate_at_the_controller_s_ts(capsys):
    assert main(["certify", "--rho", "3", "--eta", "90", "--robot", LIGHT]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("NOT certified at Ts = 0.001 s, the controller's sample time in")
    system = sr.open_system("scara", command="certify", robot=LIGHT)
    plants, check, name = system.sampled()
    direct = sr.check_sample_time(plants, sr.design(system.model, 3, 90).discretize(1e-3), check=check,
                                  set_name=name)
    assert not direct.certified and direct.message in first
    assert main(["certify", "--rho", "3", "--eta", "90", "--robot", LIGHT, "--format", "json"]) == 0
    record = json.loads(capsys.readouterr().out)[0]
    assert record["method"] == "sampled-at-ts" and record["certified"] is False and record["Ts"] == 0.001


def test_without_a_sample_time_certify_leads_with_the_largest_certified_one(capsys):
    assert main(["certify", "--rho", "3", "--eta", "90"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    system = sr.open_system("scara", command="certify")
    plants, check, _ = system.sampled()
    limit = sr.max_sample_time(plants, sr.design(system.model, 3, 90), check=check, rtol=1e-3)
    assert first.startswith("continuous-time certificates below; sampled as export discretizes the controller:")
    assert limit.message in first and 1e-3 < limit.certified_ts < 1.2e-3


def test_the_page_leads_with_it(capsys):
    pytest.importorskip("bokeh", reason="the design page: pip install '.[app]'")
    from scara_robust.cli._app import explorer_of

    explorer = explorer_of(build_parser().parse_args(["app", "--robot", LIGHT, "--rho", "1:5:3", "--eta",
                                                      "10:90:3"]))
    try:
        assert explorer.controller_ts == 0.001
        answer = explorer.quick(3.0, 90.0)
        function, arguments = explorer.slow_answers(answer.design)["sample_time"]
        result = function(*arguments)
        assert not result.certified and result.certificate.Ts == 0.001
        from bokeh.document import Document

        from scara_robust.app._page import build_page

        doc = Document()
        build_page(doc, explorer)
        answers = doc.get_model_by_name("answers")
        assert [child.name for child in answers.children][0] == "sample_time"  # it leads the answers
        assert "The controller runs at Ts = 0.001 s" in " ".join(
            getattr(m, "text", "") or "" for m in doc.roots if hasattr(m, "text"))
    finally:
        explorer.close()


@pytest.mark.lmi
def test_synthesize_ts_finds_a_gain_certified_at_the_controller_s_ts(tmp_path, capsys):
    out = tmp_path / "light-1ms.json"
    assert main(["synthesize", "--robot", LIGHT, "--ts", "0.001", "--output", str(out)]) == 0
    text = capsys.readouterr().out
    assert "\ncertified: u = -K x(t_k) held at Ts = 0.001 s" in text
    K = sr.load_design(out).K
    # re-verified here: the held loop's own LMI and numpy, on the certificate's plants and its check grid
    system = sr.open_system("scara", command="certify", robot=LIGHT)
    plants, check, _ = system.sampled()
    again = sr.sampled_certificate(plants, sr.SampledStateFeedback(K, 1e-3), check=check)
    assert again.certified and again.rate > 0
    # certify leads with it: the PID of this gain, discretized as export does, is certified at 1 ms too
    assert main(["certify", "--design", str(out), "--robot", LIGHT]) == 0
    assert capsys.readouterr().out.startswith("certified at Ts = 0.001 s, the controller's sample time in")


@pytest.mark.parametrize(("argv", "text"), [
    (["--ts", "-0.001"], "`--ts` must be > 0 s, found -0.001"),
    (["--ts", "0.001", "--objective", "l2"], "`--objective` is an option of the continuous-time synthesis"),
    (["--ts", "0.001", "--output", "x.txt"], "a design file is .json"),
])
def test_synthesize_ts_refuses_what_it_does_not_take(capsys, argv, text):
    assert main(["synthesize", "--robot", LIGHT, *argv]) == 2
    err = capsys.readouterr().err
    assert text in err and err.count("\n") == 1
