"""The radiance signals of the one-pixel panel: linear radiance of one pixel over time.

Every signal is `level` times a dimensionless shape, so the light level (and with it the photoreceptor's
bandwidth, which scales with the photocurrent) is one knob. A pixel of a real recording comes from
`recording_pixel`: its APS frames at the pixel with the most events, linearised and interpolated in log.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim import EvsimInputError

#: the built-in shapes; "recording" (a real pixel) needs a PixelTrace
SIGNALS = ("sinusoid", "step", "ramp", "flicker")
STEP_LOG = 1.0  # log units of the step's rise (a factor e)
SINE_LOG, SINE_HZ = 0.8, 4.0  # log amplitude and frequency (Hz) of the sinusoid
RAMP_LOG = 2.0  # log units the ramp climbs over the whole signal
FLICKER_HZ, FLICKER_DEPTH = 100.0, 0.8  # a mains lamp: 100 Hz flicker, 80 % modulation depth


@dataclass(frozen=True)
class PixelTrace:
    """One pixel of a recording: times (int64 us from the recording's first frame) and linear radiance (relative
    to the frames' full scale); name says where it comes from."""

    t_us: np.ndarray
    radiance: np.ndarray
    name: str


def pixel_signal(kind: str, t_us: np.ndarray, level: float, trace: PixelTrace | None = None) -> np.ndarray:
    """float32 linear radiance of signal `kind` at times `t_us` (int64 us), scaled by `level` (radiance units).

    Parameters
    ----------
    kind : str
        One of SIGNALS, or "recording" (then `trace` is interpolated in log radiance, looped over its length).
    t_us : numpy.ndarray
        Sample times in microseconds.
    level : float
        Mean radiance (units of the DVS's full illumination); > 0.
    trace : PixelTrace, optional
        The real pixel for kind "recording".
    """
    if not level > 0:
        raise EvsimInputError(f"the light level must be > 0 (radiance units), got {level}")
    t = np.asarray(t_us, np.float64) * 1e-6
    span = max(float(t[-1] - t[0]), 1e-6)
    if kind == "sinusoid":
        shape = np.exp(SINE_LOG * np.sin(2 * np.pi * SINE_HZ * t))
    elif kind == "step":
        shape = np.exp(STEP_LOG * ((t >= 0.3 * span) & (t < 0.7 * span)))
    elif kind == "ramp":
        shape = np.exp(RAMP_LOG * (t - t[0]) / span - RAMP_LOG / 2)
    elif kind == "flicker":
        shape = 1.0 + FLICKER_DEPTH * np.sin(2 * np.pi * FLICKER_HZ * t)
    elif kind == "recording":
        if trace is None:
            raise EvsimInputError("the recording signal needs a real recording (none was found)")
        tt = (trace.t_us - trace.t_us[0]) * 1e-6
        log_r = np.log(np.maximum(trace.radiance, 1e-4))
        shape = np.exp(np.interp(np.mod(t - t[0], max(tt[-1], 1e-6)), tt, log_r))
        shape /= np.exp(log_r.mean())
    else:
        raise EvsimInputError(f"unknown signal {kind!r}; one of {', '.join((*SIGNALS, 'recording'))}")
    return (level * shape).astype(np.float32)


def recording_pixel(path: str | Path) -> PixelTrace:
    """The pixel of a real hybrid recording (AEDAT4, IJRR folder, ...) with the most events: its frames'
    responses linearised as DN / full scale (the DAVIS APS is close to linear), at mid-exposure times."""
    from generators.formats import load

    rec = load(Path(path))
    if rec.frames is None or rec.frames.shape[0] < 2:
        raise EvsimInputError(f"{path}: the recording needs at least two frames for a pixel signal")
    counts = np.bincount(rec.events["y"].astype(np.int64) * rec.width + rec.events["x"],
                         minlength=rec.width * rec.height)
    y, x = divmod(int(np.argmax(counts)), rec.width)
    full = float((1 << rec.frame_bit_depth) - 1)
    radiance = np.maximum(rec.frames[:, y, x].astype(np.float64), 0.5) / full
    t = rec.frame_t_mid_us.astype(np.int64)
    return PixelTrace(t - t[0], radiance, f"{Path(path).name} pixel (x={x}, y={y})")
