"""The frames' temporal noise from the frames themselves: the read noise in DN (estimate_read_noise), its variance
in the CRF's x units (frame_noise_variance) and the AKF frame update's variance (frame_log_variance).

A static pixel's value in two frames differs by the noise alone, d = round(mu + n_1) - round(mu + n_2) with
n_i ~ N(0, sigma^2) (sigma: the read noise in DN, before quantisation). Each pair of consecutive frames is first
aligned by the integer shift that makes it most alike (a panning camera), and only the flattest quarter of its
unclipped pixels are used, ranked by the slope of their 3 x 3 box mean, from which the pixel's own value cancels
(a moving edge changes a flat pixel least; the ranking does not select the noise). Pixels that still moved add a
heavy tail, so the scale is read from the median of |d| (Hampel 1974 [Hampel1974]), not from its variance. At the read
noise of 8-bit frames (about 1 DN) the median of the integers |d| is 0, 1 or 2, so the median is taken of the grouped
distribution (the counts of |d| = k spread over [k - 1/2, k + 1/2), |d| = 0 over [0, 1/2)) and inverted through the
same statistic of the quantised model: the distribution of d averaged over a uniform phase of mu (the pixels'
means spread over many levels; Widrow and Kollar 2008 [Widrow2008]). The continuous MAD / 0.6745 / sqrt(2) of a
quantised |d| gives 1.05 DN for every sigma from about 0.9 to 1.6 DN.

Used by `evsim calibrate` (the sensor file's [input] read_noise_dn, evsim_eval.realism's static threshold) and by
the AKF's frame update (AKFParams.read_noise_dn; None: estimated; `evsim evaluate` notes which it used).

References (docs/models/references.md): Hampel 1974 [Hampel1974], the median of abs(d); Widrow and Kollar
2008 [Widrow2008], quantisation noise; EMVA 1288 [EMVA1288] (temporal noise from the difference of two frames).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from scipy import ndimage
from scipy.optimize import brentq
from scipy.special import ndtr

from sim.errors import EvsimInputError

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

__all__ = ["FrameNoise", "estimate_read_noise", "frame_noise_variance", "frame_log_variance", "frame_read_noise",
           "MAX_PAIRS"]

FLAT_FRACTION = 0.25  # the flattest quarter of the pixels: a moving scene changes them least
MAX_SHIFT_PX = 6  # the alignment search: a scene moving up to 6 px between frames (180 px/s at 30 fps)
STILL_RATIO = 0.9  # a shift aligns a pair only if it lowers the median |d| below this fraction of no shift's
MAX_PAIRS = 16  # frame pairs used at most (evenly spaced): enough pixels for a 1 % median, bounded cost
COARSE_STEP = 4  # the alignment search looks at every 4th row and column
_PHASES = 32  # phase samples of the quantised model
_CONTINUOUS_DN = 20.0  # above this read noise quantisation is negligible: the continuous half-normal median


@dataclass(frozen=True)
class FrameNoise:
    """A frame noise estimate.

    Attributes
    ----------
    read_noise_dn : float
        The temporal noise of a frame pixel before quantisation (DN rms of the frames' bit depth).
    bit_depth : int
        The frames' bits.
    pixels : int
        How many pixel pairs it was read from.
    source : str
        How it was obtained (e.g. "estimated from 16 frame pairs (321331 flat pixel pairs)").
    """

    read_noise_dn: float
    bit_depth: int
    pixels: int
    source: str

    @property
    def total_dn(self) -> float:
        """The temporal noise of a frame value, quantisation included: sqrt(read_noise_dn^2 + 1/12) (DN rms)."""
        return math.sqrt(self.read_noise_dn**2 + 1.0 / 12.0)


def estimate_read_noise(frames: npt.ArrayLike, bit_depth: int = 8, *, flat_fraction: float = FLAT_FRACTION,
                        max_shift: int = MAX_SHIFT_PX, max_pairs: int = MAX_PAIRS) -> FrameNoise:
    """The read noise (DN rms) of (F, H, W) integer frames from the differences of consecutive frames (see the
    module): each pair aligned by the integer shift (up to max_shift pixels each way, and a quarter of the
    frame) that makes it most alike, over the flat_fraction flattest of its pixels where neither value is clipped
    (0 or 2^bit_depth - 1). At most max_pairs evenly spaced pairs are used. EvsimInputError with fewer than 2
    frames or no usable pixel.

    Parameters
    ----------
    frames : array_like
        (F, H, W) integer frames (DN), F >= 2, at least 3 x 3 pixels.
    bit_depth : int, optional
        The frames' bits (default 8).
    flat_fraction : float, optional
        The fraction of each pair's unclipped pixels used, the flattest (default FLAT_FRACTION, 0.25).
    max_shift : int, optional
        Largest alignment shift, pixels each way (default MAX_SHIFT_PX, 6; at most a quarter of the frame).
    max_pairs : int, optional
        Frame pairs used at most, evenly spaced (default MAX_PAIRS, 16).

    Returns
    -------
    FrameNoise
        The read noise (DN rms), the bit depth, the pixel pairs used and how it was obtained.
    """
    frames = np.asarray(frames)
    if frames.ndim != 3 or frames.shape[0] < 2 or min(frames.shape[1:]) < 3:
        raise EvsimInputError(f"the read noise needs at least 2 frames (F, H, W) of at least 3 x 3 pixels, got "
                              f"shape {frames.shape}")
    max_shift = min(int(max_shift), (min(frames.shape[1:]) - 3) // 4)  # small frames: small shifts
    m = max_shift + 1
    full = (1 << int(bit_depth)) - 1
    n = frames.shape[0]
    pairs = np.unique(np.linspace(0, n - 2, min(max_pairs, n - 1)).round().astype(np.int64))
    counts = np.zeros(1, np.int64)
    shifts = [(dy, dx) for dy in range(-max_shift, max_shift + 1) for dx in range(-max_shift, max_shift + 1)]
    shift_array = np.array(shifts, np.int64).reshape(-1, 2)
    still = len(shifts) // 2  # (0, 0)
    for k in pairs:
        pair = _Pair(frames[k], frames[k + 1], full, m, flat_fraction)
        medians = pair.coarse(shift_array)
        best = int(np.argmin(medians))
        if medians[best] > STILL_RATIO * medians[still]:  # no shift clearly better: the scene is still
            best = still
        d = pair.diffs(*shifts[best])
        c = np.bincount(d)
        counts = np.pad(counts, (0, max(c.size - counts.size, 0)))
        counts[:c.size] += c
    used = int(counts.sum())
    if used == 0:
        raise EvsimInputError("no unclipped pixel pair to estimate the frames' read noise from")
    return FrameNoise(_invert(_grouped_median(counts / used)), int(bit_depth), used,
                      f"estimated from {pairs.size} frame pairs ({used} flat pixel pairs)")


def frame_noise_variance(read_noise_dn: float, crf: CRF, bit_depth: int = 8) -> float:
    """The variance (x^2) of a frame pixel at the response of largest f^w, what eq. 6's sigma_im2 stands for (Rbar =
    sigma_im2 / f^w), from its temporal noise in DN, quantisation included:
    (read_noise_dn^2 + 1/12) / (2^bit_depth - 1)^2 / CRF'(x*)^2 with x* = CRF^-1(y*), y* the response of largest
    weight.

    Parameters
    ----------
    read_noise_dn : float
        The frames' read noise before quantisation (DN rms).
    crf : CRF
        The frames' response curve.
    bit_depth : int, optional
        The frames' bits (default 8).

    Returns
    -------
    float
        The variance (x units squared).
    """
    full = float((1 << int(bit_depth)) - 1)
    y = (np.arange(1, 1024) / 1024.0)
    y_star = float(y[int(np.argmax(crf.weight(y)))])
    slope = float(crf.derivative(np.asarray([crf.inverse(y_star)], np.float64))[0])
    return (read_noise_dn**2 + 1.0 / 12.0) / full**2 / slope**2


def frame_read_noise(frames: npt.ArrayLike, bit_depth: int = 8) -> float:
    """estimate_read_noise's read noise (DN), or 0 (quantisation only) where the frames cannot tell it: one frame,
    frames smaller than 3 x 3 pixels, every pixel clipped (where no frame update happens anyway).

    Parameters
    ----------
    frames : array_like
        (F, H, W) integer frames (DN).
    bit_depth : int, optional
        The frames' bits (default 8).

    Returns
    -------
    float
        The read noise (DN rms), >= 0.
    """
    try:
        return estimate_read_noise(frames, bit_depth).read_noise_dn
    except EvsimInputError:
        return 0.0


def frame_log_variance(y: npt.ArrayLike, crf: CRF, read_noise_dn: float, bit_depth: int = 8, gain: float = 1.0,
                       i0: float = 1e-3) -> np.ndarray:
    """The variance (log^2) of L = log(I + i0), I = gain CRF^-1(y), of a frame pixel of normalised response y whose
    raw value carries read_noise_dn of noise and the quantisation of bit_depth bits: the response variance
    (read_noise_dn^2 + 1/12) / (2^bit_depth - 1)^2 through the CRF's slope, gain^2 var_y / (CRF'(x) (I + i0))^2
    (first order; inf where the CRF is flat: a clipped response). The frame update's variance.

    Parameters
    ----------
    y : array_like
        Normalised responses in [0, 1].
    crf : CRF
        The frames' response curve.
    read_noise_dn : float
        The read noise before quantisation (DN rms).
    bit_depth : int, optional
        The frames' bits (default 8).
    gain : float, optional
        The frame's exposure gain T_0 / T_k (default 1).
    i0 : float, optional
        The log offset (x units; default 1e-3).

    Returns
    -------
    numpy.ndarray
        The variance (log units squared) of y's shape; inf where the CRF is flat.
    """
    full = float((1 << int(bit_depth)) - 1)
    var_y = (read_noise_dn**2 + 1.0 / 12.0) / full**2
    x = np.asarray(crf.inverse(np.asarray(y, np.float64)), np.float64)
    slope = np.asarray(crf.derivative(x), np.float64)
    with np.errstate(divide="ignore"):
        return np.where(slope > 0, gain**2 * var_y / (slope * (gain * x + i0)) ** 2, np.inf)


class _Pair:
    """Two consecutive frames (int64) with the local slopes of each."""

    def __init__(self, a: np.ndarray, b: np.ndarray, full: int, margin: int, flat_fraction: float):
        self.a, self.b, self.full, self.margin, self.flat_fraction = a.astype(np.int64), b.astype(np.int64), full, \
            margin, flat_fraction
        self.slope_a, self.slope_b = _local_slope(self.a), _local_slope(self.b)
        grid = (slice(margin, -margin, COARSE_STEP), slice(margin, -margin, COARSE_STEP))
        a_grid, slope_grid = self.a[grid], self.slope_a[grid]
        ok = (a_grid > 0) & (a_grid < full)
        self._coarse = ok & (slope_grid <= np.quantile(slope_grid[ok], flat_fraction)) if ok.any() else ok

    def _at(self, dy: int, dx: int) -> tuple[slice, slice]:
        """The slices of b that sit under a's inner region (margin from the border) when b is shifted by (dy, dx)."""
        m, (h, w) = self.margin, self.b.shape
        return slice(m - dy, h - m - dy), slice(m - dx, w - m - dx)

    def coarse(self, shifts: np.ndarray) -> np.ndarray:
        """For each (dy, dx) row of shifts, the grouped median of |a - b shifted by (dy, dx)| over a's flattest
        unclipped pixels on a coarse grid (the alignment search's criterion; inf where none)."""
        return _coarse_medians(self.a, self.b, self._coarse, self.margin, COARSE_STEP, shifts, self.full)

    def diffs(self, dy: int, dx: int) -> np.ndarray:
        """|a - b shifted by (dy, dx)| over the flat_fraction flattest of the unclipped pixels at least margin from
        the border."""
        m = self.margin
        inner, at = (slice(m, -m), slice(m, -m)), self._at(dy, dx)
        a, b = self.a[inner], self.b[at]
        slope = np.maximum(self.slope_a[inner], self.slope_b[at])
        ok = (a > 0) & (a < self.full) & (b > 0) & (b < self.full)
        if not ok.any():
            return np.zeros(0, np.int64)
        keep = ok & (slope <= np.quantile(slope[ok], self.flat_fraction))
        return np.abs(a - b)[keep]


