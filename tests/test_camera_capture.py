"""LDRCamera.capture: frame timing, motion blur against the analytic box integral, rolling shutter, streaming."""

import inspect

import numba
import numpy as np
import pytest

import crf_models
from sim import CameraParams, EvsimInputError, InvalidParameterError, LDRCamera, TimeOrderError
from sim.source import RadianceSource

LO, HI = 0.2, 0.8  # radiance left / right of the edge


def _frac_integral(u):
    """Antiderivative of clip(u, 0, 1)."""
    return np.where(u < 0, 0.0, np.where(u <= 1, u * u / 2, u - 0.5))


class MovingEdge:
    """A vertical edge at p(t) = p0 + v t (pixels): pixel c (covering [c, c + 1]) sees LO on the left part and
    HI on the right part, area-weighted. Its exposure mean is known in closed form (mean_over)."""

    def __init__(self, height=4, width=48, speed=1000.0, p0=4.0, duration_us=100_000):
        self.height, self.width, self.duration_us = height, width, duration_us
        self.speed, self.p0 = speed, p0

    def _frac(self, t_us):
        return np.clip(np.arange(self.width) + 1 - (self.p0 + self.speed * t_us * 1e-6), 0, 1)

    def radiance(self, t_us):
        row = LO + (HI - LO) * self._frac(t_us)
        return np.broadcast_to(row.astype(np.float32), (self.height, self.width))

    def max_speed_px_per_s(self):
        return abs(self.speed)

    def mean_over(self, t0_us, t1_us):
        """(1 / T) * integral of the radiance over [t0, t1]: the analytic box integral, per column."""
        c = np.arange(self.width) + 1 - self.p0
        u0, u1 = c - self.speed * t0_us * 1e-6, c - self.speed * t1_us * 1e-6
        return LO + (HI - LO) * (_frac_integral(u0) - _frac_integral(u1)) / (u0 - u1)


class Ramp:
    """Static scene whose brightness rises linearly in time: a + b t (t in us)."""

    def __init__(self, height=50, width=3, a=0.1, b=5e-6, duration_us=50_000):
        self.height, self.width, self.duration_us, self.a, self.b = height, width, duration_us, a, b

    def radiance(self, t_us):
        return np.full((self.height, self.width), self.a + self.b * t_us, np.float32)

    def max_speed_px_per_s(self):
        return 0.0


def _camera(src, crf=None, **kw):
    base = dict(fps=50.0, exposure_us=10_000, noise=False, read_noise_e=0.0, reference_fill=1.0, bit_depth=16)
    return LDRCamera(src.height, src.width, CameraParams(**{**base, **kw}), crf or crf_models.get("linear"), seed=0)


def test_test_sources_follow_the_protocol():
    assert isinstance(MovingEdge(), RadianceSource) and isinstance(Ramp(), RadianceSource)


@pytest.mark.parametrize("n_subframes", [None, 64])
def test_motion_blur_equals_the_analytic_box_integral(n_subframes):
    src = MovingEdge(speed=1000.0)  # 10 px of motion per 10 ms exposure
    cam = _camera(src, n_subframes=n_subframes)
    frames = list(cam.capture(src))
    assert len(frames) == 5
    for f in frames:
        S = f.n_subframes
        assert S == (10 if n_subframes is None else 64)  # automatic: at most 1 px of motion per sub-frame
        truth = src.mean_over(f.t_start_us, f.t_end_us)
        # Midpoint rule on a piecewise-linear signal: only the 2 sub-frames holding a kink err, each by at most
        # (motion per sub-frame) / 8 of the step, averaged over S; times rounded to 1 us add v * 0.5 us.
        delta = src.speed * (f.exposure_us / S) * 1e-6
        tol = (HI - LO) * (2 * delta / (8 * S) + src.speed * 0.5e-6) + 1e-6
        np.testing.assert_allclose(f.irradiance, np.broadcast_to(truth, f.irradiance.shape), atol=tol)
        np.testing.assert_allclose(f.clean_response, np.minimum(f.irradiance, 1.0), atol=1e-6)
        np.testing.assert_array_equal(f.image, np.rint(np.minimum(f.irradiance.astype(float), 1) * 65535))
    # the blur is real: the first frame spreads the edge over about 10 columns
    ramp = frames[0].irradiance[0]
    assert np.sum((ramp > LO + 0.01) & (ramp < HI - 0.01)) >= 9


