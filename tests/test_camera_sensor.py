"""The LDR sensor model through LDRCamera.expose: photon transfer, clipping, fixed patterns, quantisation, CRF."""

import numpy as np
import pytest

import crf_models
from sim import CameraParams, EvsimInputError, InvalidParameterError, LDRCamera

LINEAR = crf_models.get("linear")


def _camera(shape=(64, 64), crf=LINEAR, seed=0, **kw):
    base = dict(exposure_us=1000, reference_radiance=1.0, reference_fill=1.0, full_well_e=20_000.0, read_noise_e=5.0,
                bit_depth=12)
    return LDRCamera(*shape, CameraParams(**{**base, **kw}), crf, seed=seed)


def test_photon_transfer_follows_the_emva_line_and_clips_at_full_well():
    # EMVA 1288: var_y = K (mu_y - mu_dark) + K^2 sigma_d^2 + 1/12, K = (2^12 - 1) / full well DN per electron.
    cam = _camera(shape=(128, 128))
    K = 4095 / 20_000
    h, w = cam.height, cam.width
    fills = np.array([0.002, 0.005, 0.02, 0.05, 0.1, 0.2, 0.4, 0.8])  # of full well (radiance 1 fills it)
    means, variances = [], []
    for i, fill in enumerate(fills):
        a = cam.expose(np.full((h, w), fill), 1000, frame_index=2 * i).image.astype(float)
        b = cam.expose(np.full((h, w), fill), 1000, frame_index=2 * i + 1).image.astype(float)
        means.append((a.mean() + b.mean()) / 2)
        variances.append(np.var(a - b) / 2)  # temporal variance, free of any fixed pattern
    means, variances = np.array(means), np.array(variances)
    line = K * means + K**2 * 5.0**2 + 1 / 12
    # linearity: within 4 standard errors of the mean of 2 N pixels
    assert np.all(np.abs(means - K * fills * 20_000) <= 4 * np.sqrt(line / (2 * h * w)) + 1e-3 * means)
    # Each level on the line within 4 standard errors of a variance estimate (relative std sqrt(2 / N)); at the
    # darkest levels the read-noise term K^2 sigma_d^2 + 1/12 = 1.13 DN^2 is 40% of the variance.
    np.testing.assert_allclose(variances, line, rtol=4 * np.sqrt(2 / (h * w)))
    # Weighted fit of the line (weights 1 / standard error): slope = K and intercept = K^2 sigma_d^2 + 1/12
    # within 4 of their standard errors.
    (slope, intercept), cov = np.polyfit(means, variances, 1, w=1 / (line * np.sqrt(2 / (h * w))), cov="unscaled")
    assert abs(slope - K) < 4 * np.sqrt(cov[0, 0])
    assert abs(intercept - (K**2 * 25 + 1 / 12)) < 4 * np.sqrt(cov[1, 1])
    sat = cam.expose(np.full((h, w), 2.0), 1000, frame_index=99).image
    assert np.all(sat == 4095)  # twice the full well: every pixel clipped


def test_dark_current_adds_mean_and_shot_noise():
    cam = _camera(dark_current_e_per_s=200_000.0, read_noise_e=0.0)  # 200 e- in 1 ms
    K = 4095 / 20_000
    dark = np.zeros((64, 64))
    a = cam.expose(dark, 1000, frame_index=0).image.astype(float)
    b = cam.expose(dark, 1000, frame_index=1).image.astype(float)
    assert a.mean() == pytest.approx(K * 200, rel=0.01)
    assert np.var(a - b) / 2 == pytest.approx(K**2 * 200 + 1 / 12, rel=0.1)


def test_fixed_patterns_are_fixed_and_have_the_configured_spread():
    cam = _camera(noise=False, prnu_sigma=0.02, dsnu_e=0.0, bit_depth=16)
    K = 65535 / 20_000
    flat = np.full((64, 64), 0.5)
    a = cam.expose(flat, 1000, frame_index=0).image.astype(float)
    b = cam.expose(flat, 1000, frame_index=5).image.astype(float)
    assert np.array_equal(a, b)
    assert a.std() / a.mean() == pytest.approx(0.02, rel=0.05)  # 4096 pixels: std of a std about 1.1%
    cam = _camera(noise=False, prnu_sigma=0.0, dsnu_e=20.0, bit_depth=16)
    c = cam.expose(flat, 1000).image.astype(float)
    assert c.std() == pytest.approx(K * 20.0, rel=0.05) and c.mean() == pytest.approx(K * 10_000, rel=1e-3)
    again = _camera(noise=False, prnu_sigma=0.0, dsnu_e=20.0, bit_depth=16, seed=1).expose(flat, 1000).image
    assert not np.array_equal(c, again)


@pytest.mark.parametrize("bits", [8, 10, 12, 16])
def test_quantisation_reaches_exactly_two_to_the_bits_levels(bits):
    n = 2**bits
    cam = _camera(shape=(256, 256), noise=False, bit_depth=bits)
    ramp = (np.arange(256 * 256) % n / (n - 1)).reshape(256, 256)  # x = d / (2^bits - 1) for every level d
    image = cam.expose(ramp, 1000).image
    assert image.dtype == (np.uint8 if bits == 8 else np.uint16)
    assert np.unique(image).size == n and image.max() == n - 1 and image.min() == 0
    assert np.array_equal(image.ravel(), np.arange(256 * 256) % n)


