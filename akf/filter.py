"""akf.reconstruct: HDR video from LDR frames and events with the Asynchronous Kalman Filter (Wang et al. 2021).

References (docs/models/references.md): Wang et al. 2021 [Wang2021], the AKF; Pan et al. 2019 [Pan2019], EDI;
Kalman and Bucy 1961 [Kalman1961].
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, NamedTuple

import numba
import numpy as np

from sim.errors import InvalidParameterError, check_number
from sim.events import slice_time
from sim.gaps import resolve_gaps
from sim.parallel import in_parallel

from . import kernels
from .augmentation import ContrastCalibration, edi_deblur, event_change, interval_start
from .clip_prior import fill_unmeasured
from .flat_field import thresholds
from .frame_noise import frame_log_variance, frame_read_noise
from .inputs import Inputs, as_crf, check_max_intensity, validate_inputs
from .noise import FrameMeasurement, frame_measurement
from .params import AKFParams
from .smoothing import EDGE_RANGE, LARGEST, smooth_uncertain

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    from crf_models import CRF

_OLD = np.iinfo(np.int64).min // 4  # "never fired" time of the border around the last event times
MIN_BLOCK_ROWS = 16  # pixel rows per thread block: fewer would cost more in thread hand-offs than they save
_DEFAULT_PARAMS = AKFParams()  # the default of params= (frozen: one shared instance is safe)


def _rows(n: int, k: int) -> np.ndarray:
    """A zeroed float64 (n, k) array whose rows start on 64-byte boundaries (one cache line per 8 values)."""
    buf = np.zeros(n * k + 8)
    off = (-buf.ctypes.data // 8) % 8
    return buf[off:off + n * k].reshape(n, k)


class _Blocks:
    """The filter's pixel rows cut into one block per numba thread; each runs on its own thread (akf.kernels.akf_events
    keeps its own last event times per block, so the blocks are independent between frame switches)."""

    def __init__(self, h: int, w: int, s0: int):
        parts = max(1, min(numba.get_num_threads(), h // MIN_BLOCK_ROWS))
        self.rows = [h * q // parts for q in range(parts + 1)]
        self.te = []  # per block: last event time of rows y0 - 1 .. y1 and a border, flat (see akf_events)
        for y0, y1 in zip(self.rows[:-1], self.rows[1:]):
            te = np.full((y1 - y0 + 2, w + 2), _OLD, np.int64)
            te[int(y0 == 0):y1 - y0 + 2 - int(y1 == h), 1:-1] = s0
            self.te.append(te.ravel())

    def run(self, fn) -> None:
        """fn(q, y0, y1) for every block q of rows [y0, y1), in parallel."""
        def parts(a, b):
            for q in range(a, b):
                fn(q, self.rows[q], self.rows[q + 1])
        in_parallel(parts, len(self.te), 1)


class _Deblurred(NamedTuple):
    """A frame's EDI-deblurred log image (log(I + I0), flat) at the start and at the end of its exposure."""

    start: np.ndarray
    end: np.ndarray


class _Interval(NamedTuple):
    """The interval from frame j to frame j + 1, per pixel (flat): its curve is start + scale * (nominal event change
    since s_j) minus the leak part of those events (see augmented_measurement)."""

    start: np.ndarray  # curve value at s_j, the exposure start of frame j (log)
    scale: np.ndarray  # contrast calibration (dimensionless): the interval's contrasts are scale * c_on, scale * c_off
    side: np.ndarray  # clip side: +1 / -1 where both frames are clipped high / low, else 0
    missed: np.ndarray | None = None  # the change (log) the events missed in the interval's gaps (None: no gaps)
    gap_ends: np.ndarray | None = None  # (G,) us: ends of the gaps whose change the curve takes, each at its end
    shares: np.ndarray | None = None  # (G,) each gap's share of missed (its duration inside the interval / theirs)

    def jump(self, t_us: int) -> np.ndarray | None:
        """The curve's step (log, flat) at the end t_us of a gap: its share of the missed change (None: none)."""
        if self.missed is None:
            return None
        at = np.flatnonzero(self.gap_ends == t_us)
        return self.missed * float(self.shares[at].sum()) if at.size else None


def interval_gaps(gaps: np.ndarray, a: int, b: int) -> tuple[bool, np.ndarray, np.ndarray]:
    """(any gap overlaps [a, b), ends, shares) of the interval [a, b) (us): the gaps that end inside (a, b] take the
    change the events missed, each in proportion to its duration inside [a, b) (an unknown change of a random walk
    accrues in proportion to time: given its total, the share of each stretch is its share of the time)."""
    if gaps.shape[0] == 0:
        return False, gaps[:, 1], np.zeros(0)
    overlaps = bool(np.any((gaps[:, 0] < b) & (gaps[:, 1] > a)))
    mine = gaps[(gaps[:, 1] > a) & (gaps[:, 1] <= b)]
    length = (np.minimum(mine[:, 1], b) - np.maximum(mine[:, 0], a)).astype(np.float64)
    return overlaps, mine[:, 1], (length / length.sum() if length.sum() > 0 else length)


