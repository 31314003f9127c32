"""The live web viewer: MuJoCo Studio glue and the live cycle loop."""

from __future__ import annotations

from kr210_sim.view.studio import LiveViewer, ViewerClosed, ViewerSettings

__all__ = [
    "LiveViewer",
    "ViewerClosed",
    "ViewerSettings",
]
