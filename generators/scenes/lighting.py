"""Any scene under flickering light: the mains flicker of fluorescent and LED lamps, which event cameras record.

A lamp on an AC supply of 50 (60) Hz modulates its light at twice that, 100 (120) Hz, by a depth that ranges from
a few percent (good LED drivers) to nearly 100 % (magnetic-ballast fluorescent tubes; IEEE Std 1789-2015 calls
2 depth / (1 + depth) the "percent flicker" of such a waveform). A DVS pixel sees every pixel of the scene
change by log(1 + depth cos(...)) in step: bursts of ON and OFF events twice per mains cycle over the whole
picture, as in the DAVIS346 lab recording of ../shared/data/events/davis346_lab (its event rate peaks every
10 ms). FlickerLighting multiplies a scene's radiance by 1 + depth cos(2 pi frequency_hz t + phase_rad), t in
seconds of scene time; frames integrate it over their exposures (max_frequency_hz tells the camera how finely
to sample it).

References (full citations also in docs/models/references.md):

- IEEE (2015). IEEE Std 1789-2015, Recommended Practices for Modulating Current in High-Brightness LEDs for
  Mitigating Health Risks to Viewers.
"""

from __future__ import annotations

import math

import numpy as np

from sim import InvalidParameterError

from .base import Scene, number, positive

__all__ = ["FlickerLighting", "LIGHTING_KEYS", "checked_lighting"]

#: the keys of a scene table's `lighting = {...}`
LIGHTING_KEYS = ("flicker_hz", "depth", "phase_rad")


def checked_lighting(flicker_hz: float = 100.0, depth: float = 0.2, phase_rad: float = 0.0, *,
                     owner: str = "lighting") -> tuple[float, float, float]:
    """(flicker_hz, depth, phase_rad) as floats, checked: flicker_hz > 0, depth in [0, 1), phase_rad finite;
    InvalidParameterError naming owner and the parameter otherwise."""
    depth = number("depth", depth, owner)
    if not 0 <= depth < 1:
        raise InvalidParameterError(f"{owner}: depth must be in [0, 1), got {depth!r}")
    return positive("flicker_hz", flicker_hz, owner), depth, number("phase_rad", phase_rad, owner)


class FlickerLighting(Scene):
    """`scene` lit by a lamp whose light is 1 + depth cos(2 pi frequency_hz t + phase_rad) times its mean
    (see the module). depth in [0, 1); frequency_hz > 0 (100 for 50 Hz mains, 120 for 60 Hz)."""

    def __init__(self, scene: Scene, *, frequency_hz: float = 100.0, depth: float = 0.2, phase_rad: float = 0.0):
        self.scene = scene
        self._init_size(scene.height, scene.width, scene.duration_us)
        self.frequency, self.depth, self.phase = checked_lighting(frequency_hz, depth, phase_rad)
        for name in ("time_origin_us", "warm_up_us"):  # a recorded clip's time base and DVS warm-up
            if hasattr(scene, name):
                setattr(self, name, getattr(scene, name))

    def gain(self, t_us: float) -> float:
        """The light's level at scene time t_us, relative to its mean."""
        return 1.0 + self.depth * math.cos(2 * math.pi * self.frequency * t_us * 1e-6 + self.phase)

    def _render(self, t_us: int) -> np.ndarray:
        return self.scene.radiance(t_us) * np.float32(self.gain(t_us))

    def max_speed_px_per_s(self) -> float:
        return self.scene.max_speed_px_per_s()

    def max_frequency_hz(self) -> float:
        """The highest temporal frequency of the radiance (Hz): the flicker's (0 at depth 0), or the scene's own
        if higher."""
        own = getattr(self.scene, "max_frequency_hz", None)
        return max(self.frequency if self.depth > 0 else 0.0, float(own()) if own is not None else 0.0)

    def describe(self) -> dict:
        """The scene's description with a `lighting` entry."""
        return {**self.scene.describe(), "lighting": {"flicker_hz": self.frequency, "depth": self.depth,
                                                      "phase_rad": self.phase}}

    def _params(self) -> dict:
        return {"flicker_hz": self.frequency, "depth": self.depth, "phase_rad": self.phase}
