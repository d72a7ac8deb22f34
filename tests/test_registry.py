"""One registry of analysis methods, one result base, one bisection.

A method of a user's own is registered and runs in the tables as the built-in ones do; bad
registrations and names are refused naming the argument; every certificate and margin
result carries the common fields; the one bisection finds what it is asked for.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

import scara_robust as sr


@pytest.fixture
def box():
    """q̈ = −0.15 q̇ + 0.05 u with two interval elements (the docstring examples' plant)."""
    return sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
                                (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))


@pytest.fixture
def own_method():
    """A method of the user's own, registered for one test and removed after it."""

    def nominal(context: sr.CertificateContext) -> sr.CertificateRow:
        loop = context.model.A - context.model.B @ context.design.K
        worst = float(np.linalg.eigvals(loop).real.max())
        return sr.CertificateRow.of(worst < 0, f"nominal loop, largest real part {worst:.4g} 1/s", value=worst)

    method = sr.AnalysisMethod("nominal", "certificate", "certificate", nominal, "the design's own loop",
                               default=False, column="real part [1/s]")
    sr.register_method(method)
    yield method
    sr.unregister_method("certificate", "nominal")


def test_a_registered_method_runs_in_the_certificate_table(box, own_method):
    d = sr.design(box, 1.0, 2.0)
    table = sr.certificate_table(box, d, methods=("theorem1-all", "nominal"))
    assert table["method"].tolist() == ["theorem1-all", "nominal"]
    row = table.set_index("method").loc["nominal"]
    expected = float(np.linalg.eigvals(d.A_cl).real.max())
    assert row["verdict"] == "certified" and row["real part [1/s]"] == pytest.approx(expected, rel=1e-12)
    # asked for by name only: the default table is the built-in rows
    assert "nominal" not in sr.certificate_table(box, d)["method"].tolist()


def test_a_user_margin_method_runs_in_the_margin_table(box):
    def half_vertex(model, design, **options):
        full = sr.robustness_margin(model, design, "vertex")
        return dataclasses.replace(full, theta=0.5 * full.theta, message="half the vertex margin")

    sr.register_method(sr.AnalysisMethod("half", "margin", "lower", half_vertex, "half the vertex margin",
                                         frozenset({"P"})))
    try:
        d = sr.design(box, 1.0, 2.0)
        table = sr.margin_table(box, d).set_index("method")
        assert table.loc["half", "theta"] == pytest.approx(0.5 * table.loc["vertex", "theta"], rel=1e-12)
        assert table.loc["half", "kind"] == "lower"
    finally:
        sr.unregister_method("margin", "half")


def test_registering_a_name_twice_is_refused(own_method):
    with pytest.raises(sr.ArgumentValueError, match=r"`method` 'nominal' is already registered in the 'certificate'"):
        sr.register_method(own_method)
    assert sr.register_method(own_method, replace=True) is own_method


def test_registering_something_else_is_refused():
    with pytest.raises(sr.ArgumentTypeError, match="`method` must be an AnalysisMethod, found function"):
        sr.register_method(lambda context: None)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "kwargs, error, match",
    [({"family": "gain"}, sr.ArgumentValueError, "`family` must be one of 'certificate'"),
     ({"bound": "both"}, sr.ArgumentValueError, "`bound` must be one of 'certificate', 'lower', 'upper'"),
     ({"needs": frozenset({"gpu"})}, sr.ArgumentValueError, "`needs` must be one of 'P'"),
     ({"run": 3}, sr.ArgumentTypeError, "`run` must be callable, found int"),
     ({"name": ""}, sr.ArgumentValueError, "`name` must be a non-empty str")],
    ids=["family", "bound", "needs", "run", "name"],
)
def test_a_bad_method_is_refused_naming_the_field(kwargs, error, match):
    fields = {"name": "x", "family": "certificate", "bound": "certificate", "run": print, "description": "",
              **kwargs}
    with pytest.raises(error, match=match):
        sr.AnalysisMethod(**fields)


def test_a_method_whose_result_lacks_the_common_fields_is_refused(box):
    sr.register_method(sr.AnalysisMethod("bare", "certificate", "certificate", lambda context: {"ok": True},
                                         "returns a dict", default=False))
    try:
        with pytest.raises(sr.ArgumentTypeError, match="'bare' .* returned a dict, not an AnalysisResult"):
            sr.certificate_table(box, sr.design(box, 1.0, 2.0), methods=("bare",))
    finally:
        sr.unregister_method("certificate", "bare")


def test_a_result_class_without_the_common_fields_cannot_be_defined():
    with pytest.raises(TypeError, match="result class Partial lacks the common field.s. verdict, status"):
        @dataclasses.dataclass(frozen=True)
        class Partial(sr.AnalysisResult):
            certified: bool
            message: str


