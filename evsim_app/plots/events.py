"""Event visualisation (`evsim plot events`): event frames, time surfaces and the event rate over time.

- Event frame over [t - window, t): per pixel the ON and OFF counts; drawn on white, ON towards red, OFF towards
  blue (pixels with many of both turn dark), saturating at the 99th percentile of the counts.
- Time surface at t (Lagorce et al. 2017 [Lagorce2017]): S = p * exp(-(t - t_last) / tau) with t_last and p the
  time and polarity of the pixel's latest event before t (0 where none in the last 10 tau); tau = the window length.
- Event rate: ON and OFF events per second (whole sensor) in bins of bin_ms.

References (docs/models/references.md): Lagorce et al. 2017 [Lagorce2017], time surfaces.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from generators.formats.streaming import EventStream
from sim import EVENT_DTYPE, EvsimInputError, slice_time

from .common import OFF_COLOUR, ON_COLOUR, pyplot, save_figure

_EMPTY = np.zeros(0, EVENT_DTYPE)

if TYPE_CHECKING:
    from generators.formats.recording import Recording


def event_frame(events: np.ndarray, height: int, width: int, t_start_us: int, t_end_us: int) -> np.ndarray:
    """(2, H, W) int64 counts of ON (index 0) and OFF (index 1) events with t_start_us <= t < t_end_us.

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    t_start_us, t_end_us : int
        The window, int64 us.

    Returns
    -------
    numpy.ndarray
        (2, H, W) int64 counts.
    """
    ev = slice_time(events, t_start_us, t_end_us)
    counts = np.zeros((2, height * width), np.int64)
    idx = ev["y"].astype(np.int64) * width + ev["x"]
    on = ev["p"] > 0
    counts[0] = np.bincount(idx[on], minlength=height * width)
    counts[1] = np.bincount(idx[~on], minlength=height * width)
    return counts.reshape(2, height, width)


def time_surface(events: np.ndarray, height: int, width: int, t_us: int, tau_us: float) -> np.ndarray:
    """(H, W) float64 signed exponential time surface at t_us (see the module docstring).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    t_us : int
        The time (int64 us); events before it count.
    tau_us : float
        The decay time (us), > 0.

    Returns
    -------
    numpy.ndarray
        (H, W) float64 values in [-1, 1].
    """
    if not tau_us > 0:
        raise EvsimInputError(f"time-surface decay must be > 0 us, got {tau_us}")
    ev = slice_time(events, int(t_us - 10 * tau_us), int(t_us))
    idx = ev["y"].astype(np.int64) * width + ev["x"]
    # the latest event per pixel: the first occurrence in the reversed (time-descending) order
    _, first = np.unique(idx[::-1], return_index=True)
    last = ev[::-1][first]
    out = np.zeros(height * width)
    out[idx[::-1][first]] = last["p"] * np.exp(-(t_us - last["t"]) / tau_us)
    return out.reshape(height, width)


def event_rate(events: np.ndarray | Mapping[str, np.ndarray], bin_us: int, t_start_us: int | None = None,
               t_end_us: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Events per second in consecutive bins of bin_us microseconds.

    Parameters
    ----------
    events : numpy.ndarray or mapping
        An event array, or a mapping of its "t" and "p" columns.
    bin_us : int
        Bin length (us), >= 1.
    t_start_us, t_end_us : int, optional
        The span (int64 us; default: the first event to just after the last).

    Returns
    -------
    bin_start_us : numpy.ndarray
        int64 start of every bin (us).
    on_rate_hz, off_rate_hz : numpy.ndarray
        ON and OFF events per second in every bin (Hz).
    """
    if bin_us < 1:
        raise EvsimInputError(f"rate bin must be >= 1 us, got {bin_us}")
    t = events["t"]
    if t_start_us is None:
        t_start_us = int(t[0]) if t.size else 0
    if t_end_us is None:
        t_end_us = int(t[-1]) + 1 if t.size else t_start_us + bin_us
    t0, t1 = int(t_start_us), int(t_end_us)
    edges = np.arange(t0, t1 + bin_us, bin_us, dtype=np.int64)
    on = events["p"] > 0
    scale = 1e6 / bin_us
    return (edges[:-1], np.histogram(t[on], edges)[0] * scale, np.histogram(t[~on], edges)[0] * scale)