def test_frame_timing_with_fps_and_explicit_times():
    src = Ramp(duration_us=100_000)
    frames = list(_camera(src, fps=100.0, exposure_us=2000).capture(src))
    t = np.array([(f.t_start_us, f.t_mid_us, f.t_end_us) for f in frames])
    assert t.dtype == np.int64 and len(frames) == 10
    np.testing.assert_array_equal(t[:, 1], 1000 + 10_000 * np.arange(10))
    np.testing.assert_array_equal(t[:, 0], t[:, 1] - 1000)
    np.testing.assert_array_equal(t[:, 2], t[:, 1] + 1000)
    # exposure of each frame = the ramp's mean over its window (exact for a linear signal)
    for f in frames:
        assert f.irradiance[0, 0] == pytest.approx(src.a + src.b * f.t_mid_us, rel=1e-6)
    cam = _camera(src, frame_times_us=(5000, 30_000, 40_000), exposure_us=(4000, 400))
    got = [(f.t_start_us, f.t_end_us, f.exposure_us) for f in cam.capture(src)]
    assert got == [(3000, 7000, 4000), (29_800, 30_200, 400), (38_000, 42_000, 4000)]


def test_exposures_cycle_and_overlaps_are_rejected():
    src = Ramp(duration_us=100_000)
    cam = _camera(src, fps=100.0, exposure_us=(1000, 8000))
    assert [f.exposure_us for f in cam.capture(src)][:4] == [1000, 8000, 1000, 8000]
    with pytest.raises(InvalidParameterError, match="overlap"):  # raised by capture() itself, not lazily
        _camera(src, frame_times_us=(5000, 7000), exposure_us=4000).capture(src)
    with pytest.raises(TimeOrderError, match="increase strictly"):
        CameraParams(frame_times_us=(5000, 5000))
    with pytest.raises(InvalidParameterError, match="before t = 0"):
        list(_camera(src, frame_times_us=(1000,), exposure_us=4000).capture(src))
    with pytest.raises(InvalidParameterError, match="after the source's duration"):
        list(_camera(src, frame_times_us=(99_000,), exposure_us=4000).capture(src))


def test_longer_exposure_collects_proportionally_more_signal():
    src = Ramp(b=0.0, a=0.05)
    cam = _camera(src, fps=50.0, exposure_us=(2000, 8000), reference_exposure_us=10_000)
    f1, f2 = list(cam.capture(src))[:2]
    assert f1.image[0, 0] == round(0.05 * 0.2 * 65535) and f2.image[0, 0] == round(0.05 * 0.8 * 65535)


def test_rolling_shutter_shifts_each_row_window():
    src = Ramp(height=50, b=5e-6)
    line = 37.0
    cam = _camera(src, fps=40.0, exposure_us=1000, n_subframes=10, rolling_shutter_line_us=line)
    for f in cam.capture(src):
        rows = np.arange(src.height)
        truth = src.a + src.b * (f.t_mid_us + rows * line)
        # sample-and-hold over 100 us intervals: the two partial intervals of a row err by at most b dt^2 / T
        np.testing.assert_allclose(f.irradiance[:, 0], truth, atol=src.b * 100**2 / 1000 + 1e-6)
        assert f.line_us == line
    with pytest.raises(InvalidParameterError):
        CameraParams(rolling_shutter_line_us=-1.0)


def test_capture_streams_and_picks_subframes_from_motion():
    src = MovingEdge(speed=0.0)
    cam = _camera(src)
    gen = cam.capture(src)
    assert inspect.isgenerator(gen)
    assert next(gen).n_subframes == 1
    fast = MovingEdge(speed=1e6, duration_us=20_000)  # 10,000 px per exposure: capped at max_subframes
    assert next(_camera(fast, max_subframes=32).capture(fast)).n_subframes == 32
    assert cam.subframes_for(exposure_us=5, speed_px_per_s=1e9) == 5  # never more than one per microsecond


def test_noisy_capture_is_reproducible():
    src = MovingEdge()
    kw = dict(noise=True, read_noise_e=3.0, full_well_e=5000.0, bit_depth=8)
    a = [f.image for f in _camera(src, **kw).capture(src)]
    threads = numba.get_num_threads()
    numba.set_num_threads(1)  # counter-based noise: independent of the thread count
    try:
        b = [f.image for f in _camera(src, **kw).capture(src)]
    finally:
        numba.set_num_threads(threads)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[3], a[4])  # identical static content, independent noise


def test_bad_sources_are_rejected():
    src = MovingEdge()
    with pytest.raises(EvsimInputError, match="RadianceSource"):
        list(_camera(src).capture(object()))
    with pytest.raises(EvsimInputError, match="camera is 8 x 48"):
        list(LDRCamera(8, 48, CameraParams(), crf_models.get("linear")).capture(src))

    class NaNSource(MovingEdge):
        def radiance(self, t_us):
            r = np.array(super().radiance(t_us))
            r[1, 2] = np.nan
            return r

    with pytest.raises(EvsimInputError, match="NaN"):
        list(_camera(src).capture(NaNSource()))


def test_presets():
    for name in ("ideal", "davis346_aps", "machine_vision"):
        p = CameraParams.preset(name, fps=10.0)
        assert p.fps == 10.0
    assert CameraParams.preset("ideal").noise is False
    assert CameraParams.preset("machine_vision").bit_depth == 12
