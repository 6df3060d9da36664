"""What every scene shares: size and duration checks, the time-range check, and a JSON description."""

from __future__ import annotations

import functools
import math

import numpy as np

from sim import EvsimInputError, InvalidParameterError


class Scene:
    """Base of the radiance sources in this package (they implement sim.source.RadianceSource).

    Subclasses set height, width, duration_us (via _init_size) and implement _render(t_us) returning linear
    radiance; radiance(t_us) checks the time and the output. describe() gives a JSON-serialisable dict for metadata.
    """

    height: int
    width: int
    duration_us: int

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
        for name, v in (("height", height), ("width", width)):
            if int(v) != v or v < 1:
                raise InvalidParameterError(f"{type(self).__name__}: {name} must be a positive integer, got {v!r}")
        if int(duration_us) != duration_us or duration_us < 1:
            raise InvalidParameterError(
                f"{type(self).__name__}: duration_us must be a positive integer (microseconds), got {duration_us!r}"
            )
        self.height, self.width, self.duration_us = int(height), int(width), int(duration_us)

    def radiance(self, t_us: int) -> np.ndarray:
        """Linear radiance at time t_us (microseconds, in [0, duration_us]): float32 (height, width), >= 0."""
        if not 0 <= t_us <= self.duration_us:
            raise EvsimInputError(
                f"{type(self).__name__}: t_us={t_us} is outside the source's time range [0, {self.duration_us}] us"
            )
        img = self._render(int(t_us))
        return np.ascontiguousarray(img, dtype=np.float32)

    def log_radiance(self, t_us: int) -> np.ndarray:
        """Natural log of radiance(t_us) (float64); -inf where the radiance is exactly zero."""
        with np.errstate(divide="ignore"):
            return np.log(self.radiance(t_us).astype(np.float64))

    def max_speed_px_per_s(self) -> float:
        return 0.0

    def describe(self) -> dict:
        """JSON-serialisable description: the class name and the parameters that define the scene."""
        return {"type": type(self).__name__, "height": self.height, "width": self.width,
                "duration_us": self.duration_us, **self._params()}

    def _params(self) -> dict:
        return {}

    def _render(self, t_us: int) -> np.ndarray:
        raise NotImplementedError


def positive(name: str, value: float, owner: str, *, allow_zero: bool = False) -> float:
    """Validate a finite positive (or non-negative) scalar parameter and return it as float."""
    v = float(value)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        need = "non-negative" if allow_zero else "positive"
        raise InvalidParameterError(f"{owner}: {name} must be a finite {need} number, got {value!r}")
    return v


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
