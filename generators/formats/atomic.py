"""Atomic outputs: write to a temporary sibling, then os.replace it onto the final path.

A failed or interrupted writer therefore never leaves anything at the final path that looks complete, and an
existing file there is untouched until the new one is whole. The temporary is deleted on every exit path that runs
Python code (exceptions, Ctrl-C, and SIGTERM under the CLI, which turns it into an exception); one left by kill -9
is deleted by the next write of the same path on the same host.
"""

from __future__ import annotations

import errno
import glob
import os
import shutil
import socket
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

_OWNER = f"{socket.gethostname()}-{os.getpid()}"


def temp_sibling(path: Path, *, directory: bool = False) -> Path:
    """A new, uniquely named temporary file (or directory) next to `path`, named `.<name>.<host>-<pid>.<random>.tmp`.

    Temporaries of `path` left by a process of this host that no longer runs (killed with kill -9) are removed
    first, so that the next write of the same path cleans up after a crash."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _sweep_stale(path)
    prefix, suffix = f".{path.name}.{_OWNER}.", ".tmp"
    if directory:
        return Path(tempfile.mkdtemp(prefix=prefix, suffix=suffix, dir=path.parent))
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=path.parent)
    os.close(fd)
    return Path(tmp)


def _sweep_stale(path: Path) -> None:
    host = socket.gethostname()
    head = f".{path.name}."
    for p in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
        owner = p.name[len(head):-len(".tmp")].rpartition(".")[0]  # "<host>-<pid>" (the random part dropped)
        h, _, pid = owner.rpartition("-")
        if h == host and pid.isdigit() and not _alive(int(pid)):
            discard(p)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def commit(tmp: Path, path: Path) -> None:
    """Move a finished temporary file or directory onto `path`, replacing what was there.

    Files are replaced atomically (os.replace). A directory cannot be replaced by rename while the old one exists,
    so the old one is first renamed aside and deleted only after the new one is in place (restored on failure).
    """
    tmp, path = Path(tmp), Path(path)
    _apply_umask(tmp)
    if not tmp.is_dir() or not path.exists():
        os.replace(tmp, path)
        return
    old = temp_sibling(path, directory=True)
    os.rmdir(old)
    os.replace(path, old)
    try:
        os.replace(tmp, path)
    except BaseException:
        os.replace(old, path)
        raise
    discard(old)


def _apply_umask(p: Path) -> None:
    """mkstemp/mkdtemp create private (0600/0700) entries; give outputs the mode a plain open() would."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(p, (0o777 if p.is_dir() else 0o666) & ~umask)


def discard(p: Path) -> None:
    """Delete a temporary file or directory if it exists."""
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)
    else:
        p.unlink(missing_ok=True)


@contextmanager
def atomic_path(path: str | Path, *, directory: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; on normal exit it replaces `path`, on exception it is deleted."""
    tmp = temp_sibling(Path(path), directory=directory)
    try:
        yield tmp
    except BaseException:
        discard(tmp)
        raise
    try:
        commit(tmp, Path(path))
    except BaseException:
        discard(tmp)
        raise


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write a text file (UTF-8) atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


_DISK_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def is_disk_full(e: BaseException) -> bool:
    """True for "no space left" / "quota" / "file too large" OSErrors (h5py reports them in the message only):
    not a fault of one output, so callers stop the whole run rather than go on to the next file."""
    if not isinstance(e, OSError):
        return False
    text = str(e)
    return e.errno in _DISK_FULL or any(os.strerror(n) in text for n in _DISK_FULL) or "errno = 28" in text
