"""The compiled engine (numba): same model, same runs, same tables as the scipy reference."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import scara_robust as sr
from scara_robust.simulation import compiled
from scara_robust.simulation.engines import ENGINES, integrate
from scara_robust.simulation.loop import ClosedLoop
from scara_robust.studies.campaign.runner import resolve_engine, run_draw, run_draws

pytestmark = pytest.mark.compiled


def _loop(name, payload=None, **options):
    ctrl = sr.make_controller(name, **options)
    return ClosedLoop(ctrl, sr.ScaraParams(), payload or sr.paper_payload(), sr.paper_reference(),
                      sr.paper_disturbance(), sr.CONTROLLERS[name].Ts)


@pytest.mark.parametrize("name", ["pid", "smc", "smc-sign"])
def test_compiled_right_hand_side_and_torque_are_the_python_ones(name):
    loop = _loop(name, torque_limit=40.0)
    kernels = compiled._build()
    th = compiled.pack_loop(loop)
    rng = np.random.default_rng(1)
    for _ in range(50):
        x = rng.normal(size=loop.n_states) * np.r_[1, 1, 3, 3, 0.5, 0.5][:loop.n_states]
        t = float(rng.uniform(0, 20))
        tc = np.zeros(2)
        kernels["torque"](th, t, x, tc)
        assert np.allclose(tc, loop.torque(t, x), rtol=1e-12, atol=1e-12)
        td = float(sr.paper_disturbance()(t)[0])
        dx = np.zeros(loop.n_states)
        kernels["rhs"](th, t, x, tc, td, dx)
        assert np.allclose(dx, loop.rhs(t, x, tc, np.array([td, td])), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("scenario", ["large", "small"])
@pytest.mark.parametrize("name", ["pid", "smc", "smc-sign"])
def test_paper_scenarios_agree_with_the_scipy_reference(name, scenario):
    payload_on = name == "pid"  # the sliding-mode figures run without payload (Figures 4-5)
    ref = sr.run_scenario(name, scenario, payload_on=payload_on)
    fast = sr.run_scenario(name, scenario, payload_on=payload_on, method="compiled")
    assert fast.method == "compiled" and fast.status == ref.status == "tracking"
    a, b = ref.metrics(), fast.metrics()
    assert abs(a.max_abs_error - b.max_abs_error) <= 1e-6
    assert abs(a.max_abs_torque - b.max_abs_torque) <= 1e-4
    assert abs(ref.peak_torque - fast.peak_torque) <= 1e-4
    assert np.array_equal(ref.t, fast.t) and np.abs(ref.e - fast.e).max() <= 1e-6


@pytest.mark.parametrize("n_draws", [2, pytest.param(20, marks=pytest.mark.slow)], ids=["2-draws", "20-draws"])
def test_random_campaign_draws_agree(tmp_path, n_draws):
    spec = sr.load_spec("examples/campaign.toml")
    spec = type(spec)(**{**spec.__dict__, "t_final": 6.5})
    for index in range(n_draws):
        draw = sr.draw_scenario(spec, 11, index)
        for ref, fast in zip(run_draw(spec, draw, "scipy"), run_draw(spec, draw, "compiled")):
            assert ref["status"] == fast["status"], (index, ref["controller"])
            assert abs(ref["max_abs_error_after_6s"] - fast["max_abs_error_after_6s"]) <= 1e-6
            assert abs(ref["max_abs_torque_after_6s"] - fast["max_abs_torque_after_6s"]) <= 1e-4
            assert abs(ref["peak_torque"] - fast["peak_torque"]) <= 1e-4


def test_a_diverging_run_is_frozen_where_the_reference_freezes_it():
    K = -0.2 * sr.design(sr.paper_model(), 3, 90).K  # positive feedback: the loop runs away
    ref = sr.run_scenario("pid", "small", K=K, t_final=5.0)
    fast = sr.run_scenario("pid", "small", K=K, t_final=5.0, method="compiled")
    assert ref.diverged and fast.diverged and fast.status == ref.status == "diverged"
    assert fast.message == ref.message and fast.t[-1] == ref.t[-1]


def test_batch_equals_single_runs_and_the_segment_engine_agrees():
    loops = [_loop("pid", payload=sr.ConstantPayload(m)) for m in (0.0, 1.0, 3.0)]
    x0s = [np.r_[sr.SCENARIOS["small"].initial_state(sr.paper_reference()), 0.0, 0.0] for _ in loops]
    batch = compiled.compiled_batch(loops, x0s, 2.0)
    for loop, x0, run in zip(loops, x0s, batch):
        single = compiled.compiled_run(loop, x0, 2.0)
        assert np.array_equal(single.x, run.x) and single.peak_torque == run.peak_torque
    # the registry's entry through the shared segment loop (one compiled call per segment)
    traj = integrate(ENGINES["compiled"], loops[1], x0s[1], 2.0, dt=1e-3, rtol=1e-8, atol=1e-10,
                     divergence_limit=50.0)
    assert np.abs(traj.x - batch[1].x).max() <= 1e-7  # other step sequences, same tolerances


def test_compiled_engine_refuses_loops_it_cannot_run():
    ctrl = sr.make_controller("pid")
    own = ClosedLoop(ctrl, sr.ScaraParams(), lambda t: 1.0, sr.paper_reference(), sr.paper_disturbance())
    with pytest.raises(sr.ArgumentValueError, match="`method` 'compiled' cannot run this loop: its payload"):
        compiled.pack_loop(own)
    with pytest.raises(sr.ArgumentValueError, match="`method` 'compiled' cannot run this loop: its controller"):
        sr.run_scenario("pid-sampled", "small", t_final=0.1, method="compiled")


def test_without_numba_the_scipy_engines_take_over(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba now raises ImportError
    assert not compiled.numba_available()
    assert resolve_engine("auto") == "scipy"
    with pytest.raises(sr.ArgumentValueError, match="`engine` 'compiled' needs numba"):
        resolve_engine("compiled")
    with pytest.raises(sr.ArgumentValueError, match="`method` 'compiled' needs numba"):
        sr.run_scenario("pid", "small", t_final=0.1, method="compiled")
    spec_file = tmp_path / "s.toml"
    spec_file.write_text('controllers = ["pid"]\nt_final = 6.1\nruns = 1\n')
    table = sr.run_campaign(sr.load_spec(spec_file), tmp_path / "r.csv")
    assert list(table["status"]) == ["tracking"]


def test_campaign_tables_do_not_depend_on_workers_or_chunks_with_the_compiled_engine(tmp_path):
    spec_file = tmp_path / "s.toml"
    spec_file.write_text('controllers = ["pid", "smc-sign"]\nt_final = 6.2\nruns = 4\nseed = 5\n'
                         'payload_peak = { min = 1.0, max = 3.0 }\ninitial_error = { min = -0.2, max = 0.2 }\n')
    spec = sr.load_spec(spec_file)
    one = sr.run_campaign(spec, tmp_path / "a.csv", engine="compiled", chunk_size=4)
    two = sr.run_campaign(spec, tmp_path / "b.csv", engine="compiled", workers=2, chunk_size=1)
    assert one.equals(two) and (one["status"] == "tracking").all()


def test_compile_time_is_measured():
    assert compiled.compile_seconds() > 0


# --- the stiff integrator (BDF, scipy's method in machine code) ------------------------------


def test_difference_array_rescaling_is_scipys():
    from scipy.integrate._ivp.bdf import change_D as scipy_change_D

    from scara_robust.simulation import _kernels

    rng = np.random.default_rng(3)
    work = np.zeros((4, 6, 6))
    for order in range(1, 6):
        for factor in (0.2, 0.5, 1.0, 1.7, 10.0):
            D = rng.normal(size=(8, 6))
            want = D.copy()
            scipy_change_D(want, order, factor)
            _kernels.change_D(D, order, factor, work)
            assert np.allclose(D, want, rtol=1e-13, atol=1e-13), (order, factor)


def test_small_lu_solves_like_lapack():
    from scara_robust.simulation import _kernels

    rng = np.random.default_rng(4)
    for _ in range(20):
        A = rng.normal(size=(6, 6))
        A[0, 0] = 1e-12  # a zero-ish leading pivot: only row exchanges get this right
        b = rng.normal(size=6)
        LU, piv, x = A.copy(), np.zeros(6, np.int64), b.copy()
        _kernels.lu_factor(LU, piv)
        _kernels.lu_solve(LU, piv, x)
        want = np.linalg.solve(A, b)
        assert np.allclose(x, want, rtol=1e-10, atol=1e-12 * np.abs(want).max())


def test_bdf_takes_the_steps_of_scipys_bdf_on_the_python_model():
    """Independent cross-check: scipy's BDF on the Python right-hand side, segment by segment."""
    from scipy.integrate import solve_ivp

    loop = _loop("pid")
    x0 = np.r_[sr.SCENARIOS["large"].initial_state(sr.paper_reference()), 0.0, 0.0]
    t_final = 2.0
    run = compiled.compiled_run(loop, x0, t_final, integrator="bdf")
    torque, rhs = loop.torque, loop.rhs
    edges = np.r_[0.0, loop.disturbance.switching_times(0.0, t_final), t_final]
    x, nfev, states = x0.copy(), 0, [x0[:, None]]
    for a, b in zip(edges[:-1], edges[1:]):
        td = np.asarray(loop.disturbance(0.5 * (a + b)), dtype=float)
        sol = solve_ivp(lambda t, y, td=td: rhs(t, y, torque(t, y), td), (a, b), x, method="BDF", rtol=1e-8,
                        atol=1e-10, dense_output=True)
        assert sol.success
        inside = run.t[(run.t > a) & (run.t <= b)]
        states.append(sol.sol(inside))
        x, nfev = sol.y[:, -1], nfev + sol.nfev
    X = np.hstack(states)
    assert np.abs(X[:4] - run.x[:4]).max() <= 1e-7  # same method, same tolerances: same trajectory
    assert abs(run.rhs_calls - nfev) <= 0.05 * nfev  # and nearly the same work (Jacobians differ)


