"""Atomic outputs: write to a temporary sibling, then os.replace it onto the final path.

A failed or interrupted writer therefore never leaves anything at the final path that looks complete, and an
existing file there is untouched until the new one is whole. The temporary is deleted on every exit path that runs
Python code (exceptions, Ctrl-C, and SIGTERM under the CLI, which turns it into an exception; the temporaries this
process has open are listed in LIVE for the CLI's SIGTERM deadline); one left by kill -9 is deleted by the next
write of the same path on the same host.

Full disks: a write that fails for want of space (ENOSPC, EDQUOT) or for a file size limit (EFBIG) becomes a
DiskFullError naming the output's final path (atomic_path converts it, whatever library reported it: OSError,
h5py's messages, OpenEXR's RuntimeError). GuardedSink is the binary file HDF5 writers write through (h5py's fileobj
driver): it never reports a failed write to HDF5, whose state after one crashes the process (HDF5 2.0) when the
file's objects are freed; the writer raises the recorded error itself once HDF5 has closed the file.
"""

from __future__ import annotations

import errno
import glob
import io
import os
import shutil
import socket
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: the temporary files and folders this process is writing (added by temp_sibling, removed by commit and discard)
LIVE: set[Path] = set()


def temp_sibling(path: Path, *, directory: bool = False) -> Path:
    """A new, uniquely named temporary file (or directory) next to `path`, named `.<name>.<host>-<pid>.<random>.tmp`.

    Temporaries of `path` left by a process of this host that no longer runs (killed with kill -9) are removed
    first, so that the next write of the same path cleans up after a crash."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _sweep_stale(path)
    prefix, suffix = f".{path.name}.{socket.gethostname()}-{os.getpid()}.", ".tmp"  # a forked child: its own pid
    if directory:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, suffix=suffix, dir=path.parent))
    else:
        fd, name = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=path.parent)
        os.close(fd)
        tmp = Path(name)
    LIVE.add(tmp)
    return tmp


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
        LIVE.discard(tmp)
        return
    old = temp_sibling(path, directory=True)
    os.rmdir(old)
    os.replace(path, old)
    try:
        os.replace(tmp, path)
    except BaseException:
        os.replace(old, path)
        LIVE.discard(old)
        raise
    LIVE.discard(tmp)
    discard(old)


def _apply_umask(p: Path) -> None:
    """mkstemp/mkdtemp create private (0600/0700) entries; give outputs the mode a plain open() would."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(p, (0o777 if p.is_dir() else 0o666) & ~umask)


def discard(p: Path) -> None:
    """Delete a temporary file or directory if it exists."""
    p = Path(p)
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)
    else:
        p.unlink(missing_ok=True)
    LIVE.discard(p)


def discard_live() -> None:
    """Delete every temporary this process is writing (the CLI's last step when SIGTERM's deadline passes while
    the main thread is still inside a library call)."""
    for p in list(LIVE):
        try:
            discard(p)
        except OSError:
            pass


