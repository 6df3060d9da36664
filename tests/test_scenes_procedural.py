import math

import numpy as np
import pytest

import sim
from generators.scenes import Checkerboard, FlickeringLight, MovingEdge, RotatingBar, RotatingDisk, SunPatch
from sim.source import RadianceSource


@pytest.mark.parametrize("t_us", [0, 137_000, 333_333, 500_000])
def test_moving_edge_position_matches_analytic_to_subpixel(t_us):
    s = MovingEdge(8, 64, 500_000, speed_px_per_s=73.3, x0=5.2, low=0.1, high=2.0)
    img = s.radiance(t_us).astype(np.float64)
    coverage = (img[3] - 0.1) / (2.0 - 0.1)
    measured = coverage.sum() - 0.5  # the bright part spans [-0.5, x_e]
    assert measured == pytest.approx(s.edge_x(t_us), abs=1e-4)
    assert s.edge_x(t_us) == pytest.approx(5.2 + 73.3 * t_us * 1e-6)
    log_img = s.log_radiance(t_us)
    assert log_img[0, 0] == pytest.approx(np.log(2.0)) and log_img[0, -1] == pytest.approx(np.log(0.1))


def test_checkerboard_contrast_and_translation():
    s = Checkerboard(32, 48, 1_000_000, square_px=6.0, velocity_px_per_s=(12.0, -5.0), low=0.02, high=400.0)
    assert s.contrast == pytest.approx(2e4)
    img = s.radiance(0)
    assert img.max() / img.min() == pytest.approx(2e4, rel=1e-5)  # fully covered squares hold the exact levels
    assert img.max() / img.min() > 1e4
    # Translation: after 0.25 s at 12 px/s the board has moved by exactly 3 px.
    s2 = Checkerboard(32, 48, 1_000_000, square_px=6.0, velocity_px_per_s=(12.0, 0.0), low=0.02, high=400.0)
    a, b = s2.radiance(0), s2.radiance(250_000)
    np.testing.assert_allclose(b[:, 3:], a[:, :-3], rtol=1e-5)
    # Sub-pixel: mean over a pixel of a checker edge is the analytic coverage fraction.
    s3 = Checkerboard(4, 16, 1_000_000, square_px=8.0, velocity_px_per_s=(1.0, 0.0), low=1.0, high=3.0,
                      origin=(0.0, -0.5))
    # At 0.3 s the bright square spans x in [0.3, 8.3) and all rows (y in [-0.5, 7.5)); pixel 0 covers
    # [-0.5, 0.5], of which 0.2 px is bright: value = low + (high - low) * 0.2.
    row = s3.radiance(300_000)[1]
    assert row[0] == pytest.approx(1.0 + 2.0 * 0.2, rel=1e-6)
    assert row[1] == pytest.approx(3.0, rel=1e-6)


def test_rotating_bar_orientation_from_image_moments():
    s = RotatingBar(64, 64, 1_000_000, angular_speed_deg_s=50.0, length_px=50, thickness_px=3, angle0_deg=10.0)
    for t_us in (0, 400_000, 900_000):
        w = s.radiance(t_us).astype(np.float64) - s.low
        yy, xx = np.mgrid[0:64, 0:64]
        m = w.sum()
        cx, cy = (w * xx).sum() / m, (w * yy).sum() / m
        mu20 = (w * (xx - cx) ** 2).sum() / m
        mu02 = (w * (yy - cy) ** 2).sum() / m
        mu11 = (w * (xx - cx) * (yy - cy)).sum() / m
        measured = math.degrees(0.5 * math.atan2(2 * mu11, mu20 - mu02))
        expected = (s.angle_deg(t_us) + 90) % 180 - 90
        assert measured == pytest.approx(expected, abs=0.3)
        assert (cx, cy) == pytest.approx(s.centre, abs=0.05)
    assert s.max_speed_px_per_s() == pytest.approx(math.radians(50) * 25)


def test_rotating_half_disk_centroid_follows_angle():
    s = RotatingDisk(81, 81, 2_000_000, angular_speed_deg_s=120.0, radius_px=30, sectors=1, low=1e-3,
                     high=1.0, background=1e-3)
    for t_us in (0, 500_000, 1_700_000):
        w = s.radiance(t_us).astype(np.float64) - 1e-3
        yy, xx = np.mgrid[0:81, 0:81]
        cx, cy = (w * xx).sum() / w.sum() - 40, (w * yy).sum() / w.sum() - 40
        assert math.hypot(cx, cy) == pytest.approx(4 * 30 / (3 * math.pi), rel=0.01)
        got = math.degrees(math.atan2(cy, cx))
        want = s.angle_deg(t_us) + 90
        assert (got - want + 180) % 360 - 180 == pytest.approx(0, abs=0.3)


