"""Command-line flags of the sensor model, shared by `evsim generate ahdr|sweep`, `convert` and `demo`:

--dvs FIELD=VALUE and --camera FIELD=VALUE set any sim.DVSParams / sim.CameraParams field (repeatable, or several
at once separated by commas: --dvs pos_threshold=0.25,neg_threshold=0.3). VALUE is read as a TOML value (0.25,
100, true, [1000, 8000]); the fields are checked by sim.sensor_file.check_dvs_fields / check_camera_fields, the
same code that checks a configuration's dvs = {...} / camera = {...} tables and a sensor file's [dvs] / [camera].
--sensor-size NAME sets the height and width of a real sensor (sim.sensor_sizes).
"""

from __future__ import annotations

import argparse
import dataclasses
import tomllib

import sim
from sim import camera_params, dvs_params
from sim.sensor_file import check_camera_fields, check_dvs_fields
from sim.sensor_sizes import SENSOR_SIZES
from sim.suggest import closest, similarity, unknown_name


def field_list(cls: type, units: dict[str, str]) -> str:
    """The fields of a parameter dataclass, for a flag's help.

    Parameters
    ----------
    cls : type
        The dataclass (sim.DVSParams, sim.CameraParams): its defaults are listed.
    units : dict of str to str
        Its units table (sim.dvs_params.FIELD_UNITS, sim.camera_params.FIELD_UNITS).

    Returns
    -------
    str
        "name (unit; default value), ..." for every field.
    """
    defaults = cls()
    return ", ".join(f"{f.name} ({units[f.name]}; default "
                     f"{_AUTOMATIC.get(f.name) or _default(getattr(defaults, f.name))})"
                     for f in dataclasses.fields(cls))


# fields that generation sets from the scene unless given (generators.ahdr.AHDRConfig auto_illumination and
# auto_exposure)
_AUTOMATIC = {"full_illumination": "the scene's 99th percentile at t = 0",
              "reference_radiance": "the scene's median at t = 0 gives the mid response"}


def _default(v: object) -> str:
    return "none" if v is None else str(v).lower() if isinstance(v, bool) else f"{v:g}" if isinstance(v, float) \
        else str(v)


def add_model_flags(group: argparse._ActionsContainer, *, sensor_size: bool = True) -> None:
    """Add --dvs, --camera (and --sensor-size) to a parser or argument group.

    Parameters
    ----------
    group : argparse._ActionsContainer
        The parser or argument group.
    sensor_size : bool, optional
        Add --sensor-size too (default True).
    """
    group.add_argument("--dvs", action="append", metavar="FIELD=VALUE",
                       help="set a DVS field over the sensor's (repeatable; FIELD=VALUE,FIELD=VALUE): "
                            + field_list(sim.DVSParams, dvs_params.FIELD_UNITS))
    group.add_argument("--camera", action="append", metavar="FIELD=VALUE",
                       help="set an LDR camera field (repeatable; lists as [1000,8000]; preset=NAME for a camera "
                            f"preset: {', '.join(camera_params.PRESETS)}): "
                            + field_list(camera_params.CameraParams, camera_params.FIELD_UNITS))
    if sensor_size:
        sizes = ", ".join(f"{name} ({h}x{w})" for name, (h, w) in SENSOR_SIZES.items())
        group.add_argument("--sensor-size", metavar="NAME",
                           help=f"height x width of a real sensor, instead of --height/--width: {sizes}")


def parse_assignments(flag: str, texts: list[str] | None) -> dict:
    """Parse FIELD=VALUE texts; field names may use - for _. EvsimInputError naming the flag for a text without '='.

    Parameters
    ----------
    flag : str
        The flag, for the error message ("--dvs", "--camera").
    texts : list of str or None
        Its values, each possibly several comma-separated assignments.

    Returns
    -------
    dict
        {field: value}, values as TOML spells them (units: the fields').
    """
    out = {}
    for text in texts or []:
        for item in _split_top_level(text):
            name, sep, value = item.partition("=")
            name = name.strip().replace("-", "_")
            if not sep or not name:
                raise sim.EvsimInputError(f"{flag} {item!r}: expected FIELD=VALUE (e.g. {flag} "
                                          f"{'pos_threshold=0.25' if flag == '--dvs' else 'fps=25'})")
            out[name] = _toml_value(value.strip())
    return out


