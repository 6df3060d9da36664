"""Benchmark: events per second of every event denoiser of sim.denoise at DAVIS346 resolution (346 x 260), each at
its default parameter, and the peak memory.

Input: a DAVIS346-like ("davis346" preset, shot noise raised with --shot-hz) emulation of a checkerboard panning
at 40 px/s, so the filters see the mix of signal and noise they are made for. Filters whose library is not
installed (pip install "evsim[denoise]") are listed as skipped.

    python bench/bench_denoise.py [--seconds 0.5] [--shot-hz 5] [--repeat 3] [--filters correlation,dv_ba]

Prints, per filter, events/s against the process's CPU time (the fairer figure on a shared machine; best of
--repeat runs, after one warm-up run that pays numba's compilation) and against wall-clock; it is not a test.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

H, W = 260, 346


def make_events(seconds: float, shot_hz: float):
    import sim
    from generators.scenes import Checkerboard

    scene = Checkerboard(H, W, int(seconds * 1e6), square_px=12.0, velocity_px_per_s=(40.0, 10.0))
    times = np.arange(0, int(seconds * 1e6) + 1, 2000)
    params = sim.DVSParams.preset("davis346", shot_noise_hz=shot_hz)
    return sim.emulate_source(scene, times, params, seed=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=0.5, help="sensor time (s)")
    ap.add_argument("--shot-hz", type=float, default=5.0, help="shot-noise rate per pixel (Hz)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per filter (the best is reported)")
    ap.add_argument("--filters", help="comma-separated sim.denoise.FILTERS (default: all)")
    args = ap.parse_args()

    from sim.denoise import FILTERS, filter_available, keep_mask

    names = args.filters.split(",") if args.filters else list(FILTERS)
    events = make_events(args.seconds, args.shot_hz)
    print(f"{events.size} events ({events.size / args.seconds / 1e6:.2f} M events/s of sensor time), {W}x{H}")
    print(f"{'filter':<16}{'parameter':>24}{'kept':>8}{'Mev/s CPU':>12}{'Mev/s wall':>12}")
    for name in names:
        f = FILTERS[name]
        if not filter_available(name):
            print(f"{name:<16}{'skipped: needs ' + f.library:>24}")
            continue
        keep = keep_mask(events, H, W, name)  # warm-up (numba compilation)
        cpu, wall = [], []
        for _ in range(args.repeat):
            c0, w0 = time.process_time(), time.perf_counter()
            keep_mask(events, H, W, name)
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        print(f"{name:<16}{f.param + '=' + format(f.default, 'g'):>24}{keep.mean():>8.3f}"
              f"{events.size / max(min(cpu), 1e-9) / 1e6:>12.2f}{events.size / max(min(wall), 1e-9) / 1e6:>12.2f}")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
