"""The formats' recognisers (generators.formats.registry): each answers whether a path holds its format, from the
suffix and the content, or raises DatasetFormatError when the suffix claims the file but the content cannot be that
format (the error then names what is wrong with it)."""

from __future__ import annotations

from pathlib import Path

import h5py

from .aedat2 import is_aedat2
from .common import fail, open_h5, reading
from .e2vid import is_e2vid
from .exr import TIMES_FILE
from .ijrr import e2vid_txt_problem, is_ijrr
from .native import is_native
from .prophesee import prophesee_kind
from .registry import REGISTRY

_AEDAT4_MAGIC = b"#!AER-DAT4"


def _hdf5_with(path: Path, test) -> bool:
    if not path.is_file() or not h5py.is_hdf5(path):
        return False
    with reading(path), open_h5(path) as f:
        return test(f)


def is_native_file(path: Path) -> bool:
    """An HDF5 file with evsim's native layout (events/t, ...)."""
    return _hdf5_with(path, is_native)


def is_e2vid_file(path: Path) -> bool:
    """An HDF5 file with E2VID's layout (events/ts, ...)."""
    return _hdf5_with(path, is_e2vid)


def is_ijrr_path(path: Path) -> bool:
    """An IJRR folder, or the events.txt inside one."""
    if path.is_dir():
        return is_ijrr(path)
    return path.name == "events.txt" and is_ijrr(path.parent)


def is_exr_folder(path: Path) -> bool:
    """A folder of EXR frames with their times in timestamps.txt."""
    return path.is_dir() and (path / TIMES_FILE).is_file()


def is_akf_mat(path: Path) -> bool:
    """A .mat file (read as the AKF's MATLAB layout)."""
    return path.suffix.lower() == ".mat" and path.is_file()


def is_e2vid_text(path: Path) -> bool:
    """A .txt or .zip file of E2VID text ("width height" first line); DatasetFormatError saying why not for any
    other .txt or .zip file (an IJRR folder's events.txt aside)."""
    suffix = path.suffix.lower()
    if suffix not in (".txt", ".zip") or not path.is_file():
        return False
    problem = e2vid_txt_problem(path)
    if problem is None:
        return True
    if path.name == "events.txt":
        return False
    raise fail(path, f"unknown layout: a {suffix} file is read as E2VID text, but {problem}")


def _first_line(path: Path) -> bytes:
    with open(path, "rb") as f:
        return f.readline(40).strip()


def is_aedat4(path: Path) -> bool:
    """An .aedat4 file, or an .aedat/.aedat2 file whose first line says AEDAT 4.0."""
    suffix = path.suffix.lower()
    if suffix == ".aedat4":
        return True
    return suffix in (".aedat2", ".aedat") and path.is_file() and _first_line(path).startswith(_AEDAT4_MAGIC)


def is_aedat2_file(path: Path) -> bool:
    """An AEDAT 2.0 file (.aedat2 or .aedat); DatasetFormatError for such a file of another AEDAT version."""
    if path.suffix.lower() not in (".aedat2", ".aedat") or not path.is_file():
        return False
    if is_aedat2(path):
        return True
    first = _first_line(path)
    if first.startswith(_AEDAT4_MAGIC):
        return False
    raise fail(path, f"unknown layout: a {path.suffix.lower()} file whose first line is {first[:20]!r}, not "
                     "'#!AER-DAT2.0' (AEDAT 2.0) or '#!AER-DAT4.0'")


def _prophesee_is(path: Path, kind: str) -> bool:
    if path.suffix.lower() not in (".raw", ".dat"):
        return False
    found = prophesee_kind(path)
    if found is None:
        raise fail(path, "unknown layout: a .raw file whose header names neither EVT 2.0 nor EVT 3.0")
    return found == kind


def is_evt3(path: Path) -> bool:
    """A Prophesee .raw file whose header names EVT 3.0."""
    return _prophesee_is(path, "evt3")


def is_evt2(path: Path) -> bool:
    """A Prophesee .raw file whose header names EVT 2.0."""
    return _prophesee_is(path, "evt2")


def is_dat(path: Path) -> bool:
    """A Prophesee .dat file."""
    return _prophesee_is(path, "dat")


def unknown_layout(path: Path) -> str:
    """Why no format recognised `path`, for its DatasetFormatError."""
    if path.is_dir() or path.name == "events.txt":
        return f"unknown layout: a folder with neither events.txt (IJRR) nor {TIMES_FILE} (EXR frames)"
    if path.is_file() and h5py.is_hdf5(path):
        return "unknown layout: HDF5 file with neither events/t (native) nor events/ts (E2VID)"
    kinds = ", ".join(dict.fromkeys(f.description for f in REGISTRY))
    return f"unknown layout: not {kinds} (or truncated?)"
