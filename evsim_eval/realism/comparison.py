"""The realism score: the statistics of a simulation set against those of the real recording it imitates.

compare(real, sim) takes two RealismStats measured on the same windows and pixel classes (measure(sim_events,
like=real)) and gives a Comparison: scores (a flat dict, below), the expected deviation of each score from perfect
that the finite number of events alone causes (seed_noise), and notes.

Scores (perfect value in brackets):
- count_ratio, on_ratio, off_ratio [1]: simulated over real events, total and per polarity;
- quiet_on_ratio, quiet_off_ratio, dark_on_ratio, dark_off_ratio [1]: noise rates on quiet / dark static pixels,
  simulated over real (inf when the real rate is 0 and the simulated one is not, NaN when both are 0);
- count_corr, count_corr_blurred [1]: Pearson correlation of the per-pixel event counts (ON + OFF), raw and
  after a 5x5 box blur;
- rate_corr [1] and rate_rel_rmse [0]: correlation and relative RMS error ||sim - real|| / ||real|| of the
  whole-sensor event rate in 10 ms bins;
- interval_l1 [0]: L1 distance sum |p_sim - p_real| (0..2) between the histograms of same-pixel inter-event
  intervals (log bins, normalised to 1);
- passage_median_diff [0]: median events per pixel per passage, simulated minus real;
- flicker_share_ratio [1]: the share of the 1 ms event rate's variance at the real recording's flicker frequency
  (lamps on AC mains; stats module), simulated over real (NaN when the real recording has no flicker).

intervals holds, for the four noise-rate ratios, their exact 95 % interval under Poisson sampling of both counts
(noise_ratio_interval: Clopper-Pearson, conditional on the sum; both rates are over the same pixels and time, so the
rate ratio is the count ratio). A noise rate is often a handful of events (the road recording's quiet OFF rate: 2
real events over 76,489 pixels and 1.92 s), and a ratio of such counts says little: 5 against 2 is x2.5, 95 %
interval 0.41-26. A criterion such as "within 2x" is decided by the counts only when the interval lies inside
[0.5, 2] (met) or outside it (not met).

seed_noise holds, for each score, the deviation from perfect two independent draws of one Poisson process with the
measured counts would show (one standard deviation for ratios and the median; the expected value for the
correlations' shortfall from 1, the RMS error and the L1 distance). Real DVS signal events are less random than
Poisson and a simulation's threshold mismatch is drawn anew per seed, so it is a scale, not a bound.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage

from generators.formats.atomic import write_text_atomic
from sim import EvsimInputError

from .stats import RealismStats

BLUR_PX = 5  # side of the box blur of the blurred per-pixel correlation (pixels)
#: the value of every score for a simulation whose statistics equal the real recording's
PERFECT = {"count_ratio": 1.0, "on_ratio": 1.0, "off_ratio": 1.0, "quiet_on_ratio": 1.0, "quiet_off_ratio": 1.0,
           "dark_on_ratio": 1.0, "dark_off_ratio": 1.0, "count_corr": 1.0, "count_corr_blurred": 1.0,
           "rate_corr": 1.0, "rate_rel_rmse": 0.0, "interval_l1": 0.0, "passage_median_diff": 0.0,
           "flicker_share_ratio": 1.0}
#: the noise-rate ratios, (score, statistic, polarity): each has a Poisson interval (Comparison.intervals)
NOISE_RATIOS = (("quiet_on_ratio", "quiet_counts", 0), ("quiet_off_ratio", "quiet_counts", 1),
                ("dark_on_ratio", "dark_counts", 0), ("dark_off_ratio", "dark_counts", 1))
INTERVAL_LEVEL = 0.95  # of Comparison.intervals


@dataclass
class Comparison:
    """What compare gives (see the module).

    Attributes
    ----------
    real, sim : RealismStats
        The two recordings' statistics.
    scores : dict
        {name: score} (PERFECT: each score's perfect value).
    seed_noise : dict
        {name: value}, how much each score varies with the simulation's seed.
    notes : list of str
        Notes on the comparison.
    intervals : dict
        {name: (low, high)}, the 95 % interval of each noise-rate ratio (NOISE_RATIOS) under Poisson sampling of
        both counts (noise_ratio_interval).
    """

    real: RealismStats
    sim: RealismStats
    scores: dict
    seed_noise: dict
    notes: list = field(default_factory=list)
    intervals: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-serialisable: {"scores", "seed_noise", "intervals", "perfect", "real", "sim", "notes"} (non-finite
        values as strings "inf", "nan").

        Returns
        -------
        dict
            The record.
        """
        return _clean({"scores": self.scores, "seed_noise": self.seed_noise, "intervals": self.intervals,
                       "perfect": PERFECT,
                       "real": self.real.summary(), "sim": self.sim.summary(), "notes": self.notes})


def _ratio(sim: float, real: float) -> float:
    if math.isnan(sim) or math.isnan(real):  # not measured (no pixel classes)
        return float("nan")
    if real > 0:
        return sim / real
    return float("nan") if sim == 0 else float("inf")


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a.ravel().astype(np.float64), b.ravel().astype(np.float64)
    a, b = a - a.mean(), b - b.mean()  # sums of products, not BLAS dot: its threads spin on a busy machine
    den = math.sqrt(float(np.sum(a * a)) * float(np.sum(b * b)))
    return float(np.sum(a * b)) / den if den > 0 else float("nan")


def _blur(counts: np.ndarray) -> np.ndarray:
    return ndimage.uniform_filter(counts.astype(np.float64), size=BLUR_PX, mode="nearest")


def _poisson_corr_shortfall(a: np.ndarray, b: np.ndarray, noise_scale: float = 1.0) -> float:
    """1 - the expected correlation of two Poisson draws of the mean map (a + b) / 2, whose per-element noise
    variance is scaled by noise_scale (1 / 25 after a 5x5 box blur)."""
    m = (a.astype(np.float64) + b) / 2
    noise = noise_scale * float(m.mean())
    signal = max(float(m.var()) - noise / 2, 0.0)
    return noise / (signal + noise) if signal + noise > 0 else float("nan")


def _relative_sd(n_real: int, n_sim: int) -> float:
    return math.sqrt(1 / n_real + 1 / n_sim) if n_real > 0 and n_sim > 0 else float("nan")


def noise_ratio_interval(n_sim: int, n_real: int, level: float = INTERVAL_LEVEL) -> tuple[float, float]:
    """The exact interval of the ratio of two Poisson rates over the same exposure from their counts: given the sum
    n_sim + n_real, n_sim is binomial with p = ratio / (1 + ratio); the Clopper-Pearson interval of p gives the
    ratio's (conservative: it covers the true ratio at least `level` of the time).

    Parameters
    ----------
    n_sim, n_real : int
        The simulated and real counts (events on the same pixels over the same time).
    level : float, optional
        The coverage (default INTERVAL_LEVEL, 0.95).

    Returns
    -------
    tuple of float
        (low, high) of the ratio sim / real; (0, inf) without events.
    """
    from scipy.stats import beta

    a = (1 - level) / 2
    p_lo = float(beta.ppf(a, n_sim, n_real + 1)) if n_sim > 0 else 0.0
    p_hi = float(beta.ppf(1 - a, n_sim + 1, n_real)) if n_real > 0 else 1.0
    return p_lo / (1 - p_lo), (p_hi / (1 - p_hi) if p_hi < 1 else float("inf"))


def _median_sd(passages: np.ndarray) -> float:
    """Standard error of a median, 1.57 IQR / sqrt(n) / 1.96 (McGill, Tukey, Larsen, "Variations of box plots",
    1978)."""
    if passages.size < 2:
        return float("nan")
    q1, q3 = np.percentile(passages, [25, 75])
    return float(1.57 * max(q3 - q1, 1.0) / math.sqrt(passages.size) / 1.96)


def _seed_noise(real: RealismStats, sim: RealismStats) -> dict:
    total = real.counts.sum(axis=0), sim.counts.sum(axis=0)
    p = (real.interval_pdf + sim.interval_pdf) / 2
    n_r, n_s = int(real.interval_counts.sum()), int(sim.interval_counts.sum())
    l1 = (float(np.sum(np.sqrt(2 / math.pi * p * (1 - p) * (1 / n_r + 1 / n_s)))) if n_r and n_s
          else float("nan"))
    rc, sc = real.rate_counts.astype(np.float64), sim.rate_counts.astype(np.float64)
    return {
        "count_ratio": _relative_sd(real.n_events, sim.n_events),
        "on_ratio": _relative_sd(real.n_on, sim.n_on), "off_ratio": _relative_sd(real.n_off, sim.n_off),
        "quiet_on_ratio": _relative_sd(real.quiet_counts[0], sim.quiet_counts[0]),
        "quiet_off_ratio": _relative_sd(real.quiet_counts[1], sim.quiet_counts[1]),
        "dark_on_ratio": _relative_sd(real.dark_counts[0], sim.dark_counts[0]),
        "dark_off_ratio": _relative_sd(real.dark_counts[1], sim.dark_counts[1]),
        "count_corr": _poisson_corr_shortfall(*total),
        "count_corr_blurred": _poisson_corr_shortfall(*total, noise_scale=1 / BLUR_PX ** 2),
        "rate_corr": _poisson_corr_shortfall(rc, sc),
        "rate_rel_rmse": math.sqrt(float((rc + sc).sum()) / float(np.sum(rc * rc))) if rc.any() else float("nan"),
        "interval_l1": l1,
        "passage_median_diff": math.hypot(_median_sd(real.passages), _median_sd(sim.passages)),
        "flicker_share_ratio": float("nan"),  # not modelled
    }


def _flicker_share_at(stats: RealismStats, frequency_hz: float) -> float:
    """stats' flicker share if its flicker is at frequency_hz (within 5 %), else 0."""
    f = stats.flicker_hz
    return stats.flicker_share if math.isfinite(f) and abs(f - frequency_hz) <= 0.05 * frequency_hz else 0.0


def compare(real: RealismStats, sim: RealismStats) -> Comparison:
    """The realism score of sim against real (see the module); both measured on the same windows (measure(...,
    like=real)), else EvsimInputError.

    Parameters
    ----------
    real : RealismStats
        The real recording's statistics.
    sim : RealismStats
        The simulation's, of the same size and windows (relative to each origin).

    Returns
    -------
    Comparison
        The scores, the two statistics and notes.
    """
    if (real.height, real.width) != (sim.height, sim.width):
        raise EvsimInputError(f"the simulation is {sim.width}x{sim.height} pixels, the real recording "
                              f"{real.width}x{real.height}: simulate at the real sensor's size")
    if real.windows_us.shape != sim.windows_us.shape or np.any(
            (real.windows_us - real.origin_us) != (sim.windows_us - sim.origin_us)):
        raise EvsimInputError("the two statistics cover different time windows: measure the simulation with "
                              "measure(events, like=real_stats)")
    total_r, total_s = real.counts.sum(axis=0), sim.counts.sum(axis=0)
    rate_r, rate_s = real.rate_hz, sim.rate_hz
    norm = float(np.sqrt(np.sum(rate_r ** 2)))
    scores = {
        "count_ratio": _ratio(sim.n_events, real.n_events),
        "on_ratio": _ratio(sim.n_on, real.n_on), "off_ratio": _ratio(sim.n_off, real.n_off),
        "quiet_on_ratio": _ratio(sim.quiet_hz[0], real.quiet_hz[0]),
        "quiet_off_ratio": _ratio(sim.quiet_hz[1], real.quiet_hz[1]),
        "dark_on_ratio": _ratio(sim.dark_hz[0], real.dark_hz[0]),
        "dark_off_ratio": _ratio(sim.dark_hz[1], real.dark_hz[1]),
        "count_corr": _corr(total_r, total_s),
        "count_corr_blurred": _corr(_blur(total_r), _blur(total_s)),
        "rate_corr": _corr(rate_r, rate_s),
        "rate_rel_rmse": float(np.sqrt(np.sum((rate_s - rate_r) ** 2))) / norm if norm > 0 else float("nan"),
        "interval_l1": float(np.abs(sim.interval_pdf - real.interval_pdf).sum()),
        "passage_median_diff": sim.passage_median - real.passage_median,
        "flicker_share_ratio": (_flicker_share_at(sim, real.flicker_hz) / real.flicker_share
                                if math.isfinite(real.flicker_hz) else float("nan")),
    }
    notes = [f"real: {n}" for n in real.notes] + [f"simulation: {n}" for n in sim.notes]
    if real.masks is None and not real.notes:
        notes.append("no pixel classes (measured without frames): noise rates and passages are not scored")
    intervals = {name: noise_ratio_interval(getattr(sim, counts)[pol], getattr(real, counts)[pol])
                 for name, counts, pol in NOISE_RATIOS if real.masks is not None}
    return Comparison(real, sim, scores, _seed_noise(real, sim), notes, intervals)


# ----- the table and the JSON file --------------------------------------------------------------------------

def _num(v: float, digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    if abs(v) >= 1e4:
        return f"{v / 1e3:.1f} k"
    return f"{v:.{digits}g}"


def _seconds(t_us: int) -> str:
    return f"{t_us / 1e6:.3f}".rstrip("0").rstrip(".")


def table_rows(c: Comparison) -> list[tuple[str, str, str, str]]:
    """(statistic, real, simulated, score) rows of the realism table.

    Parameters
    ----------
    c : Comparison
        The comparison.

    Returns
    -------
    list of tuple of str
        The rows, as text.
    """
    r, s, k = c.real, c.sim, c.scores
    span = ", ".join(f"{_seconds(a - r.origin_us)}-{_seconds(b - r.origin_us)}" for a, b in r.windows_us[:3])
    span += ", ..." if len(r.windows_us) > 3 else ""
    def ratio(text: str) -> str:
        return text if text == "-" else f"x{text}"

    def noise(name: str) -> str:  # the ratio and its 95 % Poisson interval
        text = ratio(_num(k[name]))
        if text == "-" or name not in c.intervals:
            return text
        lo, hi = c.intervals[name]
        return f"{text} ({_num(lo, 2)}-{_num(hi, 2)})"

    return [
        (f"events ({span} s)", _num(r.n_events), _num(s.n_events), ratio(_num(k["count_ratio"]))),
        ("ON events", _num(r.n_on), _num(s.n_on), ratio(_num(k["on_ratio"]))),
        ("OFF events", _num(r.n_off), _num(s.n_off), ratio(_num(k["off_ratio"]))),
        ("noise on quiet static pixels, ON (Hz per pixel)", _num(r.quiet_hz[0], 2), _num(s.quiet_hz[0], 2),
         noise("quiet_on_ratio")),
        ("noise on quiet static pixels, OFF (Hz per pixel)", _num(r.quiet_hz[1], 2), _num(s.quiet_hz[1], 2),
         noise("quiet_off_ratio")),
        ("dark static pixels (< 20 DN), ON (Hz per pixel)", _num(r.dark_hz[0], 2), _num(s.dark_hz[0], 2),
         noise("dark_on_ratio")),
        ("dark static pixels (< 20 DN), OFF (Hz per pixel)", _num(r.dark_hz[1], 2), _num(s.dark_hz[1], 2),
         noise("dark_off_ratio")),
        ("events per pixel per passage (median)", _num(r.passage_median), _num(s.passage_median),
         f"{k['passage_median_diff']:+g}" if math.isfinite(k["passage_median_diff"]) else "-"),
        ("per-pixel count correlation", "1", _num(k["count_corr"]), _num(k["count_corr"])),
        ("per-pixel count correlation, 5x5 blurred", "1", _num(k["count_corr_blurred"]),
         _num(k["count_corr_blurred"])),
        ("whole-frame 10 ms event rate, correlation", "1", _num(k["rate_corr"]), _num(k["rate_corr"])),
        ("whole-frame 10 ms event rate, relative RMS error", "0", _num(k["rate_rel_rmse"]),
         _num(k["rate_rel_rmse"])),
        ("inter-event-interval histogram mismatch (L1, 0..2)", "0", _num(k["interval_l1"]),
         _num(k["interval_l1"])),
        ("event-rate flicker (1 ms bins; share of the variance)", _flicker(r), _flicker(s),
         ratio(_num(k["flicker_share_ratio"]))),
    ]


def _flicker(stats: RealismStats) -> str:
    f = stats.flicker_hz
    return f"{f:.0f} Hz, {stats.flicker_share:.0%}" if math.isfinite(f) else f"none, {stats.flicker_share:.0%}"


def format_comparison(c: Comparison, real_name: str = "real", sim_name: str = "sim") -> str:
    """The realism table as text, with the pixel classes and notes.

    Parameters
    ----------
    c : Comparison
        The comparison.
    real_name, sim_name : str, optional
        The column headers (default "real", "sim").

    Returns
    -------
    str
        The table.
    """
    rows = [("statistic", real_name, sim_name, "score"), *table_rows(c)]
    widths = [max(len(row[i]) for row in rows) for i in range(4)]
    lines = ["  ".join(f"{v:<{widths[0]}}" if i == 0 else f"{v:>{widths[i]}}" for i, v in enumerate(row))
             for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    m = c.real.masks
    if m is not None and m.source == "events":
        hot = 0 if m.hot is None else int(m.hot.sum())
        lines.append(f"pixel classes from the real events (no frames): {int(m.quiet.sum())} quiet pixels, {hot} hot "
                     "pixels; no dark pixels or passages (they need frames); the per-pixel correlation assumes the "
                     "simulation shows the same scene")
    elif m is not None:
        reach = "" if m.reach_px is None else (f", beyond the real events' signal reach ({m.reach_px[0]} px dark, "
                                                f"{m.reach_px[1]} px brighter)")
        lines.append(f"pixel classes from {m.frames_used} real frames: {int(m.quiet.sum())} quiet static, "
                     f"{int(m.dark.sum())} dark{reach}; change threshold {m.change_dn:.3g} DN (read noise "
                     f"{m.read_noise_dn:.2g} DN); {c.real.passages.size} real and {c.sim.passages.size} simulated "
                     "passages")
    lines += [f"note: {n}" for n in c.notes]
    return "\n".join(lines)


def _clean(v: object) -> object:
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else str(float(v))
    if isinstance(v, np.integer):
        return int(v)
    return v


def write_comparison_json(c: Comparison, path: str | Path) -> None:
    """Comparison.to_dict() as JSON, atomically.

    Parameters
    ----------
    c : Comparison
        The comparison.
    path : str or pathlib.Path
        The file to write.
    """
    write_text_atomic(path, json.dumps(c.to_dict(), indent=2) + "\n")
