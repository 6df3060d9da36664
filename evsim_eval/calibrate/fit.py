"""Fitting the DVS model to a real hybrid recording: simulate its own frames, match the statistics of its events.

The objective is the realism score (evsim_eval.realism: the same statistics `evsim evaluate --task realism`
reports), measured on the recording's window with its frames' pixel classes. The search, in three stages:

1. Log offset (dark level) and thresholds (fit_offset_and_thresholds): for each offset b on a log grid
   (OFFSET_GRID_DN, 8-bit DN), the ON and OFF thresholds are set by secant steps so that the simulated ON and OFF
   counts match the real ones (counts fall roughly as 1 / threshold); the b of the smallest loss is kept. This
   stage alone, with b refined at the vertex of a parabola in log b through the best grid offset and its
   neighbours, is what `evsim evaluate` uses for a recording without thresholds (evsim_eval.calibrate.thresholds).
2. Nelder-Mead (scipy.optimize.minimize; Nelder and Mead 1965) over the log of the ON and OFF thresholds, the
   offset, the refractory period and the photoreceptor cutoff, and the threshold spread, from stage 1's best.
3. Noise by moments: on the static pixels the simulation without noise is compared with the real rates, apart
   on the dark pixels (excess E_d, ON + OFF) and the brighter quiet ones (E_b), where dark shot noise D weighs
   s = b / (level + b) on average (s_d, s_b): E_b = S + D s_b and E_d = S + D s_d for shot noise S. Candidates:
   dark shot noise alone (D = E_d / s_d); S and D solving both; shot noise = twice the brighter pixels' OFF excess
   and leak = their ON excess beyond it (DVSParams.with_observed_leak), when ON exceeds OFF, with that D. Each gets
   the hot pixels of the real static pixels firing far above the others (their share and mean rate), and is tried
   without them too (the model's fire both polarities, a real one may fire one); its thresholds are rescaled once
   so that the counts match; the candidate of the smallest loss is kept, and a leak in it is refined by secant
   steps on the quiet ON rate (the drift's observed rate also follows the input's residual noise). (The excess
   over all quiet pixels, dark ones included, took the dark pixels' rate for shot noise everywhere: on the DAVIS346
   cradle the quiet and dark rates came out at x0.68 / x0.85 and x0.53 / x0.64 of the real ON / OFF.)
Noise parameters are fitted with noise-free signal parameters, whose counts on static pixels come from the input
(frame read noise through the flow upsampling): the moments are what the input does not explain.

The loss (loss_of) weighs: squared log count ratios ON and OFF (x 10), 1 - blurred per-pixel count correlation
(x 5), the squared relative RMS error of the 10 ms rate curve (x 2), the interval-histogram L1 distance (x 1), the
squared log ratios of the quiet static noise counts, ON and OFF each (x 0.5, one event added to each side; in stage
3 only: the signal stages simulate without noise) and the passage median difference (x 0.1). Per polarity, because a
real sensor's static noise may be almost all ON (the reference's leak): matching ON + OFF alone let shot noise, which
fires both, stand in for it (on the road recording: ON x0.48 and OFF x95 of the real quiet rates).

References (docs/models/references.md): Nelder and Mead 1965 [Nelder1965], stage 2's simplex search; Hu et al. 2021
[Hu2021], v2e.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import sim
from generators.formats import load
from generators.formats.recording import Recording

from .camera import recorded_camera
from .sensor import calibrated_sensor
from .simulation import InputSettings, RecordingSimulation
from .verify import converted_scores

if TYPE_CHECKING:
    from evsim_eval.realism import RealismStats

# stage 1's log offsets b, in 8-bit frame DN (scaled to the frames' full scale for deeper frames)
OFFSET_GRID_DN = (0.03, 1.0, 3.0, 10.0, 20.0, 40.0, 80.0)
HOT_FACTOR = 50.0  # a static pixel firing this many times the quiet static rate (and >= HOT_MIN_EVENTS) is hot
HOT_MIN_EVENTS = 10
MIN_EVENTS = 20  # real ON and OFF events the window must hold, each
SETTLE_S = 0.4  # s after the first frame's exposure start left out of the window (at most a fifth of the clip)
WEIGHTS = {"counts": 10.0, "corr": 5.0, "rate": 2.0, "intervals": 1.0, "quiet": 0.5, "passages": 0.1}  # of loss_of


@dataclass
class Calibration:
    """What calibrate gives.

    Attributes
    ----------
    path : pathlib.Path
        The recording.
    window_s : tuple of float
        The fitted window (seconds from the first frame's exposure start).
    dvs : DVSParams
        The fitted parameters (full_illumination: the recording's resolved value; dark_fraction relative to it, as
        convert's auto illumination resolves it on the same recording).
    preset : DVSParams
        The starting preset's parameters (same full_illumination).
    preset_name : str
        Its name.
    input : InputSettings
        The frames' black level etc.
    read_noise_dn : float
        The frames' read noise (DN rms, evsim_eval.realism.frame_masks).
    offset_dn : float
        The log offset b in frame DN (the pixel responds to log(DN - black + b)).
    scores : dict
        {"preset": ..., "fitted": ..., "search": ...} realism scores: the preset and the fitted sensor as `evsim
        convert --sensor` and the realism task give them (the fit's own simulation's with verify=False), and the
        fit's own simulation of the fitted parameters.
    real : dict
        The real statistics' summary.
    loss : float
        The fitted parameters' loss (loss_of).
    seed : int
        The simulations' seed.
    evaluations : int
        Simulations run.
    wall_s, cpu_s : float
        Time taken (seconds).
    history : list
        (stage, loss) per evaluation.
    camera : dict
        The recording's frame camera as CameraParams fields (evsim_eval.calibrate.camera.recorded_camera).
    sha256 : str
        The recording's sha256 (its file, or its folder's files).
    """

    path: Path
    window_s: tuple[float, float]
    dvs: sim.DVSParams
    preset: sim.DVSParams
    preset_name: str
    input: InputSettings
    read_noise_dn: float
    offset_dn: float
    scores: dict
    real: dict
    loss: float
    seed: int
    evaluations: int
    wall_s: float
    cpu_s: float
    history: list = field(default_factory=list)
    camera: dict = field(default_factory=dict)
    sha256: str = ""


    def to_dict(self) -> dict:
        """JSON-serialisable summary: the fitted and preset DVS parameters, input, scores, real statistics, timing.

        Returns
        -------
        dict
            The summary.
        """
        return {"recording": str(self.path), "window_s": list(self.window_s), "preset_name": self.preset_name,
                "fitted": dataclasses.asdict(self.dvs), "preset": dataclasses.asdict(self.preset),
                "input": dataclasses.asdict(self.input), "read_noise_dn": self.read_noise_dn,
                "offset_dn": self.offset_dn, "scores": self.scores, "real": self.real, "loss": self.loss,
                "seed": self.seed, "evaluations": self.evaluations, "wall_s": self.wall_s, "cpu_s": self.cpu_s,
                "camera": self.camera}


def loss_of(scores: dict, real_quiet: tuple[int, int], sim_quiet: tuple[int, int], noise: bool = True) -> float:
    """The calibration loss of realism scores (module docstring).

    Parameters
    ----------
    scores : dict
        Realism scores (evsim_eval.realism.compare).
    real_quiet, sim_quiet : tuple of int
        (ON, OFF) events on the quiet static pixels, real and simulated.
    noise : bool, optional
        Include the quiet-noise term (default True); False for the signal stages, which simulate without noise: what
        the noise stage adds is not theirs to match.

    Returns
    -------
    float
        The loss (lower is better).
    """
    def log_ratio(r):
        return math.log(r) if r > 0 and math.isfinite(r) else 5.0

    terms = {
        "counts": log_ratio(scores["on_ratio"]) ** 2 + log_ratio(scores["off_ratio"]) ** 2,
        "corr": 1.0 - _finite(scores["count_corr_blurred"], 0.0),
        "rate": _finite(scores["rate_rel_rmse"], 10.0) ** 2,
        "intervals": _finite(scores["interval_l1"], 2.0),
        "quiet": sum(math.log((s + 1) / (r + 1)) ** 2 for s, r in zip(sim_quiet, real_quiet)),
        "passages": abs(_finite(scores["passage_median_diff"], 10.0)),
    }
    return float(sum(WEIGHTS[k] * v for k, v in terms.items() if noise or k != "quiet"))


def _finite(v: float, default: float) -> float:
    return float(v) if v is not None and math.isfinite(v) else default


class _Objective:
    """Simulates, scores and counts; remembers the best parameters seen."""

    def __init__(self, simulation: RecordingSimulation, real, seed: int, bar):
        from evsim_eval.realism import compare, measure

        self._compare, self._measure = compare, measure
        self.simulation, self.real, self.seed, self.bar = simulation, real, seed, bar
        self.evaluations, self.history, self.noise = 0, [], False
        self.best: tuple[float, sim.DVSParams | None, dict | None] = (math.inf, None, None)

    def stats(self, dvs: sim.DVSParams):
        events = self.simulation.simulate(dvs, self.seed)
        return self._measure(events, like=self.real)

    def __call__(self, dvs: sim.DVSParams, stage: str) -> tuple[float, dict, object]:
        stats = self.stats(dvs)
        scores = {**self._compare(self.real, stats).scores, "sim_quiet_hz": list(stats.quiet_hz)}  # for the table
        value = loss_of(scores, self.real.quiet_counts, stats.quiet_counts, self.noise)
        self.evaluations += 1
        self.history.append((stage, value))
        if value < self.best[0]:
            self.best = (value, dvs, scores)
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix_str(f"{stage} loss {value:.3f} best {self.best[0]:.3f}", refresh=False)
        return value, scores, stats


def _match_counts(objective: _Objective, dvs: sim.DVSParams, stage: str, steps: int = 3):
    """Secant steps on log thresholds so that ON and OFF counts match: counts ~ threshold^-k (k from the steps,
    starting at 1). Returns (loss, dvs, scores)."""
    k = [1.0, 1.0]
    value, scores, _ = objective(dvs, stage)
    for _ in range(steps):
        ratios = (scores["on_ratio"], scores["off_ratio"])
        if all(abs(math.log(max(r, 1e-9))) < 0.03 for r in ratios):
            break
        new = []
        for r, name, kk in zip(ratios, ("pos_threshold", "neg_threshold"), k):
            r = min(max(r, 1e-3), 1e3)
            new.append(max(getattr(dvs, name) * r ** (1.0 / kk), 0.02))
        trial = dvs.replace(pos_threshold=new[0], neg_threshold=new[1])
        t_value, t_scores, _ = objective(trial, stage)
        for i, (name, key) in enumerate((("pos_threshold", "on_ratio"), ("neg_threshold", "off_ratio"))):
            d_thr = math.log(getattr(trial, name) / getattr(dvs, name))
            d_cnt = math.log(max(t_scores[key], 1e-9) / max(scores[key], 1e-9))
            if abs(d_thr) > 1e-6 and d_cnt < 0:
                k[i] = min(max(-d_cnt / d_thr, 0.3), 4.0)
        dvs, value, scores = trial, t_value, t_scores
    return value, dvs, scores


def fit_offset_and_thresholds(objective: _Objective, start: sim.DVSParams,
                              refine: bool = False) -> tuple[float, sim.DVSParams]:
    """Stage 1 (module docstring) from `start`: for each log offset of OFFSET_GRID_DN the ON and OFF thresholds
    matched to the counts (each offset starting from the previous one's thresholds); refine: then the offset at
    the vertex of the parabola in log b through the best grid offset and its two neighbours, when that lies between
    them (for a search that ends here: calibrate's stage 2 refines the offset itself).

    Parameters
    ----------
    objective : _Objective
        The calibration's objective (simulation, real statistics, seed).
    start : DVSParams
        The starting parameters.
    refine : bool, optional
        Refine the offset between grid points (default False).

    Returns
    -------
    loss : float
        The smallest loss.
    dvs : DVSParams
        Its parameters.
    """
    simulation = objective.simulation
    grid = np.log(OFFSET_GRID_DN)
    tried, dvs = [], start
    for b in OFFSET_GRID_DN:
        trial = dvs.replace(dark_fraction=simulation.dark_fraction(b * simulation.dn_per_radiance / 255.0))
        value, dvs, _ = _match_counts(objective, trial, f"offset {b:g} DN", steps=2)
        tried.append((value, dvs))
    i = min(range(len(tried)), key=lambda k: tried[k][0])
    best = tried[i]
    if refine and 0 < i < len(tried) - 1:
        (x0, x1, x2), (f0, f1, f2) = grid[i - 1:i + 2], [tried[k][0] for k in (i - 1, i, i + 1)]
        den = (x1 - x0) * (f1 - f2) - (x1 - x2) * (f1 - f0)  # < 0 when the parabola opens up (f1 the smallest)
        vertex = x1 - 0.5 * ((x1 - x0) ** 2 * (f1 - f2) - (x1 - x2) ** 2 * (f1 - f0)) / den if den < 0 else x1
        if x0 < vertex < x2 and abs(vertex - x1) > 0.05:
            b = math.exp(vertex)
            near = tried[i - 1 if vertex < x1 else i + 1][1]  # thresholds between the two: start from the mean
            trial = best[1].replace(
                dark_fraction=simulation.dark_fraction(b * simulation.dn_per_radiance / 255.0),
                pos_threshold=math.sqrt(best[1].pos_threshold * near.pos_threshold),
                neg_threshold=math.sqrt(best[1].neg_threshold * near.neg_threshold))
            value, trial, _ = _match_counts(objective, trial, f"offset {b:.3g} DN", steps=2)
            if value < best[0]:
                best = (value, trial)
    return best


def _excess(real_counts, sim_counts, pixels: int, duration_s: float) -> tuple[float, float]:
    """(ON, OFF) real events beyond the simulated ones per pixel and second (each at least 0)."""
    return tuple(max((r - s) / (max(pixels, 1) * duration_s), 0.0) for r, s in zip(real_counts, sim_counts))


def _noise_moments(objective: _Objective, dvs: sim.DVSParams) -> dict:
    """The static pixels' excess over the noise-free simulation `dvs`, split by brightness (module docstring, stage
    3): "bright" (ON, OFF) on the quiet pixels that are not dark, "dark" (ON + OFF) on the dark ones, and the mean
    share b / (level + b) of the dark shot noise on each (it scales as I_d / (I + I_d), sim.dvs)."""
    real, masks, dur = objective.real, objective.real.masks, objective.real.duration_s
    stats = objective.stats(dvs)
    objective.evaluations += 1
    n_quiet, n_dark = int(masks.quiet.sum()), int(masks.dark.sum())
    b_dn = objective.simulation.offset_dn(dvs)
    black = objective.simulation.settings.black_level

    def share(pixels):
        level = np.maximum(masks.median_dn[pixels].astype(np.float64) - black, 0.0)
        return float(np.mean(b_dn / (level + b_dn))) if level.size else 0.0

    if n_quiet > n_dark:  # the brighter quiet pixels: quiet counts less the dark ones' (dark pixels are quiet)
        real_b = [q - d for q, d in zip(real.quiet_counts, real.dark_counts)]
        sim_b = [q - d for q, d in zip(stats.quiet_counts, stats.dark_counts)]
        bright = _excess(real_b, sim_b, n_quiet - n_dark, dur)
    else:
        bright = _excess(real.quiet_counts, stats.quiet_counts, n_quiet, dur)
    dark = sum(_excess(real.dark_counts, stats.dark_counts, n_dark, dur)) if n_dark else 0.0
    return {"bright": bright, "dark": dark, "share_bright": share(masks.quiet & ~masks.dark),
            "share_dark": share(masks.dark)}


def _noise_candidates(objective: _Objective, dvs: sim.DVSParams) -> list[sim.DVSParams]:
    """Stage 3's candidate noise settings (module docstring), from the static pixels' excess over the noise-free
    simulation `dvs` (_noise_moments)."""
    m = _noise_moments(objective, dvs)
    (e_on, e_off), e_dark, s_b, s_d = m["bright"], m["dark"], m["share_bright"], m["share_dark"]

    def dark_shot(beyond: float) -> float:  # the dark pixels' excess beyond `beyond`, as dark shot noise
        return max(e_dark - beyond, 0.0) / (s_d - s_b) if s_d > s_b else 0.0

    real, masks = objective.real, objective.real.masks
    counts = real.counts.sum(axis=0)
    static_counts = counts[masks.static]
    quiet_events = sum(real.quiet_counts) / max(int(masks.quiet.sum()), 1)
    hot = static_counts[static_counts >= max(HOT_MIN_EVENTS, HOT_FACTOR * quiet_events)]
    extra = {}
    if hot.size:
        extra.update(hot_pixel_fraction=hot.size / counts.size, hot_pixel_hz=float(hot.mean()) / real.duration_s)
    base = dvs.replace(**extra)
    # dark shot noise alone; shot and dark shot noise solving both pixel classes' excess
    # (bright: S + D s_b, dark: S + D s_d); shot from the OFF excess and a leak for ON's surplus
    d = dark_shot(e_on + e_off)
    shot = max(e_on + e_off - d * s_b, 0.0)
    candidates = [base.replace(dark_shot_noise_hz=e_dark / s_d if s_d > 0 else 0.0),
                  base.replace(shot_noise_hz=shot, dark_shot_noise_hz=d)]
    if e_on > e_off:  # an ON-only excess is leak
        moments = base.replace(shot_noise_hz=2.0 * e_off, dark_shot_noise_hz=d)
        candidates.append(moments.with_observed_leak(e_on - e_off))
    if base.hot_pixel_fraction > 0:  # the model's hot pixels fire both polarities, a real one may fire one
        candidates += [c.replace(hot_pixel_fraction=0.0) for c in candidates]
    return candidates


def _refine_leak(objective: _Objective, steps: int = 2) -> None:
    """Secant steps on the best candidate's leak so that its quiet ON rate is the real one: the drift's observed
    rate also follows the input's residual noise, which brings a pixel to its threshold early (on the road
    recording the leak of the moments gave twice the real rate). Thresholds are matched again at each step; the
    objective keeps the best."""
    _, dvs, scores = objective.best
    real_on = objective.real.quiet_hz[0]
    for _ in range(steps):
        if dvs is None or dvs.leak_hz <= 0:
            return
        sim_on = scores["sim_quiet_hz"][0]
        if not (sim_on > 0 and real_on > 0) or abs(math.log(sim_on / real_on)) < 0.05:
            return
        _, dvs, scores = _match_counts(objective, dvs.replace(leak_hz=dvs.leak_hz * real_on / sim_on), "noise",
                                       steps=1)


class LightFlickerWarning(sim.EvsimNote):
    """The real events flicker with the light (a lamp on AC mains), which the recording's frames cannot show: the
    fit takes it for noise."""


def flicker_warning(real: RealismStats) -> LightFlickerWarning | None:
    """The LightFlickerWarning for real statistics whose event rate flickers (RealismStats.flicker_hz), else
    None.

    Parameters
    ----------
    real : RealismStats
        The real recording's statistics.

    Returns
    -------
    LightFlickerWarning or None
        The warning.
    """
    if not math.isfinite(real.flicker_hz):
        return None
    what = (f"the real events flicker at {real.flicker_hz:.0f} Hz ({real.flicker_share:.0%} of the 1 ms event "
            "rate's variance: a lamp on AC mains), which the frames cannot show; the fit takes it for noise. "
            "Simulate it under flickering light: ")
    return LightFlickerWarning(
        what + f"lighting={{'flicker_hz': {real.flicker_hz:.0f}, 'depth': ..., 'rise_fraction': ...}} in the scene "
               "(generators.scenes.FlickerLighting)",
        what + f"convert with --lighting flicker_hz={real.flicker_hz:.0f},depth=...,rise_fraction=... "
               "(docs/guide/convert.md)")


def calibrate(path: str | Path, window_s: tuple[float, float] | None = None, *, preset: str = "davis346",
              black_level: float | None = None, conditioning: str | None = None, seed: int = 0,
              max_evaluations: int = 120, verify: bool = True,
              progress: bool = True, log: Callable[[str], None] | None = None) -> Calibration:
    """Fit the DVS model to the recording at `path`, starting from `preset`. See the module.

    Parameters
    ----------
    path : str or pathlib.Path
        An AEDAT4 file or IJRR folder with frames, or any hybrid layout generators.formats reads.
    window_s : tuple of float, optional
        (start, end) seconds from its first frame's exposure start (default: the recording's frames less a settling
        start, default_window: 0.4 s, at most a fifth of the span, to the last
        frame's mid-exposure).
    preset : str, optional
        The starting DVS preset (default "davis346").
    black_level : float, optional
        The frames' value for no light (DN; default: the recording's darkest 0.01 % of frame values, the floor a
        black pixel reads).
    conditioning : str, optional
        The input conditioning of the frames (None: temporal, as convert does; "off" for noise-free frames).
    seed : int, optional
        The simulations' seed (default 0).
    max_evaluations : int, optional
        Bound of stage 2's simulations (default 120).
    verify : bool, optional
        Score the preset and the fitted sensor by converting the recording with each, as `evsim convert --sensor`
        does, and scoring the conversion as `evsim evaluate --task realism` does (default True; the table is then
        what the user will measure). False: the fit's own simulations' scores (faster).
    progress : bool, optional
        Show a progress bar (default True).
    log : callable, optional
        log(text) receives progress messages.

    Returns
    -------
    Calibration
        The fitted parameters and how they were found (an events_only.EventsOnlyCalibration for a recording
        without frames: window_s None is then its whole span less a warm-up).
    """
    from tqdm.auto import tqdm

    wall0, cpu0 = time.perf_counter(), time.process_time()
    path = Path(path)
    window_s = None if window_s is None else _checked_window(window_s)  # before the recording is read
    rec = load(path)
    if rec.frames is None or not len(rec.frames):  # events only: evsim_eval.calibrate.events_only
        from .events_only import calibrate_events_only
        return calibrate_events_only(path, rec, window_s, preset=preset, seed=seed, log=log)
    window_s = default_window(rec) if window_s is None else window_s
    start = sim.DVSParams.preset(preset)
    real, simulation = prepare(path, rec, window_s, black_level, conditioning, log)
    note = flicker_warning(real)
    if note is not None:
        warnings.warn(note, stacklevel=2)
    bar = tqdm(total=len(OFFSET_GRID_DN) * 3 + max_evaluations + 8, unit="sim", desc="calibrate",
               disable=not progress, leave=False)
    objective = _Objective(simulation, real, seed, bar)
    settings = simulation.settings
    try:
        objective.noise = True
        preset_scores = objective(start, "preset")[1]
        objective.noise = False
        objective.best = (math.inf, None, None)  # the search's best: noise-free parameters
        noiseless = start.replace(shot_noise_hz=0.0, dark_shot_noise_hz=0.0, leak_hz=0.0, hot_pixel_fraction=0.0)
        dvs = fit_offset_and_thresholds(objective, noiseless)[1]  # stage 1
        # stage 2: Nelder-Mead on the signal parameters
        dvs = _nelder_mead(objective, dvs, max_evaluations)
        # stage 3: noise candidates by moments, each with its thresholds matched again; the best is kept
        objective.best, objective.noise = (math.inf, None, None), True
        for candidate in _noise_candidates(objective, dvs):
            _match_counts(objective, candidate, "noise", steps=1)
        _refine_leak(objective)
        loss, final, fitted_scores = objective.best
    finally:
        bar.close()
    camera = recorded_camera(rec, real.masks.read_noise_dn)
    scores = {"search": fitted_scores}
    if verify:  # the table as the realism task scores `evsim convert --sensor` (evsim_eval.calibrate.verify)
        if log is not None:
            log("scoring the preset and the fitted sensor as `evsim convert --sensor` gives them ...")
        for key, dvs in (("preset", start), ("fitted", final)):
            sensor = calibrated_sensor(key, simulation.params(dvs), preset, black_level=settings.black_level,
                                       read_noise_dn=real.masks.read_noise_dn, offset_dn=simulation.offset_dn(dvs),
                                       camera=camera)
            scores[key] = converted_scores(path, rec, sensor, window_s, conditioning=settings.conditioning)
    else:
        scores.update(preset=preset_scores, fitted=fitted_scores)
    return Calibration(
        path=path, window_s=tuple(window_s), dvs=simulation.params(final), preset=simulation.params(start),
        preset_name=preset, input=settings, read_noise_dn=float(real.masks.read_noise_dn),
        offset_dn=simulation.offset_dn(final), scores=scores, real=real.summary(), loss=loss, seed=seed,
        evaluations=objective.evaluations, wall_s=time.perf_counter() - wall0,
        cpu_s=time.process_time() - cpu0, history=objective.history, camera=camera,
        sha256=simulation.scene.describe()["input"]["sha256"])


def default_window(rec: Recording) -> tuple[float, float]:
    """(start, end) s from the first frame's exposure start: SETTLE_S (at most a fifth of the frames' span) to the
    last frame's mid-exposure.

    Parameters
    ----------
    rec : Recording
        The recording (with frames).

    Returns
    -------
    start, end : float
        Seconds.
    """
    end = (int(rec.frame_t_mid_us[-1]) - int(rec.frame_t_start_us[0])) / 1e6
    return min(SETTLE_S, 0.2 * end), end


def _checked_window(window_s: tuple[float, float]) -> tuple[float, float]:
    start_s, end_s = (float(v) for v in window_s)
    if not (math.isfinite(start_s) and math.isfinite(end_s) and 0 <= start_s < end_s):
        raise sim.EvsimInputError(f"the window must satisfy 0 <= start < end seconds, got {start_s} .. {end_s}")
    return start_s, end_s


def prepare(path: Path, rec: Recording, window_s: tuple[float, float], black_level: float | None = None,
            conditioning: str | None = None,
            log: Callable[[str], None] | None = None) -> tuple[RealismStats, RecordingSimulation]:
    """(real statistics over window_s, RecordingSimulation) of the recording `rec` read from `path`, checked: frames
    (at least 3) and MIN_EVENTS real ON and OFF events in the window (sim.EvsimInputError otherwise).

    Parameters
    ----------
    path : pathlib.Path
        Where the recording was read from (for messages).
    rec : Recording
        The recording.
    window_s : tuple of float
        (start, end) seconds from its origin.
    black_level : float, optional
        The frames' value for no light (DN); None: the frames' darkest 0.01 %.
    conditioning : str, optional
        The frames' input conditioning (None: temporal).
    log : callable, optional
        log(text) receives messages.

    Returns
    -------
    real : RealismStats
        The real statistics over the window.
    simulation : RecordingSimulation
        The recording's simulation.
    """
    from evsim_eval.realism import measure_recording

    start_s, end_s = _checked_window(window_s)
    n_frames = 0 if rec.frames is None else rec.frames.shape[0]
    if n_frames < 3:
        raise sim.EvsimInputError(f"{path}: calibration needs a recording with frames (at least 3; it holds "
                                  f"{n_frames})")
    if black_level is None:
        black_level = float(np.percentile(np.asarray(rec.frames), 0.01))
    real = measure_recording(rec, (start_s, end_s))
    if min(real.n_on, real.n_off) < MIN_EVENTS:
        span = (int(rec.events["t"][-1]) - real.origin_us) / 1e6 if rec.events.size else 0.0
        raise sim.EvsimInputError(
            f"{path}: {real.n_on} ON and {real.n_off} OFF events in the window {start_s:g}-{end_s:g} s (its events "
            f"end at {span:.3g} s from the first frame): the fit needs at least {MIN_EVENTS} of each; give a window "
            "over a part with motion")
    if log is not None:
        log(f"upsampling the {n_frames} frames of {path.name} (flow) ...")
    settings = InputSettings(black_level=black_level, conditioning=conditioning)
    return real, RecordingSimulation(path, settings, recording=rec)


_NM_FIELDS = ("pos_threshold", "neg_threshold", "dark_fraction", "refractory_us", "cutoff_hz")


def _nelder_mead(objective: _Objective, dvs: sim.DVSParams, max_evaluations: int) -> sim.DVSParams:
    """Stage 2: scipy's Nelder-Mead over log of _NM_FIELDS and threshold_sigma (linear)."""
    from scipy.optimize import minimize

    start = dvs.replace(refractory_us=max(dvs.refractory_us, 1), cutoff_hz=max(dvs.cutoff_hz, 1.0))

    def params(x):
        values = {name: float(math.exp(v)) for name, v in zip(_NM_FIELDS, x[:-1])}
        values["refractory_us"] = int(round(values["refractory_us"]))
        return start.replace(**values, threshold_sigma=float(abs(x[-1])))

    x0 = np.array([math.log(getattr(start, n)) for n in _NM_FIELDS] + [start.threshold_sigma])
    steps = np.array([0.15, 0.15, 0.7, 0.7, 0.5, 0.03])
    simplex = np.vstack([x0] + [x0 + np.eye(x0.size)[i] * steps[i] for i in range(x0.size)])
    result = minimize(lambda x: objective(params(x), "simplex")[0], x0, method="Nelder-Mead",
                      options={"maxfev": max_evaluations, "initial_simplex": simplex, "xatol": 0.01,
                               "fatol": 1e-3})
    best = objective.best[1]
    return best if best is not None and objective.best[0] <= result.fun else params(result.x)


__all__ = ["Calibration", "calibrate", "default_window", "fit_offset_and_thresholds", "prepare", "loss_of",
           "OFFSET_GRID_DN", "WEIGHTS", "SETTLE_S", "LightFlickerWarning", "flicker_warning"]
