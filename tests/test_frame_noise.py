"""akf.frame_noise: the frames' read noise recovered from the frames (quantised synthetic frames, the LDR camera model
with a configured read noise, still and panned), the frame update's variance it sets, and where `evsim evaluate`
takes it from (a sensor file's [input] read_noise_dn, else the estimate)."""

import math

import numpy as np
import pytest
from scipy import ndimage

import akf
import crf_models
import sim
from akf.frame_noise import estimate_read_noise, frame_log_variance, frame_noise_variance
from evsim_eval.protocols import with_read_noise
from generators.formats.recording import Recording

LINEAR = crf_models.get("linear")


def _quantised(sigma, rng, n=6, h=100, w=120):
    """8-bit frames of a still scene whose pixel means spread over 20..230 DN, with Gaussian noise sigma DN."""
    mu = rng.uniform(20, 230, (h, w))
    return np.clip(np.round(mu + rng.normal(0, sigma, (n, h, w))), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("sigma", [0.3, 0.8, 1.3, 3.0, 8.0])
def test_read_noise_of_quantised_frames_is_recovered(sigma):
    frames = _quantised(sigma, np.random.default_rng(int(sigma * 10)))
    assert estimate_read_noise(frames).read_noise_dn == pytest.approx(sigma, rel=0.03)


def test_the_continuous_mad_of_quantised_differences_cannot_tell_08_from_13_dn():
    """The estimator it replaces (MAD / 0.6745 / sqrt(2) of the integer differences) reads 1.05 DN for both."""
    rng = np.random.default_rng(1)
    naive = [np.median(np.abs(np.diff(_quantised(s, rng).astype(float), axis=0))) / 0.6745 / math.sqrt(2)
             for s in (0.8, 1.3)]
    assert naive[0] == naive[1] == pytest.approx(1.048, abs=1e-3)


class _Texture:
    """A random texture (radiance 0.1..0.3 of the full well, 1.5 px correlation) panned at speed px/s to the left."""

    def __init__(self, speed, h=96, w=128, duration_us=400_000, seed=0):
        self.height, self.width, self.duration_us, self.speed = h, w, duration_us, speed
        field = ndimage.gaussian_filter(np.random.default_rng(seed).normal(size=(h, w + 200)), 1.5, mode="wrap")
        self._tex = 0.2 + 0.1 * field / np.abs(field).max()

    def radiance(self, t_us):
        shift = self.speed * t_us * 1e-6
        return ndimage.shift(self._tex, (0, -shift), order=1, mode="wrap")[:, :self.width].astype(np.float32)

    def max_speed_px_per_s(self):
        return abs(self.speed)


@pytest.mark.parametrize("speed", [0.0, 100.0])
def test_camera_read_noise_is_recovered_still_and_panned(speed):
    """sim.LDRCamera, linear CRF, 8 bits, full well 2550 e- (10 e- per DN), read noise 40 e- (4 DN), 1 ms
    exposures at 50 fps, the texture still or panned by 2 px per frame: the estimate is the configured temporal
    noise, sqrt(read noise^2 + mean signal electrons) / 10 DN (Poisson shot noise), within 7 % (measured: still
    +0.6 %, panned +4.5 %; panned without the alignment +15 %, without the flat-pixel selection too +33 %)."""
    src = _Texture(speed)
    params = sim.CameraParams(fps=50.0, exposure_us=1000, full_well_e=2550.0, read_noise_e=40.0, reference_fill=1.0,
                              reference_radiance=1.0, bit_depth=8)
    frames = np.stack([f.image for f in sim.LDRCamera(src.height, src.width, params, LINEAR, seed=3).capture(src)])
    electrons = 2550.0 * float(np.mean(src._tex))
    expected = math.sqrt(40.0**2 + electrons) / 10.0
    assert estimate_read_noise(frames).read_noise_dn == pytest.approx(expected, rel=0.07)


def test_frame_variance_is_read_noise_and_quantisation_through_the_crf():
    """Linear 8-bit frames: x = DN / 255, so a pixel's variance is (sigma^2 + 1/12) / 255^2 in x^2, and in
    log(I + I0) that over (I + I0)^2; a 2.2 gamma curve, y = x^(1/2.2), divides the response variance by its
    squared slope y' = y / (2.2 x); twice the exposure time (gain 1/2) halves I and its standard deviation."""
    assert frame_noise_variance(1.5, LINEAR, 8) == pytest.approx((1.5**2 + 1 / 12) / 255**2, rel=1e-9)
    var_y = (1.5**2 + 1 / 12) / 255**2
    y = np.array([0.2, 0.5, 0.9])
    np.testing.assert_allclose(frame_log_variance(y, LINEAR, 1.5, i0=1e-3), var_y / (y + 1e-3) ** 2, rtol=1e-9)
    gamma = crf_models.get("gamma", gamma=2.2)
    x = y**2.2
    np.testing.assert_allclose(frame_log_variance(y, gamma, 1.5, i0=1e-3), var_y / (y / (2.2 * x) * (x + 1e-3)) ** 2,
                               rtol=1e-5)
    np.testing.assert_allclose(frame_log_variance(y, LINEAR, 1.5, gain=0.5, i0=1e-3),
                               0.25 * var_y / (0.5 * y + 1e-3) ** 2, rtol=1e-9)


def _recording(rng):
    frames = _quantised(1.3, rng, n=5, h=40, w=50)
    t = np.arange(5, dtype=np.int64) * 40_000
    return Recording(sim.empty_events(), 40, 50, frames=frames, frame_t_start_us=t, frame_t_mid_us=t + 250,
                     frame_t_end_us=t + 500)


def test_evaluate_takes_the_sensor_files_read_noise_else_the_estimate(tmp_path):
    rec = _recording(np.random.default_rng(2))
    fed = np.arange(0, 5, 2)
    path = tmp_path / "cam.toml"
    path.write_text('name = "cam"\n[input]\nread_noise_dn = 2.5\n')
    options, note = with_read_noise({}, rec, LINEAR, fed, str(path))
    assert options["params"].read_noise_dn == 2.5 and "2.5 DN from sensor file cam.toml" in note
    options, note = with_read_noise({}, rec, LINEAR, fed, None)
    assert options["params"].read_noise_dn == pytest.approx(1.3, rel=0.1) and "estimated" in note
    given = akf.AKFParams(read_noise_dn=0.7)
    options, note = with_read_noise({"params": given}, rec, LINEAR, fed, str(path))
    assert options["params"] is given and "as given" in note


def test_the_default_akf_uses_the_estimated_read_noise():
    rec = _recording(np.random.default_rng(3))
    args = (sim.empty_events(), rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, LINEAR, [100_000])
    estimate = estimate_read_noise(rec.frames).read_noise_dn
    default = akf.reconstruct(*args)
    np.testing.assert_array_equal(default, akf.reconstruct(*args, params=akf.AKFParams(read_noise_dn=estimate)))
    assert not np.array_equal(default, akf.reconstruct(*args, params=akf.AKFParams(read_noise_dn=0.0)))
