"""Flow vectors on still surroundings are dropped (flow_interpolation.still_where_unmoved): a pixel unchanged between
two frames over which no changing content moves keeps its value at every key frame, while moving content and the
pixels it sweeps keep their motion."""

import numpy as np

from generators.scenes.flow_interpolation import FlowPair, occlusion, still_where_unmoved


def _frames() -> tuple[np.ndarray, np.ndarray]:
    """60x80 log frames: a still horizontal edge (rows >= 45 darker by 0.7) and a bright 6x6 square moving 6 px to
    the right at rows 10-15."""
    log0 = np.zeros((60, 80), np.float32)
    log0[45:] = -0.7
    log1 = log0.copy()
    log0[10:16, 10:16] = 1.0
    log1[10:16, 16:22] = 1.0
    return log0, log1


def _spurious_flows() -> tuple[np.ndarray, np.ndarray]:
    """The square's true motion on its pixels, and a 2 px vector everywhere else (what DIS leaves on still content
    near edges and borders)."""
    f01 = np.full((60, 80, 2), (2.0, 1.0), np.float32)
    f10 = np.full((60, 80, 2), (-2.0, -1.0), np.float32)
    f01[10:16, 10:16] = (6.0, 0.0)
    f10[10:16, 16:22] = (-6.0, 0.0)
    return f01, f10


def test_vectors_are_dropped_only_where_no_changing_content_passes():
    log0, log1 = _frames()
    f01, f10 = _spurious_flows()
    still = still_where_unmoved(f01, log0, log1)
    assert still[40:, :].all() and not f01[40:].any()  # the still edge: 24+ px from the square
    assert not still[10:16, 10:16].any() and (f01[10:16, 10:16] == (6.0, 0.0)).all()  # the square keeps its motion
    assert not still[10:16, 16:22].any()  # where it arrives


def test_pixels_a_thin_bar_crosses_between_the_frames_keep_their_vectors():
    log0, log1 = np.zeros((30, 60), np.float32), np.zeros((30, 60), np.float32)
    log0[5:25, 10:12] = 1.0  # a 2 px bar 12 px to the right between the frames: x 14-19 see it only in between
    log1[5:25, 22:24] = 1.0
    flow = np.zeros((30, 60, 2), np.float32)
    flow[5:25, 10:12] = (12.0, 0.0)
    still = still_where_unmoved(flow, log0, log1)
    assert not still[8:22, 14:20].any()  # unchanged in both frames, but swept
    assert still[8:22, 30:].all() and still[:2].all()  # nothing passes there


def test_a_still_pixel_far_from_change_keeps_its_value_at_every_key():
    log0, log1 = _frames()
    raw = FlowPair(log0, log1, *_spurious_flows(), *_occlusions(*_spurious_flows()), 6.0)
    f01, f10 = _spurious_flows()
    still_where_unmoved(f01, log0, log1)
    still_where_unmoved(f10, log1, log0)
    fixed = FlowPair(log0, log1, f01, f10, *_occlusions(f01, f10), 6.0)
    zero = np.zeros_like(f01)
    still_pair = FlowPair(log0, log1, zero, zero, *_occlusions(zero, zero), 6.0)  # no motion anywhere
    edge = (slice(43, 48), slice(5, 75))  # both sides of the still edge
    keys = range(1, fixed.n_keys)  # (the zero-motion keys differ from the frames by the upsampling's smoothing)
    assert max(np.abs(raw.key(j)[edge] - still_pair.key(j)[edge]).max() for j in keys) > 0.1  # a dip, unfixed
    for j in keys:
        np.testing.assert_array_equal(fixed.key(j)[edge], still_pair.key(j)[edge])
    # the square still moves: at half-way its centre is 3 px to the right of where it started
    mid = fixed.key(fixed.n_keys // 2)
    assert mid[12:14, 15:17].mean() > 0.8 and mid[12:14, 10:12].mean() < 0.5


def _occlusions(f01: np.ndarray, f10: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return occlusion(f01, f10)[0], occlusion(f10, f01)[0]


def test_pixels_without_motion_blended_at_their_centre_give_what_warping_them_gives():
    """_warp_blend blends the samples at the pixel (centre) for the pixels without motion and warps the others; a
    flow too small to move anything (1e-30 px) on the still pixels, and no step limit, make it warp every pixel at
    every key: the same keys."""
    log0, log1 = _frames()
    f01, f10 = _spurious_flows()
    still_where_unmoved(f01, log0, log1)
    still_where_unmoved(f10, log1, log0)
    pair = FlowPair(log0, log1, f01, f10, *_occlusions(f01, f10), 6.0)
    tiny01, tiny10 = (np.where(f == 0, np.float32(1e-30), f) for f in (f01, f10))
    warped = FlowPair(log0, log1, tiny01, tiny10, pair.occlusion0, pair.occlusion1, 6.0)
    pair.step_limit_px = warped.step_limit_px = 0.0  # (every pixel of step 1)
    pair.prepare()
    warped.prepare()
    h, w = log0.shape
    assert 0 < pair._row_start[-1] < h * w / 2 and warped._row_start[-1] == h * w
    for j in range(1, pair.n_keys):
        np.testing.assert_allclose(pair.key(j), warped.key(j), rtol=0, atol=1e-6)
