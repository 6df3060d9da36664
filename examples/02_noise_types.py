"""DVS noise types side by side: the same slowly moving edge seen by sensors with one kind of non-ideality each.

Columns: an ideal sensor; threshold mismatch (per-pixel thresholds with sigma 0.05 log units: edges give uneven event
counts); shot noise (5 Hz per pixel of random-polarity events); leak (ON events at 2 Hz per pixel as the reference
drifts); hot pixels (1 % of pixels firing at 50 Hz); and the "noisy" preset with all of them. Top: ON/OFF event
counts over the whole 1 s; bottom: how many events of each label (signal, shot, leak, hot) each sensor produced.

Run: python examples/02_noise_types.py [--out FOLDER]
"""

import numpy as np
from _shared import output_dir

import sim
from evsim_app.plots.common import pyplot, save_figure
from evsim_app.plots.events import event_frame, event_frame_rgb
from generators.scenes import MovingEdge

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


def main():
    out = output_dir(__doc__.splitlines()[0])
    scene = MovingEdge(H, W, DURATION_US, speed_px_per_s=30.0, low=0.2, high=1.0)
    times = np.arange(0, DURATION_US + 1, 2000, dtype=np.int64)
    plt = pyplot()
    fig, axes = plt.subplots(2, len(CASES), figsize=(2.6 * len(CASES), 5.2),
                             gridspec_kw={"height_ratios": [1, 0.8]})
    labels = sim.EVENT_LABELS
    for k, (title, params) in enumerate(CASES):
        ev, lab = sim.emulate_source(scene, times, params, seed=k, return_labels=True)
        axes[0, k].imshow(event_frame_rgb(event_frame(ev, H, W, 0, DURATION_US + 1)), interpolation="nearest")
        axes[0, k].set_title(f"{title}\n{ev.size} events", fontsize=8)
        axes[0, k].axis("off")
        counts = np.bincount(lab, minlength=len(labels))
        axes[1, k].bar(range(len(labels)), counts, color=["0.3", "tab:orange", "tab:green", "tab:purple"])
        axes[1, k].set_xticks(range(len(labels)), labels, fontsize=7, rotation=45)
        axes[1, k].set_yscale("symlog")
        axes[1, k].tick_params(labelsize=7)
        print(f"{title.replace(chr(10), ' ')}: " + ", ".join(f"{n} {c}" for n, c in zip(labels, counts)))
    axes[1, 0].set_ylabel("events by label")
    path = save_figure(fig, out / "02_noise_types.png")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
