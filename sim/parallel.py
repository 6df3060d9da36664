"""Parts of a loop on numba's thread count: contiguous parts of range(n) run on a shared thread pool, for kernels
that release the GIL (njit(nogil=True)); plain threads instead of numba's parallel loops, whose compilation is
costly. One pool per process (a forked child builds its own)."""

from __future__ import annotations

import itertools
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING

import numba

if TYPE_CHECKING:
    from collections.abc import Callable

_POOL: ThreadPoolExecutor | None = None
_POOL_PID = 0  # the process that made _POOL: a forked child has its object but not its threads


def split(n: int, min_part: int, per_thread: int = 1) -> list[int]:
    """The bounds of the parts in_parallel cuts range(n) into: [0, ..., n], parts [bounds[i], bounds[i + 1]).

    Parameters
    ----------
    n, min_part, per_thread : int
        As for in_parallel.

    Returns
    -------
    list of int
        The ascending bounds, one part ([0, n]) when the work does not go to several threads.
    """
    most = n // max(1, min_part)
    threads = max(1, min(numba.get_num_threads(), most)) if most > 1 else 1  # (get_num_threads costs ~10 us)
    if threads == 1:
        return [0, n]
    parts = min(most, threads * max(1, per_thread))
    return [n * i // parts for i in range(parts + 1)]


def in_parallel(fn: Callable[[int, int], object], n: int, min_part: int, per_thread: int = 1,
                bounds: list[int] | None = None) -> None:
    """fn(a, b) over contiguous parts [a, b) of range(n), of at least min_part items, on up to
    numba.get_num_threads() threads (the kernels release the GIL), this thread included.

    per_thread > 1 cuts up to that many parts per thread, taken in turn by whichever thread is free: on a loaded
    machine a thread that is descheduled (or slow to wake) then delays the call by one small part, not by half of
    the work. bounds: the parts, split(n, min_part, per_thread) when None. The first exception raised by fn is
    re-raised here once every part has run.
    """
    global _POOL, _POOL_PID
    if bounds is None:
        bounds = split(n, min_part, per_thread)
    parts = len(bounds) - 1
    if parts == 1:
        fn(bounds[0], bounds[1])
        return
    threads = min(parts, numba.get_num_threads())
    if _POOL is None or _POOL._max_workers < threads - 1 or _POOL_PID != os.getpid():
        _POOL_PID = os.getpid()
        _POOL = ThreadPoolExecutor(max_workers=max(threads - 1, numba.config.NUMBA_NUM_THREADS - 1),
                                   thread_name_prefix="evsim-dvs")
    take = itertools.count().__next__  # atomic under the GIL
    lock, finished, done, errors = threading.Lock(), threading.Event(), [0], []

    def worker():
        while (i := take()) < parts:
            try:
                fn(bounds[i], bounds[i + 1])
            except BaseException as e:  # noqa: BLE001 (re-raised by the caller's thread)
                errors.append(e)
            with lock:
                done[0] += 1
                if done[0] == parts:
                    finished.set()

    for _ in range(threads - 1):
        _POOL.submit(worker)  # a helper that starts after every part is taken returns at once
    worker()
    finished.wait()
    if errors:
        raise errors[0]
