"""The `evsim` command line. Each subcommand is a thin layer over the public Python API.

Exit codes: 0 success, 2 usage error, bad input or a full disk (message "evsim: error: ..."), 3 some sequences
failed (each listed with its error at the end; the others were written or scored: rerun with --resume), 1 unexpected
failure, 130 interrupted (Ctrl-C), 143 terminated (SIGTERM); temporary files are removed on every exit path.
Units: times in seconds (-s) or microseconds (-us) as the flag names say, sizes in pixels, rates in Hz,
speeds in pixels per second, angles in degrees, contrast thresholds in natural-log units.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import traceback
import warnings
from pathlib import Path

import sim
from evsim_eval.choices import DEFAULT_METHODS, DEFAULT_METRICS, KALMAN_METHODS, PROTOCOLS, TUNE_FRACTION, TUNE_METRIC
from generators.choices import DIS_PRESET_NAMES, EXPORT_FORMATS, FLOW_METHODS, OUTPUTS, UPSAMPLE_MODES
from generators.runner import TasksFailed, raise_failures
from sim.suggest import unknown_name

from . import export_command, lab_command
from .calibrate_command import add_parser as add_calibrate_parser
from .model_flags import add_model_flags, camera_overrides, dvs_overrides, flag_hint, parse_assignments, sensor_size
from .plots.cli import add_plot_parser
from .realism_command import add_realism_flags
from .sigterm import MESSAGE as SIGTERM_MESSAGE
from .sigterm import Watchdog, end_now
from .suggesting_parser import SuggestingParser

EPILOG = ("Units: times in seconds (-s) or microseconds (-us) as the flag names say, sizes in pixels, rates in Hz, "
          "speeds in pixels per second, angles in degrees, contrast thresholds in natural-log units. "
          "Exit codes: 0 success, 2 usage error, bad input or full disk, 3 some sequences failed (listed at the end; "
          "the others were done), 1 unexpected failure, 130 Ctrl-C, 143 SIGTERM.")
DEMO_SIZE = (90, 120)  # height, width of the demo sequence (pixels)
SENSOR_HELP = (f"the sensor model: a DVS preset ({', '.join(sim.DVS_PRESETS)}) or a sensor file (.toml: see "
               "docs/guide/calibrate.md)")


# ----- building a dataset configuration from flags -----------------------------------------------------------

def _settings_from_flags(args) -> dict:
    """Sequence settings (generators.config schema) from the flags that were given."""
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


def _scene_sequences(args) -> list[dict]:
    """[[sequence]] tables for the scene flags: --image, or --scene (built-in names), or the whole built-in set."""
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


def _lighting(args) -> dict | None:
    """The scene lighting table of --lighting (None without it); EvsimInputError naming the flag for an unknown
    field."""
    from generators.scenes import LIGHTING_KEYS, checked_lighting

    table = parse_assignments("--lighting", args.lighting)
    for name in table:
        if name not in LIGHTING_KEYS:
            raise sim.EvsimInputError(f"--lighting: {unknown_name('field', name, LIGHTING_KEYS)}")
    checked_lighting(**table, owner="--lighting")
    return table or None


def _dataset_config(args):
    from generators.config import load_config, parse_config, resolve_sensor

    if args.config is not None:
        given = [f for f in _SCENE_FLAGS if getattr(args, f) not in (None, False)]
        if given:
            raise sim.EvsimInputError(f"--{given[0].replace('_', '-')} cannot be combined with --config: "
                                      "set it in the configuration file")
        cfg = load_config(args.config)
        sensor = None if args.sensor is None else resolve_sensor("--sensor", args.sensor)
        dvs, camera = dvs_overrides(args), camera_overrides(args)
        lighting = _lighting(args)
        for spec in cfg.sequences:  # the model flags over every sequence's settings
            if sensor is not None:
                spec.settings["sensor"] = sensor
            spec.settings["dvs"] = {**spec.settings["dvs"], **dvs}
            spec.settings["camera"] = {**spec.settings["camera"], **camera}
            if lighting is not None:
                spec.scene = {**spec.scene, "lighting": {**spec.scene.get("lighting", {}), **lighting}}
        return cfg
    sequences, lighting = _scene_sequences(args), _lighting(args)
    if lighting is not None:
        sequences = [{**seq, "scene": {**seq["scene"], "lighting": lighting}} for seq in sequences]
    data = {"defaults": _settings_from_flags(args), "sequence": sequences}
    return parse_config(data, source="<command line>")


# ----- paths checked before any work ----------------------------------------------------------------------

_FOLDER_OUTPUT_COMMANDS = ("demo", "generate", "convert", "reconstruct")  # their --out is a folder
_FILE_OUTPUT_FLAGS = ("json", "out", "animate", "video")  # of the other commands (evaluate, plot): files
#: suffixes of the files evsim reads and writes: a new --out folder ending in one is a mistaken file name
_FILE_SUFFIXES = (".h5", ".hdf5", ".aedat4", ".aedat2", ".aedat", ".raw", ".dat", ".mat", ".zip", ".exr", ".txt",
                  ".json", ".mp4", ".avi", ".mov")
MAX_NAME_BYTES = 255  # per path component (NAME_MAX of Linux, macOS and Windows file systems)


def _check_paths(args) -> None:
    """--config and the outputs, before any work: EvsimInputError (exit 2, one line) naming the flag, the path and
    the problem. The configuration file itself is read by generators.config.read_text_file."""
    config = getattr(args, "config", None)
    if config is not None and not str(config):
        raise sim.EvsimInputError("--config is empty: give a TOML configuration file")
    folder = args.command in _FOLDER_OUTPUT_COMMANDS
    for flag in ("out",) if folder else _FILE_OUTPUT_FLAGS:
        value = getattr(args, flag, None)
        if value is not None:
            _check_output(f"--{flag}", str(value), folder=folder)
    if args.command == "export":  # DST: a file, or a folder for a folder of sequences
        _check_output("DST", str(args.dest), folder=None)


def _check_output(flag: str, text: str, *, folder: bool | None) -> None:
    """An output path that can be created (or, for a folder, exists as one) and written; folder=None: either."""
    from generators.config import missing_path_reason

    kind = "folder" if folder else "file"
    if not text:
        raise sim.EvsimInputError(f"{flag} is empty: give an output {kind}" + (" ('.' for the current folder)"
                                                                                 if folder else ""))
    path = Path(text)
    long = [part for part in path.parts if len(part.encode()) > MAX_NAME_BYTES]
    if long:
        raise sim.EvsimInputError(f"{flag} {text:.80}...: a name of {len(long[0].encode())} bytes, more than the "
                                  f"{MAX_NAME_BYTES} a file system allows")
    if path.is_symlink() and not path.exists():
        raise sim.EvsimInputError(f"{flag}: {missing_path_reason(path)}; remove the link or give another {kind}")
    if path.exists():
        if folder is None:
            return
        if folder and not path.is_dir():
            raise sim.EvsimInputError(f"{flag} {path} exists and is not a folder")
        if not folder and path.is_dir():
            raise sim.EvsimInputError(f"{flag} {path} is a folder, not a file")
        if folder and not _writable(path):
            raise sim.EvsimInputError(f"{flag} {path}: the folder is not writable (permissions or a read-only "
                                      "file system)")
        return
    if folder and path.suffix.lower() in _FILE_SUFFIXES:
        raise sim.EvsimInputError(f"{flag} {text} ends in {path.suffix}, a file's suffix, but names the output "
                                  f"folder (the files inside are named after each sequence): give a folder, e.g. "
                                  f"{flag} {path.with_suffix('')}")
    parent = next((q for q in path.absolute().parents if q.exists()), None)
    if parent is not None and not parent.is_dir():
        raise sim.EvsimInputError(f"{flag}: {parent} is a file, not a folder, so {path} cannot be created")
    if parent is not None and not _writable(parent):
        raise sim.EvsimInputError(f"{flag} {path} cannot be created: {parent} is not writable (permissions or a "
                                  "read-only file system)")


def _writable(folder: Path) -> bool:
    """Whether a file can be created in `folder`: tried (a temporary file, removed at once), since permission bits
    do not tell for root, read-only mounts or virtual file systems such as /proc."""
    import tempfile

    if not os.access(folder, os.W_OK | os.X_OK):
        return False
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


# ----- subcommands -----------------------------------------------------------------------------------------

def _cmd_generate_ahdr(args) -> int:
    from generators.dataset import generate_dataset

    cfg = _dataset_config(args)
    index = generate_dataset(cfg, args.out, overwrite=args.overwrite, progress=not args.no_progress,
                             fmt=args.format, seed=args.seed, **_run_options(args))
    print(f"wrote {len(cfg.sequences)} sequence(s) to {index.parent} (index: {index.name})")
    return 0


def _cmd_generate_sweep(args) -> int:
    from generators.config import build_scene, to_ahdr_config
    from generators.sweep import DEFAULT_GRID, GRID_KEYS, generate_sweep

    cfg = _dataset_config(args)
    spec = cfg.sequences[0]
    grid = dict(cfg.sweep)  # the configuration's [sweep], the grid flags over it; DEFAULT_GRID when neither
    for key in GRID_KEYS:
        values = getattr(args, key)
        if values is not None:
            grid[key] = values
    grid = grid or dict(DEFAULT_GRID)
    s = spec.settings
    scene = build_scene(spec.scene, s["height"], s["width"], spec.duration_us, where=f"sequence {spec.name!r}")
    index = generate_sweep(scene, args.out, grid, to_ahdr_config(s), cfg.seed if args.seed is None else args.seed,
                           overwrite=args.overwrite, progress=not args.no_progress, fmt=args.format or cfg.format,
                           **_run_options(args))
    print(f"wrote the sweep over {', '.join(grid)} for {spec.name!r} to {index.parent} (index: {index.name})")
    return 0


def _cmd_convert(args) -> int:
    from types import SimpleNamespace

    from generators.convert import convert
    from generators.convert_config import load_convert_config, merge_settings

    # --config's settings, the flags over them
    cfg = load_convert_config(args.config) if args.config is not None else {"settings": {}, "video": {}}
    # the sensor flags as generate reads them, with the LDR camera's frame rate from --camera-fps
    flags = SimpleNamespace(**{**vars(args), "fps": args.camera_fps, "fps_flag": "--camera-fps",
                               "duration_s": None, "height": None, "width": None, "sensor_size": None})
    settings = merge_settings(cfg["settings"], _settings_from_flags(flags))
    height, width = settings.pop("height", None), settings.pop("width", None)
    if args.sensor_size is not None or args.height is not None or args.width is not None:
        height, width = sensor_size(args)
    video = {k: getattr(args, k) for k in ("start_s", "stop_s", "fps", "slowmo", "timestamps", "upsample", "flow",
                                           "flow_preset", "flow_scale", "input_crf", "resize", "black_level")}
    video["conditioning"] = _conditioning_option(args)
    video["lighting"] = _lighting(args)
    video = {k: v for k, v in video.items() if v is not None}
    seed = args.seed if args.seed is not None else cfg.get("seed") or 0
    index = convert(args.inputs, args.out, settings=settings, height=height, width=width, seed=seed,
                    fmt=args.format or cfg.get("format") or "native", overwrite=args.overwrite,
                    progress=not args.no_progress, **{**cfg["video"], **video}, **_run_options(args))
    import json

    n = len(json.loads(index.read_text())["sequences"])
    print(f"converted {n} clip(s) to {index.parent} (index: {index.name})")
    return 0


def _conditioning_option(args) -> str | dict | None:
    """convert's scene option `conditioning` from --input-conditioning and --input-noise-dn."""
    if args.input_noise_dn is None:
        return args.input_conditioning
    if args.input_conditioning == "off":
        raise sim.EvsimInputError("--input-noise-dn sets the conditioning's noise: drop --input-conditioning off")
    return {"mode": "temporal", "noise_dn": args.input_noise_dn}


