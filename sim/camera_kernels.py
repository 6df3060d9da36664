"""Numba kernels of the LDR camera: the exposure integral and the per-pixel sensor model.

Random numbers come from a counter-based generator (SplitMix64 streams keyed by (frame key, pixel index)), so
results do not depend on the number of threads or on the order in which pixels are processed.

References (docs/models/references.md): Hoermann 1993 [Hormann1993], Box and Muller 1958 [Box1958], Steele et al.
2014 [Steele2014].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernel_math import GOLDEN, log_row, mix64
from .parallel import in_parallel

_NORMAL_SALT = np.uint64(0x94D049BB133111EB)  # keys the read-noise streams apart from the shot-noise ones
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53
# draw numbers as int64 globals: a literal argument (_uniform(s, 1)) would compile one more specialisation each
_DRAW1, _DRAW2 = np.int64(1), np.int64(2)


@njit(cache=True)
def accumulate_rows(acc: np.ndarray, radiance: np.ndarray, row_weight: np.ndarray) -> bool:
    """acc[r, c] += row_weight[r] * radiance[r, c] for rows with a non-zero weight.

    Returns False when a used radiance value is NaN, infinite or negative (acc is then not to be trusted).
    Serial on purpose: it is memory-bound, runs once per sub-frame, and a parallel launch per sub-frame costs
    more than it saves when the cores are shared.
    """
    height, width = radiance.shape
    good = True
    for r in range(height):
        w = np.float32(row_weight[r])
        if w == 0.0:
            continue
        for c in range(width):
            v = radiance[r, c]
            good &= (v >= 0.0) & (v < np.inf)
            acc[r, c] += w * v
    return good


@njit(cache=True)
def _uniform(stream, i):
    """Uniform in (0, 1): draw i (1, 2, ...) of the SplitMix64 stream that starts at counter `stream`."""
    return (np.float64(mix64(stream + np.uint64(i) * GOLDEN) >> np.uint64(11)) + 0.5) * _TO_UNIT


@njit(cache=True)
def _ptrs_constants(lam):
    """(a, b, vr) of Hoermann's PTRS for mean lam >= 10."""
    b = 0.931 + 2.53 * math.sqrt(lam)
    return -0.059 + 0.02483 * b, b, 0.9277 - 3.6224 / (b - 2.0)


@njit(cache=True, error_model="numpy")
def _poisson(lam, stream, i):
    """Exact Poisson sample from the stream, starting at its draw i (1 for a fresh sample): multiplication method
    below 10, Hoermann's PTRS (as numpy) above, where draws i, i + 1 make a candidate.

    Scalar arguments only (an array argument would cost reference counting on every call).
    """
    if lam < 10.0:
        limit = math.exp(-lam)
        k = 0
        prod = _uniform(stream, i)
        while prod > limit:
            k += 1
            i += 1
            prod *= _uniform(stream, i)
        return float(k)
    a, b, vr = _ptrs_constants(lam)
    log_lam = math.log(lam)
    while True:
        u = _uniform(stream, i) - 0.5
        v = _uniform(stream, i + 1)
        i += 2
        us = 0.5 - abs(u)
        k = math.floor((2.0 * a / us + b) * u + lam + 0.43)
        if us >= 0.07 and v <= vr:
            return float(k)
        if k < 0 or (us < 0.013 and v > us):
            continue
        if math.log(v * _ptrs_inv_alpha(b) / (a / (us * us) + b)) <= -lam + k * log_lam - math.lgamma(k + 1.0):
            return float(k)


@njit(cache=True)
def _ptrs_inv_alpha(b):
    return 1.1239 + 1.1328 / (b - 3.4)


@njit(cache=True, error_model="numpy")
def _poisson_row(lam, streams, out, f, bits):
    """out[c] = exact Poisson(lam[c]) sample of stream streams[c], the same as _poisson(lam[c], streams[c], 1).

    The first PTRS candidate of every pixel is drawn and tested at once (_ptrs_first, vectorised); the pixels
    whose candidate was rejected (about 10 %) continue in the scalar sampler from their second candidate, the few
    that test cannot decide start the scalar sampler afresh. Scratch: f float64 (10, n), bits int64 (3, n).
    """
    _ptrs_first(lam, streams, out, f, bits)
    for c in range(lam.size):
        if out[c] < 0.0:
            out[c] = _poisson(lam[c], streams[c], 3 if out[c] == -2.0 else 1)


