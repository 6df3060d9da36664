"""Closed-form curves with analytic inverse and derivative: linear (black level, clipping), gamma, sigmoid and
Hable's filmic curve.

References (docs/models/references.md): Hable 2010 [Hable2010], the filmic curve.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .base import CRF, CRFError, real_param


class LinearCRF(CRF):
    """y = black_level + (1 - black_level) * min(x / x_clip, 1): linear ADC counts with an offset, clipped at
    x_clip (the DAVIS APS is close to this). Below x_clip nothing is clipped.

    Parameters
    ----------
    black_level : float, optional
        Response at x = 0, in [0, 1) (default 0).
    x_clip : float, optional
        Normalised irradiance at which the response reaches 1, in (0, 1] (default 1).
    **kw
        ``weighting`` (see CRF).
    """

    name = "linear"

    def __init__(self, black_level: float = 0.0, x_clip: float = 1.0, **kw: Any) -> None:
        super().__init__(**kw)
        black_level, x_clip = real_param("black_level", black_level), real_param("x_clip", x_clip)
        if not 0.0 <= black_level < 1.0:
            raise CRFError(f"black_level must lie in [0, 1), got {black_level}")
        if not 0.0 < x_clip <= 1.0:
            raise CRFError(f"x_clip must lie in (0, 1], got {x_clip}")
        self.black_level, self.x_clip = float(black_level), float(x_clip)
        self._set_range(0.0, self.x_clip, clip_low=False)

    def _f(self, x):
        return self.black_level + (1.0 - self.black_level) * x / self.x_clip

    def _finv(self, y):
        return (y - self.black_level) * self.x_clip / (1.0 - self.black_level)

    def _df(self, x):
        return np.full_like(x, (1.0 - self.black_level) / self.x_clip)

    def _own_params(self):
        return {"black_level": self.black_level, "x_clip": self.x_clip}


class GammaCRF(CRF):
    """y = min(x, 1) ** (1 / gamma). The slope is unbounded at x = 0 when gamma > 1 (see CRF._max_slope).

    Parameters
    ----------
    gamma : float, optional
        The exponent's reciprocal, > 0 (default 2.2).
    **kw
        ``weighting`` (see CRF).
    """

    name = "gamma"

    def __init__(self, gamma: float = 2.2, **kw: Any) -> None:
        super().__init__(**kw)
        if not real_param("gamma", gamma) > 0:
            raise CRFError(f"gamma must be a positive finite number, got {gamma}")
        self.gamma = float(gamma)
        self._set_range(0.0, 1.0, clip_low=False)

    def _f(self, x):
        return x ** (1.0 / self.gamma)

    def _finv(self, y):
        return y**self.gamma

    def _df(self, x):
        with np.errstate(divide="ignore"):
            return x ** (1.0 / self.gamma - 1.0) / self.gamma

    def _own_params(self):
        return {"gamma": self.gamma}


class SigmoidCRF(CRF):
    """A smooth S-curve in linear irradiance: the logistic s(x) = 1 / (1 + exp(-k (x - x0))) rescaled so that
    x = 0 -> 0 and x = 1 -> 1; flat toe and shoulder like the measured CRFs the AKF authors show (their Fig. 2).

    Parameters
    ----------
    steepness : float, optional
        k > 0 (larger: more compressed ends), per unit of x (default 10).
    midpoint : float, optional
        x0 in (0, 1), the normalised irradiance of the steepest slope (default 0.5).
    **kw
        ``weighting`` (see CRF).
    """

    name = "sigmoid"

    def __init__(self, steepness: float = 10.0, midpoint: float = 0.5, **kw: Any) -> None:
        super().__init__(**kw)
        steepness, midpoint = real_param("steepness", steepness), real_param("midpoint", midpoint)
        if not steepness > 0:
            raise CRFError(f"steepness must be a positive finite number, got {steepness}")
        if not 0.0 < midpoint < 1.0:
            raise CRFError(f"midpoint must lie in (0, 1), got {midpoint}")
        self.steepness, self.midpoint = float(steepness), float(midpoint)
        self._s0, self._s1 = self._logistic(0.0), self._logistic(1.0)
        self._set_range(0.0, 1.0, clip_low=False)

    def _logistic(self, x):
        return 1.0 / (1.0 + np.exp(-self.steepness * (np.asarray(x) - self.midpoint)))

    def _f(self, x):
        return (self._logistic(x) - self._s0) / (self._s1 - self._s0)

    def _finv(self, y):
        s = self._s0 + y * (self._s1 - self._s0)
        return np.clip(self.midpoint + np.log(s / (1.0 - s)) / self.steepness, 0.0, 1.0)

    def _df(self, x):
        s = self._logistic(x)
        return self.steepness * s * (1.0 - s) / (self._s1 - self._s0)

    def _own_params(self):
        return {"steepness": self.steepness, "midpoint": self.midpoint}


class FilmicCRF(CRF):
    """Hable's filmic tone curve ("Uncharted 2"), a rational S-curve with a toe and a shoulder:
    h(v) = (v (A v + C B) + D E) / (v (A v + B) + D F) - E / F, y = h(x W) / h(W) for x in [0, 1],
    with the published constants A..F and white point W (x = 1 maps to W).

    Parameters
    ----------
    white_point : float, optional
        W > 0, the curve's input that x = 1 stands for (default 11.2, Hable's).
    **kw
        ``weighting`` (see CRF).
    """

    name = "filmic"
    _A, _B, _C, _D, _E, _F = 0.15, 0.50, 0.10, 0.20, 0.02, 0.30

    def __init__(self, white_point: float = 11.2, **kw: Any) -> None:
        super().__init__(**kw)
        if not real_param("white_point", white_point) > 0:
            raise CRFError(f"white_point must be a positive finite number, got {white_point}")
        self.white_point = float(white_point)
        self._hw = self._h(self.white_point)
        self._set_range(0.0, 1.0, clip_low=False)

    def _h(self, v):
        A, B, C, D, E, F = self._A, self._B, self._C, self._D, self._E, self._F
        return (v * (A * v + C * B) + D * E) / (v * (A * v + B) + D * F) - E / F

    def _f(self, x):
        return self._h(x * self.white_point) / self._hw

    def _finv(self, y):
        # h(v) = t  <=>  (A - A t') v^2 + (C B - B t') v + (D E - D F t') = 0 with t' = t + E / F.
        A, B, C, D, E, F = self._A, self._B, self._C, self._D, self._E, self._F
        t = y * self._hw + E / F
        a, b, c = A * (1.0 - t), B * (C - t), D * (E - F * t)
        # c <= 0 < a: exactly one root v >= 0; pick it with the cancellation-free form of the formula.
        sq = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
        v = np.where(b >= 0, 2.0 * c / np.minimum(-b - sq, -1e-300), (sq - b) / (2.0 * a))
        return np.clip(v / self.white_point, 0.0, 1.0)

    def _df(self, x):
        A, B, C, D, E, F = self._A, self._B, self._C, self._D, self._E, self._F
        v = x * self.white_point
        num, den = v * (A * v + C * B) + D * E, v * (A * v + B) + D * F
        dnum, dden = 2 * A * v + C * B, 2 * A * v + B
        return (dnum * den - num * dden) / den**2 * self.white_point / self._hw

    def _own_params(self):
        return {"white_point": self.white_point}
