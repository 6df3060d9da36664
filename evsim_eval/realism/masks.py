"""Pixel classes of a hybrid recording read from its frames: static pixels (quiet and dark ones), whose events are
noise, and the frame intervals in which each pixel changed (motion), which tell passages from noise bursts.

A pixel is static when no frame over the scored windows departs from its temporal median by more than the change
threshold, max(STATIC_SIGMAS x the frames' temporal noise (read noise and quantisation), MIN_CHANGE_DN); quiet
when it is static, unsaturated and its whole 5x5 neighbourhood is static (no moving edge within 2 pixels); dark
when quiet and its median is below DARK_DN (8-bit DN, scaled by 2**(bits - 8) for deeper frames). A pixel moves
in the interval between frames k and k + 1 when its value changes by more than the change threshold. The read
noise is the one the AKF's frame update uses, estimated from the frame-to-frame differences of the flat pixels
(akf.frame_noise.estimate_read_noise: a robust median corrected for the frames' quantisation).

Signal reach (beyond_signal_reach; measure_recording applies it with the real recording's own events). The frames
certify a pixel still only to the change threshold, and the DVS sees less: a change of its contrast threshold, about
20 % of the pixel's value plus its log offset, is a few DN on a dark pixel, below 6 read-noise sigmas. So around a
moving object (its blurred edge, its shadow and the lens's glare, motion between two frames) pixels that the frames
call static fire signal events. Quiet and dark pixels must also lie beyond that reach, which the real events show:
signal is densest next to the moving pixels and falls off with distance, noise does not. For the dark and the
brighter quiet pixels separately, the rings at Chebyshev distance k = QUIET_RADIUS_PX + 1, 2, ... from the nearest
non-static pixel are set against the far field (distance > REACH_MAX_PX): the reach is the last of the consecutive
rings from the first whose event count (ON + OFF) the far field's rate makes improbable (one-sided conditional
binomial test, false alarm REACH_FALSE_ALARM per ring), and the quiet pixels are further away. A ring is dropped only
on a significant excess, so the selection biases the quiet rate by less than the test resolves; a recording too
short to show a reach keeps QUIET_RADIUS_PX. Measured (real ON + OFF rate against the far field's, Hz per pixel):
on the DAVIS346 cradle 1.9 against 0.21 at 3 px on dark pixels and 0.23 against 0.0071 at 20-80 DN, down to the
far rate at 9 px (dark) and 5 px (brighter): reach 7 and 4 px, and half the events the frames' quiet pixels held
were signal; on the road 0.015 against 0.0014 at 3 px on dark pixels (reach 3 px), where both real OFF events the
frames' quiet pixels held lie, while its brighter pixels have too few events to show one (reach 2 px).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from akf.frame_noise import estimate_read_noise

STATIC_SIGMAS = 6.0  # a static pixel stays within this many read-noise sigmas of its median (59 frames: ~1e-6 miss)
MIN_CHANGE_DN = 3.0  # floor of the change threshold (8-bit DN): three quantisation steps
DARK_DN = 20.0  # dark pixels: median below this (8-bit DN)
QUIET_RADIUS_PX = 2  # quiet pixels: every pixel within this Chebyshev distance is static
REACH_MAX_PX = 16  # signal reach: rings up to this distance from a non-static pixel are tested; beyond is the far field
REACH_FALSE_ALARM = 1e-3  # a ring of the same rate as the far field is taken for signal this rarely


@dataclass(frozen=True)
class FrameMasks:
    """Pixel classes from a recording's frames (see the module).

    Attributes
    ----------
    static, quiet, dark : numpy.ndarray
        (H, W) bool pixel classes.
    motion : numpy.ndarray
        (F - 1, H W) bool, pixel changed between frames k and k + 1.
    frame_t_us : numpy.ndarray
        (F,) the frames' mid-exposure times, int64 us.
    median_dn : numpy.ndarray
        (H, W) float32 temporal median of the frames used (DN).
    change_dn : float
        The change threshold (frame DN).
    read_noise_dn : float
        The estimated read noise (frame DN rms).
    frames_used : int
        How many frames (those bracketing the windows) set static, quiet and dark.
    source : str
        What the classes were read from: "frames", or "events" for a recording without frames
        (evsim_eval.realism.event_masks: quiet pixels from the events, no dark pixels, no motion).
    hot : numpy.ndarray or None
        (H, W) bool hot pixels found from the events (source "events"), else None.
    reach_px : tuple of int or None
        (dark, brighter) signal reach (beyond_signal_reach): quiet pixels are further than this from any non-static
        pixel; None before the real events set it.
    """

    static: np.ndarray
    quiet: np.ndarray
    dark: np.ndarray
    motion: np.ndarray
    frame_t_us: np.ndarray
    median_dn: np.ndarray
    change_dn: float
    read_noise_dn: float
    frames_used: int
    source: str = "frames"
    hot: np.ndarray | None = None
    reach_px: tuple[int, int] | None = None


def bracketing_frames(frame_t_us: np.ndarray, windows_us: np.ndarray) -> np.ndarray:
    """Indices of the frames whose mid-exposure times lie in the windows, with the last one before and the first
    one after each window.

    Parameters
    ----------
    frame_t_us : numpy.ndarray
        (F,) mid-exposure times, ascending int64 us.
    windows_us : numpy.ndarray
        (K, 2) windows [start, end), int64 us.

    Returns
    -------
    numpy.ndarray
        Ascending frame indices.
    """
    n = frame_t_us.size
    keep = np.zeros(n, bool)
    for a, b in windows_us:
        k0 = max(int(np.searchsorted(frame_t_us, a, side="right")) - 1, 0)
        k1 = min(int(np.searchsorted(frame_t_us, b, side="left")), n - 1)
        keep[k0:k1 + 1] = True
    return np.flatnonzero(keep)


def frame_masks(frames: np.ndarray, frame_t_us: np.ndarray, windows_us: np.ndarray, bit_depth: int = 8
                ) -> FrameMasks:
    """FrameMasks of integer frames over the frames bracketing the windows; bit_depth scales the 8-bit constants.

    Parameters
    ----------
    frames : numpy.ndarray
        (F, H, W) integer frames (DN).
    frame_t_us : numpy.ndarray
        (F,) their mid-exposure times, int64 us.
    windows_us : numpy.ndarray
        (K, 2) windows, int64 us.
    bit_depth : int, optional
        The frames' bits (default 8).

    Returns
    -------
    FrameMasks
        The pixel classes.
    """
    frames = np.asarray(frames)
    t = np.asarray(frame_t_us, dtype=np.int64)
    f, h, w = frames.shape
    scale = 2.0 ** (bit_depth - 8)
    diffs = np.abs(np.diff(frames.astype(np.float32), axis=0)) if f > 1 else np.zeros((0, h, w), np.float32)
    noise = estimate_read_noise(frames, bit_depth) if f > 1 else None
    read_noise, total = (noise.read_noise_dn, noise.total_dn) if noise else (0.0, 0.0)
    change = max(STATIC_SIGMAS * total, MIN_CHANGE_DN * scale)
    used = bracketing_frames(t, windows_us)
    sel = frames[used].astype(np.float32)
    median = np.median(sel, axis=0) if used.size else np.zeros((h, w), np.float32)
    static = (np.abs(sel - median).max(axis=0) <= change) if used.size > 1 else np.zeros((h, w), bool)
    unsaturated = median < (2 ** bit_depth - 1) - change
    size = 2 * QUIET_RADIUS_PX + 1
    neighbourhood = ndimage.minimum_filter(static.astype(np.uint8), size=size, mode="nearest").astype(bool)
    quiet = neighbourhood & unsaturated
    dark = quiet & (median < DARK_DN * scale)
    motion = (diffs > change).reshape(max(f - 1, 0), h * w)
    return FrameMasks(static, quiet, dark, motion, t, median.astype(np.float32), float(change), read_noise,
                      int(used.size))


def _ring_reach(rings: np.ndarray, counts: np.ndarray, pixels: np.ndarray) -> int:
    """The signal reach (px) of one brightness class: the last of the consecutive rings from QUIET_RADIUS_PX + 1 on
    whose event count is too high for the far field's rate (one-sided conditional binomial test at
    REACH_FALSE_ALARM), or QUIET_RADIUS_PX. rings: (H, W) distance to the nearest non-static pixel, counts: (H, W)
    events, pixels: (H, W) bool, the class."""
    from scipy import stats  # (slow to import: only when a recording with frames is measured)

    far = pixels & (rings > REACH_MAX_PX)
    n_far, px_far = float(counts[far].sum()), int(far.sum())
    reach = QUIET_RADIUS_PX
    if px_far == 0:
        return reach
    for k in range(QUIET_RADIUS_PX + 1, REACH_MAX_PX + 1):
        ring = pixels & (rings == k)
        px, n = int(ring.sum()), float(counts[ring].sum())
        if px == 0:  # no pixel of the class at this distance: no evidence either way
            continue
        if n == 0:
            break
        # equal rates: the ring's share of the ring + far events is binomial with its share of their pixels
        if stats.binom.sf(n - 1, n + n_far, px / (px + px_far)) >= REACH_FALSE_ALARM:
            break
        reach = k
    return reach


def beyond_signal_reach(masks: FrameMasks, counts: np.ndarray) -> FrameMasks:
    """masks with its quiet and dark pixels limited to those beyond the reach of signal, measured from the real
    events around the non-static pixels (see the module), for dark and brighter quiet pixels separately.

    Parameters
    ----------
    masks : FrameMasks
        Pixel classes from the frames (source "frames").
    counts : numpy.ndarray
        (2, H, W) ON and OFF events per pixel of the real recording over the scored windows (or (H, W) their sum).

    Returns
    -------
    FrameMasks
        A copy with quiet and dark narrowed and reach_px (dark, brighter) set.
    """
    c = np.asarray(counts, dtype=np.float64)
    c = c.sum(axis=0) if c.ndim == 3 else c
    if masks.static.all() or not masks.static.any():
        return replace(masks, reach_px=(QUIET_RADIUS_PX, QUIET_RADIUS_PX))
    rings = ndimage.distance_transform_cdt(masks.static, metric="chessboard")
    reach_dark = _ring_reach(rings, c, masks.dark)
    reach_bright = _ring_reach(rings, c, masks.quiet & ~masks.dark)
    dark = masks.dark & (rings > reach_dark)
    quiet = dark | (masks.quiet & ~masks.dark & (rings > reach_bright))
    return replace(masks, quiet=quiet, dark=dark, reach_px=(reach_dark, reach_bright))
