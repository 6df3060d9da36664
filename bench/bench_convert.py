"""Benchmark of video conversion (not a test): input frames per second and events per second at 346x260.

The clip (--clip): ../shared/data/video/bikes.mp4 (real footage, 640x272 at 25 fps, cropped and area-resized to
346x260; fast motion: 20-45 px per frame at that size) when present, or "synthetic": the built-in astronaut scene
under a 30 px/s pan and 1 px shake rendered at 30 fps into a float .npy stack. For each
upsampling mode (none, linear, flow):
- events only: the VideoScene sampled by the adaptive sampler into the DVS emulator (davis346), which is what
  "converting to events" costs; reported as input frames/s, events/s and the real-time factor (clip seconds per
  second of processing, > 1 is faster than real time), in wall-clock and process CPU time;
- the whole pipeline (generate_ahdr: events, the LDR camera's frames and the HDR reference, HDF5 writing), with
  its time split.

- --hd: the conversion at 1280x720 (`evsim convert` at defaults, events only: generate_ahdr into an HDF5 file) of
  bikes.mp4 area-resized to 1280x720 (else the synthetic clip rendered at that size), against its DVS pass alone
  (the emulator's feed calls of an untimed first pass, warm-up included, copied and replayed on an emulator of its
  own): the ratio of their wall times (the figure issue 37 asks at most 1.5 of) and the conversion's CPU time /
  wall time. Then the scene's frame pairs alone (decoding, conditioning, both flows, masks, 4x copies; no key
  frames) and the floor they set: (DVS pass CPU + frame pairs CPU) / cores / DVS pass wall, the ratio a conversion
  whose key frames cost nothing would reach with every core busy.

    python bench/bench_convert.py [--duration-s 10] [--clip bikes|synthetic] [--modes none linear flow]
                                  [--flow-preset medium] [--flow-scale 0.5] [--max-keys 32] [--full]
                                  [--hd [--hd-duration-s 0.5]]

Also prints the process's peak resident memory. Numba kernels are compiled (or loaded from cache) by a short
warm-up first. Wall-clock figures depend on whatever else the machine runs; CPU time (time.process_time, all
threads) is the steadier figure.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import sim  # noqa: E402
from generators.ahdr import AHDRConfig, generate_ahdr, resolve_sensors  # noqa: E402
from generators.sampling import AdaptiveSampler  # noqa: E402
from generators.scenes import Trajectory, VideoScene, builtin_image_scene  # noqa: E402
from generators.scenes.flow_interpolation import FLOW_SCALE, MAX_KEYS  # noqa: E402
from sim.seeding import as_seed_sequence, child_seed  # noqa: E402

BIKES = Path(__file__).resolve().parents[2] / "shared" / "data" / "video" / "bikes.mp4"
HEIGHT, WIDTH = 260, 346
_CHUNK = 16


def make_clip(folder: Path, duration_s: float, which: str) -> tuple[Path, dict]:
    if which == "bikes" and BIKES.is_file():
        return BIKES, {"stop_s": duration_s}
    fps = 30.0
    scene = builtin_image_scene(HEIGHT, WIDTH, int(duration_s * 1e6) + 1,
                                Trajectory(pan_px_per_s=(30.0, 8.0), shake_px=1.0, shake_hz=2.0))
    times = np.arange(0, duration_s * 1e6 + 1, 1e6 / fps).astype(np.int64)
    path = folder / "astronaut_30fps.npy"
    np.save(path, np.stack([scene.radiance(int(t)) for t in times]))
    return path, {"fps": fps}


class _FeedRecorder:
    """While active, keeps a copy of every call of DVSEmulator.feed and feed_log (the DVS pass's samples, as
    generate_ahdr feeds them: the warm-up, then chunks of key frames) to replay them on an emulator alone."""

    def __init__(self):
        self.calls = []

    def __enter__(self):
        self._saved = sim.DVSEmulator.feed, sim.DVSEmulator.feed_log
        plain, log = self._saved

        def feed(emu, x, t, **kw):
            self.calls.append(("feed", np.array(x), np.array(t), kw))
            return plain(emu, x, t, **kw)

        def feed_log(emu, x, t, **kw):
            self.calls.append(("feed_log", np.array(x), np.array(t), kw))
            return log(emu, x, t, **kw)

        sim.DVSEmulator.feed, sim.DVSEmulator.feed_log = feed, feed_log
        return self

    def __exit__(self, *exc):
        sim.DVSEmulator.feed, sim.DVSEmulator.feed_log = self._saved


def hd_case(folder: Path, duration_s: float, which: str) -> dict:
    """The 1280x720 conversion against its DVS pass alone on the same samples (module docstring, --hd)."""
    h, w = 720, 1280
    if which == "bikes" and BIKES.is_file():
        path, options = BIKES, {"stop_s": duration_s}
    else:
        fps = 30.0
        scene = builtin_image_scene(h, w, int(duration_s * 1e6) + 1,
                                    Trajectory(pan_px_per_s=(120.0, 30.0), shake_px=1.0, shake_hz=2.0))
        times = np.arange(0, duration_s * 1e6 + 1, 1e6 / fps).astype(np.int64)
        path, options = folder / "astronaut_hd.npy", {"fps": fps}
        np.save(path, np.stack([scene.radiance(int(t)) for t in times]))
    config = AHDRConfig(outputs=("events",), crf="srgb")  # what `evsim convert` runs at defaults
    scene = VideoScene(path, height=h, width=w, **options)
    with _FeedRecorder() as rec:  # untimed: records the DVS pass's calls
        generate_ahdr(scene, folder / "record.h5", config, 0, progress=False)
    dvs_params = resolve_sensors(scene, config)[0]
    del scene
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    r = generate_ahdr(VideoScene(path, height=h, width=w, **options), folder / "hd.h5", config, 0, progress=False)
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    dvs = sim.DVSEmulator(h, w, dvs_params, child_seed(as_seed_sequence(0), 0))
    d_wall, d_cpu, n_events, n_samples = 0.0, 0.0, 0, 0
    for method, x, t, kw in rec.calls:
        w0, c0 = time.perf_counter(), time.process_time()
        n_events += getattr(dvs, method)(x, t, **kw).size
        d_wall += time.perf_counter() - w0
        d_cpu += time.process_time() - c0
        n_samples += len(t)
    pairs_cpu = frame_pairs_cpu(VideoScene(path, height=h, width=w, **options))
    cores = len(os.sched_getaffinity(0))
    return {"clip": path.name, "clip_s": duration_s, "samples": n_samples, "events": r.n_events,
            "replay_events": n_events, "wall_s": wall, "cpu_s": cpu, "dvs_wall_s": d_wall, "dvs_cpu_s": d_cpu,
            "ratio": wall / d_wall, "cores": cpu / wall, "split_s": {k: round(v, 2) for k, v in r.timings_s.items()},
            "pairs_cpu_s": pairs_cpu, "n_cores": cores, "floor": (d_cpu + pairs_cpu) / cores / d_wall}


def frame_pairs_cpu(scene: VideoScene) -> float:
    """CPU seconds (all threads) the scene takes to make all its frame pairs, one after the other."""
    scene.radiance(0)  # opens the clip
    c0 = time.process_time()
    for k in range(scene.times.size - 1):
        scene._make_pair(k)
    return time.process_time() - c0


def events_only(path: Path, options: dict, mode: str, preset: str, scale: float = FLOW_SCALE,
                max_keys: int = MAX_KEYS) -> dict:
    """Sample the VideoScene into the DVS emulator; return counts and timings."""
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    scene = VideoScene(path, height=HEIGHT, width=WIDTH, upsample=mode, flow_preset=preset, flow_scale=scale,
                       max_keys=max_keys, **options)
    params = sim.DVSParams.preset("davis346", full_illumination=float(np.percentile(scene.radiance(0), 99)))
    dvs = sim.DVSEmulator(HEIGHT, WIDTH, params, 0)
    sampler = AdaptiveSampler(scene, threshold=min(params.pos_threshold, params.neg_threshold), fraction=0.5,
                              min_step_us=10, max_step_us=5000,
                              log_eps=params.dark_fraction * params.full_illumination)
    n_events, stack, times = 0, [], []
    for t, img in sampler:
        stack.append(img)
        times.append(t)
        if len(stack) == _CHUNK:
            n_events += dvs.feed(np.stack(stack), np.asarray(times, dtype=np.int64)).size
            stack, times = [], []
    if stack:
        n_events += dvs.feed(np.stack(stack), np.asarray(times, dtype=np.int64)).size
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    clip_s = scene.duration_us / 1e6
    n_in = scene.times.size
    return {"mode": mode, "clip_s": clip_s, "input_frames": n_in, "events": n_events,
            "dvs_samples": sampler.n_samples, "wall_s": wall, "cpu_s": cpu,
            "frames_per_s": n_in / wall, "events_per_s": n_events / wall, "realtime_x": clip_s / wall,
            "realtime_x_cpu": clip_s / cpu}


def full_pipeline(path: Path, options: dict, mode: str, preset: str, scale: float, max_keys: int,
                  out: Path) -> dict:
    scene = VideoScene(path, height=HEIGHT, width=WIDTH, upsample=mode, flow_preset=preset, flow_scale=scale,
                       max_keys=max_keys, **options)
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    r = generate_ahdr(scene, out, AHDRConfig(), 0, progress=False)
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    return {"mode": mode, "events": r.n_events, "frames": r.n_frames, "wall_s": wall, "cpu_s": cpu,
            "realtime_x": scene.duration_us / 1e6 / wall, "split_s": {k: round(v, 2) for k, v in r.timings_s.items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration-s", type=float, default=10.0, help="clip length in seconds (default 10)")
    ap.add_argument("--modes", nargs="+", default=["none", "linear", "flow"], choices=["none", "linear", "flow"])
    ap.add_argument("--flow-preset", default="medium", choices=["ultrafast", "fast", "medium"])
    ap.add_argument("--flow-scale", type=float, default=FLOW_SCALE,
                    help=f"size factor of the frames the flow is computed on (default {FLOW_SCALE})")
    ap.add_argument("--max-keys", type=int, default=MAX_KEYS,
                    help=f"most key frames per frame pair (default {MAX_KEYS})")
    ap.add_argument("--clip", choices=["bikes", "synthetic"], default="bikes",
                    help="bikes.mp4 (when present; else synthetic) or the synthetic astronaut clip")
    ap.add_argument("--full", action="store_true", help="also run the whole pipeline (frames, reference, HDF5)")
    ap.add_argument("--hd", action="store_true", help="also the 1280x720 conversion against its DVS pass alone")
    ap.add_argument("--hd-duration-s", type=float, default=0.5, help="clip length of the --hd case (default 0.5 s)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        path, options = make_clip(d, args.duration_s, args.clip)
        warm = d / "warm.npy"
        np.save(warm, np.random.default_rng(0).random((3, 16, 16)).astype(np.float32))
        events_only(warm, {"fps": 30.0}, "flow", args.flow_preset)  # numba compile / cache load
        print(f"clip: {path.name} ({options}), sensor {WIDTH}x{HEIGHT}, DIS preset {args.flow_preset}, "
              f"flow scale {args.flow_scale}, max keys {args.max_keys}; load average {os.getloadavg()[0]:.1f}")
        print(f"{'mode':8s} {'in frames':>9s} {'events':>10s} {'samples':>8s} {'wall s':>7s} {'cpu s':>7s} "
              f"{'frames/s':>9s} {'events/s':>10s} {'x real time (wall / cpu)':>25s}")
        for mode in args.modes:
            r = events_only(path, options, mode, args.flow_preset, args.flow_scale, args.max_keys)
            print(f"{mode:8s} {r['input_frames']:9d} {r['events']:10d} {r['dvs_samples']:8d} {r['wall_s']:7.2f} "
                  f"{r['cpu_s']:7.2f} {r['frames_per_s']:9.1f} {r['events_per_s']:10.3g} "
                  f"{r['realtime_x']:12.2f} / {r['realtime_x_cpu']:.2f}")
        print(f"peak resident memory: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB; "
              f"load average {os.getloadavg()[0]:.1f}")
        if args.hd:
            r = hd_case(d, args.hd_duration_s, args.clip)
            print(f"1280x720 conversion of {r['clip']} ({r['clip_s']:g} s, events only, defaults): {r['samples']} DVS "
                  f"samples, {r['events']} events, wall {r['wall_s']:.2f} s ({r['wall_s'] / r['clip_s']:.1f}x its "
                  f"duration), CPU {r['cpu_s']:.2f} s (CPU / wall {r['cores']:.2f}), split {r['split_s']}; its DVS "
                  f"pass alone on the same samples: wall {r['dvs_wall_s']:.2f} s, CPU {r['dvs_cpu_s']:.2f} s "
                  f"({r['replay_events']} events); conversion / DVS pass: {r['ratio']:.2f}x wall; load average "
                  f"{os.getloadavg()[0]:.1f}")
            print(f"  its frame pairs alone: CPU {r['pairs_cpu_s']:.2f} s; floor with free key frames and "
                  f"{r['n_cores']} cores busy: {r['floor']:.2f}x its DVS pass")
        if args.full:
            print("whole pipeline (events + LDR frames + HDR reference + HDF5):")
            for mode in args.modes:
                r = full_pipeline(path, options, mode, args.flow_preset, args.flow_scale, args.max_keys,
                                  d / f"{mode}.h5")
                print(f"  {mode:8s} events {r['events']}, frames {r['frames']}, wall {r['wall_s']:.2f} s, "
                      f"cpu {r['cpu_s']:.2f} s, x{r['realtime_x']:.2f} real time, split {r['split_s']}")


if __name__ == "__main__":
    main()
