"""Helpers shared by the example scripts: the --out flag and a small built-in sequence generated on the fly."""

from __future__ import annotations

import argparse
from pathlib import Path


def example_args(description: str = "an evsim teaching example", *, video: bool = False) -> argparse.Namespace:
    """Parse the examples' flags: --out (default ./examples_out; the folder is created) and, with video=True,
    --video (a clip to convert instead of the built-in one). sphinx-gallery runs the examples with --out set."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", type=Path, default=Path("examples_out"), help="folder for the figures "
                                                                              "(default ./examples_out)")
    if video:
        parser.add_argument("--video", type=Path, default=None,
                            help="a video file to convert (default: a clip made from the built-in astronaut photo)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def output_dir(description: str = "an evsim teaching example") -> Path:
    """Parse --out (default ./examples_out), create the folder and return it."""
    return example_args(description).out


def builtin_sequence(path, *, scene=None, height=72, width=96, duration_s=0.5, sensor="ideal", crf="gamma",
                     reference_rate_hz=100.0, seed=0, **settings):
    """Generate one built-in scene (default: the astronaut photo, made HDR, under a pan) into the native file
    `path` with generators.ahdr; returns the path. Extra settings follow the generators.config schema."""
    from generators.ahdr import generate_ahdr
    from generators.config import build_scene, parse_config, to_ahdr_config

    scene = scene or {"type": "builtin_image", "image": "astronaut", "trajectory": {"pan_px_per_s": [30.0, 8.0]}}
    data = {"seed": seed, "defaults": {"duration_s": duration_s, "height": height, "width": width, "sensor": sensor,
                                       "crf": {"name": crf}, "output": {"reference_rate_hz": reference_rate_hz},
                                       **settings},
            "sequence": [{"name": Path(path).stem, "scene": scene}]}
    spec = parse_config(data, source="<example>").sequences[0]
    s = spec.settings
    generate_ahdr(build_scene(spec.scene, s["height"], s["width"], spec.duration_us), path, to_ahdr_config(s), seed,
                  progress=False)
    return Path(path)