def _cmd_info(args) -> int:
    from .info import describe, format_description

    print(format_description(describe(args.file)))
    return 0


def _cmd_demo(args) -> int:
    import numpy as np

    from generators.builtin import ahdr_suite, ahdr_suite_config
    from generators.dataset import first_missing, remove_if_empty, write_sequence

    from .precompile import start_background_compile, wait

    height, width = sensor_size(args)
    height, width = height or DEMO_SIZE[0], width or DEMO_SIZE[1]
    if args.duration_s <= 0 or height <= 0 or width <= 0:
        raise sim.InvalidParameterError("--duration-s, --height and --width must be positive")
    from generators.config import resolve_sensor

    config = ahdr_suite_config(resolve_sensor("--sensor", args.sensor), dvs=dvs_overrides(args),
                               camera=camera_overrides(args))
    # The first sequence of the built-in AHDR suite (the AKF paper's construction; needs no files).
    name, scene = ahdr_suite(height, width, args.duration_s, include_hdr=False)[0]
    compiling = None if args.no_reconstruct else start_background_compile()  # on the other core meanwhile
    out = Path(args.out)
    created = first_missing(out)
    out.mkdir(parents=True, exist_ok=True)
    try:
        entry = write_sequence(out, "demo", scene, config, np.random.SeedSequence(args.seed),
                               "native", progress=not args.no_progress)
    except BaseException:  # failed or interrupted: no empty folder left behind
        remove_if_empty(out, created)
        raise
    path = out / entry["file"]
    from .info import describe, format_description

    print(f"evsim demo: {name} ({scene.describe()['image']}), written to {path}")
    print(format_description(describe(path)))
    if args.no_reconstruct:
        return 0
    from evsim_eval.evaluate import evaluate_recording
    from evsim_eval.protocols import UNITS
    from evsim_eval.tables import format_scores
    from generators.formats import load
    from generators.formats.atomic import write_text_atomic

    wait(compiling)
    table, _ = evaluate_recording(load(path))
    text = format_scores(table)
    write_text_atomic(out / "metrics.txt", text + "\n")
    print()
    print(text)
    print(f"(units: {UNITS['reference']})")
    print(f"\nmetrics written to {out / 'metrics.txt'}")
    return 0


