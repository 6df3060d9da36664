"""
The pixel: events from log intensity
====================================

One DVS pixel of evsim's emulator watching a light whose log intensity swings as a 4 Hz sinusoid. The pixel fires
an ON event each time its low-passed log intensity L_f rises a threshold C above its reference level, an OFF event
each time it falls C below; the reference then moves to the crossing. So the event count is about the total
variation of the log intensity divided by C: double the threshold, half the events.
"""

# %%
# The count against the threshold
# --------------------------------
# `evsim_app.lab.pixel_model.simulate_pixel` runs `sim.DVSEmulator` on one pixel, the LDR camera and the AKF; the
# events are exactly those of `sim.emulate`.

import numpy as np

from evsim_app.lab.pixel_model import PixelSettings, simulate_pixel
from evsim_app.plots.common import pyplot

plt = pyplot()
thresholds = np.round(np.arange(0.1, 0.81, 0.05), 2)
ideal = {"threshold_sigma": 0.0, "shot_noise_hz": 0.0, "leak_hz": 0.0, "cutoff_hz": 0.0, "refractory_us": 0}
counts = [simulate_pixel(PixelSettings(pos_threshold=c, neg_threshold=c, **ideal)).n_events for c in thresholds]
r = simulate_pixel(PixelSettings(**ideal))
variation = np.sum(np.abs(np.diff(r.log_input)))
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(thresholds, counts, "o-", label="events (evsim's DVS model)")
ax.plot(thresholds, variation / thresholds, "k--", label="total variation of log I / C")
ax.set_xlabel("contrast threshold C (log units)")
ax.set_ylabel("events in 1 s")
ax.legend()
print(f"total variation {variation:.2f} log units; events at C = 0.2: {counts[2]}")

# %%
# The pixel over time
# -------------------
# The reference level (grey) steps after the photoreceptor output (green); with a larger threshold the steps are
# larger and fewer.

fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
for ax, c in zip(axes, (0.2, 0.4)):
    r = simulate_pixel(PixelSettings(pos_threshold=c, neg_threshold=c))
    ax.plot(r.t_us / 1e3, r.log_input, "k-", lw=1, label="log(I + I_d)")
    ax.plot(r.trace_t_us / 1e3, r.photoreceptor, color="tab:green", lw=1, label="L_f")
    ax.step(r.trace_t_us / 1e3, r.reference, where="post", color="0.5", label="reference")
    ax.set_title(f"C = {c}: {r.n_events} events", fontsize=9)
    ax.set_ylabel("log units")
axes[0].legend(fontsize=7, ncol=3)
axes[-1].set_xlabel("time (ms)")

# %%
# In Jupyter: the panel
# ---------------------
# The same computation behind sliders (needs the ``lab`` extra); ``evsim lab`` serves it in the browser.

import panel as pn  # noqa: E402

from evsim_app.lab.pixel_panel import PixelPanel  # noqa: E402

pn.extension()
PixelPanel().view
