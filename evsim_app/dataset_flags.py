"""The scene and sensor flags of `generate` and `convert`, and the dataset configuration they build (the
generators.config schema): --scene/--image and motion, sizes, the LDR camera, CRF, sampling, outputs, lighting and the
model flags (evsim_app.model_flags)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import sim
from sim.suggest import unknown_name

from .flags import SENSOR_HELP, output_list, positive
from .model_flags import add_model_flags, camera_overrides, dvs_overrides, parse_assignments, sensor_size

if TYPE_CHECKING:
    from generators.config import DatasetConfig


def settings_from_flags(args: argparse.Namespace) -> dict:
    """Sequence settings (generators.config schema) from the flags that were given.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    dict
        The settings (generators.config.DEFAULTS keys and units).
    """
    from generators.config import resolve_sensor

    height, width = sensor_size(args)
    s = {k: v for k, v in (("duration_s", args.duration_s), ("height", height), ("width", width)) if v is not None}
    if args.sensor is not None:
        s["sensor"] = resolve_sensor("--sensor", args.sensor)
    s["dvs"] = dvs_overrides(args)
    s["camera"] = camera_overrides(args, {getattr(args, "fps_flag", "--fps"): ("fps", args.fps),
                                          "--exposure-us": ("exposure_us", args.exposure_us)})
    if args.crf is not None:
        s["crf"] = {"name": args.crf, "params": {}}
    if args.sampling is not None:
        s["sampling"] = {"mode": args.sampling}
    if args.sampling_quantile is not None:
        s.setdefault("sampling", {})["quantile"] = args.sampling_quantile
    s["output"] = {"labels": True} if args.labels else {}
    if args.outputs is not None:
        s["output"]["outputs"] = args.outputs
    if args.reference_rate_hz is not None:
        s["output"]["reference_rate_hz"] = args.reference_rate_hz
    return s


def scene_sequences(args: argparse.Namespace) -> list[dict]:
    """[[sequence]] tables for the scene flags: --image, or --scene (built-in names), or the whole built-in set.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    list of dict
        The sequence tables.
    """
    from generators.builtin_sequences import BUILTIN_SEQUENCES

    if args.image is not None:
        traj = {"pan_px_per_s": list(args.pan), "zoom_per_s": args.zoom, "rotation_deg_per_s": args.rotation,
                "shake_px": args.shake_px}
        return [{"name": Path(args.image).stem, "scene": {"type": "image", "path": str(Path(args.image).resolve()),
                                                         "trajectory": traj}}]
    if args.scene is None:
        return [dict(s) for s in BUILTIN_SEQUENCES]
    by_name = {s["name"]: s for s in BUILTIN_SEQUENCES}
    if args.scene not in by_name:
        raise sim.EvsimInputError(f"unknown --scene {args.scene!r}; built-in scenes: {', '.join(by_name)}")
    return [dict(by_name[args.scene])]


_SCENE_FLAGS = ("scene", "image", "duration_s", "height", "width", "sensor_size", "fps", "exposure_us", "crf",
                "labels", "reference_rate_hz", "sampling", "outputs")


def lighting_from_flags(args: argparse.Namespace) -> dict | None:
    """The scene lighting table of --lighting; EvsimInputError naming the flag for an unknown field.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    dict or None
        The table (generators.scenes.LIGHTING_KEYS: Hz, fraction, radians, fraction), None without --lighting.
    """
    from generators.scenes import LIGHTING_KEYS, checked_lighting

    table = parse_assignments("--lighting", args.lighting)
    for name in table:
        if name not in LIGHTING_KEYS:
            raise sim.EvsimInputError(f"--lighting: {unknown_name('field', name, LIGHTING_KEYS)}")
    checked_lighting(**table, owner="--lighting")
    return table or None


def dataset_config(args: argparse.Namespace) -> DatasetConfig:
    """The dataset configuration of generate: --config with the model flags over every sequence, or the scene
    flags' sequences.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    DatasetConfig
        The configuration.
    """
    from generators.config import load_config, parse_config, resolve_sensor

    if args.config is not None:
        given = [f for f in _SCENE_FLAGS if getattr(args, f) not in (None, False)]
        if given:
            raise sim.EvsimInputError(f"--{given[0].replace('_', '-')} cannot be combined with --config: "
                                      "set it in the configuration file")
        cfg = load_config(args.config)
        sensor = None if args.sensor is None else resolve_sensor("--sensor", args.sensor)
        dvs, camera = dvs_overrides(args), camera_overrides(args)
        lighting = lighting_from_flags(args)
        for spec in cfg.sequences:  # the model flags over every sequence's settings
            if sensor is not None:
                spec.settings["sensor"] = sensor
            spec.settings["dvs"] = {**spec.settings["dvs"], **dvs}
            spec.settings["camera"] = {**spec.settings["camera"], **camera}
            if lighting is not None:
                spec.scene = {**spec.scene, "lighting": {**spec.scene.get("lighting", {}), **lighting}}
        return cfg
    sequences, lighting = scene_sequences(args), lighting_from_flags(args)
    if lighting is not None:
        sequences = [{**seq, "scene": {**seq["scene"], "lighting": lighting}} for seq in sequences]
    data = {"defaults": settings_from_flags(args), "sequence": sequences}
    return parse_config(data, source="<command line>")


def add_sensor_flags(g: argparse._ArgumentGroup, crf_default: str = "window") -> None:
    """The LDR camera, CRF, DVS sampling and output flags shared by generate and convert (read by
    settings_from_flags, with the camera's --fps).

    Parameters
    ----------
    g : argparse._ArgumentGroup
        The group to add the flags to.
    crf_default : str, optional
        The --crf default (default "window").
    """
    g.add_argument("--exposure-us", type=positive(int),
                   help="exposure time of each frame in microseconds (default 10000)")
    g.add_argument("--crf", help=f"camera response function name from crf_models (default: {crf_default})")
    g.add_argument("--sampling", choices=("adaptive", "fixed"), help="DVS input sampling (default adaptive)")
    g.add_argument("--sampling-quantile", type=float,
                   help="adaptive sampling: quantile of the per-pixel log change kept below half the threshold per "
                        "sample (default 0.95; 1 = the worst pixel, about 10x denser)")
    g.add_argument("--labels", action="store_true", help="store per-event labels (signal/shot/leak/hot)")
    g.add_argument("--outputs", type=output_list, metavar="LIST",
                   help="what each file holds, comma-separated: events[,frames,reference] (LDR frames, HDR "
                        "reference; default: all three for generate, events only for convert)")
    g.add_argument("--reference-rate-hz", type=float,
                   help="rate in Hz of extra HDR reference frames, besides one per LDR frame (default 0)")
    g.add_argument("--lighting", action="append", metavar="FIELD=VALUE",
                   help="light every scene with a flickering lamp (generators.scenes.FlickerLighting; repeatable, "
                        "FIELD=VALUE,FIELD=VALUE): flicker_hz (Hz: 100 for 50 Hz mains, 120 for 60 Hz), depth "
                        "(modulation, 0..1; default 0.2), phase_rad (default 0), rise_fraction (share of the "
                        "period in which the light rises, 0.05..0.95; default 0.5, a cosine)")
    add_model_flags(g)


def add_scene_flags(p: argparse.ArgumentParser) -> None:
    """--config and the scene, sensor and model flags of `evsim generate` (read by dataset_config).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser to add the flags to.
    """
    from generators.builtin_sequences import BUILTIN_SEQUENCES

    names = ", ".join(s["name"] for s in BUILTIN_SEQUENCES)
    p.add_argument("--config", help="TOML dataset configuration (see generators.config)")
    g = p.add_argument_group("scene and sensors (without --config)")
    g.add_argument("--scene", help=f"a built-in scene: {names} (default: all of them for ahdr, the first for sweep)")
    g.add_argument("--image", help="an HDR image (.exr, .hdr, .npy) or an LDR image (inverse sRGB) to move over")
    g.add_argument("--pan", type=float, nargs=2, default=(60.0, 0.0), metavar=("VX", "VY"),
                   help="with --image: camera pan in pixels per second (default: 60 0)")
    g.add_argument("--zoom", type=float, default=0.0, help="with --image: zoom rate in 1/s (log magnification per "
                                                          "second; default 0)")
    g.add_argument("--rotation", type=float, default=0.0, help="with --image: rotation in degrees per second")
    g.add_argument("--shake-px", type=float, default=0.0, help="with --image: hand-held shake amplitude in pixels")
    g.add_argument("--duration-s", type=positive(float), help="sequence duration in seconds (default 1.0)")
    g.add_argument("--height", type=positive(int), help="sensor height in pixels (default 180)")
    g.add_argument("--width", type=positive(int), help="sensor width in pixels (default 240)")
    g.add_argument("--fps", type=positive(float), help="frame rate of the LDR camera in frames per second (default 30)")
    add_sensor_flags(g)
    p.add_argument("--sensor", metavar="NAME|FILE",
                   help=f"{SENSOR_HELP} (default davis346); with --config it replaces every sequence's sensor")
