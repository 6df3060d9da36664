"""A noise-sweep study: how reconstruction quality degrades with DVS shot noise and threshold mismatch.

generators.sweep writes one sequence per grid point (the same scene and seeds, only the swept DVS parameters
change); evsim_app.plots.plot_sweep scores the AKF, the complementary filter and frames only on each (against the
HDR reference, between the first and last frame) and draws each metric against each swept parameter.

Run: python examples/05_noise_sweep.py [--out FOLDER]
"""

from _shared import output_dir

from evsim_app.plots import plot_sweep
from generators.config import build_scene, parse_config, to_ahdr_config
from generators.sweep import generate_sweep

GRID = {"shot_noise_hz": [0.0, 5.0, 20.0], "threshold_sigma": [0.0, 0.06]}


def main():
    out = output_dir(__doc__.splitlines()[0])
    data = {"seed": 0, "defaults": {"duration_s": 0.3, "height": 40, "width": 56, "sensor": "ideal",
                                    "crf": {"name": "gamma"}, "output": {"reference_rate_hz": 100.0}},
            "sequence": [{"name": "pan", "scene": {"type": "builtin_image", "image": "astronaut",
                                                   "trajectory": {"pan_px_per_s": [30.0, 8.0]}}}]}
    spec = parse_config(data, source="<example>").sequences[0]
    s = spec.settings
    scene = build_scene(spec.scene, s["height"], s["width"], spec.duration_us)
    results = out / "05_sweep"
    generate_sweep(scene, results, GRID, to_ahdr_config(s), 0, overwrite=True, progress=False)
    for metric in ("mse", "pu21_psnr"):
        rows = plot_sweep(results, out / f"05_sweep_{metric}.png", metric=metric)
        print(f"wrote {out / f'05_sweep_{metric}.png'}")
    for r in rows:
        print(r["point"], {m: round(v["pu21_psnr"], 2) for m, v in r["scores"].items()})


if __name__ == "__main__":
    main()