@pytest.mark.parametrize(
    "call, match",
    [(lambda box, d: sr.certificate_table(box, d, methods=("lmi-boxx",)),
      r"`methods` must be one of 'theorem1-all'.*found 'lmi-boxx'; did you mean 'lmi-box'\?"),
     (lambda box, d: sr.robustness_margin(box, d, "vertexx"),
      r"`method` must be one of 'theorem1'.*found 'vertexx'; did you mean 'vertex'\?"),
     (lambda box, d: sr.get_method("payload", "payload-lmj"), r"did you mean 'payload-lmi'\?")],
    ids=["certificate", "margin", "payload"],
)
def test_an_unknown_name_lists_the_registered_ones_and_suggests(box, call, match):
    with pytest.raises(sr.ArgumentValueError, match=match):
        call(box, sr.design(box, 1.0, 2.0))


def test_the_built_in_lists_are_the_registry():
    assert sr.CERTIFICATE_METHODS == sr.analysis_methods("certificate", defaults=True)
    assert tuple(sr.MARGIN_METHODS) == sr.analysis_methods("margin", defaults=True)
    assert tuple(sr.PARAMETER_METHODS) == sr.analysis_methods("parameter", defaults=True)
    assert sr.PAYLOAD_METHODS == sr.analysis_methods("payload", defaults=True)
    for family in sr.METHOD_FAMILIES:
        for name in sr.analysis_methods(family):
            method = sr.get_method(family, name)
            assert method.family == family and method.bound in sr.METHOD_BOUNDS


#: Every certificate, margin and bound the package returns.
RESULT_CLASSES = ("Certificate", "FalsifierResult", "L2Gain", "PeakBound", "LMICertificate", "Margin", "RateBracket",
                  "RateCertificate", "RateMargin", "PolytopeCertificate", "SampledCertificate", "SampleTimeLimit",
                  "SampleTimeCheck", "Synthesis", "RateL2Gain", "CertificateRow")


@pytest.mark.parametrize("name", RESULT_CLASSES)
def test_every_result_class_has_the_common_base(name):
    cls = getattr(sr, name)
    assert issubclass(cls, sr.AnalysisResult)
    for field in sr.RESULT_FIELDS:
        assert hasattr(cls, field) or field in {f.name for f in dataclasses.fields(cls)}


def test_results_say_the_same_in_their_fields_and_their_table(box):
    d = sr.design(box, 1.0, 2.0)
    results = [sr.certify(box, d), sr.vertex_certificate(box, d), sr.robustness_margin(box, d, "vertex"),
               sr.falsify(box.vertex_closed_loops(d.K), d.P, n_tries=3)]
    for result in results:
        row = result.to_pandas()
        assert row["verdict"] == result.verdict and row["certified"] == result.certified
        assert isinstance(result.message, str) and result.message
        assert all(np.ndim(v) == 0 or isinstance(v, tuple) for v in row.to_numpy())


def test_the_falsifier_verdict_and_its_growth_agree():
    """A loop that grows, slowly, below the detection threshold: the verdict says so, not "no counterexample"."""
    A = np.array([[[0.02, 1.0], [-1.0, 0.02]]])  # a frozen spiral growing at 0.02 1/s
    result = sr.falsify(A, n_tries=2, seed=0)
    assert not result.found and result.growth_rate > 0
    assert result.verdict == "growth below the detection threshold" and result.certified is None
    stable = sr.falsify(np.array([[[-1.0, 0.0], [0.0, -2.0]]]), n_tries=2, seed=0)
    assert stable.growth_rate < 0 and stable.verdict == "no counterexample found"


@pytest.mark.parametrize("midpoint", sorted(sr.MIDPOINTS))
def test_the_one_bisection_finds_the_end(midpoint):
    lo, hi = sr.bisect(lambda x: x < math.sqrt(2.0), 0.5, 4.0, 1e-9, midpoint=midpoint)
    assert lo < math.sqrt(2.0) <= hi and hi - lo <= 1e-9 * hi


def test_the_bisection_counts_a_failing_test_as_false_and_stops_when_asked():
    class Undefined(Exception):
        pass

    def ok(x: float) -> bool:
        if x > 3.0:
            raise Undefined
        return x < 2.0

    assert sr.bisect(ok, 0.0, 10.0, 1e-6, fails=(Undefined,))[1] == pytest.approx(2.0, rel=1e-6)
    calls: list[float] = []
    bracket = sr.bisect(lambda x: calls.append(x) or False, 0.0, 1.0, 1e-9, midpoint="eighth",
                        stop=lambda lo, hi, mid: mid < 0.01)
    # from lo = 0 each probe is hi/8, all failing, until the next would fall below 0.01
    assert calls == [0.125, 0.125 / 8] and bracket == (0.0, 0.125 / 8)
    with pytest.raises(sr.ArgumentValueError, match="`midpoint` must be one of"):
        sr.bisect(ok, 0.0, 1.0, 1e-3, midpoint="golden")


