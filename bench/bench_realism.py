"""Benchmark: the realism score's cost per simulation (evsim_eval.realism.measure with like=, then compare), the
figure a parameter fit pays on every trial, as a ratio to a yardstick in the same process: one stable argsort of
the events' pixel indices (what grouping the events by pixel, the obvious alternative to the one-pass kernel,
would cost at least).

Input: the real davis346_road recording (../shared/data; its 0.4-2.32 s) as the reference and, as the simulation,
its own events with their times jittered (or, without the data, a 346x260 emulation of a checkerboard).

    python bench/bench_realism.py [--repeat 20]

Prints the median times (CPU of this process and wall-clock) and their ratio to the yardstick; it is not a test.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "davis346_road" / "ijrr"


def _inputs():
    from evsim_eval.realism import measure_recording
    from generators.formats import load

    if ROAD.is_dir():
        rec = load(ROAD)
        window = (0.4, 2.32)
    else:
        import sim
        from generators.formats.recording import Recording
        from generators.scenes import Checkerboard

        scene = Checkerboard(260, 346, 1_000_000, square_px=12.0, velocity_px_per_s=(40.0, 10.0))
        times = np.arange(0, 1_000_001, 2000)
        events = sim.emulate_source(scene, times, sim.DVSParams.preset("davis346"), seed=0)
        mid = np.arange(0, 1_000_001, 40_000)
        frames = np.stack([(np.clip(scene.radiance(int(t)), 0, 1) * 255).astype(np.uint8) for t in mid])
        rec = Recording(events, 260, 346, frames=frames, frame_t_start_us=mid, frame_t_mid_us=mid,
                        frame_t_end_us=mid)
        window = (0.0, 1.0)
    real = measure_recording(rec, window)
    sim_events = rec.events.copy()
    rng = np.random.default_rng(0)
    sim_events["t"] += rng.integers(0, 2000, sim_events.size)
    sim_events.sort(order="t", kind="stable")
    return real, sim_events


def _time(fn, repeat: int) -> tuple[float, float]:
    cpu, wall = [], []
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return float(np.median(cpu)), float(np.median(wall))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20, help="timed runs (the median is reported)")
    args = ap.parse_args()

    from evsim_eval.realism import compare, measure

    real, sim_events = _inputs()
    width = real.width
    compare(real, measure(sim_events, like=real))  # warm-up: numba compilation, imports
    pixel = sim_events["y"].astype(np.int64) * width + sim_events["x"]
    yard = _time(lambda: np.argsort(pixel, kind="stable"), args.repeat)
    meas = _time(lambda: measure(sim_events, like=real), args.repeat)
    stats = measure(sim_events, like=real)
    comp = _time(lambda: compare(real, stats), args.repeat)
    print(f"{sim_events.size} events, {real.width}x{real.height}, windows {real.windows_us.tolist()} us")
    print(f"{'step':<28}{'CPU ms':>10}{'wall ms':>10}{'x yardstick (CPU)':>20}")
    for name, (c, w) in (("yardstick: argsort by pixel", yard), ("measure(like=real)", meas),
                         ("compare", comp)):
        print(f"{name:<28}{c * 1e3:>10.1f}{w * 1e3:>10.1f}{c / yard[0]:>20.2f}")


if __name__ == "__main__":
    main()
