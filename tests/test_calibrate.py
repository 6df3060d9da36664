"""Calibration to a sensor (evsim_eval.calibrate): on a synthetic hybrid recording simulated with known DVS
parameters, calibrate recovers them (thresholds within 10 %, log offset within 25 %, shot noise within 30 %); the
simulation of a recording's own frames keeps its time base; the fitted sensor file round-trips."""

import math

import numpy as np
import pytest

import sim
from generators.ahdr import AHDRConfig, generate_ahdr, warm_up_input
from generators.scenes.base import Scene

TRUTH = sim.DVSParams(pos_threshold=0.25, neg_threshold=0.3, threshold_sigma=0.02, refractory_us=100,
                      cutoff_hz=300.0, dark_fraction=0.02, shot_noise_hz=0.5, dark_shot_noise_hz=0.0, leak_hz=0.0,
                      hot_pixel_fraction=0.0)


class _GlowingWall(Scene):
    """A static wall whose brightness spans two decades across x (so the log offset matters); the left half is
    lit by a light that swells and fades (log brightness sinusoidal, 1.5 Hz, +-1.5), the right half is static
    (its events are noise)."""

    def __init__(self, height: int = 32, width: int = 48, duration_us: int = 1_600_000):
        self._init_size(height, width, duration_us)
        x = np.arange(width) % (width // 2)
        self._base = np.broadcast_to(np.exp(np.log(0.01) * (1 - x / (width // 2 - 1))), (height, width))
        self._lit = np.arange(width) < width // 2

    def _render(self, t_us):
        gain = math.exp(1.5 * math.sin(2 * math.pi * 1.5 * t_us * 1e-6))
        return np.where(self._lit, self._base * gain, self._base).astype(np.float32)


@pytest.fixture(scope="module")
def synthetic_recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("calibrate") / "wall.h5"
    camera = sim.CameraParams(fps=25.0, exposure_us=2000, reference_radiance=5.0, reference_fill=1.0, noise=False,
                              bit_depth=16)
    generate_ahdr(_GlowingWall(), path, AHDRConfig(dvs=TRUTH, camera=camera, crf="linear", auto_exposure=False,
                                                   threshold_maps=False), seed=3, progress=False)
    return path


@pytest.mark.slow
def test_calibrate_recovers_known_parameters(synthetic_recording):
    from evsim_eval.calibrate import calibrate

    # the simulated frames are noise-free: no input conditioning (which takes half the picture moving for noise)
    cal = calibrate(synthetic_recording, (0.2, 1.5), conditioning="off", max_evaluations=60, progress=False)
    fitted = cal.dvs
    assert fitted.pos_threshold == pytest.approx(TRUTH.pos_threshold, rel=0.10)
    assert fitted.neg_threshold == pytest.approx(TRUTH.neg_threshold, rel=0.10)
    # both dark fractions are relative to the 99th percentile of the radiance at t = 0 (auto illumination)
    assert fitted.dark_fraction == pytest.approx(TRUTH.dark_fraction, rel=0.25)
    assert fitted.shot_noise_hz == pytest.approx(TRUTH.shot_noise_hz, rel=0.30)
    assert cal.scores["fitted"]["count_ratio"] == pytest.approx(1.0, abs=0.05)


def test_warm_up_input_mirrors_the_start():
    """The warm-up is the clip's start mirrored in time before t = 0 (oldest first), t = 0 left out."""
    images = [np.full((2, 2), v, np.float32) for v in (1.0, 2.0, 3.0)]
    stack, times = warm_up_input(images, [0, 10, 30])
    assert times.tolist() == [-30, -10]
    assert [float(s[0, 0]) for s in stack] == [3.0, 2.0]
    with pytest.raises(sim.InvalidParameterError):
        warm_up_input(images[:1], [0])


def test_warm_up_removes_the_start_up_burst():
    """A static noisy input with leak: without warm-up the first 100 ms fire far more than the steady state; with
    the mirrored warm-up the first 100 ms are within 30 % of the steady rate."""
    rng = np.random.default_rng(1)
    times = np.arange(0, 1_000_001, 2000, dtype=np.int64)
    frames = (1.0 + 0.01 * rng.standard_normal((times.size, 24, 24))).astype(np.float32)
    params = sim.DVSParams(pos_threshold=0.05, neg_threshold=0.05, leak_hz=0.5, shot_noise_hz=0.0,
                           dark_shot_noise_hz=0.0, hot_pixel_fraction=0.0, cutoff_hz=0.0, refractory_us=0)

    def first_and_steady(events):
        t = events["t"]
        return np.sum(t <= 100_000), np.sum(t > 500_000) / 5

    cold = sim.emulate(frames, times, params, 0)
    pre, pre_t = warm_up_input(list(frames[:250]), times[:250])
    warm = sim.emulate(np.concatenate([np.stack(pre), frames]), np.concatenate([pre_t, times]), params, 0)
    warm = warm[warm["t"] > 0]
    first, steady = first_and_steady(cold)
    assert first > 1.5 * steady
    first, steady = first_and_steady(warm)
    assert first == pytest.approx(steady, rel=0.3)


def test_convert_keeps_the_recordings_time_base(synthetic_recording, tmp_path):
    """A recording's frames converted: the scene's t = 0 is the first mid-exposure, in the recording's time base,
    and the written events and frames carry those times (not times from the first frame)."""
    from generators.convert import convert
    from generators.formats import load

    real = load(synthetic_recording)
    index = convert(synthetic_recording, tmp_path / "out", progress=False, upsample="linear", conditioning="off")
    sim_rec = load(next((tmp_path / "out").glob("*.h5")))
    origin = int(real.frame_t_mid_us[0])
    assert origin > 0 and index.is_file()
    assert sim_rec.metadata["time_origin_us"] == origin
    assert sim_rec.metadata["scene"]["warm_up_us"] == 500_000  # a recording's frames: the DVS is warmed up
    assert sim_rec.events["t"].min() > origin
    # the simulated events of the lit half follow the real ones in time: their rate curves correlate
    bins = np.arange(origin, int(real.events["t"].max()), 50_000)
    r = np.histogram(real.events["t"], bins)[0]
    s = np.histogram(sim_rec.events["t"], bins)[0]
    assert np.corrcoef(r, s)[0, 1] > 0.8


def test_black_level_and_sensor_input_table(tmp_path):
    """black_level is subtracted before linearising (linear CRF: (DN - black) / (255 - black)); a sensor file's
    [input] table round-trips and gives convert its black level."""
    from generators.convert import convert_config
    from generators.scenes.video import VideoScene

    stack = np.full((3, 4, 6), 10, np.uint8)
    stack[:, :, 3:] = 255
    np.save(tmp_path / "s.npy", stack)
    scene = VideoScene(tmp_path / "s.npy", fps=25.0, input_crf="linear", black_level=10.0, upsample="none",
                       conditioning="off")
    img = scene.radiance(0)
    assert img[:, :3].max() == 0.0 and img[:, 3:].min() == pytest.approx(1.0)
    sensor = sim.Sensor(name="cam", dvs=sim.DVSParams(), tables={"input": {"black_level": 10.0, "offset_dn": 12.5}})
    path = sim.write_sensor(tmp_path / "cam.toml", sensor)
    assert sim.load_sensor(path).tables["input"] == {"black_level": 10.0, "offset_dn": 12.5}
    cfg = convert_config(tmp_path / "s.npy", settings={"sensor": str(path)}, fps=25.0)
    assert cfg.sequences[0].scene["black_level"] == 10.0
    with pytest.raises(sim.InvalidParameterError, match="offset_dn"):
        sim.Sensor(name="cam", tables={"input": {"offset_dn": 0.0}})


def test_calibrate_refuses_bad_windows_and_recordings_without_frames(tmp_path):
    from evsim_eval.calibrate import calibrate
    from generators.formats import export
    from generators.formats.recording import Recording

    with pytest.raises(sim.EvsimInputError, match="0 <= start < end"):
        calibrate(tmp_path / "any.h5", (2.0, 1.0), progress=False)
    events = np.zeros(3, sim.EVENT_DTYPE)
    events["t"] = [10, 20, 30]
    events["p"] = 1
    export(Recording(events=events, height=4, width=4), tmp_path / "ev.h5", "native")
    with pytest.raises(sim.EvsimInputError, match="needs a recording with frames"):
        calibrate(tmp_path / "ev.h5", (0.0, 1.0), progress=False)
