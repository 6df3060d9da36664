"""Baselines with the inputs and outputs of akf.reconstruct: complementary filter, events-only high-pass filter,
frames only (nearest / linear blend) and direct event integration.

A frame k is taken to describe the scene at its mid-exposure time tau_k = (start + end) / 2, and it is used from
then on (zero-order hold, causal). Intensities are CRF^-1 scaled to frame 0's exposure time (times T_0 / T_k).
Output images at t include the events with timestamps < t; output is float32
(T, H, W) linear intensity in the CRF's scaled-irradiance units (max(exp(log) - I0, 0) for the log-domain filters:
never negative). crf is a crf_models curve or its registered name.

References (docs/models/references.md): Scheerlinck et al. 2018 [Scheerlinck2018], the complementary and
high-pass filters; Wang et al. 2021 [Wang2021].
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from sim.errors import InvalidParameterError, check_number
from sim.events import slice_time
from sim.gaps import resolve_gaps
from sim.parallel import in_parallel

from . import kernels
from .augmentation import MIN_PART_ROWS
from .inputs import Inputs, as_crf, check_max_intensity, validate_inputs
from .params import AKFParams

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

_I0 = AKFParams().i0


def _intensity(inp: Inputs, crf, k: int) -> np.ndarray:
    """CRF^-1 of frame k in frame 0's exposure units (scaled by T_0 / T_k), float64 (H, W)."""
    return inp.exposure_gain(k) * np.asarray(crf.inverse(inp.response(k)), np.float64)


def _log_frame(inp: Inputs, crf, k: int, i0: float) -> np.ndarray:
    return np.log(_intensity(inp, crf, k) + i0).ravel()


def _run_log_filter(inp: Inputs, t0, switch_times, on_switch, run_events, publish):
    """Drive a per-pixel log filter over the events from t0 (us) on: frame switches at switch_times (ascending, us)
    call on_switch(k) after every pixel was brought to that time; outputs are published in order."""
    out = np.zeros((inp.out_t.shape[0], *inp.shape), np.float32)
    if not out.shape[0]:
        return out
    cursor = t0
    marks = sorted([(int(t), 0, k) for k, t in enumerate(switch_times) if t <= inp.out_t[-1]] +
                   [(int(t), 1, j) for j, t in enumerate(inp.out_t)])
    for t, kind, idx in marks:
        if t > cursor:
            run_events(np.ascontiguousarray(slice_time(inp.events, cursor, t)))  # one layout: one compiled kernel
            cursor = t
        if kind == 0:
            publish(t, np.empty(0, np.float32))
            on_switch(idx)
        else:
            publish(t, out[idx].reshape(-1))
    return out


def _crossover_alpha(crossover_hz, alpha):
    if (crossover_hz is None) == (alpha is None):
        raise InvalidParameterError("give exactly one of crossover_hz (Hz) or alpha (rad/s)")
    if alpha is None:
        return 2 * math.pi * check_number("crossover_hz", crossover_hz, positive=False)
    return check_number("alpha", alpha, positive=False)


