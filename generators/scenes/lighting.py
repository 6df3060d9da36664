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

References (docs/models/references.md): IEEE Std 1789-2015 [IEEE1789].
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
    """The flicker's parameters checked; InvalidParameterError naming owner and the parameter otherwise.

    Parameters
    ----------
    flicker_hz : float, optional
        Flicker frequency (Hz, > 0; default 100: 50 Hz mains).
    depth : float, optional
        Percent flicker as a fraction, in [0, 1) (default 0.2).
    phase_rad : float, optional
        Phase at t = 0 (radians, finite; default 0).
    rise_fraction : float, optional
        The share of the period in which the light rises, in [0.05, 0.95] (default 0.5: a cosine).
    owner : str, optional
        Who takes them, for the error messages (default "lighting").

    Returns
    -------
    tuple of float
        (flicker_hz, depth, phase_rad, rise_fraction).
    """
    depth = number("depth", depth, owner)
    if not 0 <= depth < 1:
        raise InvalidParameterError(f"{owner}: depth must be in [0, 1), got {depth!r}")
    rise = number("rise_fraction", rise_fraction, owner)
    if not 0.05 <= rise <= 0.95:
        raise InvalidParameterError(f"{owner}: rise_fraction must be in [0.05, 0.95], got {rise_fraction!r}")
    return positive("flicker_hz", flicker_hz, owner), depth, number("phase_rad", phase_rad, owner), rise


def flicker_gain(t_us: npt.ArrayLike, flicker_hz: float, depth: float, phase_rad: float = 0.0,
                 rise_fraction: float = 0.5) -> np.ndarray:
    """1 + depth w(t): the light relative to its mean (see the module).

    Parameters
    ----------
    t_us : array_like
        Scene times (us; an array or a scalar).
    flicker_hz, depth, phase_rad, rise_fraction
        As checked_lighting's (Hz, fraction, radians, fraction).

    Returns
    -------
    numpy.ndarray
        float64 gain (dimensionless, mean 1) at each time, of t_us's shape.
    """
    cycle = (flicker_hz * np.asarray(t_us, np.float64) * 1e-6 + phase_rad / (2 * math.pi)) % 1.0  # 0 at the peak
    fall = 1.0 - rise_fraction
    w = np.where(cycle < fall, np.cos(math.pi * cycle / fall),
                 -np.cos(math.pi * (cycle - fall) / rise_fraction))
    return 1.0 + depth * w


class FlickerLighting(Scene):
    """`scene` lit by a lamp whose light is 1 + depth w(t) times its mean (see the module).

    Parameters
    ----------
    scene : Scene
        The scene under the lamp (its radiance at the lamp's mean).
    flicker_hz : float, optional
        Flicker frequency (Hz, > 0; 100 for 50 Hz mains, the default, 120 for 60 Hz).
    depth : float, optional
        Percent flicker as a fraction, in [0, 1) (default 0.2).
    phase_rad : float, optional
        Phase at t = 0 (radians; default 0).
    rise_fraction : float, optional
        The share of the period in which the light rises, in [0.05, 0.95] (default 0.5: a cosine).
    """

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
        """The light's level at a time, relative to its mean: 1 + depth w(t) (see the module).

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        float
            The gain (dimensionless, mean 1).
        """
        return float(flicker_gain(t_us, self.frequency, self.depth, self.phase, self.rise))

    def _render(self, t_us: int) -> np.ndarray:
        return self.scene.radiance(t_us) * np.float32(self.gain(t_us))

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion: the lit scene's (light moves nothing).

        Returns
        -------
        float
            scene.max_speed_px_per_s() (pixels per second).
        """
        return self.scene.max_speed_px_per_s()

    def max_frequency_hz(self) -> float:
        """The highest temporal frequency of the radiance, for the adaptive DVS sampling.

        Returns
        -------
        float
            That of the flicker's shorter half cosine (Hz; flicker_hz at rise_fraction 0.5, 0 at depth 0), or the
            scene's own if higher.
        """
        own = getattr(self.scene, "max_frequency_hz", None)
        flicker = self.frequency / (2 * min(self.rise, 1 - self.rise)) if self.depth > 0 else 0.0
        return max(flicker, float(own()) if own is not None else 0.0)

    def describe(self) -> dict:
        """The scene's description with a `lighting` entry.

        Returns
        -------
        dict
            scene.describe() and "lighting": flicker_hz (Hz), depth, phase_rad (radians), rise_fraction.
        """
        return {**self.scene.describe(), "lighting": self._params()}

    def _params(self) -> dict:
        return {"flicker_hz": self.frequency, "depth": self.depth, "phase_rad": self.phase,
                "rise_fraction": self.rise}
