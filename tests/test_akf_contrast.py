"""The contrast threshold from the data, and the per-pixel calibration acting under threshold mismatch.

Two small AHDR sequences (48x64 pixels, 0.3 s, the astronaut photo panning): an ideal DVS with thresholds 0.3 seen
through a linear CRF (the estimate against the known threshold), and the noisy davis346 DVS with thresholds 0.3
(sigma 0.03) behind the window CRF, reconstructed with the nominal 0.2 (calibration on against off)."""

import dataclasses

import numpy as np
import pytest

import akf
import crf_models
from generators import load
from generators.ahdr import generate_ahdr
from generators.builtin import ahdr_suite, ahdr_suite_config
from sim.errors import EvsimInputError

TRUE_C = 0.3


def _generate(path, preset, crf):
    _, scene = ahdr_suite(48, 64, 0.3, include_hdr=False)[0]
    cfg = ahdr_suite_config(preset)
    cfg = dataclasses.replace(cfg, dvs=dataclasses.replace(cfg.dvs, pos_threshold=TRUE_C, neg_threshold=TRUE_C),
                              crf=crf, compression=None)
    generate_ahdr(scene, path, cfg, 0, progress=False)
    return load(path)


@pytest.fixture(scope="module")
def ideal_linear(tmp_path_factory):
    return _generate(tmp_path_factory.mktemp("c") / "ideal.h5", "ideal", "linear")


@pytest.fixture(scope="module")
def davis_window(tmp_path_factory):
    return _generate(tmp_path_factory.mktemp("c") / "davis.h5", "davis346", "window")


def _crf(rec):
    return crf_models.get(rec.crf["name"], **rec.crf["params"])


def test_estimate_recovers_a_known_threshold(ideal_linear):
    rec = ideal_linear
    est = akf.estimate_contrast(rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, _crf(rec))
    assert est.c_on == pytest.approx(TRUE_C, rel=0.08)
    assert est.c_off == pytest.approx(TRUE_C, rel=0.08)
    assert min(est.n_on, est.n_off) > 1000
    # the events are what it reads: halving the threshold doubles the event count -> the estimate halves
    ev = rec.events
    doubled = np.sort(np.concatenate([ev, ev]), order="t", kind="stable")
    half = akf.estimate_contrast(doubled, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, "linear")
    assert half.c_on == pytest.approx(est.c_on / 2, rel=0.02)


def test_estimate_refuses_data_without_evidence(ideal_linear):
    rec = ideal_linear
    still = np.repeat(rec.frames[:1], 3, axis=0)
    with pytest.raises(EvsimInputError, match="give the contrast"):
        akf.estimate_contrast(rec.events[:0], still, rec.frame_t_start_us[:3], rec.frame_t_end_us[:3], "linear")


def test_calibration_brings_the_akf_closer_to_the_truth_under_mismatch(davis_window):
    rec = davis_window
    inside = (rec.reference_t_us > rec.frame_t_mid_us[0]) & (rec.reference_t_us < rec.frame_t_mid_us[-1])
    ref, times = rec.reference[inside], rec.reference_t_us[inside]
    errors = {}
    for cal in (True, False):
        out = akf.reconstruct(rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, "window", times,
                              contrast=0.2, params=akf.AKFParams(calibrate=cal))
        errors[cal] = float(np.mean((out - ref) ** 2))
    # measured 0.0297 (on) against 0.0303 (off); 0.0307 against 0.0321 with the earlier max_variance 1e-4
    assert errors[True] < 0.985 * errors[False]


def test_carried_calibration_learns_a_pixel_threshold_and_shrinks_to_the_pooled_one():
    from akf.augmentation import ContrastCalibration

    params = akf.AKFParams(calib_prior=1.0)
    cal = ContrastCalibration(3, params)
    change = np.array([0.4, 0.4, 0.4])  # 2 nominal events of 0.2 each
    net = np.array([2, 2, 2])
    clipped = np.array([False, False, True])
    d_start = np.zeros(3)
    for _ in range(10):  # pixels 0 and 1: true thresholds 0.3 and 0.24 (scales 1.5 and 1.2); pixel 2 always clipped
        scale = cal.interval(d_start, np.array([0.6, 0.48, 5.0]), change, net, clipped)
        np.testing.assert_allclose(scale[:2], [1.5, 1.2])  # eq. 12 where the interval calibrates
    carried = cal.carried()
    pooled = (10 * 0.6 + 10 * 0.48) / (10 * 0.4 + 10 * 0.4)
    np.testing.assert_allclose(carried, [(6 + pooled) / 5, (4.8 + pooled) / 5, pooled])
    assert np.all(scale[2] == carried[2])  # the clipped pixel takes the carried (pooled) scale, not 1
    off = ContrastCalibration(3, akf.AKFParams(calibrate=False))
    np.testing.assert_array_equal(off.interval(d_start, np.array([0.6, 0.48, 5.0]), change, net, clipped),
                                  np.ones(3))


@pytest.mark.xfail(strict=True, reason="known bias: calibrate's first stage estimates 0.21 for the true 0.3 here. "
                   "The davis346 pixel (at b = 3 DN) and an ideal one (b = 1 DN) tie within 0.1 %, the integer "
                   "passage median (1 event, x 0.1) decides for the davis346 pixel, whose bandwidth and refractory "
                   "period need lower thresholds for the same counts; with a continuous passage term the ideal "
                   "pixel wins, but quantised dark frames still favour b = 1 DN: 0.262 / 0.257, at the tolerance's "
                   "edge (CHANGELOG, known regression)")
def test_interleave_on_a_davis_like_export_estimates_the_contrast_and_tunes(ideal_linear, tmp_path):
    """A real DAVIS recording carries neither contrast nor CRF: exported so (IJRR layout), the interleave protocol
    estimates the thresholds from the events and the fed frames only, and the tuning protocol runs on it."""
    from evsim_eval.evaluate import evaluate_dataset
    from evsim_eval.protocols import recording_case
    from generators.formats import export

    bare = dataclasses.replace(ideal_linear, crf=None, metadata={}, threshold_maps=None)
    export(bare, tmp_path / "davis", "ijrr")
    task, notes = recording_case(load(tmp_path / "davis"), "interleave")
    assert any("calibrate's first stage" in n for n in notes) and any("assumed linear" in n for n in notes)
    assert task.contrast == pytest.approx((TRUE_C, TRUE_C), rel=0.15)
    assert task.frames.shape[0] == (ideal_linear.frames.shape[0] + 1) // 2  # held-out frames are not fed
    result, notes, tuning, _ = evaluate_dataset(tmp_path / "davis", protocol="interleave",
                                                methods=("akf", "cf", "frames"), metrics=("mse01", "ssim01"),
                                                tune=True, progress=False)
    assert set(tuning) == {"akf", "cf", "frames"} and "alpha" in tuning["cf"]
    assert any(n.startswith("tuned cf: alpha=") for n in notes)
    assert result["akf"]["davis"]["mse01"] < result["frames"]["davis"]["mse01"]
