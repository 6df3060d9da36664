"""The statistics of one event stream over time windows, for the realism score (evsim_eval.realism.compare).

measure(events, windows_us, height=, width=, masks=) gives a RealismStats: event counts per polarity and per pixel,
noise rates on the quiet and dark static pixels of FrameMasks (Hz per pixel), the whole-sensor event rate in
RATE_BIN_US bins, the histogram of the intervals between successive events of a pixel (log bins) and the events
per pixel per passage. measure(sim_events, like=real) measures a simulation on the windows and pixel classes of a
real recording's statistics, which are computed once (measure_recording) and reused; measure_recording narrows the
frames' quiet and dark pixels to those beyond the reach of signal in the real events (masks.beyond_signal_reach).
A recording without frames gets the pixel classes of its own events (event_masks: quiet pixels whose neighbourhood
fires no more than noise, hot pixels; no dark pixels, no passages).

Flicker: the whole-sensor event count in FLICKER_BIN_US bins over the longest window; its power spectrum's
strongest frequency in FLICKER_BAND_HZ (lamps on AC mains: 100 or 120 Hz) is the flicker when that frequency and
its two neighbouring bins hold at least FLICKER_MIN_SHARE of the rate's variance.

A passage is a maximal run of one pixel's events whose successive intervals are at most PASSAGE_GAP_US, counted
only where the recording's frames saw that pixel change (FrameMasks.motion) in a frame interval overlapping the
run: an edge or object crossing the pixel, not a noise event.

Coverage: a recording whose events cover only part of the time (dropped packets, exposure-gated exports) is
scored on the covered windows only. The gaps are the event stream's own (sim.find_gaps, the gaps the AKF reads as
missing data: an empty span that a Poisson stream of the rate on both sides would leave empty with probability
e**-30); they are cut out of the windows and listed in the notes. Resolution: the events' own times.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from sim import EvsimInputError, find_gaps, validate_events

from .kernels import pixel_runs
from .masks import FrameMasks, beyond_signal_reach, frame_masks

RATE_BIN_US = 10_000  # whole-sensor rate curve bins (us)
PASSAGE_GAP_US = 50_000  # a pixel's events further apart than this belong to different passages (us)
INTERVAL_DECADES = (0, 7)  # interval histogram from 10**0 to 10**7 us (1 us .. 10 s), out-of-range intervals clipped
BINS_PER_DECADE = 10
FLICKER_BIN_US = 1_000  # event-rate bins of the flicker spectrum (us): frequencies up to 500 Hz
FLICKER_BAND_HZ = (40.0, 500.0)  # where a flicker peak is looked for
FLICKER_MIN_SHARE = 0.2  # share of the rate's variance a peak must hold to count as flicker
#: edges (us) of the log bins of the same-pixel inter-event-interval histogram, BINS_PER_DECADE per decade
INTERVAL_EDGES_US = 10.0 ** np.arange(INTERVAL_DECADES[0], INTERVAL_DECADES[1] + 1e-9, 1 / BINS_PER_DECADE)


@dataclass
class RealismStats:
    """What measure gives (see the module). Times are int64 us, rates Hz.

    Attributes
    ----------
    height, width : int
        Sensor size (pixels).
    windows_us : numpy.ndarray
        (K, 2) scored [start, end) windows.
    gaps_us : numpy.ndarray
        (G, 2) coverage gaps cut out of the requested windows.
    masks : FrameMasks or None
        The pixel classes from the frames, or None.
    counts : numpy.ndarray
        (2, H, W) int64 ON and OFF events per pixel.
    rate_hz : numpy.ndarray
        Whole-sensor event rate in the RATE_BIN_US bins of every window (the last bin of a window may be shorter).
    rate_counts : numpy.ndarray
        The events of those bins.
    interval_counts : numpy.ndarray
        (len(INTERVAL_EDGES_US) - 1,) number of same-pixel intervals per log bin.
    passages : numpy.ndarray
        Events of each passage.
    quiet_hz, dark_hz : tuple of float
        (ON, OFF) mean event rate per quiet / dark pixel, NaN without masks.
    quiet_counts, dark_counts : tuple of int
        (ON, OFF) events on those pixels.
    notes : list of str
        Notes on the measurement.
    origin_us : int
        The recording's time zero, from which windows given in seconds count (measure_recording).
    flicker_hz : float
        The event rate's flicker frequency (Hz; NaN without one).
    flicker_share : float
        The share of the rate's variance it holds (see the module).
    """

    height: int
    width: int
    windows_us: np.ndarray
    gaps_us: np.ndarray
    masks: FrameMasks | None
    counts: np.ndarray
    rate_hz: np.ndarray
    rate_counts: np.ndarray
    interval_counts: np.ndarray
    passages: np.ndarray
    quiet_hz: tuple[float, float]
    dark_hz: tuple[float, float]
    quiet_counts: tuple[int, int]
    dark_counts: tuple[int, int]
    notes: list[str] = field(default_factory=list)
    origin_us: int = 0
    flicker_hz: float = float("nan")
    flicker_share: float = 0.0

    @property
    def duration_s(self) -> float:
        """Total length of the scored windows (s)."""
        return float(np.sum(self.windows_us[:, 1] - self.windows_us[:, 0])) / 1e6

    @property
    def n_on(self) -> int:
        return int(self.counts[0].sum())

    @property
    def n_off(self) -> int:
        return int(self.counts[1].sum())

    @property
    def n_events(self) -> int:
        return self.n_on + self.n_off

    @property
    def interval_pdf(self) -> np.ndarray:
        """Fraction of the same-pixel intervals in each log bin (zeros without intervals)."""
        total = self.interval_counts.sum()
        return self.interval_counts / total if total else self.interval_counts.astype(float)

    @property
    def passage_median(self) -> float:
        """Median events per pixel per passage (NaN without passages)."""
        return float(np.median(self.passages)) if self.passages.size else float("nan")

    def summary(self) -> dict:
        """The scalar statistics as a JSON-serialisable dict (Hz, s, counts).

        Returns
        -------
        dict
            {name: value}.
        """
        masks = self.masks
        return {
            "windows_s": (self.windows_us / 1e6).tolist(), "gaps_s": (self.gaps_us / 1e6).tolist(),
            "duration_s": self.duration_s, "events": self.n_events, "on_events": self.n_on, "off_events": self.n_off,
            "quiet_pixels": None if masks is None else int(masks.quiet.sum()),
            "dark_pixels": None if masks is None else int(masks.dark.sum()),
            "signal_reach_px": None if masks is None or masks.reach_px is None else list(masks.reach_px),
            "quiet_counts": list(self.quiet_counts), "dark_counts": list(self.dark_counts),
            "quiet_on_hz": self.quiet_hz[0], "quiet_off_hz": self.quiet_hz[1],
            "dark_on_hz": self.dark_hz[0], "dark_off_hz": self.dark_hz[1],
            "passages": int(self.passages.size), "passage_median": self.passage_median,
            "mean_rate_hz": self.n_events / self.duration_s if self.duration_s else float("nan"),
            "flicker_hz": self.flicker_hz, "flicker_share": self.flicker_share,
            "notes": list(self.notes),
        }


def as_windows(windows_us: np.ndarray | list | tuple) -> np.ndarray:
    """(K, 2) int64 [start, end) windows in us, sorted and disjoint, each non-empty; EvsimInputError otherwise."""
    w = np.asarray(windows_us)
    if w.ndim == 1 and w.size == 2:
        w = w[None]
    if w.ndim != 2 or w.shape[1] != 2 or w.shape[0] == 0 or (w.size and w.dtype.kind not in "iu"):
        raise EvsimInputError(f"time windows must be (K, 2) integer microseconds [start, end), got {w.dtype} "
                              f"{w.shape}")
    w = w.astype(np.int64)
    if np.any(w[:, 1] <= w[:, 0]):
        raise EvsimInputError(f"every time window must end after it starts, got {w.tolist()}")
    if np.any(w[1:, 0] < w[:-1, 1]):
        raise EvsimInputError(f"time windows must be sorted and must not overlap, got {w.tolist()}")
    return w


def bin_edges(a: int, b: int) -> np.ndarray:
    """RATE_BIN_US bin edges of the window [a, b) (us; the last bin may be shorter)."""
    return np.append(np.arange(a, b, RATE_BIN_US, dtype=np.int64), np.int64(b))


def coverage_gaps(t: np.ndarray, windows_us: np.ndarray) -> np.ndarray:
    """The gaps in event coverage inside the windows (see the module): sim.find_gaps of the stream, clipped to the
    windows.

    Parameters
    ----------
    t : numpy.ndarray
        The events' sorted int64 times (us).
    windows_us : numpy.ndarray
        (W, 2) int64 [start, end) windows (us).

    Returns
    -------
    numpy.ndarray
        (G, 2) int64 [start, end) gaps (us), each within one window.
    """
    found = find_gaps(t)
    gaps = [[max(g0, a), min(g1, b)] for a, b in windows_us for g0, g1 in found if g0 < b and g1 > a]
    return np.array(gaps, dtype=np.int64).reshape(-1, 2)


def cut(windows_us: np.ndarray, gaps_us: np.ndarray) -> np.ndarray:
    """The windows with the gaps (sorted, disjoint, inside the windows) removed."""
    out = []
    for a, b in windows_us:
        start = a
        for g0, g1 in gaps_us:
            if g1 <= start or g0 >= b:
                continue
            if g0 > start:
                out.append((start, g0))
            start = max(start, g1)
        if start < b:
            out.append((start, b))
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def _window_slices(t: np.ndarray, windows_us: np.ndarray) -> list[tuple[int, int]]:
    ends = np.searchsorted(t, windows_us.ravel(), side="left").reshape(-1, 2)
    return [(int(i0), int(i1)) for i0, i1 in ends]


def _rate(value: int, pixels: np.ndarray, duration_s: float) -> float:
    n = int(pixels.sum())
    return value / (n * duration_s) if n and duration_s > 0 else float("nan")


def _describe_gaps(gaps_us: np.ndarray, windows_us: np.ndarray) -> str:
    total = float(np.sum(windows_us[:, 1] - windows_us[:, 0])) / 1e6
    missing = float(np.sum(gaps_us[:, 1] - gaps_us[:, 0])) / 1e6
    listed = ", ".join(f"{a / 1e6:.3f}-{b / 1e6:.3f}" for a, b in gaps_us[:5]) + (", ..." if len(gaps_us) > 5 else "")
    return (f"events cover {total - missing:.3f} of {total:.3f} s: {len(gaps_us)} gap(s) of {RATE_BIN_US // 1000} ms "
            f"bins without events in a busy stream ({listed} s, times as in the file) are not scored")


def _check_events(events: np.ndarray, height: int, width: int) -> None:
    """EvsimInputError unless events are sim.EVENT_DTYPE, sorted by time and inside the height x width sensor."""
    validate_events(events)
    if events.size and (int(events["x"].max()) >= width or int(events["y"].max()) >= height):
        raise EvsimInputError(f"events outside the {width}x{height} sensor (max x {int(events['x'].max())}, max y "
                              f"{int(events['y'].max())}): simulate at the real sensor's size")


def measure(events: np.ndarray, windows_us: np.ndarray | list | tuple | None = None, *, height: int | None = None,
            width: int | None = None, masks: FrameMasks | None = None, like: RealismStats | None = None,
            detect_gaps: bool = False) -> RealismStats:
    """The statistics of events over windows.

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE, sorted by t.
    windows_us : array_like, optional
        (K, 2) or (2,) int64 us windows [start, end).
    height, width : int, optional
        Sensor size (pixels).
    masks : FrameMasks, optional
        Pixel classes for the noise rates and passages (NaN rates and no passages without).
    like : RealismStats, optional
        The statistics of a real recording, whose windows, sensor size and pixel classes are used (a simulation is
        measured on them; windows_us, height, width and masks must then be left out).
    detect_gaps : bool, optional
        Cut coverage gaps out of the windows (see the module), noted in RealismStats.notes (default False).

    Returns
    -------
    RealismStats
        The statistics.
    """
    if like is not None:
        if windows_us is not None or height is not None or width is not None or masks is not None:
            raise EvsimInputError("measure(like=...) takes the windows, sensor size and masks of `like`: give "
                                  "none of them")
        windows_us, height, width, masks = like.windows_us, like.height, like.width, like.masks
        origin = like.origin_us
    elif windows_us is None or height is None or width is None:
        raise EvsimInputError("measure needs windows_us, height and width (or like=)")
    else:
        origin = 0
    windows = as_windows(windows_us)
    _check_events(events, height, width)
    t = events["t"]
    gaps = np.zeros((0, 2), np.int64)
    notes = []
    if detect_gaps:
        gaps = coverage_gaps(t, windows)
        if gaps.size:
            notes.append(_describe_gaps(gaps, windows))
            windows = cut(windows, gaps)
            if not windows.size:
                raise EvsimInputError("no time window is covered by events")
    n_pixels = height * width
    parts = _window_slices(t, windows)
    motion = masks.motion if masks is not None else np.zeros((0, n_pixels), bool)
    frame_t = masks.frame_t_us if masks is not None else np.zeros(0, np.int64)
    counts = np.zeros((2, n_pixels), np.int64)
    rate_counts, rate_hz, intervals, passages = [], [], [], []
    for (i0, i1), (a, b) in zip(parts, windows):
        ev = events[i0:i1]
        tw = np.ascontiguousarray(ev["t"], dtype=np.int64)
        pix = ev["y"].astype(np.int64) * width + ev["x"].astype(np.int64)
        on = ev["p"] > 0
        counts[0] += np.bincount(pix[on], minlength=n_pixels)
        counts[1] += np.bincount(pix[~on], minlength=n_pixels)
        edges = bin_edges(a, b)
        c = np.diff(np.searchsorted(tw, edges))
        rate_counts.append(c)
        rate_hz.append(c / (np.diff(edges) / 1e6))
        iv = np.empty(tw.size, np.int64)
        out_passage = np.empty(tw.size + 1, np.int64)
        n = pixel_runs(tw, pix, n_pixels, PASSAGE_GAP_US, frame_t, motion, iv, out_passage)
        intervals.append(iv[iv >= 0])
        passages.append(out_passage[:n])
    iv = np.concatenate(intervals) if intervals else np.zeros(0, np.int64)
    nbins = INTERVAL_EDGES_US.size - 1
    k = np.floor(np.log10(np.maximum(iv, 1)) * BINS_PER_DECADE + 1e-9).astype(np.int64) - \
        INTERVAL_DECADES[0] * BINS_PER_DECADE
    interval_counts = np.bincount(np.clip(k, 0, nbins - 1), minlength=nbins)
    duration = float(np.sum(windows[:, 1] - windows[:, 0])) / 1e6
    quiet_counts, dark_counts, quiet_hz, dark_hz = _class_rates(counts, masks, duration)
    flicker_hz, flicker_share = _flicker(t, windows)
    return RealismStats(height, width, windows, gaps, masks, counts.reshape(2, height, width),
                        np.concatenate(rate_hz), np.concatenate(rate_counts), interval_counts,
                        np.concatenate(passages) if passages else np.zeros(0, np.int64),
                        quiet_hz, dark_hz, quiet_counts, dark_counts, notes, origin, flicker_hz, flicker_share)


def _class_rates(counts: np.ndarray, masks: FrameMasks | None, duration: float) -> tuple:
    """(quiet_counts, dark_counts, quiet_hz, dark_hz) of (2, H W) or (2, H, W) counts on the masks' pixel classes
    (zeros and NaN without masks)."""
    if masks is None:
        return (0, 0), (0, 0), (float("nan"), float("nan")), (float("nan"), float("nan"))
    counts = counts.reshape(2, -1)
    quiet, dark = masks.quiet.ravel(), masks.dark.ravel()
    quiet_counts = (int(counts[0][quiet].sum()), int(counts[1][quiet].sum()))
    dark_counts = (int(counts[0][dark].sum()), int(counts[1][dark].sum()))
    return (quiet_counts, dark_counts, tuple(_rate(c, quiet, duration) for c in quiet_counts),
            tuple(_rate(c, dark, duration) for c in dark_counts))


def with_masks(stats: RealismStats, masks: FrameMasks) -> RealismStats:
    """stats with other pixel classes (of the same recording: evsim_eval.realism.event_masks for one without frames,
    masks.beyond_signal_reach for one with) and their noise rates; the passages are the ones measured.

    Parameters
    ----------
    stats : RealismStats
        Statistics measured without masks, or with masks of the same motion.
    masks : FrameMasks
        The pixel classes.

    Returns
    -------
    RealismStats
        A copy with masks, quiet and dark counts and rates.
    """
    quiet_counts, dark_counts, quiet_hz, dark_hz = _class_rates(stats.counts, masks, stats.duration_s)
    return replace(stats, masks=masks, quiet_counts=quiet_counts, dark_counts=dark_counts, quiet_hz=quiet_hz,
                   dark_hz=dark_hz)


def with_event_masks(stats: RealismStats) -> RealismStats:
    """stats of a recording without frames with the pixel classes of its own events
    (evsim_eval.realism.event_masks: quiet and hot pixels; no dark pixels, no passages) and their noise rates.

    Parameters
    ----------
    stats : RealismStats
        Statistics measured without masks.

    Returns
    -------
    RealismStats
        A copy with masks (source "events"), quiet and dark counts and rates.
    """
    from .event_masks import event_masks

    return with_masks(stats, event_masks(stats.counts))


def _flicker(t: np.ndarray, windows: np.ndarray) -> tuple[float, float]:
    """(frequency Hz or NaN, share of the rate variance) of the flicker of the event times t (sorted, us) over the
    longest window (see the module)."""
    if not windows.size:
        return float("nan"), 0.0
    a, b = windows[int(np.argmax(windows[:, 1] - windows[:, 0]))]
    edges = np.arange(a, b + 1, FLICKER_BIN_US)
    if edges.size < 33:  # fewer than 32 bins: no spectrum worth the name
        return float("nan"), 0.0
    counts = np.diff(np.searchsorted(t, edges)).astype(np.float64)
    power = np.abs(np.fft.rfft(counts - counts.mean())) ** 2
    freq = np.fft.rfftfreq(counts.size, FLICKER_BIN_US * 1e-6)
    total = float(power[1:].sum())
    band = np.flatnonzero((freq >= FLICKER_BAND_HZ[0]) & (freq <= FLICKER_BAND_HZ[1]))
    if total <= 0 or not band.size:
        return float("nan"), 0.0
    k = int(band[np.argmax(power[band])])
    share = float(power[max(k - 1, 1):k + 2].sum()) / total
    if share < FLICKER_MIN_SHARE:
        return float("nan"), share
    # the frequency from a 16x zero-padded spectrum, between the peak's neighbouring bins (a short window's bins
    # are coarse: 13 Hz apart for 75 ms)
    fine = np.abs(np.fft.rfft(counts - counts.mean(), 16 * counts.size)) ** 2
    fine_freq = np.fft.rfftfreq(16 * counts.size, FLICKER_BIN_US * 1e-6)
    near = np.flatnonzero((fine_freq >= freq[max(k - 1, 0)]) & (fine_freq <= freq[min(k + 1, freq.size - 1)]))
    return float(fine_freq[near[np.argmax(fine[near])]]), share


def shifted(stats: RealismStats, origin_us: int) -> RealismStats:
    """stats with its windows, gaps and frame times moved to a recording whose time zero is origin_us.

    Parameters
    ----------
    stats : RealismStats
        The statistics.
    origin_us : int
        The other recording's time zero (int64 us).

    Returns
    -------
    RealismStats
        A shifted copy.
    """
    d = origin_us - stats.origin_us
    masks = None if stats.masks is None else replace(stats.masks, frame_t_us=stats.masks.frame_t_us + d)
    return replace(stats, windows_us=stats.windows_us + d, gaps_us=stats.gaps_us + d, masks=masks,
                   origin_us=origin_us)


def recording_origin_us(rec: object) -> int:
    """Time zero of a recording (us): its first frame's exposure start (t0 of the IJRR layout), else its first
    event's time (0 without events). Windows given in seconds count from it.

    Parameters
    ----------
    rec : Recording
        The recording.

    Returns
    -------
    int
        Time zero, int64 us.
    """
    if getattr(rec, "frames", None) is not None and len(rec.frame_t_start_us):
        return int(rec.frame_t_start_us[0])
    return int(rec.events["t"][0]) if rec.events.size else 0


def same_clock(real: object, sim: object) -> bool:
    """Whether `sim` is evsim's conversion of `real`'s frames on `real`'s own clock: sim has no frames and its
    scene's time zero (metadata time_origin_us) is one of real's frames' mid-exposure times. Its first event is then
    no time zero: its origin is real's (recording_origin_us of a frame-less recording is its first event).

    Parameters
    ----------
    real, sim : Recording
        The real recording and the simulation.

    Returns
    -------
    bool
        True for a conversion on the same clock.
    """
    origin = (getattr(sim, "metadata", None) or {}).get("time_origin_us")
    if origin is None or getattr(sim, "frames", None) is not None or getattr(real, "frames", None) is None:
        return False
    return bool(np.isin(int(origin), np.asarray(real.frame_t_mid_us, np.int64)))


def measure_recording(rec: object, window_s: tuple[float, float] | None = None, *,
                      like: RealismStats | None = None, detect_gaps: bool = True,
                      origin_us: int | None = None) -> RealismStats:
    """measure of a generators.formats Recording, with the pixel classes of its frames (if any; their quiet and
    dark pixels beyond the reach of signal in its events: masks.beyond_signal_reach), or with like=. Coverage gaps
    are cut out (detect_gaps).

    Parameters
    ----------
    rec : Recording
        The recording.
    window_s : tuple of float, optional
        (start, end) seconds from its origin (recording_origin_us; default: its whole event stream).
    like : RealismStats, optional
        Another recording's statistics, whose windows are taken from that recording's origin to this one's.
    detect_gaps : bool, optional
        Cut coverage gaps out of the windows (default True).
    origin_us : int, optional
        Its time zero, when known to be another's (a conversion on the recording's own clock: same_clock); default
        recording_origin_us.

    Returns
    -------
    RealismStats
        The statistics, origin_us set to the recording's origin.
    """
    origin = recording_origin_us(rec) if origin_us is None else int(origin_us)
    if like is not None:
        if (rec.height, rec.width) != (like.height, like.width):
            raise EvsimInputError(f"the simulation is {rec.width}x{rec.height} pixels, the real recording "
                                  f"{like.width}x{like.height}: simulate at the real sensor's size")
        return measure(rec.events, like=shifted(like, origin), detect_gaps=detect_gaps)
    if window_s is None:
        t = rec.events["t"]
        if not t.size:
            raise EvsimInputError("the recording has no events to score")
        windows = np.array([[int(t[0]), int(t[-1]) + 1]], np.int64)
    else:
        start, end = window_s
        if not end > start:
            raise EvsimInputError(f"the window must end after it starts, got {start} .. {end} s")
        windows = np.array([[origin + round(start * 1e6), origin + round(end * 1e6)]], np.int64)
    masks = None
    notes = []
    if rec.frames is not None and len(rec.frame_t_mid_us) > 1:
        masks = frame_masks(np.asarray(rec.frames), rec.frame_t_mid_us, windows, rec.frame_bit_depth)
    stats = measure(rec.events, windows, height=rec.height, width=rec.width, masks=masks, detect_gaps=detect_gaps)
    if masks is not None:  # quiet and dark pixels beyond the reach of signal seen in the real events
        stats = with_masks(stats, beyond_signal_reach(masks, stats.counts))
    else:  # quiet pixels from the events (event_masks); no dark pixels, no passages
        stats = with_event_masks(stats)
        notes.append(f"no frames: quiet pixels found from the events ({int(stats.masks.quiet.sum())} pixels whose "
                     "neighbourhood fires no more than noise); dark pixels and passages are not measured")
    stats.notes[:0] = notes
    return replace(stats, origin_us=origin)
