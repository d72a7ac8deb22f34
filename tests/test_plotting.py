"""Figures a control engineer would put in a report: units everywhere, legends off the data, readable scales."""

import re

import numpy as np
import pandas as pd
import pytest

import scara_robust as sr

UNIT = re.compile(r"\[[^\]]+\]|\d (rad|N·m|kg|s)\b")


@pytest.fixture(scope="module")
def large_run():
    return sr.run_scenario("pid", "large", t_final=7.0)


@pytest.fixture(scope="module")
def surface_A():
    return sr.design_surface(sr.paper_model(), np.linspace(0.01, 10, 25), np.linspace(1, 200, 25), "A")


def _labels_have_units(fig):
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            continue
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            assert not label or UNIT.search(label), label
        legend = ax.get_legend()
        if legend is not None:
            for text in legend.get_texts():
                assert UNIT.search(text.get_text()) or "(" in text.get_text(), text.get_text()


def _legend_outside(ax):
    legend = ax.get_legend()
    assert legend is not None
    fig = ax.figure
    fig.canvas.draw()
    box = legend.get_window_extent()
    axes_box = ax.get_window_extent()
    assert box.x0 >= axes_box.x1 - 1 or box.y1 <= axes_box.y0 + 1, "legend sits on the data"


def test_response_has_units_legends_off_the_data_and_its_own_disturbance_panel(large_run):
    fig = sr.plot_response(large_run, bounds=(0.02, 7.5))
    err, trq, sig = fig.axes[:3]
    assert err.get_ylabel() == "joint error [rad]" and trq.get_ylabel() == "control torque [N·m]"
    assert sig.get_ylabel() == "Td [N·m]" and fig.axes[3].get_ylabel() == "m_p [kg]"
    _labels_have_units(fig)
    for ax in (err, trq, sig):
        _legend_outside(ax)
    # the 645 N·m initial spike does not set the scale: the steady torques (±8 N·m) fill it
    low, high = trq.get_ylim()
    assert high < 20 and any("off scale" in t.get_text() for t in trq.texts)
    # the bounds are drawn and named with their unit
    assert any(line.get_label() == "bound ±0.02 rad" for line in err.get_lines())


def test_signals_have_units_and_a_short_window(large_run):
    sign = sr.run_scenario("smc-sign", "small", t_final=0.2)
    fig = sr.plot_signals([sign], "torque", t_start=0.1, t_end=0.13)
    ax = fig.axes[0]
    _labels_have_units(fig)
    assert ax.get_xlim()[1] - ax.get_xlim()[0] < 0.05
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["Tc1 [N·m]", "Tc2 [N·m]"]
    fig = sr.plot_signals([large_run], "error")
    assert fig.axes[-1].get_ylabel() == "Td [N·m]"  # the disturbance on its own panel, not over the errors


def test_surface_shows_the_zero_plane_the_certified_region_and_a_colorbar(surface_A):
    ax = sr.plot_surface(surface_A, mark=(3, 90))
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(label.startswith("max λ(Z) = 0") for label in labels)
    assert any(label.startswith("certified grid points") for label in labels)
    assert any(a.get_label() == "<colorbar>" for a in ax.figure.axes)
    # the ρ -> 0 spike is clipped so the negative region keeps its extent
    assert ax.get_zlim()[1] < surface_A.max_eig.max()


def test_comparison_bound_only_over_the_pid_bars():
    table = pd.DataFrame(
        {
            "controller": ["pid", "pid", "smc", "smc"],
            "scenario": ["large", "small"] * 2,
            "payload": ["on"] * 4,
            "max_abs_error_after_6s": [0.022, 0.011, 0.007, 0.007],
            "max_abs_torque_after_6s": [8.6, 8.6, 8.5, 8.5],
            "chattering_index": [69.0, 69.0, 24000.0, 24000.0],
        }
    )
    fig = sr.plot_comparison(table)
    ax = fig.axes[0]
    segments = [c for c in ax.collections if c.get_label().startswith("paper's PID bound")]
    assert len(segments) == 1
    (x0, _), (x1, _) = segments[0].get_segments()[0]
    assert -0.5 <= x0 < x1 <= 0.5  # over the PID group (x = 0) only
    assert "payload on" in fig._suptitle.get_text() and "Figures 4-5" not in fig._suptitle.get_text()


def test_log_axes_read_as_plain_decimals():
    table = pd.DataFrame(
        {
            "controller": ["pid"] * 3 + ["smc"] * 3,
            "scenario": range(6),
            "success": [True] * 6,
            "status": ["tracking"] * 6,
            "max_abs_error_after_6s": [0.005, 0.006, 0.007, 3.0, 5.0, 9.8],
            "max_abs_torque_after_6s": [6.0, 6.1, 6.2, 6.3, 6.4, 6.5],
        }
    )
    fig = sr.plot_campaign(table)
    fig.canvas.draw()
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    texts = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert texts and all(re.fullmatch(r"[0-9.]+", t) for t in texts), texts
    assert fig.axes[1].get_yscale() == "linear"  # 6.0-6.5 N·m spans no decade


def test_margin_figures(surface_A):
    m = sr.paper_model()
    surface = sr.design_surface(m, np.linspace(0.5, 10, 8), np.linspace(1, 200, 8), measure="margin")
    ax = sr.plot_margin_map(surface, mark=(3, 90))
    _labels_have_units(ax.figure)
    with pytest.raises(sr.ArgumentValueError, match="`surface` has no margins"):
        sr.plot_margin_map(surface_A)
    d = sr.design(m, 3, 90)
    table = pd.DataFrame(
        [("theorem1", "lower", 0.55, 0.55, 0.55), ("frozen", "upper", 0.64, 0.63, 0.64),
         ("bracket", "both", 0.55, 0.55, 0.64)], columns=["method", "kind", "theta", "lo", "hi"])
    ax = sr.plot_margin_bracket({"published": table})
    assert "θ" in ax.get_xlabel() and "[-]" in ax.get_xlabel()
    _legend_outside(ax)
    del d