@contextmanager
def atomic_path(path: str | Path, *, directory: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; on normal exit it replaces `path`, on exception it is deleted.
    A full disk or file size limit, in the body or on the final move, raises DiskFullError naming `path`."""
    tmp = temp_sibling(Path(path), directory=directory)
    try:
        yield tmp
    except BaseException as e:
        discard(tmp)
        if is_disk_full(e):
            raise disk_full_error(e, path) from e
        raise
    try:
        commit(tmp, Path(path))
    except BaseException as e:
        discard(tmp)
        if is_disk_full(e):
            raise disk_full_error(e, path) from e
        raise


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write a text file (UTF-8) atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


_DISK_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


class DiskFullError(OSError):
    """An output could not be written for want of space (ENOSPC, EDQUOT) or for a file size limit (EFBIG).
    errno and strerror as OSError's; filename: the output's final path (nothing was written in its place)."""

    def __str__(self) -> str:
        return f"cannot write {self.filename}: {self.strerror} (nothing was written in its place)"


def _disk_full_errno(e: BaseException) -> int | None:
    if isinstance(e, OSError) and e.errno in _DISK_FULL:
        return e.errno
    if isinstance(e, (OSError, RuntimeError)):  # h5py, OpenEXR and dv-processing say it in the message only
        text = str(e)
        for n in _DISK_FULL:
            if os.strerror(n) in text or f"errno = {n}," in text:
                return n
    return None


def is_disk_full(e: BaseException) -> bool:
    """True for "no space left" / "quota" / "file too large" errors, as OSError or in the message of h5py's,
    OpenEXR's and dv-processing's errors: not a fault of one output, so callers stop the whole run rather than
    go on to the next file."""
    return _disk_full_errno(e) is not None


def disk_full_error(e: BaseException, path: str | Path) -> DiskFullError:
    """The DiskFullError for error `e` (is_disk_full(e)) while writing the output `path`."""
    n = _disk_full_errno(e) or errno.ENOSPC
    strerror = "disk full (no space left on device)" if n == errno.ENOSPC else os.strerror(n).lower()
    return DiskFullError(n, strerror, str(path))


class GuardedSink(io.RawIOBase):
    """A binary file for h5py's fileobj driver (`h5py.File(sink, "w")`) whose writes never fail as HDF5 sees
    them: the first OSError (a full disk, a size limit, an I/O error) is recorded in `error`, and that write and
    all later ones are kept in memory instead, so that HDF5 reads back what it wrote and closes the file cleanly.
    Writers call check() after each block of data (raises the recorded error: the memory kept stays one block)
    and close() after closing the h5py.File (also raises it); the temporary file is then discarded. Signals that
    would raise inside HDF5's calls are held meanwhile by the writer (common.H5Output, held_interrupts)."""

    def __init__(self, path: str | Path):
        super().__init__()
        self._fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC | getattr(os, "O_BINARY", 0), 0o600)
        self._pos = self._size = 0
        self.error: OSError | None = None
        self._kept: list[tuple[int, bytes]] = []  # (offset, data) written since the error

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, pos: int, whence: int = os.SEEK_SET) -> int:
        self._pos = {os.SEEK_SET: 0, os.SEEK_CUR: self._pos, os.SEEK_END: self._size}[whence] + int(pos)
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, b: bytearray | memoryview) -> int:
        view = memoryview(b).cast("B")
        n = max(0, min(len(view), self._size - self._pos))
        data = _pread(self._fd, n, self._pos) if n else b""
        view[: len(data)] = data
        view[len(data) : n] = bytes(n - len(data))
        for off, blob in self._kept:
            lo, hi = max(off, self._pos), min(off + len(blob), self._pos + n)
            if lo < hi:
                view[lo - self._pos : hi - self._pos] = blob[lo - off : hi - off]
        self._pos += n
        return n

    def write(self, b: bytes | bytearray | memoryview) -> int:
        view = memoryview(b).cast("B")
        n, off = len(view), self._pos
        if self.error is None:
            try:
                while len(view):
                    k = _pwrite(self._fd, view, off)
                    view, off = view[k:], off + k
            except OSError as e:
                self.error = e
        if self.error is not None and len(view):
            self._kept.append((off, bytes(view)))
        self._pos += n
        self._size = max(self._size, self._pos)
        return n

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else int(size)
        if self.error is None:
            try:
                os.ftruncate(self._fd, size)
            except OSError as e:
                self.error = e
        self._size = size
        return size

    def flush(self) -> None:
        pass

    def check(self) -> None:
        """Raise the recorded write error, if any."""
        if self.error is not None:
            raise self.error

    def close(self) -> None:
        """Close the file descriptor (idempotent); raise the recorded write error, if any."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd, self._kept = None, []
            super().close()
        self.check()


def _pread(fd: int, n: int, offset: int) -> bytes:
    if hasattr(os, "pread"):
        return os.pread(fd, n, offset)
    os.lseek(fd, offset, os.SEEK_SET)  # (Windows)
    return os.read(fd, n)


def _pwrite(fd: int, data: memoryview, offset: int) -> int:
    if hasattr(os, "pwrite"):
        return os.pwrite(fd, data, offset)
    os.lseek(fd, offset, os.SEEK_SET)  # (Windows)
    return os.write(fd, data)
