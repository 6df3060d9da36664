"""
What the LDR camera loses and what the CRF does
===============================================

An LDR camera maps scaled irradiance x (x = 1: the full well) through its camera response function (CRF) to a
response y in [0, 1] that is then quantised; what lies above the full well, or in the flat ends of the curve, is
clipped or crushed into a few levels. The AKF weights each frame pixel by the certainty of its response,
f^w(y) (eq. 5 of the AKF paper): high where the curve is steep, zero where it is clipped.

This example draws every curve of `crf_models` with its weighting, then passes the built-in HDR image (more than
1e4:1) through a few curves at the same exposure. Run it yourself:
``python examples/03_crf_family.py --out FOLDER``.
"""

# %%
# The curves and their weighting
# ------------------------------
# `evsim_app.plots.plot_crfs` draws y against x on a logarithmic axis (left) and the weighting f^w(y) (right)
# for every curve `crf_models.available` lists.

import numpy as np
from _shared import output_dir

import crf_models
from evsim_app.plots import ToneMap, plot_crfs
from evsim_app.plots.common import pyplot, save_figure
from generators.scenes import builtin_hdr_image

out = output_dir("What the LDR camera loses and what the CRF does")
plot_crfs(out / "03_crf_family.png")
print(f"wrote {out / '03_crf_family.png'}")

# %%
# An HDR image through five curves
# --------------------------------
# The built-in HDR astronaut, exposed so that its median radiance lands at x = 0.18, through five curves; the
# titles give the fraction of pixels at 0 or 1 (clipped). The first panel is the HDR radiance itself,
# tone-mapped (a global log map, evsim_app.plots.ToneMap) for display.

SHOWN = ("linear", "gamma", "srgb", "filmic", "window")
hdr = builtin_hdr_image("astronaut")[::4, ::4].astype(np.float64)
x = hdr * 0.18 / np.median(hdr)
plt = pyplot()
fig, axes = plt.subplots(1, len(SHOWN) + 1, figsize=(2.6 * (len(SHOWN) + 1), 3.0))
axes[0].imshow(ToneMap.from_reference(hdr)(hdr), cmap="gray", vmin=0, vmax=1)
axes[0].set_title(f"HDR radiance ({hdr.max() / hdr.min():.0f}:1)\ntone-mapped", fontsize=8)
for ax, name in zip(axes[1:], SHOWN):
    y = crf_models.get(name).forward(x)
    clipped = np.mean((y <= 0.0) | (y >= 1.0))
    ax.imshow(y, cmap="gray", vmin=0, vmax=1)
    ax.set_title(f"{name}\n{100 * clipped:.0f} % of pixels clipped", fontsize=8)
    print(f"{name}: {100 * clipped:.1f} % of the pixels clipped")
for ax in axes:
    ax.axis("off")
print(f"wrote {save_figure(fig, out / '03_crf_images.png')}")

# %%
# The "window" curve is the AKF paper's AHDR setting: only a band of the base response is kept and stretched to
# [0, 1], so most of the image is clipped at one end or the other. Those pixels get weight 0 and the largest
# frame variance in the filter, which then follows the events there.
