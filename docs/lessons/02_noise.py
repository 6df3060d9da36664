"""
Noise: shot noise, leak and hot pixels
======================================

A real DVS fires events with no change of light: shot noise (random events, more in the dark), leak (the reference
drifts down, so a static pixel fires ON events now and then) and hot pixels (a few pixels firing all the time).
evsim labels every event with its cause, so the noise can be counted exactly.
"""

# %%
# One pixel: noise events against the shot-noise rate
# ---------------------------------------------------
# The labelled shot-noise events of one pixel over 1 s follow the rate set (a Poisson count).

import numpy as np

from evsim_app.lab.images import events_rgba
from evsim_app.lab.pixel_model import PixelSettings, simulate_pixel
from evsim_app.lab.scene_model import NOISE_TYPES, SceneSettings, simulate_scene
from evsim_app.plots.common import pyplot

plt = pyplot()
rates = [0, 2, 5, 10, 20]
shot = [np.mean([simulate_pixel(PixelSettings(shot_noise_hz=f, leak_hz=0, seed=s)).counts["shot"]
                 for s in range(5)]) for f in rates]
fig, ax = plt.subplots(figsize=(5, 3.2))
ax.plot(rates, shot, "o-", label="labelled shot events (mean of 5 seeds)")
ax.plot(rates, rates, "k--", label="the rate x 1 s")
ax.set_xlabel("shot noise (Hz)")
ax.set_ylabel("events in 1 s")
ax.legend(fontsize=8)

# %%
# The whole sensor: noise types one by one
# ----------------------------------------
# The astronaut scene panned at 200 px/s, 346x260 pixels; the last 20 ms of events with each noise type alone.

cases = [("no noise", ())] + [(name, (name,)) for name in NOISE_TYPES]
fig, axes = plt.subplots(1, len(cases), figsize=(15, 2.6))
for ax, (title, noise) in zip(axes, cases):
    r = simulate_scene(SceneSettings(noise=noise))
    ax.imshow(events_rgba(r.on, r.off).view(np.uint8).reshape(*r.on.shape, 4)[::-1])
    ax.set_title(f"{title}\n{r.n_events} events, {r.n_noise} noise", fontsize=8)
    ax.axis("off")

# %%
# In Jupyter: the panel
# ---------------------

import panel as pn  # noqa: E402

from evsim_app.lab.scene_panel import ScenePanel  # noqa: E402

pn.extension()
scene = ScenePanel()
scene.start()
scene.view
