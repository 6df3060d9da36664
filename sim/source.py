"""The radiance-source protocol: what both sensor models sample.

Scenes in generators/ implement it; the sensors depend only on this protocol, never on generators.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["RadianceSource"]


@runtime_checkable
class RadianceSource(Protocol):
    """A linear-radiance video defined at every integer microsecond in [0, duration_us].

    radiance(t_us) gives a float32 (height, width) array, linear radiance (any scale), finite and >= 0;
    max_speed_px_per_s() an upper bound of image-plane motion in pixels per second over the whole source (0 for
    static or flicker-only sources), used to choose how many sub-frames a blurred exposure needs.

    Optional: max_frequency_hz(), the highest temporal frequency of the radiance that is not motion (a flickering
    light); an exposure then takes at least sim.camera.SUBFRAMES_PER_PERIOD sub-frames per period of it. And
    offset_log(t_us, offset), float32 log(radiance + offset), with has_log_at(offset), whether the source holds it
    without an exp (a scene that interpolates in log space, generators' VideoScene): at the DVS's dark level,
    generation then feeds it to DVSEmulator.feed_log, which needs no log.

    Attributes
    ----------
    height, width : int
        Image size in pixels.
    duration_us : int
        Length of the source in microseconds.
    """

    height: int
    width: int
    duration_us: int

    def radiance(self, t_us: int) -> np.ndarray:
        """The radiance at one time.

        Parameters
        ----------
        t_us : int
            Time, integer microseconds in [0, duration_us].

        Returns
        -------
        numpy.ndarray
            float32 (height, width) linear radiance (any scale), finite and >= 0.
        """
        ...

    def max_speed_px_per_s(self) -> float:
        """An upper bound of image-plane motion over the whole source.

        Returns
        -------
        float
            Pixels per second (0 for static or flicker-only sources).
        """
        ...
