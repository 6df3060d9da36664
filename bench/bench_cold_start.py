"""Benchmark: the cold start of `evsim demo`: the numba compilation CPU time of every kernel it compiles, on an
empty cache, and the whole run's CPU and wall time.

    python bench/bench_cold_start.py [--serial] [--keep-cache DIR] [demo options, e.g. --height 90 --width 120]

Runs the demo in this process with NUMBA_CACHE_DIR pointed at a new empty folder (or DIR), listening to numba's
compile events. Each kernel's time is its own (exclusive) thread CPU time, without the kernels it compiles in turn,
so the column sums to the total; specialisations (one line per signature) show extra compiles. The kernels the
demo's child process compiles in the background (evsim_app.precompile) count as its CPU time; --serial runs
without it. CPU time rather than wall: the machine is shared. It is not a test.
"""

from __future__ import annotations

import os
import resource
import sys
import tempfile
import threading
import time
from collections import defaultdict


def main() -> None:
    argv = sys.argv[1:]
    cache = None
    if "--keep-cache" in argv:
        i = argv.index("--keep-cache")
        cache = argv[i + 1]
        del argv[i:i + 2]
    serial = "--serial" in argv  # no background compilation (evsim_app.precompile), for comparison
    if serial:
        argv.remove("--serial")
    cache = cache or tempfile.mkdtemp(prefix="evsim-numba-")
    os.environ["NUMBA_CACHE_DIR"] = cache  # before numba is imported
    out = tempfile.mkdtemp(prefix="evsim-demo-")

    c0, w0 = time.process_time(), time.perf_counter()
    import numba.core.event as ev

    local = threading.local()
    own = defaultdict(float)  # (kernel, signature) -> exclusive thread CPU seconds
    count = defaultdict(int)

    class Compiles(ev.Listener):
        def on_start(self, event):
            stack = getattr(local, "stack", None)
            if stack is None:
                stack = local.stack = []
            stack.append([time.thread_time(), 0.0])

        def on_end(self, event):
            start, nested = local.stack.pop()
            total = time.thread_time() - start
            d = event.data["dispatcher"]
            key = (f"{d.py_func.__module__}.{d.py_func.__qualname__}", str(tuple(event.data["args"])))
            own[key] += total - nested
            count[key] += 1
            if local.stack:
                local.stack[-1][1] += total

    ev.register("numba:compile", Compiles())
    from evsim_app.cli import main as cli_main

    if serial:
        import evsim_app.precompile

        evsim_app.precompile.start_background_compile = lambda: None

    c_import = time.process_time() - c0
    cli_main(["demo", "--out", out, "--no-progress", *argv])
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    child_cpu = child.ru_utime + child.ru_stime

    per_kernel = defaultdict(float)
    n_sig = defaultdict(int)
    for (name, _), s in own.items():
        per_kernel[name] += s
        n_sig[name] += 1
    print(f"\nnumba cache: {cache}")
    print(f"{'kernel':64s} {'sigs':>4s} {'compile CPU-s':>13s}")
    for name, s in sorted(per_kernel.items(), key=lambda kv: -kv[1]):
        print(f"{name:64s} {n_sig[name]:4d} {s:13.2f}")
    if os.environ.get("EVSIM_BENCH_SIGS"):
        for (name, sig), s in sorted(own.items(), key=lambda kv: -kv[1]):
            print(f"  {s:6.2f}  {name} {sig}")
    total = sum(per_kernel.values())
    print(f"compilation in this process: {total:.1f} CPU-s over {len(per_kernel)} kernels, {len(own)} specialisations")
    print(f"whole run: {cpu:.1f} CPU-s in this process (imports {c_import:.1f}) + {child_cpu:.1f} CPU-s in child "
          f"processes (evsim_app.precompile), {wall:.1f} s wall, {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