def _local_slope(frame: np.ndarray) -> np.ndarray:
    """(H, W) largest central difference of the 3 x 3 box mean across each pixel, horizontal or vertical (edges
    replicated): the pixel's own value cancels from it, so selecting pixels by it does not select their noise."""
    m = np.pad(ndimage.uniform_filter(frame.astype(np.float64), 3, mode="nearest"), 1, mode="edge")
    return np.maximum(np.abs(m[1:-1, 2:] - m[1:-1, :-2]), np.abs(m[2:, 1:-1] - m[:-2, 1:-1]))


@njit(cache=True)
def _coarse_medians(a: np.ndarray, b: np.ndarray, mask: np.ndarray, margin: int, step: int, shifts: np.ndarray,
                    full: int) -> np.ndarray:
    """_grouped_median of |a[y, x] - b[y - dy, x - dx]| over the grid points (y, x) = (margin + i step,
    margin + j step) where mask[i, j], for each (dy, dx) of shifts."""
    out = np.empty(shifts.shape[0])
    hist = np.empty(full + 1, np.int64)
    for s in range(shifts.shape[0]):
        dy, dx = shifts[s, 0], shifts[s, 1]
        hist[:] = 0
        n = top = 0
        for i in range(mask.shape[0]):
            y = margin + i * step
            for j in range(mask.shape[1]):
                if mask[i, j]:
                    x = margin + j * step
                    d = abs(a[y, x] - b[y - dy, x - dx])
                    hist[d] += 1
                    n, top = n + 1, max(top, d)
        out[s] = _grouped_median(hist[:top + 1] / n) if n else np.inf  # (as np.bincount(d) / d.size)
    return out


