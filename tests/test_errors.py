"""One exception hierarchy; library errors name parameters, the CLI maps them to options from one table."""

import pickle

import numpy as np
import pytest

import scara_robust as sr
from scara_robust._validation import check_int, check_real
from scara_robust.cli import main
from scara_robust.cli._common import OPTION_NAMES, error_message
from scara_robust.simulation.metrics import metric_names


@pytest.mark.parametrize(
    ("cls", "builtin"),
    [(sr.ArgumentValueError, ValueError), (sr.ArgumentTypeError, TypeError), (sr.InputFileError, ValueError),
     (sr.CampaignSpecError, ValueError)],
    ids=["value", "type", "file", "spec"],
)
def test_every_error_is_a_package_error_and_a_builtin_one(cls, builtin):
    assert issubclass(cls, sr.ScaraRobustError) and issubclass(cls, builtin)


def test_argument_error_keeps_its_fields_across_pickling():
    # process pools and Dask send errors back pickled
    err = pickle.loads(pickle.dumps(sr.ArgumentValueError("rho", "must be > 0, found -1.0")))
    assert (err.argument, err.problem, str(err)) == ("rho", "must be > 0, found -1.0", "`rho` must be > 0, found -1.0")


@pytest.mark.parametrize(
    ("call", "error"),
    [(lambda: check_int("n", "3", 1), TypeError), (lambda: check_real("x", "3"), TypeError),
     (lambda: check_int("n", 0, 1), ValueError), (lambda: check_real("x", -1.0, positive=True), ValueError)],
    ids=["int-text", "real-text", "int-small", "real-negative"],
)
def test_the_same_mistake_gets_the_same_error_type(call, error):
    with pytest.raises(error, match=r"^`(n|x)` must be"):
        call()


def test_library_errors_name_the_library_parameter():
    with pytest.raises(sr.ArgumentValueError, match="^`rhos` must be > 0") as info:
        sr.design_surface(sr.paper_model(), [-1.0], [1.0])
    assert info.value.argument == "rhos"
    with pytest.raises(sr.ArgumentValueError, match=r"^`path` must end in \.csv or \.parquet, found 'x\.txt'"):
        sr.read_results("x.txt")


@pytest.mark.parametrize("parameter", sorted(OPTION_NAMES), ids=sorted(OPTION_NAMES))
def test_cli_renders_a_parameter_as_its_option(parameter):
    message = error_message(sr.ArgumentValueError(parameter, "must be fine, found bad"))
    assert message == f"`{OPTION_NAMES[parameter]}` must be fine, found bad"


def test_cli_keeps_names_it_has_no_option_for():
    assert error_message(sr.ArgumentValueError("m1 [kg]", "must be > 0")) == "`m1 [kg]` must be > 0"
    assert error_message(ValueError("plain\nmessage")) == "plain message"


def test_cli_surface_names_the_option(capsys):
    assert main(["surface", "--rho=-1:2:3", "--eta", "1:2:3"]) == 2
    assert capsys.readouterr().err == "scara_robust: error: `--rho` must be > 0.0, found -1.0\n"


def test_metric_keys_name_the_transient_they_were_taken_after():
    t = np.linspace(0.0, 10.0, 101)
    m = sr.tracking_metrics(t, np.ones((2, 101)), np.zeros((2, 101)), t_transient=3.0)
    assert list(m.to_dict()) == list(metric_names(3.0))
    assert all("6s" not in k for k in m.to_dict()) and "max_abs_error_after_3s" in m.to_dict()
    assert sr.METRIC_NAMES == metric_names(6.0) and sr.METRIC_NAMES[0] == "max_abs_error_after_6s"
