"""Dataset file formats: the native HDF5 layout and export profiles, with readers.

FORMATS: the names export() accepts. load(path) reads any readable layout (detected from the content):
native HDF5, E2VID HDF5, IJRR text folder (or its events.txt), AKF .mat, and AEDAT4 when the optional `aedat`
package is installed. Bad files raise DatasetFormatError.
"""

from __future__ import annotations

from pathlib import Path

import h5py

from sim import EvsimInputError

from ..recording import Recording
from .aedat4 import read_aedat4
from .akfmat import read_akf_mat, write_akf_mat
from .common import DatasetFormatError, fail, open_h5, reading, validated
from .e2vid import is_e2vid, read_e2vid, write_e2vid
from .exr import write_exr_sequence
from .ijrr import is_ijrr, read_ijrr, write_ijrr
from .native import NativeWriter, is_native, iter_native_events, open_native_images, read_native, write_native

FORMATS = ("native", "e2vid", "ijrr", "akf-mat", "exr")

__all__ = ["FORMATS", "DatasetFormatError", "NativeWriter", "detect", "export", "load"]


def detect(path) -> str:
    """The layout of `path`: "native", "e2vid", "ijrr", "akf-mat" or "aedat4"; DatasetFormatError when unknown."""
    path = Path(path)
    if not path.exists():
        raise fail(path, "no such file or directory")
    if path.is_dir() or path.name == "events.txt":
        if is_ijrr(path if path.is_dir() else path.parent):
            return "ijrr"
        raise fail(path, "unknown layout: a folder without events.txt")
    if path.suffix.lower() == ".mat":
        return "akf-mat"
    if path.suffix.lower() == ".aedat4":
        return "aedat4"
    if h5py.is_hdf5(path):
        with reading(path), open_h5(path) as f:
            if is_native(f):
                return "native"
            if is_e2vid(f):
                return "e2vid"
        raise fail(path, "unknown layout: HDF5 file with neither events/t (native) nor events/ts (E2VID)")
    raise fail(path, "unknown layout: not HDF5, .mat, .aedat4 or an IJRR folder (or truncated?)")


def load(path) -> Recording:
    """Read a dataset in any readable layout into a Recording (events, frames with exposure times, reference
    frames with times, threshold maps, labels, CRF and metadata, where the layout holds them).

    What a reader returns is checked by generators.recording.validate_recording; every problem (an invalid
    recording, or what h5py, zlib, json, scipy.io or numpy raise on malformed content) is a DatasetFormatError
    naming the file."""
    readers = {"native": read_native, "e2vid": read_e2vid, "ijrr": read_ijrr, "akf-mat": read_akf_mat,
               "aedat4": read_aedat4}
    kind = detect(path)
    with reading(path):
        rec = readers[kind](path)
    return validated(path, rec)


def export(recording_or_native_path, out_path, fmt: str, **options) -> None:
    """Write a Recording (or a native HDF5 file, streamed) to out_path in format `fmt` (one of FORMATS).

    options: akf-mat takes ct= and f_q= (see akfmat.write_akf_mat); exr takes half=True for float16 files.
    "exr" writes the reference frames as an EXR folder with a timestamps.txt sidecar. Atomic for every format.
    """
    if fmt not in FORMATS:
        raise EvsimInputError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    src = recording_or_native_path
    if isinstance(src, Recording):
        _write(src, out_path, fmt, options)
        return
    src = Path(src)
    if detect(src) != "native":
        raise EvsimInputError(f"{src}: export reads native HDF5 files or Recordings")
    if fmt == "akf-mat":  # a .mat file is written in one piece
        _write(read_native(src), out_path, fmt, options)
        return
    # events streamed in chunks, frames and reference read one image at a time: memory stays flat
    with open_native_images(src) as rec:
        _write(rec, out_path, fmt, {**options, "event_source": iter_native_events(src)} if fmt != "exr" else options)


def _write(rec: Recording, out_path, fmt: str, options: dict) -> None:
    if fmt == "exr":
        if rec.reference is None:
            raise EvsimInputError("exr export needs reference frames: the recording has none")
        write_exr_sequence(out_path, rec.reference, rec.reference_t_us, **options)
        return
    writers = {"native": write_native, "e2vid": write_e2vid, "ijrr": write_ijrr, "akf-mat": write_akf_mat}
    writers[fmt](rec, out_path, **options)
