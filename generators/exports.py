"""Exporting what evsim reads to another layout (`evsim export SRC DST --format F`).

A source is a file or folder generators.formats.load() reads (native HDF5, E2VID, IJRR, AKF .mat, AEDAT4, EVT
2.0/3.0, DAT, E2VID text, an EXR folder) or a folder of them: a dataset folder written by `evsim generate` /
`evsim convert` (its index.json names the sequences' native files), or any folder whose entries are readable
(e.g. one written by this export). One source becomes the file or folder DST; a folder of sequences becomes the
folder DST with one export per sequence, named <name> + the suffix `generate --format` gives that format
(generators.formats.registry), and an export.json naming the format, the source and the sequences (what `evsim
info` reads to call the folder an export). Every export goes through generators.formats.export (the one writer per
format, also behind `generate --format`): native sources are streamed in chunks, memory stays flat. DST appears
whole or not at all (atomic); an existing DST is refused unless overwrite=True.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim import EvsimInputError, OptionError

from .choices import EXPORT_FILE, FORMATS, INDEX_FILE
from .formats import HOLDS, DatasetFormatError, ExportDropWarning, detect, export
from .formats.atomic import atomic_path, discard
from .formats.registry import format_record

__all__ = ["ExportedSequence", "export_path", "folder_sequences", "export_suffix"]


@dataclass
class ExportedSequence:
    """One export.

    Attributes
    ----------
    name : str
        The sequence's name.
    source : Path
        Its source file or folder.
    out : Path
        The file or folder written.
    dropped : list of str
        The parts of the recording that the format cannot hold (left out).
    """

    name: str
    source: Path
    out: Path
    dropped: list[str]


def export_suffix(fmt: str) -> str:
    """The name suffix of a sequence's export, as `generate --format` names it (generators.formats.registry).

    Parameters
    ----------
    fmt : str
        An export format.

    Returns
    -------
    str
        The suffix ("<name><suffix>", e.g. "_e2vid.h5").
    """
    return format_record(fmt).export_suffix


def folder_sequences(folder: str | Path) -> list[tuple[str, Path]] | None:
    """(name, path) of the sequences of a folder of sequences: a dataset folder's index.json entries (their
    native files), else every entry of the folder that load() reads (sorted by name); None when `folder` is
    itself one recording (an IJRR or EXR folder) or not a folder. DatasetFormatError for a folder with neither.

    Parameters
    ----------
    folder : str or Path
        The folder.

    Returns
    -------
    list of (str, Path) or None
        (name, path) of each sequence, or None.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return None
    index = folder / INDEX_FILE
    if index.is_file():
        try:
            entries = json.loads(index.read_text())["sequences"]
            return [(str(e["name"]), folder / e["file"]) for e in entries]
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise DatasetFormatError(f"{index}: not a dataset index ({type(e).__name__}: {e})") from None
    try:
        detect(folder)
        return None  # one recording
    except DatasetFormatError:
        pass
    found = []
    for entry in sorted(folder.iterdir()):
        if entry.name.startswith(".") or entry.suffix == ".json":
            continue  # temporaries, manifests
        try:
            detect(entry)
        except DatasetFormatError:
            continue
        name = entry.name[: -len(entry.suffix)] if entry.is_file() and entry.suffix else entry.name
        found.append((name, entry))
    if not found:
        raise DatasetFormatError(f"{folder}: no dataset evsim reads here (no {INDEX_FILE}, events.txt or "
                                 "timestamps.txt, and no readable file or folder in it)")
    return found


def export_path(source: str | Path, dst: str | Path, fmt: str, *, overwrite: bool = False,
                progress: bool = False, **options: Any) -> list[ExportedSequence]:
    """Export a recording or a folder of sequences. The drop warnings of the single exports are gathered into one
    ExportDropWarning for the whole call.

    Parameters
    ----------
    source : str or Path
        A readable file or folder, or a folder of sequences (see the module docstring).
    dst : str or Path
        The file or folder to write (a folder of exports for a folder of sequences).
    fmt : str
        One of generators.choices.FORMATS.
    overwrite : bool, optional
        Replace an existing dst (default False).
    progress : bool, optional
        Show progress bars (default False).
    **options
        As for generators.formats.export.

    Returns
    -------
    list of ExportedSequence
        What was written.
    """
    source, dst = Path(source), Path(dst)
    if fmt not in FORMATS:
        raise EvsimInputError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    if not source.exists():
        raise EvsimInputError(f"{source}: no such file or folder")
    if dst.exists() or dst.is_symlink():
        if not overwrite:
            raise OptionError(f"output {dst} already exists; pass overwrite=True to replace it",
                              f"output {dst} already exists; pass --overwrite to replace it")
        if dst.resolve() == source.resolve():
            raise EvsimInputError(f"output {dst} is the source itself")
    sequences = folder_sequences(source)
    done = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExportDropWarning)
        if sequences is None:
            done.append(ExportedSequence(source.stem if source.is_file() else source.name, source, dst,
                                         export(source, dst, fmt, progress=progress, **options)))
        else:
            names = [name for name, _ in sequences]
            dup = next((n for n in names if names.count(n) > 1), None)
            if dup is not None:
                raise EvsimInputError(f"{source}: two sequences are named {dup!r} (their exports would collide)")
            if dst.is_file():
                discard(dst)  # (overwrite: a folder replaces a file)
            with atomic_path(dst, directory=True) as tmp:
                for name, path in sequences:
                    out = tmp / f"{name}{export_suffix(fmt)}"
                    done.append(ExportedSequence(name, path, dst / out.name,
                                                 export(path, out, fmt, progress=progress, **options)))
                record = {"format": fmt, "source": str(source.resolve()),
                          "sequences": {d.name: Path(d.out).name for d in done}}
                (tmp / EXPORT_FILE).write_text(json.dumps(record, indent=2) + "\n")
    for w in caught:
        if not issubclass(w.category, ExportDropWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    dropped = sorted({part for d in done for part in d.dropped}, key=list(HOLDS["native"]).index)
    if dropped:
        warnings.warn(f"{fmt} holds {', '.join(HOLDS[fmt])} and the sensor size: left out {', '.join(dropped)}",
                      ExportDropWarning, stacklevel=2)
    return done
