"""Benchmark of end-to-end AHDR generation (not a test).

1. Work per stage for a 346x260 sequence (default 1 s, 30 fps) of one scene: a built-in sequence by name
   (default astronaut_pan: the astronaut photo under pan and shake; camera_zoom_rotate, ...) or --image PATH with
   --pan VX VY (as `evsim generate ahdr --image`), with the davis346 sensor and the default camera and AHDRConfig.
   "Work" is the CPU time (time.process_time, all threads) of the generate_ahdr call alone: in a process whose
   imports are done and whose numba kernels are compiled or loaded from the cache by a short warm-up run first,
   so it excludes interpreter start, imports and compilation. Per stage: scene (rendering and sampling-step
   control), dvs (the emulator), camera (exposure, noise, CRF; without its rendering), writing (HDF5 compression
   and I/O), other (setup: sensor resolution, metadata). The machine's 2 cores are shared, so CPU time is the
   figure to compare; wall time is printed as well.
   With --compare-dense, the same sequence again with the dense rendering the defaults are checked against (every
   sample's step bound on the worst pixel, sampling_quantile 1.0, and image scenes rendered on the supersampled
   grid, prefilter=False): its work and samples, and the agreement of the default's events with it (count ratio,
   per-pixel count correlation).
2. Peak resident memory of generating 346x260 sequences of --memory-duration-s (default 8 s) and a quarter of it,
   to show that memory is flat in duration; each run is a fresh subprocess so that the peaks are independent.
   With --export, also the peak of exporting each file to the E2VID layout.

    python bench/bench_generate.py [--scene astronaut_pan | --image ../shared/data/hdr/Desk.exr --pan 60 0]
                                   [--duration-s 1] [--compare-dense] [--compression gzip|lzf|none]
                                   [--memory-duration-s 8] [--skip-memory] [--export] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

STAGES = ("scene", "dvs", "camera", "writing")


def scene_table(args) -> dict:
    """The scene table (generators.config schema) of the benchmarked sequence."""
    if args.image:
        return {"type": "image", "path": str(Path(args.image).resolve()),
                "trajectory": {"pan_px_per_s": list(args.pan)}}
    from generators.builtin_sequences import BUILTIN_SEQUENCES

    by_name = {s["name"]: s for s in BUILTIN_SEQUENCES}
    if args.scene not in by_name:
        sys.exit(f"unknown --scene {args.scene!r}; one of {', '.join(by_name)}")
    return dict(by_name[args.scene]["scene"])


def run_once(scene: dict, duration_s: float, height: int, width: int, out: Path, compression: str | None = "gzip",
             dense: bool = False) -> dict:
    from generators.ahdr import AHDRConfig, generate_ahdr
    from generators.config import build_scene

    if dense and scene["type"] in ("image", "builtin_image"):
        scene = {**scene, "prefilter": False}
    src = build_scene(scene, height, width, int(round(duration_s * 1e6)))
    config = AHDRConfig(compression=compression, sampling_quantile=1.0 if dense else AHDRConfig.sampling_quantile)
    t0, c0 = time.perf_counter(), time.process_time()
    r = generate_ahdr(src, out, config, 0, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"duration_s": duration_s, "size": f"{width}x{height}", "wall_s": wall, "cpu_s": cpu,
            "stages_cpu_s": r.cpu_s, "stages_wall_s": r.timings_s,
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
    scene, compression = json.loads(args.scene_json), None if args.compression == "none" else args.compression
    with tempfile.TemporaryDirectory() as d:
        run_once(scene, 0.05, 16, 16, Path(d) / "warm.h5", compression)  # numba compile / cache load
        out = Path(args.keep) if args.keep else Path(d) / "seq.h5"
        print(json.dumps(run_once(scene, args.duration_s, args.height, args.width, out, compression, args.dense)))


def _spawn(args, duration_s: float, keep: Path | None = None, dense: bool = False) -> dict:
    cmd = [sys.executable, __file__, "--child", "--scene-json", json.dumps(scene_table(args)),
           "--duration-s", str(duration_s), "--compression", args.compression]
    cmd += (["--keep", str(keep)] if keep else []) + (["--dense"] if dense else [])
    return _run(cmd)


def _spawn_export(path: Path) -> dict:
    return _run([sys.executable, __file__, "--child", "--export-from", str(path)])


def _run(cmd) -> dict:
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", default="astronaut_pan", help="built-in sequence name (default astronaut_pan)")
    p.add_argument("--image", help="an image file to pan over instead of a built-in sequence")
    p.add_argument("--pan", type=float, nargs=2, default=(60.0, 0.0), metavar=("VX", "VY"),
                   help="with --image: pan in pixels per second (default 60 0)")
    p.add_argument("--duration-s", type=float, default=1.0, help="timed sequence length in seconds (346x260)")
    p.add_argument("--memory-duration-s", type=float, default=8.0,
                   help="longer memory run in seconds (346x260; the shorter one is a quarter of it)")
    p.add_argument("--skip-memory", action="store_true", help="only the work per stage")
    p.add_argument("--export", action="store_true", help="memory runs: also export each file to the E2VID layout")
    p.add_argument("--compression", choices=("gzip", "lzf", "none"), default="gzip",
                   help="HDF5 compression (default gzip, the generator's default)")
    p.add_argument("--compare-dense", action="store_true",
                   help="also run the dense rendering and compare the events")
    p.add_argument("--json", type=Path, help="also write the results to this JSON file")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--scene-json", help=argparse.SUPPRESS)
    p.add_argument("--dense", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--height", type=int, default=260, help=argparse.SUPPRESS)
    p.add_argument("--width", type=int, default=346, help=argparse.SUPPRESS)
    p.add_argument("--keep", help=argparse.SUPPRESS)
    p.add_argument("--export-from", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        _child(args)
        return
    name = args.image or args.scene
    results = {"bench": "bench_generate", "scene": name, "compression": args.compression, "memory": []}
    with tempfile.TemporaryDirectory() as tmp:
        r = _spawn(args, args.duration_s, keep=Path(tmp) / "default.h5")
        _print_split(name, args.compression, r)
        results["work"] = r
        if args.compare_dense:
            dense = _spawn(args, args.duration_s, keep=Path(tmp) / "dense.h5", dense=True)
            a, b = (_pixel_counts(Path(tmp) / f, 260, 346) for f in ("default.h5", "dense.h5"))
            print(f"dense rendering (quantile 1.0, supersampled grid): work {dense['cpu_s']:.2f} CPU-s "
                  f"({dense['n_dvs_samples']:,} samples, {dense['n_events']:,} events); default: work "
                  f"{r['cpu_s']:.2f} CPU-s ({r['n_dvs_samples']:,} samples), events x{a.sum() / b.sum():.4f}, "
                  f"per-pixel count correlation {np.corrcoef(a, b)[0, 1]:.4f}")
    if args.skip_memory:
        _write_json(args.json, results)
        return
    print(f"peak memory, 346x260 {name} (generation{'; export of that file to e2vid' if args.export else ''}):")
    for d in (args.memory_duration_s / 4, args.memory_duration_s):
        with tempfile.TemporaryDirectory() as tmp:
            m = _spawn(args, d, keep=Path(tmp) / "seq.h5")
            e = _spawn_export(Path(tmp) / "seq.h5") if args.export else None
        print(f"  {d:6.1f} s: peak RSS {m['peak_rss_mb']:7.0f} MB ({m['n_events']:,} events, {m['file_mb']:.0f} MB "
              f"file, {m['cpu_s']:.1f} CPU-s)"
              + (f"; export {e['peak_rss_mb']:.0f} MB ({e['wall_s']:.1f} s)" if e else ""))
        results["memory"].append({**m, "export": e})
    _write_json(args.json, results)


def _write_json(path: Path | None, results: dict) -> None:
    if path:
        path.write_text(json.dumps(results, indent=1))


def _pixel_counts(path: Path, height: int, width: int):
    from generators import load

    ev = load(path).events
    return np.bincount(ev["y"].astype(np.int64) * width + ev["x"], minlength=height * width).astype(float)


def _print_split(name: str, compression: str, r: dict) -> None:
    c, w = r["stages_cpu_s"], r["stages_wall_s"]
    print(f"{name}, {r['size']}, {r['duration_s']:g} s sequence, compression {compression}: {r['n_events']:,} events, "
          f"{r['n_frames']} frames, {r['n_dvs_samples']:,} DVS samples, {r['file_mb']:.1f} MB file")
    other_c, other_w = c["total"] - sum(c[k] for k in STAGES), w["total"] - sum(w[k] for k in STAGES)
    for k, vc, vw in [(k, c[k], w[k]) for k in STAGES] + [("other", other_c, other_w)]:
        print(f"  {k:<8} {vc:6.3f} CPU-s ({100 * vc / c['total']:4.1f} %)   wall {vw:6.3f} s")
    print(f"  work     {r['cpu_s']:6.3f} CPU-s (time.process_time of the generate_ahdr call, all threads; "
          "warm process: "
          f"no interpreter start, imports or numba compilation) for {r['duration_s']:g} s of sequence -> "
          f"{r['duration_s'] / r['cpu_s']:.2f}x real time per CPU-second ({r['n_frames'] / r['cpu_s']:.1f} frames "
          f"per CPU-second); wall {r['wall_s']:.2f} s; peak RSS {r['peak_rss_mb']:.0f} MB")


if __name__ == "__main__":
    main()