def complementary_filter(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                         frame_t_end_us: npt.ArrayLike, crf: CRF | str, output_times_us: npt.ArrayLike, *,
                         contrast: npt.ArrayLike = 0.2, crossover_hz: float | None = None, alpha: float | None = None,
                         adaptive_gain: bool = False, adaptive_factor: float = 0.1, adaptive_margin: float = 0.05,
                         max_intensity: float | None = 1.0, i0: float = _I0, bit_depth: int = 8,
                         gaps_us: npt.ArrayLike | str | None = None) -> npt.NDArray[np.float32]:
    """Complementary filter (Scheerlinck et al. 2018 [Scheerlinck2018]) on the log image L = log(I + I0).

    dL/dt = E(t) - alpha (L - L^F): events E are high-passed, the latest frame's log L^F low-passed; per event
    L <- L^F + (L - L^F) exp(-alpha dt) + sigma c, with crossover alpha (rad/s) = 2 pi crossover_hz (default
    0.5 Hz, the original ROS default). The filter starts at tau_0 from L^F of frame 0.

    Bounded output: the state is kept in [log(I0), log(max_intensity + I0)], i.e. I in [0, max_intensity], and L^F
    likewise; max_intensity None: unbounded (the textbook filter, whose event integration at a mismatched threshold
    can run far above anything the sensor saw where frames are clipped).
    adaptive_gain (the paper's adaptive crossover): alpha(p) = alpha for frame logs in [L_low, L_high], falling
    linearly to adaptive_factor * alpha (lambda) at the ends L_min, L_max of what the frame can represent
    (log of CRF^-1(0) and CRF^-1(1) in frame 0's exposure units); L_low / L_high lie adaptive_margin * (L_max -
    L_min) inside them. Events thus dominate where the frame is (nearly) clipped; the bound keeps the state
    finite even for lambda = 0 (an integrator there).
    Gaps (spans where events are missing: dropped packets, exposure-gated exports; sim.gaps): the state then misses
    the change of the gap, which the slow crossover would carry for seconds; at the first frame after a gap's end
    every pixel's state is reset to that frame's log (the next frame decides). Not in the original filter; a
    complete stream is filtered as before, bit for bit.

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, contrast, bit_depth
        As akf.reconstruct's: events (sim.EVENT_DTYPE, time-sorted), (N, H, W) raw frames of bit_depth bits, their
        exposures (int64 us), the CRF (a curve or its name), output times (int64 us) and the nominal log contrast
        threshold(s).
    crossover_hz : float, optional
        Crossover frequency (Hz), >= 0; default 0.5 when alpha is not given either. Give at most one of crossover_hz
        and alpha.
    alpha : float, optional
        Crossover gain (rad/s), >= 0, instead of crossover_hz.
    adaptive_gain : bool, optional
        The paper's adaptive crossover (default False).
    adaptive_factor : float, optional
        lambda as a fraction of alpha at the ends of the frame's range, in [0, 1] (default 0.1).
    adaptive_margin : float, optional
        Where the ramp starts, as a fraction of L_max - L_min inside the ends, in [0, 0.5] (default 0.05).
    max_intensity : float, optional
        Bound of the output (x units; default 1, the top of the CRF's input range: the full well); None: unbounded.
    i0 : float, optional
        The log offset I0 (x units), > 0 (default AKFParams().i0).
    gaps_us : array_like, "none" or None, optional
        As akf.reconstruct's: None (default) detects the gaps (sim.find_gaps), "none" reads every empty span as no
        change, or (G, 2) int64 [start, end) us.

    Returns
    -------
    numpy.ndarray
        float32 (T, H, W) intensity max(exp(L) - I0, 0) in the CRF's scaled-irradiance units (x units).
    """
    if crossover_hz is None and alpha is None:
        crossover_hz = 0.5
    a = _crossover_alpha(crossover_hz, alpha)
    for name, v, lo, hi in (("adaptive_factor", adaptive_factor, 0.0, 1.0), ("adaptive_margin", adaptive_margin,
                                                                             0.0, 0.5)):
        if not lo <= check_number(name, v, positive=False) <= hi:
            raise InvalidParameterError(f"{name} must be in [{lo}, {hi}], got {v!r}")
    check_max_intensity(max_intensity)
    check_number("i0", i0, positive=True)
    inp = validate_inputs(events, frames, frame_t_start_us, frame_t_end_us, output_times_us, contrast, bit_depth)
    inp = dataclasses.replace(inp, gaps=resolve_gaps(gaps_us, inp.events, inp.t_start, inp.t_end))
    crf = as_crf(crf)
    bounds = (math.log(i0), math.log(max_intensity + i0)) if max_intensity is not None else _UNBOUNDED

    def log_frame(k):
        return np.clip(_log_frame(inp, crf, k, i0), *bounds)

    def gains(k, lf):
        if not adaptive_gain:
            return np.full(lf.shape[0], a)
        g = inp.exposure_gain(k)
        l_min, l_max = (math.log(g * float(crf.inverse(y)) + i0) for y in (0.0, 1.0))
        m = adaptive_margin * (l_max - l_min)
        # 0 at L_min / L_max, 1 inside [L_low, L_high]
        ramp = np.clip(np.minimum(lf - l_min, l_max - lf) / m, 0.0, 1.0) if m > 0 else np.ones_like(lf)
        return a * (adaptive_factor + (1 - adaptive_factor) * ramp)

    out = _cf(inp, log_frame, gains, bounds, i0)
    return np.maximum(out, 0.0, out=out)


