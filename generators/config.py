"""Dataset configuration files (TOML) and scene specifications.

A configuration describes a dataset of sequences. Every key is optional except [[sequence]].scene.type:

    seed = 0                      # root seed (numpy SeedSequence entropy); sequence i gets its i-th child
    format = "native"             # extra export per sequence: native | e2vid | ijrr | akf-mat | e2vid-txt |
                                  # aedat4 | aedat2 | evt3 | evt2 | dat

    [defaults]                    # applies to every sequence; a sequence may override any of these keys
    duration_s = 1.0              # seconds
    height = 180                  # pixels (1..65535 per side, at most 2**25 pixels)
    width = 240                   # pixels
    sensor = "davis346"           # a DVS preset (sim.DVS_PRESETS) or a sensor file (sim.sensor_file; a path relative
                                  # to this file): its [dvs] values, and its [camera] values under camera = {...}
    dvs = { pos_threshold = 0.2 } # sim.DVSParams fields (units: sim.dvs_params.FIELD_UNITS), over the sensor's
    camera = { fps = 20.0 }       # sim.CameraParams fields (units: sim.camera_params.FIELD_UNITS), or
                                  # preset = "davis346_aps" (sim.CAMERA_PRESETS) with fields over it
    crf = { name = "window", params = {} }   # crf_models.get(name, **params)
    sampling = { mode = "adaptive", fraction = 0.5, quantile = 0.95, min_step_us = 10, max_step_us = 5000,
                 rate_hz = 2000.0 }   # quantile: of the per-pixel log change held below fraction x threshold
    output = { labels = false, threshold_maps = true, reference_times_us = [], reference_rate_hz = 0.0,
               compression = "gzip",    # or "lzf" (faster to write, larger) or "none"
               outputs = ["events", "frames", "reference"] }   # what each file holds (events always)

    [[sequence]]
    name = "desk_pan"             # a plain file name: no path separators, no leading dot, not empty
    speeds = [0.5, 1.0, 2.0]      # optional: one sequence per factor (finite, > 0), all scene speeds scaled by it;
                                  # the scene must set its speed (else the factors would be ignored: an error)
    scene = { type = "image", path = "Desk.exr", trajectory = { pan_px_per_s = [120.0, 0.0] } }

    [sweep]                       # for `evsim generate sweep` (first sequence only): lists of values
    threshold_sigma = [0.0, 0.03]

Scene types: see SCENE_TYPES; the other keys of a scene table are the keyword arguments of the scene class
(lists become tuples; "path" and "timestamps" are relative to the configuration file). Any scene table may add
lighting = { flicker_hz = 100.0, depth = 0.2, phase_rad = 0.0, rise_fraction = 0.5 }: the scene under a flickering
lamp (generators.scenes.FlickerLighting). Errors raise InvalidParameterError naming the file and the key.
"""

from __future__ import annotations

import copy
import math
import os
import stat
import tomllib
from dataclasses import dataclass
from pathlib import Path

import crf_models
import sim
from sim import EvsimInputError, InvalidParameterError
from sim.errors import toml_type
from sim.sensor_file import check_camera_fields, check_dvs_fields
from sim.suggest import unknown_name

from . import scenes
from .ahdr import AHDRConfig, check_outputs
from .choices import OUTPUTS
from .formats import EXPORT_FORMATS
from .formats.native import COMPRESSIONS

__all__ = ["load_config", "parse_config", "build_scene", "to_ahdr_config", "DatasetConfig", "SequenceSpec",
           "SCENE_TYPES", "DEFAULTS", "SWEEP_KEYS", "check_sequence_name"]

