"""Seams in converted frames (issue 34): thin lines in the flow-interpolated radiance that neither input frame has.
A rigid translation has no motion boundaries, and its interpolation adds no thin line; on real clips the seams
are where objects move against each other (docs/guide/convert.md, "Seams")."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from generators.scenes import VideoScene

THIN_LOG = 0.25  # a 3x3 black-hat or top-hat of the log radiance above this marks a 1-2 px wide line


def thin_lines(log_radiance: np.ndarray) -> np.ndarray:
    """Pixels of 1-2 px wide dark or bright lines (3x3 black-hat / top-hat of the log radiance above THIN_LOG)."""
    k = np.ones((3, 3), np.uint8)
    img = log_radiance.astype(np.float32)
    return (cv2.morphologyEx(img, cv2.MORPH_BLACKHAT, k) > THIN_LOG) | \
        (cv2.morphologyEx(img, cv2.MORPH_TOPHAT, k) > THIN_LOG)


def seam_excess(scene: VideoScene) -> float:
    """Thin-line pixels of the radiance half-way between input frames, less the mean of the two frames' own, as a
    share of the pixels (averaged over the intervals)."""
    t, eps, out = scene.times, scene.log_eps, []
    for k in range(len(t) - 1):
        logs = [np.log(scene.radiance(int(v)) + eps) for v in (t[k], (t[k] + t[k + 1]) // 2, t[k + 1])]
        out.append(thin_lines(logs[1]).mean() - 0.5 * (thin_lines(logs[0]).mean() + thin_lines(logs[2]).mean()))
    return float(np.mean(out))


def test_interpolating_a_rigid_pan_adds_no_seam(tmp_path):
    skimage_data = pytest.importorskip("skimage.data")
    photo = cv2.resize(cv2.cvtColor(skimage_data.astronaut(), cv2.COLOR_RGB2GRAY), (512, 512))[150:286]
    path = tmp_path / "pan.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25, (320, 136))
    for k in range(9):  # 6 px per frame to the left: flow interpolates between frames, no occlusion inside
        writer.write(cv2.cvtColor(np.ascontiguousarray(photo[:, 6 * k:6 * k + 320]), cv2.COLOR_GRAY2BGR))
    writer.release()
    scene = VideoScene(path)
    # fewer thin lines than the frames (the interpolation smooths a little), never more; bikes.mp4 at 2.8-3.02 s,
    # where cars move against each other: +5.8e-4
    assert seam_excess(scene) < 2e-4
