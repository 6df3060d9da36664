"""Dataset file formats: the native HDF5 layout and export profiles, with readers.

FORMATS: the names export() accepts. load(path) reads any readable layout (detected from the content):
native HDF5, E2VID HDF5, IJRR text folder (or its events.txt), E2VID text (.txt / .zip with a "width height"
first line), AKF .mat, Prophesee EVT 3.0 / EVT 2.0 .raw and .dat, AEDAT 2.0 (jAER, DAVIS layout: .aedat2 or .aedat),
an EXR folder (reference frames only), and AEDAT4 when the optional `aedat` package is installed. Bad files raise
DatasetFormatError.
HOLDS: what each export format can hold; export() warns (ExportDropWarning) and returns the names of the parts
of a recording that the format cannot hold.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import h5py

from sim import EvsimInputError, EvsimNote

from ..choices import EXPORT_FORMATS, FORMATS
from .aedat2 import SUFFIXES as AEDAT2_SUFFIXES
from .aedat2 import is_aedat2, read_aedat2, write_aedat2
from .aedat4 import read_aedat4, write_aedat4
from .akfmat import read_akf_mat, write_akf_mat
from .common import DatasetFormatError, ReaderNoteWarning, fail, open_h5, reading, validated
from .e2vid import is_e2vid, read_e2vid, write_e2vid
from .exr import TIMES_FILE, read_exr_recording, write_exr_sequence
from .ijrr import e2vid_txt_problem, is_ijrr, read_e2vid_txt, read_ijrr, write_e2vid_txt, write_ijrr
from .interop import from_tonic, to_tonic
from .native import NativeWriter, is_native, iter_native_events, open_native_images, read_native, write_native
from .prophesee import PROPHESEE_FORMATS, prophesee_kind, read_prophesee, write_prophesee
from .recording import Recording, missing_part_error

_ALL_PARTS = ("events", "frames", "reference", "threshold_maps", "event_labels", "crf", "metadata")
# What each export format can hold, of a Recording's parts (every format also holds the sensor size).
HOLDS = {
    "native": _ALL_PARTS, "e2vid": _ALL_PARTS, "ijrr": _ALL_PARTS, "akf-mat": _ALL_PARTS,
    "exr": ("reference",),
    "e2vid-txt": ("events",),
    "aedat4": ("events", "frames"),
    "aedat2": ("events",),
    **{fmt: ("events",) for fmt in PROPHESEE_FORMATS},
}

__all__ = ["EXPORT_FORMATS", "FORMATS", "HOLDS", "DatasetFormatError", "ExportDropWarning", "NativeWriter",
           "ReaderNoteWarning", "detect", "export", "from_tonic", "load", "to_tonic"]


class ExportDropWarning(EvsimNote):
    """An export format cannot hold part of the recording (labels, reference, thresholds, ...): it is left out."""


def detect(path: str | Path) -> str:
    """The layout of `path`: "native", "e2vid", "ijrr", "exr" (a folder of EXR frames with timestamps.txt),
    "e2vid-txt", "akf-mat", "aedat4", "aedat2", "evt3", "evt2" or "dat"; DatasetFormatError when unknown. A .txt
    or .zip file (other than an IJRR events.txt) is E2VID text, or a DatasetFormatError saying why it is not (a .zip
    with several members, a byte-order mark, ...)."""
    path = Path(path)
    if not path.exists():
        raise fail(path, "no such file or directory")
    suffix = path.suffix.lower()
    if suffix in (".txt", ".zip") and path.is_file():
        problem = e2vid_txt_problem(path)
        if problem is None:
            return "e2vid-txt"
        if path.name != "events.txt":  # (an IJRR events.txt is read with its folder below)
            raise fail(path, f"unknown layout: a {suffix} file is read as E2VID text, but {problem}")
    if suffix in (".raw", ".dat"):
        kind = prophesee_kind(path)
        if kind is None:
            raise fail(path, "unknown layout: a .raw file whose header names neither EVT 2.0 nor EVT 3.0")
        return kind
    if path.is_dir() or path.name == "events.txt":
        if is_ijrr(path if path.is_dir() else path.parent):
            return "ijrr"
        if (path / TIMES_FILE).is_file():
            return "exr"
        raise fail(path, f"unknown layout: a folder with neither events.txt (IJRR) nor {TIMES_FILE} (EXR frames)")
    if suffix == ".mat":
        return "akf-mat"
    if suffix == ".aedat4":
        return "aedat4"
    if suffix in AEDAT2_SUFFIXES and path.is_file():
        if is_aedat2(path):
            return "aedat2"
        with open(path, "rb") as f:
            first = f.readline(40).strip()
        if first.startswith(b"#!AER-DAT4"):
            return "aedat4"
        raise fail(path, f"unknown layout: a {suffix} file whose first line is {first[:20]!r}, not '#!AER-DAT2.0' "
                         "(AEDAT 2.0) or '#!AER-DAT4.0'")
    if h5py.is_hdf5(path):
        with reading(path), open_h5(path) as f:
            if is_native(f):
                return "native"
            if is_e2vid(f):
                return "e2vid"
        raise fail(path, "unknown layout: HDF5 file with neither events/t (native) nor events/ts (E2VID)")
    raise fail(path, "unknown layout: not HDF5, .mat, .aedat4, .aedat2, .raw, .dat, E2VID text or an IJRR folder "
                     "(or truncated?)")


def load(path: str | Path) -> Recording:
    """Read a dataset in any readable layout into a Recording (events, frames with exposure times, reference
    frames with times, threshold maps, labels, CRF and metadata, where the layout holds them).

    What a reader returns is checked by generators.formats.recording.validate_recording; every problem (an invalid
    recording, or what h5py, zlib, json, scipy.io or numpy raise on malformed content) is a DatasetFormatError
    naming the file."""
    readers = {"native": read_native, "e2vid": read_e2vid, "ijrr": read_ijrr, "akf-mat": read_akf_mat,
               "aedat4": read_aedat4, "aedat2": read_aedat2, "e2vid-txt": read_e2vid_txt, "exr": read_exr_recording,
               **{fmt: read_prophesee for fmt in PROPHESEE_FORMATS}}
    with reading(path):  # detection reads the content too
        rec = readers[detect(path)](path)
    return validated(path, rec)


def export(source: Recording | str | Path, out_path: str | Path, fmt: str, *, progress: bool = False,
           **options: Any) -> list[str]:
    """Write a Recording, or a file or folder in any layout load() reads, to out_path in format `fmt` (one of
    FORMATS).

    A native HDF5 source is streamed: events in chunks of EVENT_CHUNK, frames and reference one image at a time,
    so memory stays flat whatever its length (progress=True shows a bar of the events written); other layouts are
    loaded whole first (their readers decode whole files). options: akf-mat takes ct= and f_q= (see
    akfmat.write_akf_mat); exr takes half=True for float16 files. "exr" writes the reference frames as an EXR
    folder with a timestamps.txt sidecar; "e2vid-txt" is zipped when out_path ends in .zip. Atomic for every
    format. Returns the parts of the recording that `fmt` cannot hold (see HOLDS), also said by an
    ExportDropWarning; [] when nothing is dropped.
    """
    if fmt not in FORMATS:
        raise EvsimInputError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    src = source
    if isinstance(src, Recording):
        _write(src, out_path, fmt, options)
        return _say_dropped(src, fmt, has_labels=src.event_labels is not None)
    src = Path(src)
    if detect(src) != "native":
        rec = load(src)
        _write(rec, out_path, fmt, options)
        return _say_dropped(rec, fmt, has_labels=rec.event_labels is not None)
    if fmt == "akf-mat":  # a .mat file is written in one piece
        rec = read_native(src)
        _write(rec, out_path, fmt, options)
        return _say_dropped(rec, fmt, has_labels=rec.event_labels is not None)
    # events streamed in chunks, frames and reference read one image at a time: memory stays flat
    with open_native_images(src) as rec:
        if fmt != "exr":
            options = {**options, "event_source": _counted(iter_native_events(src), src, progress)}
        _write(rec, out_path, fmt, options)
        with open_h5(src) as f:
            has_labels = "events/label" in f
        return _say_dropped(rec, fmt, has_labels=has_labels)


def _counted(chunks, src: Path, progress: bool):
    """The (events, labels) chunks of `chunks`, counted by a progress bar of the events of `src` when asked."""
    if not progress:
        yield from chunks
        return
    from tqdm.auto import tqdm

    with open_h5(src) as f:
        total = int(f["events/t"].shape[0])
    with tqdm(total=total, unit="ev", unit_scale=True, desc=f"export {src.name}", leave=False) as bar:
        for events, labels in chunks:
            yield events, labels
            bar.update(events.size)


def _say_dropped(rec: Recording, fmt: str, *, has_labels: bool) -> list[str]:
    """Warn about, and return, the parts of `rec` that format `fmt` cannot hold."""
    present = {"events": True, "frames": rec.frames is not None, "reference": rec.reference is not None,
               "threshold_maps": rec.threshold_maps is not None, "event_labels": has_labels,
               "crf": rec.crf is not None, "metadata": bool(rec.metadata)}
    dropped = [part for part in _ALL_PARTS if present[part] and part not in HOLDS[fmt]]
    if dropped:
        warnings.warn(f"{fmt} export holds {', '.join(HOLDS[fmt])} and the sensor size; it leaves out "
                      f"{', '.join(dropped)}", ExportDropWarning, stacklevel=3)
    return dropped


def _write(rec: Recording, out_path, fmt: str, options: dict) -> None:
    if fmt == "exr":
        if rec.reference is None:
            raise missing_part_error("exr export needs reference frames: the recording has none", rec, "reference")
        write_exr_sequence(out_path, rec.reference, rec.reference_t_us, **options)
        return
    if fmt in PROPHESEE_FORMATS:
        write_prophesee(rec, out_path, fmt, **options)
        return
    writers = {"native": write_native, "e2vid": write_e2vid, "ijrr": write_ijrr, "akf-mat": write_akf_mat,
               "e2vid-txt": write_e2vid_txt, "aedat4": write_aedat4, "aedat2": write_aedat2}
    writers[fmt](rec, out_path, **options)