#: scene type of a configuration -> what it is and its keys (or the scene class whose keyword arguments they are)
SCENE_TYPES = {
    "image": "an HDR (or LDR) image file under camera motion: path, trajectory {...}, channel, crf, crf_params, "
             "scale, interpolation, border, gain, supersample (sub-samples per output pixel and axis when the "
             "image is shrunk, so that each pixel integrates its area; default 3), prefilter (bilinear affine "
             "views from one warp of a box-filtered source instead of the sub-sample grid; default true)",
    "frames": "a folder of EXR frames: path, fps (when no timestamps.txt), interpolation, log_eps (the frames "
              "set the duration; their size must match height and width)",
    "video": "a video file, a folder of images, a .npy stack or a hybrid recording's frames (generators.scenes.video): "
             "path, start_s, stop_s, fps (the capture rate of the input frames), slowmo (video files: capture rate "
             "= container rate x slowmo), timestamps (file), upsample (flow | linear | none), flow (dis | "
             "farneback), flow_preset, flow_scale, key_step_px, max_keys, input_crf, input_crf_params, channel, "
             "black_level, warm_up_s, resize (crop | pad | stretch: to the aspect ratio of height x width), "
             "conditioning (temporal | off, or a table of generators.scenes.conditioning.ConditioningParams fields) "
             "(the clip sets the duration)",
    "builtin_image": "an image shipped with scikit-image made HDR (see generators.scenes.builtin_images): image, "
                     "trajectory {...}",
    "moving_edge": "MovingEdge", "checkerboard": "Checkerboard", "rotating_bar": "RotatingBar",
    "rotating_disk": "RotatingDisk", "flicker": "FlickeringLight", "sun": "SunPatch",
}
_SPEED_KEYS = ("speed_px_per_s", "velocity_px_per_s", "angular_speed_deg_s")
_TRAJECTORY_SPEED_KEYS = ("pan_px_per_s", "zoom_per_s", "rotation_deg_per_s", "shake_hz")

MAX_SIDE_PX = 65535  # event coordinates are uint16
MAX_PIXELS = 1 << 25  # about 33 M pixels (8K UHD): larger sensors are refused as almost surely a typo
SAMPLING_KEYS = {"mode": str, "fraction": float, "quantile": float, "min_step_us": int, "max_step_us": int,
                 "rate_hz": float}
OUTPUT_KEYS = {"labels": bool, "threshold_maps": bool, "reference_times_us": list, "reference_rate_hz": float,
               "compression": str, "outputs": list}
SEQUENCE_KEYS = {"duration_s": float, "height": int, "width": int, "sensor": str, "dvs": dict, "camera": dict,
                 "crf": dict, "sampling": dict, "output": dict}
_LIGHTING_TABLE = dict.fromkeys(scenes.LIGHTING_KEYS, float)  # a scene's lighting table: all numbers
#: the DVS parameters a [sweep] table may vary
SWEEP_KEYS = ("threshold_sigma", "shot_noise_hz", "leak_hz", "refractory_us", "hot_pixel_fraction", "hot_pixel_hz")

#: the settings of a sequence that neither [defaults] nor the sequence sets (see the module docstring)
DEFAULTS = {
    "duration_s": 1.0, "height": 180, "width": 240, "sensor": "davis346", "dvs": {}, "camera": {},
    "crf": {"name": "window", "params": {}},
    "sampling": {"mode": "adaptive", "fraction": 0.5, "quantile": 0.95, "min_step_us": 10, "max_step_us": 5000,
                 "rate_hz": 2000.0},
    "output": {"labels": False, "threshold_maps": True, "reference_times_us": [], "reference_rate_hz": 0.0,
               "compression": "gzip", "outputs": list(OUTPUTS)},
}


@dataclass
class SequenceSpec:
    """One sequence of a dataset, fully resolved.

    Attributes
    ----------
    name : str
        The sequence's name (its file-name stem).
    scene : dict
        Its scene table (see SCENE_TYPES; speeds in pixels or degrees per second).
    settings : dict
        Its settings as in DEFAULTS (duration_s in seconds, sizes in pixels, dvs / camera tables in the fields'
        units).
    """

    name: str
    scene: dict
    settings: dict

    @property
    def duration_us(self) -> int:
        return int(round(self.settings["duration_s"] * 1e6))


@dataclass
class DatasetConfig:
    """A dataset configuration, validated (parse_config, load_config).

    Attributes
    ----------
    seed : int
        The root seed: sequence i is seeded with child i of SeedSequence(seed).
    format : str
        The output format ("native" or an export format).
    sequences : list of SequenceSpec
        The sequences, resolved.
    sweep : dict
        The [sweep] table (SWEEP_KEYS name -> list of values), or {}.
    source : str
        Where the configuration comes from (a file's path, or "<flags>"), for messages and index.json.
    """

    seed: int
    format: str
    sequences: list[SequenceSpec]
    sweep: dict
    source: str = "<flags>"


