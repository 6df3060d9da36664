"""The output paths of every subcommand, checked before any work: EvsimInputError (exit 2, one line) naming the
flag, the path and the problem (empty, too long a name, a dangling link, a file where a folder goes, not writable)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import sim
from generators.choices import READ_SUFFIXES, VIDEO_SUFFIXES

_FOLDER_OUTPUT_COMMANDS = ("demo", "generate", "convert", "reconstruct")  # their --out is a folder


_FILE_OUTPUT_FLAGS = ("json", "out", "animate", "video")  # of the other commands (evaluate, plot): files


#: suffixes of the files evsim reads and writes: a new --out folder ending in one is a mistaken file name
_FILE_SUFFIXES = (*READ_SUFFIXES, *VIDEO_SUFFIXES, ".exr", ".json")


MAX_NAME_BYTES = 255  # per path component (NAME_MAX of Linux, macOS and Windows file systems)


def check_paths(args: argparse.Namespace) -> None:
    """--config and the outputs, before any work: EvsimInputError (exit 2, one line) naming the flag, the path and
    the problem. The configuration file itself is read by generators.config.read_text_file.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command-line flags.
    """
    config = getattr(args, "config", None)
    if config is not None and not str(config):
        raise sim.EvsimInputError("--config is empty: give a TOML configuration file")
    folder = args.command in _FOLDER_OUTPUT_COMMANDS
    for flag in ("out",) if folder else _FILE_OUTPUT_FLAGS:
        value = getattr(args, flag, None)
        if value is not None:
            check_output(f"--{flag}", str(value), folder=folder)
    if args.command == "export":  # DST: a file, or a folder for a folder of sequences
        check_output("DST", str(args.dest), folder=None)


def check_output(flag: str, text: str, *, folder: bool | None) -> None:
    """Check an output path: it can be created (or, for a folder, exists as one) and written; EvsimInputError
    naming the flag otherwise.

    Parameters
    ----------
    flag : str
        The flag that gave it, for the message.
    text : str
        The path.
    folder : bool or None
        True for a folder, False for a file, None for either.
    """
    from generators.config import missing_path_reason

    kind = "folder" if folder else "file"
    if not text:
        raise sim.EvsimInputError(f"{flag} is empty: give an output {kind}" + (" ('.' for the current folder)"
                                                                                 if folder else ""))
    path = Path(text)
    long = [part for part in path.parts if len(part.encode()) > MAX_NAME_BYTES]
    if long:
        raise sim.EvsimInputError(f"{flag} {text:.80}...: a name of {len(long[0].encode())} bytes, more than the "
                                  f"{MAX_NAME_BYTES} a file system allows")
    if path.is_symlink() and not path.exists():
        raise sim.EvsimInputError(f"{flag}: {missing_path_reason(path)}; remove the link or give another {kind}")
    if path.exists():
        if folder is None:
            return
        if folder and not path.is_dir():
            raise sim.EvsimInputError(f"{flag} {path} exists and is not a folder")
        if not folder and path.is_dir():
            raise sim.EvsimInputError(f"{flag} {path} is a folder, not a file")
        if folder and not writable(path):
            raise sim.EvsimInputError(f"{flag} {path}: the folder is not writable (permissions or a read-only "
                                      "file system)")
        return
    if folder and path.suffix.lower() in _FILE_SUFFIXES:
        raise sim.EvsimInputError(f"{flag} {text} ends in {path.suffix}, a file's suffix, but names the output "
                                  f"folder (the files inside are named after each sequence): give a folder, e.g. "
                                  f"{flag} {path.with_suffix('')}")
    parent = next((q for q in path.absolute().parents if q.exists()), None)
    if parent is not None and not parent.is_dir():
        raise sim.EvsimInputError(f"{flag}: {parent} is a file, not a folder, so {path} cannot be created")
    if parent is not None and not writable(parent):
        raise sim.EvsimInputError(f"{flag} {path} cannot be created: {parent} is not writable (permissions or a "
                                  "read-only file system)")


def writable(folder: Path) -> bool:
    """Whether a file can be created in `folder`: tried (a temporary file, removed at once), since permission bits
    do not tell for root, read-only mounts or virtual file systems such as /proc.

    Parameters
    ----------
    folder : Path
        An existing folder.

    Returns
    -------
    bool
        Whether a file could be created there.
    """
    import tempfile

    if not os.access(folder, os.W_OK | os.X_OK):
        return False
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False
