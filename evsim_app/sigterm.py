"""SIGTERM ends any evsim command within a second.

The CLI's SIGTERM handler raises Terminated in the main thread, so that every writer's cleanup runs as on Ctrl-C.
Python runs that handler only between bytecodes of the main thread: not while it waits inside a C library call
(an HDF5 read, a numba kernel, a Dask cluster's shutdown). The Watchdog is a thread woken by the signal itself
(signal.set_wakeup_fd: the C-level handler writes to a pipe the moment the signal arrives) that ends the process
DEADLINE_S after the signal if it is still running: it deletes the temporary files this process writes
(generators.formats.atomic.LIVE), stops its child processes (generators.runner.stop_child_processes: also
the temporaries of Dask workers), and exits with 143.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from pathlib import Path

DEADLINE_S = 0.7  # after the signal; the children get up to 0.15 s more to go
MESSAGE = "evsim: terminated (SIGTERM); temporary files removed"


class Watchdog:
    """Started by the CLI's main() in the main thread; stop() when main() returns (a SIGTERM already received
    keeps its deadline: the interpreter's own teardown is bounded too)."""

    def __init__(self) -> None:
        self.reported = False  # the main thread printed MESSAGE itself
        self._r = self._w = -1
        self._previous_fd = -1
        self._thread: threading.Thread | None = None
        try:
            self._r, self._w = os.pipe()
            os.set_blocking(self._w, False)
            self._previous_fd = signal.set_wakeup_fd(self._w, warn_on_full_buffer=False)
        except (ValueError, OSError, AttributeError):  # not the main thread, or no pipes
            self._close()
            return
        self._thread = threading.Thread(target=self._watch, name="evsim-sigterm-watchdog", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Restore the previous wakeup fd and let the thread go (unless a SIGTERM has armed it)."""
        if self._thread is None:
            return
        self._thread = None
        try:
            signal.set_wakeup_fd(self._previous_fd)
        except ValueError:
            pass
        try:
            os.write(self._w, b"\0")  # (0: no signal number) wakes the thread to leave
        except OSError:
            pass

    def _close(self) -> None:
        for fd in (self._r, self._w):
            if fd >= 0:
                os.close(fd)
        self._r = self._w = -1

    def _watch(self) -> None:
        while True:
            try:
                data = os.read(self._r, 64)
            except OSError:
                return
            if signal.SIGTERM in data:
                break
            if not data or 0 in data:
                self._close()
                return
        time.sleep(DEADLINE_S)  # the main thread's own cleanup usually ends the process before this
        end_now(self.reported)


def end_now(reported: bool = False) -> None:
    """Delete this process's temporaries, stop its child processes, exit 143 (the SIGTERM deadline).

    Parameters
    ----------
    reported : bool, optional
        The SIGTERM message is printed already (default False: print it).
    """
    from generators.formats.atomic import discard_live
    from generators.runner import stop_child_processes

    discard_live()
    stop_child_processes()
    if not reported:
        print(MESSAGE, file=sys.stderr)
    try:
        sys.stderr.flush()
        sys.stdout.flush()
    except (OSError, ValueError):
        pass
    os._exit(128 + signal.SIGTERM)


class Terminated(BaseException):
    """Raised in the main thread on SIGTERM, so that every writer's cleanup (temporary files) runs as on Ctrl-C."""


def on_sigterm(signum: int, frame: object) -> None:
    """The CLI's SIGTERM handler: raise Terminated in the main thread.

    Parameters
    ----------
    signum : int
        The signal number.
    frame : object
        The interrupted frame (unused).
    """
    raise Terminated()


def interrupted_message(out: str | Path | None, resumable: bool) -> str:
    """The line for Ctrl-C: what was kept of the run into `out` and how to finish it (complete sequences carry a
    manifest: generators.dataset); nothing to resume when no sequence was complete or the run cannot resume."""
    if not resumable or out is None:
        return "evsim: interrupted (Ctrl-C)"
    from generators.choices import MANIFEST_SUFFIX

    folder = Path(out)
    kept = sorted(folder.glob(f"*{MANIFEST_SUFFIX}")) if folder.is_dir() else []
    if not kept:
        gone = "" if folder.is_dir() else f"; {folder} was not left behind"
        return f"evsim: interrupted (Ctrl-C): no sequence was complete, nothing was kept{gone}"
    return (f"evsim: interrupted (Ctrl-C): {len(kept)} complete sequence(s) kept in {folder}; run the same command "
            "with --resume to finish")
