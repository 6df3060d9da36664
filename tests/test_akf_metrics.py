"""Metrics against known values."""

import numpy as np
import pytest

from evsim_eval import metrics
from sim.errors import EvsimInputError


def test_mse_and_psnr_of_a_known_error():
    ref = np.full((8, 8), 0.5)
    ref[0, 0] = 2.0
    x = ref + 0.1
    assert metrics.mse(x, ref) == pytest.approx(0.01)
    assert metrics.psnr(x, ref) == pytest.approx(10 * np.log10(4.0 / 0.01))  # data range = reference max = 2
    assert metrics.psnr(x, ref, data_range=1.0) == pytest.approx(20.0)
    assert metrics.psnr(ref, ref) == np.inf


def test_ssim_identity_and_scale():
    rng = np.random.default_rng(0)
    ref = rng.uniform(0, 3, (32, 32))
    assert metrics.ssim(ref, ref) == pytest.approx(1.0)
    assert metrics.ssim(ref * 0.5, ref) < 0.95
    with pytest.raises(EvsimInputError):
        metrics.ssim(ref, np.ones((32, 32)))
    with pytest.raises(EvsimInputError):
        metrics.mse(ref, ref[:-1])


def test_pu21_anchor_values_and_monotonicity():
    y = np.logspace(np.log10(0.005), 4, 200)
    v = metrics.pu21_encode(y)
    assert np.all(np.diff(v) > 0)
    assert metrics.pu21_encode(0.005) == pytest.approx(0.0, abs=1e-6)  # the encoding starts at 0
    assert metrics.pu21_encode(100.0) == pytest.approx(256.0, abs=0.5)  # SDR white maps to ~256 like 8-bit sRGB
    assert metrics.pu21_encode(10000.0) == pytest.approx(595.4, abs=0.1)
    assert metrics.pu21_encode(1e6) == metrics.pu21_encode(1e4)  # clamped to the model's range
    ref = np.linspace(0.01, 5, 256).reshape(16, 16)
    assert metrics.pu21_psnr(ref, ref) == np.inf
    assert metrics.pu21_ssim(ref, ref) == pytest.approx(1.0)
    assert metrics.pu21_psnr(ref * 1.1, ref) > metrics.pu21_psnr(ref * 1.5, ref)


def test_paper_protocol_maps_white_to_1_and_clips_highlights():
    ref = np.full((16, 16), 0.5)
    ref[:2] = 80.0  # highlights far above white: the [0, 1] protocol sees them as 1
    x = ref.copy()
    x[:2] = 1.0  # a reconstruction that reaches white there has no [0, 1] error...
    assert metrics.mse01(x, ref, white=1.0) == 0.0
    assert metrics.mse(x, ref) > 700  # ...while the raw MSE is all highlight
    y = ref * 0.5
    expected = np.mean((np.clip(y / 2, 0, 1) - np.clip(ref / 2, 0, 1)) ** 2)
    assert metrics.mse01(y, ref, white=2.0) == pytest.approx(expected)
    assert metrics.ssim01(ref, ref, white=2.0) == pytest.approx(1.0)
    assert metrics.ssim01(y, ref, white=2.0) == pytest.approx(
        metrics.ssim(np.clip(y / 2, 0, 1), np.clip(ref / 2, 0, 1), data_range=1.0))
    assert metrics.score("mse01", y, ref, white=2.0) == metrics.mse01(y, ref, white=2.0)
    with pytest.raises(EvsimInputError, match="white"):
        metrics.score("ssim01", y, ref)
    assert set(metrics.NORMALISATION) == set(metrics.METRICS)