def _cmd_evaluate(args) -> int:
    from evsim_eval.evaluate import evaluate_dataset
    from evsim_eval.tables import format_table, scoring_record, write_json

    if args.task == "denoise":
        return _evaluate_denoise(args)
    if args.task == "realism":
        from .realism_command import evaluate_realism

        return evaluate_realism(args)
    matched = not args.point_scoring
    scores = evaluate_dataset(args.dataset, protocol=args.protocol, methods=_names(args.methods),
                              metrics=_metrics(args), method_options=_akf_options(args), tune=args.tune,
                              tune_fraction=args.tune_fraction, tune_metric=args.tune_metric,
                              progress=False if args.no_progress else None, strict=False, exposure_matched=matched,
                              sensor=args.sensor,
                              **_run_options(args))
    scored = [s for s in next(iter(scores.table.values()), {}) if s != "mean"]
    if scored:
        print(format_table(scores.table, args.protocol, scores.notes, matched))
    raise_failures("sequences", scores.failures, len(scores.failures) + len(scored),
                   "the table above is over the others" + (f"; {args.json} not written" if args.json else ""))
    if args.json is not None:
        write_json(scores.table, args.json, scores.tuning, scoring_record(args.protocol, matched, scores.notes))
        print(f"\nscores written to {args.json}")
    return 0


