"""Figures a control engineer would put in a report: units everywhere, legends off the data, readable scales.

Small inputs (7-s runs, 20 x 20 grids), so the module runs in a few seconds.
"""

import os
import re

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.contour import ContourSet

import scara_robust as sr

EXAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples")
#: A unit in brackets (``[rad]``, ``[N·m]``, ``[-]``) or a number with its unit (``0.02 rad``, ``t = 6 s``).
UNIT = re.compile(r"\[[^\]]+\]|\d (rad|N·m|kg|s)\b")
#: Legend entries of dimensionless statements that `tests/test_reproduction.py` pins word for word.
DIMENSIONLESS = re.compile(r"^\(ρ, η\) = \(|max λ\(Z\) < 0")
#: A plain decimal tick label: ``0.02``, ``50``, ``20000`` (no ``10⁻²``, ``9.8×10⁰``, ``1e+04``).
PLAIN = re.compile(r"[-−]?[0-9]+(\.[0-9]+)?")


@pytest.fixture(scope="module")
def large_run():
    return sr.run_scenario("pid", "large", t_final=7.0)


@pytest.fixture(scope="module")
def small_run():
    return sr.run_scenario("pid", "small", t_final=7.0)


@pytest.fixture(scope="module")
def surface_A():
    """ΔA only: certified for ρ > 1, with the ρ -> 0 spike (max 37 against a 95th percentile of 4.8)."""
    return sr.design_surface(sr.paper_model(), np.linspace(0.1, 10, 20), np.linspace(1, 200, 20), "A")


@pytest.fixture(scope="module")
def surface_all():
    """All ten elements: nothing certified, max λ(Z) > 0 everywhere."""
    return sr.design_surface(sr.paper_model(), np.linspace(0.5, 10, 8), np.linspace(1, 200, 8), "all")


def _check_units(fig):
    """Every axis label names its unit; every legend entry names one or is a dimensionless statement."""
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            continue
        for label in (ax.get_xlabel(), ax.get_ylabel(), getattr(ax, "get_zlabel", str)()):
            assert not label or UNIT.search(label), f"axis label without a unit: {label!r}"
        legend = ax.get_legend()
        for text in legend.get_texts() if legend is not None else []:
            entry = text.get_text()
            assert UNIT.search(entry) or DIMENSIONLESS.search(entry), f"legend entry without a unit: {entry!r}"


def _assert_off_the_data(legend, ax):
    """The legend's box does not overlap the axes' box (it sits beside or below the data)."""
    fig = ax.figure
    fig.canvas.draw()
    box, data = legend.get_window_extent(), ax.get_window_extent()
    overlap_x = min(box.x1, data.x1) - max(box.x0, data.x0)
    overlap_y = min(box.y1, data.y1) - max(box.y0, data.y0)
    assert overlap_x <= 1 or overlap_y <= 1, f"legend {box} sits on the data {data}"


def _legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def _tick_texts(axis):
    return [t.get_text() for t in axis.get_ticklabels() if t.get_text()]


# --- Figures 3 and 6: plot_response -------------------------------------------------------------


def test_response_has_a_panel_each_for_errors_torques_disturbance_and_payload(large_run):
    fig = sr.plot_response(large_run)
    assert len(fig.axes) == 4
    err, trq, sig, mass = fig.axes
    assert [ax.get_ylabel() for ax in fig.axes] == ["joint error [rad]", "control torque [N·m]", "Td [N·m]", "m_p [kg]"]
    assert mass.get_xlabel() == "time t [s]"
    # the disturbance and the payload are drawn on their own axes, not beside the errors
    assert _legend_texts(err) == ["e1 [rad]", "e2 [rad]"]
    assert _legend_texts(sig) == ["Td1 = Td2 [N·m]"] and _legend_texts(mass) == ["m_p [kg]"]
    np.testing.assert_array_equal(sig.get_lines()[0].get_ydata(), large_run.disturbance[0])
    np.testing.assert_array_equal(mass.get_lines()[0].get_ydata(), large_run.payload)
    _check_units(fig)
    for ax in fig.axes:
        _assert_off_the_data(ax.get_legend(), ax)