class _Frames:
    """Per-frame measurements and deblurred frames, computed on demand and kept for a few frames only."""

    def __init__(self, inp: Inputs, crf, params: AKFParams, read_noise_dn: float = 0.0):
        self.inp, self.crf, self.params = inp, crf, params
        self.read_noise_dn = read_noise_dn  # the frames' read noise: the frame update's variance (akf.frame_noise)
        self._own = {}  # exposure gain -> the frame update's log variance of every raw level
        self._meas, self._deb, self._tables = {}, {}, {}
        self._calibration = ContrastCalibration(inp.c_on.shape[0], params)
        self._next = 0  # intervals must be taken in order (the calibration accumulates)

    def measurement(self, k):
        """Frame k's akf.noise.FrameMeasurement (H, W)."""
        if k not in self._meas:
            self._meas = {j: m for j, m in self._meas.items() if j >= k - 1}
            self._meas[k] = self._measure(k)
        return self._meas[k]

    def _measure(self, k):
        """The measurement is a function of the raw level and the exposure gain: where the frame has more pixels
        than levels it is looked up in a table of every level (a few tables are kept, one per gain)."""
        gain, frame, n_levels = self.inp.exposure_gain(k), self.inp.frames[k], self.inp.full_scale + 1
        if n_levels > frame.size:
            return frame_measurement(self.inp.response(k), self.crf, self.params, gain)
        if gain not in self._tables:
            if len(self._tables) > 3:
                self._tables.clear()
            levels = np.arange(n_levels) / self.inp.full_scale  # = response(k) at each level
            self._tables[gain] = frame_measurement(levels, self.crf, self.params, gain)
        table = self._tables[gain]
        return FrameMeasurement(*(np.take(getattr(table, f.name), frame) for f in fields(table)))

    def deblurred(self, k) -> _Deblurred:
        """L^D of frame k at its exposure start and end."""
        if k not in self._deb:
            self._deb = {j: d for j, d in self._deb.items() if j >= k - 1}
            inp = self.inp
            log = self.measurement(k).log.ravel()
            if self.params.deblur:
                ev = slice_time(inp.events, int(inp.t_start[k]), int(inp.t_end[k]))
                self._deb[k] = _Deblurred(*edi_deblur(log, ev, inp.t_start[k], inp.t_end[k], inp.c_on, inp.c_off,
                                                      inp.shape[1]))
            else:
                self._deb[k] = _Deblurred(log, log)
        return self._deb[k]

    def at_mid(self, k) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Frame k as a measurement at its mid-exposure time tau_k for the discrete frame update (flat): its
        bias-corrected log (the mean of the radiance over the exposure equals the radiance at mid-exposure up to
        second order in the change over the exposure, with no event quantisation, unlike the EDI-deblurred value)
        and its own log variance (its read noise and quantisation through the CRF: akf.frame_noise.
        frame_log_variance), 0 where the frame is clipped (no update there), and its clip side (+1 / -1 / 0). None
        when params.frame_update is off."""
        if not self.params.frame_update:
            return None
        m, gain = self.measurement(k), self.inp.exposure_gain(k)
        if gain not in self._own:
            levels = np.arange(self.inp.full_scale + 1) / self.inp.full_scale
            self._own[gain] = frame_log_variance(levels, self.crf, self.read_noise_dn,
                                                 int(self.inp.full_scale).bit_length(), gain, self.params.i0)
        own = np.take(self._own[gain], self.inp.frames[k])
        return m.log.ravel(), np.where(m.clipped | ~np.isfinite(own), 0.0, own).ravel(), m.side.ravel()

    def interval(self, j) -> _Interval:
        """The interval from frame j to frame j + 1. The last frame's interval is open-ended: forward integration
        from its deblurred start with the carried contrast calibration, side of that frame.
        Intervals are taken once each, in order (see akf.augmentation.ContrastCalibration)."""
        if j != self._next:
            raise AssertionError(f"interval {j} taken out of order (expected {self._next})")
        self._next += 1
        inp = self.inp
        d_start = self.deblurred(j).start
        if j == inp.frames.shape[0] - 1:
            return _Interval(d_start.copy(), self._calibration.carried(), self.measurement(j).side.ravel())
        d_end = self.deblurred(j + 1).end
        a, b = int(inp.t_start[j]), int(inp.t_end[j + 1])
        ev = slice_time(inp.events, a, b)
        change, net = event_change(ev, inp.c_on, inp.c_off, inp.shape[1])
        start_clipped = self.measurement(j).clipped.ravel()
        end_clipped = self.measurement(j + 1).clipped.ravel()
        gappy, ends, shares = interval_gaps(inp.gaps, a, b)
        if gappy:  # the events missed part of the change: eq. 12's ratio would read that as the contrast
            scale = self._calibration.carried()
        else:
            scale = self._calibration.interval(d_start, d_end, change, net, start_clipped | end_clipped)
        side_a, side_b = self.measurement(j).side.ravel(), self.measurement(j + 1).side.ravel()
        side = np.where(side_a == side_b, side_b, 0)
        start = interval_start(d_start, d_end, change, scale, end_clipped & ~start_clipped)
        if ends.size == 0:
            return _Interval(start, scale, side)
        # both frames measure the pixel: the curve starts at the earlier frame and takes the change the events
        # missed (d_end - d_start - their change) in steps at the gaps' ends, so it ends at the later frame
        both = ~(start_clipped | end_clipped)
        missed = np.where(both, d_end - d_start - scale * change, 0.0)
        return _Interval(np.where(both, d_start, start), scale, side, missed, ends, shares)


@dataclass(frozen=True)
class AugmentedMeasurement:
    """The AKF's frame augmentation at a few pixels (log(I + I0) units; pixels flat, y * W + x).

    Attributes
    ----------
    log : numpy.ndarray
        (T, n) augmented frame L^A at the requested times (eq. 13), exactly the measurement the filter tracks.
    deblurred : numpy.ndarray
        (N, 2, n) EDI-deblurred log at each exposure's start and end.
    intensity : numpy.ndarray
        (N, n) frame k's CRF^-1 in frame 0's exposure units.
    clipped : numpy.ndarray
        (N, n) bool, frame k saturated (its variance at the cap).
    """

    log: np.ndarray
    deblurred: np.ndarray
    intensity: np.ndarray
    clipped: np.ndarray


def augmented_measurement(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                          frame_t_end_us: npt.ArrayLike, crf: CRF | str, times_us: npt.ArrayLike,
                          pixels: npt.ArrayLike, *, contrast: npt.ArrayLike = 0.2, leak_rate_hz: float = 0.0,
                          params: AKFParams = _DEFAULT_PARAMS, bit_depth: int = 8,
                          gaps_us: npt.ArrayLike | str | None = None) -> AugmentedMeasurement:
    """The augmented frame L^A(t) of reconstruct (same inputs) at times_us for the flat pixel indices `pixels`.

    Interval j's curve is M_j(t) = m_j + scale_j * (nominal event change of the pixel over [s_j, t)) - (the leak
    part of those events, see reconstruct; 0 when leak_rate_hz = 0) (m_j: its value at the exposure start s_j,
    scale_j: its contrast calibration); in frame window k = [s_k, s_k+1) L^A blends M_{k-1} into M_k across the
    exposure [s_k, e_k] (the first window uses M_0 alone).

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf
        As reconstruct's.
    times_us : array_like
        Non-decreasing int64 us, none before the first exposure starts (as reconstruct's output_times_us).
    pixels : array_like
        Flat pixel indices y * W + x, in [0, H W).
    contrast, leak_rate_hz, params, bit_depth, gaps_us
        As reconstruct's (a curve takes its share of the change its events missed from the end of each gap on).

    Returns
    -------
    AugmentedMeasurement
        L^A at (times_us, pixels), with the EDI-deblurred logs, the frames' intensities and clipping at the pixels.
    """
    if not isinstance(params, AKFParams):
        raise InvalidParameterError(f"params must be an akf.AKFParams, got {type(params).__name__}")
    check_number("leak_rate_hz", leak_rate_hz, positive=False)
    crf = as_crf(crf)
    inp = prepared_inputs(events, frames, frame_t_start_us, frame_t_end_us, times_us, contrast, bit_depth, params,
                          crf, gaps_us)
    pixels = np.asarray(pixels, np.int64).ravel()
    h, w = inp.shape
    if np.any((pixels < 0) | (pixels >= h * w)):
        raise InvalidParameterError(f"pixel indices must lie in [0, {h * w}), got {pixels.min()}..{pixels.max()}")
    fr = _Frames(inp, crf, params)
    nf, t = inp.frames.shape[0], inp.out_t.astype(np.int64)
    start, scale = np.empty((nf, pixels.size)), np.empty((nf, pixels.size))
    missed, taken = np.zeros((nf, pixels.size)), np.zeros((nf, t.size))  # taken: share of missed stepped in by t
    for j in range(nf):
        iv = fr.interval(j)
        start[j], scale[j] = iv.start[pixels], iv.scale[pixels]
        if iv.missed is not None:
            missed[j] = iv.missed[pixels]
            taken[j] = np.concatenate([[0.0], np.cumsum(iv.shares)])[np.searchsorted(iv.gap_ends, t, side="left")]
    s_k = inp.t_start.astype(np.int64)
    k = np.clip(np.searchsorted(s_k, t, side="right") - 1, 0, nf - 1)
    kp = np.maximum(k - 1, 0)
    wt = np.clip((t - s_k[k]) / np.maximum(inp.t_end[k] - s_k[k], 1), 0.0, 1.0)
    wt = np.where(k == 0, 1.0, wt)
    ev, steps = inp.events, np.arange(t.size)
    ev_pix = ev["y"].astype(np.int64) * w + ev["x"]
    out = np.empty((t.size, pixels.size))
    for n, i in enumerate(pixels):
        mine = ev[(ev_pix == i) & (ev["t"] >= s_k[0])]  # the filter starts at the first exposure
        et = mine["t"]
        cum = np.concatenate([[0.0], np.cumsum(np.where(mine["p"] > 0, inp.c_on[i], -inp.c_off[i]))])
        leaked = np.concatenate([[0.0], np.cumsum(_leaked(et, scale[:, n] * inp.c_on[i], inp, leak_rate_hz))])
        cur = start[k, n] + scale[k, n] * _change(et, s_k[k], t, cum) - _change(et, s_k[k], t, leaked) \
            + missed[k, n] * taken[k, steps]
        prev = start[kp, n] + scale[kp, n] * _change(et, s_k[kp], t, cum) - _change(et, s_k[kp], t, leaked) \
            + missed[kp, n] * taken[kp, steps]
        out[:, n] = prev + wt * (cur - prev)
    deb = np.array([(d.start[pixels], d.end[pixels]) for d in map(fr.deblurred, range(nf))])
    intensity = np.array([fr.measurement(j).intensity.ravel()[pixels] for j in range(nf)])
    clipped = np.array([fr.measurement(j).clipped.ravel()[pixels] for j in range(nf)])
    return AugmentedMeasurement(out, deb, intensity, clipped)


def _change(et: np.ndarray, a, b, c: np.ndarray) -> np.ndarray:
    """Change of the cumulative c (c[i]: the sum over the first i events) over the events of times et (ascending)
    in [a, b)."""
    return c[np.searchsorted(et, b, side="left")] - c[np.searchsorted(et, a, side="left")]


def _leaked(et, c_on_intervals, inp: Inputs, leak_rate_hz: float) -> np.ndarray:
    """The leak part (log) of each event of one pixel (times et, us), as akf.kernels.akf_events takes it:
    c_on_intervals[j] is interval j's calibrated ON contrast, blended across each exposure as the events' change."""
    if leak_rate_hz == 0 or et.size == 0:
        return np.zeros(et.size)
    s_k = inp.t_start.astype(np.int64)
    k = np.clip(np.searchsorted(s_k, et, side="right") - 1, 0, s_k.size - 1)
    wt = np.clip((et - s_k[k]) / np.maximum(inp.t_end[k] - s_k[k], 1), 0.0, 1.0)
    c_prev, c_cur = c_on_intervals[np.maximum(k - 1, 0)], c_on_intervals[k]
    c_on = c_prev + wt * (c_cur - c_prev)
    drift = leak_rate_hz * 1e-6 * c_on * np.diff(et, prepend=s_k[0])
    out = np.minimum(drift, c_on)
    out[0] = kernels.leaked_before_first_event(drift[0], c_on[0])
    return out


def reconstruct(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                frame_t_end_us: npt.ArrayLike, crf: CRF | str, output_times_us: npt.ArrayLike, *,
                contrast: npt.ArrayLike = 0.2, leak_rate_hz: float = 0.0, params: AKFParams = _DEFAULT_PARAMS,
                bit_depth: int = 8, max_intensity: float | None = None, return_variance: bool = False,
                return_gain: bool = False, gaps_us: npt.ArrayLike | str | None = None
                ) -> npt.NDArray[np.float32] | tuple[npt.NDArray[np.float32], ...]:
    """Reconstruct linear HDR intensity at output_times_us with the Asynchronous Kalman Filter (Wang et al. 2021
    [Wang2021]; the model, equation by equation, is docs/models/akf.md).

    Where leak_rate_hz > 0, the leak part of each crossing is removed from the event's change: the drift since the
    pixel's previous event (at most c_on), and at its first event also the drift from before the start, unknown but
    uniform on [0, c_on) for a pixel that has been leaking (its mean is removed and its variance c_on^2 / 12 added to
    Q). In clipped regions, where frames cannot correct it, that pre-start drift otherwise leaves every pixel's
    estimate high by c_on / 2 on average. The event-interpolated frame curves the state is pulled toward take the
    same leak-aware changes; EDI deblurring and the eq. 12 calibration keep the nominal contrasts, as in the paper.

    No max_intensity (the default) leaves the output unbounded, as high as the events carry a pixel above the frames'
    clip (HDR is the point). What keeps pixels no frame measures from running off is evidence, not a constant: their
    thresholds are flat-fielded from the event counts (params.flat_field; akf.flat_field), the one-sided rule keeps
    them on their side of the clip level, and the clip prior and the output smoothing average their speckle. On the
    AHDR pan of the real HDR photo Desk (davis346 sensor) the largest output is 5.2 x the truth's largest (2e9 x with
    the nominal thresholds). An estimate run out of float32's range (events integrated with a far too large
    threshold) is published as akf.smoothing.LARGEST, a finite number.

    P is the variance under the paper's noise model, not a calibrated error bar: the model has no term for the
    events' quantisation (between events the true level may sit up to a threshold from the reported one), so on
    noise-free data (tests/test_akf_filter.py's moving scene) 2 sqrt(P) covers 51 % of the log errors with
    thresholds of 0.05 and 7 % with 0.2 (78 % and 27 % without the frame update, whose posterior P is the frame's
    own R).

    Frame update (params.frame_update, default on; not in the paper): at each frame's mid-exposure time every pixel
    the frame measures gets a discrete Kalman update with the frame, its prior variance matched to the innovation
    (akf.kernels.akf_frame_update), so at frame times the estimate is within the frame's noise of a well-exposed
    frame (the paper's continuous measurement leaves pixels that leave a clipped region tens of sigmas away). The
    frame's noise is its read noise (params.read_noise_dn, else estimated from the frames: akf.frame_noise) and
    quantisation through the CRF.
    Output smoothing (params.smooth_range > 0, default; not in the paper): each published log image is
    bilateral-filtered where the last frame did not measure the pixel (clipped) and the state is uncertain, weighted
    by its variance P and never past the clipped frame's level (akf.smoothing), with the range smooth_range between
    two frames clipped on one side and at most akf.smoothing.EDGE_RANGE where the next frame measures the pixel;
    this averages the event speckle of pixels no frame measures and leaves the pixels the last frame measured bit
    for bit.
    Clip prior (params.clip_prior, default; not in the paper; needs the frame update): a pixel no frame has
    measured yet whose interval's frames are both clipped on one side has only a bound from them; each published
    image gives it the median level, beyond its bound, of the pixels on that side that a frame did measure
    (akf.clip_prior), before the smoothing.

    Gaps (not in the paper): an interval between two frames with a gap in its events is not calibrated (eq. 12 would
    read the missed change as a larger contrast; it takes the calibration carried from complete intervals), and where
    both frames measure a pixel its curve starts at the earlier deblurred frame and takes the change the events
    missed, d_end - d_start - (their change), in steps at the ends of its gaps, each gap's share its share of the
    interval's gap time (a random walk's change accrues with time), so the curve ends at the later frame. At a gap's
    end every pixel's variance P grows by params.gap_variance (an unknown change): the state then follows the curve,
    and the next frame decides what the events could not. On a complete stream nothing changes, bit for bit.

    Frame k+1 is needed to augment the interval after frame k, so the filter has one frame of latency; it streams
    window by window (events sliced by binary search), so memory does not grow with the sequence length. It runs
    blocks of pixel rows on numba's thread count (numba.set_num_threads), the output the same bit for bit whatever
    the count, and (with more than one) the next interval's frame work on one more thread.

    Publishing is a pure read: each pixel is brought to t with the exact between-event solution (the one-sided
    clipped-frame rule switching at the exact time the estimate crosses the clip level, not at sub-segment starts)
    without storing the result, so the image at t is the same, bit for bit, whatever other times are requested.

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE, time-sorted (t in int64 us).
    frames : array_like
        (N, H, W) unsigned raw responses of bit_depth bits.
    frame_t_start_us, frame_t_end_us : array_like
        (N,) int64 us: frame k is exposed over [frame_t_start_us[k], frame_t_end_us[k]) (non-overlapping).
    crf : CRF or str
        A crf_models curve or its name (e.g. "window": crf_models.get(name) with default parameters).
    output_times_us : array_like
        (T,) non-decreasing int64 us, none before the first exposure starts; the image at t includes the events
        with timestamps < t.
    contrast : array_like, optional
        Nominal log contrast threshold(s) (log units): a scalar, (c_on, c_off) or (2, H, W) per-pixel maps (c_off as
        a magnitude); default 0.2.
    leak_rate_hz : float, optional
        The sensor's mean leak rate (Hz: ON events per second of a static pixel, whose reference drifts down by
        leak_rate_hz c_on log units per second); 0 (default: unknown or none) gives the paper's filter.
    params : AKFParams, optional
        The filter's parameters (default AKFParams()).
    bit_depth : int, optional
        Bits of the frames' responses (default 8).
    max_intensity : float, optional
        An output bound (x units), or None (default): unbounded.
    return_variance : bool, optional
        Also return the state variance P (default False).
    return_gain : bool, optional
        Also return the Kalman gain K (default False).
    gaps_us : array_like, "none" or None, optional
        Spans of the event stream where events are missing (dropped packets, an export that keeps only the events
        inside the exposures), read as unknown change: None (default) detects them (sim.find_gaps, with the frames'
        exposures; a complete stream has none), "none" reads every empty span as no change (the paper's filter), or
        a (G, 2) int64 array of [start, end) us. At each gap's end every pixel's P grows by params.gap_variance and
        the interval's curve steps by the gap's share of the change its events missed (see the Gaps paragraph).

    Returns
    -------
    intensity : numpy.ndarray
        float32 (T, H, W) intensity I = clip(exp(L_hat) - I0, 0, max_intensity) (radiance is never negative) in the
        CRF's scaled-irradiance units (x units, of frame 0's exposure time: frame k's CRF^-1 is scaled by T_0 / T_k).
    variance : numpy.ndarray
        Only with return_variance: float32 (T, H, W) state variance P (log^2) at the same times.
    gain : numpy.ndarray
        Only with return_gain: float32 (T, H, W) Kalman gain K = P / R (1/s) at the same times.
    """
    check_filter_options(params, leak_rate_hz, max_intensity)
    crf = as_crf(crf)
    inp = prepared_inputs(events, frames, frame_t_start_us, frame_t_end_us, output_times_us, contrast, bit_depth,
                          params, crf, gaps_us)
    nt, (h, w) = inp.out_t.shape[0], inp.shape
    out_i = np.zeros((nt, h, w), np.float32)
    out_p = np.zeros((nt, h, w), np.float32) if return_variance else None
    out_k = np.zeros((nt, h, w), np.float32) if return_gain else None
    run_filter(inp, crf, params, leak_rate_hz, out_i, out_p, out_k, finish_image(params, inp.shape))
    np.clip(out_i, 0.0, LARGEST if max_intensity is None else max_intensity, out=out_i)  # NaN-free and finite
    result = [out_i] + ([out_p] if return_variance else []) + ([out_k] if return_gain else [])
    return result[0] if len(result) == 1 else tuple(result)


def check_filter_options(params: AKFParams, leak_rate_hz: float, max_intensity: float | None) -> None:
    """The filter's own options checked at the boundary (InvalidParameterError naming the option)."""
    if not isinstance(params, AKFParams):
        raise InvalidParameterError(f"params must be an akf.AKFParams, got {type(params).__name__}")
    check_number("leak_rate_hz", leak_rate_hz, positive=False)
    check_max_intensity(max_intensity)


def prepared_inputs(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                    frame_t_end_us: npt.ArrayLike, output_times_us: npt.ArrayLike, contrast: npt.ArrayLike,
                    bit_depth: int, params: AKFParams, crf: CRF, gaps_us: npt.ArrayLike | str | None = "none"
                    ) -> Inputs:
    """The validated inputs (akf.inputs.validate_inputs), with the thresholds flat-fielded from the event counts
    (akf.flat_field) when params.flat_field and the contrast is a scalar or an (ON, OFF) pair, and the gaps of the
    event stream (sim.resolve_gaps of gaps_us: None detects them, "none" has none)."""
    inp = validate_inputs(events, frames, frame_t_start_us, frame_t_end_us, output_times_us, contrast, bit_depth)
    c_on, c_off = thresholds(contrast, inp.events, inp.frames, inp.full_scale, crf, params)
    gaps = resolve_gaps(gaps_us, inp.events, inp.t_start, inp.t_end)
    return dataclasses.replace(inp, c_on=c_on, c_off=c_off, gaps=gaps)


class Masks(NamedTuple):
    """What the filter knows of each pixel (flat) at a published time, beside its state: the clip side of its current
    interval (+1 / -1 / 0), whether a frame has measured it yet and when last (us; -inf: never), and the
    smoothing's variance floor and log bounds from the last frame (see _filter)."""

    side: np.ndarray
    measured: np.ndarray
    floor: np.ndarray
    low: np.ndarray
    high: np.ndarray
    when: np.ndarray


def finish_image(params: AKFParams, shape: tuple[int, int]) -> Callable[[int, np.ndarray, np.ndarray, Masks], None]:
    """The causal filter's last steps on each published image, in place: the clip prior, then the output smoothing
    (see reconstruct). Returns post(j, intensity, variance, masks) for run_filter."""
    prior = params.clip_prior and params.frame_update

    def post(j, oi, op, masks: Masks):
        if prior:  # before the smoothing, which then averages the filled levels too
            fill_unmeasured(oi, params.i0, masks.side, masks.measured)
        smooth_published(oi, op, masks, params, shape)
    return post


def smooth_published(oi: np.ndarray, op: np.ndarray, masks: Masks, params: AKFParams, shape: tuple[int, int]) -> None:
    """The output smoothing of one published image (flat intensity and variance), in place: pixels between two frames
    clipped on one side (only events and the bound know them) with the full range, the others the last frame clipped
    (the next frame measures them: things moving across the edge of a clipped area) with at most EDGE_RANGE."""
    if params.smooth_range <= 0:
        return
    one_sided = masks.side != 0
    for part, rng in ((one_sided, params.smooth_range), (~one_sided, min(params.smooth_range, EDGE_RANGE))):
        part_floor = np.where(part, masks.floor, np.float32(np.inf))
        if np.isfinite(part_floor).any():
            smooth_uncertain(oi.reshape(shape), op.reshape(shape), params.i0, rng, part_floor.reshape(shape),
                             masks.low.reshape(shape), masks.high.reshape(shape))


def run_filter(inp: Inputs, crf: CRF, params: AKFParams, leak_rate_hz: float, out_i: np.ndarray,
               out_p: np.ndarray | None, out_k: np.ndarray | None,
               post: Callable[[int, np.ndarray, np.ndarray, Masks], None]) -> None:
    """The filter over inp, writing exp(L) - I0 (and P, K when out_p / out_k are arrays) at inp.out_t into out_i
    (T, H, W), each image then given to post(j, intensity, variance, masks) (flat views; where out_p is None, the
    variance is a scratch array when params.smooth_range > 0, which reads it, else empty) before the next."""
    nf, (h, w) = inp.frames.shape[0], inp.shape
    n = h * w
    read_noise = params.read_noise_dn
    if read_noise is None and params.frame_update:
        read_noise = frame_read_noise(inp.frames, int(inp.full_scale).bit_length())
    fr = _Frames(inp, crf, params, read_noise or 0.0)
    strong = params.sigma_im2 / params.max_variance
    noise = kernels.noise_params(params.sigma_proc2, params.sigma_iso2, params.sigma_ref2, params.rho_bar_us, strong,
                                 leak_rate_hz * 1e-6)
    s0 = int(inp.t_start[0])

    iv0 = fr.interval(0)
    S = _rows(n, kernels.N_STATE)
    S[:, [kernels.SL, kernels.SMP, kernels.SMC]] = iv0.start[:, None]
    S[:, kernels.SP] = params.p0
    S[:, kernels.ST] = s0
    r0 = fr.measurement(0).r.ravel()
    S[:, kernels.SRA] = S[:, kernels.SRB] = r0
    S[:, kernels.SRC] = fr.measurement(1).r.ravel() if nf > 1 else r0
    C = _rows(n, kernels.N_C)
    C[:, [kernels.CP_ON, kernels.CC_ON]] = (iv0.scale * inp.c_on)[:, None]
    C[:, [kernels.CP_OFF, kernels.CC_OFF]] = (iv0.scale * inp.c_off)[:, None]
    C[:, [kernels.CP_SIDE, kernels.CC_SIDE]] = iv0.side[:, None]
    C[:, kernels.C_FIRST] = 1.0
    blocks = _Blocks(h, w, s0)

    mid0 = fr.at_mid(0)

    def run(ahead):
        _filter(ahead, inp, fr, S, C, blocks, noise, strong, params, out_i, out_p, out_k, (iv0, mid0), post)

    if numba.get_num_threads() > 1:
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="akf-frames", initializer=numba.set_num_threads,
                                initargs=(numba.get_num_threads(),)) as ahead:  # the thread count is per thread
            run(ahead)
    else:  # one thread allowed (e.g. a dataset worker's share of the cores): the frame work runs in turn
        run(_AtOnce())