def _split_top_level(text: str) -> list[str]:
    """Split at the commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(text):
        if quote:
            quote = "" if c == quote else quote
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    return [p for p in [*parts, text[start:]] if p.strip()]


def _toml_value(text: str) -> object:
    """The TOML value a text spells (true/false in any case), else the text itself (then refused or taken by the
    field's check, e.g. preset=davis346_aps)."""
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def dvs_overrides(args: argparse.Namespace) -> dict:
    """The --dvs fields, checked (sim.sensor_file.check_dvs_fields).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    dict
        {field: value} (units: sim.dvs_params.FIELD_UNITS).
    """
    return check_dvs_fields("--dvs", parse_assignments("--dvs", getattr(args, "dvs", None)))


def camera_overrides(args: argparse.Namespace, named: dict[str, tuple[str, object]] | None = None) -> dict:
    """The --camera fields and those of the named camera flags given (flag -> (field, value); value None: not
    given), checked (sim.sensor_file.check_camera_fields). EvsimInputError when a named flag and --camera set the
    same field.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.
    named : dict, optional
        Named camera flags: flag -> (field, value), value None when not given.

    Returns
    -------
    dict
        {field: value} (units: sim.camera_params.FIELD_UNITS).
    """
    fields = parse_assignments("--camera", getattr(args, "camera", None))
    for flag, (key, value) in (named or {}).items():
        if value is not None:
            if key in fields:
                raise sim.EvsimInputError(f"{flag} and --camera {key}=... both set {key}: give one")
            fields[key] = value
    return check_camera_fields("--camera", fields)


def sensor_size(args: argparse.Namespace) -> tuple[int | None, int | None]:
    """The sensor size from --sensor-size, else from --height and --width. EvsimInputError for an unknown name
    (with the closest) or when --height/--width are given too.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed flags.

    Returns
    -------
    tuple of int or None
        (height, width) in pixels (None where not given).
    """
    name = getattr(args, "sensor_size", None)
    if name is None:
        return args.height, args.width
    if name not in SENSOR_SIZES:
        raise sim.EvsimInputError(f"--sensor-size: {unknown_name('sensor size', name, SENSOR_SIZES)}")
    if args.height is not None or args.width is not None:
        raise sim.EvsimInputError("--sensor-size sets the height and width: drop --height/--width, or "
                                  "--sensor-size")
    return SENSOR_SIZES[name]


#: v2e's model flags (Hu et al. 2021 [Hu2021], v2e's --help) -> what sets the same here
V2E_FLAGS = {
    "pos_thres": "--dvs pos_threshold=VALUE", "neg_thres": "--dvs neg_threshold=VALUE",
    "sigma_thres": "--dvs threshold_sigma=VALUE", "cutoff_hz": "--dvs cutoff_hz=VALUE",
    "leak_rate_hz": "--dvs leak_hz=VALUE", "shot_noise_rate_hz": "--dvs shot_noise_hz=VALUE",
    "refractory_period": "--dvs refractory_us=MICROSECONDS", "dvs128": "--sensor-size dvs128",
    "dvs240": "--sensor-size davis240", "dvs346": "--sensor-size davis346", "dvs640": "--sensor-size dvxplorer",
}


def flag_hint(flag: str) -> tuple[str, float] | None:
    """(what sets the model field a flag names, how close the name is: 0..1) for a field typed as a flag
    (--pos-threshold, --shot-noise, v2e's --pos_thres): "--dvs FIELD=VALUE", "--camera FIELD=VALUE" or
    "--sensor-size NAME".

    Parameters
    ----------
    flag : str
        The unknown flag.

    Returns
    -------
    tuple of (str, float) or None
        (what sets the field, how close the name is: 0..1); None when it is near no field.
    """
    name = flag.lstrip("-").replace("-", "_").lower()
    if name in V2E_FLAGS:
        return V2E_FLAGS[name], 1.0
    found = [(similarity(name, match), f"{option} {match}=VALUE")
             for table, option in ((dvs_params.FIELD_UNITS, "--dvs"), (camera_params.FIELD_UNITS, "--camera"))
             if (match := closest(name, table))]
    return max(found)[::-1] if found else None
