"""The DVS contrast threshold estimated from the data, for recordings that carry none.

Between the mid-exposures of two consecutive frames a pixel whose true log intensity changed by dL fires about dL /
c net events (ON minus OFF), whatever its quantisation phase (uniform on [0, c)): E[net | dL] = dL / c. So the slope
of net on dL over many pixels is 1 / c without the bias of regressing dL on net (the phase noise is in net). dL is
measured as the change of log(CRF^-1(response) * T_0 / T_k + I0) between the two frames (I0: the pixel's log offset,
the DVS model's dark level sim.DVSParams.dark_fraction x full_illumination in the frames' units; given, or estimated
as the offset under which the estimate does not depend on brightness: estimate_log_offset), on pixels with both
responses inside [margin, 1 - margin] (unclipped) and |dL| >= min_change (frame noise in the regressor would bias
the slope toward 0). ON and OFF are estimated separately (pixels with dL > 0 give c_on, dL < 0 c_off). Robust: the
slope is refitted on the pixels whose residual lies within 3 scaled MADs, twice.

References (docs/models/references.md): Brandli et al. 2014 [Brandli2014b].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim.errors import EvsimInputError, InvalidParameterError
from sim.events import slice_time

from .inputs import as_crf, validate_inputs

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

_I0 = 1e-3


@dataclass(frozen=True)
class ContrastEstimate:
    """The contrast thresholds estimated by estimate_contrast.

    Attributes
    ----------
    c_on, c_off : float
        Estimated thresholds (log units, OFF as a magnitude).
    n_on, n_off : int
        Pixel-intervals used.
    i0 : float
        The log offset used (x units).
    """

    c_on: float
    c_off: float
    n_on: int
    n_off: int
    i0: float = _I0

    @property
    def pair(self) -> tuple[float, float]:
        return self.c_on, self.c_off


def _slope(dl: np.ndarray, net: np.ndarray) -> float:
    """Robust least-squares slope of net on dl with an intercept (3-MAD trimming, two refits)."""
    keep = np.ones(dl.shape[0], bool)
    slope = 0.0
    for _ in range(3):
        d, n = dl[keep], net[keep]
        dm = d - d.mean()
        slope = float(np.dot(dm, n - n.mean()) / np.dot(dm, dm))
        resid = net - n.mean() - slope * (dl - d.mean())
        mad = 1.4826 * float(np.median(np.abs(resid[keep] - np.median(resid[keep]))))
        keep = np.abs(resid) <= 3 * max(mad, 0.5)
    return slope


def _pixel_intervals(events, frames, frame_t_start_us, frame_t_end_us, crf, bit_depth, margin):
    """(x0, x1, net): for every pixel and pair of consecutive frames with both responses inside [margin,
    1 - margin], the linear intensities (CRF^-1 x T_0 / T_k) at the two frames and the net events between their
    mid-exposures."""
    times = np.asarray(frame_t_start_us)[:1]
    inp = validate_inputs(events, frames, frame_t_start_us, frame_t_end_us, times, 0.2, bit_depth)
    crf = as_crf(crf)
    nf, (h, w) = inp.frames.shape[0], inp.shape
    if nf < 2:
        raise EvsimInputError("contrast estimation needs at least 2 frames")
    x0s, x1s, nets = [], [], []
    prev_y = inp.response(0).ravel()
    prev_x = inp.exposure_gain(0) * np.asarray(crf.inverse(prev_y), np.float64)
    for k in range(1, nf):
        y = inp.response(k).ravel()
        x = inp.exposure_gain(k) * np.asarray(crf.inverse(y), np.float64)
        ev = slice_time(inp.events, int(np.floor(inp.tau[k - 1])), int(np.floor(inp.tau[k])))
        net = np.bincount(ev["y"].astype(np.int64) * w + ev["x"], weights=ev["p"].astype(np.float64),
                          minlength=h * w)
        ok = (prev_y >= margin) & (prev_y <= 1 - margin) & (y >= margin) & (y <= 1 - margin)
        x0s.append(prev_x[ok])
        x1s.append(x[ok])
        nets.append(net[ok])
        prev_y, prev_x = y, x
    return np.concatenate(x0s), np.concatenate(x1s), np.concatenate(nets)


def _contrast_at(x0, x1, net, i0: float, min_change: float, min_pixels: int, raise_errors: bool = True):
    """[(c, n) for ON, OFF] of the pixel intervals with offset i0 (see the module), or None where too few."""
    dl = np.log(x1 + i0) - np.log(x0 + i0)
    big = np.abs(dl) >= min_change
    out = []
    for sign, name in ((1, "ON"), (-1, "OFF")):
        sel = big & (sign * dl > 0)
        if sel.sum() < min_pixels:
            if not raise_errors:
                return None
            raise EvsimInputError(f"contrast estimation: only {int(sel.sum())} unclipped pixel intervals with a "
                                  f"{name} change >= {min_change} (need {min_pixels}): give the contrast instead")
        slope = _slope(sign * dl[sel], sign * net[sel])
        if not slope > 0:
            if not raise_errors:
                return None
            raise EvsimInputError(f"contrast estimation: the {name} events do not follow the frames' log change")
        out.append((1.0 / slope, int(sel.sum())))
    return out


def estimate_contrast(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                      frame_t_end_us: npt.ArrayLike, crf: CRF | str, *, bit_depth: int = 8, margin: float = 0.05,
                      min_change: float = 0.1, min_pixels: int = 50, i0: float | None = _I0) -> ContrastEstimate:
    """Estimate (c_on, c_off) from events against the log change between consecutive unclipped frames (see the
    module docstring). Raises EvsimInputError when fewer than min_pixels usable pixel intervals exist for a
    polarity (static scene, clipped frames or no events).

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf, bit_depth
        As akf.reconstruct's: events (sim.EVENT_DTYPE, time-sorted), at least 2 (N, H, W) raw frames of bit_depth
        bits, their exposures (int64 us) and the CRF (a curve or its name).
    margin : float, optional
        Pixels count only with both responses inside [margin, 1 - margin], 0 <= margin < 0.5 (default 0.05).
    min_change : float, optional
        Least abs(dL) of a pixel interval (log units), > 0 (default 0.1).
    min_pixels : int, optional
        Least number of pixel intervals per polarity, >= 1 (default 50).
    i0 : float, optional
        The pixel's log offset (dark level) in the frames' x units (the DVS model's I_d:
        sim.DVSParams.dark_fraction x full_illumination, in x units; default 1e-3); None estimates it
        (estimate_log_offset).

    Returns
    -------
    ContrastEstimate
        The thresholds, the pixel intervals used and the offset.
    """
    if not (0 <= margin < 0.5 and min_change > 0 and min_pixels >= 1):
        raise InvalidParameterError("need 0 <= margin < 0.5, min_change > 0 and min_pixels >= 1")
    x0, x1, net = _pixel_intervals(events, frames, frame_t_start_us, frame_t_end_us, crf, bit_depth, margin)
    if i0 is None:
        i0 = _offset_of(x0, x1, net, min_change, min_pixels)
    (c_on, n_on), (c_off, n_off) = _contrast_at(x0, x1, net, float(i0), min_change, min_pixels)
    return ContrastEstimate(c_on, c_off, n_on, n_off, float(i0))


#: candidate log offsets of estimate_log_offset, as fractions of the frames' full scale (x = 1)
OFFSET_GRID = tuple(float(v) for v in np.geomspace(1e-3, 0.5, 28))


def _offset_of(x0, x1, net, min_change: float, min_pixels: int) -> float:
    """The offset of OFFSET_GRID whose contrast estimates agree best across brightness: per polarity, the pixel
    intervals are split into BRIGHTNESS_BINS by the geometric mean of their two intensities and the spread
    (standard deviation of log c over the bins) is summed over ON and OFF."""
    level = np.sqrt(np.maximum(x0, 0) * np.maximum(x1, 0))
    edges = np.quantile(level, np.linspace(0, 1, BRIGHTNESS_BINS + 1)[1:-1])
    bins = np.searchsorted(edges, level)
    best, best_spread = _I0, np.inf
    for i0 in OFFSET_GRID:
        logs = []
        for b in range(BRIGHTNESS_BINS):
            sel = bins == b
            est = _contrast_at(x0[sel], x1[sel], net[sel], i0, min_change, min_pixels, raise_errors=False)
            if est is None:
                break
            logs.append([math.log(c) for c, _ in est])
        if len(logs) < BRIGHTNESS_BINS:
            continue
        spread = float(np.std(np.array(logs), axis=0).sum())
        if spread < best_spread:
            best, best_spread = i0, spread
    return best


BRIGHTNESS_BINS = 4


def estimate_log_offset(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                        frame_t_end_us: npt.ArrayLike, crf: CRF | str, *, bit_depth: int = 8, margin: float = 0.05,
                        min_change: float = 0.1, min_pixels: int = 50) -> float:
    """The pixel's log offset i0 (x units) under which the contrast estimate does not depend on brightness.

    A DVS pixel responds to log(I + I_d): with too small an offset, dim pixels seem to fire too few events per
    log change (their log change is overstated) and the estimate grows with darkness. The offset of OFFSET_GRID
    that minimises the spread of the estimates over BRIGHTNESS_BINS brightness quantiles is returned (on the
    DAVIS346 road recording: about 0.1, i.e. 25 DN, where evsim calibrate fits 20-35 DN).

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf, bit_depth, margin, min_change, min_pixels
        As estimate_contrast's.

    Returns
    -------
    float
        The offset (x units), one of OFFSET_GRID (1e-3 when no candidate has enough pixel intervals in every bin).
    """
    x0, x1, net = _pixel_intervals(events, frames, frame_t_start_us, frame_t_end_us, crf, bit_depth, margin)
    return _offset_of(x0, x1, net, min_change, min_pixels)