def test_both_integrators_agree_and_bdf_needs_a_fraction_of_the_calls():
    loop = _loop("pid")
    x0 = np.r_[sr.SCENARIOS["large"].initial_state(sr.paper_reference()), 0.0, 0.0]
    bdf = compiled.compiled_run(loop, x0, 8.0, integrator="bdf")
    dopri = compiled.compiled_run(loop, x0, 8.0, integrator="dopri5")
    assert np.abs(bdf.error - dopri.error)[:2].max() <= 1e-7 and abs(bdf.peak_torque - dopri.peak_torque) <= 1e-5
    assert bdf.rhs_calls < dopri.rhs_calls / 3
    with pytest.raises(sr.ArgumentValueError, match="`integrator` must be one of"):
        compiled.compiled_run(loop, x0, 1.0, integrator="rk45")


def test_run_scenarios_batches_compiled_runs_and_equals_single_runs():
    requests = [
        {"controller": "pid", "scenario": "small", "t_final": 6.5, "method": "compiled"},
        {"controller": "smc", "scenario": "large", "t_final": 6.5, "method": "compiled"},
        {"controller": "nope", "scenario": "small"},
        {"controller": "pid", "scenario": "large", "t_final": 6.5, "method": "compiled",
         "payload": sr.ConstantPayload(2.0)},
        {"controller": "pid", "scenario": "small", "t_final": 6.5},  # lsoda, one by one
    ]
    results = sr.run_scenarios(requests, errors="return")
    assert isinstance(results[2], sr.ArgumentValueError) and "`controller` must be one of" in str(results[2])
    for request, result in zip(requests, results):
        if request["controller"] == "nope":
            continue
        single = sr.run_scenario(**request)
        assert result.method == single.method and result.status == single.status
        assert result.metrics() == single.metrics() and np.array_equal(result.e, single.e)  # bit for bit
    with pytest.raises(sr.ArgumentValueError, match="`controller` must be one of"):
        sr.run_scenarios(requests)
    with pytest.raises(sr.ArgumentValueError, match="`errors` must be one of"):
        sr.run_scenarios(requests, errors="ignore")


