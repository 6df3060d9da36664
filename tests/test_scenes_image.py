from pathlib import Path

import cv2
import numpy as np
import pytest

import crf_models
import sim
from generators.scenes import REC709_WEIGHTS, FrameSequenceScene, ImageMotionScene, Trajectory, load_image, to_luminance

HDR_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "hdr"


def _texture(h=40, w=56, seed=1):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0.01, 10.0, (h, w)).astype(np.float32), (0, 0), 1.5)
    return img


def test_luminance_weights_and_channel_selection():
    assert REC709_WEIGHTS == (0.2126, 0.7152, 0.0722)
    img = np.zeros((2, 3, 4), np.float32)
    img[..., 0], img[..., 1], img[..., 2], img[..., 3] = 1.0, 2.0, 4.0, 100.0  # alpha is ignored
    np.testing.assert_allclose(to_luminance(img), 0.2126 + 2 * 0.7152 + 4 * 0.0722, rtol=1e-6)
    assert np.all(to_luminance(img, "G") == 2.0) and np.all(to_luminance(img, 2) == 4.0)
    with pytest.raises(sim.EvsimInputError, match="channel"):
        to_luminance(img, "Q")
    with pytest.raises(sim.EvsimInputError, match="NaN"):
        to_luminance(np.full((2, 2), np.nan))


def test_pure_integer_translation_equals_shifted_image():
    src = _texture()
    traj = Trajectory(pan_px_per_s=(4.0, -2.0))  # the view moves +4 px in x, -2 px in y per second
    s = ImageMotionScene(src, 1_000_000, traj, border="constant")
    out = s.radiance(1_000_000)  # view shifted by (4, -2) px: out[y, x] = src[y - 2, x + 4]
    np.testing.assert_array_equal(out[2:, :-4], src[:-2, 4:])
    np.testing.assert_array_equal(s.radiance(0), src)
    assert s.max_speed_px_per_s() == pytest.approx(np.hypot(4, 2))


def test_subpixel_translation_is_bilinear_within_tolerance():
    src = _texture()
    s = ImageMotionScene(src, 1_000_000, Trajectory(pan_px_per_s=(1.0, 0.0)))
    out = s.radiance(300_000)  # 0.3 px: out[:, x] = 0.7 src[:, x] + 0.3 src[:, x + 1]
    expected = 0.7 * src[:, :-1] + 0.3 * src[:, 1:]
    # OpenCV quantises bilinear weights to 1/32 px: error <= |gradient| / 64.
    tol = np.abs(np.diff(src, axis=1)) / 60 + 1e-5
    assert np.all(np.abs(out[:, :-1] - expected) <= tol)


def test_rotation_zoom_and_shake_are_smooth_and_bounded():
    src = _texture(64, 64)
    traj = Trajectory(pan_px_per_s=(10.0, 0.0), zoom_per_s=0.2, rotation_deg_per_s=15.0, shake_px=1.0, shake_deg=0.5,
                      shake_hz=3.0, shake_seed=7)
    s = ImageMotionScene(src, 500_000, traj, height=32, width=32)
    bound = s.max_speed_px_per_s()
    # Track the output position of a source point through the homography: its speed never exceeds the bound.
    p_src = np.array([34.0, 30.0, 1.0])
    ts = np.arange(0, 500_001, 1000)
    pos = np.array([(np.linalg.inv(s.homography(int(t))) @ p_src)[:2] for t in ts])
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=1) / 1e-3
    assert speed.max() <= bound
    assert speed.max() > 0.2 * bound  # the bound is not absurdly loose
    # The 64x64 source was area-reduced to 32x32 (scale 2): the output centre maps to its centre plus the shake.
    dx, dy, _ = traj._shake(0)
    np.testing.assert_allclose(s.homography(0) @ [15.5, 15.5, 1], [15.5 + dx, 15.5 + dy, 1], atol=1e-9)
    # same seed -> same shake
    t2 = Trajectory(shake_px=1.0, shake_seed=7)
    assert np.allclose(t2._shake(0.123), Trajectory(shake_px=1.0, shake_seed=7)._shake(0.123))