def _compression(name: str):
    """A configuration's compression name as NativeWriter takes it ("none" -> None)."""
    return None if name == "none" else name


def _fail(where: str, msg: str) -> InvalidParameterError:
    return InvalidParameterError(f"{where}: {msg}")


def _check_type(where: str, value, kind):
    ok = {float: lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
          int: lambda v: isinstance(v, int) and not isinstance(v, bool)}.get(kind, lambda v: isinstance(v, kind))
    if not ok(value):
        wanted = {float: "a number", int: "an integer", str: "a string", dict: "a table", list: "an array"}.get(
            kind, f"a {kind.__name__}")
        raise _fail(where, f"expected {wanted}, got {toml_type(value)} {value!r}")
    return float(value) if kind is float else value


def _check_table(where: str, table, allowed: dict) -> dict:
    if not isinstance(table, dict):
        raise _fail(where, f"expected a table, got {toml_type(table)}")
    out = {}
    for key, value in table.items():
        if key not in allowed:
            raise _fail(f"{where}.{key}", unknown_name("key", key, sorted(allowed)))
        out[key] = _check_type(f"{where}.{key}", value, allowed[key])
    return out


def resolve_sensor(where: str, value: object, base_dir: Path | None = None) -> str:
    """A configuration's sensor setting checked (sim.load_sensor): a preset name as is, a sensor file as its absolute
    path (relative paths are relative to base_dir, default the current folder). InvalidParameterError naming
    `where` otherwise."""
    value = _check_type(where, value, str)
    try:
        sensor = sim.load_sensor(value, base_dir=base_dir)
    except EvsimInputError as e:
        raise _fail(where, str(e)) from None
    return value if sensor.path is None else sensor.path


def resolve_settings(where: str, table: dict, base: dict, base_dir: Path | None = None) -> dict:
    """Validate the sequence-level keys of `table` (SEQUENCE_KEYS) and merge them over `base` (sub-tables merged
    key by key); a sensor file's path is taken relative to base_dir."""
    settings = copy.deepcopy(base)
    for key, value in table.items():
        if key not in SEQUENCE_KEYS:
            raise _fail(f"{where}.{key}", unknown_name("key", key, SEQUENCE_KEYS))
        value = _check_type(f"{where}.{key}", value, SEQUENCE_KEYS[key])
        if key == "sampling":
            value = _check_table(f"{where}.sampling", value, SAMPLING_KEYS)
        elif key == "output":
            value = _check_table(f"{where}.output", value, OUTPUT_KEYS)
            for i, t in enumerate(value.get("reference_times_us", [])):
                _check_type(f"{where}.output.reference_times_us[{i}]", t, int)
            if "outputs" in value:
                try:
                    value["outputs"] = list(check_outputs(value["outputs"]))
                except InvalidParameterError as e:
                    raise _fail(f"{where}.output.outputs", str(e)) from None
        elif key == "dvs":
            value = check_dvs_fields(f"{where}.dvs", value)
        elif key == "camera":
            value = check_camera_fields(f"{where}.camera", value)
        elif key == "sensor":
            value = resolve_sensor(f"{where}.sensor", value, base_dir)
        elif key == "crf":
            value = _check_table(f"{where}.crf", value, {"name": str, "params": dict})
            if "name" not in value:
                raise _fail(f"{where}.crf.name", "missing: a crf table replaces the default curve, so it must name "
                                                 f"one of {', '.join(crf_models.available())}")
            try:  # built here once, so that a bad curve is refused with the file, not by each sequence later
                crf_models.get(value["name"], **value.get("params", {}))
            except crf_models.CRFError as e:
                raise _fail(f"{where}.crf", str(e)) from None
        if isinstance(value, dict) and key != "crf":
            settings[key] = {**settings[key], **value}
        else:
            settings[key] = value
    if settings["sampling"]["mode"] not in ("adaptive", "fixed"):
        raise _fail(f"{where}.sampling.mode", f"must be 'adaptive' or 'fixed', got {settings['sampling']['mode']!r}")
    if _compression(settings["output"]["compression"]) not in COMPRESSIONS:
        raise _fail(f"{where}.output.compression",
                    f"must be 'gzip', 'lzf' or 'none', got {settings['output']['compression']!r}")
    for key in ("height", "width"):
        if not 1 <= settings[key] <= MAX_SIDE_PX:
            raise _fail(f"{where}.{key}", f"must be 1..{MAX_SIDE_PX} pixels, got {settings[key]}")
    if settings["height"] * settings["width"] > MAX_PIXELS:
        raise _fail(where, f"sensor of {settings['height']}x{settings['width']} pixels: at most {MAX_PIXELS}")
    if not (math.isfinite(settings["duration_s"]) and settings["duration_s"] > 0):
        raise _fail(f"{where}.duration_s", f"must be finite and > 0 seconds, got {settings['duration_s']}")
    return settings


