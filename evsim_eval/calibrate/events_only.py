"""Calibration of an event camera without frames (DVXplorer, Prophesee, ...): what the events alone identify.

Without frames the light on each pixel is unknown, so the contrast thresholds (log change per event), their
spread, the photoreceptor cutoff and the log offset cannot be fitted: they come from the preset (--preset) or are
given (--thresholds ON OFF), and the table and the sensor file's provenance say so. What the events identify:

- Quiet and hot pixels (evsim_eval.realism.event_masks): pixels whose neighbourhood fires no more than noise, and
  isolated pixels firing far above them; the realism task uses the same classes for a recording without frames.
- Background noise per polarity: the events of the quiet, not hot pixels. The model's shot noise is symmetric (half
  ON, half OFF, sim.dvs) and its leak gives ON events only, so shot noise = twice the OFF rate and leak = the ON
  rate beyond it. Leak events come from a drift restarted by every event, and the emulator starts each pixel at a
  uniform drift phase (sim.dvs), so the leak rate a simulation shows depends on its length: leak_hz is set so that a
  still scene simulated over the recording's window shows the measured ON excess (leak_rate_over, the emulator's
  renewal process); the stationary rate of a long simulation (DVSParams.observed_leak_hz) is reported too. OFF
  beyond ON cannot be made by the model: the total is then split evenly and the table says so. Dark shot noise
  needs the light level: it is set to 0, so the noise is the measured one at any illumination.
- Hot pixels: their share of the quiet pixels and their mean rate (the Poisson rate that shows it through the
  refractory period), ON share reported (the model's hot pixels are half ON).
- Activity dependence: the background rates in time bins (ACTIVITY_BIN_US) against the whole sensor's event rate
  in them: the quietest and busiest thirds of the bins and the slope. The model's noise does not depend on activity:
  the fitted rates are the recording's mean, and the table shows how far the bins depart from it.
- Refractory period: the lower edge of the same-pixel interval histogram (the EDGE_QUANTILE quantile of the
  intervals), when at least EDGE_MIN_INTERVALS intervals lie within EDGE_WIDTH of it (a pile-up at the dead time);
  else the preset's.
- Timestamps: resolution (the greatest common divisor of the steps between distinct timestamps), order (steps
  back), events sharing a timestamp (packets) and the longest step. Reported; the emulator's timestamps are whole
  microseconds per event.

The fitted sensor is checked as the realism task would: a still scene simulated over the window, measured on the
recording's quiet pixels (still_scene_check).
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import sim
from generators.formats import load

if TYPE_CHECKING:
    from evsim_eval.realism import RealismStats

WARM_UP_FRACTION = 0.02  # the default window leaves out this share of the recording's span at its start ...
WARM_UP_MAX_S = 0.1  # ... at most this long (s)
MIN_EVENTS = 20  # real ON and OFF events the window must hold, each
ACTIVITY_BIN_US = 50_000  # time bins of the activity dependence (us)
EDGE_QUANTILE = 1e-4  # the refractory edge: this quantile of the same-pixel intervals ...
EDGE_MIN_INTERVALS = 10  # ... identified when at least this many intervals lie within ...
EDGE_WIDTH = 1.5  # ... this factor above it
LEAK_PIXELS = 100_000  # pixels of the leak renewal computation (leak_rate_over)
#: the DVS fields events alone fit (the others are the preset's, or given)
FITTED_FIELDS = ("shot_noise_hz", "dark_shot_noise_hz", "leak_hz", "hot_pixel_fraction", "hot_pixel_hz",
                 "refractory_us")


@dataclass
class EventsOnlyCalibration:
    """What calibrate gives for a recording without frames (see the module). Rates in Hz per pixel.

    Attributes
    ----------
    path : pathlib.Path
        The recording.
    window_s : tuple of float
        The fitted window (seconds from the first event).
    warm_up_s : float
        The start left out when no window was given (s; 0 for a given window).
    dvs, preset : DVSParams
        The fitted parameters and the preset's.
    preset_name : str
        The preset.
    thresholds_given : bool
        True when the thresholds were given, False when they are the preset's.
    noise : dict
        The measured noise: quiet and hot pixels, background and hot rates per polarity, the leak's rates.
    activity : dict
        The activity dependence of the background noise.
    refractory : dict
        The refractory edge: {"edge_us", "near", "identified"}.
    timestamps : dict
        The timestamp behaviour.
    check : dict
        The still-scene check: quiet ON and OFF rates of the preset and of the fitted sensor.
    real : dict
        The real statistics' summary (RealismStats.summary).
    notes : list of str
        What the model cannot reproduce, and what was not identified.
    seed : int
        The simulations' seed.
    wall_s, cpu_s : float
        Time taken (s).
    """

    path: Path
    window_s: tuple[float, float]
    warm_up_s: float
    dvs: sim.DVSParams
    preset: sim.DVSParams
    preset_name: str
    thresholds_given: bool
    noise: dict
    activity: dict
    refractory: dict
    timestamps: dict
    check: dict
    real: dict
    notes: list = field(default_factory=list)
    seed: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0

    def to_dict(self) -> dict:
        """JSON-serialisable summary.

        Returns
        -------
        dict
            The calibration's fields (DVS parameters as dicts).
        """
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out.update(path=str(self.path), dvs=dataclasses.asdict(self.dvs), preset=dataclasses.asdict(self.preset),
                   window_s=list(self.window_s), events_only=True)
        return out


# ----- what the events tell ------------------------------------------------------------------------------------

def timestamp_behaviour(t: np.ndarray) -> dict:
    """The timestamp behaviour of an event stream (see the module).

    Parameters
    ----------
    t : numpy.ndarray
        (N,) event times in file order, int64 us.

    Returns
    -------
    dict
        resolution_us (int; 0 without two distinct times), steps_back (int: events earlier than the one before),
        shared_fraction (share of events with the previous event's time), max_per_timestamp (int),
        longest_step_ms (float).
    """
    t = np.asarray(t, np.int64)
    steps = np.diff(t)
    distinct = np.unique(t)
    gaps = np.diff(distinct)
    resolution = int(np.gcd.reduce(gaps)) if gaps.size else 0
    per_stamp = np.unique(t, return_counts=True)[1] if t.size else np.zeros(1, np.int64)
    return {"resolution_us": resolution, "steps_back": int(np.sum(steps < 0)),
            "shared_fraction": float(np.mean(steps == 0)) if steps.size else 0.0,
            "max_per_timestamp": int(per_stamp.max()), "longest_step_ms": float(steps.max()) / 1e3 if steps.size
            else 0.0}


def refractory_edge(intervals_us: np.ndarray) -> dict:
    """The lower edge of the same-pixel interval histogram: the dead time after an event (see the module).

    Parameters
    ----------
    intervals_us : numpy.ndarray
        Same-pixel inter-event intervals (us, > 0).

    Returns
    -------
    dict
        edge_us (int), near (intervals within EDGE_WIDTH of it), identified (bool), intervals (int).
    """
    iv = np.sort(np.asarray(intervals_us, np.int64)[np.asarray(intervals_us) > 0])
    if not iv.size:
        return {"edge_us": 0, "near": 0, "identified": False, "intervals": 0}
    edge = int(iv[max(math.ceil(EDGE_QUANTILE * iv.size), 1) - 1])
    near = int(np.searchsorted(iv, EDGE_WIDTH * edge, side="right")) - int(np.searchsorted(iv, edge))
    return {"edge_us": edge, "near": near, "identified": near >= EDGE_MIN_INTERVALS, "intervals": int(iv.size)}


def same_pixel_intervals(events: np.ndarray, windows_us: np.ndarray, width: int, height: int) -> np.ndarray:
    """The intervals between successive events of each pixel inside each window (us).

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE, sorted by t.
    windows_us : numpy.ndarray
        (K, 2) windows, int64 us.
    width, height : int
        Sensor size (pixels).

    Returns
    -------
    numpy.ndarray
        int64 intervals (us).
    """
    from evsim_eval.realism.kernels import pixel_runs

    out = []
    for a, b in windows_us:
        i0, i1 = np.searchsorted(events["t"], [a, b])
        ev = events[i0:i1]
        tw = np.ascontiguousarray(ev["t"], dtype=np.int64)
        pix = ev["y"].astype(np.int64) * width + ev["x"].astype(np.int64)
        iv = np.empty(tw.size, np.int64)
        passages = np.empty(tw.size + 1, np.int64)
        pixel_runs(tw, pix, width * height, 1, np.zeros(0, np.int64), np.zeros((0, width * height), bool), iv,
                   passages)
        out.append(iv[iv >= 0])
    return np.concatenate(out) if out else np.zeros(0, np.int64)


def activity_dependence(events: np.ndarray, windows_us: np.ndarray, cold: np.ndarray) -> dict:
    """The background noise (events of the `cold` pixels) per polarity against the whole sensor's activity, in
    ACTIVITY_BIN_US bins (see the module).

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE, sorted by t.
    windows_us : numpy.ndarray
        (K, 2) windows, int64 us.
    cold : numpy.ndarray
        (H, W) bool: the quiet, not hot pixels.

    Returns
    -------
    dict
        bins (int), sensor_hz, on_hz, off_hz (lists per bin: the whole sensor's event rate, the background rates
        per pixel), quiet_third and busy_third ({"sensor_hz", "on_hz", "off_hz"} over the quietest and busiest
        third of the bins), slope_per_mhz (background ON + OFF rate per pixel per million sensor events per
        second, least squares; NaN with fewer than 3 bins).
    """
    h, w = cold.shape
    n_cold = max(int(cold.sum()), 1)
    flat = cold.ravel()
    rows = []  # (duration s, sensor events, ON, OFF)
    for a, b in windows_us:
        edges = np.append(np.arange(a, b, ACTIVITY_BIN_US, dtype=np.int64), np.int64(b))
        idx = np.searchsorted(events["t"], edges)
        for k in range(edges.size - 1):
            ev = events[idx[k]:idx[k + 1]]
            mine = flat[ev["y"].astype(np.int64) * w + ev["x"]]
            on = ev["p"][mine] > 0
            rows.append(((edges[k + 1] - edges[k]) / 1e6, ev.size, int(on.sum()), int((~on).sum())))
    d, n, on, off = (np.array(c, np.float64) for c in zip(*rows))
    sensor, on_hz, off_hz = n / d, on / (d * n_cold), off / (d * n_cold)
    order = np.argsort(sensor)
    third = max(order.size // 3, 1)

    def pooled(sel: np.ndarray) -> dict:
        dd = d[sel].sum()
        return {"sensor_hz": float(n[sel].sum() / dd), "on_hz": float(on[sel].sum() / (dd * n_cold)),
                "off_hz": float(off[sel].sum() / (dd * n_cold))}

    slope = float("nan")
    if order.size >= 3 and np.ptp(sensor) > 0:
        slope = float(np.polyfit(sensor / 1e6, on_hz + off_hz, 1, w=np.sqrt(d))[0])
    return {"bins": int(order.size), "sensor_hz": sensor.tolist(), "on_hz": on_hz.tolist(), "off_hz": off_hz.tolist(),
            "quiet_third": pooled(order[:third]), "busy_third": pooled(order[-third:]), "slope_per_mhz": slope}


def leak_rate_over(leak_hz: float, shot_hz: float, refractory_us: int, spread: float, horizon_s: float,
                   seed: int = 0) -> float:
    """The mean leak event rate (Hz per pixel) a static pixel of the emulator shows over its first horizon_s
    seconds: leak rates log-normal over pixels (mean leak_hz, spread), each starting at a uniform drift phase
    (sim.dvs), every event (shot noise at shot_hz, leak) restarting the drift after the refractory period.

    The count is the expectation over the shot noise at each cycle (the probability that the drift completes before
    a shot event), over LEAK_PIXELS pixels of stratified rates and phases (fixed seed), so the result is smooth in
    leak_hz.

    Parameters
    ----------
    leak_hz : float
        Mean drift rate (Hz, DVSParams.leak_hz).
    shot_hz : float
        Shot-noise rate, ON and OFF together (Hz).
    refractory_us : int
        Refractory period (us).
    spread : float
        DVSParams.leak_spread.
    horizon_s : float
        The simulated time (s).
    seed : int, optional
        Seed of the pixels' draws (default 0).

    Returns
    -------
    float
        Leak events per pixel per second.
    """
    if leak_hz <= 0 or horizon_s <= 0:
        return 0.0
    from scipy.special import ndtri

    rng = np.random.default_rng(seed)
    grid = (np.arange(LEAK_PIXELS) + 0.5) / LEAK_PIXELS  # stratified: rates' normal quantiles, phases' uniform ones
    rates = leak_hz * np.exp(spread * ndtri(grid) - 0.5 * spread * spread)
    period, r = 1.0 / rates, refractory_us * 1e-6
    t = np.zeros(LEAK_PIXELS)
    due = rng.permutation(grid) * period  # the first leak event
    # the first cycle's expectation over the uniform phase: P(first leak before the horizon and before a shot event)
    reach = np.minimum(horizon_s, period)
    expected = float(np.sum((-np.expm1(-shot_hz * reach) / shot_hz if shot_hz > 0 else reach) / period))
    live = np.arange(LEAK_PIXELS)
    first = True
    while live.size:
        live = live[due[live] < horizon_s]  # a pixel whose next leak falls after the horizon shows no more
        wait = due[live] - t[live]
        p_leak = np.exp(-shot_hz * wait)  # no shot event before the drift completes
        expected += 0.0 if first else float(p_leak.sum())
        first = False
        u = rng.random((2, live.size))
        leak = u[0] < p_leak
        # else a shot event first: its time, an exponential truncated to the wait
        shot = -np.log1p(-u[1] * -np.expm1(-shot_hz * wait)) / shot_hz if shot_hz > 0 else wait
        t[live] = np.where(leak, due[live], t[live] + shot) + r
        due[live] = t[live] + period[live]
    return expected / (LEAK_PIXELS * horizon_s)


def leak_for(observed_hz: float, shot_hz: float, refractory_us: int, spread: float, horizon_s: float) -> float:
    """The leak_hz whose leak_rate_over the horizon is observed_hz (bisection in log leak_hz).

    Parameters
    ----------
    observed_hz : float
        The measured ON excess (Hz per pixel).
    shot_hz : float
        Shot-noise rate (Hz).
    refractory_us : int
        Refractory period (us).
    spread : float
        DVSParams.leak_spread.
    horizon_s : float
        The simulated time (s).

    Returns
    -------
    float
        leak_hz (0 for observed_hz 0).
    """
    if observed_hz <= 0:
        return 0.0
    lo, hi = math.log(observed_hz * 0.5), math.log(observed_hz * 2.0)
    while leak_rate_over(math.exp(hi), shot_hz, refractory_us, spread, horizon_s) < observed_hz and hi < 30:
        lo, hi = hi, hi + math.log(4.0)
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if leak_rate_over(math.exp(mid), shot_hz, refractory_us, spread, horizon_s) < observed_hz:
            lo = mid
        else:
            hi = mid
    return math.exp(0.5 * (lo + hi))


def measure_noise(real: RealismStats) -> dict:
    """The noise of the quiet pixels of real statistics measured with the pixel classes of their events.

    Parameters
    ----------
    real : RealismStats
        Statistics of a recording without frames (masks from its events: evsim_eval.realism.event_masks).

    Returns
    -------
    dict
        quiet_pixels, hot_pixels (int); quiet_on_hz, quiet_off_hz (all quiet pixels, hot ones included, as the
        realism task measures them); background_on_hz, background_off_hz (the quiet, not hot pixels);
        hot_fraction (of the quiet pixels), hot_observed_hz (mean rate of a hot pixel beyond the background),
        hot_on_share (share of their events that are ON; NaN without hot pixels).
    """
    masks, dur = real.masks, real.duration_s
    quiet = masks.quiet
    hot = masks.hot if masks.hot is not None else np.zeros_like(quiet)
    cold = quiet & ~hot
    n_quiet, n_hot, n_cold = int(quiet.sum()), int(hot.sum()), int(cold.sum())
    on, off = real.counts[0], real.counts[1]
    bg_on = float(on[cold].sum()) / (n_cold * dur) if n_cold else float("nan")
    bg_off = float(off[cold].sum()) / (n_cold * dur) if n_cold else float("nan")
    hot_events = int(on[hot].sum() + off[hot].sum())
    return {"quiet_pixels": n_quiet, "hot_pixels": n_hot, "quiet_on_hz": real.quiet_hz[0],
            "quiet_off_hz": real.quiet_hz[1], "background_on_hz": bg_on, "background_off_hz": bg_off,
            "hot_fraction": n_hot / n_quiet if n_quiet else 0.0,
            "hot_observed_hz": max(hot_events / (n_hot * dur) - bg_on - bg_off, 0.0) if n_hot else 0.0,
            "hot_on_share": float(on[hot].sum()) / hot_events if hot_events else float("nan")}


def fit_noise(start: sim.DVSParams, noise: dict, refractory: dict, horizon_s: float,
              notes: list[str]) -> sim.DVSParams:
    """The DVS parameters events alone identify (FITTED_FIELDS) set over `start` from the measured noise (see the
    module); what the model cannot reproduce is appended to notes.

    Parameters
    ----------
    start : DVSParams
        The preset (with any given thresholds).
    noise : dict
        measure_noise's result.
    refractory : dict
        refractory_edge's result.
    horizon_s : float
        The window's length (s): the leak is set for a still scene simulated this long.
    notes : list of str
        Receives the notes.

    Returns
    -------
    DVSParams
        The fitted parameters.
    """
    dvs = start.replace(dark_shot_noise_hz=0.0)
    if refractory["identified"]:
        dvs = dvs.replace(refractory_us=refractory["edge_us"])
    else:
        notes.append(f"refractory period not identified (only {refractory['near']} same-pixel intervals near the "
                     f"shortest, {refractory['edge_us']} us): the preset's {start.refractory_us} us is kept")
    on, off = noise["background_on_hz"], noise["background_off_hz"]
    if not (math.isfinite(on) and math.isfinite(off)):
        notes.append("no quiet pixels (the scene moves everywhere): the preset's noise is kept")
        return dvs.replace(dark_shot_noise_hz=start.dark_shot_noise_hz)
    if off > on:
        notes.append(f"the quiet pixels fire more OFF ({off:.3g} Hz) than ON ({on:.3g} Hz): the model's noise is "
                     "symmetric (shot noise) or ON (leak), so the fitted sensor splits the total evenly; an OFF excess "
                     "would need a polarity share of shot noise or a reference that drifts up")
        dvs = dvs.replace(shot_noise_hz=on + off, leak_hz=0.0)
    else:
        dvs = dvs.replace(shot_noise_hz=2.0 * off)
        dvs = dvs.replace(leak_hz=leak_for(on - off, dvs.shot_noise_hz, dvs.refractory_us, dvs.leak_spread,
                                           horizon_s))
    if noise["hot_pixels"]:
        m, r = noise["hot_observed_hz"], dvs.refractory_us * 1e-6
        # the Poisson rate that shows m events per second through the dead time: m / (1 - m r)
        dvs = dvs.replace(hot_pixel_fraction=noise["hot_fraction"], hot_pixel_hz=m / max(1.0 - m * r, 0.05))
        share = noise["hot_on_share"]
        if abs(share - 0.5) > 0.1:
            notes.append(f"the hot pixels fire {share:.0%} ON; the model's hot pixels fire half ON, half OFF")
    else:
        dvs = dvs.replace(hot_pixel_fraction=0.0)
    return dvs


def still_scene_check(dvs: sim.DVSParams, real: RealismStats, seed: int = 0) -> tuple[float, float]:
    """The quiet-pixel noise (ON, OFF; Hz per pixel) of a still scene simulated with dvs over the real window,
    measured on the real recording's quiet pixels (what the realism task scores).

    Parameters
    ----------
    dvs : DVSParams
        The sensor.
    real : RealismStats
        The real statistics (masks from the events).
    seed : int, optional
        The simulation's seed (default 0).

    Returns
    -------
    tuple of float
        (ON, OFF) Hz per pixel.
    """
    from evsim_eval.realism import measure, shifted

    like = shifted(real, 0)
    end = int(like.windows_us[-1, 1])
    frames = np.full((2, real.height, real.width), 0.5 * dvs.full_illumination, np.float32)
    events = sim.emulate(frames, np.array([0, end], np.int64), dvs, seed)
    return measure(events, like=like).quiet_hz


def events_window(path: Path, rec: object, window_s: tuple[float, float] | None) -> tuple[tuple[float, float], float]:
    """((start, end) seconds from the first event, warm-up s) of the fitted window: window_s checked against the
    events (an end at most 10 ms or 1 % past the last event is clipped to it), or (None) the whole recording less
    a warm-up (WARM_UP_FRACTION of its span, at most WARM_UP_MAX_S).

    Parameters
    ----------
    path : pathlib.Path
        The recording (for messages).
    rec : Recording
        The recording.
    window_s : tuple of float or None
        The requested window, seconds from the first event.

    Returns
    -------
    window : tuple of float
        The window (s).
    warm_up : float
        The warm-up left out (s; 0 for a given window).
    """
    t = rec.events["t"]
    if not t.size:
        raise sim.EvsimInputError(f"{path}: the recording has no events to calibrate on")
    span = (int(t[-1]) + 1 - int(t[0])) / 1e6
    if window_s is None:
        warm = min(WARM_UP_FRACTION * span, WARM_UP_MAX_S)
        return (round(warm, 6), round(span, 6)), warm
    start, end = (float(v) for v in window_s)
    if not (math.isfinite(start) and math.isfinite(end) and 0 <= start < end):
        raise sim.EvsimInputError(f"--window {start:g} {end:g}: the window must satisfy 0 <= START < END seconds")
    if start >= span or end > span + max(0.01, 0.01 * span):  # up to 10 ms or 1 % past the last event: clipped
        raise sim.EvsimInputError(f"{path}: --window {start:g} {end:g} reaches past its events, which span 0-"
                                  f"{span:.3f} s from the first one: give a window inside it, or none for the whole "
                                  "recording")
    return (start, min(end, round(span, 6))), 0.0


def calibrate_events_only(path: str | Path, recording: object | None = None,
                          window_s: tuple[float, float] | None = None, *, preset: str = "davis346",
                          thresholds: tuple[float, float] | None = None, seed: int = 0,
                          log: Callable[[str], None] | None = None) -> EventsOnlyCalibration:
    """Fit what the events of a recording without frames identify (see the module).

    Parameters
    ----------
    path : str or pathlib.Path
        The recording (any event layout generators.formats reads).
    recording : Recording, optional
        The recording at path, when the caller has loaded it.
    window_s : tuple of float, optional
        (start, end) seconds from the first event (default None: the whole recording less a warm-up).
    preset : str, optional
        The DVS preset the unidentified parameters come from (default "davis346").
    thresholds : tuple of float, optional
        (ON, OFF) contrast thresholds (log units) to use instead of the preset's.
    seed : int, optional
        Seed of the still-scene check (default 0).
    log : callable, optional
        log(text) receives progress messages.

    Returns
    -------
    EventsOnlyCalibration
        The fit.
    """
    from evsim_eval.realism import measure_recording

    wall0, cpu0 = time.perf_counter(), time.process_time()
    path = Path(path)
    rec = load(path) if recording is None else recording
    if rec.frames is not None and len(rec.frames):
        raise sim.EvsimInputError(f"--thresholds: {path} holds frames, from which calibrate fits the thresholds; "
                                  "--thresholds is for a recording without frames")
    start = sim.DVSParams.preset(preset)
    if thresholds is not None:
        start = start.replace(pos_threshold=float(thresholds[0]), neg_threshold=float(thresholds[1]))
    window, warm = events_window(path, rec, window_s)
    if log is not None:
        log(f"{path.name}: no frames; fitting what its events identify over {window[0]:g}-{window[1]:g} s")
    real = measure_recording(rec, window)
    if min(real.n_on, real.n_off) < MIN_EVENTS:
        raise sim.EvsimInputError(f"{path}: {real.n_on} ON and {real.n_off} OFF events in the window "
                                  f"{window[0]:g}-{window[1]:g} s: the fit needs at least {MIN_EVENTS} of each")
    notes: list[str] = []
    noise = measure_noise(real)
    refractory = refractory_edge(same_pixel_intervals(rec.events, real.windows_us, rec.width, rec.height))
    dvs = fit_noise(start, noise, refractory, real.duration_s, notes)
    cold = real.masks.quiet & ~(real.masks.hot if real.masks.hot is not None else False)
    activity = activity_dependence(rec.events, real.windows_us, cold)
    noise["leak_observed_hz"] = max(noise["background_on_hz"] - noise["background_off_hz"], 0.0)
    noise["leak_stationary_hz"] = dvs.observed_leak_hz()
    check = {"preset": still_scene_check(start, real, seed), "fitted": still_scene_check(dvs, real, seed)}
    return EventsOnlyCalibration(
        path=path, window_s=window, warm_up_s=warm, dvs=dvs, preset=start, preset_name=preset,
        thresholds_given=thresholds is not None, noise=noise, activity=activity, refractory=refractory,
        timestamps=timestamp_behaviour(rec.events["t"]), check=check, real=real.summary(), notes=notes, seed=seed,
        wall_s=time.perf_counter() - wall0, cpu_s=time.process_time() - cpu0)


# ----- the table and the sensor file ---------------------------------------------------------------------------

def _hz(v: float) -> str:
    return f"{v:.3g}" if isinstance(v, (int, float)) and math.isfinite(v) else "-"


def _pair(a: float, b: float) -> str:
    return f"{_hz(a)} / {_hz(b)}"


def events_only_table(cal: EventsOnlyCalibration) -> str:
    """The fit of a recording without frames as a Markdown table: what was fitted, from what, and what was not.

    Parameters
    ----------
    cal : EventsOnlyCalibration
        The fit.

    Returns
    -------
    str
        The table, and its notes below it.
    """
    pre, fit, n, a = cal.preset, cal.dvs, cal.noise, cal.activity
    source = "given" if cal.thresholds_given else f"{cal.preset_name}'s (not fitted: events alone do not tell them)"
    w0, w1 = cal.window_s
    rows = [("quantity", "real", cal.preset_name, "fitted"), ("---", "---:", "---:", "---:"),
            ("ON / OFF threshold (log)", source, f"{pre.pos_threshold:.3f} / {pre.neg_threshold:.3f}",
             f"{fit.pos_threshold:.3f} / {fit.neg_threshold:.3f}"),
            ("threshold spread, cutoff, log offset", "not identified", "", "the preset's"),
            ("refractory (us)", f"{cal.refractory['edge_us']}" + ("" if cal.refractory["identified"] else " (?)"),
             f"{pre.refractory_us}", f"{fit.refractory_us}")]
    for name, label in (("shot_noise_hz", "shot noise, ON + OFF (Hz)"), ("leak_hz", "leak (Hz)"),
                        ("dark_shot_noise_hz", "dark shot noise (Hz; needs the light level)"),
                        ("hot_pixel_fraction", "hot pixels (fraction)"), ("hot_pixel_hz", "hot pixel rate (Hz)")):
        rows.append((label, "", f"{getattr(pre, name):.3g}", f"{getattr(fit, name):.3g}"))
    rows += [
        (f"events {w0:g}-{w1:g} s (from the first event)", f"{cal.real['events'] / 1000:.1f} k", "", ""),
        (f"quiet pixels: {n['quiet_pixels']}, hot among them: {n['hot_pixels']}", "", "", ""),
        ("quiet-pixel noise ON / OFF (Hz), still scene simulated", _pair(n["quiet_on_hz"], n["quiet_off_hz"]),
         _pair(*cal.check["preset"]), _pair(*cal.check["fitted"])),
        ("background (quiet, not hot) ON / OFF (Hz)", _pair(n["background_on_hz"], n["background_off_hz"]), "",
         ""),
        ("leak: ON beyond OFF (Hz); a long simulation's", _hz(n["leak_observed_hz"]), "",
         _hz(n["leak_stationary_hz"])),
        ("hot pixels: rate beyond background (Hz), ON share", f"{_hz(n['hot_observed_hz'])}, "
         f"{n['hot_on_share']:.0%}" if n["hot_pixels"] else "-", "", "half ON"),
        (f"background ON / OFF, quietest third of {a['bins']} bins of {ACTIVITY_BIN_US // 1000} ms (Hz)",
         _pair(a["quiet_third"]["on_hz"], a["quiet_third"]["off_hz"]), "", "no activity dependence"),
        (f"... busiest third (sensor at {a['busy_third']['sensor_hz'] / 1e3:.0f} k/s, quietest "
         f"{a['quiet_third']['sensor_hz'] / 1e3:.0f} k/s)", _pair(a["busy_third"]["on_hz"], a["busy_third"]["off_hz"]),
         "", ""),
        ("timestamps: resolution (us), steps back, shared", f"{cal.timestamps['resolution_us']}, "
         f"{cal.timestamps['steps_back']}, {cal.timestamps['shared_fraction']:.0%}", "", "1, 0, per event"),
    ]
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    lines = ["| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |" for r in rows]
    notes = ([f"warm-up: the first {cal.warm_up_s:.3g} s left out"] if cal.warm_up_s else []) + cal.notes
    return "\n".join(lines + [f"note: {t}" for t in notes])


def events_only_sensor(cal: EventsOnlyCalibration, name: str, description: str = "") -> sim.Sensor:
    """The sim.Sensor of an events-only fit: the fitted DVS fields (FITTED_FIELDS, and the thresholds when given)
    over the preset, and a provenance that says the thresholds were not fitted.

    Parameters
    ----------
    cal : EventsOnlyCalibration
        The fit.
    name : str
        The sensor's name.
    description : str, optional
        Its description (default: what was fitted and what is the preset's).

    Returns
    -------
    Sensor
        The sensor.
    """
    from generators.scenes.recording_frames import sha256_of

    path = cal.path
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    thresholds = ("given (--thresholds), not fitted" if cal.thresholds_given else
                  f"the preset {cal.preset_name}'s, not fitted: events alone do not tell the contrast thresholds")
    n, a = cal.noise, cal.activity
    provenance = {
        "method": "evsim calibrate, events only (no frames): noise per polarity, hot pixels and refractory period "
                  "fitted from the events (evsim_eval.calibrate.events_only)",
        "recording": path.name, "sha256": sha256_of(files), "window_s": [float(v) for v in cal.window_s],
        "thresholds": thresholds,
        "not_fitted": "pos_threshold, neg_threshold, threshold_sigma, cutoff_hz, dark_fraction: "
                      + ("given" if cal.thresholds_given else cal.preset_name) + "; dark_shot_noise_hz set to 0",
        "quiet_pixels": n["quiet_pixels"], "quiet_on_hz": round(n["quiet_on_hz"], 6),
        "quiet_off_hz": round(n["quiet_off_hz"], 6), "background_on_hz": round(n["background_on_hz"], 6),
        "background_off_hz": round(n["background_off_hz"], 6),
        "busy_over_quiet_noise": round((a["busy_third"]["on_hz"] + a["busy_third"]["off_hz"])
                                       / max(a["quiet_third"]["on_hz"] + a["quiet_third"]["off_hz"], 1e-12), 3),
        "refractory_identified": bool(cal.refractory["identified"]),
        "timestamp_resolution_us": cal.timestamps["resolution_us"], "seed": cal.seed,
        "date": datetime.date.today(),
    }
    fields = FITTED_FIELDS + (("pos_threshold", "neg_threshold") if cal.thresholds_given else ())
    return sim.Sensor(name=name, dvs=cal.dvs, base=cal.preset_name, dvs_fields=fields, provenance=provenance,
                      description=description or f"fitted to {path.name} by evsim calibrate from its events alone "
                                                 f"(no frames); thresholds {thresholds}")


def write_events_only(cal: EventsOnlyCalibration, path: str | Path, name: str | None = None) -> Path:
    """Write the sensor file of an events-only fit (sim.write_sensor, atomic); return its path.

    Parameters
    ----------
    cal : EventsOnlyCalibration
        The fit.
    path : str or pathlib.Path
        The sensor file (.toml).
    name : str, optional
        The sensor's name (default: the file's stem).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    path = Path(path)
    sim.write_sensor(path, events_only_sensor(cal, name or path.stem))
    return path


__all__ = ["EventsOnlyCalibration", "calibrate_events_only", "events_only_table", "events_only_sensor",
           "write_events_only", "timestamp_behaviour", "refractory_edge", "activity_dependence", "leak_rate_over",
           "leak_for", "measure_noise", "fit_noise", "still_scene_check", "same_pixel_intervals", "events_window"]
