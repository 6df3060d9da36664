"""
The AKF, and a wrong threshold
==============================

The Asynchronous Kalman Filter fuses the events (fast, relative) and the frames (slow, absolute, clipped) into HDR
video. Between frames it adds p C for each event; at each frame it moves toward the frame with the gain
K = P / (P + R), where R is large where the frame clipped. Tell it a wrong threshold C and every event moves the
estimate by the wrong step: the error grows with the events between frames.
"""

# %%
# Error against the contrast the filter is told
# ---------------------------------------------
# `evsim_app.lab.reconstruction_model` generates a small AHDR sequence once (astronaut photo, DAVIS346-like
# sensor, gamma CRF) and runs the AKF, the complementary filter and frames only at every reference time.

import numpy as np

from evsim_app.lab import reconstruction_model as model
from evsim_app.plots.common import pyplot

plt = pyplot()
n = model.reference_times().size
picks = list(range(5, n, 10))
scales = [0.5, 0.7, 1.0, 1.4, 2.0]
rmse = {m: [np.mean([model.snapshot(i, s).rmse[m] for i in picks]) for s in scales] for m in model.METHODS}
fig, ax = plt.subplots(figsize=(6, 3.5))
for m, values in rmse.items():
    ax.plot(scales, values, "o-", label=m)
ax.set_xscale("log")
ax.set_xlabel("contrast the AKF is told / the sensor's")
ax.set_ylabel("log RMSE")
ax.legend()

# %%
# The images and their errors
# ---------------------------
# In the middle of the sequence: the reference, each method (one log tone map) and its log error (red: too bright).

for scale in (1.0, 2.0):
    s = model.snapshot(n // 2, scale)
    fig, axes = plt.subplots(2, 4, figsize=(12, 4.4))
    axes[0, 0].imshow(s.tone(s.reference), cmap="gray", vmin=0, vmax=1)
    axes[0, 0].set_title("reference", fontsize=8)
    axes[1, 0].imshow(s.ldr, cmap="gray", vmin=0, vmax=1)
    axes[1, 0].set_title("LDR frame", fontsize=8)
    for k, m in enumerate(model.METHODS, start=1):
        axes[0, k].imshow(s.tone(s.images[m]), cmap="gray", vmin=0, vmax=1)
        axes[0, k].set_title(f"{m} (AKF told {scale:g} C)" if m == "akf" else m, fontsize=8)
        axes[1, k].imshow(s.log_error[m], cmap="RdBu_r", vmin=-2, vmax=2)
        axes[1, k].set_title(f"log error, RMSE {s.rmse[m]:.3f}", fontsize=8)
    for ax in axes.ravel():
        ax.axis("off")

# %%
# In Jupyter: the panel
# ---------------------

import panel as pn  # noqa: E402

from evsim_app.lab.reconstruction_panel import ReconstructionPanel  # noqa: E402

pn.extension()
recon = ReconstructionPanel()
recon.start()
recon.view