MAX_NAME_LEN = 200


def check_sequence_name(where: str, name: object) -> str:
    """A sequence name is a plain file-name stem: not empty, no path separator, no leading dot (hidden files,
    "..") and at most MAX_NAME_LEN characters, so that <out>/<name>.h5 stays inside the output folder.

    Parameters
    ----------
    where : str
        Where the name comes from, for the error message.
    name : object
        The name to check.

    Returns
    -------
    str
        The name; InvalidParameterError naming where otherwise.
    """
    name = _check_type(where, name, str)
    if not name or len(name) > MAX_NAME_LEN:
        raise _fail(where, f"must be 1..{MAX_NAME_LEN} characters, got {name!r:.80}")
    if any(c in name for c in "/\\\0") or Path(name).is_absolute() or name.startswith("."):
        raise _fail(where, f"must be a plain file name (no path separators, no leading dot), got {name!r}")
    return name


def _has_speed(scene: dict) -> bool:
    traj = scene.get("trajectory")
    return any(k in scene for k in _SPEED_KEYS) or (
        isinstance(traj, dict) and any(k in traj for k in _TRAJECTORY_SPEED_KEYS))


def _check_speed_values(where: str, scene: dict) -> None:
    traj = scene.get("trajectory") if isinstance(scene.get("trajectory"), dict) else {}
    for key, v in [*((k, scene[k]) for k in _SPEED_KEYS if k in scene),
                   *((f"trajectory.{k}", traj[k]) for k in _TRAJECTORY_SPEED_KEYS if k in traj)]:
        for x in v if isinstance(v, list) else [v]:
            _check_type(f"{where}.scene.{key}", x, float)


def _scale_speeds(scene: dict, k: float) -> dict:
    scene = copy.deepcopy(scene)
    for key in _SPEED_KEYS:
        if key in scene:
            v = scene[key]
            scene[key] = [k * x for x in v] if isinstance(v, list) else k * v
    traj = scene.get("trajectory")
    if isinstance(traj, dict):
        for key in _TRAJECTORY_SPEED_KEYS:
            if key in traj:
                v = traj[key]
                traj[key] = [k * x for x in v] if isinstance(v, list) else k * v
    return scene


def _check_scene(where: str, scene, base_dir: Path) -> dict:
    if not isinstance(scene, dict):
        raise _fail(where, "expected a table with at least 'type'")
    if "type" not in scene:
        raise _fail(f"{where}.type", f"missing; one of {', '.join(SCENE_TYPES)}")
    if not isinstance(scene["type"], str) or scene["type"] not in SCENE_TYPES:
        raise _fail(f"{where}.type", unknown_name("scene type", scene["type"], SCENE_TYPES))
    scene = dict(scene)
    for key in ("path", "timestamps"):
        if key in scene:
            p = Path(_check_type(f"{where}.{key}", scene[key], str)).expanduser()
            scene[key] = str(p if p.is_absolute() else (base_dir / p).resolve())
    if "path" not in scene and scene["type"] in ("image", "frames", "video"):
        raise _fail(f"{where}.path", f"required for scene type {scene['type']!r}")
    if "lighting" in scene:
        scene["lighting"] = _check_table(f"{where}.lighting", scene["lighting"], _LIGHTING_TABLE)
    return scene