def test_flicker_period_and_amplitude():
    s = FlickeringLight(16, 16, 100_000, frequency_hz=120.0, mean=5.0, depth=0.6, background=0.1, radius_px=5)
    assert s.period_us == pytest.approx(1e6 / 120)
    ts = np.arange(0, 100_000, 100)
    centre = np.array([s.radiance(int(t))[8, 8] for t in ts])
    assert centre.max() == pytest.approx(0.1 + 5 * 1.6, rel=1e-3)
    assert centre.min() == pytest.approx(0.1 + 5 * 0.4, rel=1e-3)
    spectrum = np.abs(np.fft.rfft(centre - centre.mean()))
    freqs = np.fft.rfftfreq(ts.size, d=100e-6)
    assert freqs[np.argmax(spectrum)] == pytest.approx(120.0, abs=10.0)  # 10 Hz bins over 0.1 s
    ups = ts[1:][(centre[:-1] < centre.mean()) & (centre[1:] >= centre.mean())]
    assert np.diff(ups).mean() == pytest.approx(1e6 / 120, abs=100)
    assert s.radiance(0)[0, 0] == pytest.approx(0.1)  # the corner is background and does not flicker
    assert s.max_speed_px_per_s() == 0


def test_sun_patch_centre_and_dynamic_range():
    s = SunPatch(48, 64, 1_000_000, sun=2000.0, dark=0.1, radius_px=4, start=(20.0, 15.0),
                 velocity_px_per_s=(10.0, 5.0))
    for t_us in (0, 600_000):
        img = s.radiance(t_us).astype(np.float64)
        w = img - s._background
        yy, xx = np.mgrid[0:48, 0:64]
        c = ((w * xx).sum() / w.sum(), (w * yy).sum() / w.sum())
        assert c == pytest.approx(s.centre(t_us), abs=0.02)
        assert w.sum() == pytest.approx(2000.0 * math.pi * 16, rel=0.01)
        assert img.max() / img.min() > 1e4


@pytest.mark.parametrize("cls", [MovingEdge, Checkerboard, RotatingBar, RotatingDisk, FlickeringLight, SunPatch])
def test_protocol_and_time_range(cls):
    s = cls(12, 20, 10_000)
    assert isinstance(s, RadianceSource)
    img = s.radiance(5_000)
    assert img.dtype == np.float32 and img.shape == (12, 20) and np.all(img > 0)
    assert s.describe()["type"] == cls.__name__
    with pytest.raises(sim.EvsimInputError, match="outside"):
        s.radiance(10_001)


def test_bad_parameters_raise():
    with pytest.raises(sim.InvalidParameterError, match="high"):
        MovingEdge(4, 4, 10, low=1.0, high=0.5)
    with pytest.raises(sim.InvalidParameterError, match="duration_us"):
        Checkerboard(4, 4, 0)
    with pytest.raises(sim.InvalidParameterError, match="depth"):
        FlickeringLight(4, 4, 10, depth=1.0)


@pytest.mark.parametrize("scene, span", [
    (RotatingBar(40, 40, 1_000_000, angular_speed_deg_s=200.0, low=0.1, high=5.0), 4.9),
    (RotatingDisk(40, 40, 1_000_000, angular_speed_deg_s=200.0, sectors=3, low=0.1, high=5.0, background=0.1), 4.9),
    (SunPatch(40, 40, 1_000_000, sun=100.0, velocity_px_per_s=(300.0, -100.0)), 100.0),
    (MovingEdge(4, 40, 1_000_000, speed_px_per_s=300.0, low=0.1, high=5.0), 4.9),
    (Checkerboard(40, 40, 1_000_000, velocity_px_per_s=(300.0, 100.0), low=0.1, high=5.0), 4.9),
])
def test_motion_is_continuous_in_time(scene, span):
    """Anti-aliasing is continuous: in dt the radiance changes by at most span * (max speed * dt) (coverage moves
    at most as fast as the boundary), which is what lets adaptive sampling resolve motion."""
    v = scene.max_speed_px_per_s()
    for t in (10_000, 33_333, 77_000):  # all objects still in view
        for dt in (1, 20, 200):
            change = np.abs(scene.radiance(t + dt).astype(np.float64) - scene.radiance(t)).max()
            assert change <= span * v * dt * 1e-6 * 1.42 + 1e-4  # sqrt(2): diagonal motion across a ramp
            assert change > 0 or dt == 1
