"""The paper-vs-package table and the figure helpers of the notebooks."""

import numpy as np
import pandas as pd
import pytest

import scara_robust as sr
from scara_robust.plotting import SIGNALS
from scara_robust.simulation.metrics import METRIC_NAMES


@pytest.fixture(scope="module")
def short_comparison():
    # 8-s runs keep the test short; the metrics after 6 s exist from 6 s on.
    return sr.compare_controllers(("pid",), ("large", "small"), t_final=8.0)


@pytest.fixture(scope="module")
def table(short_comparison):
    return sr.reproduction_table(short_comparison)


@pytest.fixture(scope="module")
def short_run():
    return sr.run_scenario("pid", "small", t_final=1.0)


def _row(table, prefix):
    rows = table[table["claim"].str.startswith(prefix)]
    assert len(rows) == 1, prefix
    return rows.iloc[0]


def test_table_shape_and_types(table):
    assert list(table.columns) == ["claim", "source", "paper", "package", "unit", "holds"]
    assert len(table) == 9
    assert table["package"].dtype == float and table["holds"].dtype == bool
    assert set(table["source"]) == {"Section 3", "Section 4", "Figure 2", "Figure 3", "Figure 6"}


def test_certificate_rows_match_an_independent_computation(table, paper, paper_design):
    assert _row(table, "max λ(Z(3, 90))")["package"] == pytest.approx(sr.certify(paper, paper_design).max_eig)
    assert not _row(table, "max λ(Z(3, 90))")["holds"]
    surf = sr.design_surface(paper, np.linspace(0.01, 10, 200), np.linspace(1, 200, 200), formulation="structured")
    assert _row(table, "(ρ, η) with max λ(Z) < 0")["package"] == surf.certified.sum()
    matched = _row(table, "K(3, 90)")
    assert matched["package"] == 9 and not matched["holds"]
    sweep = _row(table, "design-surface sweep")
    assert sweep["package"] > 0 and sweep["holds"] == (sweep["package"] < 5)


@pytest.mark.parametrize(
    ("prefix", "scenario", "metric", "bound"),
    [
        ("large IC: max |e|", "large", "max_abs_error_after_6s", 0.02),
        ("large IC: max |Tc|", "large", "max_abs_torque_after_6s", 7.5),
        ("small IC: initial |Tc|", "small", "peak_torque", 14.5),
        ("small IC: max |Tc|", "small", "max_abs_torque_after_6s", 7.5),
        ("small IC: max |e|", "small", "max_abs_error_after_6s", 0.02),
    ],
    ids=["large-e", "large-Tc", "small-Tc0", "small-Tc", "small-e"],
)
def test_simulation_rows_come_from_the_comparison(table, short_comparison, prefix, scenario, metric, bound):
    row = _row(table, prefix)
    expected = short_comparison.set_index(["controller", "scenario"]).loc[("pid", scenario), metric]
    assert row["package"] == expected
    assert row["holds"] == (expected <= bound)


def test_bad_comparison_tables(short_comparison):
    with pytest.raises(TypeError, match="`comparison` must be a pandas DataFrame"):
        sr.reproduction_table({"controller": "pid"})
    with pytest.raises(ValueError, match=r"`comparison` must have the columns of .*missing \['peak_torque'\]"):
        sr.reproduction_table(short_comparison.drop(columns="peak_torque"))
    off = short_comparison.assign(payload="off")
    with pytest.raises(ValueError, match="one 'pid' row with payload 'on' for scenario 'large', found 0"):
        sr.reproduction_table(off)
    doubled = pd.concat([short_comparison, short_comparison])
    with pytest.raises(ValueError, match="found 2"):
        sr.reproduction_table(doubled)
    assert set(METRIC_NAMES) <= set(short_comparison.columns)


@pytest.mark.parametrize("signal", ["error", "torque"])
def test_plot_signals_one_panel_per_result(short_run, signal):
    fig = sr.plot_signals([short_run, short_run], signal, labels=["a", "b"], title="T", t_start=0.5)
    panels = [ax for ax in fig.axes if ax.get_title() in {"a", "b"}]
    assert len(panels) == 2
    t = panels[0].get_lines()[0].get_xdata()
    assert t.min() >= 0.5 and t.max() == pytest.approx(1.0)
    assert panels[0].get_ylabel() == SIGNALS[signal]
    assert len(fig.axes) == (3 if signal == "error" else 2)  # the disturbance on a panel of its own


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"signal": "speed"}, ValueError, "`signal` must be one of 'error', 'torque'"),
        ({"labels": ["only one", "two"]}, ValueError, r"`labels` must have one entry per result \(1\), found 2"),
        ({"t_start": 5.0}, ValueError, "`t_start` must be at most the final time 1 s, found 5"),
        ({"t_start": -1.0}, ValueError, "`t_start`"),
    ],
    ids=["signal", "labels", "t_start-late", "t_start-negative"],
)
def test_plot_signals_bad_input(short_run, kwargs, error, match):
    with pytest.raises(error, match=match):
        sr.plot_signals([short_run], **kwargs)


def test_plot_signals_needs_a_result():
    with pytest.raises(ValueError, match="`results` must hold at least one SimulationResult"):
        sr.plot_signals([])


def test_plot_response_window(short_run):
    fig = sr.plot_response(short_run, t_start=0.25)
    t = fig.axes[0].get_lines()[0].get_xdata()
    assert t.min() >= 0.25 and np.all(np.diff(t) > 0)


@pytest.mark.parametrize(
    ("elements", "legend"),
    [("all", "no grid point has max λ(Z) < 0"), ("A", "max λ(Z) < 0 (certified)")],
    ids=["all", "A"],
)
def test_contour_legend_says_whether_anything_is_certified(paper, elements, legend):
    s = sr.design_surface(paper, np.linspace(0.5, 5, 6), np.linspace(1, 100, 6), elements)
    ax = sr.plot_surface_contour(s, mark=(3, 90))
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == [legend, "(ρ, η) = (3, 90)"]


def test_error_after_6s_is_the_tail_of_the_slow_transient():
    table = sr.error_sensitivity(t_final=8.0).set_index("case")
    base = table.loc["this package"]
    # the max after 6 s sits just after 6 s and has halved a second later: a decaying transient
    assert 6.0 <= base["at t [s]"] <= 6.5
    assert table["max |e| after 7 s [rad]"].max() < 0.6 * base["max |e| after 6 s [rad]"]
    # L2 and the payload move it by a few per cent; the disturbance's phase by more (phase 0 is favourable)
    physical = table.loc[["L2 = 0.2 m", "L2 = 0.3 m", "L2 = 0.5 m", "payload off"], "max |e| after 6 s [rad]"]
    assert np.all(np.abs(physical / base["max |e| after 6 s [rad]"] - 1) < 0.05)
    phases = table.loc[["phase = 1π/2", "phase = 2π/2", "phase = 3π/2"], "max |e| after 6 s [rad]"]
    assert np.all(phases > base["max |e| after 6 s [rad]"])
