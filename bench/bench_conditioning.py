"""Cost of the input conditioning (generators.scenes.conditioning) as a ratio to the video scene's own frame work.

A random 8-bit clip (60 frames at 1280x720, MPEG-4 Part 2 in MP4, a key frame every 30 frames) is decoded,
linearised and area-resized to each sensor size by VideoScene with upsample "none", once with conditioning off
and once on; the ratio of the two wall-clock times (best of --repeats, same process) is the conditioning's cost
relative to decoding, linearising and resizing. The DVS, the camera and flow interpolation, which a conversion
adds, are left out, so the ratio is an upper bound of its share of a conversion.
Usage: python bench/bench_conditioning.py [--frames 60] [--repeats 2]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from generators.scenes import VideoScene


def _clip(path: Path, n: int) -> Path:
    rng = np.random.default_rng(0)
    w = cv2.VideoWriter(str(path), cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*"mp4v"), 30, (1280, 720),
                        [cv2.VIDEOWRITER_PROP_GOP_SIZE, 30, cv2.VIDEOWRITER_PROP_IS_COLOR, 0])
    for _ in range(n):
        w.write(np.clip(rng.normal(100, 30, (720, 1280)), 0, 255).astype(np.uint8))
    w.release()
    return path


def _seconds(path: Path, conditioning: str, size: tuple[int, int]) -> float:
    scene = VideoScene(path, upsample="none", conditioning=conditioning, height=size[0], width=size[1])
    t0 = time.perf_counter()
    for t in scene.times:
        scene.radiance(int(t))
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        clip = _clip(Path(tmp) / "clip.mp4", args.frames)
        _seconds(clip, "temporal", (72, 128))  # compile the kernels
        for size in ((720, 1280), (260, 346)):
            off = min(_seconds(clip, "off", size) for _ in range(args.repeats))
            on = min(_seconds(clip, "temporal", size) for _ in range(args.repeats))
            print(f"{size[1]}x{size[0]}: decode + linearise + resize {off / args.frames * 1e3:.1f} ms/frame, "
                  f"conditioned {on / args.frames * 1e3:.1f} ms/frame: ratio {on / off:.2f}")


if __name__ == "__main__":
    main()
