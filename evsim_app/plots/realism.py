"""`evsim plot realism REAL SIM`: a real recording's events beside a simulation's, on the statistics of the realism
score (evsim_eval.realism): event frames over one short window side by side, per-pixel event counts over the scored
time, the whole-sensor 10 ms event rate, the same-pixel inter-event-interval histograms and the events per
passage. Registered on `evsim plot` by add_realism_plot_parser.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from evsim_eval.realism import INTERVAL_EDGES_US, Comparison, load_one, score_recordings
from evsim_eval.realism.stats import RealismStats, bin_edges
from generators.formats.recording import Recording
from sim import EvsimInputError

from .common import ON_COLOUR, pyplot, save_figure
from .events import event_frame, event_frame_rgb

REAL_COLOUR, SIM_COLOUR = "0.15", (0.85, 0.45, 0.1)  # black real, orange simulation in every panel
MAX_PASSAGE_EVENTS = 20  # the passage histogram's last bin holds this many events and more


def rate_bins_s(stats: RealismStats) -> np.ndarray:
    """Start of every rate bin of stats (s from the recording's origin), in the order of stats.rate_hz."""
    return np.concatenate([bin_edges(a, b)[:-1] for a, b in stats.windows_us]).astype(float) / 1e6 - \
        stats.origin_us / 1e6


def busiest_time_s(stats: RealismStats) -> float:
    """Middle of the real recording's busiest rate bin (s from its origin).

    Parameters
    ----------
    stats : RealismStats
        The real recording's statistics.

    Returns
    -------
    float
        Seconds from its origin.
    """
    k = int(np.argmax(stats.rate_hz))
    return float(rate_bins_s(stats)[k]) + 0.005


def plot_realism(c: Comparison, real: Recording, sim: Recording, out: str | Path, *, at_s: float | None = None,
                 window_ms: float = 20.0) -> dict:
    """Draw the realism figure of the Comparison c of sim against real (score_recordings) into the image file out.

    Parameters
    ----------
    c : Comparison
        The comparison (evsim_eval.realism.score_recordings).
    real, sim : Recording
        The two recordings.
    out : str or pathlib.Path
        The image file.
    at_s : float, optional
        Middle of the event frames' window (s from each recording's origin; default: the real recording's busiest
        10 ms).
    window_ms : float, optional
        The event frames' window [at_s - window_ms / 2, at_s + window_ms / 2) (ms), > 0 (default 20).

    Returns
    -------
    dict
        {"at_s", "frames": (real, sim) (2, H, W) counts}.
    """
    if not window_ms > 0:
        raise EvsimInputError(f"--window-ms must be > 0, got {window_ms}")
    at_s = busiest_time_s(c.real) if at_s is None else float(at_s)
    half = int(round(window_ms * 500))
    frames = [event_frame(rec.events, rec.height, rec.width, stats.origin_us + round(at_s * 1e6) - half,
                          stats.origin_us + round(at_s * 1e6) + half)
              for rec, stats in ((real, c.real), (sim, c.sim))]

    plt = pyplot()
    aspect = real.height / real.width
    fig = plt.figure(figsize=(16, 4 * aspect + 4.6), layout="constrained")
    grid = fig.add_gridspec(2, 4, height_ratios=[4 * aspect, 3.6])
    for k, (name, counts) in enumerate(zip(("real", "simulated"), frames)):
        ax = fig.add_subplot(grid[0, k])
        ax.imshow(event_frame_rgb(counts), interpolation="nearest")
        ax.set_title(f"{name} events, {at_s - window_ms / 2e3:.3f}-{at_s + window_ms / 2e3:.3f} s\n"
                     f"ON {int(counts[0].sum())}, OFF {int(counts[1].sum())}", fontsize=9)
        ax.axis("off")
    maps = [s.counts.sum(axis=0) for s in (c.real, c.sim)]
    map_axes = []
    top = max(float(np.percentile(maps[0], 99.5)), 1.0)
    for k, (name, counts) in enumerate(zip(("real", "simulated"), maps)):
        ax = fig.add_subplot(grid[0, 2 + k])
        map_axes.append(ax)
        im = ax.imshow(np.log10(1 + counts), cmap="magma", vmin=0, vmax=np.log10(1 + top), interpolation="nearest")
        ax.set_title(f"{name}: events per pixel over the scored {c.real.duration_s:.3g} s\n(one scale)", fontsize=9)
        ax.axis("off")
    fig.colorbar(im, ax=map_axes, fraction=0.03, label="log10(1 + events)")

    ax = fig.add_subplot(grid[1, :2])
    t = rate_bins_s(c.real)
    for stats, name, colour in ((c.real, "real", REAL_COLOUR), (c.sim, "simulated", SIM_COLOUR)):
        ax.step(t, stats.rate_hz / 1e3, where="post", color=colour, lw=1, label=name)
    for a, b in c.real.gaps_us:
        ax.axvspan((a - c.real.origin_us) / 1e6, (b - c.real.origin_us) / 1e6, color="0.85", lw=0)
    ax.axvspan(at_s - window_ms / 2e3, at_s + window_ms / 2e3, color=ON_COLOUR, alpha=0.15, lw=0)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("events (k/s, 10 ms bins)")
    ax.set_title(f"whole-sensor event rate: correlation {c.scores['rate_corr']:.3g}, relative RMS error "
                 f"{c.scores['rate_rel_rmse']:.3g}" + (" (grey: gaps, not scored)" if c.real.gaps_us.size else ""),
                 fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    ax = fig.add_subplot(grid[1, 2])
    for stats, name, colour in ((c.real, "real", REAL_COLOUR), (c.sim, "simulated", SIM_COLOUR)):
        ax.stairs(stats.interval_pdf, INTERVAL_EDGES_US / 1e3, color=colour, label=name)
    ax.set_xscale("log")
    ax.set_xlabel("interval between a pixel's events (ms)")
    ax.set_ylabel("fraction of intervals")
    ax.set_title(f"inter-event intervals: L1 {c.scores['interval_l1']:.3g}", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    ax = fig.add_subplot(grid[1, 3])
    edges = np.arange(1, MAX_PASSAGE_EVENTS + 2) - 0.5
    for stats, name, colour in ((c.real, "real", REAL_COLOUR), (c.sim, "simulated", SIM_COLOUR)):
        n = np.minimum(stats.passages, MAX_PASSAGE_EVENTS)
        share = np.bincount(n, minlength=MAX_PASSAGE_EVENTS + 1)[1:] / max(n.size, 1)
        ax.stairs(share, edges, color=colour, label=f"{name} (median {stats.passage_median:g})")
    ax.set_xlabel(f"events per pixel per passage (last bin: >= {MAX_PASSAGE_EVENTS})")
    ax.set_ylabel("fraction of passages")
    ax.set_title("passages", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ratios = c.scores
    fig.suptitle(f"events x{ratios['count_ratio']:.3g} (ON x{ratios['on_ratio']:.3g}, OFF x{ratios['off_ratio']:.3g})"
                 f"; quiet static noise ON x{ratios['quiet_on_ratio']:.3g}; per-pixel count correlation "
                 f"{ratios['count_corr']:.3g} ({ratios['count_corr_blurred']:.3g} 5x5 blurred)", fontsize=10)
    save_figure(fig, out)
    return {"at_s": at_s, "frames": frames}


def cmd_realism(args: argparse.Namespace) -> int:
    real, sim = load_one(args.real, "REAL"), load_one(args.sim, "SIM")
    c = score_recordings(real, sim, None if args.window is None else tuple(args.window))
    out = args.out or Path(f"{Path(args.sim).stem}_realism.png")
    res = plot_realism(c, real, sim, out, at_s=args.at_s, window_ms=args.window_ms)
    print(f"wrote {out} (event frames at {res['at_s']:.3f} s; events x{c.scores['count_ratio']:.3g}, interval L1 "
          f"{c.scores['interval_l1']:.3g})")
    return 0
