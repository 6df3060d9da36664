"""
The AKF fusing events and frames, step by step
==============================================

The Asynchronous Kalman Filter (AKF; Wang, Ng, Scheerlinck and Mahony, ICCV 2021) on a built-in AHDR sequence, in
the paper's setting: a DAVIS346-like event sensor and an LDR camera behind the clipping "window" CRF, over an HDR
scene (the astronaut photo made HDR, under a pan).

1. what the sensors give: event frames, time surfaces and the event rate;
2. one well-exposed and one saturated pixel over time: the true log intensity, the DVS reference level and its
   events, the LDR samples through the inverse CRF, the augmented frame (EDI-deblurred frames joined by events),
   the AKF estimate with its +-2 sqrt(P) band and the complementary filter;
3. the whole image: LDR input, AKF, complementary filter, frames only and the HDR reference, with error maps and
   the Kalman gain;
4. events against the reconstruction over time, as an animation.

Run it yourself: ``python examples/04_akf_step_by_step.py --out FOLDER``.
"""

# %%
# A built-in sequence
# -------------------
# `generators.ahdr.generate_ahdr` simulates both sensors over the scene and writes one native HDF5 file with the
# events, the LDR frames and the HDR reference frames; `evsim_app.plots.prepare` reads it and derives what the
# reconstructions need (the CRF, the contrast thresholds, the reference in the CRF's units).

import numpy as np
from _shared import builtin_sequence, output_dir

from evsim_app.plots import animate, load_recording, plot_compare, plot_events, plot_pixel, prepare

out = output_dir("The AKF fusing events and frames, step by step")
path = builtin_sequence(out / "04_sequence.h5", sensor="davis346", crf="window")
prep = prepare(load_recording(path))
rec = prep.rec
print(f"{rec.events.size} events and {rec.frames.shape[0]} frames of {rec.width}x{rec.height} px")

# %%
# 1. What the sensors give
# ------------------------
# Event frames (ON red, OFF blue) and time surfaces over 10 ms windows at three times, and the event rate.

plot_events(rec, out / "04_events.png", window_ms=10)

# %%
# 2. One pixel over time
# ----------------------
# A pixel whose first frame is mid-grey, and the brightest pixel of the first reference frame, which the window
# CRF clips. Between frames the AKF follows the events; at each frame it is pulled toward the augmented frame
# with a gain set by the frame's certainty, so a clipped frame barely pulls and the events carry the estimate.

counts = np.bincount(rec.events["y"].astype(np.int64) * rec.width + rec.events["x"],
                     minlength=rec.width * rec.height).reshape(rec.height, rec.width)
mid = np.abs(rec.frames[0].astype(float) - 128) + 1000 * (counts < 10)
picks = {"well_exposed": np.unravel_index(np.argmin(mid), mid.shape),
         "saturated": np.unravel_index(np.argmax(rec.reference[0]), mid.shape)}
for name, (y, x) in picks.items():
    s = plot_pixel(prep, int(x), int(y), out / f"04_pixel_{name}.png")
    print(f"{name} pixel (x={x}, y={y}): {s.event_t_us.size} events, "
          f"{int(s.frame_clipped.sum())}/{s.frame_clipped.size} frames clipped")

# %%
# 3. The whole image
# ------------------
# At the reference time nearest the middle of the sequence: the LDR input, each method and the HDR reference
# (one log tone map for all, its range in x on the colour bar), then the AKF's Kalman gain and each method's signed
# log error.

res = plot_compare(prep, out / "04_compare.png")
print(f"at {res['t_us'] / 1e3:g} ms, PU21-PSNR: " + ", ".join(f"{m} {v:.2f} dB" for m, v in res["pu21_psnr"].items()))

# %%
# 4. Events against the reconstruction
# ------------------------------------
# Each animation frame shows the events since the previous one next to the AKF's estimate at that time and the
# HDR reference.

animate(prep, out / "04_events_vs_akf.gif", n_frames=20)
print(f"wrote the figures and the animation to {out}")
