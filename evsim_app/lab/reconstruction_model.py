"""The reconstruction panel's computation: a small AHDR sequence generated once (the astronaut photo made HDR,
panned under a DAVIS346-like sensor and an LDR camera behind a gamma CRF), reconstructed at every
reference time by the AKF, the complementary filter (CF) and frames only.

The sequence and the CF and frames-only images are computed once and cached; the AKF is cached per contrast
scale, the factor between the thresholds the filter is told and the sensor's nominal ones (1: right; 0.5 or 2:
every event integrated with half or twice its real step).
"""

from __future__ import annotations

import functools
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import akf
from evsim_app.plots.common import Prepared, ToneMap, load_recording, prepare
from evsim_eval.metrics import log_rmse

HEIGHT, WIDTH, DURATION_S, REFERENCE_HZ = 72, 96, 0.5, 100.0
METHODS = ("akf", "cf", "frames")
CRF = "gamma"  # the LDR camera's response: clips the brightest parts of the HDR photo, not most of it


@functools.lru_cache(maxsize=1)
def sequence() -> Prepared:
    """The generated sequence, read back and prepared for akf (cached: about 10 s the first time)."""
    from generators.ahdr import generate_ahdr
    from generators.config import build_scene, parse_config, to_ahdr_config

    data = {"seed": 0, "defaults": {"duration_s": DURATION_S, "height": HEIGHT, "width": WIDTH, "sensor": "davis346",
                                    "crf": {"name": CRF}, "output": {"reference_rate_hz": REFERENCE_HZ}},
            "sequence": [{"name": "lab", "scene": {"type": "builtin_image", "image": "astronaut",
                                                   "trajectory": {"pan_px_per_s": [30.0, 8.0]}}}]}
    spec = parse_config(data, source="<evsim lab>").sequences[0]
    s = spec.settings
    path = Path(tempfile.mkdtemp(prefix="evsim_lab_")) / "lab.h5"
    generate_ahdr(build_scene(spec.scene, s["height"], s["width"], spec.duration_us), path, to_ahdr_config(s), 0,
                  progress=False)
    return prepare(load_recording(path), need_reference=True)


def reference_times() -> np.ndarray:
    """The reference times (int64 us) within the frames, where every method has a frame on either side."""
    rec = sequence().rec
    t = rec.reference_t_us.astype(np.int64)
    return t[(t > rec.frame_t_mid_us[0]) & (t < rec.frame_t_mid_us[-1])]


@functools.lru_cache(maxsize=8)
def reconstruction(method: str, contrast_scale: float = 1.0) -> np.ndarray:
    """(T, H, W) float64 images (x units) of `method` at reference_times(); the thresholds given to it are the
    recording's nominal ones times contrast_scale (only the AKF is recomputed when it changes)."""
    prep = sequence()
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; one of {', '.join(METHODS)}")
    if method != "akf" and contrast_scale != 1.0:
        return reconstruction(method, 1.0)
    contrast = tuple(c * contrast_scale for c in prep.contrast)
    opts = {"contrast": contrast, "bit_depth": prep.rec.frame_bit_depth}
    if method == "akf":
        opts["leak_rate_hz"] = prep.leak_rate_hz
    return akf.METHODS[method](*prep.reconstruct_args(), reference_times(), **opts).astype(np.float64)


@dataclass
class Snapshot:
    """One time of the reconstruction panel: t_us; reference and images {method: image} (x units); tone the one
    tone map of all of them; log_error {method: signed log error against the reference, natural log units};
    rmse {method: log_rmse}; ldr the nearest frame's normalised response."""

    t_us: int
    reference: np.ndarray
    images: dict
    tone: ToneMap
    log_error: dict
    rmse: dict
    ldr: np.ndarray


def snapshot(index: int, contrast_scale: float = 1.0) -> Snapshot:
    """The panel's view at reference_times()[index] with the AKF told contrast_scale times the thresholds."""
    prep = sequence()
    times = reference_times()
    index = int(np.clip(index, 0, times.size - 1))
    t = int(times[index])
    r = int(np.argmin(np.abs(prep.rec.reference_t_us - t)))
    reference = prep.reference_x[r]
    k = int(np.argmin(np.abs(prep.rec.frame_t_mid_us - t)))
    top = float(prep.frames_range()[1].max())
    tone = ToneMap.from_reference(reference, frames_top=top)
    images = {m: reconstruction(m, contrast_scale if m == "akf" else 1.0)[index] for m in METHODS}
    return Snapshot(t_us=t, reference=reference, images=images, tone=tone,
                    log_error={m: tone.log_error(im, reference) for m, im in images.items()},
                    rmse={m: log_rmse(np.maximum(im, 0), reference, top) for m, im in images.items()},
                    ldr=prep.rec.frames[k].astype(np.float64) / ((1 << prep.rec.frame_bit_depth) - 1))