def parse_config(data: dict, *, source: str = "<config>", base_dir: Path | None = None) -> DatasetConfig:
    """Validate a configuration already parsed from TOML (a dict) and resolve every sequence.

    Parameters
    ----------
    data : dict
        The parsed TOML (see the module docstring for its tables).
    source : str, optional
        Where it comes from, for the messages (default "<config>").
    base_dir : Path, optional
        The folder relative paths (images, videos, sensor files) are resolved against (default the current one).

    Returns
    -------
    DatasetConfig
        The configuration; InvalidParameterError naming the key otherwise.
    """
    base_dir = Path.cwd() if base_dir is None else base_dir
    top = {"seed": int, "format": str, "defaults": dict, "sequence": list, "sweep": dict}
    for key in data:
        if key not in top:
            raise _fail(f"{source}: {key}", unknown_name("key", key, top))
    seed = _check_type(f"{source}: seed", data.get("seed", 0), int)
    if seed < 0:
        raise _fail(f"{source}: seed", f"must be >= 0, got {seed}")
    fmt = _check_type(f"{source}: format", data.get("format", "native"), str)
    if fmt not in EXPORT_FORMATS:
        raise _fail(f"{source}: format", unknown_name("format", fmt, EXPORT_FORMATS))
    defaults_table = _check_type(f"{source}: defaults", data.get("defaults", {}), dict)
    defaults = resolve_settings(f"{source}: defaults", defaults_table, DEFAULTS, base_dir)
    seq_tables = _check_type(f"{source}: sequence", data.get("sequence", []), list)
    if not seq_tables:
        raise _fail(f"{source}: sequence", "no [[sequence]] defined")
    sequences, names = [], set()
    for i, table in enumerate(seq_tables):
        where = f"{source}: sequence[{i}]"
        if not isinstance(table, dict):
            raise _fail(where, "expected a table")
        own = {"name", "scene", "speeds"}
        for key in table:
            if key not in own and key not in SEQUENCE_KEYS:
                raise _fail(f"{where}.{key}", unknown_name("key", key, [*own, *SEQUENCE_KEYS]))
        name = check_sequence_name(f"{where}.name", table.get("name", f"seq{i:03d}"))
        scene = _check_scene(f"{where}.scene", table.get("scene"), base_dir)
        settings = resolve_settings(where, {k: v for k, v in table.items() if k in SEQUENCE_KEYS}, defaults,
                                    base_dir)
        speeds = _check_type(f"{where}.speeds", table.get("speeds", [None]), list)
        if "speeds" in table:
            if not speeds:
                raise _fail(f"{where}.speeds", "expected a non-empty list of speed factors")
            _check_speed_values(where, scene)
            if not _has_speed(scene):
                keys = f"{', '.join(_SPEED_KEYS)} or trajectory.{{{', '.join(_TRAJECTORY_SPEED_KEYS)}}}"
                raise _fail(f"{where}.speeds", f"would be ignored: the scene sets none of {keys}")
        for k in speeds:
            if k is not None:
                k = _check_type(f"{where}.speeds", k, float)
                if not (math.isfinite(k) and k > 0):
                    raise _fail(f"{where}.speeds", f"speed factors must be finite and > 0, got {k}")
            seq_name = name if k is None else f"{name}_x{k:g}"
            if seq_name in names:
                raise _fail(f"{where}.name", f"duplicate sequence name {seq_name!r}")
            names.add(seq_name)
            sequences.append(SequenceSpec(seq_name, scene if k is None else _scale_speeds(scene, k), settings))
    sweep = _check_type(f"{source}: sweep", data.get("sweep", {}), dict)
    for key, values in sweep.items():
        if key not in SWEEP_KEYS:
            raise _fail(f"{source}: sweep.{key}", unknown_name("sweep parameter", key, SWEEP_KEYS))
        if not isinstance(values, list) or not values:
            raise _fail(f"{source}: sweep.{key}", "expected a non-empty list of values")
        for i, v in enumerate(values):
            _check_type(f"{source}: sweep.{key}[{i}]", v, int if key == "refractory_us" else float)
        check_sweep_values(f"{source}: sweep", key, values)
    return DatasetConfig(seed, fmt, sequences, sweep, source)