@pytest.mark.parametrize("name,params", [("srgb", {}), ("window", {}), ("sigmoid", {}), ("logc3", {}),
                                         ("gamma", {"gamma": 2.2}), ("linear", {"black_level": 0.05})])
def test_digital_numbers_are_the_rounded_crf_response(name, params):
    crf = crf_models.get(name, **params)
    cam = _camera(crf=crf, noise=False, bit_depth=10)
    x = np.random.default_rng(3).uniform(0, 1.2, (64, 64))
    frame = cam.expose(x, 1000)
    want = np.rint(crf.forward(np.minimum(x, 1.0)) * 1023)
    assert np.array_equal(frame.image, want)
    np.testing.assert_allclose(frame.clean_response, crf.forward(np.minimum(x, 1.0)), atol=1e-6)


def test_ahdr_window_frames_clip_exactly_at_the_band_and_rbar_saturates_there():
    crf = crf_models.get("window", low=100, high=160, base="linear")
    cam = _camera(shape=(1, 2560), crf=crf, noise=False, bit_depth=8)
    x = np.linspace(0, 1, 2560)[None]
    image = cam.expose(x, 1000).image[0].astype(int)
    z = 255 * x[0]  # the base (linear 8-bit) value
    assert np.all(image[z < 100] == 0) and np.all(image[z > 160] == 255)
    inside = (z > 100.5) & (z < 159.5)
    assert np.all((image[inside] > 0) & (image[inside] < 255))
    np.testing.assert_array_equal(image, np.rint(np.clip((z - 100) / 60, 0, 1) * 255))
    rbar = crf.variance(image / 255, sigma_im2=0.01, max_variance=3.0)
    assert np.all(rbar[(image == 0) | (image == 255)] == 3.0)
    np.testing.assert_allclose(rbar[(image > 0) & (image < 255)], 0.01)


def test_noise_is_reproducible_per_frame_and_seed():
    a = _camera(seed=7).expose(np.full((64, 64), 0.3), 1000, frame_index=3).image
    b = _camera(seed=np.random.SeedSequence(7)).expose(np.full((64, 64), 0.3), 1000, frame_index=3).image
    c = _camera(seed=7).expose(np.full((64, 64), 0.3), 1000, frame_index=4).image
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert _camera(seed=7).seed_entropy == 7


def test_subframe_stack_is_averaged():
    cam = _camera(noise=False, bit_depth=16)
    stack = np.stack([np.full((64, 64), v) for v in (0.1, 0.2, 0.45)])
    frame = cam.expose(stack, 1000)
    np.testing.assert_allclose(frame.irradiance, 0.25, rtol=1e-6)
    assert frame.n_subframes == 3 and np.all(frame.image == 16384)  # round(0.25 * 65535)


def test_bad_input_is_rejected():
    cam = _camera()
    bad = np.full((64, 64), 0.5)
    bad[3, 4] = np.nan
    with pytest.raises(EvsimInputError, match="NaN"):
        cam.expose(bad, 1000)
    with pytest.raises(EvsimInputError, match="64 x 64"):
        cam.expose(np.zeros((32, 64)), 1000)
    with pytest.raises(InvalidParameterError, match="exposure_us"):
        cam.expose(np.zeros((64, 64)), -5)
    for kw, msg in [({"bit_depth": 7}, "bit_depth"), ({"bit_depth": 17}, "bit_depth"),
                    ({"exposure_us": -1}, "exposure_us"),
                    ({"full_well_e": 0.0}, "full_well_e"), ({"read_noise_e": -1.0}, "read_noise_e"),
                    ({"n_subframes": 0}, "n_subframes"), ({"reference_fill": 1.5}, "reference_fill")]:
        with pytest.raises(InvalidParameterError, match=msg):
            CameraParams(**kw)
    with pytest.raises(InvalidParameterError, match="unknown camera preset"):
        CameraParams.preset("nope")


@pytest.mark.parametrize("lam", [3.0, 30.0])
def test_shot_noise_is_poisson_in_electrons(lam):
    # K = 1 DN per electron and no read noise: the digital numbers are the electron counts themselves.
    from scipy.stats import poisson

    cam = _camera(shape=(128, 128), full_well_e=65535.0, read_noise_e=0.0, bit_depth=16)
    counts = cam.expose(np.full((128, 128), lam / 65535), 1000).image.ravel()
    n = counts.size
    k = np.arange(int(lam + 4 * np.sqrt(lam)) + 1)
    observed = np.bincount(counts, minlength=k.size)[k] / n
    expected = poisson.pmf(k, lam)
    assert np.all(np.abs(observed - expected) <= 5 * np.sqrt(expected * (1 - expected) / n) + 1e-4)


def test_bad_seed_is_rejected_with_a_clear_error():
    import crf_models

    for seed in (-1, 1.5, "0"):
        with pytest.raises(InvalidParameterError, match="seed must be a non-negative int"):
            LDRCamera(4, 4, CameraParams(), crf_models.get("linear"), seed=seed)
