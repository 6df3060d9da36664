"""One tuning protocol for every method: a small coordinate search over each method's main parameters.

A setting is a dict of the search parameters of SEARCH_SPACES[method]; setting_options() turns it into the
method's contrast and keyword options. tune() starts from DEFAULTS (the untuned method) and, for each parameter in
turn, keeps the value of its grid that minimises the objective with the other parameters at their best so far
(one sweep: sum of the grid sizes runs, not their product); lower is better; ties keep the earlier value.
tune_cases() is the protocol's objective: the mean of one metric over the tuning split of every sequence (each an
evsim_eval.scoring.Case), negated for metrics where higher is better.

Parameters (all multiplicative or in the method's units):
- contrast_scale: multiplies the nominal contrast thresholds (every event-based method).
- alpha: the complementary filter's crossover gain (rad/s); 2 pi 0.5 Hz = 3.14 is the ROS default.
- event_noise_scale: multiplies the AKF's event noise (sigma_proc2, sigma_iso2, sigma_ref2).
- frame_noise_scale: multiplies the AKF's frame noise sigma_im2, the variance of a well-exposed pixel; the
  saturated variance of clipped pixels (max_variance) is the clip's, not noise, and stays (raised to sigma_im2
  if the scaled noise exceeds it), so the mse01 tuning of HDR photos, whose error sits in clipped highlights,
  cannot buy a weaker pull of clipped frames with noisier well-exposed pixels. The frame update's variance is the
  frames' measured read noise (AKFParams.read_noise_dn, akf.frame_noise), a property of the data: not scaled.
- smooth_range: the AKF's output smoothing range sigma (log units; 0: off; see akf.smoothing).
- smoother_drift2: the smoother's growth (log^2 / s) of a carried level's error with the time since its frame
  (AKFParams.smoother_drift2; the smoother only).
- clip_prior_variance: the variance (log^2) the smoother gives the clip prior's level (AKFParams.clip_prior_variance;
  the smoother only).
- max_intensity: the output bound (x units; None: unbounded) of every event-based method that has one: None by
  default for the AKF and the smoother (events tell what lies above the full well), 1 (the full well) for both
  complementary filters; the same grid is searched for each method, last.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from akf.params import AKFParams
from sim.errors import InvalidParameterError

from .metrics import HIGHER_IS_BETTER

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence
    from typing import Protocol

    import numpy.typing as npt

    #: a setting: {search parameter: value}; values are numbers, or None for an unbounded max_intensity
    Setting = dict[str, float | None]

    class _Case(Protocol):
        """What tune_cases needs of an evsim_eval.scoring.Case (not imported here: evsim_eval.scoring imports this
        module)."""

        def run(self, method: str, sel: slice | np.ndarray, setting: Setting | None) -> np.ndarray: ...

        def scores(self, images: np.ndarray, sel: slice | np.ndarray, metrics: Sequence[str]) -> dict[str, float]: ...

__all__ = ["SEARCH_SPACES", "DEFAULTS", "Tuned", "tune", "tune_cases", "setting_options", "default_setting",
           "describe_setting"]

# each grid reaches past the best setting of every method on the AHDR photos and the DAVIS346 road recording, on
# mse01 and on ssim01 (the chosen values are interior; the bound's None, unbounded, is its natural end)
_CONTRAST = (0.4, 0.5, 0.67, 0.8, 1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0)
_ALPHA = (0.3, 1.0, 2 * math.pi * 0.5, 5.0, 15.0, 50.0, 150.0, 500.0)
_NOISE = (1 / 4096, 1 / 256, 1 / 64, 1 / 16, 0.25, 1.0, 4.0, 16.0, 64.0, 256.0, 4096.0)
_BOUND = (0.5, 1.0, 4.0, 16.0, 64.0, None)
_SMOOTH = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0)
_DRIFT = (0.01, 0.1, 1.0, 10.0, 100.0)
_PRIOR_VARIANCE = (1.0, 4.0, 16.0, 64.0, 256.0)
#: method -> {parameter: the grid the tuning searches} (the parameters are listed in the module docstring)
SEARCH_SPACES = {
    "akf": {"contrast_scale": _CONTRAST, "event_noise_scale": _NOISE, "frame_noise_scale": _NOISE,
            "smooth_range": _SMOOTH, "max_intensity": _BOUND},
    "aks": {"contrast_scale": _CONTRAST, "event_noise_scale": _NOISE, "frame_noise_scale": _NOISE,
            "smooth_range": _SMOOTH, "smoother_drift2": _DRIFT, "clip_prior_variance": _PRIOR_VARIANCE,
            "max_intensity": _BOUND},
    "cf": {"alpha": _ALPHA, "contrast_scale": _CONTRAST, "max_intensity": _BOUND},
    "cf_adaptive": {"alpha": _ALPHA, "contrast_scale": _CONTRAST, "max_intensity": _BOUND},
    "direct": {"contrast_scale": _CONTRAST},
    "frames": {},
    "frames_linear": {},
}
#: the untuned value of every search parameter, where the search starts
DEFAULTS = {"contrast_scale": 1.0, "alpha": 2 * math.pi * 0.5, "event_noise_scale": 1.0, "frame_noise_scale": 1.0,
            "smooth_range": AKFParams.smooth_range, "smoother_drift2": AKFParams.smoother_drift2,
            "clip_prior_variance": AKFParams.clip_prior_variance,
            "max_intensity": 1.0}
#: method -> {parameter: its untuned value} where it differs from DEFAULTS
METHOD_DEFAULTS = {"akf": {"max_intensity": None}, "aks": {"max_intensity": None}}


@dataclass(frozen=True)
class Tuned:
    """The chosen setting, its objective, and every (setting, objective) tried, in order.

    Attributes
    ----------
    setting : dict
        {parameter: value} chosen.
    objective : float
        Its objective (lower is better).
    trials : tuple
        Every (setting, objective) tried, in order.
    """

    setting: Setting
    objective: float
    trials: tuple[tuple[Setting, float], ...]


def setting_options(method: str, setting: Setting, contrast: npt.ArrayLike, options: dict[str, Any] | None = None
                    ) -> tuple[float | tuple[float, ...] | npt.NDArray[np.float64], dict[str, Any]]:
    """(contrast, keyword options) of `method` for a setting.

    Parameters
    ----------
    method : str
        An akf.METHODS name.
    setting : dict
        {parameter: value} (DEFAULTS names: contrast_scale, alpha in rad/s, max_intensity in x units, noise scales,
        smooth_range in log units, smoother_drift2 in log^2/s, clip_prior_variance in log^2).
    contrast : array_like
        The method's contrast threshold(s) (log units) before the setting.
    options : dict, optional
        The method's other keywords (an AKF "params" there is the base the noise scales multiply).

    Returns
    -------
    contrast : float, tuple or numpy.ndarray
        The scaled contrast threshold(s), in contrast's form.
    options : dict
        The keyword options with the setting applied.
    """
    options = dict(options or {})
    c = np.asarray(contrast, np.float64) * setting.get("contrast_scale", 1.0)
    if "alpha" in setting:
        options["alpha"] = float(setting["alpha"])
        options.pop("crossover_hz", None)
    if "max_intensity" in setting:
        options["max_intensity"] = setting["max_intensity"]
    if method in ("akf", "aks") and {"event_noise_scale", "frame_noise_scale", "smooth_range",
                                     "smoother_drift2", "clip_prior_variance"} & set(setting):
        p = options.get("params", AKFParams())
        e, f = setting.get("event_noise_scale", 1.0), setting.get("frame_noise_scale", 1.0)
        options["params"] = dataclasses.replace(p, sigma_proc2=p.sigma_proc2 * e, sigma_iso2=p.sigma_iso2 * e,
                                                sigma_ref2=p.sigma_ref2 * e, sigma_im2=p.sigma_im2 * f,
                                                max_variance=max(p.max_variance, p.sigma_im2 * f),
                                                smooth_range=float(setting.get("smooth_range", p.smooth_range)),
                                                smoother_drift2=float(setting.get("smoother_drift2",
                                                                                  p.smoother_drift2)),
                                                clip_prior_variance=float(setting.get("clip_prior_variance",
                                                                                      p.clip_prior_variance)))
    return (float(c) if c.ndim == 0 else tuple(c.tolist()) if c.ndim == 1 else c), options


def _untuned(method: str, parameters) -> Setting:
    """{parameter: the method's untuned value} (METHOD_DEFAULTS, else DEFAULTS) of the named parameters."""
    return {k: METHOD_DEFAULTS.get(method, {}).get(k, DEFAULTS[k]) for k in parameters}


def default_setting(method: str) -> Setting:
    """The untuned setting of a method (its defaults for the searched parameters).

    Parameters
    ----------
    method : str
        An akf.METHODS name.

    Returns
    -------
    dict
        {parameter: value} (empty for a method with nothing to search).
    """
    return _untuned(method, SEARCH_SPACES.get(method, {}))


def tune(method: str, objective: Callable[[Setting], float],
         space: dict[str, Sequence[float | None]] | None = None) -> Tuned:
    """Coordinate search of `method`'s SEARCH_SPACES entry (or `space`). Every setting is evaluated once.

    Parameters
    ----------
    method : str
        An akf.METHODS name.
    objective : callable
        objective(setting) -> float, lower is better (a non-finite value counts as inf).
    space : dict, optional
        {parameter: grid} instead of SEARCH_SPACES[method].

    Returns
    -------
    Tuned
        The best setting, its objective and every trial.
    """
    space = SEARCH_SPACES.get(method, {}) if space is None else space
    unknown = [k for k in space if k not in DEFAULTS]
    if unknown:
        raise InvalidParameterError(f"unknown tuning parameters {unknown}; known: {sorted(DEFAULTS)}")
    best = _untuned(method, space)
    seen = {}

    def value(setting):
        key = tuple(sorted(setting.items()))
        if key not in seen:
            v = float(objective(dict(setting)))
            seen[key] = v if math.isfinite(v) else math.inf
        return seen[key]

    best_v = value(best)
    for name, grid in space.items():
        for v in grid:
            trial = {**best, name: v}
            tv = value(trial)
            if tv < best_v:
                best, best_v = trial, tv
    trials = tuple((dict(k), v) for k, v in seen.items())
    return Tuned(best, best_v, trials)


def tune_cases(method: str, cases: Sequence[_Case], selections: Sequence[slice | np.ndarray], metric: str,
               space: dict[str, Sequence[float | None]] | None = None) -> Tuned:
    """tune() of `method` on the mean of `metric` over cases[i] (evsim_eval.scoring.Case) scored at its times
    [selections[i]]; the Tuned objective is that mean (negated where higher is better).

    Parameters
    ----------
    method : str
        An akf.METHODS name.
    cases : sequence of Case
        The cases.
    selections : sequence of slice or numpy.ndarray
        The scored times of each case to tune on.
    metric : str
        The objective's metric.
    space : dict, optional
        {parameter: grid} instead of SEARCH_SPACES[method].

    Returns
    -------
    Tuned
        The best setting, its objective and every trial.
    """
    sign = -1.0 if metric in HIGHER_IS_BETTER else 1.0

    def objective(setting):
        values = [case.scores(case.run(method, sel, setting), sel, (metric,))[metric]
                  for case, sel in zip(cases, selections)]
        return sign * float(np.mean(values))

    return tune(method, objective, space)


def describe_setting(setting: Setting) -> str:
    """A setting in one line, e.g. 'alpha=50 rad/s, contrast x1.25' ('no parameters' when empty).

    Parameters
    ----------
    setting : dict
        {parameter: value}.

    Returns
    -------
    str
        The description.
    """
    parts = []
    for k, v in setting.items():
        parts.append(f"alpha={v:.3g} rad/s" if k == "alpha" else
                     f"bound {'none' if v is None else f'{v:.3g} x'}" if k == "max_intensity" else
                     f"contrast x{v:.3g}" if k == "contrast_scale" else
                     f"smoothing {v:.3g} log" if k == "smooth_range" else
                     f"smoother drift {v:.3g} log^2/s" if k == "smoother_drift2" else
                     f"clip prior variance {v:.3g} log^2" if k == "clip_prior_variance" else
                     f"{k[:-len('_scale')].replace('_', ' ')} x{v:.3g}")
    return ", ".join(parts) if parts else "no parameters"
