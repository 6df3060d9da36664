"""Any scene under flickering light: the mains flicker of fluorescent and LED lamps, which event cameras record.

A lamp on an AC supply of 50 (60) Hz modulates its light at twice that, 100 (120) Hz, by a depth that ranges from
a few percent (good LED drivers) to nearly 100 % (magnetic-ballast fluorescent tubes); depth is IEEE Std
1789-2015's "percent flicker", (max - min) / (max + min), as a fraction. A DVS pixel sees every pixel of the scene
change by log(1 + depth w(t)) in step: bursts of ON and OFF events at the flicker frequency over the whole
picture, as in the DAVIS346 lab recording of ../shared/data/events/davis346_lab (its event rate peaks every
10 ms: a sharp ON burst as the light rises, OFF events spread over its slower fall). FlickerLighting multiplies a
scene's radiance by 1 + depth w(t), w a periodic wave of mean 0 between -1 and 1 that falls from 1 as a half
cosine over a fraction 1 - rise_fraction of the period and rises back as a half cosine over rise_fraction; at
rise_fraction 0.5 it is cos(2 pi flicker_hz t + phase_rad), t in seconds of scene time. Frames integrate it over
their exposures and the DVS input samples it finely (max_frequency_hz: the frequency of the shorter half).

References (full citations also in docs/models/references.md):

- IEEE (2015). IEEE Std 1789-2015, Recommended Practices for Modulating Current in High-Brightness LEDs for
  Mitigating Health Risks to Viewers.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sim import InvalidParameterError

from .base import Scene, number, positive

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = ["FlickerLighting", "LIGHTING_KEYS", "checked_lighting", "flicker_gain"]

#: the keys of a scene table's `lighting = {...}`
LIGHTING_KEYS = ("flicker_hz", "depth", "phase_rad", "rise_fraction")


def checked_lighting(flicker_hz: float = 100.0, depth: float = 0.2, phase_rad: float = 0.0,
                     rise_fraction: float = 0.5, *, owner: str = "lighting") -> tuple[float, float, float, float]:
    """(flicker_hz, depth, phase_rad, rise_fraction) as floats, checked: flicker_hz > 0, depth in [0, 1),
    phase_rad finite, rise_fraction in [0.05, 0.95]; InvalidParameterError naming owner and the parameter
    otherwise."""
    depth = number("depth", depth, owner)
    if not 0 <= depth < 1:
        raise InvalidParameterError(f"{owner}: depth must be in [0, 1), got {depth!r}")
    rise = number("rise_fraction", rise_fraction, owner)
    if not 0.05 <= rise <= 0.95:
        raise InvalidParameterError(f"{owner}: rise_fraction must be in [0.05, 0.95], got {rise_fraction!r}")
    return positive("flicker_hz", flicker_hz, owner), depth, number("phase_rad", phase_rad, owner), rise


def flicker_gain(t_us: npt.ArrayLike, flicker_hz: float, depth: float, phase_rad: float = 0.0,
                 rise_fraction: float = 0.5) -> np.ndarray:
    """1 + depth w(t) at scene times t_us (us; array or scalar): the light relative to its mean (see the module)."""
    cycle = (flicker_hz * np.asarray(t_us, np.float64) * 1e-6 + phase_rad / (2 * math.pi)) % 1.0  # 0 at the peak
    fall = 1.0 - rise_fraction
    w = np.where(cycle < fall, np.cos(math.pi * cycle / fall),
                 -np.cos(math.pi * (cycle - fall) / rise_fraction))
    return 1.0 + depth * w


class FlickerLighting(Scene):
    """`scene` lit by a lamp whose light is 1 + depth w(t) times its mean (see the module). depth in [0, 1);
    flicker_hz > 0 (100 for 50 Hz mains, 120 for 60 Hz); rise_fraction: the share of the period in which the
    light rises (0.5: a cosine)."""

    def __init__(self, scene: Scene, *, flicker_hz: float = 100.0, depth: float = 0.2, phase_rad: float = 0.0,
                 rise_fraction: float = 0.5):
        self.scene = scene
        self._init_size(scene.height, scene.width, scene.duration_us)
        self.frequency, self.depth, self.phase, self.rise = checked_lighting(flicker_hz, depth, phase_rad,
                                                                             rise_fraction)
        for name in ("time_origin_us", "warm_up_us"):  # a recorded clip's time base and DVS warm-up
            if hasattr(scene, name):
                setattr(self, name, getattr(scene, name))

    def gain(self, t_us: float) -> float:
        """The light's level at scene time t_us, relative to its mean: 1 + depth w(t) (see the module)."""
        return float(flicker_gain(t_us, self.frequency, self.depth, self.phase, self.rise))

    def _render(self, t_us: int) -> np.ndarray:
        return self.scene.radiance(t_us) * np.float32(self.gain(t_us))

    def max_speed_px_per_s(self) -> float:
        return self.scene.max_speed_px_per_s()

    def max_frequency_hz(self) -> float:
        """The highest temporal frequency of the radiance (Hz): that of the flicker's shorter half cosine
        (flicker_hz at rise_fraction 0.5; 0 at depth 0), or the scene's own if higher."""
        own = getattr(self.scene, "max_frequency_hz", None)
        flicker = self.frequency / (2 * min(self.rise, 1 - self.rise)) if self.depth > 0 else 0.0
        return max(flicker, float(own()) if own is not None else 0.0)

    def describe(self) -> dict:
        """The scene's description with a `lighting` entry."""
        return {**self.scene.describe(), "lighting": self._params()}

    def _params(self) -> dict:
        return {"flicker_hz": self.frequency, "depth": self.depth, "phase_rad": self.phase,
                "rise_fraction": self.rise}
