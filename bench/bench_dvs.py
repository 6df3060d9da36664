"""Benchmark of the DVS emulator on a moving textured HDR scene (not a test).

The scene is a periodic log-normal texture (smoothed noise, contrast p0.1..p99.9 far above 1000:1) translating
--speed pixels per frame along x, sampled at --fps. Frames are generated in blocks outside the timed section and
fed --block at a time. For 346x260 and 1280x720 it prints pixel-frames/s, frames/s and events/s (wall clock),
pixel-frames per CPU-second (steadier on a shared machine) and peak memory (traced allocations and max RSS).

    python bench/bench_dvs.py --frames 3000 --frames-hd 300 --preset davis346 --speed 0.2
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc

import numpy as np

import sim


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


def run(height: int, width: int, n_frames: int, preset: str, fps: float, block: int, speed: float) -> None:
    scene = TexturedScene(height, width, speed_px=speed)
    dt = int(round(1e6 / fps))
    emu = sim.DVSEmulator(height, width, sim.DVSParams.preset(preset), seed=0)
    warm = 10
    first = scene.frames(0, warm)
    q = np.percentile(first[0], [0.1, 99.9])
    emu.feed(first, np.arange(warm) * dt)  # initialise, size the buffers and compile outside the timing
    block = block or max(1, 2**23 // (height * width))
    k, n_events, elapsed, cpu = warm, 0, 0.0, 0.0
    tracemalloc.start()
    while k < n_frames + warm:
        m = min(block, n_frames + warm - k)
        frames = scene.frames(k, m)  # generation is not timed
        t_start, c_start = time.perf_counter(), time.process_time()
        n_events += emu.feed(frames, (k + np.arange(m)) * dt).size
        elapsed += time.perf_counter() - t_start
        cpu += time.process_time() - c_start
        k += m
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=3000, help="frames timed at 346x260 (default 3000)")
    ap.add_argument("--frames-hd", type=int, default=300, help="frames timed at 1280x720 (default 300)")
    ap.add_argument("--preset", default="davis346", help="DVS preset (default davis346)")
    ap.add_argument("--fps", type=float, default=1000.0, help="frame rate of the input video (default 1000)")
    ap.add_argument("--block", type=int, default=0, help="frames per feed() call (default: the emulator's block)")
    ap.add_argument("--speed", type=float, default=0.2, help="scene motion in pixels per frame (default 0.2)")
    args = ap.parse_args()
    run(260, 346, args.frames, args.preset, args.fps, args.block, args.speed)
    if args.frames_hd > 0:
        run(720, 1280, args.frames_hd, args.preset, args.fps, args.block, args.speed)


if __name__ == "__main__":
    main()
