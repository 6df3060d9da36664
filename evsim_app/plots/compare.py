"""Methods against the HDR reference at one reference time (`evsim plot compare`, and the README's HDR figure).

plot_compare: top row, the LDR input (the frame nearest in mid-exposure time, shown as its raw response), each
method's reconstruction and the HDR reference, all through one common.ToneMap (a global log map from a floor to the
reference's top, the same for every panel) with a colour bar in x on which the frame's recorded range
[CRF^-1(0), CRF^-1(1)] is marked. Bottom row: the AKF's Kalman gain K = P / R (1/s, log colour scale) and each
method's signed log error log(max(I, f)) - log(max(R, f)) (f the tone map's floor; natural log units, diverging
colours, one symmetric range for all methods), titled with its PU21-PSNR.
plot_hdr_recovery: the same tone-mapped panels and log errors without the gain, the reference first, the LDR input
under it (the README's figure; docs/make_hdr_figure.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from sim import EvsimInputError

from .common import Prepared, ToneMap, default_time_us, pyplot, save_figure

if TYPE_CHECKING:
    from pathlib import Path

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from akf.params import AKFParams
    from generators.formats.recording import Recording

DEFAULT_METHODS = ("akf", "cf", "frames")
ERROR_PERCENTILE = 99.5  # the log-error colour range: this percentile of |error| over every method's map
MIN_ERROR_RANGE = 0.5  # ... but at least this (log units: a factor 1.65), so a near-exact method is not all colour
ERROR_LABEL = "log(max(I, f)) - log(max(R, f))\n(ln units; red: too bright)"  # the error colour bar's label
FRAMES_COLOUR = "tab:orange"  # the frames' recorded range on the colour bar (and in the pixel figure)


def nearest_reference(rec: Recording, t_us: int) -> int:
    """Index of the reference frame nearest to t_us."""
    return int(np.argmin(np.abs(rec.reference_t_us - t_us)))


def compare_images(prep: Prepared, t_us: int | None = None, methods: Sequence[str] = DEFAULT_METHODS,
                   params: AKFParams | None = None, *, gain: bool = True) -> dict:
    """Reconstruct the reference time nearest t_us with each method and score it against the reference.

    Parameters
    ----------
    prep : Prepared
        The recording (needs an HDR reference in known units).
    t_us : int, optional
        Time (us); the nearest reference frame is used (default: the one nearest the middle of the frames).
    methods : sequence of str
        Names in akf.METHODS, each called by name with the recording's contrast and bit depth.
    params : AKFParams, optional
        The AKF's parameters (default AKFParams()); also given to "akf" through akf.METHODS.
    gain : bool
        Also return the AKF's Kalman gain (runs "akf" through akf.reconstruct with return_gain=True).

    Returns
    -------
    dict
        "t_us", "frame_index" (the frame nearest in mid-exposure time), "ldr" (its normalised response),
        "frames_range" ((lo, hi) x that frame records), "reference", "images" {method: image} (x units, unbounded),
        "tone_map" (ToneMap.from_reference of the reference with the frames' top), "log_error" {method: signed log
        error against the reference, natural log units, floored at the tone map's floor}, "pu21_psnr" {method:
        dB}, "gain" (the AKF's K in 1/s, or None).
    """
    import akf
    import evsim_eval

    rec = prep.rec
    references = prep.reference_x
    if references is None:
        raise EvsimInputError("the dataset has no HDR reference frames (in known units) to compare against")
    if not methods:
        raise EvsimInputError("no methods to compare (--methods): name at least one of akf.METHODS")
    unknown = [m for m in methods if m not in akf.METHODS]
    if unknown:
        raise EvsimInputError(f"unknown method {unknown[0]!r} (--methods); one of {', '.join(sorted(akf.METHODS))}")
    r = nearest_reference(rec, default_time_us(rec) if t_us is None else t_us)
    t = int(rec.reference_t_us[r])
    if t < rec.frame_t_start_us[0]:
        raise EvsimInputError(f"time {t / 1e3:g} ms (--at-ms) is before the first exposure starts "
                              f"({rec.frame_t_start_us[0] / 1e3:g} ms)")
    reference = references[r]
    opts = {"contrast": prep.contrast, "bit_depth": rec.frame_bit_depth}
    akf_opts = {"params": params or akf.AKFParams(), "leak_rate_hz": prep.leak_rate_hz}
    images, k_gain = {}, None
    for name in methods:
        if name == "akf" and gain:
            est, k_gain = akf.reconstruct(*prep.reconstruct_args(), [t], return_gain=True, **akf_opts, **opts)
            k_gain = k_gain[0]
        else:
            est = akf.METHODS[name](*prep.reconstruct_args(), [t], **(akf_opts if name == "akf" else {}), **opts)
        images[name] = est[0].astype(np.float64)
    k = int(np.argmin(np.abs(rec.frame_t_mid_us - t)))
    lo, hi = prep.frames_range()
    tone = ToneMap.from_reference(reference, frames_top=float(hi[k]))
    log_error = {m: tone.log_error(im, reference) for m, im in images.items()}
    psnr = {m: evsim_eval.pu21_psnr(np.clip(im, 0, None), reference) for m, im in images.items()}
    ldr = rec.frames[k].astype(np.float64) / ((1 << rec.frame_bit_depth) - 1)
    return {"t_us": t, "frame_index": k, "ldr": ldr, "frames_range": (float(lo[k]), float(hi[k])),
            "reference": reference, "images": images, "tone_map": tone, "gain": k_gain, "log_error": log_error,
            "pu21_psnr": psnr}


def _draw_tone_mapped(ax: Axes, tone: ToneMap, image: np.ndarray, title: str) -> np.ndarray:
    """Show tone(image) in grey on ax (0 black, 1 white) with the title; return the displayed array."""
    shown = tone(image)
    ax.imshow(shown, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    ax.set_title(title, fontsize=9)
    return shown


def _tone_colorbar(fig: Figure, ax: Axes | Sequence[Axes], tone: ToneMap, frames_range: tuple[float, float]) -> None:
    """A grey colour bar beside ax giving the tone map in x (log scale, floor to top), with the frames' recorded
    range [CRF^-1(0), CRF^-1(1)] drawn on it as an orange band (its part inside the tone map's range)."""
    import matplotlib.cm as mcm
    import matplotlib.colors as mcolors

    sm = mcm.ScalarMappable(norm=mcolors.LogNorm(vmin=tone.floor, vmax=tone.top), cmap="gray")
    bar = fig.colorbar(sm, ax=ax, fraction=0.05, pad=0.02)
    bar.set_label("radiance x (log scale)", fontsize=8)
    lo, hi = max(frames_range[0], tone.floor), min(frames_range[1], tone.top)
    if lo < hi:
        bar.ax.axhspan(lo, hi, color=FRAMES_COLOUR, alpha=0.55, lw=0)
        bar.ax.text(-0.15, float(np.sqrt(lo * hi)), "frames", rotation=90, ha="right", va="center", fontsize=7,
                    color=FRAMES_COLOUR, transform=bar.ax.get_yaxis_transform())
    bar.ax.tick_params(labelsize=7)


def _error_range(log_error: dict[str, np.ndarray]) -> float:
    """The symmetric colour range (log units) of the log-error maps: ERROR_PERCENTILE of the finite |error| over
    every method's map (an overflowed output gives inf), at least MIN_ERROR_RANGE."""
    finite = [np.abs(e[np.isfinite(e)]) for e in log_error.values()]
    return max([MIN_ERROR_RANGE] + [float(np.percentile(a, ERROR_PERCENTILE)) for a in finite if a.size])


def _draw_log_error(ax: Axes, error: np.ndarray, emax: float, title: str):
    """Show a signed log-error map on ax (red: brighter than the reference, blue: darker, white: exact) in
    [-emax, emax]; return the image (for a colour bar)."""
    im = ax.imshow(error, cmap="RdBu_r", vmin=-emax, vmax=emax, interpolation="nearest")
    ax.set_title(title, fontsize=8)
    return im


def plot_compare(prep: Prepared, out: str | Path, *, t_us: int | None = None, methods: Sequence[str] = DEFAULT_METHODS,
                 params: AKFParams | None = None) -> dict:
    """Draw compare_images(...) into the image file `out` (see the module docstring).

    Parameters
    ----------
    prep : Prepared
        The recording (needs an HDR reference in known units).
    out : str or pathlib.Path
        The image file.
    t_us, methods, params
        As compare_images'.

    Returns
    -------
    dict
        compare_images' result plus "shown" {panel: the displayed [0, 1] array} for "reference" and each method.
    """
    import matplotlib.colors as mcolors

    res = compare_images(prep, t_us, methods, params)
    tone = res["tone_map"]
    plt = pyplot()
    names = list(res["images"])
    cols = len(names) + 2
    fig, axes = plt.subplots(2, cols, figsize=(2.9 * cols + 0.8, 5.6), squeeze=False, layout="constrained")
    axes[0, 0].imshow(res["ldr"], cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    axes[0, 0].set_title(f"LDR input (frame {res['frame_index']})", fontsize=9)
    shown = {n: _draw_tone_mapped(ax, tone, res["images"][n], n) for ax, n in zip(axes[0, 1:], names)}
    shown["reference"] = _draw_tone_mapped(axes[0, -1], tone, res["reference"], "HDR reference")
    _tone_colorbar(fig, axes[0, 1:], tone, res["frames_range"])
    emax = _error_range(res["log_error"])
    for ax, n in zip(axes[1, 1:], names):
        im = _draw_log_error(ax, res["log_error"][n], emax, f"log error {n}\nPU21-PSNR {res['pu21_psnr'][n]:.2f} dB")
    fig.colorbar(im, ax=axes[1, 1:], fraction=0.05, pad=0.02).set_label(ERROR_LABEL, fontsize=7)
    ax = axes[1, 0]
    if res["gain"] is not None:
        g = np.clip(res["gain"], 1e-3, None)
        gi = ax.imshow(g, cmap="viridis", norm=mcolors.LogNorm(vmin=g.min(), vmax=max(g.max(), g.min() * 10)),
                       interpolation="nearest")
        fig.colorbar(gi, ax=ax, fraction=0.046, label="K = P / R (1/s)")
        ax.set_title("AKF Kalman gain", fontsize=9)
    else:
        ax.axis("off")
    axes[1, -1].axis("off")
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    lo, hi = res["frames_range"]
    fig.suptitle(f"t = {res['t_us'] / 1e3:g} ms; tone mapping: {tone.describe()}; the frames record "
                 f"{lo:.3g}..{hi:.3g} x", fontsize=9)
    save_figure(fig, out)
    return {**res, "shown": shown}


def plot_hdr_recovery(prep: Prepared, out: str | Path, *, t_us: int | None = None,
                      methods: Sequence[str] = ("frames", "akf"), params: AKFParams | None = None,
                      label: str = "") -> dict:
    """The HDR reference and each method tone-mapped alike side by side, with the methods' log-error maps below
    and the LDR input under the reference; every method is called through akf.METHODS by name.

    Parameters
    ----------
    prep, t_us, methods, params
        As compare_images (gain=False).
    out : str or Path
        The image file (format from the suffix).
    label : str
        Put before the figure's title (the time and the tone map), e.g. the dataset's name.

    Returns
    -------
    dict
        compare_images' result plus "shown" {panel: the displayed [0, 1] array}.
    """
    res = compare_images(prep, t_us, methods, params, gain=False)
    tone = res["tone_map"]
    plt = pyplot()
    names = list(res["images"])
    cols = len(names) + 1
    fig, axes = plt.subplots(2, cols, figsize=(3.0 * cols + 1.2, 5.2), squeeze=False, layout="constrained")
    shown = {"reference": _draw_tone_mapped(axes[0, 0], tone, res["reference"], "HDR reference")}
    shown.update({n: _draw_tone_mapped(ax, tone, res["images"][n], f"{n}  (PU21-PSNR {res['pu21_psnr'][n]:.1f} dB)")
                  for ax, n in zip(axes[0, 1:], names)})
    _tone_colorbar(fig, axes[0, :], tone, res["frames_range"])
    lo, hi = res["frames_range"]
    axes[1, 0].imshow(res["ldr"], cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    axes[1, 0].set_title(f"LDR input (records {lo:.2g}..{hi:.2g} x)", fontsize=8)
    emax = _error_range(res["log_error"])
    for ax, n in zip(axes[1, 1:], names):
        im = _draw_log_error(ax, res["log_error"][n], emax, f"log error {n}")
    fig.colorbar(im, ax=axes[1, :], fraction=0.05, pad=0.02).set_label(ERROR_LABEL, fontsize=7)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"{label + ', ' if label else ''}t = {res['t_us'] / 1e3:g} ms; tone mapping: {tone.describe()}",
                 fontsize=9)
    save_figure(fig, out)
    return {**res, "shown": shown}
