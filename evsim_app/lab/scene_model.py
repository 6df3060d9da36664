"""The scene panel's computation: evsim's DVS emulator and LDR camera over a moving scene at the DAVIS346's
346x260 pixels.

The scene's radiance is rendered once per (scene, speed) at SAMPLE_US steps over DURATION_US and cached; each
change of a sensor knob then costs one `sim.emulate` over the cached samples and one `sim.LDRCamera.expose` of the
last exposure (its samples as sub-frames). The event view accumulates the last WINDOW_US of events.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import crf_models
import sim
from generators.scenes import (
    Checkerboard,
    FlickeringLight,
    ImageMotionScene,
    RotatingDisk,
    Trajectory,
    builtin_image_scene,
    load_image,
)

HEIGHT, WIDTH = 260, 346  # the DAVIS346's pixel array
DURATION_US, SAMPLE_US = 100_000, 1000  # the simulated span and the radiance sampling (1 kHz)
WINDOW_US = 20_000  # the event view's accumulation window, ending at DURATION_US
RATE_BIN_US = 5000  # the event rate's bins
SCENES = ("astronaut", "checkerboard", "rotating disk", "flickering lamp")
#: the noise types toggled one by one: name -> the sim.DVSParams fields it sets when on (off: all zero)
NOISE_TYPES = {
    "threshold mismatch": {"threshold_sigma": 0.03},
    "shot noise": {"shot_noise_hz": 2.0, "dark_shot_noise_hz": 5.0},
    "leak": {"leak_hz": 1.0},
    "hot pixels": {"hot_pixel_fraction": 5e-4, "hot_pixel_hz": 50.0},
}
_NOISE_OFF = {"threshold_sigma": 0.0, "shot_noise_hz": 0.0, "dark_shot_noise_hz": 0.0, "leak_hz": 0.0,
              "hot_pixel_fraction": 0.0}


@dataclass(frozen=True)
class SceneSettings:
    """The scene panel's knobs: scene (one of SCENES, or a photo's path) and its motion speed_px_per_s; the DVS's
    threshold (ON and OFF, log units), refractory_us, cutoff_hz (photoreceptor bandwidth at full illumination) and
    the noise types that are on (names of NOISE_TYPES); the LDR camera's exposure_us and crf; seed."""

    scene: str = "astronaut"
    speed_px_per_s: float = 200.0
    threshold: float = 0.2
    refractory_us: int = 100
    cutoff_hz: float = 300.0
    noise: tuple[str, ...] = ()
    exposure_us: int = 10_000
    crf: str = "gamma"
    seed: int = 0

    def dvs_params(self, full_illumination: float) -> sim.DVSParams:
        """The davis346 preset with this threshold, refractory and bandwidth, and only the chosen noise types."""
        unknown = set(self.noise) - set(NOISE_TYPES)
        if unknown:
            raise sim.EvsimInputError(f"unknown noise types {sorted(unknown)}; known: {', '.join(NOISE_TYPES)}")
        fields = dict(_NOISE_OFF)
        for name in self.noise:
            fields.update(NOISE_TYPES[name])
        return sim.DVSParams.preset("davis346", pos_threshold=self.threshold, neg_threshold=self.threshold,
                                    refractory_us=int(self.refractory_us), cutoff_hz=self.cutoff_hz,
                                    full_illumination=full_illumination, **fields)


@dataclass
class SceneResult:
    """What the scene panel draws: on, off (H, W) event counts per pixel in the last WINDOW_US; frame (H, W) the
    LDR frame's DN (exposure ending at DURATION_US) and its bit depth's top max_dn; rate_t_us, rate_hz: the whole
    sensor's event rate (events per second) in RATE_BIN_US bins; n_events, n_noise: events (all, and labelled
    noise) over DURATION_US."""

    on: np.ndarray
    off: np.ndarray
    frame: np.ndarray
    max_dn: int
    rate_t_us: np.ndarray
    rate_hz: np.ndarray
    n_events: int
    n_noise: int


@functools.lru_cache(maxsize=4)
def scene_radiance(scene: str, speed_px_per_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(times int64 us, (T, HEIGHT, WIDTH) float32 radiance) of a scene over DURATION_US, cached."""
    src = _scene(scene, speed_px_per_s)
    times = np.arange(0, DURATION_US + 1, SAMPLE_US, dtype=np.int64)
    return times, np.stack([src.radiance(int(t)) for t in times])


def _scene(scene: str, speed: float):
    if scene == "astronaut":
        return builtin_image_scene(HEIGHT, WIDTH, DURATION_US, Trajectory(pan_px_per_s=(speed, 0.2 * speed)))
    if scene == "checkerboard":
        return Checkerboard(HEIGHT, WIDTH, DURATION_US, square_px=16.0, velocity_px_per_s=(speed, 0.0))
    if scene == "rotating disk":
        return RotatingDisk(HEIGHT, WIDTH, DURATION_US, angular_speed_deg_s=speed)
    if scene == "flickering lamp":
        return FlickeringLight(HEIGHT, WIDTH, DURATION_US, frequency_hz=100.0)
    if Path(scene).is_file():
        return ImageMotionScene(load_image(scene), DURATION_US, Trajectory(pan_px_per_s=(speed, 0.2 * speed)),
                                height=HEIGHT, width=WIDTH, name=Path(scene).name)
    raise sim.EvsimInputError(f"unknown scene {scene!r}: one of {', '.join(SCENES)} or an image file")


def simulate_scene(settings: SceneSettings) -> SceneResult:
    """Emulate the DVS over the cached scene and expose the last LDR frame (see the module docstring)."""
    times, radiance = scene_radiance(settings.scene, float(settings.speed_px_per_s))
    full = float(np.percentile(radiance[0], 99))  # generate's auto illumination: the first image's 99th percentile
    events, labels = sim.emulate(radiance, times, settings.dvs_params(full), settings.seed, return_labels=True)
    recent = events[events["t"] >= DURATION_US - WINDOW_US]
    flat = recent["y"].astype(np.int64) * WIDTH + recent["x"]
    on = np.bincount(flat[recent["p"] > 0], minlength=HEIGHT * WIDTH).reshape(HEIGHT, WIDTH)
    off = np.bincount(flat[recent["p"] < 0], minlength=HEIGHT * WIDTH).reshape(HEIGHT, WIDTH)
    edges = np.arange(0, DURATION_US + 1, RATE_BIN_US)
    rate = np.histogram(events["t"], edges)[0] / (RATE_BIN_US * 1e-6)
    cam = sim.CameraParams(exposure_us=int(settings.exposure_us), reference_radiance=full,
                           reference_exposure_us=10_000)
    camera = sim.LDRCamera(HEIGHT, WIDTH, cam, crf_models.get(settings.crf), seed=settings.seed)
    first = int(np.searchsorted(times, DURATION_US - settings.exposure_us))
    frame = camera.expose(radiance[first:], int(settings.exposure_us), t_start_us=DURATION_US - settings.exposure_us)
    return SceneResult(on=on, off=off, frame=frame.image, max_dn=cam.max_dn, rate_t_us=edges[:-1] + RATE_BIN_US // 2,
                       rate_hz=rate, n_events=int(events.size), n_noise=int(np.count_nonzero(labels)))
