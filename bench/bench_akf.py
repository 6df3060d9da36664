"""Benchmark: events per second of the AKF, its smoother and the complementary filter at DAVIS346 resolution
(346 x 260), with 30 fps frames and images published at 30 Hz, on numba's default thread count (the machine's
cores); and the peak memory.

Synthetic input: spatially coherent random-walk events (walkers stepping one pixel per event, random polarity)
at the requested rate, and 8-bit frames of a smooth pattern through the AHDR window CRF.

    python bench/bench_akf.py [--rate 10e6] [--seconds 1.0] [--threads N] [--repeat 3] [--json FILE]

AKF-paper is the AKF without the frame update and the output smoothing (AKFParams(frame_update=False,
smooth_range=0)), for their cost as a ratio; AKS the smoother (akf.reconstruct_smoothed: the filter forward and
backward, fused), whose time per event is printed as a ratio to the AKF's in the same run. Prints throughput
(events/s, excluding the one-off numba compilation) against wall-clock and against the process's CPU time (the
fairer figure on a shared machine: with N threads it is the work, not the elapsed time), the best of --repeat
timed runs each, and peak memory; it is not a test.
"""

from __future__ import annotations

import argparse
import functools
import json
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np

H, W = 260, 346


def random_walk_events(rate: float, seconds: float, walkers: int = 2000, seed: int = 0) -> np.ndarray:
    import sim

    rng = np.random.default_rng(seed)
    n = int(rate * seconds)
    per = -(-n // walkers)
    steps = rng.integers(-1, 2, (walkers, per, 2))
    start = rng.integers(0, [W, H], (walkers, 1, 2))
    pos = (start + np.cumsum(steps, axis=1)).reshape(-1, 2)[:n]
    ev = sim.empty_events(n)
    ev["t"] = np.sort(rng.integers(0, int(seconds * 1e6), n))
    ev["x"] = pos[:, 0] % W
    ev["y"] = pos[:, 1] % H
    ev["p"] = rng.choice(np.array([-1, 1], np.int8), n)
    return ev


def frames_and_times(seconds: float, crf):
    ts = np.arange(0, int(seconds * 1e6) - 10_000, 33_333)
    te = ts + 10_000
    yy, xx = np.mgrid[0:H, 0:W]
    frames = np.stack([np.round(crf.forward(0.25 * np.exp(np.sin(0.05 * (xx - 0.02 * t)) * np.cos(0.03 * yy))) * 255)
                       .astype(np.uint8) for t in ts])
    return frames, ts, te


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=10e6, help="event rate of the synthetic sensor (events/s)")
    ap.add_argument("--seconds", type=float, default=1.0, help="sensor time (s)")
    ap.add_argument("--threads", type=int, default=None,
                    help="numba threads (default: numba's default, the machine's cores); the filters run row blocks "
                         "in parallel")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per method (the best is printed)")
    ap.add_argument("--leak-hz", type=float, default=0.0, help="the AKF's leak_rate_hz (0: the paper's event model)")
    ap.add_argument("--json", type=Path, help="also write the results to this JSON file")
    args = ap.parse_args()

    import numba

    import akf
    import crf_models

    threads = numba.config.NUMBA_NUM_THREADS if args.threads is None else args.threads
    numba.set_num_threads(threads)
    crf = crf_models.get("window")
    events = random_walk_events(args.rate, args.seconds)
    frames, ts, te = frames_and_times(args.seconds, crf)
    out_t = np.arange(int(ts[0]) + 1, int(args.seconds * 1e6), 33_333)  # 30 Hz publishing
    print(f"{events.size:,} events over {args.seconds:g} s at {W}x{H}, {len(frames)} frames, "
          f"{len(out_t)} published images, {threads} thread(s), AKF leak_rate_hz {args.leak_hz:g}")
    paper = akf.AKFParams(frame_update=False, smooth_range=0.0)  # the paper's filter: no frame update, no smoothing
    methods = (("AKF", functools.partial(akf.reconstruct, leak_rate_hz=args.leak_hz)),
               ("AKF-paper", functools.partial(akf.reconstruct, leak_rate_hz=args.leak_hz, params=paper)),
               ("AKS", functools.partial(akf.reconstruct_smoothed, leak_rate_hz=args.leak_hz)),
               ("CF", akf.complementary_filter))
    # warm-up on the first 3 frames, with events between them and 2 published images: every kernel the timed run
    # uses is compiled (or loaded from the numba cache) here, not timed
    warm_events = events[: np.searchsorted(events["t"], ts[3])][::50]
    results = {"bench": "bench_akf", "events": int(events.size), "seconds": args.seconds, "size": f"{W}x{H}",
               "frames": len(frames), "published": len(out_t), "threads": threads, "leak_hz": args.leak_hz,
               "repeat": args.repeat, "methods": {}}
    for name, fn in methods:
        fn(warm_events, frames[:3], ts[:3], te[:3], crf, out_t[:2])
        dt = cpu = float("inf")
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            fn(events, frames, ts, te, crf, out_t)
            dt, cpu = min(dt, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
        tracemalloc.start()  # apart: tracing slows allocation-heavy code
        fn(events, frames, ts, te, crf, out_t)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(f"{name:9s} {events.size / dt / 1e6:7.2f} M events/s wall ({dt:.3f} s, best of {args.repeat}), "
              f"{events.size / cpu / 1e6:7.2f} M events/s of CPU time ({cpu:.3f} s)  "
              f"peak traced memory {peak / 2**20:.1f} MiB (output {len(out_t) * H * W * 4 / 2**20:.1f} MiB)")
        results["methods"][name] = {"wall_s": dt, "cpu_s": cpu, "events_per_s": events.size / dt,
                                    "events_per_cpu_s": events.size / cpu, "peak_traced_mib": peak / 2**20}
    ratio = results["methods"]["AKS"]["wall_s"] / results["methods"]["AKF"]["wall_s"]
    results["aks_over_akf_wall"] = ratio
    print(f"AKS / AKF time per event: {ratio:.2f} (wall, same run)")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"process max RSS {rss:.0f} MiB (includes the input events and frames)")
    if args.json:
        args.json.write_text(json.dumps({**results, "max_rss_mib": rss}, indent=1))


if __name__ == "__main__":
    main()
