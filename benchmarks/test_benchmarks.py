"""Timing with pytest-benchmark.

``make bench`` enables timing and writes ``benchmark.json``; ``python benchmarks/report.py
benchmark.json`` turns it into the performance page's table of ratios. ``make test`` runs each
benchmark once with ``--benchmark-disable``, at reduced sizes (``benchmark.disabled``), so
none of them can rot and the test suite stays short. Slow references run
a fixed, small number of rounds (``benchmark.pedantic``).
"""

import re
import time

import numpy as np
import pytest

import scara_robust as sr
from scara_robust.simulation.compiled import compile_seconds

GRIDS = {"50x50": 50, "200x200": 200}


@pytest.fixture(scope="module")
def model():
    return sr.paper_model()


@pytest.mark.parametrize("method", ["structured", "reference"], ids=["structured", "reference"])
@pytest.mark.parametrize("grid", list(GRIDS), ids=list(GRIDS))
def test_surface(benchmark, model, grid, method):
    benchmark.group = f"surface {grid}"
    benchmark.extra_info["points"] = GRIDS[grid] ** 2
    # under `make test` (benchmarks disabled) a benchmark only has to run: a small grid
    n = GRIDS[grid] if not benchmark.disabled else 10
    rhos, etas = np.linspace(0.1, 10, n), np.linspace(1, 200, n)
    if method == "reference":
        surface = benchmark.pedantic(
            sr.design_surface, (model, rhos, etas, "all"), {"formulation": method}, rounds=3 if n <= 50 else 1
        )
    else:
        surface = benchmark(sr.design_surface, model, rhos, etas, "all", formulation=method)
    assert surface.max_eig.shape == (n, n) and surface.hurwitz.all()


@pytest.mark.parametrize("method", ["lsoda", "interconnect", "compiled"], ids=["lsoda", "interconnect", "compiled"])
def test_simulation_pid_20s(benchmark, method):
    benchmark.group = "simulation: PID, large IC, 20 s"
    t_final = 20.0 if not benchmark.disabled else 2.0
    if method == "compiled":
        pytest.importorskip("numba")
        benchmark.extra_info["compile_seconds"] = compile_seconds()  # cached on disk after the first time
        res = benchmark(sr.run_scenario, "pid", "large", t_final=t_final, method=method)
    else:
        res = benchmark.pedantic(sr.run_scenario, ("pid", "large"), {"t_final": t_final, "method": method}, rounds=3)
    assert res.success and res.t[-1] == pytest.approx(t_final)


@pytest.mark.parametrize("integrator", ["bdf", "dopri5"])
def test_compiled_integrators(benchmark, integrator):
    """The compiled kernel alone on the PID's 20-s large-IC run: right-hand-side calls and time per call."""
    pytest.importorskip("numba")
    from scara_robust.simulation.loop import ClosedLoop

    benchmark.group = "compiled kernel: PID, large IC, 20 s"
    t_final = 20.0 if not benchmark.disabled else 2.0
    loop = ClosedLoop(sr.make_controller("pid"), sr.ScaraParams(), sr.paper_payload(), sr.paper_reference(),
                      sr.paper_disturbance())
    x0 = np.r_[sr.SCENARIOS["large"].initial_state(sr.paper_reference()), 0.0, 0.0]
    compile_seconds()
    run = benchmark(sr.compiled_run, loop, x0, t_final, integrator=integrator)
    benchmark.extra_info["rhs_calls"] = run.rhs_calls
    assert run.success and run.t[-1] == pytest.approx(t_final)


@pytest.mark.parametrize("engine", ["scipy", "compiled"])
def test_campaign_throughput(benchmark, engine, tmp_path):
    """examples/campaign.toml (PID and sliding mode, 20 s each) on 2 worker processes."""
    if engine == "compiled":
        pytest.importorskip("numba")
    benchmark.group = "campaign: examples/campaign.toml, 2 workers"
    spec = sr.load_spec("examples/campaign.toml")
    # 200 compiled scenarios take about 3 s, so the workers' start (about 0.5 s) weighs little
    runs = (200 if engine == "compiled" else 8) if not benchmark.disabled else 1
    benchmark.extra_info["scenarios"] = runs
    counter = iter(range(1000))

    def campaign():
        return sr.run_campaign(spec, tmp_path / f"r{next(counter)}.csv", runs=runs, workers=2, engine=engine)

    table = benchmark.pedantic(campaign, rounds=1)
    assert len(table) == 2 * runs and (table["status"] == "tracking").all()


