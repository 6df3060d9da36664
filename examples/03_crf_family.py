"""The camera response functions of crf_models and their weighting functions, and what they do to an HDR image.

Figure 1: every curve (y against x on a log axis) and its weighting f^w(y) (eq. 5 of the AKF paper: the certainty
of a response, which sets the frame variance the filter uses). Figure 2: the built-in HDR image (more than 1e4:1)
through a few curves at the same exposure (median radiance at x = 0.18), next to the tone-mapped HDR radiance.

Run: python examples/03_crf_family.py [--out FOLDER]
"""

import numpy as np
from _shared import output_dir

import crf_models
from evsim_app.plots import ToneMap, plot_crfs
from evsim_app.plots.common import pyplot, save_figure
from generators.scenes import builtin_hdr_image

SHOWN = ("linear", "gamma", "srgb", "filmic", "window")


def main():
    out = output_dir(__doc__.splitlines()[0])
    plot_crfs(out / "03_crf_family.png")
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
    for ax in axes:
        ax.axis("off")
    print(f"wrote {out / '03_crf_family.png'}")
    print(f"wrote {save_figure(fig, out / '03_crf_images.png')}")


if __name__ == "__main__":
    main()
