"""The page: a Bokeh document over a :class:`~scara_robust.app.DesignExplorer`, and its server.

Left, the (ρ, η) map coloured by the chosen measure with its certification contour; hovering
shows the value, a click selects the design. Right, the selected design: its gain, Theorem
1's verdict, the response, then the slower answers as they arrive. Every asset is served by
the Bokeh server itself (its ``/static`` route): the page needs no network.
"""

from __future__ import annotations

import asyncio
import base64
import html
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from bokeh.application import Application
from bokeh.application.handlers.function import FunctionHandler
from bokeh.core.templates import get_env
from bokeh.document import Document
from bokeh.events import DoubleTap, Event, Tap
from bokeh.layouts import column, row
from bokeh.models import ColumnDataSource, HoverTool, LinearColorMapper, Range1d, TapTool
from bokeh.models.annotations import ColorBar, Legend, Title
from bokeh.models.widgets import Button, Div, Select, TextInput
from bokeh.palettes import RdBu11
from bokeh.plotting import figure
from bokeh.plotting.contour import contour_data
from bokeh.server.server import Server

from ..exceptions import ArgumentError
from ..model.initial import SCENARIOS
from ..plotting import gain_entry_labels
from ._explorer import MEASURES, PAYLOAD_MAP_TOL, Answer, DesignExplorer, QuickAnswer, Response, RunSettings

__all__ = ["build_page", "envelope", "serve", "start_in_thread"]

#: Certified is blue, not certified red (RdBu11 runs from dark blue at the low end to dark red).
_PALETTE = {"max_eig": tuple(RdBu11), "margin": tuple(reversed(RdBu11)), "payload": tuple(reversed(RdBu11)),
            "deployable": tuple(reversed(RdBu11))}
_TABLE = "style='border-collapse:collapse' cellpadding='3' border='1'"
#: The page's roots in a grid: the title across, the map on the left, K and then the answers on the right.
_LAYOUT = """{% extends base %}
{% block contents %}
<div style="display: grid; grid-template-columns: 575px 600px; column-gap: 10px; align-items: start">
  <div style="grid-column: 1 / 3">{{ embed(roots.header) }}</div>
  <div style="grid-row: 2 / 8">{{ embed(roots.left) }}</div>
  <div>{{ embed(roots.design) }}</div>
  <div>{{ embed(roots.response) }}</div>
  <div>{{ embed(roots.plots) }}</div>
  <div>{{ embed(roots.answers) }}</div>
  <div>{{ embed(roots["export-root"]) }}</div>
  SCHEDULE
</div>
{% endblock %}"""
_TEMPLATE = get_env().from_string(_LAYOUT.replace("SCHEDULE", ""))
#: With a scheduled gain: its panel under both columns.
_SCHEDULE_TEMPLATE = get_env().from_string(_LAYOUT.replace(
    "SCHEDULE", '<div style="grid-column: 1 / 3">{{ embed(roots.schedule) }}</div>'))
#: Entries of a scheduled gain the page draws (the largest first), and its panels per row.
SCHEDULE_ENTRIES, SCHEDULE_COLUMNS = 12, 4
_COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2")


def _color_range(key: str, values: np.ndarray, level: float) -> tuple[float, float]:
    """A colour scale centred on the certification level, wide enough for most of the map."""
    finite = values[np.isfinite(values)]
    if key in ("margin", "payload"):
        top = float(np.percentile(finite, 95)) if finite.size else 2.0 * level
        half = max(abs(top - level), 0.5 * level)
        return level - half, level + half
    half = float(np.percentile(np.abs(finite), 90)) if finite.size else 1.0
    half = half if half > 0 else 1.0
    return -half, half


def _cells(values: np.ndarray) -> tuple[float, float]:
    """Start and width of an image axis whose cells are centred on the grid `values` (evenly spaced)."""
    step = float(values[1] - values[0]) if values.size > 1 else max(abs(float(values[0])) * 0.1, 0.1)
    return float(values[0]) - step / 2, float(values[-1] - values[0]) + step


