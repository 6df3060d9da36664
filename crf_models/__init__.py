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

References (docs/models/references.md): Wang et al. 2021 [Wang2021]; Robertson et al. 2003 [Robertson2003];
Debevec and Malik 1997 [Debevec1997]; Grossberg and Nayar 2003 [Grossberg2003] (DoRF, EMoR) and 2004
[Grossberg2004].
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
    """Names accepted by get() (aliases included), sorted.

    Returns
    -------
    list of str
        The curve names and aliases (e.g. "lut" for "tabulated").
    """
    return sorted([*_REGISTRY, *_ALIASES])


def get(name: str, **params: Any) -> CRF:
    """The curve `name` built with `params` (keyword arguments of its class); raises CRFError when unknown.

    Parameters
    ----------
    name : str
        A name of available() (a curve's ``name``, or an alias).
    **params
        Keyword arguments of the curve's class (e.g. ``gamma=2.2`` for "gamma", ``weighting`` for every curve);
        bad or missing ones raise CRFError.

    Returns
    -------
    CRF
        The curve.
    """
    key = _ALIASES.get(name, name)
    if key not in _REGISTRY:
        raise CRFError(f"unknown CRF {name!r}; available: {', '.join(available())}")
    try:
        return _REGISTRY[key](**params)
    except TypeError as exc:  # unexpected or missing keyword
        raise CRFError(f"bad parameters for CRF {name!r}: {exc}") from exc
