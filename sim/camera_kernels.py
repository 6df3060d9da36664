"""Numba kernels of the LDR camera: the exposure integral and the per-pixel sensor model.

Random numbers come from a counter-based generator (SplitMix64 streams keyed by (frame key, pixel index)), so
results do not depend on the number of threads or on the order in which pixels are processed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53


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


@njit(cache=True, inline="always")
def _mix(z):
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@njit(cache=True, inline="always")
def _uniform(state):
    """Next uniform in (0, 1) of the SplitMix64 stream whose counter is state[0]."""
    state[0] += _GOLDEN
    return (np.float64(_mix(state[0]) >> np.uint64(11)) + 0.5) * _TO_UNIT


@njit(cache=True)
def _poisson(lam, state):
    """Exact Poisson sample: multiplication method below 10, Hoermann's PTRS (as numpy) above."""
    if lam < 10.0:
        limit = math.exp(-lam)
        k = 0
        prod = _uniform(state)
        while prod > limit:
            k += 1
            prod *= _uniform(state)
        return float(k)
    slam = math.sqrt(lam)
    b = 0.931 + 2.53 * slam
    a = -0.059 + 0.02483 * b
    vr = 0.9277 - 3.6224 / (b - 2.0)
    while True:
        u = _uniform(state) - 0.5
        v = _uniform(state)
        us = 0.5 - abs(u)
        k = math.floor((2.0 * a / us + b) * u + lam + 0.43)
        if us >= 0.07 and v <= vr:
            return float(k)
        if k < 0 or (us < 0.013 and v > us):
            continue
        invalpha = 1.1239 + 1.1328 / (b - 3.4)
        if math.log(v * invalpha / (a / (us * us) + b)) <= -lam + k * math.log(lam) - math.lgamma(k + 1.0):
            return float(k)


@njit(cache=True, parallel=True)
def sense(irradiance, gain, dark_e, prnu, dsnu, use_maps, noise, read_noise_e, full_well_e, key, thresholds, bin_start, image):
    """Digital numbers of one frame, written into `image` (uint8 or uint16 (H, W)).

    mean electrons = irradiance * gain * prnu + dark_e + dsnu, with the (H, W) fixed-pattern maps prnu
    (relative gain) and dsnu (offset, e-) used only when use_maps; with noise: Poisson(mean) + Normal(0, read_noise_e^2); then clipped to
    [0, full_well_e], normalised by full_well_e and quantised by the CRF's decision thresholds: DN = number of
    thresholds <= x (see LDRCamera._quantiser), counted from bin_start[b], the count below b / n_bins for the
    bin b of x (bin_start has n_bins + 1 entries). key: 64-bit stream key of the frame.
    """
    height, width = irradiance.shape
    n_thr = thresholds.size
    n_bins = bin_start.size - 1
    inv_fw = 1.0 / full_well_e
    normal_key = key ^ _M2  # a second family of streams for the read noise
    for r in prange(height):
        state = np.empty(1, dtype=np.uint64)
        z_next = 0.0
        for c in range(width):
            if use_maps:
                e = irradiance[r, c] * gain * prnu[r, c] + dark_e + dsnu[r, c]
            else:
                e = irradiance[r, c] * gain + dark_e
            if noise:
                state[0] = _mix(key ^ (np.uint64(r * width + c) * _GOLDEN))
                e = _poisson(max(e, 0.0), state)
                if read_noise_e > 0.0:
                    if c % 2 == 0:  # Box-Muller gives two independent normals: one for c, one for c + 1
                        state[0] = _mix(normal_key ^ (np.uint64((r * width + c) // 2) * _GOLDEN))
                        radius = read_noise_e * math.sqrt(-2.0 * math.log(_uniform(state)))
                        angle = 2.0 * math.pi * _uniform(state)
                        e += radius * math.cos(angle)
                        z_next = radius * math.sin(angle)
                    else:
                        e += z_next
            x = min(max(e, 0.0), full_well_e) * inv_fw
            d = bin_start[min(int(x * n_bins), n_bins - 1)]
            while d < n_thr and thresholds[d] <= x:
                d += 1
            image[r, c] = d
