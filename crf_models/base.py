"""The CRF base class: clipping, inverse, certainty (eq. 4), weighting (eq. 5) and frame variance (eq. 6).

Conventions (shared by every curve):
- x: normalised scaled irradiance, x >= 0. x = 1 is the top of the curve's input range (full well for the LDR
  camera); curves are constant (clipped) above their invertible range and, where stated, below it.
- y: normalised response in [0, 1]; a camera's digital number is DN = round(y * (2**bits - 1)).
- The invertible range is [x_lo, x_hi] with responses [y_lo, y_hi]; forward() is strictly increasing on it.

References (docs/models/references.md): Wang et al. 2021 [Wang2021], the AKF paper (equations 4-6); Robertson
et al. 1999 [Robertson1999] and 2003 [Robertson2003], the "robertson" weighting.
"""

from __future__ import annotations

import math
import numbers
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    #: what the curves' elementwise methods return: float64 values of the input's shape, a numpy float64 scalar
    #: (not a 0-d array) for a scalar input
    FloatValues = npt.NDArray[np.float64] | np.float64

#: the weighting rules f^w of CRF.weight: "derivative" (certainty of the response, eq. 5 of the AKF paper) and
#: "robertson" (a Gaussian weight of the 8-bit response, as the AKF authors' code uses)
WEIGHTINGS = ("derivative", "robertson")

# Response grid on which the certainty's normalising slope is searched (see CRF._max_slope).
_SLOPE_GRID = 1024


class CRFError(ValueError):
    """Bad input to a camera response function: parameters, tables, files or values out of the domain."""


