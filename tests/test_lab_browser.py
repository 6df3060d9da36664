"""`evsim lab` in a real headless browser (Debian's Chromium driven by Playwright): moving a threshold slider
changes the number of events shown as the model says, the page logs no error and no request leaves localhost.

EVSIM_LAB_SCREENSHOTS=FOLDER also writes the screenshots the docs page shows (docs/figures/lab_*.png)."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import urlparse

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
LOCAL_HOSTS = {"127.0.0.1", "localhost"}


def _requirements():
    pytest.importorskip("panel", reason="the lab extra (panel) is not installed")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    if not Path(CHROMIUM).is_file():
        pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium)")
    return sync_api


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def lab_url():
    """`evsim lab --no-browser --port P` as a subprocess; its address once it answers."""
    _requirements()
    port = _free_port()
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "evsim_app", "lab", "--no-browser", "--port", str(port)],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    line = proc.stdout.readline()
    assert f"http://127.0.0.1:{port}/" in line, line
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            time.sleep(0.2)
    yield f"http://127.0.0.1:{port}/"
    proc.send_signal(2)  # Ctrl-C: stops cleanly with exit 0 and a message
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out
    assert "evsim lab: stopped" in out


@pytest.fixture
def page(lab_url, tmp_path):
    """A fresh Chromium page on the lab; records every request and every console error or page error."""
    sync_api = _requirements()
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch_persistent_context(str(tmp_path / "profile"), executable_path=CHROMIUM,
                                                       args=ARGS, viewport={"width": 1250, "height": 950})
        pg = browser.new_page()
        pg.requests, pg.errors = [], []
        pg.on("request", lambda r: pg.requests.append(r.url))
        pg.on("console", lambda m: pg.errors.append(m.text) if m.type == "error" else None)
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))
        pg.goto(lab_url)
        yield pg
        browser.close()


def _count(pg, element_id: str) -> int:
    return int(pg.inner_text(f"#{element_id}"))


def _press_until_changed(pg, slider_title: str, element_id: str, presses: int) -> tuple[int, int]:
    """Focus the handle of the slider titled slider_title, press the right arrow `presses` times (one step each)
    and wait for the counter to change; (count before, count after)."""
    before = _count(pg, element_id)
    handle = pg.locator(".bk-input-group", has_text=slider_title).locator(".noUi-handle")
    handle.focus()
    for _ in range(presses):
        pg.keyboard.press("ArrowRight")
    deadline = time.monotonic() + 30
    while _count(pg, element_id) == before and time.monotonic() < deadline:
        time.sleep(0.05)
    return before, _count(pg, element_id)


def _only_local(requests: list[str]) -> list[str]:
    return [u for u in requests if urlparse(u).scheme not in ("blob", "data")
            and urlparse(u).hostname not in LOCAL_HOSTS]


def _screenshot(pg, name: str, tmp_path: Path) -> None:
    pg.screenshot(path=str(tmp_path / name))
    folder = os.environ.get("EVSIM_LAB_SCREENSHOTS")
    if folder:
        from PIL import Image

        img = Image.open(tmp_path / name).convert("RGB")
        img.thumbnail((1000, 1000))
        img.quantize(colors=128).save(Path(folder) / name, optimize=True)


def test_pixel_threshold_slider_lowers_the_event_count(page, tmp_path):
    from evsim_app.lab.pixel_model import PixelSettings, simulate_pixel

    page.wait_for_selector("#pixel-events", timeout=60_000)
    before, after = _press_until_changed(page, "ON threshold", "pixel-events", presses=3)  # C_on 0.20 -> 0.35
    assert before == simulate_pixel(PixelSettings()).n_events
    assert after == simulate_pixel(PixelSettings(pos_threshold=0.35)).n_events
    assert after < before
    _screenshot(page, "lab_pixel.png", tmp_path)
    assert page.errors == []
    assert _only_local(page.requests) == []
    assert any(u.endswith(".js") for u in page.requests)  # the scripts were requested, from here


def test_scene_threshold_slider_lowers_the_event_count(page, tmp_path):
    from evsim_app.lab.scene_model import SceneSettings, simulate_scene

    page.locator(".bk-tab", has_text="Sensor over a scene").click()
    page.wait_for_selector("#scene-events", timeout=120_000)  # the scene is rendered on first display
    before, after = _press_until_changed(page, "contrast threshold C", "scene-events", presses=2)  # 0.2 -> 0.3
    assert before == simulate_scene(SceneSettings()).n_events
    assert after == simulate_scene(SceneSettings(threshold=0.3)).n_events
    assert after < before
    _screenshot(page, "lab_scene.png", tmp_path)
    assert page.errors == []
    assert _only_local(page.requests) == []