def test_arm6_campaign_throughput(benchmark, tmp_path):
    """examples/campaign-arm6.toml on examples/robot-arm6.toml (10 s each, noise and torque limits), 2 workers."""
    pytest.importorskip("numba")
    pytest.importorskip("pinocchio")
    benchmark.group = "campaign: examples/campaign-arm6.toml, 2 workers"
    spec = sr.arm_campaign_spec(sr.load_spec("examples/campaign-arm6.toml"), "examples/robot-arm6.toml")
    runs = 1000 if not benchmark.disabled else 2
    benchmark.extra_info["scenarios"] = runs
    counter = iter(range(1000))

    def campaign():
        return sr.run_campaign(spec, tmp_path / f"r{next(counter)}.parquet", runs=runs, workers=2, engine="compiled")

    table = benchmark.pedantic(campaign, rounds=1)
    benchmark.extra_info["tracking"] = int((table["status"] == "tracking").sum())
    assert len(table) == runs and table["success"].all()


def test_compare(benchmark):
    benchmark.group = "compare: 4 controllers x 2 scenarios, 20 s"
    table = benchmark.pedantic(sr.compare_controllers, kwargs={"t_final": 20.0 if not benchmark.disabled else 6.5},
                               rounds=2)
    assert (table["status"] == "tracking").all() and len(table) == 2 * len(sr.COMPARED_CONTROLLERS)


def _grid50():
    return np.linspace(0.5, 10, 50), np.linspace(1, 200, 50)


def test_margin_map_theorem1(benchmark, model):
    # Ratio against test_surface[50x50-structured]: the limit is 20x.
    benchmark.group = "margin map 50x50"
    rhos, etas = _grid50()
    surface = benchmark(sr.design_surface, model, rhos, etas, "all", measure="margin")
    assert surface.margin.shape == (50, 50) and np.all(surface.margin > 0)


def test_margin_vertex_one_point(benchmark, model):
    benchmark.group = "vertex margin, one design"
    design = sr.design(model, 3.0, 90.0)
    margin = benchmark(sr.robustness_margin, model, design, "vertex")
    assert 0.5 < margin.theta < 0.6


def test_margin_map_vertex(benchmark, model):
    benchmark.group = "margin map 50x50"
    rhos, etas = _grid50()
    if benchmark.disabled:
        rhos, etas = rhos[::10], etas[::10]
    surface = benchmark.pedantic(
        sr.design_surface, (model, rhos, etas, "all"), {"measure": "margin", "margin_method": "vertex"}, rounds=1
    )
    assert surface.margin.shape == (rhos.size, etas.size)


STARTUP = {
    # what every process pays before it computes: the bare package, the whole API (what --help paid
    # before the command line imported only the command given), and the command line's --help
    "import": "import scara_robust",
    "api": "import scara_robust as sr; sr.design",
    "help": "import runpy, sys; sys.argv = ['scara_robust', '--help']; runpy.run_module('scara_robust', "
            "run_name='__main__')",
}


@pytest.mark.parametrize("what", list(STARTUP))
def test_startup(benchmark, what):
    """A fresh interpreter importing the package, as a CLI call, a test worker or a subprocess test does."""
    import subprocess
    import sys

    benchmark.group = "start-up: a new Python process"

    def run():
        done = subprocess.run([sys.executable, "-c", STARTUP[what]], capture_output=True, text=True, check=False)
        assert done.returncode == 0, done.stderr

    benchmark.pedantic(run, rounds=3 if not benchmark.disabled else 1)