def test_downscaling_prereduces_and_keeps_mean():
    src = _texture(80, 80)
    s = ImageMotionScene(src, 1000, height=20, width=20, interpolation="cubic")
    out = s.radiance(0)
    assert out.shape == (20, 20) and np.all(out >= 0)
    assert out.mean() == pytest.approx(src.mean(), rel=0.02)


def test_npy_and_ldr_loading(tmp_path):
    rgb = np.random.default_rng(0).uniform(0, 5, (6, 7, 3)).astype(np.float32)
    np.save(tmp_path / "a.npy", rgb)
    np.testing.assert_allclose(load_image(tmp_path / "a.npy"), rgb @ np.array(REC709_WEIGHTS, np.float32), rtol=1e-6)
    ldr = np.array([[0, 64, 128, 255]], np.uint8)
    cv2.imwrite(str(tmp_path / "g.png"), ldr)
    lin = load_image(tmp_path / "g.png", crf="gamma", crf_params={"gamma": 2.2})
    np.testing.assert_allclose(lin[0], (ldr[0] / 255.0) ** 2.2, rtol=1e-5, atol=1e-7)
    srgb = load_image(tmp_path / "g.png")  # default inverse sRGB
    np.testing.assert_allclose(srgb[0], crf_models.get("srgb").inverse(ldr[0] / 255.0), rtol=1e-5)
    with pytest.raises(sim.EvsimInputError, match="not found"):
        load_image(tmp_path / "missing.exr")
    with pytest.raises(sim.InvalidParameterError, match="unknown CRF"):
        load_image(tmp_path / "g.png", crf="nope")


