"""akf.reconstruct_smoothed: the asynchronous Kalman smoother, the AKF run forward and backward in time and fused
(offline use: evaluation, `evsim reconstruct`, datasets; not in the paper).

A causal filter cannot anchor a pixel that starts clipped: a frame that measures it later reveals its absolute
level only in the future. The two-filter smoother (Fraser and Potter 1969 [Fraser1969]) runs the filter a second time
over the time-reversed inputs (frames and exposures in reverse order, every event's time mirrored and its polarity
flipped, so the ON and OFF thresholds swap), and fuses the two estimates of each pixel at each published time:

- each pass's estimate has a variance: where a frame measured the pixel (before t for the forward pass, after
  t for the backward one), the filter's P plus AKFParams.smoother_drift2 times the time since (until) that frame,
  since a level carried by events drifts; where none did yet, the pass holds only a clip bound and events, and
  gets the clip prior's level (akf.clip_prior: the median of the levels beyond the bound that measured pixels
  reached) with the variance AKFParams.clip_prior_variance, or nothing where the prior has no level;
- the two are fused by information weight, L = (L_f / V_f + L_b / V_b) / (1 / V_f + 1 / V_b);
- where no frame ever measures the pixel, its level comes from its neighbours (akf.anchoring: the harmonic
  extension of the measured pixels' levels over the time-mean differences of the event curves, with the clip
  prior's level as a weak prior), within its clip bound.

Then the output smoothing of the filter (akf.smoothing) on the fused estimate. With no frame after t the backward
filter knows nothing, so after the last frame's mid-exposure the smoother equals the filter. The backward pass uses
the paper's event model (no leak correction: in reversed time the leak's ON events are OFF events).

References (docs/models/references.md): Fraser and Potter 1969 [Fraser1969], the two-filter smoother; Wang et
al. 2021 [Wang2021], the AKF.
"""

from __future__ import annotations

import dataclasses
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING

import numba
import numpy as np

from .anchoring import anchor_offsets
from .clip_prior import fill_unmeasured
from .filter import Masks, check_filter_options, prepared_inputs, run_filter, smooth_published
from .frame_noise import frame_read_noise
from .inputs import Inputs, as_crf
from .params import AKFParams
from .smoothing import LARGEST, finite_log

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

__all__ = ["reconstruct_smoothed"]

_DEFAULT_PARAMS = AKFParams()


@dataclasses.dataclass
class _Pass:
    """One filter pass's raw outputs at its published times: intensity exp(L) - I0 and P (T, n), and its Masks as
    (T, n) arrays."""

    intensity: np.ndarray
    variance: np.ndarray
    side: np.ndarray
    measured: np.ndarray
    floor: np.ndarray
    low: np.ndarray
    high: np.ndarray
    age: np.ndarray


def _run_pass(inp: Inputs, crf, params: AKFParams, leak_rate_hz: float) -> _Pass:
    nt, (h, w) = inp.out_t.shape[0], inp.shape
    n = h * w
    out_i, out_p = np.zeros((nt, h, w), np.float32), np.zeros((nt, h, w), np.float32)
    rec = _Pass(out_i.reshape(nt, n), out_p.reshape(nt, n), np.zeros((nt, n), np.int8), np.zeros((nt, n), bool),
                np.zeros((nt, n), np.float32), np.zeros((nt, n), np.float32), np.zeros((nt, n), np.float32),
                np.zeros((nt, n), np.float32))

    def keep(j, oi, op, masks: Masks):
        rec.side[j], rec.measured[j], rec.floor[j] = masks.side, masks.measured, masks.floor
        rec.low[j], rec.high[j] = masks.low, masks.high
        rec.age[j] = (inp.out_t[j] - masks.when) * 1e-6  # s since the last frame measured the pixel (inf: never)

    run_filter(inp, crf, params, leak_rate_hz, out_i, out_p, None, keep)
    return rec


def _both_passes(inp: Inputs, reverse: Inputs | None, crf, params: AKFParams, leak_rate_hz: float
                 ) -> tuple[_Pass, _Pass | None]:
    """The forward pass over inp and the backward one over `reverse` (None: no backward pass). With more than one
    numba thread the two run at once, one thread each: their serial parts (frame work, publishing) overlap, where
    one pass on two threads leaves a core idle during them."""
    threads = numba.get_num_threads()
    if reverse is None or threads < 2:
        return (_run_pass(inp, crf, params, leak_rate_hz),
                None if reverse is None else _run_pass(reverse, crf, params, 0.0))

    def one_thread(pass_inp, leak):
        numba.set_num_threads(1)  # per calling thread
        return _run_pass(pass_inp, crf, params, leak)

    with ThreadPoolExecutor(max_workers=2, thread_name_prefix="aks-pass") as pool:
        backward = pool.submit(one_thread, reverse, 0.0)
        forward = pool.submit(one_thread, inp, leak_rate_hz)
        return forward.result(), backward.result()


