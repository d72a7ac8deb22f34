import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

import scara_robust as sr  # noqa: E402

# One fixed, CI-friendly profile: derandomized (same examples every run), no deadline
# (a Riccati solve may be slow on a loaded machine), few examples per property.
settings.register_profile(
    "ci", max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("ci")


#: Optional extras by marker: the module each one installs.
EXTRAS = {"lmi": "cvxpy", "dask": "distributed", "parquet": "pyarrow", "compiled": "numba", "robots": "pinocchio",
          "mujoco": "mujoco", "app": "bokeh"}
#: `make test` sets this, so that a missing extra fails the run instead of skipping its tests.
REQUIRE_EXTRAS = os.environ.get("SCARA_ROBUST_REQUIRE_EXTRAS") == "1"


def _installed(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def _distribution(name: str) -> bool:
    """True when the distribution `name` is installed (example-robot-data has no importable module of its name)."""
    import importlib.metadata

    try:
        importlib.metadata.distribution(name)
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


#: The test files that take longest, started first: `make test` runs files in this order
#: (``--no-loadscope-reorder``), so each of its two processes takes one of the long files at
#: the start and the short ones fill in, instead of a long file starting last and running alone.
#: Measured per file (a 2-core machine, seconds of one process): the guides' commands 150, the site's build
#: 140, tuning 215, schedules 155, then 40 to 70 each. Tuning's search runs the SCARA's compiled engine,
#: so it starts after the first minutes, once the background compile has written numba's cache. The arm's
#: kernels are not in that warm-up: the first test that runs them compiles them (about 2 min, measured).
LONGEST_FILES = ("test_readme.py", "test_site.py", "test_lint.py", "test_board.py", "test_app.py",
                 "test_controller_ts.py", "test_ros2.py", "test_tracking.py", "test_scheduled.py",
                 "test_campaign_arm.py", "test_one_answer.py", "test_joint_limits.py", "test_app_schedule.py",
                 "test_deploy.py", "test_simulation.py", "test_jitter.py", "test_compiled.py", "test_campaign.py",
                 "test_synthesis.py", "test_arm.py", "test_notebooks.py", "test_robust_certificates.py",
                 "test_plant_type.py")


def pytest_configure(config):
    """Under ``-n`` (make test), warm numba's disk cache of the compiled engine in the background.

    Each process that needs the compiled engine compiles it (about a minute) unless the disk
    cache already holds it; in a fresh clone it does not. One compile started here, while
    the first, long files (which do not use it) run, leaves the cache for every process.
    """
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None) or not _installed("numba"):
        return
    config._numba_warmup = subprocess.Popen([sys.executable, "-c", _WARMUP], cwd=Path(__file__).parent.parent,
                                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


#: The warm-up: the SCARA's kernels, then (with Pinocchio) an arm's, continuous and held, which
#: the arm's test files would otherwise each compile (72 s on one core), at once on both workers.
_WARMUP = """
from scara_robust.simulation.compiled import compile_seconds
compile_seconds()
try:
    import pinocchio  # noqa: F401
except ImportError:
    raise SystemExit(0)
import numpy as np
import scara_robust as sr
setup = sr.load_arm("examples/robot-arm6.toml")
K = sr.design(setup.plant, 1000, 3).K
table = sr.ScheduledGain("m_p", "kg", [0.0, 3.0], np.stack([K, K]))
ramp = sr.parameter_profile(setup.plant, "m_p", "ramp", t_final=0.2)
sr.simulate_arm(setup, table, ramp, t_final=0.2, measurement_bias=0.05, method="compiled")
sr.simulate_arm(setup, K, ramp, t_final=0.2, method="compiled")
sr.simulate_arm(setup, K, ramp, t_final=0.2, method="compiled", Ts=1e-3)
"""


def pytest_unconfigure(config):
    warmup = getattr(config, "_numba_warmup", None)
    if warmup is not None:
        try:
            warmup.wait(timeout=300)
        except subprocess.TimeoutExpired:
            warmup.kill()


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: each file keeps its order


#: `.ci/run` installs the board's Debian packages and sets this, so that their absence fails the run.
REQUIRE_BOARD = os.environ.get("SCARA_ROBUST_REQUIRE_BOARD") == "1"


def pytest_runtest_setup(item):
    if item.get_closest_marker("board") is not None:
        try:
            sr.check_toolchain("cortex-m4f")
        except sr.MissingToolError as err:
            if REQUIRE_BOARD:
                pytest.fail(f"{err} (SCARA_ROBUST_REQUIRE_BOARD=1 requires it)", pytrace=False)
            pytest.skip(str(err))
    if item.get_closest_marker("robot_data") is not None and not _distribution("example-robot-data"):
        pytest.skip("the `robot-data` extra (example-robot-data, about 130 MB) is not installed: "
                    "pip install '.[robot-data]'")  # never required: make test does not install it
    for extra, module in EXTRAS.items():
        if item.get_closest_marker(extra) is None or _installed(module):
            continue
        message = f"the `{extra}` extra ({module}) is not installed: pip install '.[{extra}]'"
        if REQUIRE_EXTRAS:
            pytest.fail(message + " (SCARA_ROBUST_REQUIRE_EXTRAS=1 requires it)", pytrace=False)
        pytest.skip(message)


def pytest_addoption(parser):
    parser.addoption("--lmi-solver", default=None, choices=sr.LMI_BACKENDS,
                     help="the default LMI solver of the whole run (sr.use_lmi_solver): `make test-clarabel` runs "
                          "the LMI tests on cvxpy + Clarabel, the reference")


@pytest.fixture(scope="session", autouse=True)
def _lmi_solver(request):
    """``--lmi-solver NAME``: every analysis called with ``solver=None`` runs on NAME, for the whole session."""
    solver = request.config.getoption("--lmi-solver")
    if solver is None:
        yield None
        return
    with sr.use_lmi_solver(solver):
        yield solver


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="session")
def paper():
    return sr.paper_model()


@pytest.fixture(scope="session")
def paper_design(paper):
    return sr.design(paper, 3.0, 90.0)


@pytest.fixture(scope="session")
def paper_sample_time(paper_design):
    """max_sample_time of (3, 90) on the robot's sampled (A, B): 61 times x 5 masses, verified on 181 x 11."""
    samples = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 61), n_masses=5)
    check = sr.physical_samples(times=np.linspace(0, 2 * np.pi, 181), n_masses=11)
    return sr.max_sample_time(samples, paper_design, check=check, rtol=1e-2)


def random_model(seed: int, n: int = 4, m: int = 2, n_elements: int = 4) -> sr.UncertainLTVModel:
    """A random stabilizable interval model with elements in A and B."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, m))
    positions = [("A", i, j) for i in range(n) for j in range(n)] + [("B", i, k) for i in range(n) for k in range(m)]
    picks = rng.choice(len(positions), size=n_elements, replace=False)
    elements = []
    for p in picks:
        mat, i, j = positions[p]
        lo = rng.uniform(-0.3, 0.0)
        elements.append(sr.UncertainElement(mat, i, j, lo, lo + rng.uniform(0.01, 0.5)))
    return sr.UncertainLTVModel(A, B, tuple(elements), name=f"random-{seed}")