_UNBOUNDED = (-1e300, 1e300)  # finite: the kernels are compiled with fastmath "ninf"


def _cf(inp: Inputs, log_frame, gains, bounds, i0):
    """The complementary filter over validated inputs; log_frame(k) gives frame k's flat log image on demand,
    gains(k, log frame) the per-pixel crossover (rad/s), bounds the (lo, hi) log range of the state."""
    w = inp.shape[1]
    lf0 = log_frame(0)
    state = {"lf": lf0, "alpha": gains(0, lf0)}
    x = state["lf"].copy()
    t0 = int(math.floor(inp.tau[0]))
    tl = np.full(x.shape[0], t0, np.int64)
    lo, hi = float(bounds[0]), float(bounds[1])

    switches = [int(math.floor(t)) for t in inp.tau[1:]]
    gap_ends = inp.gaps[:, 1]

    def on_switch(k):
        lf = log_frame(k)
        state["lf"], state["alpha"] = lf, gains(k, lf)
        since = switches[k - 2] if k > 1 else t0
        if np.any((gap_ends > since) & (gap_ends <= switches[k - 1])):  # a gap since the last frame: unknown change
            x[:] = lf

    h = inp.shape[0]

    def run_events(ev):
        in_parallel(lambda y0, y1: kernels.cf_events(ev, w, inp.c_on, inp.c_off, x, tl, state["lf"], state["alpha"],
                                                     lo, hi, y0, y1), h, MIN_PART_ROWS)

    def publish(t, out):
        in_parallel(lambda y0, y1: kernels.cf_publish(np.int64(t), x, tl, state["lf"], state["alpha"], i0, out,
                                                      y0 * w, y1 * w), h, MIN_PART_ROWS)

    return _run_log_filter(inp, t0, switches, lambda k: on_switch(k + 1), run_events, publish)


def high_pass_filter(events: np.ndarray, shape: tuple[int, int], output_times_us: npt.ArrayLike, *,
                     contrast: npt.ArrayLike = 0.2, crossover_hz: float | None = None, alpha: float | None = None,
                     t0_us: int = 0) -> npt.NDArray[np.float32]:
    """Events-only high-pass filter (Scheerlinck et al. 2018 [Scheerlinck2018]): the complementary filter with zero
    frame input (L^F = 0), started at t0_us with a zero log image.

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE, time-sorted.
    shape : tuple of int
        (H, W), pixels.
    output_times_us : array_like
        Non-decreasing int64 us, none before t0_us; the image at t includes the events with timestamps < t.
    contrast : array_like, optional
        Nominal log contrast threshold(s), as akf.reconstruct's (default 0.2).
    crossover_hz, alpha : float, optional
        The crossover, in Hz or rad/s (at most one; default 0.5 Hz), as complementary_filter's.
    t0_us : int, optional
        Start time (int64 us; default 0).

    Returns
    -------
    numpy.ndarray
        float32 (T, H, W) log intensity (relative, log units).
    """
    if crossover_hz is None and alpha is None:
        crossover_hz = 0.5
    a = _crossover_alpha(crossover_hz, alpha)
    h, w = shape
    frames = np.zeros((1, h, w), np.uint8)
    inp = validate_inputs(events, frames, [t0_us], [t0_us], output_times_us, contrast, 8)
    out = _cf(inp, lambda k: np.zeros(h * w), lambda k, lf: np.full(h * w, a), _UNBOUNDED, 0.0)
    return np.log(out)


