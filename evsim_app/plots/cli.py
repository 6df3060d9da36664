"""`evsim plot pixel|events|compare|sweep|roc|realism`: registered on the evsim command line by
add_plot_parser(subparsers).

Handlers raise sim.EvsimInputError on bad input (the evsim entry point prints "evsim: error: ..." and exits 2);
this includes a missing matplotlib (evsim_app.plots.common.PlotDependencyError, with the pip command to fix it).
Figures are written atomically; the format follows the --out suffix (.png, .pdf, .svg, ...).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sim import EvsimInputError

PLOT_EPILOG = ("Times in milliseconds (-ms) or seconds (-s) as the flag names say, pixel coordinates from 0 "
               "(x: column, y: row). Log intensities are natural logs of the CRF's scaled irradiance plus I0. "
               "Needs matplotlib: pip install 'evsim[plot]'. Exit codes: 0 success, 2 bad input, 1 unexpected failure, "
               "130 Ctrl-C, 143 SIGTERM.")


def _default_out(dataset: Path, kind: str) -> Path:
    return Path(f"{Path(dataset).stem}_{kind}.png")


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return v


def _cmd_pixel(args) -> int:
    from .common import load_recording, prepare
    from .pixel import check_pixel, plot_pixel

    rec = load_recording(args.dataset)
    check_pixel(rec, args.x, args.y)
    out = args.out or _default_out(args.dataset, f"pixel_x{args.x}_y{args.y}")
    s = plot_pixel(prepare(rec), args.x, args.y, out, n_times=args.n_times)
    print(f"wrote {out} (pixel x={args.x}, y={args.y}: {s.event_t_us.size} events, {s.frame_log.size} frames)")
    return 0


def _cmd_events(args) -> int:
    from generators.formats import detect
    from generators.formats.streaming import open_event_stream

    from .common import load_recording, prepare
    from .events import plot_events

    if args.video is not None:
        from .video import check_video_options, write_video

        check_video_options(args.video, args.frame_ms, args.video_fps, args.full_scale, args.scale)
        if not Path(args.dataset).exists():
            raise EvsimInputError(f"dataset not found: {args.dataset}")
        v = write_video(args.dataset, args.video, frame_ms=args.frame_ms, fps=args.video_fps,
                        full_scale=args.full_scale, scale=args.scale, progress=not args.no_progress)
        print(f"wrote {args.video} ({v['frames']} frames of {v['frame_us'] / 1e3:g} ms, {v['events']} events, "
              f"played at {args.video_fps:g} fps)")
        if args.out is None and args.animate is None:
            return 0
    if args.animate is not None:
        from .animate import check_output

        check_output(args.animate)
    # a native file is read window by window (memory stays flat); other layouts, and an animation, load it
    native = args.animate is None and Path(args.dataset).is_file() and detect(args.dataset) == "native"
    rec = open_event_stream(args.dataset) if native else load_recording(args.dataset)
    out = args.out or _default_out(args.dataset, "events")
    res = plot_events(rec, out, at_ms=args.at_ms, window_ms=args.window_ms, bin_ms=args.bin_ms)
    print(f"wrote {out} (windows ending at {', '.join(f'{t / 1e3:g}' for t in res['times_us'])} ms)")
    if args.animate is not None:
        from .animate import animate

        animate(prepare(rec), args.animate, n_frames=args.frames, fps=args.fps)
        print(f"wrote {args.animate} ({args.frames} frames at {args.fps:g} fps)")
    return 0


def _cmd_compare(args) -> int:
    from .common import load_recording, prepare
    from .compare import plot_compare

    prep = prepare(load_recording(args.dataset), need_reference=True)
    out = args.out or _default_out(args.dataset, "compare")
    t_us = None if args.at_ms is None else int(round(args.at_ms * 1e3))
    res = plot_compare(prep, out, t_us=t_us, methods=tuple(args.methods))
    scores = ", ".join(f"{m} {v:.2f} dB" for m, v in res["pu21_psnr"].items())
    print(f"wrote {out} (t = {res['t_us'] / 1e3:g} ms; PU21-PSNR: {scores})")
    print(f"tone mapping: {res['tone_map'].describe()}")
    return 0


def _cmd_realism(args) -> int:
    from .realism import cmd_realism

    return cmd_realism(args)


def _cmd_sweep(args) -> int:
    from .sweep import AUC_METRICS, DEFAULT_FILTERS, DEFAULT_METHODS, METRICS_FILE, plot_sweep

    out = args.out or Path(f"{Path(args.results).resolve().name}_sweep.png")
    methods = args.methods or (DEFAULT_FILTERS if args.metric in AUC_METRICS else DEFAULT_METHODS)
    rows = plot_sweep(args.results, out, methods=tuple(methods), metric=args.metric, recompute=args.recompute,
                      progress=not args.no_progress)
    print(f"wrote {out} ({len(rows)} grid points; scores in {Path(args.results) / METRICS_FILE})")
    return 0


def _cmd_roc(args) -> int:
    from .roc import load_roc_result, plot_roc

    filters = None if args.filters is None else tuple(args.filters)
    out = args.out or Path(f"{Path(args.source).stem}_roc.png")
    result = load_roc_result(args.source, filters)
    aucs = plot_roc(result, out)
    n = len(result["sequences"])
    scores = ", ".join(f"{name} {a['all']:.3f}" for name, a in aucs.items())
    if n == 1:
        print(f"wrote {out} (AUC over all noise: {scores})")
    else:
        mean = ", ".join(f"{name} {result['mean_auc'][name]['all']:.3f}" for name in aucs if name in
                         result.get("mean_auc", {}))
        print(f"wrote {out} (AUC over all noise, the {n} sequences' points pooled: {scores}; mean of the "
              f"sequences' AUCs, as evsim evaluate reports: {mean})")
    return 0


def _add_events_parser(psub: argparse._SubParsersAction) -> None:
    """Register `plot events` (figure, animation and DVS video)."""
    e = psub.add_parser("events", epilog=PLOT_EPILOG,
                        help="event frames (ON red, OFF blue), time surfaces and the event rate over time")
    e.add_argument("dataset", type=Path, help="a dataset (any layout evsim reads)")
    e.add_argument("--at-ms", type=float, nargs="+", help="window end times in ms (default: 3 spread over the data)")
    e.add_argument("--window-ms", type=float, default=10.0, help="event-frame window and time-surface decay in ms "
                                                                 "(default 10)")
    e.add_argument("--bin-ms", type=float, help="event-rate bin in ms (default: the span / 200, at least 0.1 ms)")
    e.add_argument("--out", type=Path, help="figure file (default ./<dataset>_events.png)")
    e.add_argument("--animate", type=Path, metavar="FILE",
                   help="also write an animation of events against the AKF reconstruction (.gif; .mp4 needs ffmpeg)")
    e.add_argument("--frames", type=_positive_int, default=40, help="animation frames (default 40)")
    e.add_argument("--fps", type=float, default=10.0, help="animation frames per second (default 10)")
    e.add_argument("--video", type=Path, metavar="FILE",
                   help="write a DVS video instead of the figure (add --out for both): event frames over "
                        "consecutive --frame-ms intervals, ON red, OFF blue; .mp4 (OpenCV) or .gif; streamed, so "
                        "memory does not grow with the recording")
    e.add_argument("--frame-ms", type=float, default=10.0, help="video: the interval each frame accumulates, ms "
                                                                "(default 10)")
    e.add_argument("--video-fps", type=float, default=30.0, help="video: playback frames per second (default 30)")
    e.add_argument("--full-scale", type=_positive_int, default=3,
                   help="video: events of one polarity in a frame that give the full colour (default 3, at most 15)")
    e.add_argument("--scale", type=_positive_int, default=1, help="video: pixels per sensor pixel side (default 1)")
    e.add_argument("--no-progress", action="store_true", help="video: no progress bar")
    e.set_defaults(func=_cmd_events)


def add_plot_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `plot` and its subcommands on the evsim subparsers; return the `plot` parser."""
    plot = subparsers.add_parser("plot", help="figures: one pixel over time, events and DVS videos, method comparison, "
                                              "sweeps, denoisers' ROC curves, realism",
                                 epilog=PLOT_EPILOG)
    psub = plot.add_subparsers(dest="plot_kind", required=True)

    p = psub.add_parser("pixel", epilog=PLOT_EPILOG,
                        help="one pixel over time in log intensity (right axis in x): truth, DVS reference level and "
                             "events, LDR samples over the frames' recorded range, augmented frame, AKF +-2 sqrt(P) "
                             "and complementary filter")
    p.add_argument("dataset", type=Path, help="a dataset with events, frames and a CRF (native HDF5 from evsim)")
    p.add_argument("--x", type=int, required=True, help="pixel column (0 .. width-1)")
    p.add_argument("--y", type=int, required=True, help="pixel row (0 .. height-1)")
    p.add_argument("--n-times", type=_positive_int, default=1500, help="dense sample times of the estimates "
                                                                       "(default 1500)")
    p.add_argument("--out", type=Path, help="figure file (default ./<dataset>_pixel_x<X>_y<Y>.png)")
    p.set_defaults(func=_cmd_pixel)

    _add_events_parser(psub)

    c = psub.add_parser("compare", epilog=PLOT_EPILOG,
                        help="LDR input, each method's reconstruction and the HDR reference through one log tone "
                             "map (colour bar in x, the frames' range marked), signed log-error and gain maps")
    c.add_argument("dataset", type=Path, help="a dataset with events, frames, a CRF and HDR reference frames")
    c.add_argument("--at-ms", type=float, help="time in ms; the nearest reference frame is used (default: the one "
                                               "nearest the middle)")
    c.add_argument("--methods", nargs="+", default=["akf", "cf", "frames"],
                   help="akf.METHODS to show (default: akf cf frames)")
    c.add_argument("--out", type=Path, help="figure file (default ./<dataset>_compare.png)")
    c.set_defaults(func=_cmd_compare)

    s = psub.add_parser("sweep", epilog=PLOT_EPILOG,
                        help="reconstruction error, or a denoiser's ROC AUC, against each swept noise parameter")
    s.add_argument("results", type=Path, help="the output folder of `evsim generate sweep`")
    s.add_argument("--metric", default="mse", help="mse (default), psnr, ssim, pu21_psnr or pu21_ssim; or a "
                                                   "denoiser's ROC AUC: auc (all noise), auc_shot, auc_leak, auc_hot "
                                                   "(sweeps written with --labels)")
    s.add_argument("--methods", nargs="+", help="methods (default: akf cf frames), or with an AUC metric the "
                                                "sim.denoise filters (default: correlation hot_pixel)")
    s.add_argument("--recompute", action="store_true", help="ignore the cached sweep_metrics.json")
    s.add_argument("--no-progress", action="store_true", help="no progress messages")
    s.add_argument("--out", type=Path, help="figure file (default ./<results folder>_sweep.png)")
    s.set_defaults(func=_cmd_sweep)

    r = psub.add_parser("roc", epilog=PLOT_EPILOG,
                        help="ROC curves of event denoisers (TPR on signal against FPR per noise type) with AUCs")
    r.add_argument("source", type=Path, help="a dataset written with --labels, or the --json of `evsim evaluate "
                                             "DATASET --task denoise`")
    r.add_argument("--filters", nargs="+", help="filters to draw (sim.denoise.FILTERS; default: all installed, or "
                                                "all in the JSON)")
    r.add_argument("--out", type=Path, help="figure file (default ./<source>_roc.png)")
    r.set_defaults(func=_cmd_roc)

    r = psub.add_parser("realism", epilog=PLOT_EPILOG,
                        help="a real recording's events beside a simulation's: event frames, per-pixel counts, "
                             "10 ms event rate, inter-event intervals, events per passage (evsim evaluate --task "
                             "realism's statistics)")
    r.add_argument("real", type=Path, help="the real recording (AEDAT4, IJRR folder, native HDF5, ...)")
    r.add_argument("sim", type=Path, help="the simulated recording (same sensor size and time axis)")
    r.add_argument("--window", type=float, nargs=2, metavar=("START_S", "END_S"),
                   help="scored time in s from each recording's origin (first exposure start; default: all)")
    r.add_argument("--at-s", type=float, help="middle of the event frames in s (default: the real recording's "
                                              "busiest 10 ms)")
    r.add_argument("--window-ms", type=float, default=20.0, help="event-frame window in ms (default 20)")
    r.add_argument("--out", type=Path, help="figure file (default ./<sim>_realism.png)")
    r.set_defaults(func=_cmd_realism)
    return plot
