"""A recording's own frames, upsampled once, as the input of many DVS simulations (the calibration's inner loop).

The frames go through the same path as `evsim convert` (generators.scenes.VideoScene: black level, the frames'
exposure times, linear input CRF for a hybrid camera's frames, flow upsampling) and are sampled once by convert's own
DVS pass (generators.dvs_input.DVSInput: the adaptive sampler with AHDRConfig's settings and the warm-up, the clip's
start mirrored before it); the samples stay in memory, so each simulation with other DVS parameters costs one
sim.emulate over them. The full illumination
is resolved as generate resolves it (generators.ahdr.resolve_sensors: the 99th percentile of the radiance at t = 0),
so a DVSParams fitted here gives the same events through `evsim convert --sensor`. Event times are in the
recording's time base.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import sim
from generators.ahdr import AHDRConfig, resolve_sensors
from generators.dvs_input import DVSInput
from generators.formats.recording import Recording
from generators.scenes.video import VideoScene


@dataclass(frozen=True)
class InputSettings:
    """How the recording's frames become radiance (what a sensor file's [input] table holds).

    Attributes
    ----------
    black_level : float
        The frames' value for no light (DN, subtracted before linearising).
    upsample, flow_preset : str
        As for generators.scenes.VideoScene ("flow", "medium").
    conditioning : str or None
        As for generators.scenes.VideoScene (None: temporal for a recording's frames).
    """

    black_level: float = 0.0
    upsample: str = "flow"
    flow_preset: str = "medium"
    conditioning: str | None = None


class RecordingSimulation:
    """The upsampled radiance of a recording's frames, ready for repeated DVS simulation.

    After construction, times_us holds the sample times in scene time (from the first frame; the warm-up's are
    negative), radiance the (N, H, W) float32 samples, and full_illumination the resolved radiance of "full
    illumination" (DVSParams.full_illumination is replaced by it in every simulation).

    Parameters
    ----------
    path : str or Path
        An AEDAT4 file, IJRR folder or other hybrid recording with frames.
    settings : InputSettings, optional
        How its frames become radiance (default InputSettings()).
    recording : Recording, optional
        The Recording at path when the caller has loaded it (not read again).
    max_pixel_samples : int
        Bound of the memory held: float32 samples x pixels (EvsimInputError beyond it).
    """

    def __init__(self, path: str | Path, settings: InputSettings | None = None, *,
                 recording: Recording | None = None, max_pixel_samples: int = 1 << 29):
        self.path = Path(path)
        self.settings = settings = settings or InputSettings()
        self.scene = scene = VideoScene(self.path, upsample=settings.upsample, flow_preset=settings.flow_preset,
                                        black_level=settings.black_level, conditioning=settings.conditioning,
                                        recording=recording)
        self.height, self.width = scene.height, scene.width
        config = AHDRConfig(dvs=sim.DVSParams.preset("davis346"), auto_exposure=False)
        dvs = resolve_sensors(scene, config)[0]
        self.full_illumination = dvs.full_illumination
        # frame DN per unit radiance (integer frames: radiance = (DN - black level) / (full scale - black level))
        self.dn_per_radiance = float((1 << scene.input_bit_depth) - 1) - settings.black_level
        self._input = DVSInput(scene, config, dvs)
        images, times = self._input.warm_up()
        self.n_warm_up = len(images)
        limit = max(2, max_pixel_samples // (self.height * self.width))
        times = list(times)
        for t, img in self._input.sampler():
            if len(times) >= limit:
                raise sim.EvsimInputError(f"{self.path}: more than {limit} DVS input samples; shorten the "
                                          "recording or raise max_pixel_samples")
            times.append(int(t))
            images.append(img)
        self.times_us = np.asarray(times, np.int64)  # scene time (the warm-up's negative)
        self.radiance = np.stack(images)
        self.time_origin_us = scene.time_origin_us

    def offset_dn(self, dvs: sim.DVSParams) -> float:
        """The log offset b of `dvs` in frame DN (the pixel responds to log(DN - black level + b)).

        Parameters
        ----------
        dvs : sim.DVSParams
            The sensor (its dark_fraction).

        Returns
        -------
        float
            b in frame DN.
        """
        return dvs.dark_fraction * self.full_illumination * self.dn_per_radiance

    def dark_fraction(self, offset_dn: float) -> float:
        """DVSParams.dark_fraction of a log offset in frame DN (the inverse of offset_dn).

        Parameters
        ----------
        offset_dn : float
            The log offset b in frame DN.

        Returns
        -------
        float
            The dark fraction (relative to this input's full illumination).
        """
        return offset_dn / self.dn_per_radiance / self.full_illumination

    def params(self, dvs: sim.DVSParams) -> sim.DVSParams:
        """dvs with this input's full illumination (what convert's auto illumination gives).

        Parameters
        ----------
        dvs : sim.DVSParams
            The sensor.

        Returns
        -------
        sim.DVSParams
            The same sensor with full_illumination resolved on this input.
        """
        return dvs.replace(full_illumination=self.full_illumination)

    def simulate(self, dvs: sim.DVSParams, seed: int | np.random.SeedSequence = 0) -> np.ndarray:
        """The events of sensor `dvs` on this input.

        Parameters
        ----------
        dvs : sim.DVSParams
            The sensor (its full illumination replaced by this input's).
        seed : int or numpy.random.SeedSequence
            The simulation's seed.

        Returns
        -------
        numpy.ndarray
            sim.EVENT_DTYPE events, times in the recording's time base (the warm-up's dropped).
        """
        events = sim.emulate(self.radiance, self.times_us, self.params(dvs), seed)
        return self._input.scene_events(events)[0]
