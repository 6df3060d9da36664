"""
Simulation against a real sensor
================================

A real DAVIS346 recording of a road beside evsim's simulation of it from its own frames, with the sensor
`evsim calibrate` fitted to it and with the uncalibrated davis346 guess, and the realism scores of both. The
recording lives in the project's shared data (../shared); without it this lesson says so and stops.
"""

# %%
# Both sensors against the recording
# ----------------------------------

from evsim_app.lab import real_model
from evsim_app.lab.images import events_rgba
from evsim_app.plots.common import pyplot

plt = pyplot()
if real_model.shared_recording() is None:
    print(f"no real recording: {real_model.RECORDING} is not in {real_model.shared_folder()}")
else:
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.4))
    for k, (label, preset) in enumerate(real_model.SENSORS.items()):
        c = real_model.compare_sensor(preset)
        if k == 0:
            axes[0].imshow(events_rgba(*c.counts(c.real, 1.0)).view("uint8").reshape(c.height, c.width, 4)[::-1])
            axes[0].set_title("real, 20 ms at 1 s", fontsize=8)
        axes[k + 1].imshow(events_rgba(*c.counts(c.simulated, 1.0)).view("uint8").reshape(c.height, c.width, 4)[::-1])
        axes[k + 1].set_title(f"{preset}: count ratio x{c.scores['count_ratio']:.2f}, "
                              f"blurred count correlation {c.scores['count_corr_blurred']:.2f}", fontsize=8)
        print(f"{label}:")
        for row in c.rows[:3] + c.rows[8:10]:
            print("   ", " | ".join(row))
    for ax in axes:
        ax.axis("off")

# %%
# In Jupyter: the panel
# ---------------------

import panel as pn  # noqa: E402

from evsim_app.lab.real_panel import RealPanel  # noqa: E402

pn.extension()
RealPanel().view
