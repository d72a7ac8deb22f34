"""The uncertain plant over named physical parameters: files, hulls, margins in units, runs, export.

Independent checks: the interval enclosure holds every sampled plant; the frozen upper bound of
the DC motor's inertia matches the Routh–Hurwitz limit in closed form; the SCARA through the
plant type gives the numbers the element-level code gave; the single-precision C matches a
float32 Python step bit for bit and the double step to float32 rounding.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.model._expressions import parse_expression

ROOT = Path(__file__).resolve().parents[1]
MOTOR = ROOT / "examples" / "plant-dc-motor.toml"
CARTS = ROOT / "examples" / "plant-two-mass.toml"
CC = shutil.which("cc")
B_FRICTION, K_TORQUE = 1e-4, 0.05  # the motor file's fixed parameters


@pytest.fixture(scope="module")
def motor():
    return sr.load_plant(MOTOR)


@pytest.fixture(scope="module")
def carts():
    return sr.load_plant(CARTS)


# --- expressions: a whitelist, never executed ---------------------------------------------

@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("__import__('os').system('true')", r"calls `__import__\('os'\).system`, which is not an allowed function"),
        ("J.__class__", "Attribute is not allowed"),
        ("[J][0]", "Subscript is not allowed"),
        ("(lambda: 1)()", "calls `lambda: 1`"),
        ("J if J else 1", "IfExp is not allowed"),
        ("J < 1", "Compare is not allowed"),
        ("'J'", "is not a number"),
        ("open('f')", "calls `open`"),
        ("x + J", "names `x`, which is not a parameter"),
        ("J ** J", "exponent must be a number"),
        ("sqrt(J, J)", "takes one positional argument"),
        ("J +", "is not an arithmetic expression"),
    ],
    ids=["import", "attribute", "subscript", "lambda", "ifexp", "compare", "string", "open", "unknown",
         "power-of-parameter", "two-arguments", "syntax"],
)
def test_expressions_outside_the_whitelist_are_refused(text, match):
    with pytest.raises(sr.ArgumentValueError, match=match):
        parse_expression(text, {"J"}, "A[1][1]")


def test_a_huge_power_overflows_instead_of_computing():
    expr = parse_expression("9**9**9", set(), "A[0][0]")
    assert math.isinf(float(expr({})))


@pytest.mark.parametrize(
    "text",
    ["-b/J", "kt/J", "sqrt(J) * 3 - exp(-J)", "sin(J * 1e4) + cos(3 * J * 1e4)", "abs(J - 4e-4) ** 2", "tanh(J*1e3)",
     "J / (J + 1e-4)", "log(J) * J ** 0.5", "(J - 4e-4) ** 3"],
    ids=["ratio", "gain", "sqrt-exp", "trig", "abs-square", "tanh", "dependent", "log-root", "odd-power"],
)
def test_interval_enclosure_holds_every_sample(text):
    """Property: the interval of an entry over the box contains the entry at 20 001 points of it."""
    expr = parse_expression(text, {"J", "b", "kt"}, "e")
    box = {"J": (2e-4, 6e-4), "b": (B_FRICTION, B_FRICTION), "kt": (K_TORQUE, K_TORQUE)}
    lo, hi = expr.interval({k: box[k] for k in expr.names})
    J = np.linspace(2e-4, 6e-4, 20_001)
    values = expr({"J": J, "b": B_FRICTION, "kt": K_TORQUE})
    # the ends are computed by the same correctly rounded operations; allow numpy's and math's last bits
    assert lo - 4 * np.spacing(abs(lo)) <= values.min() and values.max() <= hi + 4 * np.spacing(abs(hi))


def test_monotone_entries_have_the_exact_hull(motor):
    """−b/J and k_t/J are monotone in J: the enclosure is exactly the range of the samples (ends included)."""
    model = motor.interval_model()
    samples = motor.samples({"J": 101})
    assert np.allclose(model.lower_bounds() + [model.A[2, 2], model.B[2, 0]],
                       [samples.A[:, 2, 2].min(), samples.B[:, 2, 0].min()], rtol=1e-15)
    assert np.allclose(model.upper_bounds() + [model.A[2, 2], model.B[2, 0]],
                       [samples.A[:, 2, 2].max(), samples.B[:, 2, 0].max()], rtol=1e-15)


def test_the_motor_file_is_the_element_file_plant(motor):
    """The parameter file and the element file describe the same box (the element file rounds to 5 digits)."""
    elements = sr.load_model(ROOT / "examples" / "plant-dc-motor-elements.toml")
    hull = motor.interval_model()
    for model in (hull, elements):
        assert model.n_states == 3 and model.n_elements == 2
    lo_h, hi_h = hull.matrices_at(hull.lower_bounds())[0], hull.matrices_at(hull.upper_bounds())[0]
    corners = elements.vertex_matrices()[0]
    assert np.allclose(np.sort([lo_h[2, 2], hi_h[2, 2]]), np.sort(np.unique(corners[:, 2, 2].round(4))), atol=1e-4)


# --- the frozen bound against Routh–Hurwitz -------------------------------------------------

@pytest.mark.parametrize(("rho", "eta"), [(1.0, 2.0), (1.0, 10.0), (3.0, 5.0)], ids=["1-2", "1-10", "3-5"])
def test_frozen_inertia_limit_is_the_routh_hurwitz_bound(motor, rho, eta):
    """J s³ + (b + k_t K_D) s² + k_t K_P s + k_t K_I is Hurwitz iff J < (b + k_t K_D) K_P / K_I."""
    d = sr.design(motor, rho, eta)
    K_I, K_P, K_D = (float(v) for v in -d.K[0])
    limit = (B_FRICTION + K_TORQUE * K_D) * K_P / K_I
    table = sr.parameter_margin(motor, d, ["frozen"])
    assert table["J high [kg·m²]"].iloc[0] == pytest.approx(limit, rel=1e-6)


# --- margins in units and rates ----------------------------------------------------------------

def test_parameter_margins_are_ordered_and_in_units(motor):
    d = sr.design(motor, 1.0, 10.0)
    table = sr.parameter_margin(motor, d).set_index("method")
    high = table["J high [kg·m²]"]
    assert (table["J low [kg·m²]"] == 2e-4).all()
    assert high["theorem1"] <= high["vertex"] <= high["lmi"] <= high["frozen"]
    assert high["theorem1"] >= 6e-4  # Theorem 1 certifies the file's whole range at (1, 10)
    # each certified range re-verified by numpy: the design's P on the hull's corners at that range
    hull = motor.with_ranges({"J": (2e-4, float(high["vertex"]))}).interval_model()
    assert sr.polytope_certificate(hull.vertex_closed_loops(d.K), d.P).certified


def test_rate_of_a_wider_range_is_certified_and_verified(motor):
    """Beyond the common-P range the certified rate is finite, and numpy verifies its P(J) on a finer grid."""
    pytest.importorskip("cvxpy")
    d = sr.design(motor, 1.0, 2.0)
    assert math.isinf(sr.parameter_rate(motor, d).rate)  # the file's range: a common P, any rate
    wide = motor.with_ranges({"J": (2e-4, 0.12)})  # past the common-P limit (0.0619 kg·m²), below the frozen one
    bracket = sr.rate_bracket(wide, d)
    assert 0 < bracket.rate < math.inf
    cert = bracket.margin.certificate
    assert cert is not None and cert.certified
    fine = wide.samples({"J": 4 * wide.parameter("J").samples - 3})
    assert sr.verify_rate_bounded(fine.closed_loops(d.K), fine.column("J"), cert.P0, cert.P1,
                                  bracket.rate) > 0
    # above it: no periodic ramp the scan tried makes this loop grow, and the bracket says so
    assert math.isinf(bracket.unstable) and "no growing periodic ramp" in bracket.message


def test_rate_bracket_finds_growth_above_the_certificate():
    """A lightly damped oscillator whose stiffness ramps between 1 and 9 1/s²: parametric resonance above."""
    pytest.importorskip("cvxpy")
    k = sr.Parameter("k", "1/s²", (1.0, 9.0))
    oscillator = sr.UncertainPlant.from_expressions([k], [[0, 1], ["-k", -0.1]], [[0], [1]], form="state")
    bracket = sr.rate_bracket(oscillator, np.zeros((1, 2)))
    assert 0 < bracket.rate < bracket.unstable < math.inf
    # the other side, recomputed: a growing Floquet multiplier at the upper rate
    ramp = 8.0 / bracket.unstable
    assert max(sr.parameter_switching_growth(oscillator, np.zeros((1, 2)), "k", bracket.unstable, hold_high=h,
                                             hold_low=h) for h in (0.0, ramp, 4 * ramp)) > 0
    # and an independent check of that growth: integrate one period of the ramp with scipy
    rate = bracket.unstable
    for h in (0.0, ramp, 4 * ramp):
        period = 2 * h + 2 * ramp

        def k_of(t, h=h, period=period):
            t = t % period
            if t < h:
                return 9.0
            if t < h + ramp:
                return 9.0 - rate * (t - h)
            if t < 2 * h + ramp:
                return 1.0
            return 1.0 + rate * (t - 2 * h - ramp)

        def f(t, x, k_of=k_of):
            return [x[1], -k_of(t) * x[0] - 0.1 * x[1]]

        monodromy = np.column_stack([solve_ivp(f, (0, period), e, rtol=1e-10, atol=1e-12, max_step=ramp / 50).y[:, -1]
                                     for e in np.eye(2)])
        growth = np.log(np.abs(np.linalg.eigvals(monodromy)).max()) / period
        expected = sr.parameter_switching_growth(oscillator, np.zeros((1, 2)), "k", rate, hold_high=h, hold_low=h,
                                                 n_ramp=400)
        assert growth == pytest.approx(expected, abs=2e-3)


# --- the SCARA through the plant type ---------------------------------------------------------

REFERENCE = json.loads((ROOT / "tests" / "data" / "scara_reference.json").read_text())


@pytest.mark.parametrize("bounds", ["paper", "derived"])
def test_scara_plant_gives_the_element_models_exactly(bounds):
    plant = sr.scara_uncertain_plant(bounds=bounds)
    old = sr.paper_model() if bounds == "paper" else sr.derived_model()
    new = plant.interval_model()
    assert new.elements == old.elements
    assert np.array_equal(new.A, old.A) and np.array_equal(new.B, old.B)


def test_scara_plant_samples_are_the_physical_samples():
    s = sr.scara_uncertain_plant().samples({"t_ref": 37, "m_p": 5})
    p = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 37), n_masses=5)
    assert np.array_equal(s.A, p.A) and np.array_equal(s.B, p.B)
    assert np.array_equal(s.column("m_p"), p.masses) and np.array_equal(s.column("t_ref"), p.times)


@pytest.mark.parametrize("bounds", ["paper", "derived"])
def test_scara_numbers_are_those_of_the_element_code(bounds):
    """K, max λ(Z) and the exact margins at (3, 90), recorded with the element-level code (tests/data)."""
    ref = REFERENCE[bounds]
    plant = sr.scara_uncertain_plant(bounds=bounds)
    d = sr.design(plant, 3.0, 90.0)
    assert np.allclose(d.K, ref["K"], rtol=1e-12, atol=0)
    assert sr.certify(plant, d).max_eig == pytest.approx(ref["max_eig"], rel=1e-9)
    for method in ("theorem1", "vertex", "frozen"):
        assert sr.robustness_margin(plant, d, method).theta == pytest.approx(ref[method], rel=1e-9), method


def test_scara_payload_margin_through_the_plant_is_that_of_the_element_code():
    """payload_margin samples the robot as an UncertainPlant over (t_ref, m_p); its numbers are unchanged."""
    ref = REFERENCE["payload"]
    d = sr.design(sr.paper_model(), 3.0, 90.0)
    table = sr.payload_margin(d, methods=("payload-design-P", "payload-frozen")).set_index("method")
    assert table.loc["payload-design-P", "mass [kg]"] == pytest.approx(ref["payload-design-P"], rel=1e-12)
    assert table.loc["payload-frozen", "mass [kg]"] == pytest.approx(ref["payload-frozen"], rel=1e-12)


# --- runs and export -----------------------------------------------------------------------------

@pytest.mark.parametrize("profile", ["sinusoid", "random-walk", "ramp"])
def test_motor_tracks_with_varying_inertia(motor, profile):
    d = sr.design(motor, 1.0, 10.0)
    p = sr.parameter_profile(motor, "J", profile, t_final=20.0, seed=3)
    run = sr.simulate_plant(motor, d.K, profiles={"J": p}, t_final=20.0)
    assert run.status == "tracking", run.reason
    J = run.p[motor.names.index("J")]
    assert J.min() >= 2e-4 - 1e-12 and J.max() <= 6e-4 + 1e-12
    assert run.max_rate[motor.names.index("J")] <= 4e-4 * (1 + 1e-6)  # within the file's rate bound
    assert J.max() - J.min() > 1e-4  # J did vary


def test_simulation_matches_the_frozen_linear_response(motor):
    """With J held, the loop is LTI: python-control's step response of the closed loop is the same run."""
    d = sr.design(motor, 1.0, 10.0)
    run = sr.simulate_plant(motor, d.K, profiles={"J": lambda t: 4e-4}, t_final=5.0, n_points=501)
    A, B = motor.frozen({"J": 4e-4})
    # x = [∫e, e, ė] with r a unit step: ẋ = (A − BK)x + [1, 0, 0]ᵀ r' ... from e(0) = 1: y = 1 − e
    closed = ct.ss(A - B @ d.K, np.zeros((3, 1)), [[0, 1, 0]], 0)
    response = ct.initial_response(closed, run.t, X0=[0.0, 1.0, 0.0])
    assert np.allclose(run.e[0], np.asarray(response.outputs).ravel(), atol=1e-6)


