"""Benchmark of dataset generation on Dask workers (not a test): sequences per second serially and on local
clusters of 1 and 2 worker processes, and each worker's peak resident memory over the run (flat in the number of
sequences: resident memory after the first, the middle and the last of its tasks, and its peak).

    python bench/bench_workers.py [--sequences 50] [--duration-s 0.5] [--height 90] [--width 120] [--workers 1 2]

The dataset cycles through the built-in scenes (generators.builtin.BUILTIN_SEQUENCES), one child seed each. Every
cluster is started and warmed up (each worker imports evsim and loads the numba kernels from the cache) before the
clock starts, so the rates are those of a long run; the start-up is printed separately. Wall-clock rates on
whatever else the machine is doing; "cpu" is the summed process time of the tasks.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's evsim (workers inherit sys.path)


def dataset(n: int, duration_s: float, height: int, width: int):
    from generators.builtin import BUILTIN_SEQUENCES
    from generators.config import parse_config

    seqs = [{**BUILTIN_SEQUENCES[i % len(BUILTIN_SEQUENCES)], "name": f"seq_{i:03d}"} for i in range(n)]
    return parse_config({"seed": 0, "defaults": {"duration_s": duration_s, "height": height, "width": width},
                         "sequence": seqs}, source="bench_workers")


def _warm() -> None:
    import tempfile as tf

    from generators.dataset import generate_dataset

    with tf.TemporaryDirectory() as d:
        generate_dataset(dataset(1, 0.05, 16, 16), Path(d) / "w", progress=False)


def run(config, out: Path, scheduler: str | None) -> dict:
    from generators.dataset import dataset_jobs, make_sequence
    from generators.runner import run_tasks

    jobs, _ = dataset_jobs(config)
    out.mkdir(parents=True)
    tasks = [(t.name, (t, s, out, "bench"), {}) for t, s in jobs]
    t0 = time.perf_counter()
    outcomes = run_tasks(make_sequence, tasks, scheduler=scheduler, progress=False)
    wall = time.perf_counter() - t0
    failed = [o.name for o in outcomes if not o.ok]
    if failed:
        raise SystemExit(f"failed: {failed}: {outcomes[0].error}")
    per_pid: dict[int, list[tuple[float, float]]] = {}
    for o in outcomes:
        per_pid.setdefault(o.stats["pid"], []).append((o.stats["rss_mb"], o.stats["peak_rss_mb"]))
    memory = {pid: {"tasks": len(r), "rss_after_first_mb": round(r[0][0], 1),
                    "rss_after_half_mb": round(r[len(r) // 2][0], 1), "rss_after_last_mb": round(r[-1][0], 1),
                    "peak_after_first_mb": round(r[0][1], 1), "peak_after_last_mb": round(r[-1][1], 1)}
              for pid, r in per_pid.items()}
    return {"sequences": len(outcomes), "wall_s": round(wall, 2), "seq_per_s": round(len(outcomes) / wall, 3),
            "task_s_sum": round(sum(o.stats["seconds"] for o in outcomes), 2), "memory_per_process": memory}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequences", type=int, default=50)
    ap.add_argument("--duration-s", type=float, default=0.5)
    ap.add_argument("--height", type=int, default=90)
    ap.add_argument("--width", type=int, default=120)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--skip-serial", action="store_true")
    args = ap.parse_args()

    from distributed import Client

    from generators.runner import local_cluster

    config = dataset(args.sequences, args.duration_s, args.height, args.width)
    _warm()
    results = {}
    with tempfile.TemporaryDirectory() as d:
        if not args.skip_serial:
            results["serial"] = run(config, Path(d) / "serial", None)
            print(json.dumps({"serial": results["serial"]}), flush=True)
        for n in args.workers:
            t0 = time.perf_counter()
            with local_cluster(n) as cluster, Client(cluster) as client:
                client.run(_warm)
                startup = time.perf_counter() - t0
                r = run(config, Path(d) / f"w{n}", cluster.scheduler_address)
            r["startup_s"] = round(startup, 2)
            results[f"workers={n}"] = r
            print(json.dumps({f"workers={n}": r}), flush=True)
    base = results.get("workers=1")
    if base:
        for key, r in results.items():
            print(f"{key:>10}: {r['seq_per_s']:.3f} sequences/s ({r['seq_per_s'] / base['seq_per_s']:.2f}x workers=1)")


if __name__ == "__main__":
    main()
