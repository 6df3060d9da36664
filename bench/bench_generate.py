"""Benchmark of end-to-end AHDR generation (not a test).

1. Time split (scene sampling, DVS, camera, writing) for a 346x260 sequence (default 10 s) of the built-in
   astronaut image under pan and shake, with the davis346 sensor and the default camera (30 fps, window CRF).
   With --compare-dense, the same sequence again with the former worst-pixel step rule (sampling_quantile 1.0):
   its work, samples and events, and the agreement of the default's events with it (count ratio, per-pixel count
   correlation).
2. Peak resident memory of generating 640x480 sequences (default 60 s, and a quarter of it to show that memory is
   flat in duration), and of exporting each file to the E2VID layout; each run is a fresh subprocess so that the
   peaks are independent.

    python bench/bench_generate.py [--duration-s 10] [--memory-duration-s 60] [--skip-memory] [--compression lzf]
                                   [--compare-dense]

Numba kernels are compiled (or loaded from cache) by a short warm-up run first. The time split is wall-clock on
whatever else the machine is doing; "work" is the CPU time (time.process_time) of the generation.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def run_once(duration_s: float, height: int, width: int, out: Path, compression: str = "gzip",
             quantile: float | None = None) -> dict:
    from generators.ahdr import AHDRConfig, generate_ahdr
    from generators.scenes import builtin_image_scene
    from generators.scenes import Trajectory

    scene = builtin_image_scene(height, width, int(duration_s * 1e6),
                                Trajectory(pan_px_per_s=(30.0, 8.0), shake_px=1.0, shake_hz=2.0))
    config = AHDRConfig(compression=compression)
    if quantile is not None:
        config = dataclasses.replace(config, sampling_quantile=quantile)
    t0, c0 = time.perf_counter(), time.process_time()
    r = generate_ahdr(scene, out, config, 0, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"duration_s": duration_s, "size": f"{width}x{height}", "wall_s": wall, "cpu_s": cpu,
            "timings_s": r.timings_s,
            "n_events": r.n_events, "n_frames": r.n_frames, "n_dvs_samples": r.n_dvs_samples,
            "file_mb": out.stat().st_size / 2**20,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _child(args) -> None:
    if args.export_from:
        from generators.formats import export

        t0 = time.perf_counter()
        export(args.export_from, Path(args.export_from).with_name("export_e2vid.h5"), "e2vid")
        print(json.dumps({"wall_s": time.perf_counter() - t0,
                          "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
        return
    with tempfile.TemporaryDirectory() as d:
        run_once(0.05, 16, 16, Path(d) / "warm.h5")  # numba compile / cache load
        out = Path(args.keep) if args.keep else Path(d) / "seq.h5"
        print(json.dumps(run_once(args.duration_s, args.height, args.width, out, args.compression, args.quantile)))


def _spawn(duration_s: float, height: int, width: int, compression: str, keep: Path | None = None,
           quantile: float | None = None) -> dict:
    cmd = [sys.executable, __file__, "--child", "--duration-s", str(duration_s), "--height", str(height),
           "--width", str(width), "--compression", compression] + (["--keep", str(keep)] if keep else [])
    cmd += ["--quantile", str(quantile)] if quantile is not None else []
    return _run(cmd)


def _spawn_export(path: Path) -> dict:
    return _run([sys.executable, __file__, "--child", "--export-from", str(path)])


def _run(cmd) -> dict:
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--duration-s", type=float, default=10.0, help="timed sequence length in seconds (346x260)")
    p.add_argument("--memory-duration-s", type=float, default=60.0, help="memory run length in seconds (640x480)")
    p.add_argument("--skip-memory", action="store_true", help="only the time split")
    p.add_argument("--compression", choices=("gzip", "lzf"), default="gzip", help="HDF5 compression (default gzip)")
    p.add_argument("--compare-dense", action="store_true",
                   help="also run the former worst-pixel sampling (quantile 1.0) and compare the events")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--quantile", type=float, help=argparse.SUPPRESS)
    p.add_argument("--height", type=int, default=260, help=argparse.SUPPRESS)
    p.add_argument("--width", type=int, default=346, help=argparse.SUPPRESS)
    p.add_argument("--keep", help=argparse.SUPPRESS)
    p.add_argument("--export-from", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        _child(args)
        return
    with tempfile.TemporaryDirectory() as tmp:
        r = _spawn(args.duration_s, 260, 346, args.compression, keep=Path(tmp) / "default.h5")
        _print_split(args, r)
        if args.compare_dense:
            dense = _spawn(args.duration_s, 260, 346, args.compression, keep=Path(tmp) / "dense.h5", quantile=1.0)
            a, b = (_pixel_counts(Path(tmp) / f, 260, 346) for f in ("default.h5", "dense.h5"))
            print(f"former worst-pixel sampling: work {dense['cpu_s']:.2f} s ({dense['n_dvs_samples']:,} samples, "
                  f"{dense['n_events']:,} events); default: work {r['cpu_s']:.2f} s, events x{a.sum() / b.sum():.4f}, "
                  f"per-pixel count correlation {np.corrcoef(a, b)[0, 1]:.4f}")
    if args.skip_memory:
        return
    print("peak memory, 640x480 (generation; export of that file to e2vid):")
    for d in (args.memory_duration_s / 4, args.memory_duration_s):
        with tempfile.TemporaryDirectory() as tmp:
            m = _spawn(d, 480, 640, args.compression, keep=Path(tmp) / "seq.h5")
            e = _spawn_export(Path(tmp) / "seq.h5")
        print(f"  {d:6.1f} s: peak RSS {m['peak_rss_mb']:7.0f} MB ({m['n_events']:,} events, {m['file_mb']:.0f} MB file, "
              f"{m['timings_s']['total']:.1f} s); export {e['peak_rss_mb']:.0f} MB ({e['wall_s']:.1f} s)")


def _pixel_counts(path: Path, height: int, width: int):
    from generators import load

    ev = load(path).events
    return np.bincount(ev["y"].astype(np.int64) * width + ev["x"], minlength=height * width).astype(float)


def _print_split(args, r: dict) -> None:
    t = r["timings_s"]
    print(f"time split ({args.compression}), {r['size']}, {r['duration_s']:g} s sequence ({r['n_events']:,} events, {r['n_frames']} frames, "
          f"{r['n_dvs_samples']:,} DVS samples, {r['file_mb']:.1f} MB file):")
    for k in ("scene", "dvs", "camera", "writing"):
        print(f"  {k:<8} {t[k]:8.2f} s  ({100 * t[k] / t['total']:4.1f} %)")
    print(f"  total    {t['total']:8.2f} s  -> {r['duration_s'] / t['total']:.2f}x real time, "
          f"{r['n_events'] / t['total']:,.0f} events/s; peak RSS {r['peak_rss_mb']:.0f} MB")
    print(f"  work     {r['cpu_s']:8.2f} s CPU ({r['duration_s'] / r['cpu_s']:.2f}x real time per CPU-second)")

if __name__ == "__main__":
    main()