def _reversed(inp: Inputs, times: np.ndarray) -> Inputs:
    """inp mirrored in time about (first exposure start + last exposure end) / 2, output at `times` mirrored plus
    1 us (so the backward image at t holds the events at t and later, the forward one those before t)."""
    mirror = int(inp.t_start[0]) + int(inp.t_end[-1])
    ev = inp.events[::-1].copy()
    ev["t"] = mirror - ev["t"]
    ev["p"] = -ev["p"]
    ts, te = mirror - inp.t_end[::-1], mirror - inp.t_start[::-1]
    gaps = (mirror + 1 - inp.gaps[::-1, ::-1]).astype(np.int64)  # no event in [a, b): none at mirror - [a, b)
    return dataclasses.replace(inp, events=ev, frames=np.ascontiguousarray(inp.frames[::-1]), t_start=ts, t_end=te,
                               tau=(ts + te) / 2.0, out_t=(mirror - times[::-1] + 1).astype(np.int64),
                               c_on=inp.c_off, c_off=inp.c_on, gaps=gaps)


def reconstruct_smoothed(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                         frame_t_end_us: npt.ArrayLike, crf: CRF | str, output_times_us: npt.ArrayLike, *,
                         contrast: npt.ArrayLike = 0.2, leak_rate_hz: float = 0.0,
                         params: AKFParams = _DEFAULT_PARAMS, bit_depth: int = 8, max_intensity: float | None = None,
                         return_variance: bool = False, gaps_us: npt.ArrayLike | str | None = None
                         ) -> npt.NDArray[np.float32] | tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """Reconstruct linear HDR intensity at output_times_us with the asynchronous Kalman smoother (see the module):
    the same inputs, parameters and units as akf.reconstruct, every event and frame of the input used at every time.

    Memory: the two passes keep their (T, H, W) estimates, variances and masks (26 bytes per pixel and time each:
    413 MiB for 30 images of 346 x 260 with the fusion's temporaries) until they are fused.

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us
        As akf.reconstruct's: events (sim.EVENT_DTYPE, time-sorted), (N, H, W) raw frames, their exposures (int64
        us), the CRF (a curve or its name) and the output times (non-decreasing int64 us).
    contrast, leak_rate_hz, params, bit_depth
        As akf.reconstruct's (log contrast threshold(s), leak rate in Hz, AKFParams, bits of the frames).
    max_intensity : float, optional
        Output bound (x units); None (default): unbounded.
    return_variance : bool, optional
        Also return the fused variance P (default False).
    gaps_us : array_like, "none" or None, optional
        As akf.reconstruct's (default None: detected); both passes read each gap as unknown change.

    Returns
    -------
    intensity : numpy.ndarray
        float32 (T, H, W) intensity in x units (frame 0's exposure), clipped to [0, max_intensity].
    variance : numpy.ndarray
        Only with return_variance: float32 (T, H, W) fused variance P (log^2).
    """
    check_filter_options(params, leak_rate_hz, max_intensity)
    crf = as_crf(crf)
    inp = prepared_inputs(events, frames, frame_t_start_us, frame_t_end_us, output_times_us, contrast, bit_depth,
                          params, crf, gaps_us)
    if params.read_noise_dn is None and params.frame_update:  # estimated once for both passes
        params = dataclasses.replace(params, read_noise_dn=frame_read_noise(inp.frames,
                                                                            int(inp.full_scale).bit_length()))
    nt, (h, w) = inp.out_t.shape[0], inp.shape
    # the backward filter knows something only before the last exposure ends
    before_end = inp.out_t <= inp.t_end[-1]
    times_b = inp.out_t[before_end]
    fwd, bwd = _both_passes(inp, _reversed(inp, times_b) if times_b.size else None, crf, params, leak_rate_hz)
    intensity, variance = fwd.intensity, fwd.variance
    masks = fwd  # fused in place
    if bwd is not None:
        order = np.arange(times_b.size)[::-1]  # backward output k is the forward time index order[k]
        rev = {f.name: getattr(bwd, f.name)[order] for f in dataclasses.fields(bwd)}
        gain = (inp.t_end[0] - inp.t_start[0]) / max(inp.t_end[-1] - inp.t_start[-1], 1) \
            if inp.t_end[-1] > inp.t_start[-1] else 1.0  # backward x units are the last frame's exposure's
        rev["intensity"] = rev["intensity"] * np.float32(gain)
        sel = np.flatnonzero(before_end)
        _fuse(intensity, variance, masks, sel, fwd, rev, params, float(np.log(gain)) if gain > 0 else 0.0)
    _anchor(intensity, masks, params.i0, (h, w))
    for j in range(nt):
        smooth_published(intensity[j], variance[j], Masks(masks.side[j].astype(np.float64), masks.measured[j],
                                                          masks.floor[j], masks.low[j], masks.high[j], None),
                         params, (h, w))
    out = intensity.reshape(nt, h, w)
    np.clip(out, 0.0, LARGEST if max_intensity is None else max_intensity, out=out)
    return (out, variance.reshape(nt, h, w)) if return_variance else out


