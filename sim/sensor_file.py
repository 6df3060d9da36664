"""Sensor files: a sensor model (DVS parameters, LDR camera defaults, where the values come from) in a small TOML
file, accepted wherever a preset name is (sim.load_sensor, `sensor = "my.toml"` in a configuration, `evsim ...
--sensor my.toml`):

    name = "my_davis346"          # required: the sensor's name, recorded in every output
    base = "davis346"             # optional: the DVS preset the [dvs] table modifies (default davis346)
    description = "..."           # optional

    [dvs]                         # sim.DVSParams fields (units: sim.dvs_params.FIELD_UNITS); the others are base's
    pos_threshold = 0.175
    [camera]                      # sim.CameraParams fields (units: sim.camera_params.FIELD_UNITS) and optionally
    fps = 25.0                    # preset = "davis346_aps": camera defaults, under any explicit camera setting
    [provenance]                  # free-form: where the values come from (recording, its sha256, fit loss, date)
    recording = "davis346_road"
    [input]                       # optional: what a real camera's frames mean (INPUT_FIELDS): black_level,
    black_level = 0.0             # read_noise_dn, offset_dn (evsim calibrate writes it; convert takes black_level)

Reading is strict: an unknown table or key, or a value the parameters refuse, raises InvalidParameterError naming
the file and the key (with the closest allowed name and the list of them). write_sensor writes a Sensor back
(units in comments, every float as its repr) so that load_sensor(write_sensor(path, s)) == s. The tables a file may
hold and their validators are TABLES.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import os
import re
import tempfile
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from . import camera_params, dvs_params
from .dvs_params import DVSParams
from .errors import EvsimInputError, InvalidParameterError, check_number, toml_type
from .suggest import did_you_mean, unknown_name

__all__ = ["Sensor", "load_sensor", "parse_sensor", "write_sensor", "sensor_toml", "check_dvs_fields",
           "check_camera_fields", "TABLES", "DEFAULT_BASE"]

#: the DVS preset a sensor file's [dvs] table modifies when it names no base
DEFAULT_BASE = "davis346"
MAX_SENSOR_FILE_BYTES = 1 << 20  # a sensor file is a few hundred bytes: a larger file is not one
_TOP_KEYS = {"name": "the sensor's name", "base": "a DVS preset", "description": "text"}


def check_dvs_fields(where: str, table: Mapping) -> dict:
    """`table` (DVSParams field -> value), checked: every key a field (else the closest name and the list of them),
    every value one the field accepts. InvalidParameterError naming where.key (where a flag such as "--dvs": "--dvs
    key") otherwise. The one check of DVS overrides: sensor files, configuration tables, `--dvs FIELD=VALUE`.

    Parameters
    ----------
    where : str
        Where the table comes from, for the error messages (e.g. "sensor file x.toml: dvs", or a flag "--dvs").
    table : mapping
        DVSParams field -> value (units: sim.dvs_params.FIELD_UNITS).

    Returns
    -------
    dict
        The table, as a dict.
    """
    return _check_fields(where, table, "DVS field", dvs_params.FIELD_UNITS, lambda t: DVSParams().replace(**t))


def check_camera_fields(where: str, table: Mapping) -> dict:
    """`table` (CameraParams field -> value, and optionally preset = a camera preset name), checked as
    check_dvs_fields checks DVS fields; lists become tuples (exposure_us, frame_times_us).

    Parameters
    ----------
    where : str
        Where the table comes from, for the error messages.
    table : mapping
        CameraParams field -> value (units: sim.camera_params.FIELD_UNITS), and optionally "preset".

    Returns
    -------
    dict
        The table, as a dict, its lists as tuples.
    """
    table = {k: tuple(v) if isinstance(v, list) else v for k, v in _check_mapping(where, table).items()}

    def build(t: dict) -> object:
        over = dict(t)
        name = over.pop("preset", None)
        if name is None:
            return camera_params.CameraParams(**over)
        if not isinstance(name, str) or name not in camera_params.PRESETS:
            raise InvalidParameterError(f"preset: {unknown_name('camera preset', name, camera_params.PRESETS)}")
        return camera_params.CameraParams.preset(name, **over)

    allowed = {**camera_params.FIELD_UNITS, "preset": "a camera preset"}
    return _check_fields(where, table, "camera field", allowed, build)


def _check_mapping(where: str, table: object) -> dict:
    if not isinstance(table, Mapping):
        raise InvalidParameterError(f"{where}: expected a table, got {toml_type(table)} {table!r:.60}")
    return dict(table)


def _check_fields(where: str, table: Mapping, what: str, allowed: Mapping[str, str],
                  build: Callable[[dict], object]) -> dict:
    table = _check_mapping(where, table)
    for key in table:
        if key not in allowed:
            at = f"{where} {key}" if where.startswith("--") else f"{where}.{key}"  # a flag: "--dvs FIELD"
            raise InvalidParameterError(f"{at}: {unknown_name(what, key, allowed)}")
    try:
        build(table)
    except (InvalidParameterError, TypeError) as e:
        raise InvalidParameterError(f"{where}: {e}") from None
    return table


def _check_provenance(where: str, table: Mapping) -> dict:
    table = _check_mapping(where, table)
    for key, value in table.items():
        _toml_value(f"{where}.{key}", value)  # it can be written back
    return table


#: the [input] table: what a real camera's frames mean (read by generators' video scene and evsim calibrate)
INPUT_FIELDS = {
    "black_level": "the frames' value for no light (DN, >= 0), subtracted before linearising",
    "read_noise_dn": "the frames' temporal read noise (DN rms, >= 0)",
    "offset_dn": "the DVS log offset b in frame DN: the pixel responds to log(DN - black_level + b) (> 0); the "
                 "[dvs] dark_fraction is the same offset relative to full illumination",
}


def check_input_fields(where: str, table: Mapping) -> dict:
    """The [input] table checked: keys of INPUT_FIELDS, finite numbers >= 0 (offset_dn > 0).

    Parameters
    ----------
    where : str
        Where the table comes from, for the error messages.
    table : mapping
        INPUT_FIELDS key -> number (DN).

    Returns
    -------
    dict
        The table, its values as floats.
    """
    table = _check_mapping(where, table)
    for key, value in table.items():
        if key not in INPUT_FIELDS:
            raise InvalidParameterError(f"{where}.{key}: {unknown_name('input field', key, INPUT_FIELDS)}")
        try:
            table[key] = check_number(key, value, positive=key == "offset_dn")
        except InvalidParameterError as e:
            raise InvalidParameterError(f"{where}: {e}") from None
    return table


#: the tables of a sensor file -> their validator (where, table) -> table; DVS, camera and provenance are fields of
#: Sensor, any other table is kept in Sensor.tables
TABLES: dict[str, Callable[[str, Mapping], dict]] = {
    "dvs": check_dvs_fields,
    "camera": check_camera_fields,
    "provenance": _check_provenance,
    "input": check_input_fields,
}


@dataclass(frozen=True)
class Sensor:
    """A sensor model: what a preset name or a sensor file stands for.

    Attributes
    ----------
    name : str
        What outputs record (non-empty).
    dvs : DVSParams
        The DVS parameters (base preset + the file's [dvs] table).
    camera : mapping
        CameraParams field overrides applied as camera defaults, under any explicit camera setting (some camera
        fields are per sequence).
    provenance : mapping
        Where the values come from (free-form).
    base : str
        The DVS preset the [dvs] table modifies (default DEFAULT_BASE, "davis346").
    description : str
        Text.
    tables : mapping
        The file's other tables (see TABLES), validated.
    dvs_fields : tuple of str
        The DVS fields the sensor sets itself (its [dvs] table; always including every field where dvs differs from
        base).
    path : str or None
        The file it was read from (None for a preset or a Sensor made in Python; not compared).
    """

    name: str
    dvs: DVSParams = field(default_factory=DVSParams)
    camera: Mapping = field(default_factory=dict)
    provenance: Mapping = field(default_factory=dict)
    base: str = DEFAULT_BASE
    description: str = ""
    tables: Mapping = field(default_factory=dict)
    dvs_fields: tuple[str, ...] = ()
    path: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InvalidParameterError(f"sensor name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.description, str):
            raise InvalidParameterError(f"sensor description must be a string, got {self.description!r}")
        if self.base not in dvs_params.PRESETS:
            raise InvalidParameterError(f"base: {unknown_name('DVS preset', self.base, dvs_params.PRESETS)}")
        if not isinstance(self.dvs, DVSParams):
            raise InvalidParameterError(f"sensor dvs must be a sim.DVSParams, got {type(self.dvs).__name__}")
        object.__setattr__(self, "camera", check_camera_fields("camera", self.camera))
        object.__setattr__(self, "provenance", _check_provenance("provenance", self.provenance))
        tables = _check_mapping("tables", self.tables)
        for key, table in tables.items():
            if key not in TABLES or key in ("dvs", "camera", "provenance"):
                extra = [t for t in TABLES if t not in ("dvs", "camera", "provenance")]
                raise InvalidParameterError(f"tables.{key}: {unknown_name('sensor table', key, extra)}")
            tables[key] = TABLES[key](key, table)
        object.__setattr__(self, "tables", tables)
        names = [f.name for f in dataclasses.fields(DVSParams)]
        for key in self.dvs_fields:
            if key not in names:
                raise InvalidParameterError(f"dvs_fields: {unknown_name('DVS field', key, names)}")
        base = dvs_params.PRESETS[self.base]
        differ = {n for n in names if getattr(self.dvs, n) != getattr(base, n)}
        object.__setattr__(self, "dvs_fields", tuple(n for n in names if n in differ or n in self.dvs_fields))

    @classmethod
    def preset(cls, name: str) -> Sensor:
        """The sensor a DVS preset name stands for (no camera defaults).

        Parameters
        ----------
        name : str
            A DVS preset name (sim.DVS_PRESETS).

        Returns
        -------
        Sensor
            The preset's sensor.
        """
        if name not in dvs_params.PRESETS:
            raise InvalidParameterError(unknown_name("DVS preset", name, dvs_params.PRESETS))
        return cls(name=name, dvs=dvs_params.PRESETS[name], base=name)

    @property
    def dvs_overrides(self) -> dict:
        """The DVS fields the sensor sets itself (field -> value): its [dvs] table."""
        return {n: getattr(self.dvs, n) for n in self.dvs_fields}

    def describe(self) -> dict:
        """JSON-serialisable record for output metadata: name, base, description, file (None for a preset), the DVS
        fields it sets, its camera defaults, provenance and other tables (dates as ISO 8601 text).

        Returns
        -------
        dict
            The record.
        """
        return _jsonable({"name": self.name, "base": self.base, "description": self.description, "file": self.path,
                          "dvs": self.dvs_overrides, "camera": dict(self.camera),
                          "provenance": dict(self.provenance), **self.tables})


def _jsonable(v: object) -> object:
    if isinstance(v, Mapping):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (datetime.date, datetime.time)):
        return v.isoformat()
    return v


def parse_sensor(data: Mapping, *, source: str = "<sensor>", path: str | None = None) -> Sensor:
    """A Sensor from a sensor file's content (a dict as tomllib parses it), checked strictly (see the module
    docstring); errors name `source` and the key.

    Parameters
    ----------
    data : mapping
        The parsed TOML.
    source : str, optional
        What the content came from, for the error messages (default "<sensor>").
    path : str, optional
        The file it was read from, recorded as Sensor.path (default None).

    Returns
    -------
    Sensor
        The sensor.
    """
    allowed = [*_TOP_KEYS, *TABLES]
    for key in data:
        if key not in allowed:
            raise InvalidParameterError(f"{source}: {key}: {unknown_name('sensor file key', key, allowed)}")
    for key in _TOP_KEYS:
        if key in data and not isinstance(data[key], str):
            raise InvalidParameterError(f"{source}: {key}: expected a string ({_TOP_KEYS[key]}), got "
                                        f"{toml_type(data[key])} {data[key]!r:.60}")
    if "name" not in data or not data["name"].strip():
        raise InvalidParameterError(f"{source}: name: missing or empty: a sensor file names its sensor (outputs "
                                    "record it)")
    base = data.get("base", DEFAULT_BASE)
    if base not in dvs_params.PRESETS:
        raise InvalidParameterError(f"{source}: base: {unknown_name('DVS preset', base, dvs_params.PRESETS)}")
    tables = {key: TABLES[key](f"{source}: {key}", data[key]) for key in TABLES if key in data}
    dvs_over = tables.pop("dvs", {})
    try:
        return Sensor(name=data["name"], dvs=dvs_params.PRESETS[base].replace(**dvs_over),
                      camera=tables.pop("camera", {}), provenance=tables.pop("provenance", {}), base=base,
                      description=data.get("description", ""), tables=tables, dvs_fields=tuple(dvs_over), path=path)
    except InvalidParameterError as e:
        raise InvalidParameterError(f"{source}: {e}") from None


def load_sensor(name_or_path: str | os.PathLike | Sensor, *, base_dir: str | os.PathLike | None = None) -> Sensor:
    """The Sensor of a DVS preset name (sim.DVS_PRESETS) or of a sensor file (.toml). A Sensor is returned as is.
    InvalidParameterError for an unknown name (with the closest preset), EvsimInputError for a file that cannot be
    read or is not TOML.

    Parameters
    ----------
    name_or_path : str, os.PathLike or Sensor
        A preset name, a sensor file path, or a Sensor.
    base_dir : str or os.PathLike, optional
        The folder a relative path is taken relative to (default: the current folder).

    Returns
    -------
    Sensor
        The sensor.
    """
    if isinstance(name_or_path, Sensor):
        return name_or_path
    if isinstance(name_or_path, str) and name_or_path in dvs_params.PRESETS:
        return Sensor.preset(name_or_path)
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise InvalidParameterError(f"sensor must be a preset name or a sensor file path, got "
                                    f"{type(name_or_path).__name__} {name_or_path!r:.60}")
    path = Path(name_or_path).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    if path.suffix.lower() != ".toml" and not path.exists():
        raise InvalidParameterError(
            f"unknown sensor {str(name_or_path)!r}{did_you_mean(str(name_or_path), dvs_params.PRESETS)}: a sensor "
            f"is a preset ({', '.join(dvs_params.PRESETS)}) or a sensor file (.toml)")
    text = _read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise EvsimInputError(f"sensor file {path}: not valid TOML: {e}") from None
    return parse_sensor(data, source=f"sensor file {path}", path=str(path.resolve()))


def _read_text(path: Path) -> str:
    try:
        if not path.is_file():
            why = "is a folder, not a file" if path.is_dir() else "does not exist" if not path.exists() else \
                "is not a regular file"
            raise EvsimInputError(f"sensor file {path} {why}")
        if path.stat().st_size > MAX_SENSOR_FILE_BYTES:
            raise EvsimInputError(f"sensor file {path} has {path.stat().st_size} bytes: not a sensor file (at most "
                                  f"{MAX_SENSOR_FILE_BYTES})")
        return path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise EvsimInputError(f"sensor file {path}: cannot be read: {e.strerror or e}") from None
    except UnicodeDecodeError:
        raise EvsimInputError(f"sensor file {path} is not UTF-8 text: is it a binary file?") from None


# ----- writing -------------------------------------------------------------------------------------------------

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.match(key) else _toml_string(key)


def _toml_string(s: str) -> str:
    # a JSON string is a TOML basic string, except that TOML also wants DEL escaped
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def _toml_value(where: str, v: object) -> str:
    """The TOML text of a value: bool, int, float (repr: exact), string, date/time, list or table (inline)."""
    import numbers

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        f = float(v)
        return ("nan" if math.isnan(f) else "inf" if f > 0 else "-inf") if not math.isfinite(f) else repr(f)
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, (datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(f"{where}[{i}]", x) for i, x in enumerate(v)) + "]"
    if isinstance(v, Mapping):
        for k in v:
            if not isinstance(k, str):
                raise InvalidParameterError(f"{where}: keys must be strings to be written to TOML, got {k!r}")
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(f'{where}.{k}', x)}" for k, x in v.items()) + "}"
    raise InvalidParameterError(f"{where}: a {type(v).__name__} cannot be written to a sensor file (TOML holds "
                                "numbers, strings, booleans, dates, lists and tables)")


def sensor_toml(sensor: Sensor) -> str:
    """The sensor file text of `sensor` (what write_sensor writes): units in comments; the DVS fields it does not
    set are listed as comments with the base preset's values.

    Parameters
    ----------
    sensor : Sensor
        The sensor.

    Returns
    -------
    str
        The TOML text.
    """
    lines = ["# evsim sensor file: `--sensor FILE`, sensor = \"FILE\" in a configuration, sim.load_sensor(FILE)",
             f"name = {_toml_string(sensor.name)}", f"base = {_toml_string(sensor.base)}"]
    if sensor.description:
        lines.append(f"description = {_toml_string(sensor.description)}")
    lines += ["", "[dvs]  # sim.DVSParams fields; the commented ones are the base preset's"]
    for f in dataclasses.fields(DVSParams):
        value = _toml_value(f"dvs.{f.name}", getattr(sensor.dvs, f.name))
        unit = f"  # {dvs_params.FIELD_UNITS[f.name]}"
        lines.append(f"{f.name} = {value}{unit}" if f.name in sensor.dvs_fields
                     else f"# {f.name} = {value}{unit} (from {sensor.base})")
    lines += ["", "[camera]  # sim.CameraParams fields: camera defaults, under any explicit camera setting"]
    units = {**camera_params.FIELD_UNITS, "preset": "camera preset"}
    lines += [f"{k} = {_toml_value(f'camera.{k}', v)}  # {units[k]}" for k, v in sensor.camera.items()]
    for table, content in [("provenance", sensor.provenance), *sensor.tables.items()]:
        lines += ["", f"[{table}]"]
        lines += [f"{_toml_key(k)} = {_toml_value(f'{table}.{k}', v)}" for k, v in content.items()]
    return "\n".join(lines) + "\n"


def write_sensor(path: str | os.PathLike, sensor: Sensor) -> Path:
    """Write `sensor` as a sensor file at `path` atomically (a temporary file in the same folder, then os.replace;
    missing folders are created); return the path. load_sensor(path) gives back an equal Sensor.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    sensor : Sensor
        The sensor.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    if not isinstance(sensor, Sensor):
        raise InvalidParameterError(f"write_sensor takes a sim.Sensor, got {type(sensor).__name__}")
    path = Path(path)
    text = sensor_toml(sensor)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
