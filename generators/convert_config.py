"""Conversion configuration files (`evsim convert --config FILE`): the settings of `evsim convert` in TOML, which
its flags override.

    seed = 0                      # root seed (clip i gets its i-th child)
    format = "native"             # extra export per clip (as generate's)

    [defaults]                    # sequence settings as in generate's [defaults] (generators.config): sensor (a
    sensor = "davis346.toml"      # preset or a sensor file, relative to this file), dvs, camera, crf, sampling,
    dvs = { pos_threshold = 0.25 }  # output, height and width (pixels; default: each clip's own). No duration_s:
                                  # the clip sets it ([video] start_s, stop_s)
    [video]                       # how the clips are read (generators.convert.SCENE_OPTIONS): start_s, stop_s, fps,
    upsample = "flow"             # timestamps (relative to this file), upsample, flow, flow_preset, flow_scale,
                                  # key_step_px, max_keys, input_crf, input_crf_params, channel

Errors raise InvalidParameterError naming the file and the key, with the closest allowed name.
"""

from __future__ import annotations

from pathlib import Path

from sim import InvalidParameterError
from sim.errors import toml_type
from sim.suggest import unknown_name

from .config import DEFAULTS, SEQUENCE_KEYS, read_toml, resolve_settings
from .convert import SCENE_OPTIONS
from .formats import EXPORT_FORMATS

__all__ = ["load_convert_config", "parse_convert_config", "merge_settings", "CONVERT_KEYS"]

#: the top-level keys of a conversion configuration
CONVERT_KEYS = ("seed", "format", "defaults", "video")
_DICT_SETTINGS = ("dvs", "camera", "sampling", "output")  # merged key by key; the other settings are replaced


def merge_settings(base: dict, over: dict) -> dict:
    """Sequence settings over others: the dvs, camera, sampling and output tables key by key, the others replaced.

    Parameters
    ----------
    base : dict
        Sequence settings (as generators.config.DEFAULTS).
    over : dict
        Settings that take precedence.

    Returns
    -------
    dict
        The merged settings (a new dict; base and over are unchanged).
    """
    out = dict(base)
    for key, value in over.items():
        out[key] = {**base.get(key, {}), **value} if key in _DICT_SETTINGS else value
    return out


def parse_convert_config(data: dict, *, source: str = "<convert config>", base_dir: Path | None = None) -> dict:
    """Check a conversion configuration already parsed from TOML: only the keys it sets.

    Parameters
    ----------
    data : dict
        The parsed TOML (top-level keys of CONVERT_KEYS).
    source : str, optional
        Where it comes from, for the messages (default "<convert config>").
    base_dir : Path, optional
        Sensor and timestamps paths are made absolute relative to it (default the current folder).

    Returns
    -------
    dict
        {"seed": int or None, "format": str or None, "settings": {...}, "video": {...}}: the sequence settings and
        the video scene options it sets (the units of generators.config's tables).
    """
    base_dir = Path.cwd() if base_dir is None else base_dir
    for key in data:
        if key not in CONVERT_KEYS:
            raise InvalidParameterError(f"{source}: {key}: {unknown_name('key', key, CONVERT_KEYS)}")
    seed, fmt = data.get("seed"), data.get("format")
    if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool) or seed < 0):
        raise InvalidParameterError(f"{source}: seed: must be an integer >= 0, got {seed!r}")
    if fmt is not None and fmt not in EXPORT_FORMATS:
        raise InvalidParameterError(f"{source}: format: {unknown_name('format', fmt, EXPORT_FORMATS)}")
    table = _table(source, "defaults", data.get("defaults", {}))
    allowed = [k for k in SEQUENCE_KEYS if k != "duration_s"]
    for key in table:
        if key == "duration_s":
            raise InvalidParameterError(f"{source}: defaults.duration_s: the clip sets the duration (use [video] "
                                        "start_s and stop_s)")
        if key not in allowed:
            raise InvalidParameterError(f"{source}: defaults.{key}: {unknown_name('key', key, allowed)}")
    resolved = resolve_settings(f"{source}: defaults", table, DEFAULTS, base_dir)
    # only what the file sets (a table's other keys keep convert's defaults, e.g. output.outputs = events)
    settings = {k: {kk: resolved[k][kk] for kk in table[k]} if k in _DICT_SETTINGS else resolved[k] for k in table}
    video = _table(source, "video", data.get("video", {}))
    for key in video:
        if key not in SCENE_OPTIONS:
            raise InvalidParameterError(f"{source}: video.{key}: {unknown_name('key', key, SCENE_OPTIONS)}")
    if "timestamps" in video:
        if not isinstance(video["timestamps"], str):
            raise InvalidParameterError(f"{source}: video.timestamps: expected a file name, got "
                                        f"{video['timestamps']!r}")
        video["timestamps"] = str((base_dir / Path(video["timestamps"]).expanduser()).resolve())
    return {"seed": seed, "format": fmt, "settings": settings, "video": video}


def _table(source: str, key: str, value: object) -> dict:
    if not isinstance(value, dict):
        raise InvalidParameterError(f"{source}: {key}: expected a table, got {toml_type(value)}")
    return dict(value)


def load_convert_config(path: str | Path) -> dict:
    """Read and check a conversion configuration file (see the module docstring and parse_convert_config).

    Parameters
    ----------
    path : str or Path
        The TOML file; relative paths in it are resolved against its folder.

    Returns
    -------
    dict
        As parse_convert_config's.
    """
    path = Path(path)
    return parse_convert_config(read_toml(path), source=str(path), base_dir=path.parent.resolve())