def _streamed_rate(src: EventStream, bin_us: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """event_rate over the whole stream of src, summed chunk by chunk over the same bins."""
    t0 = src.t_range[0] if src.count else 0
    t1 = src.t_range[1] + 1 if src.count else t0 + bin_us
    start, on, off = event_rate(_EMPTY, bin_us, t0, t1)
    for chunk in src.chunks(("t", "p")):
        _, on_k, off_k = event_rate(chunk, bin_us, t0, t1)
        on, off = on + on_k, off + off_k
    return start, on, off


def event_frame_rgb(counts: np.ndarray, top: float | None = None) -> np.ndarray:
    """(H, W, 3) float image of a (2, H, W) event frame: white, ON towards red, OFF towards blue (see module doc),
    full colour at `top` events (default: the 99th percentile of the counts).

    Parameters
    ----------
    counts : numpy.ndarray
        (2, H, W) ON and OFF event counts (event_frame).
    top : float, optional
        Count shown in full colour (default: the 99th percentile of the non-zero counts, at least 1).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float RGB in [0, 1].
    """
    if top is None:
        top = max(float(np.percentile(counts[counts > 0], 99)) if np.any(counts > 0) else 1.0, 1.0)
    on, off = (np.clip(c / top, 0, 1)[..., None] for c in counts)
    white = np.ones(3)
    to_on, to_off = (np.array(c) - white for c in (ON_COLOUR, OFF_COLOUR))
    rgb = white + on * to_on + off * to_off
    return np.clip(rgb, 0, 1)


def default_times_us(events: np.ndarray | EventStream, n: int = 3) -> list[int]:
    """n window end times spread evenly over the events' span, on whole milliseconds (us).

    Parameters
    ----------
    events : numpy.ndarray or EventStream
        The events.
    n : int, optional
        How many (default 3).

    Returns
    -------
    list of int
        The times (us).
    """
    src = events if isinstance(events, EventStream) else EventStream.of_array(events, 1, 1)
    if src.count == 0:
        raise EvsimInputError("the dataset has no events")
    t0, t1 = src.t_range
    return [int(round((t0 + (t1 - t0) * (k + 1) / n) / 1e3)) * 1000 for k in range(n)]


def plot_events(rec: Recording | EventStream, out: str | Path, *, at_ms: Sequence[float] | None = None,
                window_ms: float = 10.0, bin_ms: float | None = None) -> dict:
    """Event frames and time surfaces at each time of at_ms (window [t - window_ms, t)), and the event rate over
    time, into the image file `out`.

    Parameters
    ----------
    rec : Recording or EventStream
        A Recording, or an EventStream (generators.formats.streaming: from open_event_stream, a native file is read
        window by window, and the rate from its t and p columns in chunks).
    out : str or pathlib.Path
        The image file.
    at_ms : sequence of float, optional
        Window end times (ms; default: 3 spread over the events' span).
    window_ms : float, optional
        Window length (ms), > 0 (default 10); also the time surfaces' decay.
    bin_ms : float, optional
        Rate bin (ms; default: about 1/200 of the span, at least 0.1 ms).

    Returns
    -------
    dict
        {"times_us", "frames", "surfaces", "rate"}: what was drawn.
    """
    src = rec if isinstance(rec, EventStream) else EventStream.of_array(rec.events, rec.height, rec.width)
    if not window_ms > 0:
        raise EvsimInputError(f"--window-ms must be > 0, got {window_ms}")
    if bin_ms is not None and not bin_ms * 1e3 >= 1:
        raise EvsimInputError(f"--bin-ms must be at least 0.001 ms, got {bin_ms}")
    win = int(round(window_ms * 1e3))
    times = default_times_us(src) if not at_ms else [int(round(t * 1e3)) for t in at_ms]
    if src.count:
        span = (src.t_range[0], src.t_range[1] + 1)
        bad = [t for t in times if not span[0] < t <= span[1] + win]
        if bad:
            raise EvsimInputError(f"time {bad[0] / 1e3:g} ms lies outside the events' span "
                                  f"{span[0] / 1e3:g}..{span[1] / 1e3:g} ms")
    h, w = src.height, src.width
    frames = [event_frame(src.window(t - win, t), h, w, t - win, t) for t in times]
    surfaces = [time_surface(src.window(int(t - 10 * win), t), h, w, t, win) for t in times]
    span_us = src.t_range[1] - src.t_range[0] + 1 if src.count else 1
    bin_us = int(round(bin_ms * 1e3)) if bin_ms else max(int(round(span_us / 200, -2)), 100)
    rate = _streamed_rate(src, bin_us)

    plt = pyplot()
    n = len(times)
    fig = plt.figure(figsize=(3.2 * n + 0.8, 8.6))
    grid = fig.add_gridspec(3, n, height_ratios=[1, 1, 0.8])
    surface_axes = []
    for k, t in enumerate(times):
        ax = fig.add_subplot(grid[0, k])
        ax.imshow(event_frame_rgb(frames[k]), interpolation="nearest")
        ax.set_title(f"events [{(t - win) / 1e3:g}, {t / 1e3:g}) ms\n"
                     f"ON {int(frames[k][0].sum())}, OFF {int(frames[k][1].sum())}", fontsize=8)
        ax.axis("off")
        ax = fig.add_subplot(grid[1, k])
        surface_axes.append(ax)
        im = ax.imshow(surfaces[k], cmap="RdBu_r", vmin=-1, vmax=1, interpolation="nearest")
        ax.set_title(f"time surface at {t / 1e3:g} ms (tau {window_ms:g} ms)", fontsize=8)
        ax.axis("off")
    fig.colorbar(im, ax=surface_axes, fraction=0.03, label="p exp(-dt / tau)")
    ax = fig.add_subplot(grid[2, :])
    t_ms = (rate[0] + bin_us / 2) / 1e3
    ax.plot(t_ms, rate[1] / 1e3, color=ON_COLOUR, lw=1, label="ON")
    ax.plot(t_ms, rate[2] / 1e3, color=OFF_COLOUR, lw=1, label="OFF")
    for t in times:
        ax.axvspan((t - win) / 1e3, t / 1e3, color="0.8", alpha=0.5)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel(f"event rate (k events/s, {bin_us / 1e3:g} ms bins)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save_figure(fig, out)
    return {"times_us": times, "frames": frames, "surfaces": surfaces, "rate": rate}
