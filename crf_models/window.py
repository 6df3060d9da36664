"""The AHDR "window" response of the AKF paper (Wang et al. 2021 [Wang2021], Sec. 6 and supplementary Sec. 4.2).

The authors made their artificial-HDR (AHDR) dataset by taking well-exposed frames of an ordinary RGB camera
and clipping "pixel values higher than 160 or lower than 100 of an 8-bit image". The input to the window is
therefore an already CRF-encoded 8-bit value, so the window sits on top of a base curve: by default a 2.2 gamma
standing in for the camera's display encoding (use base="linear" to window raw linear counts).

y = clip((levels * base(x) - low) / (high - low), 0, 1): the band [low, high] of the base response is stretched
to the full range and everything else is clipped, so f^w vanishes at y = 0 and y = 1 and Rbar saturates there.

References (docs/models/references.md): Wang et al. 2021 [Wang2021].
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .base import CRF, CRFError, real_param


class WindowCRF(CRF):
    """Band [low, high] (on a 0..levels scale of the base response) stretched to [0, 1], the rest clipped.

    Parameters
    ----------
    low, high : float, optional
        The band, 0 <= low < high <= levels, on the base response's 0..levels scale (default 100 and 160, the
        AKF paper's); it must lie within the base curve's responses.
    levels : float, optional
        The scale's top, > 0 (default 255: 8-bit values).
    base : str, optional
        The underlying curve: any registered name except "window" (default "gamma").
    base_params : dict, optional
        Its parameters (default: its defaults).
    **kw
        ``weighting`` (see CRF).
    """

    name = "window"

    def __init__(
        self,
        low: float = 100.0,
        high: float = 160.0,
        levels: float = 255.0,
        base: str = "gamma",
        base_params: dict[str, Any] | None = None,
        **kw: Any,
    ) -> None:
        super().__init__(**kw)
        from . import get  # the registry imports this module

        low, high, levels = (real_param(n, v) for n, v in (("low", low), ("high", high), ("levels", levels)))
        if not levels > 0:
            raise CRFError(f"levels must be a positive finite number, got {levels}")
        if not 0.0 <= low < high <= levels:
            raise CRFError(f"the window must satisfy 0 <= low < high <= levels, got low={low}, high={high}")
        if base == self.name:
            raise CRFError("a window cannot be based on another window")
        self.low, self.high, self.levels = float(low), float(high), float(levels)
        self.base = get(base, **(base_params or {}))
        lo, hi = self.low / self.levels, self.high / self.levels
        if not (self.base.y_lo <= lo and hi <= self.base.y_hi):
            raise CRFError(f"window [{low}, {high}] lies outside the base curve's responses")
        self._set_range(float(self.base.inverse(lo)), float(self.base.inverse(hi)), clip_low=low > 0)

    def _f(self, x):
        return np.clip((self.levels * self.base._f(x) - self.low) / (self.high - self.low), 0.0, 1.0)

    def _finv(self, y):
        return self.base._finv((self.low + y * (self.high - self.low)) / self.levels)

    def _df(self, x):
        return self.levels * self.base._df(x) / (self.high - self.low)

    def _own_params(self):
        return {
            "low": self.low,
            "high": self.high,
            "levels": self.levels,
            "base": self.base.name,
            "base_params": self.base.params,
        }
