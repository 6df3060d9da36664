"""Gaps in an event stream: spans in which events are missing, not absent (dropped USB packets at high event rates,
exports that keep only the events inside the frames' exposures).

A quiet scene and a missing stretch of data both give no events; what tells them apart is the rest of the stream.
Two rules, each from the events alone (and the frames' exposure windows where given):

- Busy stream: an empty span between two successive events is a gap when the stream on both sides of it is busy
  enough that a Poisson stream of its rate would leave it empty with a negligible probability: with n events
  (BUSY_EVENTS on each side, fewer near the ends) over the time span S before (and after) the empty span of length
  d, the rate n / S must give (n / S) d >= SIGNIFICANCE on both sides (P(empty) = exp(-30) = 1e-13), and d >=
  MIN_GAP_US (shorter holes carry too little change to matter). A genuine pause of a noisy sensor is not a gap:
  its noise events keep coming; a pause followed or preceded by a quiet stretch is not a gap either (one side is
  not busy).
- Exposure-gated export: when no event at all falls between the frames' exposures (from the first exposure's start
  to the last one's end) while the stream's mean rate over the exposures would put at least SIGNIFICANCE events
  there, every span between two exposures, [end of exposure k, start of exposure k + 1), is a gap, whatever its
  length (a busy-stream gap around one is replaced by it: the exposures bound it exactly).

Gaps are [start, end) int64 microseconds: no event has start <= t < end, and end is the time the stream resumes
(the first event after the gap, or the next exposure's start).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from .errors import InvalidParameterError

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = ["find_gaps", "resolve_gaps", "describe_gaps"]

SIGNIFICANCE = 30.0  # expected events in the empty span at the local rate: P(empty) = exp(-30) in a Poisson stream
BUSY_EVENTS = 300  # events on each side of an empty span that measure the local rate (+- 6 %)
MIN_GAP_US = 1_000  # shorter empty spans are never gaps (us)


def _empty(shape: int = 0) -> npt.NDArray[np.int64]:
    return np.zeros((shape, 2), np.int64)


@njit(cache=True, nogil=True)
def _long_steps(t, min_step):
    """Indices i with t[i + 1] - t[i] >= min_step, in one pass over t (a strided view of the events' times is
    read in place: no (N,) differences array)."""
    n = 0
    for i in range(t.size - 1):
        n += t[i + 1] - t[i] >= min_step
    out = np.empty(n, np.int64)
    n = 0
    for i in range(t.size - 1):
        if t[i + 1] - t[i] >= min_step:
            out[n] = i
            n += 1
    return out


@njit(cache=True, nogil=True)
def _events_in(t, starts, ends):
    """The number of times t (sorted) in the windows [starts[k], ends[k]), summed over k (binary searches on t in
    place: numpy's searchsorted would copy a strided view of the events' times)."""
    n = 0
    for k in range(starts.size):
        n += np.searchsorted(t, ends[k]) - np.searchsorted(t, starts[k])
    return n


def _busy_gaps(t: np.ndarray) -> np.ndarray:
    """Gaps of the busy-stream rule (see the module) in the sorted int64 times t."""
    i = _long_steps(t, MIN_GAP_US)  # candidate: the empty span between events i and i + 1
    if i.size == 0:
        return _empty()
    n_before = np.minimum(i, BUSY_EVENTS)  # events before event i (the span is from event i - n to event i)
    span_before = t[i] - t[i - n_before]
    n_after = np.minimum(t.size - 2 - i, BUSY_EVENTS)
    span_after = t[i + 1 + n_after] - t[i + 1]
    dd = (t[i + 1] - t[i]).astype(np.float64)
    busy = ((n_before >= SIGNIFICANCE) & (n_before * dd >= SIGNIFICANCE * span_before)
            & (n_after >= SIGNIFICANCE) & (n_after * dd >= SIGNIFICANCE * span_after))
    i = i[busy]
    return np.stack([t[i] + 1, t[i + 1]], axis=1).astype(np.int64)


def _gated_gaps(t: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Gaps of the exposure-gated rule (see the module): the spans between exposures when all are empty."""
    if starts.size < 2:
        return _empty()
    between = np.stack([ends[:-1], starts[1:]], axis=1)
    between = between[between[:, 1] > between[:, 0]]
    if between.size == 0:
        return _empty()
    inside = _events_in(t, starts, ends)
    exposed = float(np.sum(np.maximum(ends - starts, 0)))
    outside = _events_in(t, np.ascontiguousarray(between[:, 0]), np.ascontiguousarray(between[:, 1]))
    expected = inside / exposed * float(np.sum(between[:, 1] - between[:, 0])) if exposed > 0 else 0.0
    return between.astype(np.int64) if outside == 0 and expected >= SIGNIFICANCE else _empty()