def test_scara_margin_command(benchmark, capsys):
    """``margin --rho 3 --eta 90`` after start-up: every row (θ and payload, the LMI bisections included).

    Target: under 5 s on 2 cores. Before the cutting planes, its LMI rows solved each step on all
    1024 corners (and 185 samples): 39 s and 15 s of the 63 s on a loaded machine (docs/performance.md).
    """
    pytest.importorskip("cvxpy")
    import scara_robust.cli._margin  # noqa: F401  start-up: the command's imports, before the clock starts
    from scara_robust.cli import main
    from scara_robust.robustness import lmi

    benchmark.group = "margin --rho 3 --eta 90, SCARA, after start-up"
    argv = ["margin", "--rho", "3", "--eta", "90"] + (["--tol", "0.2"] if benchmark.disabled else [])

    def margin():
        lmi._SOLVED.clear()  # no answer kept from a previous round
        return main(argv)

    assert benchmark.pedantic(margin, rounds=1 if benchmark.disabled else 3) == 0
    out = capsys.readouterr().out
    bracket = re.search(r"^\s+bracket\s+both\s+lower\s+(\S+)\s+(\S+)\s+(\S+)", out, re.M)
    assert bracket is not None, out
    lo, hi = float(bracket.group(2)), float(bracket.group(3))
    benchmark.extra_info["bracket"] = [lo, hi]
    assert 0.5 < lo < hi < 0.7