def _refuse_run_flags(args, why: str) -> None:
    if args.workers is not None or args.scheduler is not None:
        raise sim.EvsimInputError(f"{why}: drop --workers/--scheduler")


def _evaluate_denoise(args) -> int:
    from evsim_eval.denoisers import evaluate_denoise_dataset, format_denoise_table, write_denoise_json

    _refuse_run_flags(args, "--task denoise runs in this process")
    filters = None if args.filters is None else _names(args.filters)
    result, notes = evaluate_denoise_dataset(args.dataset, filters=filters, reconstruct=not args.no_reconstruct,
                                             protocol=args.protocol, methods=_names(args.methods),
                                             metrics=_metrics(args), method_options=_akf_options(args),
                                             progress=not args.no_progress)
    print(format_denoise_table(result, notes))
    if args.json is not None:
        write_denoise_json(result, args.json)
        print(f"\nscores written to {args.json}")
    return 0


def _cmd_reconstruct(args) -> int:
    from evsim_eval.reconstruct import reconstruct_dataset

    if args.leak_hz is not None and args.method not in KALMAN_METHODS:
        raise sim.EvsimInputError(f"--leak-hz applies to the akf and aks methods only, not {args.method!r}")
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not args.overwrite:
        raise sim.EvsimInputError(f"output {out} already exists and is not an empty folder; pass --overwrite to "
                                  "replace it")
    options = _akf_options(args).get(args.method)
    from generators.formats.atomic import atomic_path

    with atomic_path(out, directory=True) as tmp:  # the whole --out appears at once, replacing the old one
        written = reconstruct_dataset(args.dataset, tmp, method=args.method, times=args.times,
                                      method_options=options, variance=args.variance)
    for name, folder, n in written:
        print(f"{name}: {n} {args.method} frames (linear, CRF x units) written to {out / folder.relative_to(tmp)}")
    return 0


def _akf_options(args) -> dict:
    """{"akf": {...}} from the AKF's command-line options (only those given: the recording's values otherwise)."""
    return {} if args.leak_hz is None else {m: {"leak_rate_hz": args.leak_hz} for m in KALMAN_METHODS}


def _metrics(args) -> tuple[str, ...]:
    """--metrics, or the --protocol's default metrics (evsim_eval.choices.DEFAULT_METRICS) when not given."""
    return DEFAULT_METRICS[args.protocol] if args.metrics is None else _names(args.metrics)