def _merged(gaps: np.ndarray) -> np.ndarray:
    """Sorted, overlapping or touching [start, end) intervals merged."""
    if gaps.shape[0] < 2:
        return gaps
    gaps = gaps[np.argsort(gaps[:, 0], kind="stable")]
    out = [list(gaps[0])]
    for a, b in gaps[1:]:
        if a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return np.array(out, np.int64)


def find_gaps(events: np.ndarray, frame_t_start_us: npt.ArrayLike | None = None,
              frame_t_end_us: npt.ArrayLike | None = None) -> npt.NDArray[np.int64]:
    """The gaps of an event stream (see the module): spans where events are missing, not absent.

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE events (or their int64 us times), time-sorted.
    frame_t_start_us, frame_t_end_us : array_like, optional
        (N,) int64 us exposure windows of the recording's frames (all of them: a held-out frame's exposure counts),
        for the exposure-gated rule; None: the busy-stream rule only.

    Returns
    -------
    numpy.ndarray
        (G, 2) int64 us [start, end) gaps, sorted and disjoint; (0, 2) when the stream has none.
    """
    t = np.asarray(events["t"] if getattr(events, "dtype", None) is not None and events.dtype.names else events,
                   np.int64)
    if t.size < 2:
        return _empty()
    gaps = _busy_gaps(t)
    if frame_t_start_us is not None and frame_t_end_us is not None:
        gated = _gated_gaps(t, np.asarray(frame_t_start_us, np.int64), np.asarray(frame_t_end_us, np.int64))
        if gated.shape[0]:  # the exposures bound the gated gaps exactly: a busy gap around one is that gap
            near = np.any((gaps[:, None, 0] < gated[None, :, 1]) & (gaps[:, None, 1] > gated[None, :, 0]), axis=1)
            gaps = _merged(np.concatenate([gaps[~near], gated]))
    return gaps


def resolve_gaps(gaps_us: npt.ArrayLike | str | None, events: np.ndarray, frame_t_start_us: npt.ArrayLike,
                 frame_t_end_us: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """The gaps a reconstruction method takes from its gaps_us option.

    Parameters
    ----------
    gaps_us : array_like, "none" or None
        None: find_gaps on the events and the frames' exposures; "none": no gaps (the stream is complete, as every
        empty span is read as no change); else explicit (G, 2) [start, end) int64 us intervals, end > start.
    events : numpy.ndarray
        sim.EVENT_DTYPE events, time-sorted.
    frame_t_start_us, frame_t_end_us : array_like
        (N,) int64 us exposure windows of the frames given to the method.

    Returns
    -------
    numpy.ndarray
        (G, 2) int64 us gaps, sorted and disjoint (overlapping ones merged).
    """
    if gaps_us is None:
        return find_gaps(events, frame_t_start_us, frame_t_end_us)
    if isinstance(gaps_us, str):
        if gaps_us != "none":
            raise InvalidParameterError(f"gaps_us must be None (detect), 'none' or a (G, 2) array of [start, end) "
                                        f"us, got {gaps_us!r}")
        return _empty()
    g = np.asarray(gaps_us)
    if g.size == 0:
        return _empty()
    if g.ndim != 2 or g.shape[1] != 2 or not np.issubdtype(g.dtype, np.integer) or np.any(g[:, 1] <= g[:, 0]):
        raise InvalidParameterError(f"gaps_us must be a (G, 2) integer array of [start, end) us with end > start, "
                                    f"got shape {g.shape}, dtype {g.dtype}")
    return _merged(g.astype(np.int64))


def describe_gaps(gaps_us: np.ndarray, span_us: tuple[int, int]) -> str:
    """One line naming the gaps: their count, total duration of the span (s) and the first few ("" for none).

    Parameters
    ----------
    gaps_us : numpy.ndarray
        (G, 2) int64 us [start, end) gaps.
    span_us : tuple of int
        (start, end) us of the stream they are counted in.

    Returns
    -------
    str
        E.g. "events: 12 gaps (0.22 s of 1.3 s) read as missing data (...): 0.104-0.122, ... s after the first
        event" (times from span_us[0]).
    """
    if gaps_us.shape[0] == 0:
        return ""
    total = float(np.sum(gaps_us[:, 1] - gaps_us[:, 0])) / 1e6
    t0 = span_us[0]
    listed = ", ".join(f"{(a - t0) / 1e6:.3f}-{(b - t0) / 1e6:.3f}" for a, b in gaps_us[:4]) + \
        (", ..." if len(gaps_us) > 4 else "")
    n = gaps_us.shape[0]
    return (f"events: {n} gap{'s' * (n != 1)} ({total:.3g} s of {(span_us[1] - t0) / 1e6:.3g} s) read as missing "
            f"data (unknown change: the next frame decides): {listed} s after the first event")