def frames_only(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                frame_t_end_us: npt.ArrayLike, crf: CRF | str, output_times_us: npt.ArrayLike, *,
                contrast: npt.ArrayLike = 0.2, mode: str = "nearest", bit_depth: int = 8) -> npt.NDArray[np.float32]:
    """CRF^-1 of the frame nearest in time (mode="nearest", by mid-exposure time) or the linear blend in intensity
    of the two frames around t (mode="linear", clamped to the first / last frame). Events are ignored.

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, contrast, bit_depth
        As akf.reconstruct's (the events and contrast are validated, not used).
    mode : {"nearest", "linear"}, optional
        Nearest frame (default) or linear blend.

    Returns
    -------
    numpy.ndarray
        float32 (T, H, W) intensity in the CRF's scaled-irradiance units (x units, frame 0's exposure time).
    """
    if mode not in ("nearest", "linear"):
        raise InvalidParameterError(f"frames_only mode must be 'nearest' or 'linear', got {mode!r}")
    inp = validate_inputs(events, frames, frame_t_start_us, frame_t_end_us, output_times_us, contrast, bit_depth)
    crf = as_crf(crf)
    tau, nf = inp.tau, inp.frames.shape[0]
    out = np.zeros((inp.out_t.shape[0], *inp.shape), np.float32)
    cache = {}

    def intensity(k):
        if k not in cache:
            if len(cache) > 2:
                cache.clear()
            cache[k] = _intensity(inp, crf, k)
        return cache[k]

    for j, t in enumerate(inp.out_t):
        k1 = int(np.searchsorted(tau, t, side="right"))  # first frame with tau > t
        k0 = max(k1 - 1, 0)
        k1 = min(k1, nf - 1)
        if k0 == k1:
            out[j] = intensity(k0)
            continue
        u = (t - tau[k0]) / (tau[k1] - tau[k0])
        if mode == "nearest":
            out[j] = intensity(k1 if u > 0.5 else k0)
        else:
            out[j] = (1 - u) * intensity(k0) + u * intensity(k1)
    return out


def direct_integration(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                       frame_t_end_us: npt.ArrayLike, crf: CRF | str, output_times_us: npt.ArrayLike, *,
                       contrast: npt.ArrayLike = 0.2, i0: float = _I0, bit_depth: int = 8) -> npt.NDArray[np.float32]:
    """The log of the first frame at tau_0 plus the contrast times the signed event count since then.

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, contrast, bit_depth
        As akf.reconstruct's.
    i0 : float, optional
        The log offset I0 (x units), > 0 (default AKFParams().i0).

    Returns
    -------
    numpy.ndarray
        float32 (T, H, W) intensity max(exp(L) - I0, 0) in the CRF's scaled-irradiance units (x units).
    """
    check_number("i0", i0, positive=True)
    inp = validate_inputs(events, frames, frame_t_start_us, frame_t_end_us, output_times_us, contrast, bit_depth)
    crf = as_crf(crf)
    x = _log_frame(inp, crf, 0, i0)
    w = inp.shape[1]

    def run_events(ev):
        kernels.integrate_events(ev, w, inp.c_on, inp.c_off, x)

    def publish(t, out):
        if out.shape[0]:
            out[:] = np.maximum(np.exp(x) - i0, 0.0)

    return _run_log_filter(inp, int(math.floor(inp.tau[0])), [], None, run_events, publish)


BASELINES = {
    "cf": complementary_filter,
    "cf_adaptive": lambda *a, **k: complementary_filter(*a, adaptive_gain=True, **k),
    "frames": frames_only,
    "frames_linear": lambda *a, **k: frames_only(*a, mode="linear", **k),
    "direct": direct_integration,
}
