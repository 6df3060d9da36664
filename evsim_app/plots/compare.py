"""Side-by-side comparison at one reference time (`evsim plot compare`).

Top row: the LDR input (the frame nearest in mid-exposure time, shown as its raw response), each method's
reconstruction and the HDR reference, all tone-mapped with common.ToneMap (global Reinhard on luminance, scale from
the reference). Bottom row: the AKF's Kalman gain K = P / R (1/s, log colour scale) and each method's absolute
log error |log(I + I0) - log(I_ref + I0)| (log units, one colour scale for all methods), titled with its PU21-PSNR.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from sim import EvsimInputError

from .common import Prepared, ToneMap, default_time_us, pyplot, save_figure

if TYPE_CHECKING:
    from pathlib import Path

    from akf.params import AKFParams
    from generators.formats.recording import Recording

DEFAULT_METHODS = ("akf", "cf", "frames")


def nearest_reference(rec: Recording, t_us: int) -> int:
    """Index of the reference frame nearest to t_us."""
    return int(np.argmin(np.abs(rec.reference_t_us - t_us)))


def compare_images(prep: Prepared, t_us: int | None = None, methods: Sequence[str] = DEFAULT_METHODS,
                   params: AKFParams | None = None) -> dict:
    """Reconstruct the reference time nearest t_us (default: the one nearest the middle of the frames) with each
    method. Returns {"t_us", "ldr" (normalised response), "reference", "images" {method: image}, "gain" (AKF K, 1/s),
    "log_error" {method: image}, "pu21_psnr" {method: dB}}; images in the CRF's scaled-irradiance units."""
    import akf

    rec = prep.rec
    references = prep.reference_x
    if references is None:
        raise EvsimInputError("the dataset has no HDR reference frames (in known units) to compare against")
    unknown = [m for m in methods if m not in akf.METHODS]
    if unknown:
        raise EvsimInputError(f"unknown method {unknown[0]!r}; one of {', '.join(sorted(akf.METHODS))}")
    r = nearest_reference(rec, default_time_us(rec) if t_us is None else t_us)
    t = int(rec.reference_t_us[r])
    if t < rec.frame_t_start_us[0]:
        raise EvsimInputError(f"time {t / 1e3:g} ms is before the first exposure starts "
                              f"({rec.frame_t_start_us[0] / 1e3:g} ms)")
    reference = references[r]
    opts = {"contrast": prep.contrast, "bit_depth": rec.frame_bit_depth}
    images, gain = {}, None
    for name in methods:
        if name == "akf":
            est, gain = akf.reconstruct(*prep.reconstruct_args(), [t], params=params or akf.AKFParams(),
                                        leak_rate_hz=prep.leak_rate_hz, return_gain=True, **opts)
            gain = gain[0]
        else:
            est = akf.METHODS[name](*prep.reconstruct_args(), [t], **opts)
        images[name] = est[0].astype(np.float64)
    i0 = (params or akf.AKFParams()).i0
    log_error = {m: np.abs(np.log(np.clip(im, 0, None) + i0) - np.log(reference + i0)) for m, im in images.items()}
    psnr = {m: akf.pu21_psnr(np.clip(im, 0, None), reference) for m, im in images.items()}
    k = int(np.argmin(np.abs(rec.frame_t_mid_us - t)))
    ldr = rec.frames[k].astype(np.float64) / ((1 << rec.frame_bit_depth) - 1)
    return {"t_us": t, "frame_index": k, "ldr": ldr, "reference": reference, "images": images, "gain": gain,
            "log_error": log_error, "pu21_psnr": psnr}


def plot_compare(prep: Prepared, out: str | Path, *, t_us: int | None = None, methods: Sequence[str] = DEFAULT_METHODS,
                 params: AKFParams | None = None) -> dict:
    """Draw compare_images(...) into the image file `out`; return its result and the tone map used."""
    import matplotlib.colors as mcolors

    res = compare_images(prep, t_us, methods, params)
    tone = ToneMap.from_reference(res["reference"])
    plt = pyplot()
    names = list(res["images"])
    cols = len(names) + 2
    fig, axes = plt.subplots(2, cols, figsize=(2.9 * cols, 5.4), squeeze=False)
    top = [(f"LDR input (frame {res['frame_index']})", res["ldr"], True)]
    top += [(n, tone(res["images"][n]), True) for n in names] + [("HDR reference", tone(res["reference"]), True)]
    for ax, (title, img, _) in zip(axes[0], top):
        ax.imshow(img, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
        ax.set_title(title, fontsize=9)
    emax = max(float(np.percentile(e, 99)) for e in res["log_error"].values()) or 1.0
    for ax, n in zip(axes[1, 1:], names):
        im = ax.imshow(res["log_error"][n], cmap="magma", vmin=0, vmax=emax, interpolation="nearest")
        ax.set_title(f"|log error| {n}\nPU21-PSNR {res['pu21_psnr'][n]:.2f} dB", fontsize=8)
    fig.colorbar(im, ax=axes[1, -1], fraction=0.1, location="left", label="log error (log units)")
    ax = axes[1, 0]
    if res["gain"] is not None:
        g = np.clip(res["gain"], 1e-3, None)
        gi = ax.imshow(g, cmap="viridis", norm=mcolors.LogNorm(vmin=g.min(), vmax=max(g.max(), g.min() * 10)),
                       interpolation="nearest")
        fig.colorbar(gi, ax=ax, fraction=0.046, label="K = P / R (1/s)")
        ax.set_title("AKF Kalman gain", fontsize=9)
    fig.text(0.5, 0.01, "tone mapping: " + tone.describe(), ha="center", fontsize=8)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    axes[1, -1].axis("off")
    if res["gain"] is None:
        axes[1, 0].axis("off")
    fig.suptitle(f"t = {res['t_us'] / 1e3:g} ms", fontsize=10)
    save_figure(fig, out)
    return {**res, "tone_map": tone}
