"""The Poisson interval of the realism score's noise-rate ratios (evsim_eval.realism.comparison.noise_ratio_interval)
against ground truth: it is the known Poisson interval of a small count, and pairs of Poisson counts drawn with a
known rate ratio fall inside it at least 95 % of the time (Clopper-Pearson is conservative)."""

from __future__ import annotations

import numpy as np
import pytest

from evsim_eval.realism.comparison import noise_ratio_interval


def test_a_count_of_two_is_known_only_to_a_factor_of_thirty():
    # against a count so large that it is exact, the ratio's interval is the 95 % Poisson interval of 2 real events,
    # 0.242-7.22 (Garwood 1936), inverted
    lo, hi = noise_ratio_interval(10 ** 7, 2)
    assert lo == pytest.approx(1e7 / 7.2247, rel=1e-3) and hi == pytest.approx(1e7 / 0.2422, rel=1e-3)
    lo, hi = noise_ratio_interval(5, 2)  # the road's quiet OFF counts before the signal reach: x2.5
    assert lo < 0.5 and hi > 2 * 2.5  # neither "within 2x" nor its opposite is decided by them
    assert noise_ratio_interval(0, 0) == (0.0, float("inf"))
    lo, hi = noise_ratio_interval(5, 0)  # (0.025 ** (1 / 5) = p at the lower bound)
    assert lo == pytest.approx(0.025 ** 0.2 / (1 - 0.025 ** 0.2)) and hi == float("inf")


@pytest.mark.parametrize("mean_real, ratio", [(1.0, 1.0), (3.0, 1.0), (3.0, 2.0), (20.0, 0.5)])
def test_the_interval_covers_the_true_ratio_at_least_95_percent_of_the_time(mean_real, ratio):
    rng = np.random.default_rng(7)
    n = 4000
    real, sim = rng.poisson(mean_real, n), rng.poisson(mean_real * ratio, n)
    covered = np.mean([lo <= ratio <= hi for lo, hi in (noise_ratio_interval(int(s), int(r))
                                                         for s, r in zip(sim, real))])
    assert covered >= 0.95 - 3 * np.sqrt(0.95 * 0.05 / n)
