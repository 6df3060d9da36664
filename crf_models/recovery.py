"""CRF recovery from an exposure stack (Debevec and Malik 1997 [Debevec1997]), on grey levels.

Solves for g(z) = ln(scaled irradiance x exposure) at every level z by weighted least squares on sampled pixels
with a second-difference smoothness penalty and g(mid) = 0, then tabulates the response y = z / (levels - 1)
against x = exp(g(z) - g(levels - 1)) (so x = 1 is the irradiance x exposure that just saturates).

References (docs/models/references.md): Debevec and Malik 1997 [Debevec1997].
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .base import CRFError, as_float_array
from .tabulated import TabulatedCRF

if TYPE_CHECKING:
    from collections.abc import Iterable

    import numpy.typing as npt


def recover_debevec(
    images: Iterable[npt.ArrayLike],
    exposure_times: npt.ArrayLike,
    *,
    smoothness: float = 100.0,
    n_samples: int = 1000,
    levels: int = 256,
    channel: int | None = None,
) -> TabulatedCRF:
    """Recover a tabulated CRF from images of a static scene taken with different exposure times (Debevec and
    Malik 1997 [Debevec1997]).

    Parameters
    ----------
    images : iterable of array_like
        P >= 2 integer arrays (H, W) or (H, W, C) of one shape, with values in [0, levels).
    exposure_times : array_like
        P positive exposure times (any unit, only ratios matter).
    smoothness : float, optional
        Debevec's lambda (weight of the second-difference penalty, in units of the data weights; default 100).
    n_samples : int, optional
        Pixels used, taken deterministically at evenly spaced grey-level quantiles of the middle exposure
        (default 1000).
    levels : int, optional
        Number of grey levels, >= 2 (default 256).
    channel : int, optional
        For colour images, the channel to use; None (default) averages the channels (fine when all channels share
        one curve, as in a digital camera's JPEGs; film scans have per-channel curves: pick one channel).

    Returns
    -------
    TabulatedCRF
        The response y = z / (levels - 1) tabulated on x = exp(g(z) - g(levels - 1)), g made non-decreasing
        (x = 1: the irradiance times exposure that just saturates).
    """
    times = as_float_array(exposure_times, "exposure_times").ravel()
    stack = [np.asarray(im) for im in images]
    if len(stack) < 2 or len(stack) != times.size:
        raise CRFError(f"need >= 2 images and one exposure time each, got {len(stack)} and {times.size}")
    if np.any(times <= 0):
        raise CRFError("exposure times must be > 0")
    if levels < 2:
        raise CRFError(f"levels must be >= 2, got {levels}")
    grey, shape = [], stack[0].shape[:2]
    for k, im in enumerate(stack):
        if not np.issubdtype(im.dtype, np.integer) or im.ndim not in (2, 3):
            raise CRFError(f"image {k} must be an integer (H, W) or (H, W, C) array, got {im.dtype} {im.shape}")
        if im.ndim == 3 and channel is not None and not 0 <= channel < im.shape[2]:
            raise CRFError(f"channel {channel} out of range for image {k} with {im.shape[2]} channels")
        if im.ndim == 3:
            g = np.rint(im.mean(axis=2)) if channel is None else im[..., channel]
        else:
            g = im
        g = g.astype(np.int64)
        if g.shape != shape or g.min() < 0 or g.max() >= levels:
            raise CRFError(f"image {k}: all images must share one shape and hold values in [0, {levels})")
        grey.append(g.ravel())
    Z = np.stack(grey)  # (P, N)
    order = np.argsort(np.argsort(times))
    middle = Z[int(np.flatnonzero(order == len(stack) // 2)[0])]
    idx = np.argsort(middle, kind="stable")[np.linspace(0, middle.size - 1, min(n_samples, middle.size)).astype(int)]
    g = _solve(Z[:, idx], np.log(times), smoothness, levels)
    # A response cannot decrease, but the poorly constrained ends of a solve may wobble: flatten wobbles
    # outwards from the well-determined middle, then make g rise by at least 1e-6 per level.
    mid = levels // 2
    g = np.concatenate([np.minimum.accumulate(g[:mid][::-1])[::-1], np.maximum.accumulate(g[mid:])])
    g = np.minimum(g, np.concatenate([np.full(mid, g[mid]), g[mid:]]))
    step = 1e-6 * np.arange(levels)
    g = np.maximum.accumulate(g - step) + step
    x = np.exp(g - g[-1])
    return TabulatedCRF(np.linspace(0.0, 1.0, levels), x=x, source=f"Debevec recovery of {len(stack)} exposures")


def _solve(Z: np.ndarray, log_t: np.ndarray, smoothness: float, levels: int) -> np.ndarray:
    """Debevec's least-squares system; Z (P, N) sample levels. Returns g (levels,)."""
    P, N = Z.shape
    zmid = (levels - 1) / 2.0
    # Debevec's hat weight, plus a tiny floor so samples clipped in every exposure keep the system regular.
    w = lambda z: np.minimum(z, levels - 1 - z) + 1e-3  # noqa: E731
    rows, cols, vals, rhs = [], [], [], []
    r = np.arange(P * N)
    zz = Z.ravel()
    ww = w(zz)
    rows += [r, r]
    cols += [zz, levels + np.tile(np.arange(N), P)]
    vals += [ww, -ww]
    rhs.append(ww * np.repeat(log_t, N))
    n = P * N
    rows.append(np.array([n]))  # g(mid) = 0 fixes the scale
    cols.append(np.array([int(zmid)]))
    vals.append(np.array([1.0]))
    rhs.append(np.zeros(1))
    n += 1
    k = np.arange(1, levels - 1)
    s = np.sqrt(smoothness) * w(k)
    for off, c in ((-1, 1.0), (0, -2.0), (1, 1.0)):
        rows.append(n + k - 1)
        cols.append(k + off)
        vals.append(c * s)
    rhs.append(np.zeros(k.size))
    import scipy.sparse  # here: scipy.sparse costs a quarter of a second to import, and few callers need it
    import scipy.sparse.linalg

    A = scipy.sparse.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n + k.size, levels + N)
    )
    b = np.concatenate(rhs)
    sol = scipy.sparse.linalg.spsolve((A.T @ A).tocsc(), A.T @ b)
    return sol[:levels]
