"""The documentation site builds with no warning, its links resolve, and it renders in a real browser.

The site is built from a copy of `docs/` (notebooks unexecuted: `make docs` executes them, with a
cache) with warnings as errors. Every internal link of every page, anchors included, must
resolve. Headless Chromium (Debian's `chromium`, driven by Playwright through
`executable_path`) then loads the landing page, a guide page, an API page and a gallery page
from a local server, with no console error and no failed request, follows the landing
page's link to the *my own plant* guide, and writes each page's screenshot to
`docs/_build/screenshots/`.
"""

from __future__ import annotations

import dataclasses
import functools
import html
import http.server
import os
import re
import shutil
import subprocess
import sys
import threading
import urllib.parse
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCREENSHOTS = ROOT / "docs" / "_build" / "screenshots"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
#: Chromium as root in a sandbox with no network: no sandbox, no GPU, no background connections.
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: The pages opened in the browser: landing, a guide page, an API page, a gallery page.
PAGES = {
    "landing": "index.html",
    "guide-own-plant": "guide/own-plant.html",
    "api-design": "api/generated/scara_robust.design.html",
    "gallery-figure3": "gallery/figure3_pid_large_ic.html",
}


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built from a copy of the sources (nothing is written into the repository)."""
    tmp = tmp_path_factory.mktemp("site")
    shutil.copytree(ROOT / "docs", tmp / "docs", symlinks=True, ignore=shutil.ignore_patterns("_build", "generated"))
    shutil.copy(ROOT / "README.md", tmp / "README.md")
    (tmp / "notebooks").symlink_to(ROOT / "notebooks")
    env = {**os.environ, "SCARA_ROBUST_DOCS_EXECUTE": "off", "PYTHONPATH": str(ROOT)}
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", "docs", "html"],
        cwd=tmp, env=env, capture_output=True, text=True, timeout=900,
    )
    assert build.returncode == 0, build.stderr[-4000:]
    assert build.stderr.strip() == "", build.stderr[-4000:]
    return tmp / "html"


#: What a page links to (href of <a> and <link>, src of <img> and <script>), and the ids it defines.
LINK = re.compile(r"<(?:a|link)\b[^>]*?\bhref=\"([^\"]+)\"|<(?:img|script)\b[^>]*?\bsrc=\"([^\"]+)\"")
ID = re.compile(r"\bid=\"([^\"]+)\"")


@dataclasses.dataclass(frozen=True)
class _Page:
    links: list[str]
    ids: set[str]


@functools.cache
def _parse(path: Path) -> _Page:
    text = path.read_text(encoding="utf-8")
    return _Page([html.unescape(a or b) for a, b in LINK.findall(text)], set(ID.findall(text)))


def test_every_internal_link_resolves(site):
    pages = sorted(p for p in site.rglob("*.html") if "_static" not in p.relative_to(site).parts)
    assert len(pages) > 250  # the guide, the gallery and a page per public name
    # every file and folder of the site, as normalized paths: a link is looked up, not stat'ed (each page
    # links to most others through its navigation)
    files = {os.path.normpath(p) for p in site.rglob("*") if p.is_file()}
    folders = {os.path.normpath(p) for p in site.rglob("*") if p.is_dir()} | {os.path.normpath(site)}
    broken = []
    for page in pages:
        for link in _parse(page).links:
            url = urllib.parse.urlsplit(link)
            if url.scheme or link.startswith(("//", "mailto:")):
                continue
            target = os.path.normpath(page.parent / urllib.parse.unquote(url.path) if url.path else page)
            if target in folders:
                target = os.path.join(target, "index.html")
            if target not in files:
                broken.append(f"{page.relative_to(site)} -> {link}")
            elif url.fragment and target.endswith(".html") and url.fragment not in _parse(Path(target)).ids:
                broken.append(f"{page.relative_to(site)} -> {link} (no such anchor)")
    assert broken == []


def test_nothing_is_fetched_from_the_network(site):
    """No page loads a script, style sheet or image from another host (no CDN)."""
    remote = [f"{page.relative_to(site)}: {tag}" for page in site.rglob("*.html") if "_static" not in page.parts
              for tag in _parse(page).links
              if tag.startswith(("http://", "https://", "//")) and tag.split("?")[0].endswith((".js", ".css", ".png"))]
    assert remote == []


def test_every_public_name_has_its_api_page(site):
    """The generated reference has a page for each name of `__all__`, with its docstring."""
    import scara_robust

    missing = [name for name in scara_robust.__all__
               if not (site / "api" / "generated" / f"scara_robust.{name}.html").exists()]
    assert missing == []
    design = (site / "api" / "generated" / "scara_robust.design.html").read_text(encoding="utf-8")
    assert "Design the PID gain from" in design and "Examples" in design


def test_the_landing_page_links_to_every_guide_question(site):
    links = _parse(site / "index.html").links
    for page in ("getting-started.html", "guide/own-plant.html", "guide/own-robot.html", "guide/robust.html",
                 "guide/variation.html", "guide/synthesis.html", "guide/deployment.html", "reproduction.html",
                 "cli.html", "api/index.html"):
        assert page in links, page


@pytest.fixture(scope="module")
def server(site):
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    handler = functools.partial(Quiet, directory=str(site))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()


@pytest.fixture(scope="module")
def browser():
    if CHROMIUM is None:
        pytest.skip("no Chromium on this machine (Debian: apt-get install chromium); .ci/run installs it")
    sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright is not installed: pip install '.[docs]'")
    with sync_api.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        yield chromium
        chromium.close()


@pytest.mark.parametrize("name", sorted(PAGES))
def test_page_renders_in_chromium(server, browser, name):
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    problems: list[str] = []
    page.on("console", lambda msg: problems.append(f"console {msg.type}: {msg.text}") if msg.type == "error" else None)
    page.on("pageerror", lambda err: problems.append(f"page error: {err}"))
    page.on("requestfailed", lambda req: problems.append(f"request failed: {req.url}"))
    page.on("response", lambda res: problems.append(f"HTTP {res.status}: {res.url}") if res.status >= 400 else None)
    response = page.goto(f"{server}/{PAGES[name]}", wait_until="networkidle")
    assert response is not None and response.ok
    assert page.locator("article h1").first.is_visible()
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SCREENSHOTS / f"{name}.png"), full_page=False)
    page.close()
    assert problems == [], "\n".join(problems)


def test_my_own_plant_is_one_click_from_the_landing_page(server, browser):
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.goto(f"{server}/index.html", wait_until="networkidle")
    page.get_by_role("link", name="analyse my own plant").first.click()
    page.wait_for_load_state("networkidle")
    assert page.url.endswith("guide/own-plant.html")
    assert page.locator("article h1").first.inner_text().startswith("Your own plant")
    page.close()
