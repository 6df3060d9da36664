"""Regenerate the README's figures in docs/figures/ (small PNGs) from a built-in AHDR sequence.

pixel.png: one pixel over time (evsim plot pixel); compare.png: the methods side by side (evsim plot compare);
events.png: event frames, time surfaces and the event rate (evsim plot events).

Run from the repository root: python examples/make_readme_figures.py [--out docs/figures]
"""

import argparse
import tempfile
from pathlib import Path

from _shared import builtin_sequence

from evsim_app.plots import load_recording, plot_compare, plot_events, plot_pixel, prepare

PIXEL = (11, 49)  # x, y: a mostly well-exposed pixel of the sequence below, with clipped stretches


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "figures")
    out = parser.parse_args().out
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        prep = prepare(load_recording(builtin_sequence(Path(tmp) / "readme.h5", sensor="davis346", crf="window")))
        plot_pixel(prep, *PIXEL, out / "pixel.png", n_times=800)
        plot_compare(prep, out / "compare.png")
        plot_events(prep.rec, out / "events.png", at_ms=[150, 300, 450], window_ms=10)
    for name in ("pixel.png", "compare.png", "events.png"):
        print(f"wrote {out / name} ({(out / name).stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
