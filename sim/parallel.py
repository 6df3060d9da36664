"""Parts of a loop on numba's thread count: contiguous parts of range(n) run on a shared thread pool, for kernels
that release the GIL (njit(nogil=True)); plain threads instead of numba's parallel loops, whose compilation is
costly. One pool per process (a forked child builds its own)."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba

_POOL: ThreadPoolExecutor | None = None
_POOL_PID = 0  # the process that made _POOL: a forked child has its object but not its threads


def in_parallel(fn, n: int, min_part: int) -> None:
    """fn(a, b) over contiguous parts [a, b) of range(n), of at least min_part items, on up to
    numba.get_num_threads() threads (the kernels release the GIL); this thread runs the first part."""
    global _POOL, _POOL_PID
    most = n // max(1, min_part)
    parts = max(1, min(numba.get_num_threads(), most)) if most > 1 else 1  # (get_num_threads costs ~10 us)
    if parts == 1:
        fn(0, n)
        return
    bounds = [n * i // parts for i in range(parts + 1)]
    if _POOL is None or _POOL._max_workers < parts - 1 or _POOL_PID != os.getpid():
        _POOL_PID = os.getpid()
        _POOL = ThreadPoolExecutor(max_workers=max(parts - 1, numba.config.NUMBA_NUM_THREADS - 1),
                                   thread_name_prefix="evsim-dvs")
    futures = [_POOL.submit(fn, bounds[i], bounds[i + 1]) for i in range(1, parts)]
    fn(bounds[0], bounds[1])
    for f in futures:
        f.result()