@njit(cache=True, error_model="numpy")
def _ptrs_first(lam, streams, res, f, bits):
    """The first PTRS candidate of each pixel (draws 1 and 2 of its stream), tested in branch-free loops that vectorise.

    res[j] = the accepted sample, -2 when the candidate is rejected, -1 when this test cannot decide (mean below
    10, or candidate below 10: Stirling's series for lgamma(k + 1), error below 1e-14, is used from 10 on).
    Scratch: f float64 (10, n), bits int64 (3, n) for n = lam.size.
    """
    n = lam.size
    us_t, v_t, k_t, quick_t = f[0], f[1], f[2], f[3]
    arg, lgs = f[4:7], f[7:10]
    for j in range(n):
        lm = lam[j]
        a, b, vr = _ptrs_constants(lm)
        s = streams[j]
        u = _uniform(s, _DRAW1) - 0.5
        v = _uniform(s, _DRAW2)
        us = 0.5 - abs(u)
        k = math.floor((2.0 * a / us + b) * u + lm + 0.43)
        k_t[j] = k
        us_t[j] = us
        v_t[j] = v
        arg[0, j] = k + 1.0 if k >= 10.0 else 1.0
        arg[1, j] = v * _ptrs_inv_alpha(b) / (a / (us * us) + b)
        arg[2, j] = lm if lm > 1.0 else 1.0
        quick_t[j] = 1.0 if (us >= 0.07) & (v <= vr) else 0.0
    for i in range(3):
        log_row(arg[i], bits[i], lgs[i])
    for j in range(n):
        lm = lam[j]
        k = k_t[j]
        us = us_t[j]
        x = k + 1.0
        ix = 1.0 / (x * x)
        series = (((((691.0 / 360360.0 * ix - 1.0 / 1188.0) * ix + 1.0 / 1680.0) * ix - 1.0 / 1260.0) * ix
                   + 1.0 / 360.0) * ix - 1.0 / 12.0)  # lgamma(x) = (x - 1/2) log x - x + log(2 pi) / 2 - series / x
        lgamma = (x - 0.5) * lgs[0, j] - x + 0.5 * math.log(2.0 * math.pi) - series / x
        big = (lm >= 10.0) & (k >= 10.0)
        squeezed = (us < 0.013) & (v_t[j] > us)  # rejected without the full test
        full_test = lgs[1, j] <= -lm + k * lgs[2, j] - lgamma
        accept = (lm >= 10.0) & ((quick_t[j] != 0.0) | (big & ~squeezed & full_test))
        reject = (lm >= 10.0) & ~accept & ((k < 0.0) | squeezed | big)
        res[j] = k if accept else (-2.0 if reject else -1.0)


def sense(irradiance: np.ndarray, gain: float, dark_e: float, prnu: np.ndarray, dsnu: np.ndarray, use_maps: bool,
          noise: bool, read_noise_e: float, full_well_e: float, key: int | np.uint64, thresholds: np.ndarray,
          bin_start: np.ndarray, image: np.ndarray) -> None:
    """Digital numbers of one frame, written into `image` (uint8 or uint16 (H, W)).

    mean electrons = irradiance * gain * prnu + dark_e + dsnu, with the (H, W) fixed-pattern maps prnu
    (relative gain) and dsnu (offset, e-) used only when use_maps; with noise: Poisson(mean) + Normal(0,
    read_noise_e^2); then clipped to [0, full_well_e], normalised by full_well_e and quantised by the CRF's
    decision thresholds: DN = number of thresholds <= x (see LDRCamera._quantiser), counted from bin_start[b],
    the count below b / n_bins for the bin b of x (bin_start has n_bins + 1 entries). key: 64-bit stream key of
    the frame.

    Blocks of rows run on sim.parallel's threads (sense_rows releases the GIL; a numba parallel loop would cost
    seconds of compilation), each row in short loops over its pixels that LLVM vectorises (see _poisson_row and
    _normal_pairs). Every pixel draws from its own streams, so threads do not change the result.
    """
    args = (irradiance, float(gain), float(dark_e), prnu, dsnu, bool(use_maps), bool(noise), float(read_noise_e),
            float(full_well_e), np.uint64(key), thresholds, bin_start, image)
    in_parallel(lambda r0, r1: sense_rows(r0, r1, *args), irradiance.shape[0], _MIN_ROWS)


_MIN_ROWS = 16  # rows per thread at least: smaller parts cost more in hand-over than they save