def test_response_torque_scale_follows_the_steady_torques_and_names_the_spike(large_run):
    fig = sr.plot_response(large_run)
    trq = fig.axes[1]
    assert large_run.torque.max() > 600  # the 645 N·m initial spike of the large initial error
    low, high = trq.get_ylim()
    assert -20 < low and high < 20  # the steady torques (about ±8 N·m) fill the axis
    spike = [t for t in _legend_texts(trq) if t.startswith("peak Tc")]
    assert len(spike) == 1 and "N·m" in spike[0] and "off scale" in spike[0]
    # the error axis is set by the errors alone
    e = np.abs(large_run.e).max()
    assert fig.axes[0].get_ylim()[1] < 1.2 * e


def test_response_bounds_from_the_transient_and_the_initial_torque_bound(small_run):
    fig = sr.plot_response(small_run, bounds=(0.02, 7.5), bounds_after=sr.PAPER_TRANSIENT, initial_torque_bound=14.5)
    err, trq = fig.axes[:2]
    (bound,) = [line for line in err.get_lines() if line.get_label() == "bound ±0.02 rad for t ≥ 6 s"]
    assert bound.get_xdata()[0] == 6.0 and bound.get_ydata()[0] == 0.02
    labels = _legend_texts(trq)
    assert "bound ±7.5 N·m for t ≥ 6 s" in labels and "bound ±14.5 N·m (initial)" in labels
    (initial,) = [line for line in trq.get_lines() if line.get_label() == "bound ±14.5 N·m (initial)"]
    assert initial.get_xdata()[0] == 0.0
    # ±0.01 rad errors fill the error axis; the ±5 N·m square wave is not on it
    assert err.get_ylim()[1] < 0.06
    _check_units(fig)


def test_response_keeps_a_torque_bound_in_view_above_the_steady_torques(large_run):
    fig = sr.plot_response(large_run, bounds=(None, 14.5))
    trq = fig.axes[1]
    assert trq.get_ylim()[1] >= 14.5 and trq.get_ylim()[1] < 20
    assert any(t.startswith("peak Tc") for t in _legend_texts(trq))  # the 645 N·m spike is still off scale


def test_response_refuses_a_negative_bounds_after(small_run):
    with pytest.raises(sr.ArgumentValueError, match="`bounds_after` must be >= 0"):
        sr.plot_response(small_run, bounds=(0.02, 7.5), bounds_after=-1.0)


# --- Figures 4 and 5: plot_signals --------------------------------------------------------------


def test_signals_after_the_transient_have_units_and_the_disturbance_panel(large_run):
    fig = sr.plot_signals([large_run, large_run], "error", labels=["a", "b"], t_start=6.0)
    assert fig.axes[-1].get_ylabel() == "Td [N·m]"
    assert fig.axes[-1].get_xlabel() == "time t [s]"
    assert fig.axes[0].get_xlim()[0] == pytest.approx(6.0)
    assert _legend_texts(fig.axes[0]) == ["e1 [rad]", "e2 [rad]"]
    _check_units(fig)
    for ax in fig.axes:
        _assert_off_the_data(ax.get_legend(), ax)


def test_a_window_of_tens_of_ms_reads_the_switching_in_ms_on_one_scale():
    sign = sr.run_scenario("smc-sign", "small", t_final=0.2)
    smooth = sr.run_scenario("smc", "small", t_final=0.2)
    fig = sr.plot_signals([smooth, sign], "torque", t_start=0.1, t_end=0.13, sharey=True)
    top, bottom = fig.axes
    assert top.get_ylim() == bottom.get_ylim()
    assert bottom.get_xlabel() == "time t − 0.1 s [ms]"
    fig.canvas.draw()
    ticks = _tick_texts(bottom.xaxis)
    assert ticks[0] == "0" and ticks[-1] == "30", ticks
    assert _legend_texts(bottom) == ["Tc1 [N·m]", "Tc2 [N·m]"]
    # a sampled law is drawn as held steps: one jump per 1-ms sample can be read
    assert bottom.get_xlim()[1] - bottom.get_xlim()[0] == pytest.approx(0.03)
    _check_units(fig)


# --- Figure 2: plot_surface and plot_surface_contour ----------------------------------------------


def test_surface_shows_the_zero_plane_the_zero_contour_and_a_colorbar(surface_A):
    ax = sr.plot_surface(surface_A, mark=sr.PAPER_DESIGN_POINT)
    assert [c for c in ax.collections if c.get_gid() == "zero plane"]
    zero = [c for c in ax.collections if isinstance(c, ContourSet) and list(c.levels) == [0.0]]
    assert len(zero) == 1
    labels = _legend_texts(ax)
    assert "plane max λ(Z) = 0 [-]" in labels and "max λ(Z) = 0 [-] on the surface" in labels
    certified = int(surface_A.certified.sum())
    assert any(label.startswith("certified") and f"{certified} of 400" in label for label in labels)
    assert any(a.get_label() == "<colorbar>" for a in ax.figure.axes)
    _check_units(ax.figure)


