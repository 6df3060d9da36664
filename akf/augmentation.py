"""Frame augmentation (section 4.1): EDI deblurring, per-pixel contrast calibration and the interval curves.

All log images are flat float64 (H*W,) arrays in L = log(I + I0). Events are assumed to report changes of this L.
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .params import AKFParams


def columns(events: np.ndarray):
    """Contiguous t, x, y, p columns of an event array (numba kernels want plain arrays)."""
    return (np.ascontiguousarray(events["t"]), np.ascontiguousarray(events["x"]),
            np.ascontiguousarray(events["y"]), np.ascontiguousarray(events["p"]))


def edi_deblur(log_frame, exposure_events, t_start_us, t_end_us, c_on, c_off, width):
    """EDI (Pan et al. 2019) of a frame to the start and end of its exposure [t_start_us, t_end_us).

    The frame is the mean of I + I0 over the exposure and I(t) + I0 = (I(t_start) + I0) exp(E(t)), E the event log
    change since t_start (nominal contrasts), so L(t_start) = L^F - log((1/T) integral exp(E(t)) dt), computed
    exactly over the piecewise-constant E, and L(t_end) = L(t_start) + E(t_end). Returns (L_start, L_end).
    """
    if t_end_us <= t_start_us:
        return log_frame.copy(), log_frame.copy()
    mean_gain, change = kernels.exposure_integral(*columns(exposure_events), width, c_on, c_off,
                                                  np.int64(t_start_us), np.int64(t_end_us), log_frame.shape[0])
    start = log_frame - np.log(mean_gain)
    return start, start + change


def event_change(events, c_on, c_off, width):
    """Per-pixel nominal event log change (sum of +c_on / -c_off, log units) and net signed event count."""
    return kernels.event_change(events["x"], events["y"], events["p"], width, c_on, c_off)


def calibrate_scale(d_start, d_end, change, net, clipped, params: AKFParams):
    """Per-pixel contrast scale c_p^k / c (eq. 12): (L^D_end - L^D_start) / (nominal event change).

    Guards (the scale stays 1, i.e. the nominal contrast): calibration disabled; fewer than calib_min_events net
    events; either deblurred frame clipped; ratio outside calib_scale_range (this also rejects opposite signs).
    """
    scale = np.ones_like(change)
    if not params.calibrate:
        return scale
    ok = (np.abs(net) >= max(params.calib_min_events, 1)) & ~clipped
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (d_end - d_start) / change
    lo, hi = params.calib_scale_range
    ok &= (ratio >= lo) & (ratio <= hi)
    scale[ok] = ratio[ok]
    return scale


def interval_start(d_start, d_end, change, scale, end_clipped):
    """Value at the interval start of its curve M(t) (eqs. 10-11).

    With a calibrated scale the forward (10) and backward (11) curves coincide and this is L^D_start. Where the
    calibration was refused the curve is anchored to the later deblurred frame (eq. 13 uses L^A+ between exposures),
    M(t) = L^D_end - scale * (event change from t to the end), except where only the later frame is clipped: there
    it is anchored to the earlier frame, M(t) = L^D_start + scale * (event change since the start).
    """
    return np.where(end_clipped, d_start, d_end - scale * change)
