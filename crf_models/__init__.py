"""Camera response functions: forward, inverse, derivative, certainty/weighting and frame variance.

crf_models.get(name, **params) builds a curve; crf_models.available() lists the names. Every curve maps
normalised scaled irradiance x >= 0 (x = 1: top of the input range, e.g. full well) to a normalised response
y in [0, 1] (DN / (2**bits - 1)); see base.py for the shared semantics. This package imports nothing else of
the project.

Exports:
- the registry: get, available;
- the base class: CRF, CRFError, WEIGHTINGS (the names of the weighting rules);
- curves: LinearCRF, GammaCRF, SigmoidCRF, FilmicCRF (closed form); SRGBCRF, BT709CRF, HLGCRF, LogC3CRF,
  SLog3CRF (colour-science transfer curves); WindowCRF (the AKF paper's AHDR window); TabulatedCRF (a LUT);
- measured curves: load_dorf (DoRF), load_emor (EMoR), break_ties, recover_debevec (from an exposure stack).

References (full citations also in docs/models/references.md):

- Wang Z, Ng Y, Scheerlinck C, Mahony R (2021). An asynchronous Kalman filter for hybrid event cameras.
  IEEE/CVF International Conference on Computer Vision (ICCV), 448-457, and its supplementary material.
  arXiv:2012.05590
- Robertson MA, Borman S, Stevenson RL (2003). Estimation-theoretic approach to dynamic range enhancement
  using multiple exposures. Journal of Electronic Imaging 12(2):219-228. doi:10.1117/1.1557695
- Debevec PE, Malik J (1997). Recovering high dynamic range radiance maps from photographs. Proceedings of
  ACM SIGGRAPH 97, 369-378. doi:10.1145/258734.258884
- Grossberg MD, Nayar SK (2003). What is the space of camera response functions? IEEE Computer Society
  Conference on Computer Vision and Pattern Recognition (CVPR), vol. 2. (DoRF, EMoR.)
- Grossberg MD, Nayar SK (2004). Modeling the space of camera response functions. IEEE Transactions on
  Pattern Analysis and Machine Intelligence 26(10):1272-1282.
"""

from __future__ import annotations

from typing import Any

from .analytic import FilmicCRF, GammaCRF, LinearCRF, SigmoidCRF
from .base import CRF, WEIGHTINGS, CRFError
from .colour_curves import BT709CRF, HLGCRF, SRGBCRF, LogC3CRF, SLog3CRF
from .recovery import recover_debevec
from .tabulated import TabulatedCRF, break_ties, load_dorf, load_emor
from .window import WindowCRF

__all__ = [
    "available", "get",
    "CRF", "CRFError", "WEIGHTINGS",
    "LinearCRF", "GammaCRF", "SigmoidCRF", "FilmicCRF",
    "SRGBCRF", "BT709CRF", "HLGCRF", "LogC3CRF", "SLog3CRF",
    "WindowCRF", "TabulatedCRF",
    "load_dorf", "load_emor", "break_ties", "recover_debevec",
]

_REGISTRY = {
    cls.name: cls
    for cls in (
        LinearCRF, GammaCRF, SRGBCRF, BT709CRF, HLGCRF, LogC3CRF, SLog3CRF,
        SigmoidCRF, FilmicCRF, WindowCRF, TabulatedCRF,
    )
}
_ALIASES = {"lut": "tabulated"}


def available() -> list[str]:
    """Names accepted by get() (aliases included), sorted."""
    return sorted([*_REGISTRY, *_ALIASES])


def get(name: str, **params: Any) -> CRF:
    """The curve `name` built with `params` (keyword arguments of its class); raises CRFError when unknown."""
    key = _ALIASES.get(name, name)
    if key not in _REGISTRY:
        raise CRFError(f"unknown CRF {name!r}; available: {', '.join(available())}")
    try:
        return _REGISTRY[key](**params)
    except TypeError as exc:  # unexpected or missing keyword
        raise CRFError(f"bad parameters for CRF {name!r}: {exc}") from exc
