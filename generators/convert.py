"""Videos to datasets (`evsim convert`): each clip is a VideoScene run through the dataset pipeline of
`evsim generate` (generators.dataset.generate_dataset: DVS emulator, LDR camera, HDR reference, writers). A
converted clip holds its events only by default (CONVERT_OUTPUTS); the LDR frames and HDR reference on request.

convert(inputs, out_dir, ...) takes video files, image folders and .npy stacks (generators.scenes.video), or
folders of video files, and writes one sequence per clip. Each sequence's metadata (its "scene") records the
input's path and sha256, the capture rate used and where it comes from (timestamps, --input-fps, --slowmo, the
container's capture-rate metadata or its rate), the part used, the linearisation, the luminance weighting, the
resize policy, the input conditioning and the upsampling. The synthetic LDR frames use the sRGB CRF unless the
settings name another.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import sim
from sim import EvsimInputError, OptionError

from .choices import VIDEO_SUFFIXES
from .config import DatasetConfig, parse_config
from .dataset import generate_dataset
from .scenes.video import HDR_IMAGE_SUFFIXES, LDR_IMAGE_SUFFIXES, input_size

__all__ = ["convert", "convert_config", "clips", "SCENE_OPTIONS", "CONVERT_OUTPUTS"]

#: what a converted clip's file holds unless settings["output"]["outputs"] says otherwise: the events
CONVERT_OUTPUTS = ("events",)

# keys of the video scene table that convert() passes through (see generators.config.SCENE_TYPES["video"])
SCENE_OPTIONS = ("start_s", "stop_s", "fps", "slowmo", "timestamps", "upsample", "flow", "flow_preset", "flow_scale",
                 "key_step_px", "max_keys", "input_crf", "input_crf_params", "channel", "resize", "conditioning",
                 "black_level", "warm_up_s", "lighting")
#: the LDR camera's CRF when the settings name none: ordinary video looks as it did (the AHDR `window` CRF of
#: `generate` maps all but a narrow band of radiance to black or white)
DEFAULT_CRF = {"name": "srgb", "params": {}}


def clips(inputs: str | Path | Iterable[str | Path]) -> list[Path]:
    """The clips of the inputs: each video file, image folder or .npy stack is one clip; a folder that holds video
    files and no images stands for its videos, in name order.

    Parameters
    ----------
    inputs : str, Path or iterable of them
        A path or a list of paths.

    Returns
    -------
    list of Path
        The clips.
    """
    paths = [Path(inputs)] if isinstance(inputs, (str, Path)) else [Path(p) for p in inputs]
    if not paths:
        raise EvsimInputError("no input given")
    out = []
    for p in paths:
        if not p.exists():
            raise EvsimInputError(f"input not found: {p}")
        if p.is_dir():
            files = [f for f in sorted(p.iterdir()) if f.is_file()]
            videos = [f for f in files if f.suffix.lower() in VIDEO_SUFFIXES]
            images = [f for f in files if f.suffix.lower() in LDR_IMAGE_SUFFIXES + HDR_IMAGE_SUFFIXES]
            if videos and images:
                raise EvsimInputError(f"{p}: holds both videos and images; convert the videos or the image "
                                      "sequence, not a mix")
            out.extend(videos or [p])
        else:
            out.append(p)
    return out


def _sensor_size(path: Path, height: int | None, width: int | None) -> tuple[int, int]:
    """height, width: as given; one alone keeps the input's aspect ratio; none gives the input's size."""
    if height is not None and width is not None:
        return height, width
    h0, w0 = input_size(path)
    if height is None and width is None:
        return h0, w0
    return (max(1, round(width * h0 / w0)), width) if height is None else (height, max(1, round(height * w0 / h0)))


def convert_config(inputs: str | Path | Iterable[str | Path], *, settings: dict | None = None,
                   height: int | None = None, width: int | None = None, seed: int = 0,
                   **scene_options: Any) -> DatasetConfig:
    """The DatasetConfig that converts the inputs: one sequence per clip, named after it.

    Parameters
    ----------
    inputs : str, Path or iterable of them
        Clips, as clips() takes them.
    settings : dict, optional
        Sequence settings as in generators.config (sensor, dvs, camera, crf, sampling, output; the crf is
        DEFAULT_CRF, sRGB, unless given; output.outputs defaults to CONVERT_OUTPUTS, the events only: add "frames"
        and "reference" for the LDR frames and the HDR reference of the clip).
    height, width : int, optional
        Sensor size (pixels; default: each clip's own; one alone keeps the clip's aspect ratio).
    seed : int, optional
        The root seed (default 0).
    **scene_options
        Keys of SCENE_OPTIONS (the video scene table's units: seconds, Hz, DN; None: the VideoScene default;
        black_level defaults to the [input] table of a sensor file given as settings["sensor"]).

    Returns
    -------
    DatasetConfig
        The configuration.
    """
    unknown = set(scene_options) - set(SCENE_OPTIONS)
    if unknown:
        raise EvsimInputError(f"unknown conversion option(s) {', '.join(sorted(unknown))}; "
                              f"known: {', '.join(SCENE_OPTIONS)}")
    options = {k: (str(Path(v).resolve()) if k == "timestamps" else v)
               for k, v in scene_options.items() if v is not None}
    _check_clip_window(options.get("start_s", 0.0), options.get("stop_s"))
    sensor = (settings or {}).get("sensor")
    if sensor is not None and "black_level" not in options:  # a sensor file's [input] table: the frames' black
        black = sim.load_sensor(sensor).tables.get("input", {}).get("black_level")
        if black is not None:
            options["black_level"] = black
    sequences, names = [], set()
    for path in clips(inputs):
        name = path.stem if path.is_file() else path.name  # a file's suffix is not part of the sequence's name
        base, i = name, 1
        while name in names:
            i += 1
            name = f"{base}_{i}"
        names.add(name)
        h, w = _sensor_size(path, height, width)
        sequences.append({"name": name, "height": h, "width": w,
                          "scene": {"type": "video", "path": str(path.resolve()), **options}})
    defaults = {"crf": DEFAULT_CRF, **(settings or {})}
    defaults["output"] = {"outputs": list(CONVERT_OUTPUTS), **defaults.get("output", {})}
    return parse_config({"seed": seed, "defaults": defaults, "sequence": sequences}, source="<convert>")


def _check_clip_window(start_s: float, stop_s: float | None) -> None:
    """Before any work: the clip's window must be non-empty (OptionError naming --start-s and --stop-s)."""
    if stop_s is not None and isinstance(start_s, (int, float)) and isinstance(stop_s, (int, float)) \
            and stop_s <= start_s:
        raise OptionError(f"start_s={start_s:g} must come before stop_s={stop_s:g} (seconds from the input's first "
                          "frame)", f"--start-s {start_s:g} must come before --stop-s {stop_s:g} (seconds from the "
                          "input's first frame)")


def convert(inputs: str | Path | Iterable[str | Path], out_dir: str | Path, *, settings: dict | None = None,
            height: int | None = None, width: int | None = None, seed: int = 0, fmt: str = "native",
            overwrite: bool = False, progress: bool = True, workers: int | None = None, scheduler: str | None = None,
            resume: bool = False, **scene_options: Any) -> Path:
    """Convert video(s) into a dataset folder (one native HDF5 file per clip, with the events only unless
    settings["output"]["outputs"] asks for frames and reference; an optional export; index.json).

    Parameters
    ----------
    inputs, settings, height, width, seed, **scene_options
        As for convert_config.
    out_dir : str or Path
        The dataset folder.
    fmt, overwrite, progress, workers, scheduler, resume
        As for generate_dataset (one task per clip; fmt default "native").

    Returns
    -------
    Path
        The index.json written.
    """
    cfg = convert_config(inputs, settings=settings, height=height, width=width, seed=seed, **scene_options)
    return generate_dataset(cfg, out_dir, overwrite=overwrite, progress=progress, fmt=fmt, workers=workers,
                            scheduler=scheduler, resume=resume)