class _AtOnce:
    """The executor interface of the frame work, running each task at once on the calling thread."""

    def submit(self, fn, *args) -> Future:
        f = Future()
        try:
            f.set_result(fn(*args))
        except Exception as e:  # raised where the result is taken, as from a thread
            f.set_exception(e)
        return f


def _events_before(t: float) -> int:
    """The end (us, exclusive) of the integer event times strictly before t (us)."""
    return int(math.ceil(t))


def _next_interval(fr: _Frames, k: int) -> tuple[_Interval, np.ndarray | None, tuple | None]:
    """Interval k, frame k + 1's log variance R (None after the last frame) and frame k's at_mid."""
    iv = fr.interval(k)
    return iv, (fr.measurement(k + 1).r.ravel() if k + 1 < fr.inp.frames.shape[0] else None), fr.at_mid(k)


class _Feed:
    """The events of one frame window (contiguous ev from s_k on) fed in order, the gap steps at their times."""

    def __init__(self, ev: np.ndarray, s_k: int, events: Callable, steps: list[tuple[int, Callable]]):
        self.ev, self.s_k, self.events, self.n0 = ev, s_k, events, 0
        self.steps = [(g, slice_time(ev, s_k, g).shape[0], step) for g, step in steps]  # (time, events before, fn)

    def until(self, t: int) -> None:
        """The events before t (us) and the gap steps at times before t, in time order."""
        n1 = slice_time(self.ev, self.s_k, max(t, self.s_k)).shape[0]
        while self.steps and self.steps[0][0] < t:
            g, n, step = self.steps.pop(0)
            self.events(self.ev[self.n0:n])
            self.n0 = n
            step(g)
        self.events(self.ev[self.n0:n1])
        self.n0 = n1

    def rest(self) -> None:
        """Every remaining event and gap step of the window."""
        self.until(np.iinfo(np.int64).max)


