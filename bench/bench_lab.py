"""Benchmark of the teaching lab's responsiveness (not a test): time from a slider change to the updated view.

Two measurements per panel (the one-pixel panel, and the scene panel at the DAVIS346's 346x260):
- in the browser: `evsim lab --no-browser` in a subprocess and Debian's Chromium driven by Playwright; the time from
  an arrow key on the threshold slider's handle to the new event count on the page (the value's trip to the server,
  the models, the new plot data's trip back and the page's redraw of the count);
- on the server: PanelClass.update() in this process (the models plus filling the plots' data sources).
Targets: pixel panel < 200 ms, scene panel < 1 s. Writes docs/results/lab.md (the machine, load and commit beside
the figures) unless --no-write. The machine is shared: the load average is recorded; medians are reported.

    PYTHONPATH=. python bench/bench_lab.py [--repeats 10] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
from make_results import machine, machine_block  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
TARGET_MS = {"pixel": 200.0, "scene": 1000.0}


def server_side(repeats: int) -> dict:
    """Median and max ms of update() after a threshold change, per panel (first, compiling, call excluded)."""
    from evsim_app.lab.pixel_panel import PixelPanel
    from evsim_app.lab.scene_panel import ScenePanel

    out = {}
    for name, panel, widget in (("pixel", PixelPanel(), "pos_threshold"), ("scene", ScenePanel(), "threshold")):
        panel.update()
        times = []
        for k in range(repeats):
            panel.w[widget].value = 0.2 + 0.05 * (k % 2)
            t0 = time.perf_counter()
            panel.update()
            times.append(1e3 * (time.perf_counter() - t0))
        out[name] = times
    return out


def in_browser(repeats: int) -> dict:
    """ms from an arrow key on the threshold slider to the new count in the page, per panel."""
    from playwright.sync_api import sync_playwright

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "evsim_app", "lab", "--no-browser", "--port", str(port)], cwd=ROOT,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    proc.stdout.readline()
    out = {}
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 1250, "height": 950})
            for _ in range(100):
                try:
                    page.goto(f"http://127.0.0.1:{port}/")
                    break
                except Exception:  # the server is still starting
                    time.sleep(0.3)
            panels = (("pixel", None, "ON threshold", "#pixel-events"),
                      ("scene", "Sensor over a scene", "contrast threshold C", "#scene-events"))
            for name, tab, title, element in panels:
                if tab:
                    page.locator(".bk-tab", has_text=tab).click()
                page.wait_for_selector(element, timeout=120_000)
                handle = page.locator(".bk-input-group", has_text=title).locator(".noUi-handle")
                times = []
                for k in range(repeats + 1):
                    text = page.inner_text(element)
                    handle.focus()
                    t0 = time.perf_counter()
                    page.keyboard.press("ArrowRight" if k % 2 == 0 else "ArrowLeft")
                    while page.inner_text(element) == text:
                        time.sleep(0.002)
                    times.append(1e3 * (time.perf_counter() - t0))
                out[name] = times[1:]  # the first change compiles nothing but warms the page
            browser.close()
    finally:
        proc.send_signal(2)
        proc.communicate(timeout=30)
    return out


def page(server: dict, browser: dict | None, m: dict, repeats: int) -> str:
    rows = []
    for name, label in (("pixel", "one pixel (1 s at 5 kHz, 30 frames, AKF)"), ("scene", "sensor over a scene, "
                                                                                         "346x260, 100 ms at 1 kHz")):
        b = browser[name] if browser else None
        rows.append(f"| {label} | {TARGET_MS[name]:.0f} | "
                    + (f"{statistics.median(b):.0f} / {max(b):.0f}" if b else "not run (no Chromium)")
                    + f" | {statistics.median(server[name]):.0f} / {max(server[name]):.0f} |")
    return "\n".join([
        "# Lab responsiveness", "",
        "Time from a change of a threshold slider to the updated view in `evsim lab` (issue 35), "
        f"{repeats} changes per panel, median / largest in ms. In the browser: Debian's Chromium (headless) driven "
        "by Playwright, from the arrow key on the slider's handle to the new event count on the page (the round "
        "trip to the server, the models and the redraw). On the server: the panel's update() alone (the models and "
        "the plots' new data). The machine is shared with other work (its load below), so the figures are noisy.",
        "", *machine_block(m),
        "Command: `python bench/bench_lab.py`", "",
        "| panel | target (ms) | in the browser: median / max (ms) | server update(): median / max (ms) |",
        "|---|---|---|---|", *rows, ""])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10, help="slider changes per panel")
    parser.add_argument("--no-write", action="store_true", help="print only; do not write docs/results/lab.md")
    args = parser.parse_args()
    m = machine()
    server = server_side(args.repeats)
    browser = in_browser(args.repeats) if Path(CHROMIUM).is_file() else None
    text = page(server, browser, m, args.repeats)
    print(text)
    if not args.no_write:
        (ROOT / "docs" / "results" / "lab.md").write_text(text)


if __name__ == "__main__":
    main()
