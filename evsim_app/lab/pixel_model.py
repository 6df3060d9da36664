"""The one-pixel panel's computation: evsim's DVS emulator and LDR camera on one pixel, and the AKF on what
they record.

The pixel is a 1x1 `sim.DVSEmulator` fed the signal in chunks, so its own state (the photoreceptor output and the
reference level) is read between chunks; the events are exactly `sim.emulate`'s for the same parameters and seed.
The frames are a 1x1 `sim.LDRCamera` exposing the signal's samples over each exposure window; the AKF
(`akf.reconstruct`) fuses the two with the sensor's nominal thresholds and leak rate.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

import akf
import crf_models
import sim

from .signals import PixelTrace, pixel_signal

DURATION_US, DT_US = 1_000_000, 200  # the signal: 1 s sampled every 200 us
CHUNK = 20  # samples fed per call: the state traces have one point per CHUNK samples (4 ms)
N_ESTIMATES = 400  # AKF output times
REFERENCE_EXPOSURE_US = 5000  # the exposure at which radiance 1 (full illumination) fills half the full well
CRFS = ("gamma", "srgb", "linear", "window", "filmic")


@dataclass(frozen=True)
class PixelSettings:
    """Every knob of the pixel panel (units in the names; log units are natural logs).

    signal: a name of signals.SIGNALS or "recording"; light: mean radiance as a fraction of the DVS's full
    illumination (the photoreceptor's bandwidth is cutoff_hz times it, plus the dark level); pos_threshold,
    neg_threshold, threshold_sigma (mismatch: the pixel's thresholds are drawn from N(C, sigma^2) with `seed`),
    refractory_us, cutoff_hz, shot_noise_hz, leak_hz: sim.DVSParams fields; exposure_us, fps: the LDR camera; crf: a
    crf_models name; seed: the pixel's draw of mismatch and noise.
    """

    signal: str = "sinusoid"
    light: float = 1.0
    pos_threshold: float = 0.2
    neg_threshold: float = 0.2
    threshold_sigma: float = 0.0
    refractory_us: int = 100
    cutoff_hz: float = 300.0
    shot_noise_hz: float = 0.1
    leak_hz: float = 0.1
    exposure_us: int = 5000
    fps: float = 30.0
    crf: str = "gamma"
    seed: int = 0

    def dvs_params(self) -> sim.DVSParams:
        """The sensor: the davis346 preset with this panel's fields (no hot pixel: it is one pixel)."""
        return sim.DVSParams.preset(
            "davis346", pos_threshold=self.pos_threshold, neg_threshold=self.neg_threshold,
            threshold_sigma=self.threshold_sigma, refractory_us=int(self.refractory_us), cutoff_hz=self.cutoff_hz,
            shot_noise_hz=self.shot_noise_hz, dark_shot_noise_hz=0.0, leak_hz=self.leak_hz, leak_spread=0.0,
            hot_pixel_fraction=0.0)

    def camera_params(self) -> sim.CameraParams:
        """The LDR camera: 8 bits, shot and read noise, radiance 1 fills half the well in REFERENCE_EXPOSURE_US."""
        return sim.CameraParams(fps=self.fps, exposure_us=int(self.exposure_us),
                                reference_exposure_us=REFERENCE_EXPOSURE_US)


@dataclass
class PixelResult:
    """What the pixel panel draws. Log values are log(I + I_d) of radiance I (I_d the DVS's dark level).

    t_us, log_input: the signal; trace_t_us, photoreceptor, reference: the emulator's low-passed log and its
    reference level (one point per chunk); events, labels: the pixel's events (sim.EVENT_DTYPE) and their
    sim.EVENT_LABELS indices; frame_t_start_us, frame_t_end_us, frame_dn, frame_log, frame_clipped: the LDR frames
    (frame_log is the radiance CRF^-1 gives back); akf_t_us, akf_log, akf_std: the AKF estimate and sqrt(P) (log
    units).
    """

    t_us: np.ndarray
    log_input: np.ndarray
    trace_t_us: np.ndarray
    photoreceptor: np.ndarray
    reference: np.ndarray
    events: np.ndarray
    labels: np.ndarray
    frame_t_start_us: np.ndarray
    frame_t_end_us: np.ndarray
    frame_dn: np.ndarray
    frame_log: np.ndarray
    frame_clipped: np.ndarray
    akf_t_us: np.ndarray
    akf_log: np.ndarray
    akf_std: np.ndarray
    counts: dict = field(default_factory=dict)

    @property
    def n_events(self) -> int:
        """All events, signal and noise."""
        return int(self.events.size)

    @property
    def n_noise_events(self) -> int:
        """Events the model labels as noise (shot, leak)."""
        return int(np.count_nonzero(self.labels))


def sample_times() -> np.ndarray:
    """The signal's sample times (int64 us)."""
    return np.arange(0, DURATION_US + 1, DT_US, dtype=np.int64)


def pixel_radiance(settings: PixelSettings, trace: PixelTrace | None = None) -> np.ndarray:
    """(T, 1, 1) float32 radiance of the settings' signal at sample_times()."""
    return pixel_signal(settings.signal, sample_times(), settings.light, trace)[:, None, None]


def simulate_pixel(settings: PixelSettings, trace: PixelTrace | None = None) -> PixelResult:
    """Run the DVS, the LDR camera and the AKF on one pixel (see the module docstring)."""
    t = sample_times()
    radiance = pixel_radiance(settings, trace)
    dvs = settings.dvs_params()
    emu = sim.DVSEmulator(1, 1, dvs, settings.seed, return_labels=True)
    parts, trace_t, lf, ref = [], [], [], []
    for k in range(0, t.size, CHUNK):
        parts.append(emu.feed(radiance[k:k + CHUNK], t[k:k + CHUNK]))
        trace_t.append(emu.time_us)
        lf.append(emu.log_intensity[0, 0])
        ref.append(emu.reference_log[0, 0])
    events = np.concatenate([p[0] for p in parts])
    labels = np.concatenate([p[1] for p in parts])
    dark = dvs.dark_fraction * dvs.full_illumination
    frames = _frames(settings, t, radiance)
    cam = settings.camera_params()
    to_x = cam.electrons_per_radiance_us * cam.exposures[0] / cam.full_well_e  # radiance -> the CRF's x
    est_t, est, std = _akf(settings, events, frames, t)
    return PixelResult(
        t_us=t, log_input=np.log(radiance[:, 0, 0].astype(np.float64) + dark),
        trace_t_us=np.asarray(trace_t, np.int64), photoreceptor=np.asarray(lf), reference=np.asarray(ref),
        events=events, labels=labels, frame_t_start_us=frames["start"], frame_t_end_us=frames["end"],
        frame_dn=frames["dn"], frame_log=np.log(frames["x"] / to_x + dark), frame_clipped=frames["clipped"],
        akf_t_us=est_t, akf_log=np.log(est / to_x + dark), akf_std=std,
        counts={"ON": int(np.sum(events["p"] > 0)), "OFF": int(np.sum(events["p"] < 0)),
                **{name: int(np.sum(labels == i)) for i, name in enumerate(sim.EVENT_LABELS)}})


def _frames(settings: PixelSettings, t: np.ndarray, radiance: np.ndarray) -> dict:
    """The LDR camera's frames of the pixel: each exposure integrates the signal's samples in its window."""
    cam_params = settings.camera_params()
    crf = crf_models.get(settings.crf)
    camera = sim.LDRCamera(1, 1, cam_params, crf, seed=settings.seed)
    schedule = cam_params.schedule(1, int(t[-1]))
    if schedule.shape[0] < 2:
        raise sim.EvsimInputError(f"{settings.fps:g} fps with {settings.exposure_us} us exposures gives fewer than "
                                  f"two frames in {DURATION_US / 1e6:g} s")
    dn = np.empty(schedule.shape[0], np.int64)
    for k, (start, _, end) in enumerate(schedule):
        i0, i1 = np.searchsorted(t, [start, end])
        dn[k] = camera.expose(radiance[i0:max(i1, i0 + 1)], int(end - start), frame_index=k,
                              t_start_us=int(start)).image[0, 0]
    top = cam_params.max_dn
    gain = cam_params.exposures[0] / (schedule[:, 2] - schedule[:, 0])
    x = np.maximum(crf.inverse(dn / top), 1e-6) * gain
    return {"start": schedule[:, 0], "end": schedule[:, 2], "dn": dn, "x": x, "clipped": (dn <= 0) | (dn >= top),
            "images": dn.astype(np.uint8 if top < 256 else np.uint16)[:, None, None]}


def _akf(settings: PixelSettings, events: np.ndarray, frames: dict, t: np.ndarray):
    """The AKF's estimate (x units) and sqrt(P) (log units) at N_ESTIMATES times after the first exposure."""
    out_t = np.linspace(int(frames["start"][0]), int(t[-1]), N_ESTIMATES).astype(np.int64)
    est, var = akf.reconstruct(events, frames["images"], frames["start"], frames["end"], settings.crf, out_t,
                               contrast=(settings.pos_threshold, settings.neg_threshold), leak_rate_hz=settings.leak_hz,
                               return_variance=True)
    return out_t, np.maximum(est[:, 0, 0].astype(np.float64), 0.0), np.sqrt(var[:, 0, 0].astype(np.float64))