def _gap_steps(gaps: np.ndarray, a: int, b: int, prev: _Interval, cur: _Interval, step: Callable
               ) -> list[tuple[int, Callable]]:
    """(time, fn) of the gap ends g in [a, b) (us), fn(g) calling step(g, the previous and current intervals'
    curve steps at g)."""
    ends = gaps[(gaps[:, 1] >= a) & (gaps[:, 1] < b), 1]
    return [(int(g), lambda g: step(g, prev.jump(g), cur.jump(g))) for g in ends]


def _filter(ahead, inp: Inputs, fr: _Frames, S, C, blocks: _Blocks, noise, strong, params: AKFParams, out_i, out_p,
            out_k, first, post):
    """The filter's window loop (see reconstruct and run_filter). The frame work of the next interval (deblurring,
    calibration) does not depend on the filter state: it runs on the executor `ahead`, a thread (which alone uses fr
    from now on) while this one processes the events, filling the cores left idle by the serial parts."""
    nf, w = inp.frames.shape[0], inp.shape[1]
    nt = inp.out_t.shape[0]
    none = np.empty(0, np.float32)
    i0 = params.i0
    # the smoothing floor of each pixel: infinite (no smoothing) where the last frame measured it, smooth_variance
    # where it was clipped or before the first frame; and the bounds (log) the smoothing may not cross: a pixel the
    # last frame clipped high (low) stays at or above (below) that frame's level, the one-sided rule of the filter;
    # whether a frame has measured each pixel (the clip prior's; the clip side is its interval's)
    masks = Masks(C[:, kernels.CC_SIDE], np.zeros(S.shape[0], bool), np.full(S.shape[0], params.smooth_variance,
                  np.float32), np.full(S.shape[0], -np.inf, np.float32), np.full(S.shape[0], np.inf, np.float32),
                  np.full(S.shape[0], -np.inf))
    # P where the caller does not ask for it but the output smoothing reads it (else akf_publish skips writing P)
    scratch_p = np.empty(S.shape[0], np.float32) if out_p is None and params.smooth_range > 0 else None

    def events(ev, win):  # ev: contiguous (one layout: one compiled kernel)
        blocks.run(lambda q, y0, y1: kernels.akf_events(ev, w, S, C, blocks.te[q], win, noise, y0, y1))

    def gap_step(t, win, jump_prev, jump_cur):  # bring every pixel to the end t of a gap: unknown change
        blocks.run(lambda q, y0, y1: kernels.akf_publish(t, S, C, win, strong, i0, none, none, none, y0 * w, y1 * w))
        S[:, kernels.SP] += params.gap_variance
        for col, jump in ((kernels.SMP, jump_prev), (kernels.SMC, jump_cur)):
            if jump is not None:
                S[:, col] += jump

    def publish(j, t, win, oi, op, ok):  # output images (flat) at t (us)
        if op.shape[0] == 0 and scratch_p is not None:
            op = scratch_p
        blocks.run(lambda q, y0, y1: kernels.akf_publish(t, S, C, win, strong, i0, oi, op, ok, y0 * w, y1 * w))
        post(j, oi, op, masks)

    def switch(t, win, iv: _Interval, r_next):  # bring every pixel to t = s_k (win: the window ending there), rotate
        on_new, off_new, side_new = iv.scale * inp.c_on, iv.scale * inp.c_off, iv.side.astype(np.float64)

        def part(q, y0, y1):
            kernels.akf_publish(t, S, C, win, strong, i0, none, none, none, y0 * w, y1 * w)  # commit to t
            kernels.akf_rotate(S, C, iv.start, on_new, off_new, side_new, r_next, y0 * w, y1 * w)
        blocks.run(part)

    def frame_update(t, win, z, r, side):  # bring every pixel to t = tau_k, then the discrete update with frame k
        def part(q, y0, y1):
            kernels.akf_publish(t, S, C, win, strong, i0, none, none, none, y0 * w, y1 * w)  # commit to t
            kernels.akf_frame_update(S, z, r, y0 * w, y1 * w)
        blocks.run(part)
        masks.floor[:] = np.where(r > 0, np.inf, params.smooth_variance)
        masks.low[:] = np.where(side > 0, z, -np.inf)
        masks.high[:] = np.where(side < 0, z, np.inf)
        masks.measured[:] |= r > 0
        masks.when[:] = np.where(r > 0, t, masks.when)

    tau = inp.tau
    j = 0  # next output index
    prev_win = None  # the previous frame window (set at the end of every iteration)
    pending = ahead.submit(_next_interval, fr, 1) if nf > 1 else None
    ivs, mid = (first[0], first[0]), first[1]  # the intervals ending and starting at the window's frame
    for k in range(nf):
        if j == nt:
            break
        win = kernels.window(inp.t_start[k], inp.t_end[k], tau[max(k - 1, 0)], tau[k], tau[min(k + 1, nf - 1)])
        if k > 0:  # bring every pixel to s_k, then rotate the intervals and frame variances
            iv, r_next, mid = pending.result()
            pending = ahead.submit(_next_interval, fr, k + 1) if k + 1 < nf else None
            switch(float(inp.t_start[k]), prev_win, iv, S[:, kernels.SRC].copy() if r_next is None else r_next)
            ivs = (ivs[1], iv)
        prev_win = win
        t_hi = int(inp.t_start[k + 1]) if k + 1 < nf else int(inp.out_t[-1])
        s_k = int(inp.t_start[k])
        steps = _gap_steps(inp.gaps, s_k, t_hi if k + 1 < nf else np.iinfo(np.int64).max, *ivs,
                           lambda g, jp, jc, win=win: gap_step(float(g), win, jp, jc))
        feed = _Feed(np.ascontiguousarray(slice_time(inp.events, s_k, t_hi)), s_k, lambda e, win=win: events(e, win),
                     steps)
        while j < nt and (inp.out_t[j] < t_hi or k == nf - 1):
            t_out = int(inp.out_t[j])
            if mid is not None and t_out >= tau[k]:  # the frame update comes first (events before tau_k)
                feed.until(_events_before(tau[k]))
                frame_update(float(tau[k]), win, *mid)
                mid = None
            feed.until(t_out)  # the events before t_out
            publish(j, float(t_out), win, out_i[j].reshape(-1), none if out_p is None else out_p[j].reshape(-1),
                    none if out_k is None else out_k[j].reshape(-1))
            j += 1
        if j < nt:
            if mid is not None:
                feed.until(_events_before(tau[k]))
                frame_update(float(tau[k]), win, *mid)
            feed.rest()
