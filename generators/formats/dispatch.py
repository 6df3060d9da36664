"""detect, load and export: each looks the format up in the registry (generators.formats.registry).

load(path) reads any readable layout (detected from the content) into a validated Recording; export(source, out,
fmt) writes a Recording, or streams a native file, in any format, and warns (ExportDropWarning) of the parts the
format cannot hold (HOLDS).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

from sim import EvsimInputError, EvsimNote

from .common import fail, open_h5, reading, validated
from .native import iter_native_events, open_native_images, read_native
from .recognise import unknown_layout
from .recording import Recording
from .registry import ALL_PARTS, FORMATS, HOLDS, REGISTRY, format_record, resolve

__all__ = ["ExportDropWarning", "detect", "load", "export"]


class ExportDropWarning(EvsimNote):
    """An export format cannot hold part of the recording (labels, reference, thresholds, ...): it is left out."""


def detect(path: str | Path) -> str:
    """The layout of `path`, by its suffix and content (generators.formats.registry: the first format whose
    recogniser answers True).

    Parameters
    ----------
    path : str or Path
        A file or folder.

    Returns
    -------
    str
        A name of FORMATS. DatasetFormatError when no format recognises it, saying why (a .txt or .zip file that is
        not E2VID text, a .raw file whose header names no EVT version, an HDF5 file of another layout, ...).
    """
    path = Path(path)
    if not path.exists():
        raise fail(path, "no such file or directory")
    for fmt in REGISTRY:
        if resolve(fmt.recognise)(path):
            return fmt.name
    raise fail(path, unknown_layout(path))


def load(path: str | Path) -> Recording:
    """Read a dataset in any readable layout into a Recording (events, frames with exposure times, reference
    frames with times, threshold maps, labels, CRF and metadata, where the layout holds them).

    What a reader returns is checked by generators.formats.recording.validate_recording; every problem (an invalid
    recording, or what h5py, zlib, json, scipy.io or numpy raise on malformed content) is a DatasetFormatError
    naming the file.

    Parameters
    ----------
    path : str or Path
        A file or folder in a layout detect() recognises.

    Returns
    -------
    Recording
        The recording (times int64 us, frames raw DN, reference in radiance units, thresholds in log units).
    """
    with reading(path):  # detection reads the content too
        rec = resolve(format_record(detect(path)).read)(path)
    return validated(path, rec)


def export(source: Recording | str | Path, out_path: str | Path, fmt: str, *, progress: bool = False,
           **options: Any) -> list[str]:
    """Write a Recording, or a file or folder in any layout load() reads, to out_path in format `fmt`.

    A native HDF5 source is streamed: events in chunks of EVENT_CHUNK, frames and reference one image at a time,
    so memory stays flat whatever its length; other layouts are loaded whole first (their readers decode whole
    files). "exr" writes the reference frames as an EXR folder with a timestamps.txt sidecar; "e2vid-txt" is zipped
    when out_path ends in .zip. Atomic for every format.

    Parameters
    ----------
    source : Recording, str or Path
        A Recording, or a file or folder in any layout load() reads.
    out_path : str or Path
        The file or folder to write.
    fmt : str
        One of FORMATS.
    progress : bool, optional
        Show a progress bar of the events written (a native source; default False).
    **options
        The writer's options: akf-mat takes ct= and f_q= (see akfmat.write_akf_mat); exr takes half=True for
        float16 files.

    Returns
    -------
    list of str
        The parts of the recording that `fmt` cannot hold (see HOLDS), also said by an ExportDropWarning; [] when
        nothing is dropped.
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
    dropped = [part for part in ALL_PARTS if present[part] and part not in HOLDS[fmt]]
    if dropped:
        warnings.warn(f"{fmt} export holds {', '.join(HOLDS[fmt])} and the sensor size; it leaves out "
                      f"{', '.join(dropped)}", ExportDropWarning, stacklevel=3)
    return dropped


def _write(rec: Recording, out_path, fmt: str, options: dict) -> None:
    record = format_record(fmt)
    resolve(record.write)(rec, out_path, **record.write_options, **options)
