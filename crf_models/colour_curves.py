"""Standard transfer curves from colour-science, normalised to map x in [0, 1] onto y in [0, 1].

y = (enc(x * in_max) - enc(0)) / (enc(in_max) - enc(0)), clipped above x = 1, where enc is the colour-science
encoding and in_max the scene-linear value (in that curve's own units) that x = 1 stands for. For sRGB, BT.709
and HLG in_max = 1 and the normalisation is the identity; for the camera log curves in_max defaults to the value
encoded as code value 1.0, so the whole code range is used. Inverses are colour-science's decodings; derivatives
are central differences of the exact curve (relative step 1e-6, one-sided at the ends).

References (docs/models/references.md): colour-science [Colour]; IEC 61966-2-1 [IEC61966], sRGB; ITU-R
BT.709-6 [BT709]; ITU-R BT.2100-2 [BT2100], hybrid log-gamma; ARRI 2012 [ARRI2012], LogC3; Sony S-Log3
[SLog3].
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from .base import CRF, CRFError, real_param


def _models():
    """colour.models, imported on first use: importing colour-science costs seconds (it pulls in matplotlib)."""
    with warnings.catch_warnings():
        # colour-science warns at import when matplotlib (an optional extra here) is absent; nothing here plots.
        warnings.filterwarnings("ignore", message='"Matplotlib" related API features are not available')
        import colour
    return colour.models


_SRGB_LINEAR_TOE = 0.0031308  # IEC 61966-2-1: the linear value where the toe of slope 12.92 ends


def _spow(x, p):
    """Sign-preserving power (colour-science's spow): sign(x) |x|^p."""
    return np.sign(x) * np.abs(x) ** p


class _ColourCurve(CRF):
    """Base for the colour-science curves: subclasses provide _encode/_decode on scene-linear values."""

    def _init_curve(self, in_max: float) -> None:
        if not real_param("in_max", in_max) > 0:
            raise CRFError(f"in_max must be a positive finite number, got {in_max}")
        self.in_max = float(in_max)
        self._e0 = float(self._enc(0.0))
        self._e1 = float(self._enc(self.in_max))
        self._set_range(0.0, 1.0, clip_low=False)

    @np.errstate(invalid="ignore", divide="ignore")  # colour evaluates both branches of piecewise curves
    def _enc(self, v):
        return np.asarray(self._encode(v), dtype=np.float64)

    @np.errstate(invalid="ignore", divide="ignore")
    def _dec(self, v):
        return np.asarray(self._decode(v), dtype=np.float64)

    def _f(self, x):
        return (self._enc(x * self.in_max) - self._e0) / (self._e1 - self._e0)

    def _finv(self, y):
        return np.clip(self._dec(self._e0 + y * (self._e1 - self._e0)) / self.in_max, 0.0, 1.0)


class SRGBCRF(_ColourCurve):
    """IEC 61966-2-1 sRGB encoding (linear toe of slope 12.92, then 1.055 x^(1/2.4) - 0.055).

    Parameters
    ----------
    **kw
        ``weighting`` (see CRF).
    """

    name = "srgb"

    # The standard's two formulas, as colour-science evaluates them (eotf_inverse_sRGB, eotf_sRGB; checked against it
    # in tests/test_crf_models.py): the most used curve (convert's input and camera default) imports no colour-science,
    # whose import costs 0.85 s of CPU per process.
    def _encode(self, v):
        v = np.asarray(v, dtype=np.float64)
        return np.where(v <= _SRGB_LINEAR_TOE, v * 12.92, 1.055 * _spow(v, 1 / 2.4) - 0.055)

    def _decode(self, v):
        v = np.asarray(v, dtype=np.float64)
        return np.where(v <= _SRGB_LINEAR_TOE * 12.92, v / 12.92, _spow((v + 0.055) / 1.055, 2.4))

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self._init_curve(1.0)

    def _own_params(self):
        return {}


class BT709CRF(_ColourCurve):
    """ITU-R BT.709 OETF (linear toe of slope 4.5, then 1.099 x^0.45 - 0.099).

    Parameters
    ----------
    **kw
        ``weighting`` (see CRF).
    """

    name = "bt709"
    def _encode(self, v):
        return _models().oetf_BT709(v)

    def _decode(self, v):
        return _models().oetf_inverse_BT709(v)

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self._init_curve(1.0)

    def _own_params(self):
        return {}


class HLGCRF(_ColourCurve):
    """ITU-R BT.2100 Hybrid Log-Gamma OETF (square root below 1/12, logarithmic above).

    Parameters
    ----------
    **kw
        ``weighting`` (see CRF).
    """

    name = "hlg"
    def _encode(self, v):
        return _models().oetf_BT2100_HLG(v)

    def _decode(self, v):
        return _models().oetf_inverse_BT2100_HLG(v)

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self._init_curve(1.0)

    def _own_params(self):
        return {}


class LogC3CRF(_ColourCurve):
    """ARRI LogC3 (ALEXA, SUP 3.x, linear scene exposure factor) at exposure index EI.

    Parameters
    ----------
    EI : int, optional
        Exposure index, one of 160, 200, 250, 320, 400, 500, 640, 800, 1000, 1280, 1600 (default 800).
    in_max : float, optional
        Scene-linear value at x = 1 (default: the value coded as 1.0, about 55.08 at EI 800).
    **kw
        ``weighting`` (see CRF).
    """

    name = "logc3"
    _EIS = (160, 200, 250, 320, 400, 500, 640, 800, 1000, 1280, 1600)

    def __init__(self, EI: int = 800, in_max: float | None = None, **kw: Any) -> None:
        super().__init__(**kw)
        if EI not in self._EIS:
            raise CRFError(f"EI must be one of {self._EIS}, got {EI}")
        self.EI = int(EI)
        self._init_curve(float(self._dec(1.0)) if in_max is None else in_max)

    def _encode(self, v):
        return _models().log_encoding_ARRILogC3(v, EI=self.EI)

    def _decode(self, v):
        return _models().log_decoding_ARRILogC3(v, EI=self.EI)

    def _own_params(self):
        return {"EI": self.EI, "in_max": self.in_max}


class SLog3CRF(_ColourCurve):
    """Sony S-Log3 (normalised code values).

    Parameters
    ----------
    in_max : float, optional
        Scene-linear reflectance at x = 1 (default: the value coded as 1.0, about 38.42).
    **kw
        ``weighting`` (see CRF).
    """

    name = "slog3"
    def _encode(self, v):
        return _models().log_encoding_SLog3(v)

    def _decode(self, v):
        return _models().log_decoding_SLog3(v)

    def __init__(self, in_max: float | None = None, **kw: Any) -> None:
        super().__init__(**kw)
        self._init_curve(float(self._dec(1.0)) if in_max is None else in_max)

    def _own_params(self):
        return {"in_max": self.in_max}