@njit(cache=True)
def _grouped_median(p: np.ndarray) -> float:
    """The median of |d| with probabilities p[k] of |d| = k spread uniformly over [k - 1/2, k + 1/2) ([0, 1/2) for
    k = 0)."""
    cum = np.cumsum(p)
    k = np.searchsorted(cum, 0.5)
    below = cum[k - 1] if k else 0.0
    lo, width = (0.0, 0.5) if k == 0 else (k - 0.5, 1.0)
    return lo + (0.5 - below) / p[k] * width


def _abs_diff_pmf(sigma: float) -> np.ndarray:
    """P(|d| = k), k = 0, 1, ..., of d = round(mu + n_1) - round(mu + n_2), n_i ~ N(0, sigma^2), mu of uniform
    phase (the module's model)."""
    j = np.arange(-int(math.ceil(6 * sigma)) - 2, int(math.ceil(6 * sigma)) + 3)
    phase = (np.arange(_PHASES) + 0.5) / _PHASES
    level = (j[None, :] - phase[:, None]) / sigma
    p = ndtr(level + 0.5 / sigma) - ndtr(level - 0.5 / sigma)  # (phase, value) P(round(mu + n) = j)
    spectrum = np.fft.rfft(p, 2 * j.size, axis=1)
    corr = np.fft.irfft(spectrum * spectrum.conj(), 2 * j.size, axis=1).mean(axis=0)  # P(d = k), k >= 0 first
    pmf = np.clip(corr[:j.size], 0.0, None)
    pmf[1:] *= 2.0  # |d| = k for k > 0 is d = k or d = -k
    return pmf / pmf.sum()


def _model_median(sigma: float) -> float:
    """The grouped median of |d| of the quantised model at read noise sigma (DN)."""
    if sigma >= _CONTINUOUS_DN:
        return 0.6744897501960817 * math.sqrt(2.0 * sigma**2 + 1.0 / 6.0)
    return _grouped_median(_abs_diff_pmf(sigma))


def _invert(median: float) -> float:
    """The read noise whose model median is `median`; 0 below the median of noise-free frames (1/4 DN)."""
    lo, hi = 1e-3, 1.0
    if median <= _model_median(lo):
        return 0.0
    while _model_median(hi) < median:
        hi *= 2.0
    return float(brentq(lambda s: _model_median(s) - median, lo, hi, xtol=1e-6))