def real_param(name: str, value: object) -> float:
    """A curve parameter as a float; CRFError naming it unless it is a finite real number (an int, float or numpy
    number; not a bool, a string or complex). Ranges are each curve's to check.

    Parameters
    ----------
    name : str
        The parameter's name, for the error message.
    value : object
        Its value.

    Returns
    -------
    float
        The value as a float.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise CRFError(f"{name} must be a finite number, got {type(value).__name__} {value!r:.60}")
    return float(value)


def as_float_array(values: npt.ArrayLike, name: str) -> npt.NDArray[np.float64]:
    """values as a float64 array; raises CRFError on NaN or infinity.

    Parameters
    ----------
    values : array_like
        The values.
    name : str
        Their name, for the error message.

    Returns
    -------
    numpy.ndarray
        float64 array of the values' shape.
    """
    arr = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise CRFError(f"{name} contains NaN or infinite values")
    return arr


def numerical_derivative(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, lo: float, hi: float,
                         step: float = 1e-6) -> np.ndarray:
    """Central difference of f at x with absolute step `step` times the range width, one-sided at the ends.

    Parameters
    ----------
    f : callable
        Elementwise function of a float64 array, defined on [lo, hi].
    x : numpy.ndarray
        Where to differentiate, in [lo, hi].
    lo, hi : float
        The domain of f; the difference points are clipped to it.
    step : float, optional
        Step as a fraction of hi - lo (default 1e-6).

    Returns
    -------
    numpy.ndarray
        df/dx at x, of x's shape.
    """
    h = step * (hi - lo)
    a = np.clip(x - h, lo, hi)
    b = np.clip(x + h, lo, hi)
    return (f(b) - f(a)) / (b - a)


class CRF(ABC):
    """A monotone camera response function y = CRF(x).

    Subclasses define the curve on its invertible range through _f, _finv and _df, call _set_range() at the
    end of __init__, and return their constructor arguments from _own_params() (JSON-serialisable) so that
    crf_models.get(crf.name, **crf.params) rebuilds the same curve.

    Parameters
    ----------
    weighting : {"derivative", "robertson"}, optional
        The weighting rule f^w (WEIGHTINGS). "derivative" (default): f^w = certainty o inverse, eq. 5 of Wang et
        al. 2021 [Wang2021]. "robertson": w = exp(-4 (z - 127.5)^2 / 127.5^2) with z = 255 y, the Gaussian-shaped
        weight of Robertson, Borman and Stevenson 1999/2003 [Robertson1999] [Robertson2003], the classic weight
        used by the AKF authors' code.
    """

    name: str = ""

    def __init__(self, *, weighting: str = "derivative") -> None:
        if weighting not in WEIGHTINGS:
            raise CRFError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
        self.weighting = weighting

    # --- to implement -------------------------------------------------------------------------------------
    @abstractmethod
    def _f(self, x: np.ndarray) -> np.ndarray:
        """The curve on [x_lo, x_hi]."""

    @abstractmethod
    def _finv(self, y: np.ndarray) -> np.ndarray:
        """Its inverse on [y_lo, y_hi]."""

    def _df(self, x: np.ndarray) -> np.ndarray:
        """dy/dx on [x_lo, x_hi]; by default a central difference of the exact curve (relative step 1e-6)."""
        return numerical_derivative(self._f, x, self.x_lo, self.x_hi)

    @abstractmethod
    def _own_params(self) -> dict:
        """Constructor arguments other than weighting."""

    # --- shared machinery ---------------------------------------------------------------------------------
    def _set_range(self, x_lo: float, x_hi: float, clip_low: bool, clip_high: bool = True) -> None:
        """Record the invertible range; clip_low/clip_high say whether the curve is flat beyond each end
        (x_lo = 0 with clip_low False: the curve starts at x = 0 and nothing lies below)."""
        if not 0.0 <= x_lo < x_hi < np.inf:
            raise CRFError(f"invertible range must satisfy 0 <= x_lo < x_hi < inf, got [{x_lo}, {x_hi}]")
        self.x_lo, self.x_hi = float(x_lo), float(x_hi)
        self.clip_low, self.clip_high = bool(clip_low), bool(clip_high)
        self.y_lo = float(self._f(np.array([x_lo]))[0])
        self.y_hi = float(self._f(np.array([x_hi]))[0])
        if not 0.0 <= self.y_lo < self.y_hi <= 1.0 + 1e-12:
            raise CRFError(f"{self.name}: responses must increase within [0, 1], got [{self.y_lo}, {self.y_hi}]")
        self._slope_max = self._max_slope()

    def _max_slope(self) -> float:
        """Largest finite slope over bin centres of a 1024-step grid in x and one in y.

        Curves whose slope is unbounded at x = 0 (pure gamma, HLG) are thereby normalised by the slope at
        the first response bin, and certainty() is capped at 1.
        """
        u = (np.arange(_SLOPE_GRID) + 0.5) / _SLOPE_GRID
        xs = np.concatenate([self.x_lo + u * (self.x_hi - self.x_lo),
                             self._finv(self.y_lo + u * (self.y_hi - self.y_lo))])
        d = self._df(np.clip(xs, self.x_lo, self.x_hi))
        d = d[np.isfinite(d)]
        if d.size == 0 or d.max() <= 0:
            raise CRFError(f"{self.name}: the curve has no positive finite slope")
        return float(d.max())

    @property
    def params(self) -> dict[str, Any]:
        """JSON-serialisable constructor arguments: crf_models.get(crf.name, **crf.params) rebuilds the curve."""
        return {**self._own_params(), "weighting": self.weighting}

    def forward(self, x: npt.ArrayLike) -> FloatValues:
        """Response y in [0, 1] of normalised scaled irradiance x >= 0 (clipped outside [x_lo, x_hi]).

        Parameters
        ----------
        x : array_like
            Normalised scaled irradiance, >= 0 (x = 1: the top of the curve's input range); NaN raises CRFError.

        Returns
        -------
        numpy.ndarray or numpy.float64
            Normalised response y in [0, 1], float64 of x's shape (a numpy scalar for a scalar x).
        """
        x = np.asarray(x, dtype=np.float64)
        if not np.all(x >= 0):
            raise CRFError("forward: x must be >= 0 and not NaN")
        return self._f(np.clip(x, self.x_lo, self.x_hi))

    def inverse(self, y: npt.ArrayLike) -> FloatValues:
        """Scaled irradiance x of response y in [0, 1]; responses in a clipped range give the range's edge
        (y <= y_lo -> x_lo, y >= y_hi -> x_hi).

        Parameters
        ----------
        y : array_like
            Normalised response in [0, 1]; values outside (or NaN) raise CRFError.

        Returns
        -------
        numpy.ndarray or numpy.float64
            Normalised scaled irradiance x in [x_lo, x_hi], float64 of y's shape.
        """
        y = np.asarray(y, dtype=np.float64)
        if not np.all((y >= 0) & (y <= 1)):
            raise CRFError("inverse: y must lie in [0, 1] and not be NaN")
        return self._finv(np.clip(y, self.y_lo, self.y_hi))

    def derivative(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """dCRF/dx; 0 where the curve is clipped (x < x_lo with clip_low, x > x_hi).

        Parameters
        ----------
        x : array_like
            Normalised scaled irradiance, >= 0.

        Returns
        -------
        numpy.ndarray
            dy/dx (response per unit of x), float64 of x's shape.
        """
        x = np.asarray(x, dtype=np.float64)
        if not np.all(x >= 0):
            raise CRFError("derivative: x must be >= 0 and not NaN")
        inside = (x <= self.x_hi) & ((x >= self.x_lo) | ~self.clip_low)
        return np.where(inside, self._df(np.clip(x, self.x_lo, self.x_hi)), 0.0)

    def certainty(self, x: npt.ArrayLike) -> FloatValues:
        """f^c (eq. 4): dCRF/dx normalised to a maximum of 1 (capped at 1, see _max_slope).

        Parameters
        ----------
        x : array_like
            Normalised scaled irradiance, >= 0.

        Returns
        -------
        numpy.ndarray or numpy.float64
            Certainty in [0, 1], float64 of x's shape.
        """
        return np.minimum(self.derivative(x) / self._slope_max, 1.0)

    def weight(self, y: npt.ArrayLike) -> FloatValues:
        """f^w(y) (eq. 5) for normalised responses y in [0, 1].

        "derivative": certainty(inverse(y)), and exactly 0 at a clipped level (y <= y_lo when clip_low,
        y >= y_hi when clip_high) because such a response stands for a whole range of irradiance.
        "robertson": exp(-4 (z - 127.5)^2 / 127.5^2), z = 255 y.

        Parameters
        ----------
        y : array_like
            Normalised response in [0, 1]; values outside (or NaN) raise CRFError.

        Returns
        -------
        numpy.ndarray or numpy.float64
            Weight in [0, 1], float64 of y's shape.
        """
        y = np.asarray(y, dtype=np.float64)
        if not np.all((y >= 0) & (y <= 1)):
            raise CRFError("weight: y must lie in [0, 1] and not be NaN")
        if self.weighting == "robertson":
            z = 255.0 * y
            return np.exp(-4.0 * (z - 127.5) ** 2 / 127.5**2)
        yc = np.clip(y, self.y_lo, self.y_hi)
        w = np.minimum(self._df(self._finv(yc)) / self._slope_max, 1.0)
        clipped = y >= self.y_hi
        if self.clip_low:
            clipped |= y <= self.y_lo
        return np.where(clipped, 0.0, w)

    def variance(self, y: npt.ArrayLike, sigma_im2: float, max_variance: float) -> npt.NDArray[np.float64]:
        """Frame variance Rbar (eq. 6) = sigma_im2 / f^w(y), saturated at max_variance (also where f^w = 0).

        Parameters
        ----------
        y : array_like
            Normalised response in [0, 1].
        sigma_im2 : float
            The base variance sigma_im^2 of eq. 6, > 0.
        max_variance : float
            The saturation value, > 0 (same units).

        Returns
        -------
        numpy.ndarray
            Rbar, float64 of y's shape, in (0, max_variance].
        """
        if not (np.isfinite(sigma_im2) and sigma_im2 > 0):
            raise CRFError(f"sigma_im2 must be a positive finite number, got {sigma_im2}")
        if not (np.isfinite(max_variance) and max_variance > 0):
            raise CRFError(f"max_variance must be a positive finite number, got {max_variance}")
        w = self.weight(y)
        big = w * max_variance <= sigma_im2
        return np.where(big, max_variance, sigma_im2 / np.where(big, 1.0, w))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items() if not isinstance(v, list))
        return f"{type(self).__name__}({args})"