def envelope(t: np.ndarray, y: np.ndarray, buckets: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """The min-max envelope of a sampled signal: per bucket of samples, its smallest and largest sample.

    A line through these points, in time order, reaches every peak and trough of `y`, with at
    most ``2 * buckets`` points (a plot a few hundred pixels wide shows nothing more).

    Parameters
    ----------
    t : ndarray, shape (k,)
        Sample times, s, increasing.
    y : ndarray, shape (k,)
    buckets : int

    Returns
    -------
    t_env, y_env : ndarray, shape (2 * buckets,), or `t` and `y` themselves when k <= 2 * buckets
    """
    k = t.size
    if k <= 2 * buckets:
        return t, y
    per = k // buckets
    starts = np.arange(buckets) * per
    block = y[:buckets * per].reshape(buckets, per)
    lo, hi = starts + np.argmin(block, axis=1), starts + np.argmax(block, axis=1)
    if k > buckets * per:  # the samples after the last whole bucket join it
        tail = y[buckets * per:]
        j = buckets * per
        if tail.min() < y[lo[-1]]:
            lo[-1] = j + int(np.argmin(tail))
        if tail.max() > y[hi[-1]]:
            hi[-1] = j + int(np.argmax(tail))
    picks = np.column_stack([np.minimum(lo, hi), np.maximum(lo, hi)]).ravel()
    return t[picks], y[picks]


def _link(name: str, data: bytes, mime: str) -> str:
    """A download link for a file of the page (a data URL: nothing is stored on the server)."""
    return (f"<a download='{html.escape(name)}' id='download-{html.escape(name.replace('.', '-'))}' "
            f"href='data:{mime};base64,{base64.b64encode(data).decode()}'>{html.escape(name)}</a>")


def _title(fig: Any) -> Title:
    """A figure's title object (figure() always makes one)."""
    title = fig.title
    assert isinstance(title, Title)
    return title


def _number(text: str, name: str, unit: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{name} must be a number ({unit}), found {text.strip()!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite ({unit}), found {text.strip()!r}")
    return value


def _gain_table(answer: QuickAnswer, output_unit: str, input_unit: str, elements: str) -> str:
    """K as K_P, K_I, K_D rows per input, with units, in HTML."""
    d = answer.design
    head = (f"<b id='design-head'>Design at ρ = {answer.rho:.4g}, η = {answer.eta:.4g}</b> "
            f"<span style='color:#666'>(K and Theorem 1 in {1e3 * answer.seconds:.1f} ms)</span>")
    verdict = ("<span style='color:#1a7f37;font-weight:bold'>certified</span>" if answer.certified else
               "<span style='color:#b31d28;font-weight:bold'>not certified</span>")
    lines = [head, f"<div id='thm1-verdict'>Theorem 1: {verdict} (max λ(Z) = {answer.max_eig:.4g}, elements "
                   f"{html.escape(elements)})</div>"]
    m, n = d.K.shape
    if n == 3 * m:
        K_I, K_P, K_D = d.pid_matrices()
        rows = "".join(
            f"<tr><td>u{j + 1}</td><td>{' '.join(f'{v:.6g}' for v in K_P[j])}</td>"
            f"<td>{' '.join(f'{v:.6g}' for v in K_I[j])}</td><td>{' '.join(f'{v:.6g}' for v in K_D[j])}</td></tr>"
            for j in range(m))
        i, o = html.escape(input_unit), html.escape(output_unit)
        lines.append(f"<div>u = K_P e + K_I ∫e + K_D ė, one row per input (columns: the errors):</div>"
                     f"<table id='gain-table' {_TABLE}><tr><th></th><th>K_P [{i}/{o}]</th>"
                     f"<th>K_I [{i}/({o}·s)]</th><th>K_D [{i}·s/{o}]</th></tr>" + rows + "</table>")
    rows = "".join(f"<tr><td>u{j + 1}</td>" + "".join(f"<td>{v:.6g}</td>" for v in d.K[j]) + "</tr>"
                   for j in range(m))
    lines.append(f"<div>K of u = −K x on the design form:</div><table id='k-matrix' {_TABLE}>" + rows + "</table>")
    return "".join(lines)


def _deployable_html(verdict: tuple[bool, str] | None) -> str:
    """The selected design's deployability beside its response: red when it needs more than the actuator gives."""
    if verdict is None:
        return ""
    ok, text = verdict
    colour = "#1a7f37" if ok else "#b00020"
    word = "Within the input limits" if ok else "Outside the input limit"
    return (f"<br><b id='deployable' style='color:{colour}'>{word}</b>: "
            f"<span id='deployable-reason'>{html.escape(text)}</span>")


def _table_html(frame: Any, columns: list[str], table_id: str) -> str:
    shown = frame[columns].copy()
    return str(shown.to_html(index=False, table_id=table_id, float_format=lambda v: f"{v:.4g}", na_rep="–",
                             border=1))


def _recorded_text(gain: Any) -> str:
    """What a schedule file says it was certified for, in words with units."""
    record, unit = gain.certified, gain.unit
    if not record:
        return "the file records no certificate"

    def number(key: str) -> str:
        value = gain.recorded(key)
        return "any" if value == math.inf else f"{value:.4g}"

    parts = []
    if "range" in record:
        parts.append(f"range {record['range'][0]:g}–{record['range'][1]:g} {unit}")
    for key, label, suffix in (("rate", "rate", f" {unit}/s"), ("measurement_error", "measurement error", f" {unit}"),
                               ("decay", "decay", " 1/s"), ("gain_bound", "gain bound ‖K_j‖ <=", "")):
        if key in record:
            parts.append(f"{label} {number(key)}{suffix}")
    if "checked_conditions" in record:
        parts.append(f"{record['checked_conditions']} conditions checked")
    if "plant" in record:
        parts.append(f"plant {record['plant']}")
    return "the file records: " + ", ".join(parts)


def _schedule_panel(doc: Document, explorer: DesignExplorer) -> tuple[Any, Callable[[Any], None]]:
    """The scheduled gain's panel and the function that draws a selected design's K beside it.

    One small figure per entry ``K_ij`` (the largest :data:`SCHEDULE_ENTRIES`): the table at
    its breakpoints (dots), linear between them as the controller interpolates, and the
    selected design's entry dashed. Above them, the certificate its file records and the
    certificate re-verified in a worker (:meth:`DesignExplorer.schedule_check`).
    """
    gain, plant = explorer.schedule, explorer.plant
    assert gain is not None and plant is not None
    names, per = gain_entry_labels(plant)
    inputs = list(plant.inputs)
    size = np.abs(gain.gains).max(axis=0)
    entries = [(int(i), int(j)) for i, j in zip(*np.unravel_index(np.argsort(-size, axis=None), size.shape))
               if size[i, j] > 0][:SCHEDULE_ENTRIES]
    p = np.linspace(*gain.range, 201)
    curve = gain.gain(p)
    fixed = ColumnDataSource({"x": [], **{f"k{k}": [] for k in range(len(entries))}}, name="schedule-fixed")
    figures = []
    for k, (i, j) in enumerate(entries):
        unit = f"{inputs[i].unit}/{per[j]}" if i < len(inputs) else "input unit per state unit"
        label = names[j] if gain.shape[0] == 1 else f"{names[j]} → {inputs[i].name if i < len(inputs) else i}"
        fig = figure(width=280, height=190, title=label, x_axis_label=f"measured {gain.parameter} [{gain.unit}]",
                     y_axis_label=f"gain [{unit}]", tools="pan,wheel_zoom,reset,save", name=f"schedule-{k}")
        fig.line(p, curve[:, i, j], color=_COLORS[0], line_width=2)
        fig.scatter(gain.breakpoints, gain.gains[:, i, j], color=_COLORS[0], size=6)
        fig.line("x", f"k{k}", source=fixed, color=_COLORS[1], line_dash="dashed", line_width=2)
        figures.append(fig)
    head = (f"<b>Scheduled gain</b> on {html.escape(gain.parameter)} [{html.escape(gain.unit)}] "
            f"({html.escape(gain.method or 'table')}, {gain.breakpoints.size} breakpoints, max ‖K_j‖ = "
            f"{gain.max_norm:.4g}): solid blue, K(p̂) of u = −K x on the design form (dots: the breakpoints, "
            f"linear between, the edge gain outside); dashed red, the selected (ρ, η) design's fixed K.<br>"
            f"{html.escape(_recorded_text(gain))}")
    check = Div(text=head + "<br><span id='schedule-check'>certificate: re-verifying…</span>", width=1150,
                name="schedule-text")

    def show_check(done: Any) -> None:
        try:
            cert, error, seconds = done.result()
        except Exception as err:  # noqa: BLE001  # the worker died: say so on the page
            cert, error, seconds = None, f"{type(err).__name__}: {err}", math.nan
        if cert is None:
            text = f"certificate: failed: {html.escape(str(error))}"
        else:
            text = (f"certificate re-verified now ({seconds:.1f} s): {html.escape(cert.verdict)}, rate "
                    f"|d{html.escape(gain.parameter)}/dt| <= {cert.rate:g} {html.escape(gain.unit)}/s, measurement "
                    f"error <= {cert.measurement_error:g} {html.escape(gain.unit)}: {html.escape(cert.message)} "
                    f"(covers: {html.escape(cert.covers)})")
        check.text = head + f"<br><span id='schedule-check'>{text}</span>"

    future = explorer.schedule_check()
    future.add_done_callback(lambda done: doc.add_next_tick_callback(partial(show_check, done)))

    def draw_fixed(K: Any) -> None:
        K = np.asarray(K, dtype=float)
        fixed.data = {"x": list(gain.range), **{f"k{k}": [K[i, j]] * 2 for k, (i, j) in enumerate(entries)}}

    rows = [row(*figures[c:c + SCHEDULE_COLUMNS]) for c in range(0, len(figures), SCHEDULE_COLUMNS)]
    return column(check, *rows, name="schedule"), draw_fixed


@dataclass(frozen=True)
class _MapView:
    """The (ρ, η) map's figure and the models its callbacks redraw."""

    fmap: figure
    mapper: LinearColorMapper
    image_src: ColumnDataSource
    contour: Any
    colorbar: ColorBar
    chosen: ColumnDataSource


@dataclass(frozen=True)
class _MapControls:
    """The widgets under the map: the measure shown, the (ρ, η) to select, the map's grid, the message line."""

    measure: Select
    rho_in: TextInput
    eta_in: TextInput
    go: Button
    rho_grid: TextInput
    eta_grid: TextInput
    regrid: Button
    message: Div


@dataclass(frozen=True)
class _DesignPanels:
    """The selected design's K, its response (text and plots), one line per slower answer, and the units."""

    design_div: Div
    response_div: Div
    status: dict[str, Div]
    err_src: ColumnDataSource
    inp_src: ColumnDataSource
    ferr: figure
    finp: figure
    out_unit: str
    in_unit: str


@dataclass(frozen=True)
class _ExportControls:
    """The export row's fields and buttons and the line their files go to."""

    ts_in: TextInput
    limit_in: TextInput
    export_btn: Button
    design_btn: Button
    figures_btn: Button
    export_div: Div


@dataclass(frozen=True)
class _Page:
    """Everything the page's callbacks read and update: the document, the explorer, the widgets, the selection."""

    doc: Document
    explorer: DesignExplorer
    #: "measure": the key of the map shown; "selected": the selected QuickAnswer, None before the first selection.
    state: dict[str, Any]
    view: _MapView
    controls: _MapControls
    panels: _DesignPanels
    export: _ExportControls
    initial: Select
    payload: Select
    draw_fixed: Callable[[Any], None] | None
    robot: bool


def build_page(doc: Document, explorer: DesignExplorer) -> None:
    """Fill `doc` with the page of `explorer`.

    Parameters
    ----------
    doc : bokeh.document.Document
    explorer : DesignExplorer
    """
    doc.title = f"scara_robust: {explorer.title}"
    state: dict[str, Any] = {"measure": "max_eig", "selected": None}
    view = _map_view(explorer)
    controls = _map_controls(explorer)
    panels = _design_panels(explorer)
    export = _export_controls(explorer, panels.in_unit)
    initial = _initial_select()
    draw_fixed: Callable[[Any], None] | None = None
    extra: list[Any] = []
    if explorer.schedule is not None:
        panel, draw_fixed = _schedule_panel(doc, explorer)
        extra.append(panel)
    payload = _payload_select()
    page = _Page(doc, explorer, state, view, controls, panels, export, initial, payload, draw_fixed,
                 explorer.robot_signals is not None)
    _wire_callbacks(page)
    _add_roots(page, extra)


def _map_view(explorer: DesignExplorer) -> _MapView:
    """Lay out the (ρ, η) map in the first measure: its image, contour, colour bar, hover, tap and selection mark."""
    first = list(MEASURES)[0]
    values = explorer.measure(first)
    low, high = _color_range(first, values, 0.0)
    mapper = LinearColorMapper(palette=_PALETTE[first], low=low, high=high, nan_color="#cccccc")
    rhos, etas = explorer.rhos, explorer.etas
    (x0, dw), (y0, dh) = _cells(rhos), _cells(etas)
    image_src = ColumnDataSource({"image": [values.T], "x": [x0], "y": [y0], "dw": [dw], "dh": [dh]})
    fmap = figure(width=560, height=480, x_range=Range1d(start=x0, end=x0 + dw), y_range=Range1d(start=y0, end=y0 + dh),
                  x_axis_label="ρ [-]", y_axis_label="η [-]", tools="pan,wheel_zoom,reset,save",
                  title=f"{MEASURES[first][0]}: certified where < 0", name="design-map")
    image = fmap.image(image="image", x="x", y="y", dw="dw", dh="dh", source=image_src,
                       color_mapper=mapper)
    # a tap selects no glyph (an image's selection would grow with every click and be sent to the server);
    # the Tap event _on_tap receives is the click's position
    tap = TapTool(renderers=[])
    fmap.add_tools(tap)
    fmap.toolbar.active_tap = tap
    fmap.add_tools(HoverTool(renderers=[image], tooltips=[("ρ", "$x{0.000}"), ("η", "$y{0.00}"),
                                                          ("value", "@image{0.0000}")]))
    contour = fmap.contour(rhos, etas, values.T, levels=[0.0, 1e-12],
                           line_color="black", line_width=2)
    colorbar = ColorBar(color_mapper=mapper, title=MEASURES[first][0], width=12)
    fmap.add_layout(colorbar, "right")
    chosen = ColumnDataSource({"x": [], "y": []})
    fmap.scatter("x", "y", source=chosen, marker="x", size=16, line_width=3, color="black")
    return _MapView(fmap, mapper, image_src, contour, colorbar, chosen)


def _map_controls(explorer: DesignExplorer) -> _MapControls:
    """Lay out the map's controls: the measure choice, the (ρ, η) fields, the grid fields and the message line."""
    robot = explorer.robot_signals is not None
    rhos, etas = explorer.rhos, explorer.etas
    shown = {"max_eig", "margin", *(["payload"] if robot else []),
             *(["deployable"] if explorer.has_input_limits else [])}
    options: list[str | tuple[Any, str]] = [(k, v[0]) for k, v in MEASURES.items() if k in shown]
    measure = Select(title="Map colour", value=list(MEASURES)[0], options=options, width=260,
                     name="measure")
    rho_in = TextInput(title="ρ [-] (> 0)", value="3", width=120, name="rho")
    eta_in = TextInput(title="η [-] (>= 1)", value="90", width=120, name="eta")
    go = Button(label="Select (ρ, η)", button_type="primary", width=130, name="select")
    rho_grid = TextInput(title="ρ grid START:STOP:NUM", value=f"{rhos[0]:g}:{rhos[-1]:g}:{rhos.size}", width=170,
                         name="rho-grid")
    eta_grid = TextInput(title="η grid START:STOP:NUM", value=f"{etas[0]:g}:{etas[-1]:g}:{etas.size}", width=170,
                         name="eta-grid")
    regrid = Button(label="Recompute map", width=130, name="regrid")
    message = Div(text="", width=560, name="message", styles={"color": "#b31d28"})
    return _MapControls(measure, rho_in, eta_in, go, rho_grid, eta_grid, regrid, message)


def _design_panels(explorer: DesignExplorer) -> _DesignPanels:
    """Lay out the selected design's panels: its K, its response's text and plots, one line per slower answer."""
    design_div = Div(text="Click the map, or type (ρ, η) and press Select.", width=560, name="design")
    response_div = Div(text="", width=560, name="response")
    # with the controller's Ts in its file, the certificate at it leads: it says whether what runs is certified
    order = ("certificates", "decay", "loop_margins", "margins", "payload", "sample_time")
    if explorer.controller_ts is not None:
        order = ("sample_time", *order[:-1])
    status = {kind: Div(text="", width=560, name=kind) for kind in order}
    err_src = ColumnDataSource({"t": []})
    inp_src = ColumnDataSource({"t": []})
    ferr = figure(width=560, height=200, x_axis_label="time t [s]", y_axis_label="tracking error",
                  tools="pan,wheel_zoom,reset,save", name="errors")
    finp = figure(width=560, height=200, x_axis_label="time t [s]", y_axis_label="controller output",
                  x_range=ferr.x_range, tools="pan,wheel_zoom,reset,save", name="inputs")
    error_labels, input_labels, out_unit, in_unit = explorer.signals
    err_src.data = {name: [] for j in range(len(error_labels)) for name in (f"te{j}", f"e{j}")}
    inp_src.data = {name: [] for j in range(len(input_labels)) for name in (f"tu{j}", f"u{j}")}
    for fig, labels, key in ((ferr, error_labels, "e"), (finp, input_labels, "u")):
        fig.add_layout(Legend(), "right")
        for j, label in enumerate(labels):
            fig.line(f"t{key}{j}", f"{key}{j}", source=err_src if key == "e" else inp_src, color=_COLORS[j % 6],
                     legend_label=label)
    ferr.yaxis.axis_label = f"tracking error [{out_unit}]"
    finp.yaxis.axis_label = f"controller output [{in_unit}]"
    return _DesignPanels(design_div, response_div, status, err_src, inp_src, ferr, finp, out_unit, in_unit)


def _export_controls(explorer: DesignExplorer, in_unit: str) -> _ExportControls:
    """Lay out the export row: the sample time and limit fields, the three export buttons and their result line."""
    ts_in = TextInput(title="Ts [s]", value="0.001", width=110, name="ts")
    limit_in = TextInput(title=f"{explorer.limit_name} [{in_unit}] (blank: none)", value="", width=200,
                         name="torque-limit")
    export_btn = Button(label="Export C", width=110, name="export")
    design_btn = Button(label="Design file (JSON)", width=150, name="design-file")
    figures_btn = Button(label="Figures (PNG)", width=130, name="figures")
    export_div = Div(text="", width=560, name="export-result")
    return _ExportControls(ts_in, limit_in, export_btn, design_btn, figures_btn, export_div)


def _initial_select() -> Select:
    """Lay out the robot's choice of initial error (the scenario's e₀)."""
    return Select(title="initial error", value="large", width=250, name="initial",
                  options=[(name, f"{name} (e₀ = ({', '.join(f'{v:g}' for v in SCENARIOS[name].e0)}) rad)")
                           for name in ("large", "small")])


def _payload_select() -> Select:
    """Lay out the robot's choice of payload: on (the file's profile) or off."""
    return Select(title="payload", value="on", width=200, name="payload",
                  options=[("on", "on (the file's profile)"), ("off", "off (m_p = 0 kg)")])


def _wire_callbacks(page: _Page) -> None:
    """Wire the map's clicks and the widgets' changes and clicks to the page's callbacks."""
    controls, export = page.controls, page.export
    controls.measure.on_change("value", lambda attr, old, new: _set_measure(page, new))
    on_tap = partial(_on_tap, page)
    page.view.fmap.on_event(Tap, on_tap)
    page.view.fmap.on_event(DoubleTap, on_tap)  # a second click within the double-click time is a DoubleTap, not a Tap
    controls.go.on_click(partial(_on_select, page))
    controls.regrid.on_click(partial(_on_regrid, page))
    export.export_btn.on_click(partial(_on_export, page))
    export.design_btn.on_click(partial(_on_design_file, page))
    export.figures_btn.on_click(partial(_on_figures, page))
    # a plant file's run has no scenario choices
    for widget in (page.initial, page.payload, export.limit_in) if page.robot else ():
        widget.on_change("value", lambda attr, old, new: _on_scenario(page))


def _add_roots(page: _Page, extra: list[Any]) -> None:
    """Lay out the page's roots (title, map column, K, response, plots, answers, export, schedule) in its template."""
    explorer, controls, panels, export = page.explorer, page.controls, page.panels, page.export
    title = Div(text=f"<h2 style='margin:0'>Robust PID design: {html.escape(explorer.title)} (Theorem 1 over "
                f"elements {html.escape(explorer.elements)})</h2>"
                "<div style='color:#444'>Blue: certified by Theorem 1 (black contour: the boundary). "
                "Hover for the value, click to select a design."
                + ("" if explorer.controller_ts is None else
                   f" The controller runs at Ts = {explorer.controller_ts:g} s (its file): the answers lead with the "
                   "sampled-data certificate at it.")
                + "</div>", width=1150)
    left = column(controls.measure, page.view.fmap,
                  row(controls.rho_in, controls.eta_in, column(Div(text="&nbsp;"), controls.go)),
                  row(controls.rho_grid, controls.eta_grid, column(Div(text="&nbsp;"), controls.regrid)),
                  controls.message, name="left")
    plots = column(*([row(page.initial, page.payload)] if page.robot else []), panels.ferr, panels.finp,
                   name="plots")
    answers = column(*panels.status.values(), name="answers")
    export_root = column(row(export.ts_in, export.limit_in, column(Div(text="&nbsp;"), export.export_btn)),
                         row(export.design_btn, export.figures_btn), export.export_div, name="export-root")
    # separate roots, placed by the page's template: a text that changes re-lays out its own root only
    # (in one root, every new K or "computing…" would lay out the map and the response plots again)
    title.name = "header"
    for root in (title, left, panels.design_div, panels.response_div, plots, answers, export_root, *extra):
        page.doc.add_root(root)
    page.doc.template = _SCHEDULE_TEMPLATE if extra else _TEMPLATE


def _set_measure(page: _Page, key: str) -> None:
    """Redraw the map in measure `key`: its image, colour scale, contour, colour bar and title."""
    explorer, view = page.explorer, page.view
    page.state["measure"] = key
    if key == "payload":
        vals = explorer.payload_values
        if vals is None:
            vals = explorer.start_payload_map(
                lambda i, masses: page.doc.add_next_tick_callback(partial(_payload_column, page)))
        grid_r, grid_e = explorer.payload_grid(vals.shape[0])
        level = explorer.payload_level
    else:
        vals, grid_r, grid_e = explorer.measure(key), explorer.rhos, explorer.etas
        level = 1.0 if key == "margin" else 0.0
    lo, hi = _color_range(key, vals, level)
    view.mapper.update(low=lo, high=hi, palette=_PALETTE[key])
    (x0, dw), (y0, dh) = _cells(grid_r), _cells(grid_e)
    view.image_src.data = {"image": [vals.T], "x": [x0], "y": [y0], "dw": [dw], "dh": [dh]}
    # the payload map fills in column by column; the deployable map is grey (NaN) where not certified
    done = key == "deployable" or bool(np.isfinite(vals).all())
    view.contour.visible = done
    if done:
        lines = np.where(np.isfinite(vals), vals, level - 1.0)
        view.contour.set_data(contour_data(grid_r, grid_e, lines.T, levels=[level, level + 1e-12]))
    view.colorbar.title = MEASURES[key][0]
    what = {"max_eig": "certified where < 0", "margin": "certified where θ >= 1",
            "deployable": "step within limits where >= 0; grey: not certified"}.get(key, "")
    if key == "payload":
        what = f"{vals.shape[0]} × {vals.shape[1]} points, to {PAYLOAD_MAP_TOL:.0%}; blue: >= {level:.3g} kg"
        if not done:
            what += f" (computing… {int(np.isfinite(vals).all(axis=1).sum())}/{vals.shape[0]})"
    _title(view.fmap).text = f"{MEASURES[key][0]}: {what}"


def _payload_column(page: _Page) -> None:
    """Redraw the payload map with its new column, if it is the map shown."""
    if page.state["measure"] == "payload":
        _set_measure(page, "payload")


def _draw_response(page: _Page, resp: Response, generation: int) -> None:
    """Draw the selected design's response: its signals' envelopes and its heading with the run's scenario."""
    explorer, panels = page.explorer, page.panels
    if generation != explorer.generation:
        return
    # the envelope of each signal: its peaks as drawn from every sample, a few hundred points sent
    panels.err_src.data = {name: v for j in range(resp.errors.shape[0])
                           for name, v in zip((f"te{j}", f"e{j}"), envelope(resp.t, resp.errors[j]), strict=True)}
    panels.inp_src.data = {name: v for j in range(resp.inputs.shape[0])
                           for name, v in zip((f"tu{j}", f"u{j}"), envelope(resp.t, resp.inputs[j]), strict=True)}
    answer = page.state["selected"]
    run = explorer.settings
    scenario = "" if not page.robot else (
        f" ({run.initial} initial error, payload {'on' if run.payload_on else 'off'}, "
        + ("no torque limit" if run.torque_limit is None else
           "torque limit " + ", ".join(f"{v:g}" for v in run.torque_limit) + " N·m") + ")")
    panels.response_div.text = (f"<b id='response-head'>Response at ρ = {answer.rho:.4g}, η = {answer.eta:.4g}</b>"
                                f"{scenario}: "
                                f"<span id='response-status'>{resp.status}</span> "
                                f"({html.escape(resp.reason)}) <span style='color:#666'>(run in "
                                f"<span id='response-ms'>{1e3 * resp.seconds:.0f}</span> ms)</span>"
                                + _deployable_html(explorer.deployable(resp)))


def _show_answer(page: _Page, answer: Answer) -> None:
    """Show a slower answer of the current selection: the response's plots, or its line of the answers."""
    if answer.generation != page.explorer.generation:
        return
    div = page.panels.status.get(answer.kind)
    if answer.kind == "response":
        if answer.error:
            page.panels.response_div.text = f"<b>Response</b>: failed ({html.escape(answer.error)})"
        else:
            _draw_response(page, answer.value, answer.generation)
        return
    assert div is not None
    took = f" <span style='color:#666'>({answer.seconds:.1f} s)</span>"
    if answer.error:
        div.text = f"<b>{answer.kind.replace('_', ' ')}</b>: failed: {html.escape(answer.error)}"
        return
    if answer.kind == "certificates":
        div.text = ("<b>Certificates</b> (max_eig: of the method's matrix, certified when < 0)" + took +
                    _table_html(answer.value, ["method", "verdict", "max_eig", "decay_rate [1/s]"],
                                "certificate-table"))
    elif answer.kind == "margins":
        v = answer.value
        upper = "no frozen instability found" if math.isinf(v["upper"]) else f"{v['upper']:.4g}"
        div.text = (f"<b>Margin θ</b> (every element range scaled about the design plant){took}: certified "
                    f"for θ <= <span id='margin-lower'>{v['lower']:.4g}</span> (Theorem 1 / vertex), a frozen "
                    f"plant unstable at θ = {upper}: bracket [{v['lower']:.4g}, {upper}]")
    elif answer.kind == "payload":
        table = answer.value.set_index("method")
        lo = float(table.loc["payload-design-P", "mass [kg]"])
        hi = float(table.loc["payload-frozen", "mass [kg]"])
        div.text = (f"<b>Payload</b>{took}: certified for a peak payload up to {lo:.4g} kg (the design's P); "
                    f"a frozen payload of {hi:.4g} kg makes the loop unstable")
    elif answer.kind == "decay":
        div.text = f"<b>Decay rate</b>{took}: <span id='decay-rate'>{html.escape(answer.value.message)}</span>"
    elif answer.kind == "loop_margins":
        div.text = (f"<b>Loop margins</b>{took}: <span id='loop-margins'>{html.escape(answer.value.message)}"
                    "</span>")
    elif answer.kind == "sample_time":
        Ts = page.explorer.controller_ts
        if Ts is None:
            div.text = f"<b>Sample time</b>{took}: {html.escape(answer.value.message)}"
        else:
            word = "certified" if answer.value.certified else "NOT certified"
            div.text = (f"<b><span id='sampled-verdict'>{word} at Ts = {Ts:g} s</span></b>, the controller's sample "
                        f"time{took}: {html.escape(answer.value.message)}")


def _deliver(page: _Page, answer: Answer) -> None:
    """Hand a slower answer over from the worker thread to the document's thread."""
    page.doc.add_next_tick_callback(partial(_show_answer, page, answer))


def _select(page: _Page, rho: float, eta: float) -> None:
    """Select the design at (`rho`, `eta`): show its K at once, then mark its slower answers pending."""
    explorer, panels = page.explorer, page.panels
    try:
        answer = explorer.quick(rho, eta)
    except ArgumentError as err:
        text = f"{err.argument} {err.problem}".replace("rho", "ρ").replace("eta", "η")
        page.controls.message.text = html.escape(text)
        return
    page.state["selected"] = answer
    if page.draw_fixed is not None:  # before the table: each change is its own message, sent in order
        page.draw_fixed(answer.design.K)
    panels.design_div.text = _gain_table(answer, panels.out_unit, panels.in_unit, explorer.elements)
    page.doc.add_next_tick_callback(partial(_mark_pending, page, answer))  # K goes out first, alone


def _mark_pending(page: _Page, answer: QuickAnswer) -> None:
    """Start the selection's slower answers and show them computing, unless a newer selection came first."""
    explorer, controls, panels = page.explorer, page.controls, page.panels
    if page.state["selected"] is not answer:
        return
    controls.message.text = ""
    try:
        explorer.submit(answer.design, partial(_deliver, page))
    except (RuntimeError, OSError) as err:  # no worker process could start
        controls.message.text = html.escape(f"the slower answers cannot be computed: {err}")
    page.view.chosen.data = {"x": [answer.rho], "y": [answer.eta]}
    controls.rho_in.value, controls.eta_in.value = f"{answer.rho:g}", f"{answer.eta:g}"
    kinds = explorer.slow_answers(answer.design)
    if "response" in kinds:  # before any answer: those are scheduled after this callback
        panels.response_div.text = "<b>Response</b>: computing…"
    for kind, div in panels.status.items():
        div.text = f"<b>{kind.replace('_', ' ')}</b>: computing…" if kind in kinds else ""
    page.export.export_div.text = ""


def _on_tap(page: _Page, event: Event) -> None:
    """Select the map's grid point nearest the click: its value is what was shown."""
    assert isinstance(event, Tap | DoubleTap)
    if event.x is None or event.y is None:
        return
    i, k = page.explorer.nearest(float(event.x), float(event.y))
    _select(page, float(page.explorer.rhos[i]), float(page.explorer.etas[k]))


def _on_select(page: _Page) -> None:
    """Select the (ρ, η) typed in the fields, or say what is wrong with them."""
    try:
        rho = _number(page.controls.rho_in.value, "ρ", "-")
        eta = _number(page.controls.eta_in.value, "η", "-")
    except ValueError as err:
        page.controls.message.text = html.escape(str(err))
        return
    _select(page, rho, eta)


def _on_regrid(page: _Page) -> None:
    """Recompute the map on the grids typed in the fields, or say why not."""
    explorer, controls, fmap = page.explorer, page.controls, page.view.fmap
    parse = explorer.parse_grid
    if parse is None:
        controls.message.text = "this page's grid is fixed"
        return
    try:
        r, e = parse(controls.rho_grid.value), parse(controls.eta_grid.value)
        explorer.compute_map(r, e)
    except ArgumentError as err:
        problem = err.problem.replace("× `etas`", "× the η grid").replace("with `etas`", "with the η grid")
        controls.message.text = html.escape(f"map refused: the ρ grid {problem}" if err.argument == "rhos"
                                            else f"map refused: the {'η' if err.argument == 'etas' else 'ρ'} grid "
                                            f"{problem}")
        return
    except ValueError as err:  # the grid's text
        controls.message.text = html.escape(f"grid: {err}")
        return
    controls.message.text = ""
    _set_measure(page, page.state["measure"])
    (x0, dw), (y0, dh) = _cells(explorer.rhos), _cells(explorer.etas)
    fmap.x_range.update(start=x0, end=x0 + dw)
    fmap.y_range.update(start=y0, end=y0 + dh)


def _limits(page: _Page) -> list[float] | None:
    """The limit field's values (blank: none); raises ValueError with the field's message."""
    limit_in, explorer, in_unit = page.export.limit_in, page.explorer, page.panels.in_unit
    if not limit_in.value.strip():
        return None
    values = [_number(v, f"the {explorer.limit_name}", in_unit) for v in limit_in.value.split(",")]
    if min(values) <= 0:
        raise ValueError(f"the {explorer.limit_name} must be > 0 {in_unit}, found {min(values):g}")
    return values


def _on_scenario(page: _Page) -> None:
    """Run the selected design's response again in the scenario chosen (or keep it for the next selection)."""
    try:
        limit = _limits(page)
    except ValueError as err:
        page.controls.message.text = html.escape(str(err))
        return
    page.controls.message.text = ""
    settings = RunSettings(page.initial.value, page.payload.value == "on", None if limit is None else tuple(limit))
    answer = page.state["selected"]
    if answer is None:
        page.explorer.settings = settings
        return
    page.panels.response_div.text = "<b>Response</b>: computing…"
    page.explorer.rerun(answer.design, settings, partial(_deliver, page))


def _on_design_file(page: _Page) -> None:
    """Link the selected design's file (for --design and load_design)."""
    explorer, export_div = page.explorer, page.export.export_div
    answer = page.state["selected"]
    if answer is None or explorer.design_file is None:
        export_div.text = "<span style='color:#b31d28'>select a design first</span>"
        return
    name = f"design-rho{answer.rho:g}-eta{answer.eta:g}.json"
    export_div.text = "Design file (for --design and load_design): " + _link(name, explorer.design_file(
        answer.rho, answer.eta).encode(), "application/json")


def _on_figures(page: _Page) -> None:
    """Start drawing the map and the selected design's response as PNG files."""
    export_div = page.export.export_div
    answer = page.state["selected"]
    if answer is None:
        export_div.text = "<span style='color:#b31d28'>select a design first</span>"
        return
    export_div.text = "Figures: drawing…"
    future = page.explorer.figures(answer.design, page.state["measure"], (answer.rho, answer.eta))
    future.add_done_callback(lambda done: page.doc.add_next_tick_callback(partial(_show_figures, page, answer, done)))


def _show_figures(page: _Page, answer: QuickAnswer, done: Any) -> None:
    """Link the drawn figures, unless a newer selection came first."""
    export_div = page.export.export_div
    if page.state["selected"] is not answer:
        return
    files, error, _ = done.result()
    if error:
        export_div.text = f"<span style='color:#b31d28'>figures: {html.escape(error)}</span>"
        return
    export_div.text = "Figures: " + " ".join(_link(name, data, "image/png") for name, data in files.items())


def _on_export(page: _Page) -> None:
    """Link the selected design's certified controller in C at the sample time typed, or say what is wrong."""
    export_div = page.export.export_div
    answer = page.state["selected"]
    if answer is None:
        export_div.text = "<span style='color:#b31d28'>select a design first</span>"
        return
    try:
        ts = _number(page.export.ts_in.value, "Ts", "s")
        files = page.explorer.export(answer.rho, answer.eta, ts, _limits(page))
    except (ValueError, ArgumentError) as err:
        export_div.text = f"<span style='color:#b31d28' id='export-error'>{html.escape(str(err))}</span>"
        return
    links = " ".join(_link(name, text.encode(), "text/plain;charset=utf-8") for name, text in files.items())
    export_div.text = f"Controller at Ts = {ts:g} s, certified: {links}"


def serve(explorer: DesignExplorer, port: int, *, address: str = "127.0.0.1",
          on_start: Callable[[str], None] | None = None) -> Server:
    """Create the Bokeh server of `explorer`'s page on ``address:port`` (not started).

    Parameters
    ----------
    explorer : DesignExplorer
    port : int
        TCP port (1-65535).
    address : str
        Interface to listen on (default: this machine only).
    on_start : callable, optional
        Called with the page's URL once the server listens.

    Returns
    -------
    bokeh.server.server.Server
    """
    app = Application(FunctionHandler(partial(build_page, explorer=explorer)))
    origins = [f"localhost:{port}", f"127.0.0.1:{port}", f"{address}:{port}"]
    server = Server({"/": app}, port=port, address=address, allow_websocket_origin=origins)
    if on_start is not None:
        on_start(f"http://{address}:{port}/")
    return server


def start_in_thread(explorer: DesignExplorer, port: int) -> tuple[Server, threading.Thread]:
    """Serve the page from a background thread (for tests and notebooks); stop with ``server.io_loop.stop()``.

    Parameters
    ----------
    explorer : DesignExplorer
    port : int

    Returns
    -------
    server : bokeh.server.server.Server
    thread : threading.Thread
    """
    ready = threading.Event()
    holder: dict[str, Server] = {}

    def run() -> None:
        asyncio.set_event_loop(asyncio.new_event_loop())
        server = serve(explorer, port)
        server.start()
        holder["server"] = server
        ready.set()
        server.io_loop.start()

    thread = threading.Thread(target=run, name="scara-robust-app-server", daemon=True)
    thread.start()
    ready.wait(30)
    return holder["server"], thread