class _TimedPinocchio:
    """Pinocchio with every call timed: the seconds a run spends inside its functions."""

    def __init__(self, module):
        self._module, self.seconds, self.calls = module, 0.0, 0

    def __getattr__(self, name):
        import time

        target = getattr(self._module, name)
        if not callable(target) or name in ("Motion",):
            return target

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return target(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
                self.calls += 1

        return timed


def _arm_run_split(setup, K, payload, t_final):
    """One arm run with Pinocchio's calls timed: (seconds in Pinocchio, seconds in all, Pinocchio calls)."""
    import time

    timed = _TimedPinocchio(setup.arm._pin)
    original, setup.arm._pin = setup.arm._pin, timed
    try:
        start = time.perf_counter()
        sr.simulate_arm(setup, K, payload, t_final=t_final)
        total = time.perf_counter() - start
    finally:
        setup.arm._pin = original
    return timed.seconds, total, timed.calls


def test_arm6_run_20s(benchmark, tmp_path):
    """The 6-joint arm of examples/ (Pinocchio's ABA, gravity feedforward), a 20-s run with a varying payload."""
    pytest.importorskip("pinocchio")
    import os

    benchmark.group = "arm: 6 joints, 20 s"
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples", "robot-arm6.toml")
    urdf = os.path.join(os.path.dirname(path), "arm6.urdf")
    text = open(path, encoding="utf-8").read().replace('urdf = "arm6.urdf"', f'urdf = "{urdf}"')
    text = re.sub(r"^reference_samples = \d+", "reference_samples = 13", text, flags=re.M)
    text = re.sub(r"^payload_samples = \d+", "payload_samples = 3", text, flags=re.M)
    (tmp_path / "arm.toml").write_text(text, encoding="utf-8")
    setup = sr.load_arm(tmp_path / "arm.toml")
    K = sr.design(setup.plant, 1000, 10).K
    t_final = 20.0 if not benchmark.disabled else 1.0
    payload = sr.parameter_profile(setup.plant, "m_p", "sinusoid", t_final=t_final)
    run = benchmark.pedantic(sr.simulate_arm, (setup, K, payload), {"t_final": t_final}, rounds=2)
    assert run.success and run.t[-1] == pytest.approx(t_final)
    pin_time, total, calls = _arm_run_split(setup, K, payload, t_final)
    benchmark.extra_info.update(pinocchio_seconds=pin_time, timed_seconds=total, pinocchio_calls=calls)
    assert 0 < pin_time < total


@pytest.fixture(scope="module")
def scara_page():
    """The design page's computations for the SCARA of examples/robot-paper.toml (Theorem 1 over ΔA)."""
    pytest.importorskip("bokeh", reason="the app extra")
    from scara_robust.cli import build_parser
    from scara_robust.cli._app import explorer_of

    explorer = explorer_of(build_parser().parse_args(["app", "--robot", "examples/robot-paper.toml", "--elements",
                                                      "A"]))
    explorer.response(explorer.quick(3.0, 90.0).design)  # the compiled engine loaded, as the page does at start
    yield explorer
    explorer.close()


def test_app_click_to_gain(benchmark, scara_page):
    """What a click computes before the page shows K: the design and Theorem 1 (target: well under 100 ms)."""
    answer = benchmark(scara_page.quick, 3.0, 90.0)
    assert answer.certified


def test_app_click_to_gain_reference(benchmark, scara_page):
    """The reference of the same run: the Riccati design alone."""
    benchmark(sr.design, scara_page.model, 3.0, 90.0)


def test_app_response(benchmark, scara_page):
    """The page's 20-s SCARA run on the compiled engine, warm (target: under 300 ms)."""
    d = scara_page.quick(3.0, 90.0).design
    resp = benchmark(scara_page.response, d)
    assert resp.status == "tracking"


@pytest.mark.slow
def test_app_page_in_chromium(benchmark, tmp_path):
    """Click to K and to the 20-s response, painted in headless Chromium: the SCARA page, default grid.

    Targets: K and Theorem 1 under 100 ms, the response under 300 ms. Each click waits 1.5 s
    after its response, as a reader would: the worker process is then usually still computing
    the previous design's slower answers, at its lower priority. The first click, untimed, waits
    for the worker processes to start.
    """
    pytest.importorskip("bokeh", reason="the app extra")
    from scara_robust.cli import build_parser
    from scara_robust.cli._app import explorer_of
    from tests import page_driver as driver

    argv = ["--robot", "examples/robot-paper.toml", "--elements", "A"]
    explorer = explorer_of(build_parser().parse_args(["app", *argv]))
    rounds = 3 if benchmark.disabled else 20
    rng = np.random.default_rng(0)
    points = iter([(int(rng.integers(3, explorer.rhos.size - 3)), int(rng.integers(3, explorer.etas.size - 3)))
                   for _ in range(rounds + 1)])
    times: dict[str, list[float]] = {"K [ms]": [], "response [ms]": []}

    def click(i: int, k: int) -> None:
        rho, eta = float(explorer.rhos[i]), float(explorer.etas[k])
        driver.watch(page, "design", driver.design_label(rho, eta))
        driver.watch(page, "response", driver.response_label(rho, eta))
        driver.click_grid_point(page, explorer.rhos, explorer.etas, i, k)
        times["K [ms]"].append(driver.painted_after_release(page, driver.design_label(rho, eta), 30_000))
        times["response [ms]"].append(driver.painted_after_release(page, driver.response_label(rho, eta), 60_000))
        time.sleep(1.5)

    try:
        with driver.open_page(argv, tmp_path / "stderr.txt") as (page, problems):
            click(*next(points))  # untimed: the worker processes start, the compiled engine loads
            for values in times.values():
                values.clear()
            benchmark.pedantic(click, setup=lambda: (next(points), {}), rounds=rounds, iterations=1)
            assert not problems, problems
    finally:
        explorer.close()
    for key, values in times.items():
        assert len(values) == (1 if benchmark.disabled else rounds)  # disabled, pedantic runs the click once
        benchmark.extra_info[key] = {"median": float(np.median(values)), "p90": float(np.percentile(values, 90)),
                                     "max": float(np.max(values)), "all": [round(v, 1) for v in values]}


_ARM6_ERRORS: dict[float, dict[str, float]] = {}


@pytest.fixture(scope="module")
def arm6_file_setup():
    """examples/robot-arm6.toml as `simulate --robot ... --rho 1000 --eta 3 --profile sinusoid` uses it."""
    pytest.importorskip("pinocchio")
    import os

    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples", "robot-arm6.toml")
    setup = sr.load_arm(path)
    return setup, sr.design(setup.plant, 1000, 3).K


#: Full-size arm runs and solves (a 20-s LSODA run, the arm's LMI on Clarabel): `make bench` and `make test-slow`;
#: tests/test_arm_compiled.py and tests/test_sdp.py check the same engines and solvers at test sizes.
@pytest.mark.slow
@pytest.mark.parametrize("method", ["lsoda", "compiled"], ids=["lsoda", "compiled"])
def test_arm6_compiled_vs_lsoda_20s(benchmark, arm6_file_setup, method):
    """The 6-joint arm's 20-s run (sinusoidal payload): Pinocchio's ABA on LSODA against the compiled engine (BDF)."""
    if method == "compiled":
        pytest.importorskip("numba")
    setup, K = arm6_file_setup
    benchmark.group = "arm: 6 joints, 20 s, compiled vs lsoda"
    t_final = 20.0 if not benchmark.disabled else 2.0
    options = {"t_final": t_final, "t_transient": sr.PAPER_TRANSIENT if not benchmark.disabled else 1.0}
    payload = sr.parameter_profile(setup.plant, "m_p", "sinusoid", t_final=t_final)
    if t_final not in _ARM6_ERRORS:  # both runs once, untimed: their max |e| (and the compiled kernels loaded)
        errors = {m: sr.simulate_arm(setup, K, payload, method=m, **options).metrics().max_abs_error
                  for m in ("lsoda", "compiled")}
        _ARM6_ERRORS[t_final] = {f"max_abs_error_{m} [rad]": e for m, e in errors.items()}
        _ARM6_ERRORS[t_final]["max_abs_error_difference [rad]"] = abs(errors["compiled"] - errors["lsoda"])
    if method == "compiled":
        run = benchmark(sr.simulate_arm, setup, K, payload, method=method, **options)
    else:
        run = benchmark.pedantic(sr.simulate_arm, (setup, K, payload), {"method": method, **options}, rounds=3)
    benchmark.extra_info.update(_ARM6_ERRORS[t_final], integrator="bdf" if method == "compiled" else "")
    assert run.success and run.t[-1] == pytest.approx(t_final)
    assert _ARM6_ERRORS[t_final]["max_abs_error_difference [rad]"] <= 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["IPM", "CLARABEL"], ids=["ipm", "clarabel"])