def test_surface_clips_the_spike_and_says_so(surface_A):
    ax = sr.plot_surface(surface_A)
    top = np.quantile(surface_A.max_eig, 0.95)
    # the ρ -> 0 spike does not set the z range: the negative region keeps its extent
    assert ax.get_zlim()[1] < 1.1 * top < surface_A.max_eig.max()
    assert ax.get_zlim()[0] < surface_A.max_eig.min()
    assert "clipped" in ax.get_title() and "95th percentile" in ax.get_title()
    unclipped = sr.plot_surface(surface_A, clip_quantile=1.0)
    assert unclipped.get_zlim()[1] >= surface_A.max_eig.max() and "clipped" not in unclipped.get_title()


def test_surface_with_nothing_certified_says_so(surface_all):
    ax = sr.plot_surface(surface_all)
    assert not [c for c in ax.collections if isinstance(c, ContourSet) and list(c.levels) == [0.0]]
    labels = _legend_texts(ax)
    assert any(label.startswith("max λ(Z) ≥ ") and "[-] on the whole grid: nothing certified" in label
               for label in labels)
    assert any("0 of 64" in label for label in labels)
    assert "clipped" not in ax.get_title()  # no spike: drawn whole


@pytest.mark.parametrize("value", [0.0, 1.5], ids=["zero", "above-one"])
def test_surface_refuses_a_bad_clip_quantile(surface_A, value):
    with pytest.raises(sr.ArgumentValueError, match="`clip_quantile` must be"):
        sr.plot_surface(surface_A, clip_quantile=value)


def test_surface_view_is_the_camera_and_is_checked(surface_A):
    ax = sr.plot_surface(surface_A, view=(20.0, -60.0))
    assert (ax.elev, ax.azim) == (20.0, -60.0)
    with pytest.raises(sr.ArgumentValueError, match=r"`view` must be \(elevation, azimuth\)"):
        sr.plot_surface(surface_A, view=(20.0,))


def test_contour_draws_the_zero_line_with_a_legend_below_the_data(surface_A):
    ax = sr.plot_surface_contour(surface_A, mark=sr.PAPER_DESIGN_POINT)
    zero = [c for c in ax.collections if isinstance(c, ContourSet) and list(c.levels) == [0.0]]
    assert len(zero) == 1 and any(t.get_text() == "max λ(Z) = 0" for t in ax.texts)
    colorbar = next(a for a in ax.figure.axes if a.get_label() == "<colorbar>")
    assert "▲: above" in colorbar.get_ylabel()  # the spike shares the top colour, and the label says so
    ax.figure.canvas.draw()
    assert all(PLAIN.fullmatch(t) for t in _tick_texts(colorbar.yaxis)), _tick_texts(colorbar.yaxis)
    _assert_off_the_data(ax.get_legend(), ax)
    _check_units(ax.figure)


# --- comparison, campaign and margin figures --------------------------------------------------------

COMPARISON = pd.DataFrame(
    {
        "controller": ["pid", "pid", "smc", "smc"],
        "scenario": ["large", "small"] * 2,
        "payload": ["on"] * 4,
        "max_abs_error_after_6s": [0.022, 0.011, 0.007, 0.007],
        "max_abs_torque_after_6s": [8.6, 8.6, 8.5, 8.5],
        "chattering_index": [69.0, 69.0, 24000.0, 24000.0],
    }
)


def test_comparison_bound_only_over_the_pid_bars_and_a_title_without_figures_4_5():
    fig = sr.plot_comparison(COMPARISON)
    ax = fig.axes[0]
    segments = [c for c in ax.collections if c.get_label() == "paper's PID bound 0.02 rad"]
    assert len(segments) == 1
    (x0, _), (x1, _) = segments[0].get_segments()[0]
    assert -0.5 <= x0 < x1 <= 0.5  # over the PID group (x = 0) only; the smc group is at x = 1
    title = fig._suptitle.get_text()
    assert "payload on" in title and "Figure" not in title
    (legend,) = fig.legends
    entries = [t.get_text() for t in legend.get_texts()]
    assert "paper's bound for the PID after 6 s (0.02 rad, 7.5 N·m)" in entries
    for ax in fig.axes:
        _assert_off_the_data(legend, ax)
        assert UNIT.search(ax.get_ylabel())


