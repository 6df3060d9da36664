"""`evsim convert INPUT...`: videos, image folders, stacks or a recording's frames -> events (+ LDR frames and HDR
reference with --outputs), one sequence per clip (generators.convert)."""

from __future__ import annotations

import argparse
from pathlib import Path

import sim
from generators.choices import DIS_PRESET_NAMES, FLOW_METHODS, UPSAMPLE_MODES

from .dataset_flags import add_sensor_flags, lighting_from_flags, settings_from_flags
from .flags import EPILOG, SENSOR_HELP, add_output_flags, add_run_flags, non_negative, positive, run_options
from .model_flags import sensor_size


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register `convert` on the evsim subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The evsim subparsers.
    """
    conv = sub.add_parser("convert", help="video(s) -> events (+ LDR frames + HDR reference with --outputs), one "
                          "sequence per clip",
                          epilog=EPILOG)
    conv.add_argument("inputs", nargs="+", type=Path, metavar="INPUT",
                      help="a video file (what OpenCV reads: mp4, avi, mov, mkv, ...), a folder of images "
                           "(PNG/JPG/TIFF 8/16-bit, EXR/HDR float) with a timestamps.txt or --fps, a .npy stack "
                           "(N, H, W[, C]), a folder of videos, or a hybrid recording's frames (.aedat4, IJRR "
                           "folder)")
    conv.add_argument("--config", help="TOML conversion configuration: seed, format, [defaults] (sensor, dvs, "
                                       "camera, crf, ... as generate's) and [video] (start_s, upsample, ...); the "
                                       "flags override it (see generators.convert_config)")
    g = conv.add_argument_group("input")
    g.add_argument("--start-s", type=non_negative(float),
                   help="start of the clip in seconds from the input's first frame (default 0)")
    g.add_argument("--stop-s", type=non_negative(float), default=None,
                   help="end of the clip in seconds (default: the input's last frame)")
    g.add_argument("--input-fps", "--fps", dest="fps", type=positive(float),
                   help="the rate the input frames were captured at, frames per second (default: a video's "
                        "capture-rate metadata, else its container rate; image folders and .npy stacks need it or "
                        "timestamps)")
    g.add_argument("--slowmo", type=float, metavar="FACTOR",
                   help="a slow-motion video: captured FACTOR times faster than its container rate (e.g. 32 for "
                        "960 fps stored at 30); phones' capture-rate metadata is read without it")
    g.add_argument("--resize", choices=("crop", "pad", "stretch"),
                   help="when the sensor's aspect ratio differs from the input's: crop (fill the sensor, centred; "
                        "default), pad (the whole input, black bars) or stretch (the whole input, distorted)")
    g.add_argument("--input-conditioning", choices=("temporal", "off"),
                   help="per-pixel temporal filter of the input before the DVS, against codec artefacts (key "
                        "frames, flicker) and read noise on static pixels (default: temporal for video files, off "
                        "for image folders and stacks)")
    g.add_argument("--input-noise-dn", type=non_negative(float), metavar="DN",
                   help="temporal noise rms of the input in its code values (e.g. a camera's read noise); turns "
                        "the conditioning on (default: estimated from a video)")
    g.add_argument("--timestamps", type=Path, help="input frame times, one per line: integer microseconds or "
                                                   "decimal seconds (default: timestamps.txt in an image folder)")
    g.add_argument("--input-crf", help="linearisation: crf_models curve whose inverse maps 8/16-bit input to linear "
                                       "radiance (default srgb; linear, or the recorded one, for a recording's frames; "
                                       "float input is taken as linear; the output's metadata states it)")
    g.add_argument("--black-level", type=non_negative(float), help="the integer input's value for no light "
                                                                    "(subtracted before linearising; default 0, or "
                                                                    "the --sensor file's [input] black_level)")
    g.add_argument("--upsample", choices=UPSAMPLE_MODES,
                   help="between input frames: flow (motion-compensated, default), linear (in log radiance) or "
                        "none (hold each frame)")
    g.add_argument("--flow", choices=FLOW_METHODS, help="optical flow (OpenCV; default dis)")
    g.add_argument("--flow-preset", choices=DIS_PRESET_NAMES, help="DIS preset (default medium)")
    g.add_argument("--flow-scale", type=float, help="compute the flow on the frames resized by this factor "
                                                    "(0 < s <= 1; default 0.5)")
    s = conv.add_argument_group("sensors")
    s.add_argument("--height", type=positive(int),
                   help="sensor height in pixels (default: the input's; alone, it keeps the aspect ratio; see "
                        "--resize; the input is area-resized)")
    s.add_argument("--width", type=positive(int), help="sensor width in pixels (default: the input's)")
    s.add_argument("--camera-fps", type=positive(float), help="frame rate of the synthetic LDR camera (default 30)")
    add_sensor_flags(s, crf_default="srgb")
    conv.add_argument("--sensor", metavar="NAME|FILE", help=f"{SENSOR_HELP} (default davis346)")
    add_output_flags(conv, "evsim_convert")
    add_run_flags(conv)
    conv.set_defaults(func=run)

def run(args: argparse.Namespace) -> int:
    """`evsim convert`: every clip to one sequence, then one line naming the folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags of `evsim convert`.

    Returns
    -------
    int
        The exit code (0: success; errors are raised, for evsim_app.main to report).
    """
    from types import SimpleNamespace

    from generators.convert import convert
    from generators.convert_config import load_convert_config, merge_settings

    # --config's settings, the flags over them
    cfg = load_convert_config(args.config) if args.config is not None else {"settings": {}, "video": {}}
    # the sensor flags as generate reads them, with the LDR camera's frame rate from --camera-fps
    flags = SimpleNamespace(**{**vars(args), "fps": args.camera_fps, "fps_flag": "--camera-fps",
                               "duration_s": None, "height": None, "width": None, "sensor_size": None})
    settings = merge_settings(cfg["settings"], settings_from_flags(flags))
    height, width = settings.pop("height", None), settings.pop("width", None)
    if args.sensor_size is not None or args.height is not None or args.width is not None:
        height, width = sensor_size(args)
    video = {k: getattr(args, k) for k in ("start_s", "stop_s", "fps", "slowmo", "timestamps", "upsample", "flow",
                                           "flow_preset", "flow_scale", "input_crf", "resize", "black_level")}
    video["conditioning"] = conditioning_option(args)
    video["lighting"] = lighting_from_flags(args)
    video = {k: v for k, v in video.items() if v is not None}
    seed = args.seed if args.seed is not None else cfg.get("seed") or 0
    index = convert(args.inputs, args.out, settings=settings, height=height, width=width, seed=seed,
                    fmt=args.format or cfg.get("format") or "native", overwrite=args.overwrite,
                    progress=not args.no_progress, **{**cfg["video"], **video}, **run_options(args))
    import json

    n = len(json.loads(index.read_text())["sequences"])
    print(f"converted {n} clip(s) to {index.parent} (index: {index.name})")
    return 0


def conditioning_option(args: argparse.Namespace) -> str | dict | None:
    """convert's scene option `conditioning` from --input-conditioning and --input-noise-dn.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    str, dict or None
        A mode name, a table with noise_dn (DN), or None (the default).
    """
    if args.input_noise_dn is None:
        return args.input_conditioning
    if args.input_conditioning == "off":
        raise sim.EvsimInputError("--input-noise-dn sets the conditioning's noise: drop --input-conditioning off")
    return {"mode": "temporal", "noise_dn": args.input_noise_dn}
