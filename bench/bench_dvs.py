"""Benchmark of the DVS emulator on a moving textured HDR scene (not a test).

The scene is a periodic log-normal texture (smoothed noise, contrast p0.1..p99.9 far above 1000:1) translating
--speed pixels per frame along x, sampled at --fps. Frames are generated in blocks outside the timed section and
fed --block at a time. For 346x260 and 1280x720 it prints pixel-frames/s, frames/s and events/s (wall clock),
pixel-frames per CPU-second (steadier on a shared machine) and peak memory (traced allocations over two more
untimed blocks, and max RSS), and the same for a bare one-thread numba kernel of the ESIM rule fed the same blocks
in the same loop (the ratio is the figure to quote on a shared machine). `--block 1` feeds frame by frame, as a
streaming user does. `--json FILE` also writes the figures as JSON (docs/make_results.py reads it).

    python bench/bench_dvs.py --frames 3000 --frames-hd 300 --preset davis346 --speed 0.2

`--densities` runs 346x260 instead at the speeds that give about 15,000, 30,000 and 60,000 events per frame (0.2,
0.4 and 0.95 px per frame) and ends with the emulator / bare-kernel speed ratio at each (issue 37: at least 1.6x).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np
from numba import njit

import sim


@njit(cache=True, nogil=True)
def bare_esim(frames, times, t_prev, log_prev, ref, c, eps, out_t, out_x, out_y, out_p):
    """The bare ESIM rule on one thread, the yardstick: log(I + eps) interpolated linearly between frames, an event
    each time it moves c from the reference (which then moves by c); no noise, no filter, no refractory, no
    sorting. Returns the event count (events beyond the buffers are counted, not stored)."""
    n, h, w = frames.shape
    cap = out_t.size
    cnt = 0
    t0 = t_prev
    for k in range(n):
        t1 = times[k]
        dt = float(t1 - t0)
        for y in range(h):
            for x in range(w):
                l0 = log_prev[y, x]
                l1 = math.log(frames[k, y, x] + eps)
                r = ref[y, x]
                d = l1 - l0
                step = c if d > 0 else -c
                while d != 0 and (r + step - l1) * step <= 0:
                    r += step
                    if cnt < cap:
                        out_t[cnt] = t0 + np.int64(math.ceil((r - l0) / d * dt))
                        out_x[cnt] = x
                        out_y[cnt] = y
                        out_p[cnt] = 1 if step > 0 else -1
                    cnt += 1
                ref[y, x] = r
                log_prev[y, x] = l1
        t0 = t1
    return cnt


DENSITY_SPEEDS = (0.2, 0.4, 0.95)  # px per frame: about 16k, 29k and 60k events per frame at 346x260


class TexturedScene:
    """A periodic log-normal HDR texture (smoothed noise) translating speed_px pixels per frame along x."""

    def __init__(self, height: int, width: int, speed_px: float = 0.2, sigma_px: float = 6.0, seed: int = 0):
        rng = np.random.default_rng(seed)
        noise = rng.standard_normal((height, width))
        fy, fx = np.fft.fftfreq(height)[:, None], np.fft.fftfreq(width)[None, :]
        field = np.fft.ifft2(np.fft.fft2(noise) * np.exp(-2 * (np.pi * sigma_px) ** 2 * (fx**2 + fy**2))).real
        self.log_tex = (field / field.std() * 2.0).astype(np.float32)  # +-3.3 sigma spans about e^13
        self.speed_px = speed_px

    def frames(self, k0: int, n: int) -> np.ndarray:
        """(n, H, W) float32 radiance of frames k0 .. k0 + n - 1."""
        out = np.empty((n, *self.log_tex.shape), dtype=np.float32)
        for j in range(n):
            s = (k0 + j) * self.speed_px
            i, f = int(np.floor(s)), np.float32(s - np.floor(s))
            a = np.roll(self.log_tex, -i, axis=1)
            np.exp((1 - f) * a + f * np.roll(a, -1, axis=1), out=out[j])
        return out


def run(height: int, width: int, n_frames: int, preset: str, fps: float, block: int, speed: float) -> dict:
    scene = TexturedScene(height, width, speed_px=speed)
    dt = int(round(1e6 / fps))
    emu = sim.DVSEmulator(height, width, sim.load_sensor(preset).dvs, seed=0)
    warm = 10
    first = scene.frames(0, warm)
    q = np.percentile(first[0], [0.1, 99.9])
    emu.feed(first, np.arange(warm) * dt)  # initialise, size the buffers and compile outside the timing
    block = block or max(1, 2**23 // (height * width))
    # the bare ESIM kernel, fed the same blocks in the same loop (so both see the same machine load)
    eps = emu.params.dark_fraction * emu.params.full_illumination
    log_prev = np.log(first[-1].astype(np.float64) + eps)
    ref = log_prev.copy()
    bufs = (np.empty(1 << 22, np.int64), np.empty(1 << 22, np.uint16), np.empty(1 << 22, np.uint16),
            np.empty(1 << 22, np.int8))
    # one untimed block as the timed ones (a single-frame feed runs code a stack does not: it loads from the cache)
    frames = scene.frames(warm, block)
    emu.feed(frames, (warm + np.arange(block)) * dt)
    bare_esim(frames, (warm + np.arange(block)) * dt, (warm - 1) * dt, log_prev, ref, 0.2, eps, *bufs)
    warm += block
    k, n_events, elapsed, cpu, bare_wall, bare_cpu, bare_events = warm, 0, 0.0, 0.0, 0.0, 0.0, 0
    while k < n_frames + warm:
        m = min(block, n_frames + warm - k)
        frames = scene.frames(k, m)  # generation is not timed
        times = (k + np.arange(m)) * dt
        t_start, c_start = time.perf_counter(), time.process_time()
        n_events += emu.feed(frames, times).size
        elapsed += time.perf_counter() - t_start
        cpu += time.process_time() - c_start
        t_start, c_start = time.perf_counter(), time.process_time()
        bare_events += bare_esim(frames, times, (k - 1) * dt, log_prev, ref, 0.2, eps, *bufs)
        bare_wall += time.perf_counter() - t_start
        bare_cpu += time.process_time() - c_start
        k += m
    # peak memory over two more blocks, untimed: tracemalloc slows every allocation (numpy's and numba's), which
    # would weigh on the emulator's per-call Python work and not on the one-call yardstick
    tracemalloc.start()
    for j in range(2):
        frames = scene.frames(k + j * block, block)
        emu.feed(frames, (k + j * block + np.arange(block)) * dt)
        del frames
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    px_frames = n_frames * height * width
    print(
        f"{width}x{height} {preset}: {n_frames} frames at {fps:g} fps (contrast {q[1] / q[0]:.0f}:1) in "
        f"{elapsed:.2f} s: {px_frames / elapsed / 1e6:.1f} M pixel-frames/s, "
        f"{n_frames / elapsed:.0f} frames/s, {n_events / elapsed / 1e6:.2f} M events/s "
        f"({n_events / n_frames:.0f} events/frame); CPU time {cpu:.2f} s ({px_frames / cpu / 1e6:.1f} M "
        f"pixel-frames per CPU-second); peak traced memory {peak / 2**20:.0f} MiB (including the {block}-frame "
        f"input block), max RSS {rss_mb:.0f} MiB"
    )
    print(
        f"  bare one-thread ESIM kernel, same frames and blocks: {n_frames / bare_wall:.0f} frames/s "
        f"({bare_events / n_frames:.0f} events/frame), CPU time {bare_cpu:.2f} s; emulator / bare speed: "
        f"{bare_wall / elapsed:.2f}x wall clock, {bare_cpu / cpu:.2f}x per CPU-second"
    )
    return {"size": f"{width}x{height}", "preset": preset, "frames": n_frames, "fps": fps, "block": block,
            "contrast": float(q[1] / q[0]), "wall_s": elapsed, "cpu_s": cpu, "events": n_events,
            "pixel_frames_per_s": px_frames / elapsed, "frames_per_s": n_frames / elapsed,
            "events_per_s": n_events / elapsed, "events_per_frame": n_events / n_frames,
            "pixel_frames_per_cpu_s": px_frames / cpu, "peak_traced_mib": peak / 2**20, "max_rss_mib": rss_mb,
            "bare_frames_per_s": n_frames / bare_wall, "bare_cpu_s": bare_cpu,
            "speed_vs_bare_wall": bare_wall / elapsed, "speed_vs_bare_cpu": bare_cpu / cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=3000, help="frames timed at 346x260 (default 3000; 0 skips)")
    ap.add_argument("--frames-hd", type=int, default=300, help="frames timed at 1280x720 (default 300; 0 skips)")
    ap.add_argument("--preset", default="davis346", help="DVS preset or sensor file (default davis346)")
    ap.add_argument("--fps", type=float, default=1000.0, help="frame rate of the input video (default 1000)")
    ap.add_argument("--block", type=int, default=0, help="frames per feed() call (default: the emulator's block)")
    ap.add_argument("--speed", type=float, default=0.2, help="scene motion in pixels per frame (default 0.2)")
    ap.add_argument("--json", type=Path, help="also write the results to this JSON file")
    ap.add_argument("--densities", action="store_true",
                    help="346x260 at about 15k, 30k and 60k events per frame (speeds 0.2, 0.4, 0.95 px per frame)")
    args = ap.parse_args()
    if min(args.frames, args.frames_hd, args.block) < 0 or args.fps <= 0:
        ap.error("--frames, --frames-hd and --block must be >= 0 and --fps > 0")
    results = []
    if args.densities:
        for speed in DENSITY_SPEEDS:
            results.append(run(260, 346, args.frames, args.preset, args.fps, args.block, speed))
        print("emulator / bare one-thread kernel, wall clock: " + ", ".join(
            f"{r['speed_vs_bare_wall']:.2f}x at {r['events_per_frame'] / 1e3:.0f}k events/frame" for r in results)
            + f"; load average {os.getloadavg()[0]:.1f}")
    elif args.frames > 0:
        results.append(run(260, 346, args.frames, args.preset, args.fps, args.block, args.speed))
    if args.frames_hd > 0 and not args.densities:
        results.append(run(720, 1280, args.frames_hd, args.preset, args.fps, args.block, args.speed))
    if args.json:
        args.json.write_text(json.dumps({"bench": "bench_dvs", "runs": results}, indent=1))


if __name__ == "__main__":
    main()