def test_comparison_log_axis_reads_as_plain_decimals():
    fig = sr.plot_comparison(COMPARISON)
    ax = fig.axes[2]
    fig.canvas.draw()
    assert ax.get_yscale() == "log"
    texts = _tick_texts(ax.yaxis)
    assert texts and all(PLAIN.fullmatch(t) for t in texts), texts
    assert ax.get_ylim()[0] <= 10  # the 69 N·m/s bars have a height


def test_campaign_log_axis_reads_as_plain_decimals():
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
    texts = _tick_texts(ax.yaxis)
    assert texts and all(PLAIN.fullmatch(t) for t in texts), texts
    assert "9.8" not in " ".join(texts) and not any("×" in t or "e" in t for t in texts)
    assert fig.axes[1].get_yscale() == "linear"  # 6.0-6.5 N·m spans no decade
    _check_units(fig)


def test_a_large_campaign_shows_density_and_only_the_tails_as_dots():
    rng = np.random.default_rng(0)
    n = 1000
    table = pd.DataFrame({"controller": ["pid"] * n, "scenario": range(n), "success": True, "status": "tracking",
                          "max_abs_error_after_6s": rng.lognormal(-4.5, 0.2, n),
                          "max_abs_torque_after_6s": rng.normal(8.5, 1.0, n)})
    fig = sr.plot_campaign(table)
    for ax in fig.axes:
        dots = [line for line in ax.lines if line.get_marker() == "o"]
        assert len(dots) == 1 and 80 <= len(dots[0].get_ydata()) <= 120  # the 10 % outside 5-95 %
        assert ax.collections  # the density
    assert "dots: runs outside 5-95 %" in fig._suptitle.get_text()
    _check_units(fig)


def test_margin_figures_have_units_plain_labels_and_legends_off_the_data(surface_A):
    surface = sr.design_surface(sr.paper_model(), np.linspace(0.5, 10, 6), np.linspace(1, 200, 6), measure="margin")
    ax = sr.plot_margin_map(surface, mark=sr.PAPER_DESIGN_POINT)
    _check_units(ax.figure)
    _assert_off_the_data(ax.get_legend(), ax)
    colorbar = next(a for a in ax.figure.axes if a.get_label() == "<colorbar>")
    assert all(PLAIN.fullmatch(t) for t in _tick_texts(colorbar.yaxis)), _tick_texts(colorbar.yaxis)
    with pytest.raises(sr.ArgumentValueError, match="`surface` has no margins"):
        sr.plot_margin_map(surface_A)
    table = pd.DataFrame(
        [("theorem1", "lower", 0.55, 0.55, 0.55), ("frozen", "upper", 0.64, 0.63, 0.64),
         ("bracket", "both", 0.55, 0.55, 0.64)], columns=["method", "kind", "theta", "lo", "hi"])
    ax = sr.plot_margin_bracket({"published": table})
    assert "θ" in ax.get_xlabel() and "[-]" in ax.get_xlabel()
    _check_units(ax.figure)
    _assert_off_the_data(ax.get_legend(), ax)


def test_a_scheduled_pid_is_drawn_as_its_pid_gains_with_units():
    """plot_schedule on a PID-form plant draws K_I, K_P, K_D (the entries of −K, positive for a stabilizing
    PID) as the command line prints them, the fixed gain beside them, every axis with its unit."""
    plant = sr.load_plant(os.path.join(EXAMPLES, "plant-arm-payload.toml"))
    gain = sr.schedule_riccati(plant, "m", np.linspace(0.0, 2.0, 3), 1.0, 10.0)
    fixed = sr.design(plant, 1.0, 10.0).K
    fig = sr.plot_schedule(gain, plant, fixed=fixed)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert sorted(ax.get_title() for ax in axes) == ["K_D", "K_I", "K_P"]
    column = {"K_I": 0, "K_P": 1, "K_D": 2}
    for ax in axes:
        j = column[ax.get_title()]
        curve, markers, dashed = ax.get_lines()
        np.testing.assert_allclose(markers.get_ydata(), -gain.gains[:, 0, j])
        np.testing.assert_allclose(curve.get_ydata(), -gain.gain(curve.get_xdata())[:, 0, j])
        assert np.all(markers.get_ydata() > 0) and dashed.get_ydata()[0] == pytest.approx(-fixed[0, j])
        assert ax.get_xlabel() == "measured m [kg]" and "N·m/" in ax.get_ylabel()
    assert "PID gains" in fig._suptitle.get_text()
    plt.close(fig)
