"""One pixel over time: the figure that explains the method (`evsim plot pixel`).

Every curve is in the filter's log space L = log(x + I0), x the CRF's scaled irradiance and I0 = AKFParams.i0:
- truth: the HDR reference frames at the pixel (reference radiance converted to x, see common.Prepared.to_x; not
  drawn when the recording has no reference in known units);
- DVS reference level: rebuilt from the pixel's events, anchor + sum of p * C_p (C_p from the threshold map),
  anchored to the truth at the first reference time (exact for an ideal sensor: no leak, refractory or noise);
- LDR samples: log(CRF^-1(y) + I0) of each frame, drawn over its exposure window (hollow where the frame is clipped,
  i.e. its variance saturated), over an orange band: the range the frames record, [CRF^-1(0), CRF^-1(1)] (times
  T_0 / T_k for frame k's exposure), held from each exposure's start to the next;
- augmented frame L^A(t) (section 4.1, eq. 13): the interval curves from the AKF's own augmentation (EDI deblurring,
  contrast calibration), blended across each exposure;
- AKF estimate with a +-2 sqrt(P) band, and the complementary-filter estimate, at dense times.
The y axis spans every curve, wherever it lies against the frames' range (a reference hundreds of x above the
frames' top, a reconstruction not bounded by 1 x); the right axis labels it in x. The +-2 sqrt(P) band is cut at
that span.
The reconstructions run on the 3x3 neighbourhood of the pixel only: that is exact for the centre pixel (each pixel's
filter depends on its own events and frames and on its 8 neighbours' event times) and makes dense sampling cheap.
The AKF curve is the filter's own estimate, without the output smoothing of the published images (akf.smoothing:
smooth_range 0), which mixes a wider neighbourhood.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim import EvsimInputError, make_events

from .common import OFF_COLOUR, ON_COLOUR, Prepared, pyplot, save_figure

if TYPE_CHECKING:
    from pathlib import Path

    from akf.params import AKFParams
    from generators.formats.recording import Recording


@dataclass
class PixelSeries:
    """What plot_pixel draws (times int64 us, log values in log(x + I0) units).

    Attributes
    ----------
    x, y : int
        The pixel (column, row).
    reference_t_us, true_log : numpy.ndarray or None
        The reference frames' times and log values at the pixel (None when the file has none).
    event_t_us, event_p : numpy.ndarray
        The pixel's events: times and polarities.
    dvs_level_t_us, dvs_level : numpy.ndarray
        The rebuilt DVS reference level (a step function: the level holds from each time to the next).
    frame_t_start_us, frame_t_end_us : numpy.ndarray
        The LDR frames' exposure windows.
    frame_log, frame_clipped : numpy.ndarray
        The LDR samples' log values, and whether each is clipped.
    frame_range_log : numpy.ndarray
        (F, 2) the range each frame records, log(CRF^-1(0) T_0 / T_k + I0) and log(CRF^-1(1) T_0 / T_k + I0).
    i0 : float
        The I0 of every log value (x units).
    deblurred : numpy.ndarray
        (F, 2) EDI-deblurred log at each exposure's start and end.
    t_us : numpy.ndarray
        The dense sample times of augmented, akf, akf_std and cf.
    augmented : numpy.ndarray
        The AKF's augmented frame L^A at t_us.
    akf : numpy.ndarray
        The AKF's estimate at t_us.
    akf_std : numpy.ndarray
        Its standard deviation sqrt(P) (log units).
    cf : numpy.ndarray
        The complementary filter's estimate at t_us.
    """

    x: int
    y: int
    reference_t_us: np.ndarray | None
    true_log: np.ndarray | None
    event_t_us: np.ndarray
    event_p: np.ndarray
    dvs_level_t_us: np.ndarray
    dvs_level: np.ndarray
    frame_t_start_us: np.ndarray
    frame_t_end_us: np.ndarray
    frame_log: np.ndarray
    frame_clipped: np.ndarray
    frame_range_log: np.ndarray
    i0: float
    deblurred: np.ndarray
    t_us: np.ndarray
    augmented: np.ndarray
    akf: np.ndarray
    akf_std: np.ndarray
    cf: np.ndarray

    def log_span(self, margin: float = 0.05) -> tuple[float, float]:
        """The y range of the figure (log(x + I0)): every curve and the frames' range, widened by `margin` of the
        span (at least of 1 log unit) each side; not the +-2 sqrt(P) band, wide where the filter knows little.

        Parameters
        ----------
        margin : float, optional
            Fraction of the span added each side (default 0.05).

        Returns
        -------
        lo, hi : float
            Log(x + I0), natural log units.
        """
        parts = [self.dvs_level, self.frame_log, self.frame_range_log, self.deblurred, self.augmented, self.akf,
                 self.cf] + ([] if self.true_log is None else [self.true_log])
        values = np.concatenate([np.ravel(v) for v in parts])
        values = values[np.isfinite(values)]
        lo, hi = float(values.min()), float(values.max())
        pad = margin * max(hi - lo, 1.0)
        return lo - pad, hi + pad


def check_pixel(rec: Recording, x: int, y: int) -> None:
    """EvsimInputError unless (x, y) lies on the sensor.

    Parameters
    ----------
    rec : Recording
        The recording.
    x, y : int
        The pixel (column, row).
    """
    if not (0 <= x < rec.width and 0 <= y < rec.height):
        raise EvsimInputError(f"pixel (x={x}, y={y}) is outside the {rec.width}x{rec.height} sensor "
                              f"(x in 0..{rec.width - 1}, y in 0..{rec.height - 1})")


def _neighbourhood(prep: Prepared, x: int, y: int, params: AKFParams):
    """Events and frames of the 3x3 (or border-clipped) block around (x, y), in block coordinates, the AKF's
    contrast there (the whole sensor's flat-fielded thresholds, as the full-frame filter reads them from every
    pixel's event count: akf.flat_field) and the pixel's position in the block."""
    rec = prep.rec
    x0, x1 = max(x - 1, 0), min(x + 2, rec.width)
    y0, y1 = max(y - 1, 0), min(y + 2, rec.height)
    ev = rec.events
    keep = (ev["x"] >= x0) & (ev["x"] < x1) & (ev["y"] >= y0) & (ev["y"] < y1)
    ev = ev[keep]
    local = make_events(ev["t"], ev["x"] - x0, ev["y"] - y0, ev["p"])
    frames = np.ascontiguousarray(rec.frames[:, y0:y1, x0:x1])
    from akf.flat_field import thresholds

    maps = thresholds(prep.contrast, rec.events, rec.frames, (1 << rec.frame_bit_depth) - 1, prep.crf, params)
    contrast = np.stack([c.reshape(rec.height, rec.width)[y0:y1, x0:x1] for c in maps])
    return local, frames, contrast, (x - x0, y - y0)


def pixel_series(prep: Prepared, x: int, y: int, *, n_times: int = 1500,
                 params: AKFParams | None = None) -> PixelSeries:
    """Compute everything plot_pixel draws for pixel (x, y) (see the module docstring).

    Parameters
    ----------
    prep : Prepared
        The recording.
    x, y : int
        The pixel (column, row).
    n_times : int, optional
        Dense samples from the first exposure start to the end of the data (default 1500).
    params : AKFParams, optional
        The AKF's parameters (default AKFParams(); the output smoothing is turned off for one pixel).

    Returns
    -------
    PixelSeries
        The curves (log(x + I0) units) and their times (int64 us).
    """
    import akf
    from akf.frame_noise import frame_read_noise

    rec = prep.rec
    check_pixel(rec, x, y)
    params = dataclasses.replace(params or akf.AKFParams(), smooth_range=0.0)
    if params.read_noise_dn is None:  # the whole frames' read noise: the neighbourhood is too small to measure it
        params = dataclasses.replace(params, read_noise_dn=frame_read_noise(rec.frames, rec.frame_bit_depth))
    i0 = params.i0
    events, frames, contrast, (lx, ly) = _neighbourhood(prep, x, y, params)
    bw = frames.shape[2]
    i = ly * bw + lx
    mine = events[(events["x"] == lx) & (events["y"] == ly)]
    ev_t = mine["t"].astype(np.int64)
    t_end = [int(rec.frame_t_end_us[-1])]
    if ev_t.size:
        t_end.append(int(ev_t[-1]) + 1)
    if rec.reference_t_us is not None and rec.reference_t_us.size:
        t_end.append(int(rec.reference_t_us[-1]))
    t_us = np.unique(np.linspace(int(rec.frame_t_start_us[0]), max(t_end), n_times).astype(np.int64))
    args = (events, frames, rec.frame_t_start_us, rec.frame_t_end_us, prep.crf, t_us)
    opts = {"contrast": contrast, "bit_depth": rec.frame_bit_depth}
    est, var = akf.reconstruct(*args, params=params, leak_rate_hz=prep.leak_rate_hz, return_variance=True, **opts)
    cf = akf.complementary_filter(*args, i0=i0, contrast=prep.contrast, bit_depth=rec.frame_bit_depth)

    aug = akf.augmented_measurement(*args, [i], params=params, leak_rate_hz=prep.leak_rate_hz,
                                    **opts)  # what the filter tracks at the pixel
    augmented, deblurred = aug.log[:, 0], aug.deblurred[:, :, 0]
    frame_x, clipped = aug.intensity[:, 0], aug.clipped[:, 0]

    true_log = ref_t = None
    if prep.to_x is not None:
        ref_t = rec.reference_t_us.astype(np.int64)
        true_log = np.log(rec.reference[:, y, x].astype(np.float64) * prep.to_x + i0)
    thr = prep.thresholds[:, y, x]
    steps = np.where(mine["p"] > 0, thr[0], -thr[1])
    anchor_t = int(ref_t[0]) if ref_t is not None else int(rec.frame_t_start_us[0])
    anchor = float(true_log[0]) if true_log is not None else float(np.log(frame_x[0] + i0))
    return PixelSeries(
        x=x, y=y, reference_t_us=ref_t, true_log=true_log, event_t_us=ev_t, event_p=mine["p"].astype(np.int8),
        dvs_level_t_us=np.concatenate([[anchor_t], ev_t]), dvs_level=anchor + np.concatenate([[0.0], np.cumsum(steps)]),
        frame_t_start_us=rec.frame_t_start_us.astype(np.int64), frame_t_end_us=rec.frame_t_end_us.astype(np.int64),
        frame_log=np.log(frame_x + i0), frame_clipped=clipped,
        frame_range_log=np.log(np.stack(prep.frames_range(), axis=1) + i0), i0=i0, deblurred=deblurred, t_us=t_us,
        augmented=augmented,
        akf=np.log(est[:, ly, lx].astype(np.float64) + i0), akf_std=np.sqrt(var[:, ly, lx].astype(np.float64)),
        cf=np.log(cf[:, ly, lx].astype(np.float64) + i0),
    )


def _x_axis(ax, i0: float) -> None:
    """A right-hand axis giving the left axis's log(x + I0) in x: ticks at the powers of ten in range, else at 1, 2
    and 5 times them, else at every 1..9 times them, whichever first gives 4 or more."""
    sec = ax.secondary_yaxis("right", functions=(lambda v: np.exp(v) - i0,
                                                 lambda x: np.log(np.maximum(np.asarray(x) + i0, 1e-300))))
    lo, hi = (np.exp(v) - i0 for v in ax.get_ylim())
    for mantissas in ((1,), (1, 2, 5), range(1, 10)):
        ticks = [m * 10.0**e for e in range(-6, 7) for m in mantissas if lo <= m * 10.0**e <= hi]
        if len(ticks) >= 4:
            break
    sec.set_yticks(ticks, [f"{t:g}" for t in ticks])
    sec.set_ylabel("x (scaled irradiance; 1 = full well)")


def plot_pixel(prep: Prepared, x: int, y: int, out: str | Path, *, n_times: int = 1500,
               params: AKFParams | None = None) -> PixelSeries:
    """Draw pixel (x, y) over time into the image file `out` (see the module docstring); return the series.

    Parameters
    ----------
    prep : Prepared
        The recording.
    x, y : int
        The pixel (column, row).
    out : str or pathlib.Path
        The image file.
    n_times, params
        As pixel_series'.

    Returns
    -------
    PixelSeries
        What was drawn.
    """
    s = pixel_series(prep, x, y, n_times=n_times, params=params)
    plt = pyplot()
    fig, (ax, axe) = plt.subplots(2, 1, figsize=(11, 6.5), sharex=True, gridspec_kw={"height_ratios": [4, 1]})
    ms = 1e-3
    if s.true_log is not None:
        ax.plot(s.reference_t_us * ms, s.true_log, "k-", lw=1.6, marker=".", ms=4,
                label="true log intensity (reference)")
    t_last = s.t_us[-1]
    edges = np.append(s.frame_t_start_us, max(t_last, s.frame_t_start_us[-1])) * ms
    band = np.vstack([s.frame_range_log, s.frame_range_log[-1:]])
    ax.fill_between(edges, band[:, 0], band[:, 1], step="post", color="tab:orange", alpha=0.12, lw=0,
                    label="range the frames record: [CRF^-1(0), CRF^-1(1)]")
    ax.step(np.append(s.dvs_level_t_us, t_last) * ms, np.append(s.dvs_level, s.dvs_level[-1]), where="post",
            color="0.55", lw=1.0, label="DVS reference level (events x threshold)")
    for k in range(s.frame_log.size):
        t0, t1 = s.frame_t_start_us[k] * ms, s.frame_t_end_us[k] * ms
        style = {"color": "tab:orange", "lw": 4, "solid_capstyle": "butt", "alpha": 0.35 if s.frame_clipped[k] else 0.9}
        ax.plot([t0, t1], [s.frame_log[k]] * 2, **style,
                label="LDR frame: log(CRF^-1(y) + I0) over its exposure (faint: clipped)" if k == 0 else None)
        ax.plot([t0, t1], s.deblurred[k], "o", color="tab:orange", mfc="none", ms=5,
                label="EDI-deblurred frame at exposure start / end" if k == 0 else None)
    ax.plot(s.t_us * ms, s.augmented, "--", color="tab:green", lw=1.2, label="augmented frame L^A(t)")
    ax.fill_between(s.t_us * ms, s.akf - 2 * s.akf_std, s.akf + 2 * s.akf_std, color="tab:purple", alpha=0.18,
                    lw=0, label="AKF +-2 sqrt(P)")
    ax.plot(s.t_us * ms, s.akf, color="tab:purple", lw=1.4, label="AKF estimate")
    ax.plot(s.t_us * ms, s.cf, ":", color="tab:brown", lw=1.4, label="complementary filter")
    ax.set_ylabel("log(x + I0)")
    ax.set_ylim(*s.log_span())
    _x_axis(ax, s.i0)
    ax.set_title(f"pixel (x={s.x}, y={s.y}): {s.event_t_us.size} events, {s.frame_log.size} frames")
    ax.legend(fontsize=7, loc="best", ncol=2)
    ax.grid(alpha=0.3)
    on = s.event_p > 0
    axe.vlines(s.event_t_us[on] * ms, 0, 1, color=ON_COLOUR, lw=0.8, label=f"ON ({int(on.sum())})")
    axe.vlines(s.event_t_us[~on] * ms, -1, 0, color=OFF_COLOUR, lw=0.8, label=f"OFF ({int((~on).sum())})")
    axe.axhline(0, color="0.3", lw=0.5)
    axe.set_ylim(-1.2, 1.2)
    axe.set_yticks([])
    axe.set_ylabel("events")
    axe.set_xlabel("time (ms)")
    axe.legend(fontsize=7, loc="upper right")
    save_figure(fig, out)
    return s