def test_arm6_sampled_lmi_solve(benchmark, arm6_file_setup, solver):
    """One solve of the sampled-data LMI at Ts = 1 ms on the 6-joint arm's coarse plants (`export`'s certificate).

    The package's interior-point method against cvxpy + Clarabel in the same run, on the same
    95 plants of 18 states: the optimal P (``stop='optimum'``), each verified by numpy; the
    decay rates of the two P's go into the record (docs/performance.md). Each solver's timed
    solve follows one untimed solve.
    """
    if solver == "CLARABEL":
        pytest.importorskip("cvxpy")
    setup, _ = arm6_file_setup
    benchmark.group = "arm: 6 joints, sampled-data LMI at 1 ms, one solve"
    points = setup.plant.coarse_points() if not benchmark.disabled else {"t_ref": 5, "m_p": 2}
    plants = setup.plant.samples(points)
    pid = sr.design(setup.plant, 1000, 3).discretize(0.001)
    # one untimed solve first for each solver: what a process pays once (imports, first calls) is not a solve's;
    # the package's solver (about 1 s a solve) five rounds, Clarabel's (about 20 s) one: single rounds of the
    # fast one varied 0.76-1.10 s on one machine, which alone moved the ratio between 19.5x and 24.9x
    cert = benchmark.pedantic(sr.sampled_certificate, ((plants.A, plants.B), pid), {"solver": solver},
                              rounds=5 if solver == "IPM" else 1, warmup_rounds=1)
    benchmark.extra_info.update(plants=int(plants.A.shape[0]), states=int(cert.P.shape[0]), rate=cert.rate,
                                solver=solver, status=cert.status)
    assert cert.certified and cert.n_plants == plants.A.shape[0]


@pytest.fixture(scope="module")
def arm6_frozen_scales(arm6_file_setup):
    """The 6-joint arm's closed loops at the first 60 scales of its frozen payload search (1, 1.02, 1.02², ...)."""
    setup, K = arm6_file_setup
    return [setup.plant.samples(theta=1.02**k).closed_loops(K) for k in range(60)]


@pytest.mark.slow
@pytest.mark.parametrize("method", ["scan", "eigenvalues"])
def test_arm6_frozen_scan(benchmark, arm6_frozen_scales, method):
    """The frozen search's stability tests on the arm: a kept Lyapunov matrix per loop against every eigenvalue."""
    from scara_robust.robustness._spectra import StabilityScan, spectral_abscissae

    benchmark.group = "arm: 6 joints, frozen payload search's scales, 1 267 loops each"

    stacks = arm6_frozen_scales if not benchmark.disabled else arm6_frozen_scales[:5]

    def scan():
        tester = StabilityScan()
        return [tester.all_stable(loops) for loops in stacks]

    def eigenvalues():
        return [bool(spectral_abscissae(loops).max() < 0) for loops in stacks]

    answers = benchmark.pedantic(scan if method == "scan" else eigenvalues, rounds=3)
    assert answers == eigenvalues()
    benchmark.extra_info.update(scales=len(stacks), loops=int(stacks[0].shape[0]))


