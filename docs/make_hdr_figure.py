"""Render the README's HDR figure: the reference, frames only and the AKF tone-mapped alike, with log-error maps.

    python docs/make_hdr_figure.py DATASET OUT.png [--methods frames akf ...] [--at-ms T]

DATASET is an AHDR sequence with events, frames and an HDR reference (e.g. one generated from the Desk photo with
`evsim generate ahdr`); the figure shows one reference time (default: the one nearest the middle of the frames)
through evsim_app.plots.plot_hdr_recovery: every panel through one global log tone map (the reference's 1st to
99.9th percentile, x units on the colour bar, the frames' recorded range marked on it), and each method's log
error against the reference (diverging colours, one symmetric range). The methods are called through akf.METHODS
by name, as they are in this checkout; the default is frames and akf, and aks when akf.METHODS has it.
Run from the repository root (this checkout's packages first on the path).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import akf  # noqa: E402
from evsim_app.plots import load_recording, plot_hdr_recovery, prepare  # noqa: E402
from sim import EvsimInputError  # noqa: E402


def default_methods() -> list[str]:
    """["frames", "akf"], and "aks" when akf.METHODS has it."""
    return ["frames", "akf"] + (["aks"] if "aks" in akf.METHODS else [])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="AHDR sequence with events, frames and an HDR reference")
    parser.add_argument("out", type=Path, help="figure file (.png, .pdf, .svg)")
    parser.add_argument("--methods", nargs="+", default=default_methods(),
                        help=f"akf.METHODS to show (default: {' '.join(default_methods())})")
    parser.add_argument("--at-ms", type=float, help="time in ms; the nearest reference frame is used (default: "
                                                    "the one nearest the middle of the frames)")
    args = parser.parse_args(argv)
    try:
        prep = prepare(load_recording(args.dataset), need_reference=True)
        t_us = None if args.at_ms is None else int(round(args.at_ms * 1e3))
        res = plot_hdr_recovery(prep, args.out, t_us=t_us, methods=args.methods,
                                label=args.dataset.stem)
    except EvsimInputError as e:
        parser.exit(2, f"{parser.prog}: error: {e}\n")
    scores = ", ".join(f"{m} {v:.2f} dB" for m, v in res["pu21_psnr"].items())
    print(f"wrote {args.out} (t = {res['t_us'] / 1e3:g} ms; PU21-PSNR: {scores}; {res['tone_map'].describe()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