def _names(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise sim.EvsimInputError(f"expected a comma-separated list of names, got {text!r}")
    return names


# ----- parser --------------------------------------------------------------------------------------------

def _non_negative(kind):
    """argparse type: a finite number >= 0 converted by kind (int for seeds, float for rates)."""
    what = "a non-negative integer" if kind is int else "a finite number >= 0"

    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            v = -1
        if not (math.isfinite(v) and v >= 0):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return v

    return parse


def _outputs(text: str) -> list[str]:
    """argparse type of --outputs: comma-separated names of generators.choices.OUTPUTS, events among them."""
    names = [o.strip() for o in text.split(",") if o.strip()]
    unknown = [o for o in names if o not in OUTPUTS]
    if unknown or "events" not in names:
        why = f"unknown output {unknown[0]!r}" if unknown else "events are always written"
        raise argparse.ArgumentTypeError(f"{why}; give events[,frames,reference], got {text!r}")
    return names


def _add_run_flags(p, *, resume: bool = True) -> None:
    """--workers / --scheduler (and --resume): where the per-sequence tasks run (generators.runner)."""
    g = p.add_argument_group("running the sequences (default: one after the other in this process)")
    where = g.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_non_negative(int), metavar="N",
                       help="run them in parallel on a local Dask cluster of N (>= 1) worker processes")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="run them on an existing Dask cluster (e.g. tcp://host:8786; its workers need evsim and "
                            "the same input and output paths)")
    if resume:
        g.add_argument("--resume", action="store_true",
                       help="complete an earlier run into --out: keep the sequences whose file is complete and "
                            "records the same configuration and seed (hash), generate the others")


def _run_options(args) -> dict:
    """workers, scheduler (and resume) keyword arguments from the flags of _add_run_flags."""
    return {k: getattr(args, k) for k in ("workers", "scheduler", "resume") if hasattr(args, k)}


def _add_akf_flags(p) -> None:
    p.add_argument("--leak-hz", type=_non_negative(float), default=None,
                   help="the DVS's leak rate (Hz) for the AKF's leak-aware event model (default: the recorded "
                        "one, else 0 = the paper's model)")


def _add_output_flags(p, default_out: str) -> None:
    p.add_argument("--out", default=default_out, help=f"output folder (default: {default_out})")
    p.add_argument("--overwrite", action="store_true", help="replace the contents of an existing, non-empty --out")
    p.add_argument("--seed", type=_non_negative(int), default=None,
                   help="root seed (non-negative integer, numpy SeedSequence entropy; default: the config's, or 0)")
    p.add_argument("--format", choices=EXPORT_FORMATS, default=None,
                   help="also export every sequence to this layout (the native HDF5 file is always written)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")


