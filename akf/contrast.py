"""The DVS contrast threshold estimated from the data, for recordings that carry none.

Between the mid-exposures of two consecutive frames a pixel whose true log intensity changed by dL fires about
dL / c net events (ON minus OFF), whatever its quantisation phase (uniform on [0, c)): E[net | dL] = dL / c. So the
slope of net on dL over many pixels is 1 / c without the bias of regressing dL on net (the phase noise is in net).
dL is measured as the change of log(CRF^-1(response) * T_0 / T_k + I0) between the two frames, on pixels with both
responses inside [margin, 1 - margin] (unclipped) and |dL| >= min_change (frame noise in the regressor would bias
the slope toward 0). ON and OFF are estimated separately (pixels with dL > 0 give c_on, dL < 0 c_off). Robust: the
slope is refitted on the pixels whose residual lies within 3 scaled MADs, twice.

References (full citations also in docs/models/references.md):

- Brandli C, Muller L, Delbruck T (2014). Real-time, high-speed video decompression using a frame- and
  event-based DAVIS sensor. IEEE International Symposium on Circuits and Systems (ISCAS), 686-689.
"""

from __future__ import annotations

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
    """c_on, c_off: estimated thresholds (log units, OFF as a magnitude); n_on, n_off: pixel-intervals used."""

    c_on: float
    c_off: float
    n_on: int
    n_off: int

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


def estimate_contrast(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                      frame_t_end_us: npt.ArrayLike, crf: CRF | str, *, bit_depth: int = 8, margin: float = 0.05,
                      min_change: float = 0.1, min_pixels: int = 50, i0: float = _I0) -> ContrastEstimate:
    """Estimate (c_on, c_off) from events against the log change between consecutive unclipped frames (see the
    module docstring). Inputs as akf.reconstruct. Raises EvsimInputError when fewer than min_pixels usable pixel
    intervals exist for a polarity (static scene, clipped frames or no events)."""
    if not (0 <= margin < 0.5 and min_change > 0 and min_pixels >= 1):
        raise InvalidParameterError("need 0 <= margin < 0.5, min_change > 0 and min_pixels >= 1")
    times = np.asarray(frame_t_start_us)[:1]
    inp = validate_inputs(events, frames, frame_t_start_us, frame_t_end_us, times, 0.2, bit_depth)
    crf = as_crf(crf)
    nf, (h, w) = inp.frames.shape[0], inp.shape
    if nf < 2:
        raise EvsimInputError("contrast estimation needs at least 2 frames")
    dls, nets = [], []
    prev_y = inp.response(0).ravel()
    prev_l = np.log(inp.exposure_gain(0) * np.asarray(crf.inverse(prev_y), np.float64) + i0)
    for k in range(1, nf):
        y = inp.response(k).ravel()
        log = np.log(inp.exposure_gain(k) * np.asarray(crf.inverse(y), np.float64) + i0)
        ev = slice_time(inp.events, int(np.floor(inp.tau[k - 1])), int(np.floor(inp.tau[k])))
        net = np.bincount(ev["y"].astype(np.int64) * w + ev["x"], weights=ev["p"].astype(np.float64),
                          minlength=h * w)
        dl = log - prev_l
        ok = ((prev_y >= margin) & (prev_y <= 1 - margin) & (y >= margin) & (y <= 1 - margin)
              & (np.abs(dl) >= min_change))
        dls.append(dl[ok])
        nets.append(net[ok])
        prev_y, prev_l = y, log
    dl, net = np.concatenate(dls), np.concatenate(nets)
    out = []
    for sign, name in ((1, "ON"), (-1, "OFF")):
        sel = sign * dl > 0
        if sel.sum() < min_pixels:
            raise EvsimInputError(f"contrast estimation: only {int(sel.sum())} unclipped pixel intervals with a "
                                  f"{name} change >= {min_change} (need {min_pixels}): give the contrast instead")
        slope = _slope(sign * dl[sel], sign * net[sel])
        if not slope > 0:
            raise EvsimInputError(f"contrast estimation: the {name} events do not follow the frames' log change")
        out.append((1.0 / slope, int(sel.sum())))
    return ContrastEstimate(out[0][0], out[1][0], out[0][1], out[1][1])