def test_log_mse_counts_ratios():
    ref = np.full((4, 4), 0.1)
    assert metrics.log_mse(2 * ref, ref) == pytest.approx(np.log((0.2 + 1e-3) / (0.1 + 1e-3)) ** 2)
    big = np.full((4, 4), 100.0)
    # a 10 % error on a highlight costs about what a 10 % error on a shadow costs
    assert metrics.log_mse(1.1 * big, big) == pytest.approx(metrics.log_mse(1.1 * ref, ref), rel=0.02)
    with pytest.raises(EvsimInputError, match="the image has -0.1 at row 0"):  # radiance is never negative
        metrics.log_mse(-ref, ref)


def test_log_rmse_of_a_known_log_offset_is_that_offset():
    rng = np.random.default_rng(2)
    ref = rng.uniform(0.05, 500.0, (16, 16))  # far above the frames' top 1: nothing clipped at the top
    for offset in (0.1, -0.7, 2.0):
        assert metrics.log_rmse(ref * np.exp(offset), ref, top=1.0) == pytest.approx(abs(offset), rel=1e-12)
    assert metrics.log_rmse(ref, ref, top=1.0) == 0.0
    # a known error on a quarter of the pixels: sqrt of the mean square, not the mean of the errors
    x = ref.copy()
    x[:4] *= np.exp(0.4)
    assert metrics.log_rmse(x, ref, top=1.0) == pytest.approx(0.4 / 2, rel=1e-12)
    assert metrics.score("log_rmse", x, ref, top=1.0) == metrics.log_rmse(x, ref, top=1.0)
    with pytest.raises(EvsimInputError, match="frames' top"):
        metrics.score("log_rmse", x, ref)


def test_log_rmse_floors_both_images_at_1e_3_of_the_frames_top():
    top = 2.0
    floor = metrics.LOG_FLOOR_FRACTION * top
    assert floor == pytest.approx(2e-3)
    ref = np.full((8, 8), 0.2)
    ref[0, :] = 0.0  # black truth...
    x = ref.copy()
    x[0, :] = 1e-6  # ...and a reconstruction far below the floor: both count as the floor, no error
    assert metrics.log_rmse(x, ref, top=top) == 0.0
    x[0, :] = 4 * floor  # above the floor by a factor 4, against a black truth: ln 4 on one row of eight
    assert metrics.log_rmse(x, ref, top=top) == pytest.approx(np.log(4.0) / np.sqrt(8), rel=1e-12)
    # the floor moves with the frames' top: with a 10 times higher top that pixel sits below the floor
    assert metrics.log_rmse(x, ref, top=10 * top) == 0.0
    np.testing.assert_allclose(metrics.score_map("log_rmse", x, ref, top=top)[0], np.log(4.0) ** 2, rtol=1e-12)


def test_pu21_scores_the_whole_reference_above_100x():
    ref = np.full((32, 32), 0.5)
    ref[8:24, 8:24] = np.linspace(250.0, 1000.0, 256).reshape(16, 16)  # a highlight up to 1000 x
    wrong = ref.copy()
    wrong[ref > 100] *= 0.5  # 125..500 x: differs only above 100 x, where Y = 100 I would clamp both at 10000 cd/m^2
    assert metrics.pu21_luminance_scale(ref) == pytest.approx(10.0)  # the reference's max -> 10000 cd/m^2
    assert metrics.pu21_luminance_scale(np.full((4, 4), 100.0)) == 100.0  # up to 100 x: 100 cd/m^2 per x
    assert metrics.pu21_psnr(ref, ref) == np.inf and metrics.pu21_ssim(ref, ref) == pytest.approx(1.0)
    assert metrics.pu21_psnr(wrong, ref) < 30 and metrics.pu21_ssim(wrong, ref) < 0.999
    # the old fixed scale saw no difference at all
    assert metrics.pu21_psnr(wrong, ref, luminance_scale=100.0) == np.inf
    assert metrics.pu21_ssim(wrong, ref, luminance_scale=100.0) == pytest.approx(1.0)
    # the per-pixel map uses the same scale
    smap = metrics.score_map("pu21_ssim", wrong, ref)
    assert smap[3:-3, 3:-3].mean() == pytest.approx(metrics.pu21_ssim(wrong, ref))