@pytest.mark.skipif(CC is None, reason="no C compiler `cc` on this machine: the exported C is not compiled")
def test_single_precision_export_compiles_and_matches(motor, tmp_path):
    d = sr.design(motor, 1.0, 10.0)
    pid = d.discretize(5e-4)
    files = sr.export_controller(pid, tmp_path, prefix="motor_pid", precision="single",
                                 outputs=motor.outputs, inputs=motor.inputs)
    header = files[0].read_text()
    assert "u = current [A]" in header and "const float e[1]" in header and "double" not in files[1].read_text()
    main_c = """#include <stdio.h>
#include "motor_pid.h"
int main(void) {
    motor_pid_state s; float e[1], ed[1], u[1]; double a, b;
    motor_pid_init(&s);
    while (scanf("%lf %lf", &a, &b) == 2) { e[0] = (float)a; ed[0] = (float)b; motor_pid_step(&s, e, ed, u);
        printf("%.9g\\n", (double)u[0]); }
    return 0;
}
"""
    (tmp_path / "main.c").write_text(main_c)
    exe = tmp_path / "replay"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off", "-o",
                    str(exe), str(tmp_path / "main.c"), str(files[1])], check=True, capture_output=True, timeout=120)
    rng = np.random.default_rng(0)
    e = np.cumsum(rng.normal(0, 0.01, 2000))
    ed = np.gradient(e, 5e-4)
    out = subprocess.run([str(exe)], input="\n".join(f"{float(a)!r} {float(b)!r}" for a, b in zip(e, ed)), check=True,
                         capture_output=True, text=True, timeout=60).stdout
    u_c = np.array([float(v) for v in out.split()], dtype=np.float32)
    step32 = sr.single_precision_step(pid)
    u_32 = np.array([step32([a], [b])[0] for a, b in zip(e, ed)], dtype=np.float32)
    assert np.array_equal(u_c, u_32)  # same float32 operations in the same order
    pid.reset()
    u_64 = np.array([pid.step([a], [b])[0] for a, b in zip(e, ed)])
    assert np.abs(u_32 - u_64).max() <= 1e-5 * np.abs(u_64).max()