def _add_sensor_flags(g, crf_default: str = "window") -> None:
    """The LDR camera, CRF, DVS sampling and output flags shared by generate and convert (read by
    _settings_from_flags, with the camera's --fps)."""
    g.add_argument("--exposure-us", type=int, help="exposure time of each frame in microseconds (default 10000)")
    g.add_argument("--crf", help=f"camera response function name from crf_models (default: {crf_default})")
    g.add_argument("--sampling", choices=("adaptive", "fixed"), help="DVS input sampling (default adaptive)")
    g.add_argument("--sampling-quantile", type=float,
                   help="adaptive sampling: quantile of the per-pixel log change kept below half the threshold per "
                        "sample (default 0.95; 1 = the worst pixel, about 10x denser)")
    g.add_argument("--labels", action="store_true", help="store per-event labels (signal/shot/leak/hot)")
    g.add_argument("--outputs", type=_outputs, metavar="LIST",
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


def _add_scene_flags(p) -> None:
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
    g.add_argument("--duration-s", type=float, help="sequence duration in seconds (default 1.0)")
    g.add_argument("--height", type=int, help="sensor height in pixels (default 180)")
    g.add_argument("--width", type=int, help="sensor width in pixels (default 240)")
    g.add_argument("--fps", type=float, help="frame rate of the LDR camera in frames per second (default 30)")
    _add_sensor_flags(g)
    p.add_argument("--sensor", metavar="NAME|FILE",
                   help=f"{SENSOR_HELP} (default davis346); with --config it replaces every sequence's sensor")


def _add_convert_parser(sub) -> None:
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
    g.add_argument("--start-s", type=_non_negative(float),
                   help="start of the clip in seconds from the input's first frame (default 0)")
    g.add_argument("--stop-s", type=_non_negative(float), default=None,
                   help="end of the clip in seconds (default: the input's last frame)")
    g.add_argument("--input-fps", "--fps", dest="fps", type=float,
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
    g.add_argument("--input-noise-dn", type=_non_negative(float), metavar="DN",
                   help="temporal noise rms of the input in its code values (e.g. a camera's read noise); turns "
                        "the conditioning on (default: estimated from a video)")
    g.add_argument("--timestamps", type=Path, help="input frame times, one per line: integer microseconds or "
                                                   "decimal seconds (default: timestamps.txt in an image folder)")
    g.add_argument("--input-crf", help="linearisation: crf_models curve whose inverse maps 8/16-bit input to linear "
                                       "radiance (default srgb; linear, or the recorded one, for a recording's frames; "
                                       "float input is taken as linear; the output's metadata states it)")
    g.add_argument("--black-level", type=_non_negative(float), help="the integer input's value for no light "
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
    s.add_argument("--height", type=int, help="sensor height in pixels (default: the input's; alone, it keeps "
                                              "the aspect ratio; see --resize; the input is area-resized)")
    s.add_argument("--width", type=int, help="sensor width in pixels (default: the input's)")
    s.add_argument("--camera-fps", type=float, help="frame rate of the synthetic LDR camera (default 30)")
    _add_sensor_flags(s, crf_default="srgb")
    conv.add_argument("--sensor", metavar="NAME|FILE", help=f"{SENSOR_HELP} (default davis346)")
    _add_output_flags(conv, "evsim_convert")
    _add_run_flags(conv)
    conv.set_defaults(func=_cmd_convert)


def build_parser() -> argparse.ArgumentParser:
    parser = SuggestingParser(prog="evsim", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG)
    parser.flag_hint = flag_hint  # a model field typed as a flag: --dvs FIELD=VALUE
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="generate a short built-in AHDR sequence, reconstruct it and print metrics",
                          epilog=EPILOG)
    demo.add_argument("--out", default="evsim_demo", help="output folder (default ./evsim_demo); demo.h5 and "
                                                          "metrics.txt in it are replaced")
    demo.add_argument("--seed", type=_non_negative(int), default=0, help="root seed (non-negative integer; default 0)")
    demo.add_argument("--duration-s", type=float, default=1.0, help="duration in seconds (default 1.0)")
    demo.add_argument("--height", type=int, help=f"height in pixels (default {DEMO_SIZE[0]})")
    demo.add_argument("--width", type=int, help=f"width in pixels (default {DEMO_SIZE[1]})")
    demo.add_argument("--sensor", metavar="NAME|FILE", default="davis346", help=f"{SENSOR_HELP} (default davis346)")
    add_model_flags(demo)
    demo.add_argument("--no-reconstruct", action="store_true", help="only generate, do not run AKF and baselines")
    demo.add_argument("--no-progress", action="store_true", help="no progress bars")
    demo.set_defaults(func=_cmd_demo)

    gen = sub.add_parser("generate", help="generate datasets (ahdr, sweep)", epilog=EPILOG)
    gsub = gen.add_subparsers(dest="generator", required=True)
    ahdr = gsub.add_parser("ahdr", help="scene(s) -> events + LDR frames + HDR reference, one file per sequence",
                           epilog=EPILOG)
    _add_scene_flags(ahdr)
    _add_output_flags(ahdr, "evsim_dataset")
    _add_run_flags(ahdr)
    ahdr.set_defaults(func=_cmd_generate_ahdr)
    sweep = gsub.add_parser("sweep", help="one scene over a grid of DVS noise/threshold parameters", epilog=EPILOG)
    _add_scene_flags(sweep)
    _add_output_flags(sweep, "evsim_sweep")
    _add_run_flags(sweep)
    grid = sweep.add_argument_group("grid (lists of values, over the configuration's [sweep]; without "
                                     "either: threshold_sigma 0 0.05 x shot_noise_hz 0 2)")
    grid.add_argument("--threshold-sigma", type=float, nargs="+", help="threshold mismatch std (log units)")
    grid.add_argument("--shot-noise-hz", type=float, nargs="+", help="shot-noise rate per pixel (Hz)")
    grid.add_argument("--leak-hz", type=float, nargs="+", help="leak-event rate per pixel (Hz)")
    grid.add_argument("--refractory-us", type=int, nargs="+", help="refractory period (microseconds)")
    grid.add_argument("--hot-pixel-fraction", type=float, nargs="+", help="fraction of hot pixels (0..1)")
    grid.add_argument("--hot-pixel-hz", type=float, nargs="+", help="event rate of a hot pixel (Hz)")
    sweep.set_defaults(func=_cmd_generate_sweep)

    _add_convert_parser(sub)

    info = sub.add_parser("info", help="what a dataset holds (duration, events, rates, frames, exposure, CRF, seed)",
                          epilog=EPILOG)
    info.add_argument("file", type=Path, help="a file or recording folder evsim reads (native or E2VID HDF5, AEDAT4, "
                                              "Prophesee .raw/.dat, IJRR or EXR folder, AKF .mat, ...) or a folder "
                                              "of them (a dataset folder: each sequence in turn)")
    info.set_defaults(func=_cmd_info)

    ev = sub.add_parser("evaluate", help="score HDR reconstructions per sequence (AKF, baselines) and print a table",
                        epilog=EPILOG)
    ev.add_argument("dataset", type=Path, help="a file evsim reads with frames (native .h5, AEDAT4, AKF .mat, ...), an "
                                               "IJRR folder, a dataset folder (index.json) or a folder of native .h5 "
                                               "files")
    ev.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                    help=f"comma-separated methods (akf.METHODS; default {','.join(DEFAULT_METHODS)})")
    ev.add_argument("--metrics",
                    help="comma-separated metrics (akf.METRICS; each table states its normalisation); default, "
                         f"--protocol reference: {','.join(DEFAULT_METRICS['reference'])} (full-range log RMSE and "
                         "PU21 over the whole HDR reference first, then the paper's [0, 1] metrics, clipped at the "
                         "white); --protocol interleave: "
                         f"{','.join(DEFAULT_METRICS['interleave'])}"),
    ev.add_argument("--protocol", choices=PROTOCOLS, default=PROTOCOLS[0],
                    help="reference: against the HDR reference frames; interleave: feed every second frame and "
                         "score on the frames in between (real data; paper supplementary Table 2)")
    ev.add_argument("--json", type=Path, help="also write {method: {sequence: {metric: value}, mean: {...}}} (with "
                                              "per-class scores metric@class, share@class; scoring: what the "
                                              "scores compare; tuning: {method: setting} with --tune)")
    ev.add_argument("--point-scoring", action="store_true",
                    help="interleave: score each reconstruction at the held-out frame's mid-exposure time instead "
                         "of averaged over its exposure window (exposure-matched, the default)")
    ev.add_argument("--tune", action="store_true",
                    help="tune every method by one protocol (akf.tuning): a coordinate search over its main "
                         "parameters (CF gain, contrast scale, AKF noise scales and smoothing, output bound; "
                         "akf.tuning.SEARCH_SPACES) on the first --tune-fraction of every sequence's scored frames; "
                         "all methods are then scored on the rest")
    ev.add_argument("--tune-fraction", type=float, default=TUNE_FRACTION,
                    help=f"fraction of each sequence's scored frames that tunes (default {TUNE_FRACTION:.3g})")
    ev.add_argument("--tune-metric",
                    help="metric the tuning minimises (maximises for SSIM/PSNR; default "
                         f"{TUNE_METRIC['reference']} with --protocol reference, {TUNE_METRIC['interleave']} with "
                         "--protocol interleave)")
    ev.add_argument("--no-progress", action="store_true", help="no progress messages (tuning, denoising; on stderr)")
    ev.add_argument("--sensor", help="sensor file (from evsim calibrate on this camera) or preset whose thresholds a "
                                     "recording without recorded ones gets (default: estimated from the data)")
    _add_akf_flags(ev)
    dn = ev.add_argument_group("--task denoise: event filters scored against the per-event labels")
    dn.add_argument("--task", choices=("reconstruction", "denoise", "realism"), default="reconstruction",
                    help="reconstruction (default): score HDR reconstructions; denoise: TPR on signal and FPR per "
                         "noise type (shot, leak, hot) of each filter over its main parameter, ROC AUCs, and the "
                         "methods on events denoised at each filter's default (needs files written with --labels; "
                         "--json then writes the result of evsim_eval.denoisers); realism: how real the events of "
                         "--against SIM are against those of DATASET (see below)")
    dn.add_argument("--filters", help="comma-separated filters (akf.denoise.FILTERS: correlation, hot_pixel, dv_ba, "
                                      "dv_knoise, dv_fast_decay, tonic_denoise; default: all whose library is "
                                      "installed)")
    dn.add_argument("--no-reconstruct", action="store_true", help="score the filters only")
    add_realism_flags(ev)
    _add_run_flags(ev, resume=False)
    ev.set_defaults(func=_cmd_evaluate)

    rc = sub.add_parser("reconstruct", help="reconstruct HDR frames and write them as EXR (with timestamps.txt)",
                        epilog=EPILOG)
    rc.add_argument("dataset", type=Path, help="as for evaluate")
    rc.add_argument("--out", required=True, help="output folder (one sub-folder per sequence when the "
                                                            "dataset has several), written atomically: it "
                                                            "appears whole")
    rc.add_argument("--method", default="akf", help="reconstruction method (akf.METHODS; default akf, the causal "
                                                     "filter; aks: the smoother, the filter run forward and "
                                                     "backward and fused). The AKF's and the smoother's output is "
                                                     "unbounded: HDR above the frames' clip")
    rc.add_argument("--variance", action="store_true", help="also write the state variance P (log^2) of akf or aks "
                                                            "as an EXR folder 'variance' in each sequence's folder")
    rc.add_argument("--times", default="reference", help="output times: reference, frames (mid-exposures) or "
                                                         "fps:N (N per second); default reference")
    rc.add_argument("--overwrite", action="store_true", help="replace an existing, non-empty --out (refused "
                                                            "otherwise)")
    _add_akf_flags(rc)
    rc.set_defaults(func=_cmd_reconstruct)
    add_plot_parser(sub)
    add_calibrate_parser(sub)
    export_command.add_parser(sub, EPILOG)
    lab_command.add_parser(sub, EPILOG)
    return parser


def _note(message, category, filename, lineno, file=None, line=None) -> None:
    """Print a warning whose category says evsim_note as "evsim: note: ...", others as Python does."""
    if getattr(category, "evsim_note", False):
        print(f"evsim: note: {getattr(message, 'cli_message', message)}", file=sys.stderr)  # in flags
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


class Terminated(BaseException):
    """Raised in the main thread on SIGTERM, so that every writer's cleanup (temporary files) runs as on Ctrl-C."""


def _on_sigterm(signum, frame):
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    """Run the `evsim` command line on argv (default: sys.argv[1:]) and return its exit code: 0 success, 2 usage
    error, bad input or a full disk, 3 some sequences failed, 1 unexpected failure, 130 interrupted, 143 terminated
    (see the module docstring)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # argparse: --help (0) or a usage error (2), message already printed
        return int(e.code or 0)
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    watchdog = Watchdog()  # ends the process 0.7 s after SIGTERM if the main thread has not by then
    if hasattr(signal, "SIGXFSZ"):  # a file size limit (ulimit -f): writes fail with EFBIG (exit 2), not a core dump
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    try:
        _check_paths(args)
        with warnings.catch_warnings():
            warnings.showwarning = _note  # the library's notes (an export leaving parts out) as one line each
            return args.func(args)
    except sim.EvsimInputError as e:
        print(f"evsim: error: {getattr(e, 'cli_message', e)}", file=sys.stderr)  # in flags (sim.OptionError)
        return 2
    except TasksFailed as e:
        for f in e.failures:
            if f.kind == "bug":  # show where
                print(f"{f.name}:\n{f.traceback}", file=sys.stderr)
        print(f"evsim: error: {e.cli_message}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        resume = (" (Ctrl-C): the complete sequences are kept; run the same command with --resume to finish"
                  if hasattr(args, "resume") else "")
        print(f"evsim: interrupted{resume}", file=sys.stderr)
        return 130
    except Terminated:  # the temporary files are removed (the writers' cleanup has run)
        watchdog.reported = True
        print(SIGTERM_MESSAGE, file=sys.stderr)
        end_now(reported=True)  # exits 143 now: the interpreter's teardown would take up to a second more

    except BrokenPipeError:  # the reader of our output went away (e.g. `evsim info f | head`): not a failure
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as e:
        from generators.formats.atomic import DiskFullError, is_disk_full

        if isinstance(e, DiskFullError):  # names the output; its temporary files are removed
            print(f"evsim: error: {e}", file=sys.stderr)
            return 2
        if is_disk_full(e):
            print(f"evsim: error: disk full or file too large, nothing written in its place: {e}", file=sys.stderr)
            return 2
        traceback.print_exc()
        print("evsim: unexpected error (a bug: please report it with the traceback above)", file=sys.stderr)
        return 1
    finally:
        signal.signal(signal.SIGTERM, previous)
        watchdog.stop()


if __name__ == "__main__":
    sys.exit(main())