def test_exr_and_radiance_hdr_loading():
    if not HDR_DIR.is_dir():
        pytest.skip(f"real HDR data not found at {HDR_DIR}")
    import OpenEXR

    desk = load_image(HDR_DIR / "Desk.exr")
    rgba = OpenEXR.File(str(HDR_DIR / "Desk.exr")).channels()["RGBA"].pixels.astype(np.float32)
    assert desk.shape == rgba.shape[:2] == (874, 644)
    np.testing.assert_allclose(desk[400, 300], np.maximum(rgba[400, 300, :3] @ REC709_WEIGHTS, 0), rtol=1e-5)
    p1, p99 = np.percentile(desk[desk > 0], [0.1, 99.9])
    assert p99 / p1 > 2**10  # a real HDR photo: the data README states about 18 stops
    grace = load_image(HDR_DIR / "Grace_Cathedral.hdr", channel="R")
    bgr = cv2.imread(str(HDR_DIR / "Grace_Cathedral.hdr"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(grace, bgr[..., 2])  # "R" is the last channel of OpenCV's BGR
    s = ImageMotionScene.from_file(HDR_DIR / "Desk.exr", 100_000, Trajectory(pan_px_per_s=(50, 0)), height=60,
                                   width=80)
    img = s.radiance(50_000)
    assert img.shape == (60, 80) and img.dtype == np.float32 and np.all(np.isfinite(img)) and img.min() >= 0


def _ramp_frames():
    frames = np.stack([np.full((3, 4), v, np.float32) for v in (1.0, 4.0, 2.0)])
    return frames, np.array([1000, 3000, 5000], np.int64)


def test_frame_sequence_interpolation_log_and_linear():
    frames, times = _ramp_frames()
    s = FrameSequenceScene(frames, times, log_eps=1e-9)
    assert s.duration_us == 4000
    assert s.radiance(0)[0, 0] == pytest.approx(1.0)
    assert s.radiance(1000)[0, 0] == pytest.approx(2.0, rel=1e-5)  # geometric mean of 1 and 4
    assert s.radiance(3000)[0, 0] == pytest.approx(np.sqrt(8), rel=1e-5)
    assert s.radiance(4000)[0, 0] == pytest.approx(2.0)
    lin = FrameSequenceScene(frames, times, interpolation="linear")
    assert lin.radiance(1000)[0, 0] == pytest.approx(2.5)
    assert lin.max_speed_px_per_s() == pytest.approx(1e6 / 2000)
    with pytest.raises(sim.TimeOrderError, match="increasing"):
        FrameSequenceScene(frames, np.array([0, 5, 5]))


def test_frame_sequence_from_exr_folder(tmp_path):
    import OpenEXR

    for i, v in enumerate((1.0, 9.0)):
        px = np.full((5, 6, 3), v, np.float32)
        OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                     {"RGB": px}).write(str(tmp_path / f"f{i:03d}.exr"))
    (tmp_path / "timestamps.txt").write_text("100\n2100\n")
    s = FrameSequenceScene.from_folder(tmp_path, log_eps=1e-9)
    assert (s.height, s.width, s.duration_us) == (5, 6, 2000)
    assert s.radiance(1000)[2, 2] == pytest.approx(3.0, rel=1e-5)


def _log_change_over_one_pixel_of_pan(scene, speed_px_per_s):
    """Image-wide sum of |L(t + dt) - L(t)| over 16 consecutive steps of 1/8 pixel of motion (two pixel periods)."""
    dt = round(1e6 / speed_px_per_s / 8)
    logs = [np.log(scene.radiance(k * dt) + 1e-3) for k in range(17)]
    return np.array([np.abs(b - a).sum() for a, b in zip(logs[:-1], logs[1:])])


def test_pan_rate_of_log_change_does_not_pulse_at_the_pixel_period():
    # A real pixel integrates the continuous image over its area, so under a constant-speed pan of detailed content
    # the image-wide rate of log change (the DVS event rate) is about constant. Point-sampling a source reduced to
    # one pixel per output pixel puts every pixel at the same sub-pixel phase, and that rate then peaks each time
    # the view crosses a pixel (the control below: 1.4-1.6 max / min on this image).
    from generators.scenes import builtin_hdr_image

    img = builtin_hdr_image("astronaut")  # 512 x 512: scale 8.5 for a 45 x 60 output
    traj = Trajectory(pan_px_per_s=(100.0, 0.0))
    rate = _log_change_over_one_pixel_of_pan(ImageMotionScene(img, 200_000, traj, height=45, width=60), 100.0)
    assert rate.max() / rate.min() < 1.2
    point = ImageMotionScene(img, 200_000, traj, height=45, width=60, supersample=1)
    assert point.supersample == 1
    control = _log_change_over_one_pixel_of_pan(point, 100.0)
    assert control.max() / control.min() > 1.4 and np.argmax(control) % 8 in (0, 7)  # peaks at whole pixels


def test_supersampling_keeps_the_mean_and_the_view():
    src = _texture(120, 168)
    fine = ImageMotionScene(src, 1000, height=40, width=56)  # scale 3: rendered on a 3x grid, area-averaged
    point = ImageMotionScene(src, 1000, height=40, width=56, supersample=1)
    assert fine.supersample == 3 and point.supersample == 1
    np.testing.assert_allclose(fine.homography(0), point.homography(0), atol=1e-12)
    # both show the source area-reduced to the output grid at t=0 (the 3x grid samples source pixel centres)
    expected = cv2.resize(src, (56, 40), interpolation=cv2.INTER_AREA)
    np.testing.assert_allclose(fine.radiance(0), expected, rtol=1e-5)
    np.testing.assert_allclose(point.radiance(0), expected, rtol=1e-5)
    with pytest.raises(sim.InvalidParameterError, match="supersample"):
        ImageMotionScene(src, 1000, height=40, width=56, supersample=0)


def test_prefiltered_views_equal_the_supersampled_grid_for_pans():
    # One warp from the box-filtered source gives the k x k grid's area average exactly for a pan of a source
    # area-reduced to k pixels per output pixel (bilinear interpolation commutes with whole-pixel shifts); for an
    # enlarged source (scale 2 < k) or a zoom with rotation, nearly the same image.
    src = _texture(240, 336)
    pan = Trajectory(pan_px_per_s=(37.0, -11.0), shake_px=0.7)
    zoom = Trajectory(zoom_per_s=0.4, rotation_deg_per_s=20.0)
    for image, trajectory, tol in ((src, pan, 1e-5), (src[:40, :56], pan, 0.01), (src, zoom, 0.01)):
        fast = ImageMotionScene(image, 500_000, trajectory, height=20, width=28)
        fine = ImageMotionScene(image, 500_000, trajectory, height=20, width=28, prefilter=False)
        for t in (0, 123_457, 480_000):
            a, b = fast.radiance(t), fine.radiance(t)
            assert np.max(np.abs(a - b) / b) < tol * (1 if tol < 1e-3 else 10)
            assert np.median(np.abs(a - b) / b) < tol
