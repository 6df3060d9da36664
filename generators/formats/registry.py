"""The file formats evsim reads and writes: one record per format, the one place that knows them.

A record names the format, the suffixes it is read from, the suffix `generate --format` and `evsim export` give a
sequence's export, what it holds of a Recording, and its recogniser, reader and writer as "module:function" paths
(resolved on first use, so that this module imports nothing: `evsim --help` lists FORMATS without loading h5py or a
decoder). detect, load and export (generators.formats.dispatch), the command line's choices, its output-path check
and the scenes' recording detector all read this table. Adding a format is adding a record and its recogniser,
reader and writer.

Records are in detection order: detect() asks each recogniser in turn and takes the first that answers True.
A recogniser may raise DatasetFormatError when the file is claimed by its suffix but cannot be this format (a .raw
file whose header names no EVT version), so that the error names the actual problem.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["Format", "REGISTRY", "FORMATS", "EXPORT_FORMATS", "HOLDS", "ALL_PARTS", "READ_SUFFIXES",
           "format_record", "resolve"]

#: the parts of a Recording an export can hold (every format also holds the sensor size)
ALL_PARTS = ("events", "frames", "reference", "threshold_maps", "event_labels", "crf", "metadata")

_PKG = "generators.formats"


@dataclass(frozen=True)
class Format:
    """One file format.

    Parameters
    ----------
    name : str
        The name `--format` and `export()` take.
    description : str
        What the user knows it as (error messages).
    suffixes : tuple of str
        Lower-case suffixes of the files it is read from; () for a folder layout.
    export_suffix : str
        The name suffix of a sequence's export: "<sequence name><export_suffix>".
    holds : tuple of str
        The Recording parts it can hold (ALL_PARTS names).
    recognise, read, write : str
        "module:function" of its recogniser ``(Path) -> bool``, reader ``(Path) -> Recording`` and writer
        ``(Recording, Path, **options) -> None``; modules relative to generators.formats.
    write_options : dict
        Keyword arguments the writer always gets (a writer shared by several formats: the format's name).
    exportable : bool
        Whether a dataset generator can write it per sequence (the EXR folder holds the reference only).
    """

    name: str
    description: str
    suffixes: tuple[str, ...]
    export_suffix: str
    holds: tuple[str, ...]
    recognise: str
    read: str
    write: str
    write_options: dict[str, Any] = field(default_factory=dict)
    exportable: bool = True


def _prophesee(name: str, description: str, suffix: str, export_suffix: str) -> Format:
    return Format(name, description, (suffix,), export_suffix, ("events",), f"recognise:is_{name}",
                  "prophesee:read_prophesee", "prophesee:write_prophesee", {"fmt": name})


#: every format, in detection order
REGISTRY: tuple[Format, ...] = (
    Format("native", "native HDF5", (".h5", ".hdf5"), ".h5", ALL_PARTS, "recognise:is_native_file",
           "native:read_native", "native:write_native"),
    Format("e2vid", "E2VID HDF5", (".h5", ".hdf5"), "_e2vid.h5", ALL_PARTS, "recognise:is_e2vid_file",
           "e2vid:read_e2vid", "e2vid:write_e2vid"),
    Format("ijrr", "an IJRR folder", (), "_ijrr", ALL_PARTS, "recognise:is_ijrr_path", "ijrr:read_ijrr",
           "ijrr:write_ijrr"),
    Format("akf-mat", ".mat", (".mat",), ".mat", ALL_PARTS, "recognise:is_akf_mat", "akfmat:read_akf_mat",
           "akfmat:write_akf_mat"),
    Format("exr", "an EXR folder", (), "_exr", ("reference",), "recognise:is_exr_folder", "exr:read_exr_recording",
           "exr:write_exr_recording", exportable=False),
    Format("e2vid-txt", "E2VID text", (".txt", ".zip"), "_e2vid.zip", ("events",), "recognise:is_e2vid_text",
           "ijrr:read_e2vid_txt", "ijrr:write_e2vid_txt"),
    Format("aedat4", ".aedat4", (".aedat4",), ".aedat4", ("events", "frames"), "recognise:is_aedat4",
           "aedat4:read_aedat4", "aedat4:write_aedat4"),
    Format("aedat2", ".aedat2", (".aedat2", ".aedat"), ".aedat2", ("events",), "recognise:is_aedat2_file",
           "aedat2:read_aedat2", "aedat2:write_aedat2"),
    _prophesee("evt3", ".raw", ".raw", "_evt3.raw"),
    _prophesee("evt2", ".raw", ".raw", "_evt2.raw"),
    _prophesee("dat", ".dat", ".dat", "_td.dat"),
)

#: the names export() and `--format` accept
FORMATS = tuple(f.name for f in REGISTRY)
#: the formats a dataset generator can write per sequence
EXPORT_FORMATS = tuple(f.name for f in REGISTRY if f.exportable)
#: what each format can hold, of a Recording's parts
HOLDS = {f.name: f.holds for f in REGISTRY}
#: every suffix a format is read from
READ_SUFFIXES = tuple(dict.fromkeys(s for f in REGISTRY for s in f.suffixes))

_BY_NAME = {f.name: f for f in REGISTRY}


def format_record(name: str) -> Format:
    """The record of format `name`.

    Parameters
    ----------
    name : str
        A name of FORMATS.

    Returns
    -------
    Format
        Its record; KeyError for an unknown name (callers check names against FORMATS first, with a message).
    """
    return _BY_NAME[name]


def resolve(ref: str) -> Callable[..., Any]:
    """The function a "module:function" path of a record names (module relative to generators.formats).

    Parameters
    ----------
    ref : str
        "module:function", e.g. "native:read_native".

    Returns
    -------
    callable
        The function, its module imported on first use.
    """
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(f"{_PKG}.{module}"), name)


def suffix_claimed(path: Path) -> bool:
    """Whether some format is read from files with `path`'s suffix (the content still decides which, if any)."""
    return path.suffix.lower() in READ_SUFFIXES
