"""The export targets' registry: refusals, a target of one's own, and the built-in targets' files."""

from __future__ import annotations

import json

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.export import registry


@pytest.fixture
def restored(monkeypatch):
    """The registry as it is now, put back after the test (whatever the test registers or removes)."""
    monkeypatch.setattr(registry, "_TARGETS", dict(registry._TARGETS))
    return registry


@pytest.fixture(scope="module")
def pids(paper_design):
    return {
        "plain": paper_design.discretize(1e-3),
        "limited": paper_design.discretize(1e-3, torque_limit=[40.0, 30.0]),
        "filtered": paper_design.discretize(5e-4, derivative="filtered", N=80.0, torque_limit=50.0),
    }


@pytest.fixture(scope="module")
def feedback():
    return sr.SampledStateFeedback(np.arange(12.0).reshape(2, 6) / 7.0, 1e-3)


def _toy_write(controller, *, prefix, notes, metadata, outputs, inputs, precision):
    return f"{prefix}: Ts = {controller.Ts!r} s, {precision}, {len(notes)} note(s)\n"


TOY = sr.ExportTarget("toy", ".txt", "<prefix>.txt: the sample time, s", _toy_write)


# -- refusals -------------------------------------------------------------------------------


def test_the_built_in_targets_are_the_export_formats():
    assert sr.export_targets() == sr.EXPORT_FORMATS == ("c", "json", "ros2")
    assert [sr.get_target(n).suffix for n in sr.export_targets()] == [".c", ".json", ".yaml"]


@pytest.mark.parametrize("name", ["c", "json"])
def test_a_second_target_of_a_registered_name_is_refused(restored, name):
    twin = sr.ExportTarget(name, ".txt", "a twin", _toy_write)
    with pytest.raises(ValueError, match=rf"`target` is named '{name}', and an export target of that name"):
        sr.register_target(twin)
    with pytest.raises(sr.ArgumentValueError, match=r"replace=True replaces it"):
        sr.register_target(twin)
    assert sr.get_target(name) is not twin


@pytest.mark.parametrize(
    "target",
    [None, "json", {"name": "toy", "suffix": ".txt"}, _toy_write],
    ids=["none", "name", "dict", "function"],
)
def test_something_other_than_a_target_is_refused(restored, target):
    with pytest.raises(TypeError, match=r"`target` must be an ExportTarget\(name, suffix, description, write\)"):
        sr.register_target(target)
    assert sr.export_targets() == ("c", "json", "ros2")


def test_replace_must_be_a_bool(restored):
    with pytest.raises(TypeError, match=r"`replace` must be True or False, found str 'yes'"):
        sr.register_target(TOY, replace="yes")


@pytest.mark.parametrize(
    ("name", "hint"),
    [("jsn", "; did you mean 'json'"), ("C", ""), ("cc", "; did you mean 'c'"), ("rust", "")],
    ids=["jsn", "C", "cc", "rust"],
)
def test_an_unknown_name_is_refused_listing_the_targets(name, hint):
    message = rf"`name` must be a registered export target \('c', 'json', 'ros2'\), found '{name}'"
    with pytest.raises(ValueError, match=message + (rf"{hint}\?$" if hint else "$")):
        sr.get_target(name)


def test_an_unknown_name_is_refused_by_unregister_too(restored):
    with pytest.raises(ValueError, match=r"`name` must be a registered export target \('c', 'json', 'ros2'\), "
                       r"found 'jason'; did you mean 'json'\?"):
        sr.unregister_target("jason")
    assert sr.export_targets() == ("c", "json", "ros2")


def test_a_name_that_is_not_a_str_is_refused():
    with pytest.raises(TypeError, match=r"`name` must be the name of an export target \(a str\), found int 3"):
        sr.get_target(3)


