"""The graphical design as a local web page: the (ρ, η) map, click a design, read its answers.

``python -m scara_robust app`` serves it (Bokeh server, every asset local);
:class:`~scara_robust.app.DesignExplorer` is what it computes, usable without a page.
"""

from ._explorer import (
    MEASURES,
    PAYLOAD_MAP_POINTS,
    PAYLOAD_MAP_TOL,
    Answer,
    DesignExplorer,
    QuickAnswer,
    Response,
    RunSettings,
)
from ._page import build_page, envelope, serve, start_in_thread

__all__ = ["MEASURES", "PAYLOAD_MAP_POINTS", "PAYLOAD_MAP_TOL", "Answer", "DesignExplorer", "QuickAnswer", "Response",
           "RunSettings", "build_page", "envelope", "serve", "start_in_thread"]
