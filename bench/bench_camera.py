"""Throughput of the LDR camera (sim.LDRCamera.capture) with noise on: pixel-subframes/s and peak memory.

The source replays a few precomputed radiance frames, so the figures measure the camera, not a scene. The
per-pixel sensor model (Poisson shot noise, read noise, quantisation) runs once per frame and the exposure
integral once per sub-frame, so throughput in pixel-subframes/s grows with the sub-frame count; both 1 and
--subframes are reported, by wall clock and per CPU-second of the process (all threads; steadier on a shared
machine). Peak traced memory covers numpy allocations (tracemalloc), max RSS the whole process.
Usage: python bench/bench_camera.py [--seconds 1.0] [--subframes 16]
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc

import numpy as np

import crf_models
from sim import CameraParams, LDRCamera


class ReplaySource:
    """A RadianceSource cycling through 8 random float32 frames; claims a speed giving the wanted sub-frames."""

    def __init__(self, height, width, duration_us, speed_px_per_s):
        rng = np.random.default_rng(0)
        self.height, self.width, self.duration_us = height, width, duration_us
        self._frames = [rng.uniform(0.05, 2.0, (height, width)).astype(np.float32) for _ in range(8)]
        self._speed = speed_px_per_s

    def radiance(self, t_us):
        return self._frames[t_us % 8]

    def max_speed_px_per_s(self):
        return self._speed


def run(height, width, seconds, subframes, crf_name):
    exposure = 10_000
    params = CameraParams.preset("machine_vision", fps=50.0, exposure_us=exposure, n_subframes=subframes)
    cam = LDRCamera(height, width, params, crf_models.get(crf_name), seed=0)
    src = ReplaySource(height, width, int(seconds * 1e6), 0.0)
    next(cam.capture(ReplaySource(height, width, 2 * exposure, 0.0)))  # compile and warm up
    tracemalloc.start()
    t0, c0 = time.perf_counter(), time.process_time()
    n_frames = n_sub = 0
    for frame in cam.capture(src, irradiance=False, clean_response=False):
        n_frames += 1
        n_sub += frame.n_subframes
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    rate = n_sub * height * width / dt
    print(
        f"{width}x{height} crf={crf_name} subframes/frame={subframes}: {n_frames} frames in {dt:.2f} s, "
        f"{rate / 1e6:.0f} M pixel-subframes/s, {n_frames / dt:.1f} frames/s, CPU time {cpu:.2f} s "
        f"({n_sub * height * width / cpu / 1e6:.0f} M pixel-subframes per CPU-second), "
        f"peak traced memory {peak / 2**20:.1f} MiB, "
        f"process max RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated duration per size (50 fps)")
    ap.add_argument("--subframes", type=int, default=16, help="sub-frames per exposure")
    ap.add_argument("--crf", default="srgb", help="crf_models name")
    args = ap.parse_args()
    for height, width in ((260, 346), (720, 1280)):
        for sub in sorted({1, args.subframes}):
            run(height, width, args.seconds, sub, args.crf)


if __name__ == "__main__":
    main()
