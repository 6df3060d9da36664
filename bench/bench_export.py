"""Benchmark of exporting a native file to every export format (not a test).

Simulates a 346x260 AHDR sequence of the built-in astronaut image under pan and shake (davis346 sensor, default
camera) lasting a quarter of --duration-s (default 10 s), and builds the full-length one by repeating it 4 times
in time (events, frames and reference shifted; simulating 10 s takes long on a shared machine, and the exporters
only see a longer stream). Then exports both files to every format in a fresh subprocess, so that each peak
resident memory is its own. Prints, per format and duration: events/s
(events over the export's CPU time, user + system, which is less noisy than wall time on a shared machine), wall
seconds, output size and peak RSS. Streaming exports keep the peak flat in duration; akf-mat (a .mat written in
one piece) does not.

    PYTHONPATH=. python bench/bench_export.py [--duration-s 10] [--formats evt3,evt2,dat,aedat4] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

SUFFIX = {"native": ".h5", "e2vid": ".h5", "ijrr": "", "akf-mat": ".mat", "exr": "", "e2vid-txt": ".zip",
          "aedat4": ".aedat4", "aedat2": ".aedat2", "evt3": ".raw", "evt2": ".raw", "dat": ".dat"}


def _generate(duration_s: float, out: Path) -> None:
    from generators.ahdr import AHDRConfig, generate_ahdr
    from generators.scenes import Trajectory, builtin_image_scene

    scene = builtin_image_scene(260, 346, int(duration_s * 1e6),
                                Trajectory(pan_px_per_s=(30.0, 8.0), shake_px=1.0, shake_hz=2.0))
    generate_ahdr(scene, out, AHDRConfig(), 0, progress=False)


def _repeat(src: Path, out: Path, times: int) -> None:
    """A native file holding `times` back-to-back copies of src (events, frames and reference shifted)."""
    import h5py

    from generators.formats import NativeWriter
    from generators.formats.native import iter_native_events, open_native_images

    with h5py.File(src) as f:
        t_last = int(f["events/t"][-1] + f["t_offset"][()])
    with open_native_images(src) as rec:
        span = max(int(rec.frame_t_end_us[-1]), int(rec.reference_t_us[-1]), t_last) + 1
        with NativeWriter(out, rec.height, rec.width, metadata=rec.metadata,
                          frame_bit_depth=rec.frame_bit_depth) as w:
            for k in range(times):
                for ev, lab in iter_native_events(src):
                    ev["t"] += k * span
                    w.add_events(ev, lab)
                for i in range(rec.frames.shape[0]):
                    w.add_frame(rec.frames[i], *(int(t[i]) + k * span for t in
                                                 (rec.frame_t_start_us, rec.frame_t_mid_us, rec.frame_t_end_us)))
                for i in range(rec.reference.shape[0]):
                    w.add_reference(rec.reference[i], int(rec.reference_t_us[i]) + k * span)
            if rec.threshold_maps is not None:
                w.set_threshold_maps(rec.threshold_maps)
            w.set_crf(rec.crf)


def _export_child(src: Path, fmt: str, out: Path) -> dict:
    import numpy as np

    from generators.formats import ExportDropWarning, export
    from generators.formats.prophesee_kernels import encode_evt3

    one = np.zeros(1, np.int64)  # numba kernel compiled (or loaded from cache) outside the timing
    encode_evt3(one, one.astype(np.uint16), one.astype(np.uint16), one.astype(np.int8), np.array([0, -1, -1]),
                np.empty(8, np.uint16))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportDropWarning)
        c0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
        export(src, out, fmt)
        c1, wall = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter() - t0
    size = sum(p.stat().st_size for p in out.rglob("*")) if out.is_dir() else out.stat().st_size
    return {"cpu_s": (c1.ru_utime + c1.ru_stime) - (c0.ru_utime + c0.ru_stime), "wall_s": wall,
            "out_mb": size / 2**20, "peak_rss_mb": c1.ru_maxrss / 1024}


def _n_events(path: Path) -> int:
    import h5py

    with h5py.File(path) as f:
        return int(f["events/t"].shape[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration-s", type=float, default=10.0)
    ap.add_argument("--formats", default="evt3,evt2,dat,aedat4,aedat2,e2vid-txt,e2vid,ijrr,native",
                    help="comma-separated export formats")
    ap.add_argument("--keep", type=Path, help="folder to keep the generated native files in (reused if present)")
    ap.add_argument("--child", nargs=3, metavar=("SRC", "FMT", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--generate", nargs=2, metavar=("DURATION_S", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_export_child(Path(args.child[0]), args.child[1], Path(args.child[2]))))
        return
    if args.generate:
        _generate(float(args.generate[0]), Path(args.generate[1]))
        return
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        durations = [args.duration_s / 4, args.duration_s]
        sources = {d: work / f"seq_{d:g}s.h5" for d in durations}
        if not sources[durations[0]].exists():
            print(f"simulating {durations[0]:g} s 346x260 ...", flush=True)
            subprocess.run([sys.executable, __file__, "--generate", str(durations[0]), str(sources[durations[0]])],
                           check=True)
        if not sources[durations[1]].exists():
            _repeat(sources[durations[0]], sources[durations[1]], 4)
        print(f"{'format':10s} {'duration':>8s} {'events':>10s} {'Mev/s cpu':>10s} {'wall s':>7s} "
              f"{'out MB':>8s} {'peak RSS MB':>11s}")
        for fmt in args.formats.split(","):
            for d in durations:
                n = _n_events(sources[d])
                out = Path(tmp) / f"out_{fmt}_{d:g}{SUFFIX[fmt]}"
                res = subprocess.run([sys.executable, __file__, "--child", str(sources[d]), fmt, str(out)],
                                     check=True, capture_output=True, text=True)
                r = json.loads(res.stdout.strip().splitlines()[-1])
                print(f"{fmt:10s} {d:7g}s {n:10d} {n / max(r['cpu_s'], 1e-9) / 1e6:10.2f} {r['wall_s']:7.1f} "
                      f"{r['out_mb']:8.1f} {r['peak_rss_mb']:11.0f}", flush=True)


if __name__ == "__main__":
    main()
