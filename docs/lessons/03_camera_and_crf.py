"""
The camera and its CRF
======================

The LDR camera integrates the light over each exposure, adds shot and read noise and maps the collected charge
through its camera response function (CRF) to 8-bit numbers; whatever fills the well clips. The inverse CRF gives
the light back only where the frame did not clip: the longer the exposure, the more of the signal is lost at the
top.
"""

# %%
# Frames against the light
# ------------------------
# The light of the one-pixel panel (a 4 Hz sinusoid in log), the frames' CRF^-1 for three exposures and two CRFs.

from evsim_app.lab.pixel_model import PixelSettings, simulate_pixel
from evsim_app.plots.common import pyplot

plt = pyplot()
fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
for ax, crf in zip(axes, ("gamma", "window")):
    for exposure, colour in ((1000, "tab:blue"), (5000, "tab:orange"), (20_000, "tab:red")):
        r = simulate_pixel(PixelSettings(exposure_us=exposure, crf=crf))
        ax.hlines(r.frame_log, r.frame_t_start_us / 1e3, r.frame_t_end_us / 1e3, color=colour, lw=4,
                  label=f"{exposure / 1e3:g} ms: {int(r.frame_clipped.sum())} of {r.frame_dn.size} clipped")
    ax.plot(r.t_us / 1e3, r.log_input, "k-", lw=1, label="log(I + I_d)")
    ax.set_title(f"CRF {crf}", fontsize=9)
    ax.set_ylabel("log radiance")
    ax.legend(fontsize=7, ncol=2)
axes[-1].set_xlabel("time (ms)")

# %%
# In Jupyter: the panel
# ---------------------
# Move the exposure and the CRF of the one-pixel panel.

import panel as pn  # noqa: E402

from evsim_app.lab.pixel_panel import PixelPanel  # noqa: E402

pn.extension()
PixelPanel().view
