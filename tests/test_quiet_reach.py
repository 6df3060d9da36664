"""The quiet pixels of the realism score lie beyond the reach of signal (evsim_eval.realism.masks.beyond_signal_reach),
against ground truth: a bright square crosses a dark scene through the lens's veiling glare, a halo falling off as
exp(-d / GLOW_PX). Where the halo's change stays below the frames' change threshold (6 read-noise sigmas) but above
the DVS's contrast threshold, pixels are static in the frames and fire events: signal, not noise. The quiet estimate
must not count them, and must recover the shot noise rate the simulation was given; without the halo (a sharp
square) nothing is signal beyond the frames' own margin, and the reach stays there.

Physics of the numbers: background 6 DN, halo 40 DN x exp(-d / 4 px) at distance d from the square. The frames
(read noise 1 DN, change threshold 6 DN) see the halo to d = 4 ln(40 / 6) = 7.6 px; the DVS (threshold 0.2 in
log, no offset to speak of) sees a change of 6 DN x (e**0.2 - 1) = 1.3 DN, to d = 4 ln(40 / 1.3) = 13.7 px. So
about 6 rows on each side of the square's path are static in the frames and fire events as the halo passes.
"""

from __future__ import annotations

import numpy as np
import pytest

import sim
from evsim_eval.realism import measure_recording
from evsim_eval.realism.masks import QUIET_RADIUS_PX, frame_masks
from generators.formats.recording import Recording

H, W = 96, 96
DURATION_US = 1_000_000
FRAME_US = 40_000  # 25 fps frames
READ_NOISE_DN = 1.0
BACKGROUND_DN = 6.0
SQUARE_DN = 220.0
GLOW_DN, GLOW_PX = 40.0, 4.0
ROWS = (42, 54)  # the square's rows
SQUARE = (200_000, 800_000)  # it crosses the sensor in this time (us)
SHOT_HZ = 1.0


def _scene_dn(t_us: int, glow: bool) -> np.ndarray:
    """(H, W) DN at t_us: the dark background, the square (12 x 12 px) crossing ROWS during SQUARE and its halo."""
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    x0 = (t_us - SQUARE[0]) / (SQUARE[1] - SQUARE[0]) * (W + 12) - 12
    dx = np.maximum(np.maximum(x0 - xx, xx - (x0 + 11)), 0)
    dy = np.maximum(np.maximum(ROWS[0] - yy, yy - (ROWS[1] - 1)), 0)
    d = np.hypot(dx, dy)  # distance from the square (0 inside)
    dn = np.full((H, W), BACKGROUND_DN) + (GLOW_DN * np.exp(-d / GLOW_PX) if glow else 0.0)
    return np.where(d == 0, SQUARE_DN, dn)


def _recording(glow: bool, seed: int = 3) -> Recording:
    """Events (shot noise only, SHOT_HZ per pixel) and 8-bit frames with read noise of the scene."""
    times = np.arange(0, DURATION_US + 1, 2000, dtype=np.int64)
    radiance = np.stack([_scene_dn(t, glow) / 255.0 for t in times]).astype(np.float32)
    params = sim.DVSParams.preset("davis346", leak_hz=0.0, hot_pixel_fraction=0.0, shot_noise_hz=SHOT_HZ,
                                  dark_shot_noise_hz=SHOT_HZ)
    events = sim.emulate(radiance, times, params, seed=seed)
    rng = np.random.default_rng(seed)
    mid = np.arange(0, DURATION_US + 1, FRAME_US, dtype=np.int64)
    aps = np.stack([np.clip(np.round(_scene_dn(t, glow) + rng.normal(0, READ_NOISE_DN, (H, W))), 0, 255)
                    for t in mid])
    return Recording(events, H, W, frames=aps.astype(np.uint8), frame_t_start_us=mid, frame_t_mid_us=mid,
                     frame_t_end_us=mid)


def _rate_hz(counts: np.ndarray, pixels: np.ndarray) -> tuple[float, int]:
    n = int(counts[:, pixels].sum())
    return n / int(pixels.sum()) / (DURATION_US / 1e6), n


@pytest.fixture(scope="module")
def glow():
    rec = _recording(glow=True)
    return rec, measure_recording(rec, (0.0, 1.0))


def test_the_halo_fires_static_pixels_beyond_the_frames_margin(glow):
    rec, stats = glow
    m = frame_masks(rec.frames, rec.frame_t_mid_us, stats.windows_us)  # the frames' classes alone
    rate, n = _rate_hz(stats.counts, m.quiet)
    assert rate > SHOT_HZ + 6 / np.sqrt(n)  # the frames' quiet pixels hold signal: the halo's events


def test_quiet_pixels_lie_beyond_the_halo_and_give_the_shot_noise_rate(glow):
    rec, stats = glow
    m = stats.masks
    reach_dark, _ = m.reach_px
    assert reach_dark >= 5  # the halo is seen by the DVS about 6 px beyond what the frames see
    yy = np.mgrid[0:H, 0:W][0]
    from_path = np.maximum(np.maximum(ROWS[0] - yy, yy - (ROWS[1] - 1)), 0)  # rows from the square's path
    # to 12 px the halo's peak change, ln((6 + 40 exp(-3)) / 6) = 0.29, fires every pixel (threshold 0.2, spread
    # 0.03): none of them is quiet (at 13 px, 0.23, only some fire: the test of the rings need not see them)
    assert not np.any(m.quiet & (from_path <= 12))
    rate, n = _rate_hz(stats.counts, m.quiet)
    assert rate == pytest.approx(SHOT_HZ, abs=4 * SHOT_HZ / np.sqrt(n))  # the noise, within 4 Poisson sd
    assert stats.quiet_hz[0] + stats.quiet_hz[1] == pytest.approx(rate)
    assert np.array_equal(m.dark, m.quiet)  # every quiet pixel is dark here (6 DN)


def test_a_sharp_square_has_no_reach_beyond_the_frames_margin():
    stats = measure_recording(_recording(glow=False), (0.0, 1.0))
    assert stats.masks.reach_px == (QUIET_RADIUS_PX, QUIET_RADIUS_PX)
    rate, n = _rate_hz(stats.counts, stats.masks.quiet)
    assert rate == pytest.approx(SHOT_HZ, abs=4 * SHOT_HZ / np.sqrt(n))
