"""
DVS noise and its labels
========================

The same slowly moving edge seen by sensors with one non-ideality each, and the label the emulator gives every
event (signal, shot, leak, hot), which is what event denoisers are scored against.

- threshold mismatch: per-pixel thresholds drawn with a standard deviation of 0.05 log units, so the edge gives
  uneven event counts along it;
- shot noise: 5 Hz per pixel of random-polarity events, at any light level;
- leak: the reference level drifts down, so a static pixel fires ON events, here 2 Hz per pixel;
- hot pixels: 1 % of the pixels fire at 50 Hz on their own;
- the "noisy" preset, with all of them at once.

Run it yourself: ``python examples/02_noise_types.py --out FOLDER``.
"""

# %%
# Six sensors, one scene
# ----------------------
# `generators.scenes.MovingEdge` is an exact analytic scene (a step edge moving at 30 pixels per second);
# `sim.emulate_source` samples it and runs the emulator, and with ``return_labels=True`` also returns one label
# per event (indices into `sim.EVENT_LABELS`).

import numpy as np
from _shared import output_dir

import sim
from evsim_app.plots.common import pyplot, save_figure
from evsim_app.plots.events import event_frame, event_frame_rgb
from generators.scenes import MovingEdge

out = output_dir("DVS noise and its labels")
H, W, DURATION_US = 48, 64, 1_000_000
IDEAL = sim.DVSParams.preset("ideal")
CASES = [
    ("ideal", IDEAL),
    ("threshold mismatch\nsigma 0.05", IDEAL.replace(threshold_sigma=0.05)),
    ("shot noise 5 Hz", IDEAL.replace(shot_noise_hz=5.0)),
    ("leak 2 Hz", IDEAL.replace(leak_hz=2.0)),
    ("hot pixels 1 %\nat 50 Hz", IDEAL.replace(hot_pixel_fraction=0.01, hot_pixel_hz=50.0)),
    ("'noisy' preset", sim.DVSParams.preset("noisy")),
]
scene = MovingEdge(H, W, DURATION_US, speed_px_per_s=30.0, low=0.2, high=1.0)
times = np.arange(0, DURATION_US + 1, 2000, dtype=np.int64)
results = {}
for k, (title, params) in enumerate(CASES):
    results[title] = sim.emulate_source(scene, times, params, seed=k, return_labels=True)
    labels = results[title][1]
    counts = np.bincount(labels, minlength=len(sim.EVENT_LABELS))
    print(f"{title.replace(chr(10), ' ')}: " + ", ".join(f"{n} {c}" for n, c in zip(sim.EVENT_LABELS, counts)))

# %%
# Event counts and labels
# -----------------------
# Top: ON (red) and OFF (blue) event counts of each pixel over the whole second; the edge sweeps from a quarter
# of the width to the right. Bottom: how many events of each label each sensor produced (a logarithmic axis).

plt = pyplot()
fig, axes = plt.subplots(2, len(CASES), figsize=(2.6 * len(CASES), 5.2), gridspec_kw={"height_ratios": [1, 0.8]})
for k, (title, (ev, lab)) in enumerate(results.items()):
    axes[0, k].imshow(event_frame_rgb(event_frame(ev, H, W, 0, DURATION_US + 1)), interpolation="nearest")
    axes[0, k].set_title(f"{title}\n{ev.size} events", fontsize=8)
    axes[0, k].axis("off")
    counts = np.bincount(lab, minlength=len(sim.EVENT_LABELS))
    axes[1, k].bar(range(len(sim.EVENT_LABELS)), counts, color=["0.3", "tab:orange", "tab:green", "tab:purple"])
    axes[1, k].set_xticks(range(len(sim.EVENT_LABELS)), sim.EVENT_LABELS, fontsize=7, rotation=45)
    axes[1, k].set_yscale("symlog")
    axes[1, k].tick_params(labelsize=7)
axes[1, 0].set_ylabel("events by label")
print(f"wrote {save_figure(fig, out / '02_noise_types.png')}")

# %%
# Shot noise and hot pixels add events everywhere, leak adds ON events where nothing moves, and mismatch changes
# only how many signal events each pixel of the edge gives. A denoiser that keeps the signal and drops the rest is
# scored by how many events of each label it keeps: `evsim evaluate --task denoise` on files written with
# ``--labels`` (see the user guide).
