"""The tuning protocol: a coordinate search that finds a known optimum, maps settings to method options, and
tunes the complementary filter's gain on data where a high gain is known to be right."""

import math

import numpy as np
import pytest

import akf
import evsim_eval
import sim
from evsim_eval.tuning import SEARCH_SPACES, default_setting, describe_setting, setting_options, tune


def test_coordinate_search_finds_the_grid_optimum_of_a_separable_objective():
    calls = []

    def objective(s):
        calls.append(s)
        bound = math.inf if s["max_intensity"] is None else s["max_intensity"]
        return (math.log(s["alpha"]) - math.log(50.0)) ** 2 + (s["contrast_scale"] - 1.25) ** 2 + (bound != 16.0)

    tuned = tune("cf", objective)
    assert tuned.setting == {"alpha": 50.0, "contrast_scale": 1.25, "max_intensity": 16.0}
    assert tuned.objective == pytest.approx(0.0)
    grid = SEARCH_SPACES["cf"]
    assert len(calls) == len({tuple(sorted(c.items())) for c in calls})  # every setting once
    assert len(calls) <= sum(len(v) for v in grid.values())  # one sweep, not the product of the grids
    assert tuned.trials[0][0] == default_setting("cf")  # the untuned method is always a candidate
    assert setting_options("cf", {"max_intensity": None}, 0.2)[1]["max_intensity"] is None  # None: unbounded
    assert describe_setting({"max_intensity": None}) == "bound none"


def test_ties_and_non_finite_objectives_keep_the_defaults():
    tuned = tune("akf", lambda s: 1.0)
    assert tuned.setting == default_setting("akf")
    assert tune("cf", lambda s: math.nan if s["alpha"] > 10 else 1.0).setting == default_setting("cf")
    assert tune("frames", lambda s: 2.0).setting == {}


def test_settings_become_method_options():
    c, opts = setting_options("cf", {"alpha": 50.0, "contrast_scale": 1.25}, (0.2, 0.3), {"crossover_hz": 2.0})
    assert c == pytest.approx((0.25, 0.375)) and opts == {"alpha": 50.0}
    c, opts = setting_options("akf", {"contrast_scale": 0.8, "event_noise_scale": 4.0, "frame_noise_scale": 0.25},
                              0.2, {"leak_rate_hz": 0.1})
    base = akf.AKFParams()
    p = opts["params"]
    assert c == pytest.approx(0.16) and opts["leak_rate_hz"] == 0.1
    assert (p.sigma_proc2, p.sigma_iso2, p.sigma_ref2) == pytest.approx(
        (4 * base.sigma_proc2, 4 * base.sigma_iso2, 4 * base.sigma_ref2))
    assert (p.sigma_im2, p.max_variance) == pytest.approx((base.sigma_im2 / 4, base.max_variance))  # the clip's
    huge = setting_options("akf", {"frame_noise_scale": 1e5}, 0.2)[1]["params"]
    assert huge.sigma_im2 == huge.max_variance == pytest.approx(1e5 * base.sigma_im2)  # max_variance >= sigma_im2
    assert describe_setting({"alpha": 50.0, "contrast_scale": 1.25}) == "alpha=50 rad/s, contrast x1.25"
    # the smoother's own parameters reach its AKFParams; its and the AKF's untuned bound is none, the CF's 1 x
    p = setting_options("aks", {"smoother_drift2": 10.0, "clip_prior_variance": 4.0}, 0.2)[1]["params"]
    assert (p.smoother_drift2, p.clip_prior_variance) == (10.0, 4.0)
    assert default_setting("aks")["max_intensity"] is None and default_setting("akf")["max_intensity"] is None
    assert default_setting("cf")["max_intensity"] == 1.0


def test_tuning_picks_a_high_cf_gain_when_the_events_lie():
    """Frames of a static scene, events of pure noise: the best CF trusts the frames (the highest gain)."""
    rng = np.random.default_rng(0)
    h, w, nf = 8, 8, 6
    frames = np.full((nf, h, w), 128, np.uint8)
    ts = np.arange(nf) * 50_000
    te = ts + 5_000
    n = 3000
    ev = sim.make_events(np.sort(rng.integers(0, ts[-1], n)), rng.integers(0, w, n), rng.integers(0, h, n),
                         rng.choice([-1, 1], n))
    truth = np.full((h, w), 128 / 255)
    times = np.arange(60_000, ts[-1], 20_000)

    def objective(s):
        c, opts = setting_options("cf", s, 0.2)
        out = akf.complementary_filter(ev, frames, ts, te, "linear", times, contrast=c, **opts)
        return float(np.mean([evsim_eval.mse(o, truth) for o in out]))

    assert tune("cf", objective).setting["alpha"] == max(SEARCH_SPACES["cf"]["alpha"])