def test_a_batched_chunk_gives_the_rows_of_single_draws():
    spec = sr.load_spec("examples/campaign.toml")
    spec = type(spec)(**{**spec.__dict__, "t_final": 6.5})
    draws = [sr.draw_scenario(spec, 3, i) for i in range(3)]
    chunk = run_draws(spec, draws, "compiled")
    one_by_one = [row for draw in draws for row in run_draw(spec, draw, "compiled")]
    assert pd.DataFrame(chunk).equals(pd.DataFrame(one_by_one))


@pytest.mark.slow
@pytest.mark.parametrize("spec_file", ["campaign.toml", "campaign-boundary.toml"])
def test_a_200_scenario_campaign_agrees_with_the_scipy_engines(tmp_path, spec_file):
    """Every status of 200 scenarios, and the metrics, as on the scipy engines (about 4 min each: `make test-slow`).

    The boundary campaign has runs that lose the reference altogether (max |e| of 2 to 21
    rad with the torque pinned at its limit). There both engines, at rtol 1e-8, are about
    1e-5 relative from the converged value (measured on scenario 106, pid-lmi: 14.741221
    rad at rtol 1e-11 on both engines), so those rows are compared relatively.
    """
    spec = sr.load_spec(Path(__file__).resolve().parents[1] / "examples" / spec_file)
    ref = sr.run_campaign(spec, tmp_path / "scipy.csv", runs=200, workers=2, engine="scipy")
    fast = sr.run_campaign(spec, tmp_path / "compiled.csv", runs=200, workers=2, engine="compiled")
    assert len(ref) == 200 * len(spec.controllers)
    assert (ref["status"].to_numpy() == fast["status"].to_numpy()).all()
    tracking = (ref["status"] == "tracking").to_numpy()
    for metric, tol in (("max_abs_error_after_6s", 1e-6), ("max_abs_torque_after_6s", 1e-4), ("peak_torque", 1e-4)):
        a, b = ref[metric].to_numpy(), fast[metric].to_numpy()
        assert np.abs(a - b)[tracking].max() <= tol, metric
        if not tracking.all():
            assert (np.abs(a - b) <= 1e-4 * np.abs(a))[~tracking].all(), metric
