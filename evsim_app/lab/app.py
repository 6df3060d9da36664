"""The lab's four panels in tabs, and the local web server `evsim lab` runs.

Every script and style sheet comes from the server itself (Bokeh's and Panel's "server" resources), so the lab works
with no network; tests/test_lab_browser.py records the page's requests and checks that none leaves localhost.
"""

from __future__ import annotations

import os
import socket

os.environ.setdefault("BOKEH_RESOURCES", "server")  # Bokeh's scripts from this server, not a CDN (before bokeh loads)

import panel as pn  # noqa: E402

from .pixel_panel import PixelPanel  # noqa: E402
from .real_panel import RealPanel  # noqa: E402
from .reconstruction_panel import ReconstructionPanel  # noqa: E402
from .scene_panel import ScenePanel  # noqa: E402
from .signals import recording_pixel  # noqa: E402

TITLE = "evsim lab"


def lab(recording: str | None = None, photo: str | None = None) -> pn.Tabs:
    """The lab: tabs One pixel, Sensor over a scene, Reconstruction, Real data. recording: a hybrid recording
    (AEDAT4, IJRR folder, ...) whose busiest pixel the pixel panel offers as a signal; photo: an image file the
    scene panel offers as a scene. The costly panels compute when their tab is first opened."""
    trace = recording_pixel(recording) if recording else None
    panels = [PixelPanel(trace), ScenePanel(photo), ReconstructionPanel(), RealPanel()]
    tabs = pn.Tabs(*(p.view for p in panels), dynamic=False)

    def opened(event) -> None:
        start = getattr(panels[event.new], "start", None)
        if start is not None:
            start()

    tabs.param.watch(opened, "active")
    return tabs


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def serve(port: int, *, open_browser: bool, recording: str | None = None, photo: str | None = None) -> None:
    """Serve the lab on http://127.0.0.1:port/ until interrupted (blocks; KeyboardInterrupt on Ctrl-C)."""
    pn.config.design = None
    pn.serve({"/": lambda: lab(recording, photo)}, port=port, address="127.0.0.1",
             websocket_origin=[f"127.0.0.1:{port}", f"localhost:{port}"], show=open_browser, title=TITLE,
             print_url=False, threaded=False)
