"""Ctrl-C and SIGTERM held while an HDF5 file is being written, and delivered where the writer can stop cleanly.

Python runs a signal's handler at whatever bytecode the main thread is on. While h5py writes through a Python file
object (atomic.GuardedSink, h5py's fileobj driver), that can be inside a call from HDF5's C code, or inside the
weakref callback that frees an h5py object: an exception raised there is either swallowed ("Exception ignored in",
the run goes on as if no Ctrl-C came) or makes HDF5 re-enter the file object and crash the interpreter (exit -11,
the temporary file left behind). So while any HDF5 output is open in the main thread, SIGINT and SIGTERM only set a
flag, and the writer delivers the signal (runs the handler that was installed before: KeyboardInterrupt, the CLI's
Terminated) at its next safe point: after a block of data (deliver_pending) or when the last output is closed
(release). A second Ctrl-C while one is held runs the previous handler at once. Outside the main thread (Dask
worker threads) nothing is held: signals reach only the main thread there.
"""

from __future__ import annotations

import signal
import threading
from types import FrameType

_HELD = (signal.SIGINT, signal.SIGTERM)
_depth = 0  # open outputs holding signals
_previous: dict[int, object] = {}  # the handlers that were installed before the first hold()
_pending: list[int] = []  # signals received while held, in order


def hold() -> bool:
    """Start holding SIGINT and SIGTERM (nested calls count); returns whether this call holds (main thread only)
    and must be paired with release()."""
    global _depth
    if threading.current_thread() is not threading.main_thread():
        return False
    if _depth == 0:
        _previous.clear()
        for sig in _HELD:
            handler = signal.getsignal(sig)
            if callable(handler):  # SIG_DFL and SIG_IGN stay as they are: no Python code runs for them
                _previous[sig] = handler
                signal.signal(sig, _record)
    _depth += 1
    return True


def release() -> None:
    """End one hold(); when the last ends, restore the previous handlers and deliver a signal received meanwhile."""
    global _depth
    _depth -= 1
    if _depth > 0:
        return
    for sig, handler in _previous.items():
        signal.signal(sig, handler)
    deliver_pending()


def deliver_pending() -> None:
    """Run the previous handler of the first signal received while held, if any (it raises KeyboardInterrupt on
    Ctrl-C, the CLI's Terminated on SIGTERM); call it where the writer can stop cleanly."""
    if _pending:
        sig = _pending[0]
        _pending.clear()
        _previous[sig](sig, None)


def _record(signum: int, frame: FrameType | None) -> None:
    if signum == signal.SIGINT and signal.SIGINT in _pending:  # a second Ctrl-C: the user insists
        _pending.clear()
        _previous[signum](signum, frame)
    _pending.append(signum)
