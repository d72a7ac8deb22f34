"""The notebooks in ``notebooks/``: stored without outputs, and every one executes."""

from pathlib import Path

import matplotlib.image as mpimg
import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOK_DIR = Path(__file__).resolve().parents[1] / "notebooks"

#: Each notebook and the PNG files it must write.
NOTEBOOKS = {
    "figure2_design_surface.ipynb": [
        "figure2_contours.png",
        "figure2_surface_derived_all.png",
        "figure2_surface_published_A.png",
        "figure2_surface_published_all.png",
    ],
    "figure3_pid_large_ic.ipynb": ["figure3_pid_large_ic.png", "figure3_pid_large_ic_after_6s.png"],
    "figures4_5_sliding_mode.ipynb": [
        "figure4_smc_errors.png",
        "figure4_smc_errors_after_6s.png",
        "figure5_smc_torques.png",
        "figure5_smc_torques_after_6s.png",
        "figure5_smc_torques_zoom.png",
    ],
    "figure6_pid_small_ic.ipynb": ["figure6_pid_small_ic.png"],
    "comparison.ipynb": ["comparison_metrics.png"],
    "your_own_plant.ipynb": ["own_plant_margin_map.png", "own_plant_run.png"],
    "robustness_margins.ipynb": ["margin_bracket.png", "margin_map_published.png"],
    "deployment.ipynb": ["anti_windup.png"],
    "robot_arm.ipynb": ["arm_run.png"],
}


#: Smaller sizes for the test run (injected after the parameters cell); the notebooks' own
#: defaults are the full sizes.
QUICK = {
    "robustness_margins.ipynb": "N_RHO, N_ETA = 8, 8\nTOL = 0.3",
    "your_own_plant.ipynb": "N_GRID = 8\nT_FINAL = 8.0",
    "deployment.ipynb": "LIMITS = [6.0]\nT_FINAL = 7.0\nN_TIMES, N_MASSES = 31, 3",
    "robot_arm.ipynb": "N_TIMES, N_MASSES = 13, 3\nT_FINAL = 8.0",
}


def _read(name):
    return nbformat.read(NOTEBOOK_DIR / name, as_version=4)


def test_every_notebook_is_listed():
    assert {p.name for p in NOTEBOOK_DIR.glob("*.ipynb")} == set(NOTEBOOKS)


@pytest.mark.parametrize("name", sorted(NOTEBOOKS), ids=sorted(NOTEBOOKS))
def test_stored_without_outputs(name):
    nb = _read(name)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, f"{name} has no code cell"
    dirty = [i for i, c in enumerate(code) if c.outputs or c.execution_count is not None]
    assert dirty == [], f"{name}: code cells {dirty} carry outputs; clear them before committing"


@pytest.mark.parametrize("name", sorted(NOTEBOOKS), ids=sorted(NOTEBOOKS))
def test_notebook_has_one_parameters_cell_first(name):
    nb = _read(name)
    tagged = [i for i, c in enumerate(nb.cells) if "parameters" in c.metadata.get("tags", [])]
    assert len(tagged) == 1
    assert "FIGURE_DIR" in nb.cells[tagged[0]].source
    assert all(c.cell_type == "markdown" for c in nb.cells[: tagged[0]])


#: Executed by `make test-slow`, `make notebooks` and `make docs` (its gallery): the longest even at
#: their test sizes, the three time responses of the paper (run_scenario and plot_response,
#: which tests/test_simulation.py and tests/test_plotting.py check in make test) and Figure 2's
#: surface (design_surface and plot_surface: tests/test_surface.py, tests/test_plotting.py), and the
#: deployment walk-through (its steps: tests/test_deploy.py and the deployment guide in tests/test_readme.py).
SLOW_NOTEBOOKS = ("robustness_margins.ipynb", "comparison.ipynb", "robot_arm.ipynb", "figure3_pid_large_ic.ipynb",
                  "figure6_pid_small_ic.ipynb", "figures4_5_sliding_mode.ipynb", "figure2_design_surface.ipynb",
                  "deployment.ipynb")


@pytest.mark.parametrize("name", [pytest.param(n, id=n, marks=[pytest.mark.slow] if n in SLOW_NOTEBOOKS else [])
                                  for n in sorted(NOTEBOOKS)])
def test_notebook_executes_and_writes_its_figures(name, tmp_path):
    nb = _read(name)
    index = next(i for i, c in enumerate(nb.cells) if "parameters" in c.metadata.get("tags", []))
    # Injected after the parameters cell, as papermill does: figures go to a temporary folder.
    overrides = f"FIGURE_DIR = Path({str(tmp_path)!r})\n" + QUICK.get(name, "")
    nb.cells.insert(index + 1, nbformat.v4.new_code_cell(overrides))
    client = NotebookClient(
        nb,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(NOTEBOOK_DIR)}},
    )
    client.execute()  # raises CellExecutionError on the first failing cell
    inline = sum("image/png" in out.get("data", {}) for cell in nb.cells if cell.cell_type == "code"
                 for out in cell.outputs)
    assert inline >= 1, f"{name} shows no figure inline (the gallery of the documentation shows its outputs)"
    written = sorted(p.name for p in tmp_path.glob("*.png"))
    assert written == sorted(NOTEBOOKS[name])
    for png in written:
        image = mpimg.imread(tmp_path / png)
        assert image.shape[0] >= 300 and image.shape[1] >= 500, png
        assert image[..., :3].std() > 0.05, f"{png} is blank"