@pytest.fixture(scope="module")
def scara_tracking_lmi():
    """The tracking synthesis LMI of `tune` on the SCARA: 30 sampled plants, α = 1/s, κ = 1000 N·m/rad."""
    samples = sr.scara_perturbed_samples(times=np.linspace(0.0, 2 * np.pi, 10), n_masses=3)
    C = np.zeros((2, 6))
    C[:, 2:4] = np.eye(2)
    problem, _ = sr.tracking_synthesis_problem(samples.A, samples.B, samples.disturbance, samples.w_bound, C, 1.0,
                                               1e3)
    return problem


@pytest.mark.parametrize("maps", ["stacked", "terms"])
def test_small_lmi_solve(benchmark, scara_tracking_lmi, maps, monkeypatch):
    """One interior-point solve of a small LMI with the linear map stacked per block size (the default below
    ``DENSE_ENTRIES``) against the same solver applying it term by term, in the same run."""
    import scara_robust.sdp.ipm as ipm

    benchmark.group = "LMI solver: SCARA tracking synthesis (6 states, 30 plants), one solve"
    if maps == "terms":
        monkeypatch.setattr(ipm, "DENSE_ENTRIES", 0)
    result = benchmark(ipm.solve_ipm, scara_tracking_lmi)
    benchmark.extra_info.update(iterations=result.iterations, objective=result.objective, maps=maps)
    assert result.status == "optimal"


@pytest.fixture(scope="module")
def board_pids():
    """The SCARA's PID at (3, 90) with an 8 N·m limit and the 6-joint arm's at (1000, 3), both at Ts = 1 ms."""
    import os

    pytest.importorskip("pinocchio")
    try:
        sr.check_toolchain("cortex-m4f")
    except sr.MissingToolError as err:
        pytest.skip(str(err))
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples", "robot-arm6.toml")
    arm = sr.design(sr.load_arm(path).plant.interval_model(), 1000, 3).discretize(1e-3)
    return {"scara": sr.design(sr.paper_model(), 3, 90).discretize(1e-3, torque_limit=8.0), "arm6": arm}


#: The board's round trips (cross-compile, two emulator runs each) are timed by `make bench` and `make test-slow`;
#: tests/test_board.py runs the same controllers on the board in `make test`.
@pytest.mark.slow
def test_board_arm_pid_with_feedforward_step(benchmark, board_pids):
    """The 6-joint arm's whole controller on the emulated Cortex-M4F: its gravity feedforward by RNEA (double,
    software floating point) and the PID, the URDF's effort limits on the total torque."""
    import os

    benchmark.group = "board: Cortex-M4F PID step"
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples", "robot-arm6.toml")
    setup = sr.load_arm(path)
    pid = sr.design(setup.plant, 1000, 3).discretize(1e-3, torque_limit=list(setup.torque_limit),
                                                        feedforward=sr.arm_feedforward(setup))
    inputs = sr.board_inputs(pid, 10_000)
    run = benchmark.pedantic(sr.run_on_board, (pid, inputs), {"precision": "double"}, rounds=2)
    assert run.agrees
    ins = run.instructions
    benchmark.extra_info.update({
        "instructions min": int(ins.min()), "instructions mean": float(ins.mean()), "instructions max": int(ins.max()),
        "flash [B]": run.flash_bytes, "RAM [B]": run.ram_bytes, "share of Ts": run.share_of_ts,
        "clock [Hz]": run.clock_hz, "max |difference|": run.max_abs_difference})


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["scara", "arm6"])
@pytest.mark.parametrize("precision", ["single", "double"])
def test_board_pid_step(benchmark, board_pids, robot, precision):
    """The exported PID on the emulated Cortex-M4F (QEMU mps2-an386): 10⁴ random steps against Python, the
    instructions of 100 traced steps, flash and RAM. The time measured is the whole round trip (cross-compile,
    two emulator runs); the board's own figures are in extra_info."""
    benchmark.group = "board: Cortex-M4F PID step"
    pid = board_pids[robot]
    inputs = sr.board_inputs(pid, 10_000)
    run = benchmark.pedantic(sr.run_on_board, (pid, inputs), {"precision": precision}, rounds=2)
    assert run.agrees
    ins = run.instructions
    benchmark.extra_info.update({
        "instructions min": int(ins.min()), "instructions mean": float(ins.mean()), "instructions max": int(ins.max()),
        "flash [B]": run.flash_bytes, "RAM [B]": run.ram_bytes, "share of Ts": run.share_of_ts,
        "clock [Hz]": run.clock_hz, "max |difference|": run.max_abs_difference})