def check_sweep_values(where: str, key: str, values: list) -> None:
    """InvalidParameterError naming where.key[i] for the first value that sim.DVSParams refuses for field key
    (a negative rate, a fraction above 1, a non-integer refractory period, ...)."""
    for i, v in enumerate(values):
        try:
            sim.DVSParams().replace(**{key: v})
        except InvalidParameterError as e:
            raise _fail(f"{where}.{key}[{i}]", str(e)) from None


MAX_CONFIG_BYTES = 16 << 20  # a configuration is a few kB: a larger file is not one


def missing_path_reason(path: Path) -> str:
    """Why `path` does not exist, for a message: a dangling symbolic link, a file where a folder should be on the
    way to it, or simply not there."""
    if path.is_symlink():
        return f"{path} is a symbolic link to {os.readlink(path)}, which does not exist"
    for parent in path.parents:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                return f"{parent} is a file, not a folder, so {path} cannot exist"
            break
    return f"{path} does not exist"


def read_text_file(path: str | Path, what: str = "configuration file") -> str:
    """The UTF-8 text of a small regular file (a leading byte-order mark is dropped). EvsimInputError naming the
    path and the problem otherwise: missing (dangling link, a file on the way), a folder, not a regular file (a
    FIFO or device, which could block or never end), unreadable, larger than MAX_CONFIG_BYTES, not UTF-8."""
    path = Path(path)
    try:
        st = path.stat()
    except (FileNotFoundError, NotADirectoryError):  # ENOTDIR: a file on the way
        raise EvsimInputError(f"{what} not found: {missing_path_reason(path)}") from None
    except OSError as e:  # EACCES on the way, ELOOP, ENAMETOOLONG
        raise EvsimInputError(f"{what} {path}: cannot be opened: {e.strerror or e}") from None
    if stat.S_ISDIR(st.st_mode):
        raise EvsimInputError(f"{what} {path} is a folder, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise EvsimInputError(f"{what} {path} is not a regular file (a FIFO, socket or device)")
    if st.st_size > MAX_CONFIG_BYTES:
        raise EvsimInputError(f"{what} {path} has {st.st_size} bytes: not a {what} (at most {MAX_CONFIG_BYTES})")
    try:
        data = path.read_bytes()
    except OSError as e:
        raise EvsimInputError(f"{what} {path}: cannot be read: {e.strerror or e}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise EvsimInputError(f"{what} {path} is not UTF-8 text (byte 0x{data[e.start]:02x} at offset {e.start}): "
                              "is it a binary file?") from None


def read_toml(path: str | Path) -> dict:
    """The TOML table of a configuration file (the file as read_text_file takes it); EvsimInputError naming the
    file and the syntax error when it is not valid TOML."""
    text = read_text_file(path)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise EvsimInputError(f"{path}: not valid TOML: {e}") from None


def load_config(path: str | Path) -> DatasetConfig:
    """Read and validate a TOML dataset configuration (see the module docstring and read_toml).

    Parameters
    ----------
    path : str or Path
        The TOML file; relative paths in it are resolved against its folder.

    Returns
    -------
    DatasetConfig
        The configuration.
    """
    path = Path(path)
    return parse_config(read_toml(path), source=str(path), base_dir=path.parent.resolve())


def _as_tuples(v):
    if isinstance(v, list):
        return tuple(_as_tuples(x) for x in v)
    if isinstance(v, dict):
        return {k: _as_tuples(x) for k, x in v.items()}
    return v


def build_scene(scene: dict, height: int, width: int, duration_us: int, *, where: str = "scene") -> scenes.Scene:
    """Construct the radiance source described by a scene table; a `lighting` table (scenes.LIGHTING_KEYS) puts it
    under flickering light (scenes.FlickerLighting).

    Parameters
    ----------
    scene : dict
        The scene table: "type" (one of SCENE_TYPES) and its keys.
    height, width : int
        Sensor size (pixels).
    duration_us : int
        Duration (us).
    where : str, optional
        Where the table comes from, for the error messages (default "scene").

    Returns
    -------
    Scene
        The scene.
    """
    lighting = scene.get("lighting")
    base = _build_scene({k: v for k, v in scene.items() if k != "lighting"}, height, width, duration_us, where)
    if lighting is None:
        return base
    lighting = _check_table(f"{where}.lighting", lighting, _LIGHTING_TABLE)
    try:
        return scenes.FlickerLighting(base, **lighting)
    except InvalidParameterError as e:  # "lighting: depth must be ..."
        raise _fail(where, str(e)) from None


def _build_scene(scene: dict, height: int, width: int, duration_us: int, where: str) -> scenes.Scene:
    params = {k: _as_tuples(v) for k, v in scene.items() if k != "type"}
    kind = scene["type"]
    try:
        if kind in ("image", "builtin_image"):
            traj = scenes.Trajectory(**params.pop("trajectory", {}))
            if kind == "image":
                return scenes.ImageMotionScene.from_file(params.pop("path"), duration_us, traj, height=height,
                                                         width=width, **params)
            return scenes.builtin_image_scene(height, width, duration_us, traj, **params)
        if kind == "video":
            return scenes.VideoScene(params.pop("path"), height=height, width=width, **params)
        if kind == "frames":
            src = scenes.FrameSequenceScene.from_folder(params.pop("path"), **params)
            if (src.height, src.width) != (height, width):
                raise _fail(where, f"frames are {src.width}x{src.height} but the sequence asks for {width}x{height}")
            return src
        cls = getattr(scenes, SCENE_TYPES[kind])
        return cls(height, width, duration_us, **params)
    except EvsimInputError:
        raise
    except (TypeError, ValueError) as e:  # an unexpected keyword argument, or a value of the wrong kind: name it
        raise _fail(where, f"bad parameter for scene type {kind!r}: {e}") from None


def to_ahdr_config(settings: dict, *, where: str = "settings") -> AHDRConfig:
    """The generation configuration of resolved sequence settings: the sensor's DVS parameters with the dvs table
    over them, the sensor's camera defaults with the camera table over them.

    Parameters
    ----------
    settings : dict
        Resolved settings (see DEFAULTS).
    where : str, optional
        Where they come from, for the error messages (default "settings").

    Returns
    -------
    AHDRConfig
        The configuration.
    """
    try:
        sensor = sim.load_sensor(settings["sensor"])
    except EvsimInputError as e:
        raise _fail(f"{where}.sensor", str(e)) from None
    dvs_over = check_dvs_fields(f"{where}.dvs", settings["dvs"])
    cam_over = check_camera_fields(f"{where}.camera", {**sensor.camera, **settings["camera"]})
    cam_preset = cam_over.pop("preset", None)
    try:
        dvs = sensor.dvs.replace(**dvs_over)
    except InvalidParameterError as e:
        raise _fail(f"{where}.dvs", str(e)) from None
    try:
        camera = (sim.CameraParams.preset(cam_preset, **cam_over) if cam_preset is not None
                  else sim.CameraParams(**cam_over))
    except (InvalidParameterError, TypeError) as e:
        raise _fail(f"{where}.camera", str(e)) from None
    sampling, output = settings["sampling"], settings["output"]
    try:
        return AHDRConfig(
            dvs=dvs, camera=camera, sensor=sensor.describe(), crf=settings["crf"].get("name", "window"),
            crf_params=settings["crf"].get("params", {}), auto_exposure="reference_radiance" not in cam_over,
            auto_illumination="full_illumination" not in {*dvs_over, *sensor.dvs_fields},
            sampling=sampling["mode"],
            sampling_fraction=sampling["fraction"], sampling_quantile=sampling["quantile"],
            min_step_us=sampling["min_step_us"], max_step_us=sampling["max_step_us"], rate_hz=sampling["rate_hz"],
            reference_times_us=tuple(output["reference_times_us"]), reference_rate_hz=output["reference_rate_hz"],
            threshold_maps=output["threshold_maps"], labels=output["labels"],
            compression=_compression(output["compression"]), outputs=tuple(output["outputs"]),
        )
    except InvalidParameterError as e:
        raise _fail(where, str(e)) from None
