"""What every scene shares: size and duration checks, the time-range check, and a JSON description."""

from __future__ import annotations

import functools
import math

import numpy as np

from sim import EvsimInputError, InvalidParameterError
from sim.errors import check_int, check_number, check_real


class Scene:
    """Base of the radiance sources in this package (they implement sim.source.RadianceSource).

    Subclasses set height, width, duration_us (via _init_size) and implement _render(t_us) returning linear
    radiance; radiance(t_us) checks the time and the output. describe() gives a JSON-serialisable dict for metadata.
    """

    height: int
    width: int
    duration_us: int
    #: True for a scene whose renders are finite by construction, its inputs checked where they enter (a video's
    #: frames as they are decoded): radiance() then skips its pass over every image
    renders_finite: bool = False

    def __init_subclass__(cls, **kwargs):
        """Every scene's constructor ends with a check that its numeric parameters (_params()) are finite: a NaN
        or infinite speed, size or level would otherwise render NaN radiance (or hang a warp) much later."""
        super().__init_subclass__(**kwargs)
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        @functools.wraps(init)
        def checked_init(self, *args, **kw):
            init(self, *args, **kw)
            if type(self) is cls:
                _check_finite(type(self).__name__, self._params())

        cls.__init__ = checked_init

    def _init_size(self, height: int, width: int, duration_us: int) -> None:
        owner = type(self).__name__
        self.height, self.width = (check_int(f"{owner}: {name}", v, minimum=1, unit="pixels")
                                   for name, v in (("height", height), ("width", width)))
        self.duration_us = check_int(f"{owner}: duration_us", duration_us, minimum=1, unit="microseconds")

    def radiance(self, t_us: int) -> np.ndarray:
        """Linear radiance at a time, checked: finite everywhere.

        Parameters
        ----------
        t_us : int
            Scene time (us), in [0, duration_us]; EvsimInputError outside.

        Returns
        -------
        numpy.ndarray
            float32 (height, width) linear radiance (the scene's radiance units), >= 0.
        """
        self._check_time(t_us)
        img = np.ascontiguousarray(self._render(int(t_us)), dtype=np.float32)
        # NaN (max propagates it) or beyond float32 (3.4e38)
        if not self.renders_finite and img.size and not img.max() < np.inf:
            raise InvalidParameterError(f"{type(self).__name__}: the radiance at t={t_us} us is not finite (NaN, or "
                                        "beyond float32's 3.4e38): check the scene's parameters")
        return img

    def _check_time(self, t_us: int) -> None:
        """EvsimInputError unless t_us is in [0, duration_us]."""
        if not 0 <= t_us <= self.duration_us:
            raise EvsimInputError(
                f"{type(self).__name__}: t_us={t_us} is outside the source's time range [0, {self.duration_us}] us"
            )

    def log_radiance(self, t_us: int) -> np.ndarray:
        """Natural log of radiance(t_us).

        Parameters
        ----------
        t_us : int
            Scene time (us), in [0, duration_us].

        Returns
        -------
        numpy.ndarray
            float64 (height, width) log radiance (log units); -inf where the radiance is exactly zero.
        """
        with np.errstate(divide="ignore"):
            return np.log(self.radiance(t_us).astype(np.float64))

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion of the scene, for the adaptive DVS sampling.

        Returns
        -------
        float
            An upper bound of the speed of any image feature (pixels per second); 0 for a static scene.
        """
        return 0.0

    def describe(self) -> dict:
        """JSON-serialisable description of the scene, recorded in the metadata.

        Returns
        -------
        dict
            "type" (the class name), "height", "width" (pixels), "duration_us" (us) and the parameters that define
            the scene.
        """
        return {"type": type(self).__name__, "height": self.height, "width": self.width,
                "duration_us": self.duration_us, **self._params()}

    def _params(self) -> dict:
        return {}

    def _render(self, t_us: int) -> np.ndarray:
        raise NotImplementedError


def positive(name: str, value: float, owner: str, *, allow_zero: bool = False) -> float:
    """A finite real number (not a bool or a string) > 0 (>= 0 with allow_zero), as a float; InvalidParameterError
    naming owner and parameter otherwise.

    Parameters
    ----------
    name : str
        The parameter's name, for the error message.
    value : float
        The value to check (any unit).
    owner : str
        The scene class, for the error message.
    allow_zero : bool, optional
        Accept 0 too (default False).

    Returns
    -------
    float
        The value.
    """
    return check_number(f"{owner}: {name}", value, positive=not allow_zero)


MAX_RADIANCE = 1e30  # radiance levels (and gains) at most this: rendered in float32 (max 3.4e38) with room to spare


def level(name: str, value: float, owner: str, *, allow_zero: bool = False) -> float:
    """A radiance level or gain: as positive(), and at most MAX_RADIANCE.

    Parameters
    ----------
    name, value, owner, allow_zero
        As positive's (value in radiance units, or a dimensionless gain).

    Returns
    -------
    float
        The value.
    """
    v = positive(name, value, owner, allow_zero=allow_zero)
    if v > MAX_RADIANCE:
        raise InvalidParameterError(f"{owner}: {name} must be at most {MAX_RADIANCE:g} (radiance is rendered in "
                                    f"float32), got {value!r}")
    return v


def number(name: str, value: float, owner: str) -> float:
    """A finite real number of any sign (not a bool or a string), as a float (speeds, angles, positions).

    Parameters
    ----------
    name, value, owner
        As positive's.

    Returns
    -------
    float
        The value.
    """
    return check_real(f"{owner}: {name}", value)


def numbers(name: str, values: tuple[float, ...], owner: str, n: int = 2) -> tuple[float, ...]:
    """A sequence of n finite real numbers (a velocity, a position), as a tuple of floats.

    Parameters
    ----------
    name, owner
        As positive's.
    values : sequence of float
        The numbers to check (any unit).
    n : int, optional
        How many there must be (default 2).

    Returns
    -------
    tuple of float
        The values.
    """
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__") or len(values) != n:
        raise InvalidParameterError(f"{owner}: {name} must be {n} numbers, got {values!r}")
    return tuple(number(f"{name}[{i}]", v, owner) for i, v in enumerate(values))


def _check_finite(owner: str, params, where: str = "") -> None:
    """InvalidParameterError unless every number in a (nested) parameter dict, list or tuple is finite."""
    items = (params.items() if isinstance(params, dict) else enumerate(params) if isinstance(params, (list, tuple))
             else ())
    for k, v in items:
        name = f"{where}.{k}" if where else str(k)
        if isinstance(v, (dict, list, tuple)):
            _check_finite(owner, v, name)
        elif isinstance(v, (float, np.floating)) and not math.isfinite(v):
            raise InvalidParameterError(f"{owner}: {name} must be finite, got {v!r}")