@pytest.mark.parametrize(
    ("fields", "error", "match"),
    [
        (("", ".txt", "d", _toy_write), ValueError, r"`name` must be a letter or digit"),
        (("to y", ".txt", "d", _toy_write), ValueError, r"`name` must be a letter or digit.*found 'to y'"),
        (("toy", "txt", "d", _toy_write), ValueError, r"`suffix` must be a file suffix such as '.json'"),
        (("toy", "./x", "d", _toy_write), ValueError, r"`suffix` must be a file suffix.*found '\./x'"),
        ((1, ".txt", "d", _toy_write), TypeError, r"`name` must be a str, found int 1"),
        (("toy", ".txt", None, _toy_write), TypeError, r"`description` must be a str, found NoneType"),
        (("toy", ".txt", "d", "write"), TypeError, r"`write` must be callable, found str"),
    ],
    ids=["empty-name", "space-in-name", "suffix-without-dot", "suffix-with-slash", "name-type", "description-type",
         "write-not-callable"],
)
def test_a_target_checks_its_fields(fields, error, match):
    with pytest.raises(error, match=match):
        sr.ExportTarget(*fields)


@pytest.mark.parametrize("written", [None, 3, {}, {"txt": "a"}, {".txt": 1}], ids=["none", "int", "empty", "no-dot",
                                                                                   "not-text"])
def test_a_write_that_returns_no_text_is_refused(pids, written):
    target = sr.ExportTarget("odd", ".txt", "returns no text", lambda controller, **options: written)
    with pytest.raises(TypeError, match=r"`write` of the export target 'odd' must return the file's text"):
        target.files(pids["plain"])


# -- a target of one's own --------------------------------------------------------------------


def test_a_registered_target_works_through_the_registry_and_can_be_removed(restored, pids, tmp_path):
    assert sr.register_target(TOY) is TOY
    assert sr.export_targets() == ("c", "json", "ros2", "toy")
    assert sr.get_target("toy") is TOY
    assert TOY.files(pids["plain"], prefix="arm", notes=["a"]) == {"arm.txt": "arm: Ts = 0.001 s, double, 1 note(s)\n"}

    paths = sr.export_controller(pids["plain"], tmp_path, format="toy", prefix="arm", precision="single")
    assert paths == [tmp_path / "arm.txt"]
    assert (tmp_path / "arm.txt").read_text() == "arm: Ts = 0.001 s, single, 0 note(s)\n"
    with pytest.raises(ValueError, match=r"`name` must be a registered export target \('c', 'json', 'ros2', 'toy'\), "
                       r"found 'tyo'; did you mean 'toy'\?"):
        sr.get_target("tyo")

    assert sr.unregister_target("toy") is TOY
    assert sr.export_targets() == ("c", "json", "ros2")
    with pytest.raises(ValueError,
                       match=r"`name` must be a registered export target \('c', 'json', 'ros2'\), found 'toy'"):
        sr.get_target("toy")
    with pytest.raises(ValueError, match=r"`format` must be one of 'c', 'json', 'ros2', found 'toy'"):
        sr.export_controller(pids["plain"], tmp_path, format="toy")


def test_the_fixture_put_the_registry_back():
    # runs after the test above (file order): nothing it registered or removed is left
    assert sr.export_targets() == ("c", "json", "ros2")
    assert "toy" not in sr.export_targets()


def test_replace_keeps_the_place_and_a_removed_target_comes_back_last(restored, pids, tmp_path):
    c_target = sr.get_target("c")
    shout = sr.ExportTarget("c", ".txt", "replaces C", lambda controller, **options: "C\n")
    sr.register_target(shout, replace=True)
    assert sr.export_targets() == ("c", "json", "ros2") and sr.get_target("c") is shout
    assert sr.export_controller(pids["plain"], tmp_path, prefix="x") == [tmp_path / "x.txt"]
    sr.register_target(c_target, replace=True)
    sr.register_target(sr.unregister_target("c"))
    assert sr.export_targets() == ("json", "ros2", "c")


def test_a_target_with_several_files_writes_them_in_its_order(restored, pids, tmp_path):
    def two(controller, *, prefix, **options):
        return {".cfg": f"[{prefix}]\n", ".dat": f"{controller.Ts}\n"}

    sr.register_target(sr.ExportTarget("pair", ".cfg", "<prefix>.cfg and <prefix>.dat", two))
    paths = sr.export_controller(pids["plain"], tmp_path, format="pair", prefix="p")
    assert paths == [tmp_path / "p.cfg", tmp_path / "p.dat"]
    assert [p.read_text() for p in paths] == ["[p]\n", "0.001\n"]


