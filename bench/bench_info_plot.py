"""Benchmark of `evsim info` and `evsim plot events` on big native files (not a test).

Writes two synthetic native files of a 1280x720 sensor over 14 s (a phone clip's size, as in issue 26): a long
one with --events events and --frames LDR frames and HDR reference frames, and one a quarter as long (events and
frames), then runs `evsim info` and `evsim plot events` on each in a fresh subprocess. Prints, per command and
file: the file size, CPU seconds of the command (user + system, less noisy than wall time on a shared machine),
wall seconds and its peak resident memory. `info` reads the recorded event summary (no events) and `plot events`
reads windows and the t and p columns in chunks: both peaks stay flat in the file's length.

    PYTHONPATH=. python bench/bench_info_plot.py [--events 1.2e8] [--frames 420] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

H, W, DURATION_US = 720, 1280, 14_000_000
_CHILD = """
import json, resource, sys, time
from evsim_app.cli import main
t0, c0 = time.perf_counter(), time.process_time()
code = main(sys.argv[1:])
r = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"code": code, "wall_s": time.perf_counter() - t0, "cpu_s": r.ru_utime + r.ru_stime,
                  "peak_mb": r.ru_maxrss / 1024}))
"""


def write_big(path: Path, n_events: int, n_frames: int, seed: int = 0) -> None:
    """Random events (uniform over the sensor, sorted in time) and noisy frames and reference frames."""
    import numpy as np

    from generators.formats import NativeWriter
    from sim import EVENT_DTYPE

    rng = np.random.default_rng(seed)
    chunk = 1 << 21
    edges = np.linspace(0, DURATION_US, -(-n_events // chunk) + 1).astype(np.int64)
    with NativeWriter(path, H, W, metadata={"generator": "bench_info_plot"}) as w:
        done = 0
        for k in range(len(edges) - 1):
            n = min(chunk, n_events - done)
            ev = np.empty(n, EVENT_DTYPE)
            ev["t"] = np.sort(rng.integers(edges[k], edges[k + 1], n))
            ev["x"], ev["y"] = rng.integers(0, W, n), rng.integers(0, H, n)
            ev["p"] = rng.choice(np.array([-1, 1], np.int8), n)
            w.add_events(ev)
            done += n
        base = rng.random((H, W), dtype=np.float32) * 100
        for i in range(n_frames):
            t = int(i * DURATION_US / n_frames)
            w.add_frame(rng.integers(0, 256, (H, W)).astype(np.uint8), t, t, t)
            w.add_reference(base * (1 + 0.01 * i) + rng.random((H, W), dtype=np.float32), t)


def run(*argv: str) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, *argv], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--events", type=float, default=1.2e8, help="events of the long file (default 1.2e8)")
    p.add_argument("--frames", type=int, default=420, help="frames and reference frames of the long file")
    p.add_argument("--keep", type=Path, help="write the files here and keep them (default: a temporary folder)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        files = {"long": folder / "long.h5", "quarter": folder / "quarter.h5"}
        for path, k in zip(files.values(), (1, 4)):
            if not path.exists():
                t0 = time.perf_counter()
                write_big(path, int(args.events) // k, args.frames // k)
                print(f"wrote {path} ({path.stat().st_size / 1e9:.2f} GB) in {time.perf_counter() - t0:.0f} s")
        print(f"{'command':12s} {'file':8s} {'GB':>6s} {'cpu s':>7s} {'wall s':>7s} {'peak MB':>8s}")
        for command in (["info"], ["plot", "events"]):
            for name, path in files.items():
                extra = ["--out", str(folder / f"{name}.png")] if command[0] == "plot" else []
                r = run(*command, str(path), *extra)
                print(f"{' '.join(command):12s} {name:8s} {path.stat().st_size / 1e9:6.2f} {r['cpu_s']:7.2f} "
                      f"{r['wall_s']:7.2f} {r['peak_mb']:8.0f}")


if __name__ == "__main__":
    main()
