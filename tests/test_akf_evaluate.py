"""evaluate_sequence: the per-method metrics table on a case with known answers, and its input checks."""

import numpy as np
import pytest

import crf_models
import evsim_eval
import sim
from sim.errors import EvsimInputError, InvalidParameterError

LINEAR = crf_models.get("linear")


def _static_sequence():
    rng = np.random.default_rng(2)
    frames = np.repeat(rng.integers(20, 240, (1, 16, 16)).astype(np.uint8), 3, axis=0)
    ts = np.array([0, 40_000, 80_000])
    return frames, ts, ts + 5_000


def test_table_of_a_static_scene():
    frames, ts, te = _static_sequence()
    ref_t = np.array([10_000, 50_000])
    reference = np.repeat(frames[:1] / 255.0, 2, axis=0)
    table = evsim_eval.evaluate_sequence(sim.empty_events(), frames, ts, te, LINEAR, reference, ref_t,
                                  methods=("frames", "akf"), metrics=("mse", "psnr", "ssim", "log_rmse"))
    assert set(table) == {"frames", "akf"} and set(table["akf"]) == {"mse", "psnr", "ssim", "log_rmse"}
    assert table["frames"]["mse"] == pytest.approx(0.0, abs=1e-12)  # float32 output of exact DN / 255
    assert table["frames"]["ssim"] == pytest.approx(1.0)
    assert table["frames"]["log_rmse"] < 1e-6  # the frames' top, CRF^-1(1) = 1, sets the floor: no parameter needed
    # without events the AKF holds the bias-corrected frame: relative error about R / 2 = sigma_im2 / (2 I^2)
    assert table["akf"]["mse"] < 1e-8
    assert table["akf"]["psnr"] > 60


def test_method_options_reach_the_method_and_images_are_returned():
    frames, ts, te = _static_sequence()
    ref_t = np.array([60_000])
    reference = frames[1:2] / 255.0
    table, images = evsim_eval.evaluate_sequence(sim.empty_events(), frames, ts, te, LINEAR, reference, ref_t,
                                          methods=("cf",), metrics=("mse",), return_images=True,
                                          method_options={"cf": {"crossover_hz": 5.0, "i0": 0.5}})
    assert images["cf"].shape == (1, 16, 16)
    assert table["cf"]["mse"] == pytest.approx(evsim_eval.mse(images["cf"][0], reference[0]))


def test_bad_requests():
    frames, ts, te = _static_sequence()
    ref = np.zeros((1, 16, 16))
    with pytest.raises(InvalidParameterError, match="unknown"):
        evsim_eval.evaluate_sequence(sim.empty_events(), frames, ts, te, LINEAR, ref, [10_000], methods=("e2vid",))
    with pytest.raises(EvsimInputError, match="reference"):
        evsim_eval.evaluate_sequence(sim.empty_events(), frames, ts, te, LINEAR, ref, [10_000, 20_000])