# --- the second example plant ------------------------------------------------------------------

def test_second_plant_has_another_shape(carts):
    assert (carts.n_states, carts.n_inputs, len(carts.varying)) == (4, 2, 2)
    hull = carts.interval_model()
    assert hull.n_states == 6 and hull.n_elements == 6
    samples = carts.samples()
    lo = hull.matrices_at(hull.lower_bounds())
    hi = hull.matrices_at(hull.upper_bounds())
    assert (samples.A >= lo[0] - 1e-12).all() and (samples.A <= hi[0] + 1e-12).all()
    assert (samples.B >= lo[1] - 1e-12).all() and (samples.B <= hi[1] + 1e-12).all()


@pytest.mark.slow  # eight 7-s runs against the element code's table (make test-slow)
def test_scara_compare_table_is_that_of_the_element_code(capsys):
    """The compare command designs its PID through the plant type; every run is the element code's."""
    assert main(["compare", "--t-final", "7", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    ref = REFERENCE["compare"]
    assert [(r["controller"], r["scenario"], r["status"]) for r in rows] == [
        (r["controller"], r["scenario"], r["status"]) for r in ref]
    for new, old in zip(rows, ref):
        for key, value in old.items():
            if isinstance(value, float):
                assert new[key] == pytest.approx(value, rel=1e-6), (new["controller"], key)


# --- bad plant files: one line, exit 2, nothing written ------------------------------------------

MOTOR_TEXT = MOTOR.read_text(encoding="utf-8")
PLANT_FILE_CASES = [
    ("min-above-max", ("range = [2e-4, 6e-4]", "range = [6e-4, 2e-4]"),
     "field `parameters.J.range` must have lower <= upper, found [0.0006, 0.0002] kg·m²"),
    ("unit-missing", ('unit = "kg·m²"\n', ""), "missing field `parameters.J.unit`"),
    ("unit-empty", ('unit = "kg·m²"', 'unit = " "'), "`parameters.J.unit` must name the unit"),
    ("unknown-name", ('["kt/J"]', '["kt/Jx"]'), "names `Jx`, which is not a parameter"),
    ("import", ('"-b/J"', "\"__import__('os').system('touch pwned')\""), "which is not an allowed function"),
    ("attribute", ('"-b/J"', '"J.__class__"'), "Attribute is not allowed"),
    ("rate-without-range", ("value = 1e-4\n", "value = 1e-4\nrate = 1.0\n"),
     "field `parameters.b.rate` bounds the change of a parameter with a `range`"),
    ("divides-by-zero", ("range = [2e-4, 6e-4]", "range = [0.0, 6e-4]"), "field `A[1][1]` is -inf at J = 0 kg·m²"),
    ("input-vanishes", ('["kt/J"]', '["kt*(J - 2e-4)/J"]'),
     "input rows B_u (p = 1) have rank 0 < 1 at J = 0.0002 kg·m²"),
    ("unknown-field", ("samples = 9", "sample = 9"), "unknown field `parameters.J.sample`"),
]


@pytest.mark.parametrize(("name", "edit", "needle"), PLANT_FILE_CASES, ids=[c[0] for c in PLANT_FILE_CASES])
@pytest.mark.parametrize("command", ["margin", "export", "simulate"])
def test_bad_plant_file_is_one_line_and_writes_nothing(capsys, tmp_path, monkeypatch, name, edit, needle, command):
    old, new = edit
    assert old in MOTOR_TEXT
    bad = tmp_path / "plant.toml"
    bad.write_text(MOTOR_TEXT.replace(old, new, 1), encoding="utf-8")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    monkeypatch.chdir(out_dir)
    argv = {"margin": ["margin", "--model", str(bad), "--rho", "1", "--eta", "10", "--output", "m.txt"],
            "export": ["export", "--model", str(bad), "--rho", "1", "--eta", "10", "--ts", "5e-4", "--output", "."],
            "simulate": ["simulate", "--model", str(bad), "--rho", "1", "--eta", "10", "--output", "run.csv"]}[command]
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("scara_robust: error:")
    assert needle in err and str(bad) in err and "Traceback" not in err
    assert list(out_dir.iterdir()) == []  # nothing written, no temporary left
    assert not (out_dir / "pwned").exists()


def test_certificate_table_runs_the_rows_asked_for(motor):
    d = sr.design(motor, 1.0, 10.0)
    table = sr.certificate_table(motor, d, methods=["lmi-physical", "vertex-box"])
    assert table["method"].tolist() == ["vertex-box", "lmi-physical"]  # in the table's own order
    assert table["certified"].tolist() == [True, True]
    with pytest.raises(sr.ArgumentValueError, match="`methods` must be one of"):
        sr.certificate_table(motor, d, methods=["vertex"])


def test_spectral_abscissae_on_threads_equal_numpys_bit_for_bit(monkeypatch):
    """The frozen scans split a stack of loops between threads: the values are numpy's own."""
    from scara_robust.robustness import _spectra

    rng = np.random.default_rng(11)
    stack = rng.standard_normal((1001, 9, 9))
    expected = np.linalg.eigvals(stack).real.max(axis=-1)
    monkeypatch.setattr(_spectra, "_workers", lambda: 3)  # three threads, uneven parts
    assert np.array_equal(_spectra.spectral_abscissae(stack), expected)
    monkeypatch.setattr(_spectra, "_workers", lambda: 1)
    assert np.array_equal(_spectra.spectral_abscissae(stack), expected)
    assert np.array_equal(_spectra.spectral_abscissae(stack[:5]), expected[:5])  # below the threads' threshold


def test_numpy_s_checks_of_a_p_on_threads_are_those_of_one_call(monkeypatch):
    """decay_rate, verify_lyapunov and decay_floor: the same values as one call on all loops, bit for bit."""
    from scara_robust.robustness import _spectra, lmi

    rng = np.random.default_rng(12)
    loops = 0.3 * rng.standard_normal((777, 6, 6)) - 2.0 * np.eye(6)
    X = rng.standard_normal((6, 6))
    P = X @ X.T + 6 * np.eye(6)
    w, V = np.linalg.eigh(P)
    root = V @ np.diag(w**-0.5) @ V.T
    PA = P @ loops
    rate = float(-np.linalg.eigvalsh(root @ (PA + np.swapaxes(PA, 1, 2)) @ root)[:, -1].max() / 2)
    largest = float(np.linalg.eigvalsh(PA + np.swapaxes(PA, 1, 2))[:, -1].max())
    floor = float(lmi.DECAY_FLOOR_RTOL * np.linalg.norm(loops, 2, axis=(1, 2)).max())
    # the largest 2-norm from the few loops whose Frobenius norm can reach it: numpy's value, bit for bit
    for scale in (1e-6, 1.0, 1e6):
        scaled = scale * loops * rng.uniform(0.5, 2.0, size=(len(loops), 1, 1))
        assert lmi._largest_spectral_norm(scaled) == float(np.linalg.norm(scaled, 2, axis=(1, 2)).max())
    for workers in (3, 1):
        monkeypatch.setattr(_spectra, "_workers", lambda: workers)  # noqa: B023
        assert lmi.decay_rate(loops, P) == rate and lmi.verify_lyapunov(loops, P)[0] == largest
        assert lmi.decay_floor(loops) == floor


@pytest.mark.parametrize("case", ["family", "spread", "near-ties", "not-first", "rounded", "small", "not-finite"])
def test_the_largest_eigenvalue_of_a_stack_is_numpy_s_bit_for_bit(case, monkeypatch):
    """largest_eigenvalue: eigvalsh(stack)[:, -1].max(), whichever matrices its screen sends to their eigenvalues."""
    from scara_robust.robustness import _spectra

    rng = np.random.default_rng(21)
    X = rng.standard_normal((700, 6, 6))
    stack = -(X @ np.swapaxes(X, 1, 2)) - 0.5 * np.eye(6)  # negative definite, λmax spread over the stack
    factored = []
    factors = _spectra._factors
    monkeypatch.setattr(_spectra, "_factors", lambda part: factored.append(len(part)) or factors(part))
    if case == "family":  # nearby matrices (a grid of loops): the first screen clears the whole stack
        Y = rng.standard_normal((6, 6))
        stack = -(Y @ Y.T) - np.eye(6) + 0.05 * (X + np.swapaxes(X, 1, 2))
    elif case == "near-ties":  # a hundred matrices within rounding of the largest: they fail the screen, in chunks
        stack[::7] = stack[0] * (1.0 + 1e-15 * rng.standard_normal((100, 1, 1)))
    elif case == "not-first":  # the largest far from what the stack's mean points to: found by the chunks
        stack[433] = -np.diag([1e-3, 50.0, 50.0, 50.0, 50.0, 50.0])
    elif case == "rounded":  # P^(-1/2) S P^(-1/2), as decay_rate forms it: symmetric but for rounding
        Y = rng.standard_normal((6, 6))
        w, V = np.linalg.eigh(Y @ Y.T + np.eye(6))
        root = V @ np.diag(w**-0.5) @ V.T
        stack = root @ stack @ root
        assert not np.array_equal(stack, np.swapaxes(stack, 1, 2))
    elif case == "small":
        stack = stack[:_spectra._SCREEN_FROM]
    elif case == "not-finite":  # numpy refuses it; so does the screen, the same way
        stack[5, 2, 1] = np.nan
        with pytest.raises(np.linalg.LinAlgError):
            np.linalg.eigvalsh(stack)
        with pytest.raises(np.linalg.LinAlgError):
            _spectra.largest_eigenvalue(stack)
        return
    expected = float(np.linalg.eigvalsh(stack)[:, -1].max())
    assert _spectra.largest_eigenvalue(stack) == expected
    if case == "family":
        assert factored == [700 - _spectra._SCREEN_FIRST]  # one factorization, the eigenvalues of 8 matrices
    elif case in ("spread", "near-ties", "not-first"):
        assert len(factored) > 1  # the screen failed on the whole stack: the chunks answered
    if case in ("spread", "near-ties", "not-first"):
        assert _spectra.largest_eigenvalue(stack.copy()) == expected  # no state kept between calls


def test_a_stability_scan_asks_the_last_unstable_matrices_first():
    """A bisection's unstable steps: answered by the matrices the last unstable answer found, the same answers."""
    from scara_robust.robustness import _spectra

    rng = np.random.default_rng(6)
    n = 6
    base = rng.standard_normal((400, n, n)) / math.sqrt(n)
    base -= (np.linalg.eigvals(base).real.max(axis=-1) + 1.0)[:, None, None] * np.eye(n)  # abscissae -1
    direction = np.zeros_like(base)
    direction[[17, 250]] = np.eye(n)  # two matrices cross the axis, at s = 1
    calls = []
    real = _spectra.spectral_abscissae

    def counted(matrices):
        calls.append(len(matrices))
        return real(matrices)

    for strict in (False, True):
        scan, lo, hi = _spectra.StabilityScan(strict=strict), 0.0, 2.0
        assert scan.all_stable(base) and not scan.all_stable(base + hi * direction)
        while hi - lo > 1e-9:
            mid = 0.5 * (lo + hi)
            stack = base + mid * direction
            expected = bool(np.linalg.eigvals(stack).real.max() < 0 if strict else
                            np.linalg.eigvals(stack).real.max() <= 0)
            calls.clear()
            with pytest.MonkeyPatch.context() as patch:
                patch.setattr(_spectra, "spectral_abscissae", counted)
                assert scan.all_stable(stack) is expected
            if not expected:  # the two matrices found last, their eigenvalues alone
                assert calls == [2]
            lo, hi = (mid, hi) if expected else (lo, mid)
        assert hi == pytest.approx(1.0, abs=1e-8)


def test_a_stability_scan_answers_as_the_eigenvalues_do_and_factors_where_it_can():
    """StabilityScan: on a sequence of nearby stacks, the answer of max Re λ < 0 and its P's residual."""
    from scara_robust.robustness import _spectra

    rng = np.random.default_rng(5)
    n = 12
    base = rng.standard_normal((300, n, n)) / math.sqrt(n)
    shift = np.linalg.eigvals(base).real.max(axis=-1)  # each matrix's abscissa moved to -1 at s = 0
    direction = 0.4 * rng.standard_normal((300, n, n)) / math.sqrt(n)
    scan = _spectra.StabilityScan()
    answers = []
    for s in np.linspace(0.0, 3.0, 61):  # nearby stacks; some become unstable along the way
        stack = base - (shift + 1.0)[:, None, None] * np.eye(n) + s * direction
        expected = bool(np.linalg.eigvals(stack).real.max() < 0)
        assert scan.all_stable(stack) is expected
        answers.append(expected)
    assert True in answers and False in answers  # both answers were asked
    assert scan.by_lyapunov > scan.by_eigenvalues  # most were decided by a kept P
    # the candidates are P = V⁻ᴴV⁻¹: AᵀP + PA = V⁻ᴴ diag(2 Re λ) V⁻¹ ≺ 0, and P ≻ 0
    A = base[:20] - (shift[:20] + 1.0)[:, None, None] * np.eye(n)
    P = _spectra._lyapunov_candidates(A)
    lam, V = np.linalg.eig(A)
    Vinv = np.linalg.inv(V)
    rhs = (np.swapaxes(Vinv, 1, 2).conj() @ (2 * lam.real[:, :, None] * Vinv)).real
    assert np.linalg.eigvalsh(rhs)[:, -1].max() < 0
    residual = np.swapaxes(A, 1, 2) @ P + P @ A - rhs
    assert np.abs(residual).max() <= 1e-10 * np.abs(rhs).max()
    assert np.linalg.eigvalsh(P)[:, 0].min() > 0
    # a kept P does not pass a non-finite matrix: its eigenvalues are asked, and numpy refuses it
    bad = A.copy()
    bad[3, 0, 0] = np.nan
    scan = _spectra.StabilityScan()
    assert scan.all_stable(A)
    with pytest.raises(np.linalg.LinAlgError):
        scan.all_stable(bad)


def test_a_non_strict_scan_and_the_chunked_factorization_answer_as_their_definitions():
    """StabilityScan(strict=False) is ``max Re λ <= 0``; the chunked Cholesky is one dpotrf per matrix."""
    from scipy.linalg.lapack import dpotrf

    from scara_robust.robustness import _spectra

    # an integrator's exactly-zero eigenvalue: not Hurwitz, and not unstable either
    marginal = np.array([[[0.0, 1.0], [0.0, -1.0]], [[-1.0, 0.0], [0.0, -2.0]]])
    assert not _spectra.StabilityScan().all_stable(marginal)
    assert _spectra.StabilityScan(strict=False).all_stable(marginal)
    assert not _spectra.StabilityScan(strict=False).all_stable(marginal + 1e-9 * np.eye(2))
    # a stack in which a few matrices, in two chunks, are not positive definite
    rng = np.random.default_rng(8)
    X = rng.standard_normal((300, 6, 6))
    stack = X @ np.swapaxes(X, 1, 2) + 0.1 * np.eye(6)
    shift = np.zeros(300)
    shift[[5, 70, 71, 299]] = 50.0  # beyond their smallest eigenvalues
    stack[140, 0, 0] = np.nan
    expected = [bool(np.isfinite(m).all()) and dpotrf(m - c * np.eye(6), lower=1, clean=0)[1] == 0
                for m, c in zip(stack, shift)]
    got = _spectra.positive_definite(stack, shift)
    assert got.tolist() == expected and not got[[5, 70, 71, 140, 299]].any() and got.sum() == 295
    assert _spectra.positive_definite(stack[:64], np.zeros(64)).all()  # the whole stack at once


def test_a_reference_is_sampled_once_per_distinct_time_with_the_values_of_each_time():
    """Reference.sample on a grid that repeats its times: the values of one call per time, in order."""
    calls = []

    def position(t):
        calls.append(t)
        return np.array([np.sin(t), t**2])

    ref = sr.Reference(position, lambda t: np.array([np.cos(t), 2 * t]), lambda t: np.array([-np.sin(t), 2.0]))
    times = np.repeat(np.linspace(0.0, 3.0, 7), 4)[::-1].copy()
    r, rd, rdd = ref.sample(times)
    assert len(calls) == 7  # each distinct time once
    np.testing.assert_array_equal(r, np.array([position(t) for t in times]))
    np.testing.assert_array_equal(rd[:, 1], 2 * times)
    np.testing.assert_array_equal(rdd[:, 0], -np.sin(times))
