"""Per-pixel key steps (flow_interpolation.FlowPair, _still_parts): a pixel whose samples move little over the pair is
warped at every 2nd, 4th or 8th key only and linear in log radiance between those, which leaves the keys where it is
warped as they were and the events of a converted clip within seed noise."""

import cv2
import numpy as np
import pytest

from generators import load
from generators.ahdr import AHDRConfig, generate_ahdr
from generators.scenes import Trajectory, VideoScene, builtin_image_scene
from generators.scenes.flow_interpolation import KEY_GROUP, STEP_CLASSES, FlowPair


def _rotating_pair(step_limit: float | None = None) -> FlowPair:
    """A textured 64x80 log frame turned 8 degrees about its centre: motion from 0 at the centre to 6 px at the
    corners, so every step class occurs."""
    rng = np.random.default_rng(1)
    h, w = 64, 80
    log0 = cv2.GaussianBlur(rng.normal(0, 1, (h, w)).astype(np.float32), (0, 0), 2)
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    cx, cy, t = (w - 1) / 2, (h - 1) / 2, np.deg2rad(8.0)

    def turned(angle):
        dx = np.cos(angle) * (xx - cx) - np.sin(angle) * (yy - cy) + cx - xx
        dy = np.sin(angle) * (xx - cx) + np.cos(angle) * (yy - cy) + cy - yy
        return np.stack([dx, dy], axis=-1).astype(np.float32)

    f01, f10 = turned(t), turned(-t)
    log1 = cv2.remap(log0, xx + f10[..., 0], yy + f10[..., 1], cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    zero = np.zeros((h, w), np.float32)
    pair = FlowPair(log0, log1, f01, f10, zero, zero, float(np.hypot(f01[..., 0], f01[..., 1]).max()))
    if step_limit is not None:
        pair.step_limit_px = step_limit
    pair.prepare()
    return pair


def test_a_pixel_is_warped_at_the_keys_its_step_divides_and_linear_between():
    pair, every = _rotating_pair(), _rotating_pair(step_limit=0.0)
    assert pair.n_keys > KEY_GROUP  # (two groups: the second one's anchors start at key KEY_GROUP)
    h, w = pair.log0.shape
    step = np.zeros((h, w), np.int64)
    for y in range(h):
        cols = pair._moving[pair._row_start[y]:pair._row_start[y + 1]]
        ends = np.concatenate([[0], pair._class_end[y]])
        for c in range(STEP_CLASSES):
            step[y, cols[ends[c]:ends[c + 1]]] = 2**c
    assert set(np.unique(step)) == {1, 2, 4, 8}
    keys = [pair.key(j) for j in range(pair.n_keys + 1)]
    exact = [every.key(j) for j in range(every.n_keys + 1)]
    for j in range(1, pair.n_keys):
        at_anchor = j % step == 0
        # (to an ulp or two: the vector loops' lengths differ, and fastmath contracts them differently)
        np.testing.assert_allclose(keys[j][at_anchor], exact[j][at_anchor], rtol=0, atol=1e-6)
        j0 = j - j % step
        j1 = np.minimum(j0 + step, pair.n_keys)
        f = ((j - j0) / (j1 - j0)).astype(np.float32)
        k0 = np.take_along_axis(np.stack(keys), j0[None], 0)[0]
        k1 = np.take_along_axis(np.stack(keys), j1[None], 0)[0]
        np.testing.assert_allclose(keys[j][~at_anchor], (k0 + f * (k1 - k0))[~at_anchor], rtol=0, atol=1e-5)
        # against the warp at every key: within what half a pixel of motion changes (the rule for key steps)
        gradient = np.hypot(*np.gradient(exact[j]))
        assert (np.abs(keys[j] - exact[j]) <= 0.5 * gradient + 0.05).mean() > 0.99


@pytest.mark.parametrize("degrees_per_s", [60.0, 120.0])
def test_per_pixel_steps_leave_the_events_of_a_converted_clip_within_seed_noise(tmp_path, monkeypatch,
                                                                                degrees_per_s):
    h, w, fps, duration = 72, 96, 24.0, 500_001
    scene = builtin_image_scene(h, w, duration, Trajectory(rotation_deg_per_s=degrees_per_s))
    clip = tmp_path / "clip.npy"
    np.save(clip, np.stack([scene.radiance(int(t)) for t in np.arange(0, duration, 1e6 / fps)]).astype(np.float32))
    prepare, stepped = FlowPair.prepare, []

    def counts(step_one: bool, seed: int) -> np.ndarray:
        def prepared(pair):
            if step_one:
                pair.step_limit_px = 0.0
            prepare(pair)
            stepped.append(pair._class_end[:, 0].sum() < pair._row_start[-1])  # some pixel of a step above 1

        monkeypatch.setattr(FlowPair, "prepare", prepared)
        out = tmp_path / f"{step_one}{seed}.h5"
        generate_ahdr(VideoScene(clip, fps=fps), out, AHDRConfig(outputs=("events",), crf="srgb"), seed,
                      progress=False)
        ev = load(out).events
        c = np.zeros((h, w))
        np.add.at(c, (ev["y"], ev["x"]), 1)
        return c

    exact, other_seed = counts(True, 0), counts(True, 1)
    assert not any(stepped)
    per_pixel = counts(False, 0)
    assert any(stepped)
    seed_corr = np.corrcoef(exact.ravel(), other_seed.ravel())[0, 1]  # 0.94 and 0.91
    assert abs(per_pixel.sum() / exact.sum() - 1) < max(2 * abs(other_seed.sum() / exact.sum() - 1), 0.002)
    assert np.corrcoef(exact.ravel(), per_pixel.ravel())[0, 1] > 1 - (1 - seed_corr) / 10  # 0.9997 on both