def _intensity(log: np.ndarray, i0: float) -> np.ndarray:
    """exp(log) - i0 as float32, at most LARGEST."""
    return np.minimum(np.exp(log) - i0, LARGEST).astype(np.float32)


def _clip_prior_filled(intensity: np.ndarray, side: np.ndarray, measured: np.ndarray, i0: float) -> np.ndarray:
    """A copy of the (T, n) estimates with the clip prior's level (akf.clip_prior) at each time where a frame has
    not measured the pixel yet and the prior has a level."""
    filled = intensity.copy()
    for j in range(filled.shape[0]):
        fill_unmeasured(filled[j], i0, side[j].astype(np.float64), measured[j])
    return filled


def _with_clip_prior(intensity: np.ndarray, side: np.ndarray, measured: np.ndarray, i0: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(log, filled) of one pass at each time: its estimate with the clip prior's level where a frame has not
    measured the pixel yet (_clip_prior_filled), and where that prior gave a level."""
    filled = _clip_prior_filled(intensity, side, measured, i0)
    return finite_log(filled, i0), (filled != intensity) & ~measured


def _fuse(intensity, variance, masks: _Pass, sel, fwd: _Pass, rev: dict, params: AKFParams, log_gain: float) -> None:
    """In place at the forward time indices sel: the fused estimate, variance and masks (see the module)."""
    i0 = params.i0
    mf, mb = fwd.measured[sel], rev["measured"]
    lf, prior_f = _with_clip_prior(fwd.intensity[sel], fwd.side[sel], mf, i0)
    lb, prior_b = _with_clip_prior(rev["intensity"], rev["side"], mb, i0)
    # each side's variance grows with the time since its last measuring frame (smoother_drift2: events carry a level
    # with an error that grows with time, from the photoreceptor's lag and threshold mismatch the filter's P omits);
    # a side no frame has measured yet holds the clip prior's level with its variance, or only a bound (infinite)
    pf = np.where(mf, fwd.variance[sel] + params.smoother_drift2 * np.where(mf, fwd.age[sel], 0.0),
                  np.where(prior_f, params.clip_prior_variance, np.inf))
    pb = np.where(mb, rev["variance"] + params.smoother_drift2 * np.where(mb, rev["age"], 0.0),
                  np.where(prior_b, params.clip_prior_variance, np.inf))
    known = np.isfinite(pf) | np.isfinite(pb)
    with np.errstate(divide="ignore", invalid="ignore"):
        wf, wb = np.where(known, 1.0 / pf, 1.0), np.where(known, 1.0 / pb, 0.0)  # a bound on both sides: forward's
        fused_l = (lf * wf + lb * wb) / (wf + wb)
        fused_p = np.where(known, 1.0 / (wf + wb), fwd.variance[sel])
    intensity[sel] = _intensity(fused_l, i0)
    variance[sel] = np.minimum(fused_p, LARGEST).astype(np.float32)
    masks.measured[sel] = mf | mb
    masks.side[sel] = np.where(fwd.side[sel] == rev["side"], fwd.side[sel], 0)
    measured_now = np.isinf(fwd.floor[sel]) | np.isinf(rev["floor"])
    masks.floor[sel] = np.where(measured_now, np.float32(np.inf), fwd.floor[sel])
    masks.low[sel] = np.maximum(fwd.low[sel], rev["low"] + np.float32(log_gain))
    masks.high[sel] = np.minimum(fwd.high[sel], rev["high"] + np.float32(log_gain))


def _anchor(intensity, masks: _Pass, i0: float, shape: tuple[int, int]) -> None:
    """In place: the never-measured pixels shifted by their anchoring offsets (akf.anchoring), the clip prior's
    level as the prior where no measured pixel reaches."""
    nt = intensity.shape[0]
    unknown = ~masks.measured.any(axis=0)
    filled = _clip_prior_filled(intensity, masks.side, masks.measured, i0)
    if not unknown.any() or unknown.all():  # nothing to anchor, or no measured pixel to anchor to
        intensity[:] = filled
        if unknown.any():
            intensity[:] = _intensity(np.clip(finite_log(intensity, i0), masks.low, masks.high), i0)
        return
    log = finite_log(intensity, i0)
    prior = (finite_log(filled, i0) - log).mean(axis=0)
    # the offsets that keep each pixel on its side of the clip bound at every time (low / high: log bounds)
    lowest = np.max(np.where(np.isfinite(masks.low), masks.low - log, -np.inf), axis=0)
    highest = np.min(np.where(np.isfinite(masks.high), masks.high - log, np.inf), axis=0)
    lowest, highest = np.minimum(lowest, 0.0), np.maximum(highest, 0.0)  # never beyond where the filter put it
    d = anchor_offsets(log.reshape(nt, *shape), unknown.reshape(shape), prior.reshape(shape),
                       lowest.reshape(shape), highest.reshape(shape)).ravel()
    # every frame clipped the never-measured pixels: each says "at least (at most) this level"
    level = np.where(unknown, np.clip(log + d, masks.low, masks.high), log)
    intensity[:] = _intensity(level, i0)
