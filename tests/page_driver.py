"""Drive the design page (``python -m scara_robust app``) in headless Chromium, and time what it shows.

Shared by tests/test_app.py (what the page shows) and benchmarks/test_benchmarks.py (how fast).
Times are taken in the page's own clock: from the mouse button's release to the animation frame
that paints a text (a hook on the Bokeh model of the text, then ``requestAnimationFrame``), so
the polling of the test driver does not enter them.
"""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]

#: Where the map's plotting frame is on the page, and its data ranges (Bokeh's view of the figure).
FRAME_JS = """() => {
  const model = Bokeh.documents[0].get_model_by_name('design-map');
  const view = Bokeh.index.get_one(model);
  const bbox = view.frame.bbox, rect = view.canvas_view.el.getBoundingClientRect();
  return {left: rect.left + bbox.left, top: rect.top + bbox.top, width: bbox.width, height: bbox.height,
          x0: view.frame.x_range.start, x1: view.frame.x_range.end,
          y0: view.frame.y_range.start, y1: view.frame.y_range.end};
}"""
#: Records when the mouse button is released anywhere on the page (the click's moment, in the page's clock).
RELEASE_JS = "() => window.addEventListener('pointerup', () => { window.__released = performance.now(); }, true)"
#: Once the Bokeh model named `name` (a Div) holds `text`: the time of the next animation frame, which paints it.
WATCH_JS = """([name, text]) => {
  const model = Bokeh.documents[0].get_model_by_name(name);
  window.__painted = window.__painted || {};
  delete window.__painted[text];
  const check = () => {
    if (!(text in window.__painted) && model.text.includes(text)) {
      window.__painted[text] = null;
      requestAnimationFrame(() => { window.__painted[text] = performance.now(); });
    }
  };
  model.change.connect(check);
}"""
PAINTED_JS = "(text) => window.__painted[text] == null ? false : window.__painted[text] - window.__released"


def free_port() -> int:
    """A TCP port free on this machine now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def open_page(argv: Sequence[str], log: Path) -> Iterator[tuple[Any, list[str]]]:
    """``python -m scara_robust app ARGV`` on a free port, opened in headless Chromium.

    Skips (with the reason) where Chromium or Playwright is missing. Yields the Playwright page
    and a list that collects console errors, failed requests and requests to other hosts. The
    server is stopped with SIGTERM, as Ctrl-C stops it, and must exit with 0.
    """
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("no Chromium on this machine (Debian: apt-get install chromium); .ci/run installs it")
    sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright is not installed: pip install '.[docs]'")
    port = free_port()
    with open(log, "w", encoding="utf-8") as err:
        server = subprocess.Popen([sys.executable, "-m", "scara_robust", "app", *argv, "--port", str(port)],
                                  stdout=subprocess.DEVNULL, stderr=err)
    try:
        deadline = time.monotonic() + 120
        while "serving the design page" not in log.read_text(encoding="utf-8"):  # said once it listens
            assert server.poll() is None and time.monotonic() < deadline, log.read_text(encoding="utf-8")
            time.sleep(0.1)
        assert f"serving the design page at http://127.0.0.1:{port}/" in log.read_text(encoding="utf-8")
        problems: list[str] = []
        local = (f"http://127.0.0.1:{port}", f"ws://127.0.0.1:{port}", "data:")
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS, headless=True)
            page = browser.new_page(viewport={"width": 1250, "height": 1150}, accept_downloads=True)
            page.on("console", lambda m: problems.append(f"console: {m.text}") if m.type == "error" else None)
            page.on("requestfailed", lambda r: problems.append(f"failed: {r.url}"))
            page.on("request", lambda r: None if r.url.startswith(local) else problems.append(f"remote: {r.url}"))
            page.goto(f"http://127.0.0.1:{port}/")
            page.wait_for_selector("text=Click the map", timeout=60_000)
            page.evaluate(RELEASE_JS)
            page.wait_for_function(f"() => ({FRAME_JS})().width > 100", timeout=30_000)
            yield page, problems
            browser.close()
    finally:
        server.terminate()  # as Ctrl-C: the page and its worker processes stop
        code = server.wait(30)
    assert code == 0, log.read_text(encoding="utf-8")


def click_grid_point(page: Any, rhos: Any, etas: Any, i: int, k: int) -> None:
    """Click the centre of grid point (i, k)'s cell of the map."""
    frame = page.evaluate(FRAME_JS)
    u = (rhos[i] - frame["x0"]) / (frame["x1"] - frame["x0"]) * frame["width"]
    v = (1 - (etas[k] - frame["y0"]) / (frame["y1"] - frame["y0"])) * frame["height"]
    assert 2 < u < frame["width"] - 2 and 2 < v < frame["height"] - 2, (u, v, frame)  # a click the frame receives
    page.mouse.click(frame["left"] + u, frame["top"] + v)


def watch(page: Any, name: str, text: str) -> None:
    """Start timing when the Div named `name` shows `text` (call before the click)."""
    page.evaluate(WATCH_JS, [name, text])


def painted_after_release(page: Any, text: str, timeout: float) -> float:
    """Milliseconds from the last mouse release to the frame that painted `text` (see :func:`watch`)."""
    return float(page.wait_for_function(PAINTED_JS, arg=text, timeout=timeout).json_value())


def design_label(rho: float, eta: float) -> str:
    """The design Div's heading for (ρ, η)."""
    return f"Design at ρ = {rho:.4g}, η = {eta:.4g}"


def response_label(rho: float, eta: float) -> str:
    """The response Div's heading for (ρ, η)."""
    return f"Response at ρ = {rho:.4g}, η = {eta:.4g}"