def test_an_unverified_infeasibility_is_unknown_not_infeasible():
    """Two loops with the common P = diag(1, 1/s²) by construction (Bᵢ + Bᵢᵀ ≺ 0, similarity T = diag(1, s)).

    At s = 3e-4 (cond P ≈ 1e7) Clarabel answers "infeasible"; its certificate of
    infeasibility fails numpy's check, so the answer is unknown, with the reason.
    """
    pytest.importorskip("cvxpy")
    B = np.array([[[-1.0, 2.0], [-2.0, -1.0]], [[-2.0, -3.0], [3.0, -0.5]]])
    T, Ti = np.diag([1.0, 3e-4]), np.diag([1.0, 1 / 3e-4])
    A = T @ B @ Ti
    assert sr.verify_lyapunov(A, Ti.T @ Ti)[1] > 0  # the P that exists
    result = sr.lmi_certificate(A)
    assert result.verdict != "infeasible"
    if result.status.startswith("infeasible"):
        assert result.verdict == "unknown" and "fails numpy's check" in result.message


def test_a_verified_infeasibility_stays_infeasible():
    """ẍ = −(2/p)x − (0.4/p)ẋ at p = 1 and 3: no common P (A(1)A(3) has negative real eigenvalues)."""
    pytest.importorskip("cvxpy")
    A = np.array([[[0.0, 1.0], [-2.0 / m, -0.4 / m]] for m in (1.0, 3.0)])
    assert (np.linalg.eigvals(A[0] @ A[1]).real < 0).all()
    result = sr.lmi_certificate(A)
    assert result.verdict == "infeasible" and "proved the LMI infeasible" in result.message


@pytest.mark.parametrize(
    "use, new",
    [(lambda box: sr.design_surface(box, [1.0], [2.0], method="reference"), "design_surface(formulation=...)"),
     (lambda box: sr.lmi_certificate(box.vertex_closed_loops(sr.design(box, 1.0, 2.0).K)).margin,
      "LMICertificate.decay_rate"),
     (lambda box: sr.robustness_margin(box, sr.design(box, 1.0, 2.0), "vertex").kind, "Margin.bound")],
    ids=["surface-method", "lmi-margin", "margin-kind"],
)
def test_old_names_still_work_and_warn(box, use, new):
    with pytest.warns(DeprecationWarning, match=re.escape(f"is renamed {new}")):
        use(box)


def test_the_old_and_the_new_keyword_together_are_refused(box):
    with pytest.raises(TypeError, match="got both `formulation` and its deprecated name `method`"):
        sr.design_surface(box, [1.0], [2.0], formulation="reference", method="reference")


def test_sample_times_are_ts_and_the_old_name_warns():
    with pytest.warns(DeprecationWarning, match=re.escape("is renamed ControllerKind.Ts")):
        assert sr.CONTROLLERS["pid-sampled"].sample_time == sr.CONTROLLERS["pid-sampled"].Ts
    with pytest.warns(DeprecationWarning, match=re.escape("simulate(sample_time=...) is renamed simulate(Ts=...)")):
        old = sr.simulate("pid-sampled", "small", sample_time=sr.CONTROLLERS["pid-sampled"].Ts, t_final=0.2)
    new = sr.simulate("pid-sampled", "small", Ts=sr.CONTROLLERS["pid-sampled"].Ts, t_final=0.2)
    assert np.array_equal(old.e, new.e)


@pytest.mark.parametrize(
    "argv, expected",
    [(["margin", "--method", "vertexx"], "argument --method: must be one of 'theorem1', 'vertex'"),
     (["certify", "--methods", "theorem1-all,lmi-boxx"], "argument --methods: must be one of 'theorem1-all'")],
    ids=["margin", "certify"],
)
def test_an_unknown_method_on_the_command_line_is_one_line_and_exit_2(capsys, argv, expected):
    from scara_robust.cli import main

    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0] and "did you mean" in lines[0]


def test_the_command_line_runs_a_method_registered_by_a_script(capsys, own_method):
    from scara_robust.cli import main

    argv = ["certify", "--model", "examples/plant-dc-motor.toml", "--rho", "1", "--eta", "2",
            "--methods", "theorem1-all,nominal,l2-rate-bounded"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "real part [1/s]" in out and "l2_gain [z/w]" in out
    assert "nominal: nominal loop, largest real part" in out
    assert "|dJ/dt| <= 0.0004 kg·m²/s" in out
