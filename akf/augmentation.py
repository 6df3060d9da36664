"""Frame augmentation (section 4.1): EDI deblurring, per-pixel contrast calibration and the interval curves.

All log images are flat float64 (H*W,) arrays in L = log(I + I0). Events are assumed to report changes of this L.

References (docs/models/references.md): Wang et al. 2021 [Wang2021] (its section numbers above); Pan et al. 2019
[Pan2019], EDI; Pan et al. 2022 [Pan2022].
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sim.parallel import in_parallel

from . import kernels
from .params import AKFParams

if TYPE_CHECKING:
    import numpy.typing as npt

MIN_PART_ROWS = 16  # pixel rows per thread part of the per-event kernels


def edi_deblur(log_frame: np.ndarray, exposure_events: np.ndarray, t_start_us: int, t_end_us: int, c_on: np.ndarray,
               c_off: np.ndarray, width: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """EDI, the event double integral (Pan, Scheerlinck, Yu, Hartley, Liu and Dai, Bringing a Blurry Frame Alive
    at High Frame-Rate with an Event Camera, CVPR 2019), of a frame to the start and end of its exposure
    [t_start_us, t_end_us).

    The frame is the mean of I + I0 over the exposure and I(t) + I0 = (I(t_start) + I0) exp(E(t)), E the event log
    change since t_start (nominal contrasts), so L(t_start) = L^F - log((1/T) integral exp(E(t)) dt), computed
    exactly over the piecewise-constant E, and L(t_end) = L(t_start) + E(t_end). Returns (L_start, L_end).
    """
    if t_end_us <= t_start_us:
        return log_frame.copy(), log_frame.copy()
    mean_gain, change = np.zeros(log_frame.shape[0]), np.zeros(log_frame.shape[0])
    exposure_events = np.ascontiguousarray(exposure_events)  # one layout: one compiled kernel
    in_parallel(lambda y0, y1: kernels.exposure_integral(exposure_events, width, c_on, c_off, np.int64(t_start_us),
                                                         np.int64(t_end_us), mean_gain, change, y0, y1),
                log_frame.shape[0] // width, MIN_PART_ROWS)
    start = log_frame - np.log(mean_gain)
    return start, start + change


def event_change(events: np.ndarray, c_on: np.ndarray, c_off: np.ndarray,
                 width: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Per-pixel nominal event log change (sum of +c_on / -c_off, log units) and net signed event count."""
    change, net = np.zeros(c_on.shape[0]), np.zeros(c_on.shape[0], np.int64)
    events = np.ascontiguousarray(events)  # one layout: one compiled kernel
    in_parallel(lambda y0, y1: kernels.event_change(events, width, c_on, c_off, change, net, y0, y1),
                c_on.shape[0] // width, MIN_PART_ROWS)
    return change, net


def calibrate_scale(d_start: np.ndarray, d_end: np.ndarray, change: np.ndarray, net: np.ndarray, clipped: np.ndarray,
                    params: AKFParams, return_valid: bool = False
                    ) -> npt.NDArray[np.float64] | tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """Per-pixel contrast scale c_p^k / c (eq. 12 of Wang et al., ICCV 2021): (L^D_end - L^D_start) / (nominal
    event change).

    Guards (the scale stays 1, i.e. the nominal contrast): calibration disabled; fewer than calib_min_events net
    events; either deblurred frame clipped; ratio outside calib_scale_range (this also rejects opposite signs).
    return_valid: also return the bool mask of the pixels that were calibrated.
    """
    scale = np.ones_like(change)
    ok = np.zeros(change.shape, bool)
    if params.calibrate:
        ok = (np.abs(net) >= max(params.calib_min_events, 1)) & ~clipped
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = (d_end - d_start) / change
        lo, hi = params.calib_scale_range
        ok &= (ratio >= lo) & (ratio <= hi)
        scale[ok] = ratio[ok]
    return (scale, ok) if return_valid else scale


class ContrastCalibration:
    """Eq. 12 calibration carried across intervals: a pixel's threshold is a property of the pixel, so what the
    intervals with two unclipped frames measured also holds where its frames are clipped (which the paper leaves at
    the nominal contrast, so calibration barely acts on data whose frames clip where the events matter).

    Per pixel p it accumulates A_p = sum |L^D_end - L^D_start| and B_p = sum |nominal change| over the intervals
    calibrated so far (causal: interval j uses intervals 0..j), and the pooled scale g = sum_p A_p / sum_p B_p
    (a global correction of the nominal contrast, 1 before any evidence). Interval j's scale is eq. 12's ratio where
    that interval is calibrated, else the carried (A_p + kappa g) / (B_p + kappa), clipped to calib_scale_range,
    kappa = params.calib_prior (log units of evidence: the shrinkage toward g of pixels with little evidence).
    With params.calibrate False every scale is 1 (the nominal contrast).
    """

    def __init__(self, n: int, params: AKFParams) -> None:
        self.params = params
        self.a, self.b = np.zeros(n), np.zeros(n)

    def carried(self) -> npt.NDArray[np.float64]:
        """The carried scale of every pixel (1 when calibration is off)."""
        if not self.params.calibrate:
            return np.ones_like(self.a)
        total_b = self.b.sum()
        g = self.a.sum() / total_b if total_b > 0 else 1.0
        k = self.params.calib_prior
        lo, hi = self.params.calib_scale_range
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(self.b + k > 0, (self.a + k * g) / (self.b + k), g)
        return np.clip(s, lo, hi)

    def interval(self, d_start: np.ndarray, d_end: np.ndarray, change: np.ndarray, net: np.ndarray,
                 clipped: np.ndarray) -> npt.NDArray[np.float64]:
        """The scale of one interval (see the class docstring); accumulates its calibrated pixels first."""
        scale, ok = calibrate_scale(d_start, d_end, change, net, clipped, self.params, return_valid=True)
        self.a[ok] += np.abs(d_end[ok] - d_start[ok])
        self.b[ok] += np.abs(change[ok])
        return np.where(ok, scale, self.carried())


def interval_start(d_start: np.ndarray, d_end: np.ndarray, change: np.ndarray, scale: np.ndarray,
                   end_clipped: np.ndarray) -> npt.NDArray[np.float64]:
    """Value at the interval start of its curve M(t) (eqs. 10-11).

    With a calibrated scale the forward (10) and backward (11) curves coincide and this is L^D_start. Where the
    calibration was refused the curve is anchored to the later deblurred frame (eq. 13 uses L^A+ between exposures),
    M(t) = L^D_end - scale * (event change from t to the end), except where only the later frame is clipped: there
    it is anchored to the earlier frame, M(t) = L^D_start + scale * (event change since the start).
    """
    return np.where(end_clipped, d_start, d_end - scale * change)