def test_the_command_line_offers_every_registered_target(restored, tmp_path, capsys):
    from scara_robust.cli import main

    with pytest.raises(SystemExit, match=r"^0$"):
        main(["export", "--help"])
    assert "--format {c,json,ros2}" in capsys.readouterr().out
    sr.register_target(TOY)
    with pytest.raises(SystemExit, match=r"^0$"):
        main(["export", "--help"])
    assert "--format {c,json,ros2,toy}" in capsys.readouterr().out
    assert main(["export", "--rho", "3", "--eta", "90", "--ts", "0.001", "--format", "toy", "--prefix", "arm",
                 "--output", str(tmp_path)]) == 0
    assert (tmp_path / "arm.txt").read_text() == "arm: Ts = 0.001 s, double, 2 note(s)\n"
    assert f"wrote {tmp_path / 'arm.txt'}" in capsys.readouterr().out


# -- the built-in targets write what the public functions give -------------------------------------


@pytest.mark.parametrize("precision", ["double", "single"])
@pytest.mark.parametrize("kind", ["plain", "limited", "filtered"])
def test_the_c_target_writes_c_source(pids, tmp_path, kind, precision):
    pid = pids[kind]
    notes = ["Sampled-data certificate: a note.", "two\nlines */"]
    header, source = sr.c_source(pid, "arm", notes, precision=precision)
    files = sr.get_target("c").files(pid, prefix="arm", notes=notes, metadata={"rho": 3.0}, precision=precision)
    assert files == {"arm.h": header, "arm.c": source}
    paths = sr.export_controller(pid, tmp_path, format="c", prefix="arm", notes=notes, precision=precision)
    assert {p.name: p.read_text(encoding="utf-8") for p in paths} == files
    assert [p.name for p in paths] == ["arm.h", "arm.c"]


@pytest.mark.parametrize("kind", ["plain", "limited", "filtered"])
def test_the_json_target_writes_controller_record(pids, tmp_path, kind):
    pid = pids[kind]
    outputs = [sr.Signal("x1", "m"), sr.Signal("x2", "m")]
    record = sr.controller_record(pid, outputs=outputs, rho=3.0, eta=90.0, notes=["a note"])
    files = sr.get_target("json").files(pid, prefix="arm", notes=["a note"], metadata={"rho": 3.0, "eta": 90.0},
                                        outputs=outputs)
    assert files == {"arm.json": json.dumps(record, indent=2) + "\n"}
    paths = sr.export_controller(pid, tmp_path, format="json", prefix="arm", notes=["a note"],
                                 metadata={"rho": 3.0, "eta": 90.0}, outputs=outputs)
    assert {p.name: p.read_text(encoding="utf-8") for p in paths} == files


@pytest.mark.parametrize("precision", ["double", "single"])
@pytest.mark.parametrize("name", ["c", "json"])
def test_the_targets_write_static_state_feedback_as_export_controller_does(feedback, tmp_path, name, precision):
    options = {"prefix": "gain", "notes": ["hello"], "metadata": {"model": "m"}, "precision": precision,
               "inputs": [sr.Signal(f"s{i}", "m") for i in range(6)]}
    files = sr.get_target(name).files(feedback, **options)
    paths = sr.export_controller(feedback, tmp_path, format=name, **options)
    assert {p.name: p.read_text(encoding="utf-8") for p in paths} == files
    assert list(files) == (["gain.h", "gain.c"] if name == "c" else ["gain.json"])
    if name == "json":
        assert json.loads(files["gain.json"])["K"] == feedback.K.tolist()
    else:
        assert "void gain_step(const " in files["gain.h"]


@pytest.mark.parametrize("name", ["c", "json"])
def test_the_targets_refuse_what_export_controller_refuses(pids, name):
    with pytest.raises(ValueError, match=r"`precision` must be one of 'double', 'single', found 'half'"):
        sr.get_target(name).files(pids["plain"], precision="half")
    with pytest.raises(ValueError, match=r"`prefix` must be a C identifier"):
        sr.get_target(name).files(pids["plain"], prefix="scara-pid")


@pytest.mark.parametrize("unit, rate", [("rad", "rad/s"), ("1", "1/s"), ("1/s", "1/s²"), ("m/s", "m/s²"),
                                        ("N·m", "N·m/s"), ("m/s²", "(m/s²)/s"), ("m/(N·s²)", "(m/(N·s²))/s")])
def test_the_unit_of_a_rate_reads_as_one(unit, rate):
    from scara_robust.export._common import per_second

    assert per_second(unit) == rate