@njit(cache=True, nogil=True, error_model="numpy")
def sense_rows(r0, r1, irradiance, gain, dark_e, prnu, dsnu, use_maps, noise, read_noise_e, full_well_e, key,
               thresholds, bin_start, image):
    """Rows r0 .. r1 - 1 of sense."""
    width = irradiance.shape[1]
    normal_key = key ^ _NORMAL_SALT  # a second family of streams for the read noise
    n_pairs = (width + 1) // 2
    lam = np.empty(width)
    e_t = np.empty(width)
    streams = np.empty(width, dtype=np.uint64)
    f = np.empty((10, width))
    bits = np.empty((3, width), dtype=np.int64)
    z = np.zeros(2 * n_pairs)
    for r in range(r0, r1):
        for c in range(width):
            if use_maps:
                e = irradiance[r, c] * gain * prnu[r, c] + dark_e + dsnu[r, c]
            else:
                e = irradiance[r, c] * gain + dark_e
            lam[c] = max(e, 0.0)
            streams[c] = mix64(key ^ (np.uint64(r * width + c) * GOLDEN))
        if noise:
            _poisson_row(lam, streams, e_t, f, bits)
            if read_noise_e > 0.0:
                _normal_pairs(normal_key, np.uint64(r * n_pairs), read_noise_e, z)
        else:
            for c in range(width):
                e_t[c] = lam[c]
        _quantise_row(e_t, z, full_well_e, thresholds, bin_start, image[r])


@njit(cache=True, error_model="numpy")
def _quantise_row(e_t, z, full_well_e, thresholds, bin_start, out):
    """out[c] = DN of e_t[c] + z[c] electrons (see sense)."""
    n_thr = thresholds.size
    n_bins = bin_start.size - 1
    inv_fw = 1.0 / full_well_e
    for c in range(out.size):
        x = min(max(e_t[c] + z[c], 0.0), full_well_e) * inv_fw
        d = bin_start[min(int(x * n_bins), n_bins - 1)]
        while d < n_thr and thresholds[d] <= x:
            d += 1
        out[c] = d


@njit(cache=True, error_model="numpy")
def _normal_pairs(key, first_pair, sigma, z):
    """z[2 j], z[2 j + 1] = two independent Normal(0, sigma^2) draws of pair first_pair + j (Box-Muller).

    Log, sine and cosine are polynomials (relative error below 1e-13) so that the loops vectorise.
    """
    n = z.size // 2
    u1 = np.empty(n)
    lg = np.empty(n)
    bits = np.empty(n, dtype=np.int64)
    for j in range(n):
        s = mix64(key ^ ((first_pair + np.uint64(j)) * GOLDEN))
        u1[j] = _uniform(s, _DRAW1)
        z[2 * j] = _uniform(s, _DRAW2)
    log_row(u1, bits, lg)
    for j in range(n):
        radius = sigma * math.sqrt(-2.0 * lg[j])
        # angle 2 pi u2 = 2 h + pi with h in (-pi/2, pi/2): cos = -cos(2 h), sin = -sin(2 h)
        h = math.pi * (z[2 * j] - 0.5)
        q = h * h
        sn = 1.0 / 121645100408832000.0  # sin(h): Taylor series to h^19 (error below 1e-16 at pi/2)
        sn = sn * q - 1.0 / 355687428096000.0
        sn = sn * q + 1.0 / 1307674368000.0
        sn = sn * q - 1.0 / 6227020800.0
        sn = sn * q + 1.0 / 39916800.0
        sn = sn * q - 1.0 / 362880.0
        sn = sn * q + 1.0 / 5040.0
        sn = sn * q - 1.0 / 120.0
        sn = sn * q + 1.0 / 6.0
        sn = (1.0 - sn * q) * h
        cs = -1.0 / 6402373705728000.0  # cos(h): Taylor series to h^18 (error below 1e-14 at pi/2)
        cs = cs * q + 1.0 / 20922789888000.0
        cs = cs * q - 1.0 / 87178291200.0
        cs = cs * q + 1.0 / 479001600.0
        cs = cs * q - 1.0 / 3628800.0
        cs = cs * q + 1.0 / 40320.0
        cs = cs * q - 1.0 / 720.0
        cs = cs * q + 1.0 / 24.0
        cs = cs * q - 0.5
        cs = cs * q + 1.0
        z[2 * j] = radius * (2.0 * sn * sn - 1.0)
        z[2 * j + 1] = -radius * (2.0 * sn * cs)
