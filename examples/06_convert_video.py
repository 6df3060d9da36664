"""A video becomes a hybrid event/frame dataset: `evsim convert` with and without motion-compensated upsampling.

The clip is ../shared/data/video/bikes.mp4 when present (the first 0.4 s, cropped and area-resized to 96 rows),
else a 30 fps AVI written here from the built-in astronaut scene under a pan. Each upsampling mode converts it
through the same pipeline as `evsim generate` (DVS emulator, LDR camera, HDR reference; davis346 sensor, sRGB
camera): "none" holds each input frame (every event at the frame times), "linear" cross-fades in log radiance
(moving edges fade out and in), "flow" interpolates along the optical flow (edges move). Left: an input frame;
then the events of a 10 ms window in the middle of an input interval for each mode; bottom: the event rate over
time (1 ms bins), where "none" shows one burst per input frame.

Run: python examples/06_convert_video.py [--out FOLDER]
"""

from pathlib import Path

import cv2
import numpy as np
from _shared import output_dir

from evsim_app.plots.common import pyplot, save_figure
from evsim_app.plots.events import event_frame, event_frame_rgb, event_rate
from generators.convert import convert
from generators.formats import load
from generators.scenes import Trajectory, builtin_image_scene

BIKES = Path(__file__).resolve().parents[2] / "shared" / "data" / "video" / "bikes.mp4"
HEIGHT, STOP_S = 96, 0.4
MODES = ("none", "linear", "flow")


def synthetic_clip(path: Path) -> Path:
    """A 30 fps 8-bit AVI of the astronaut scene panning at 90 px/s (sRGB-encoded, as a camera would write)."""
    scene = builtin_image_scene(HEIGHT, 128, 500_000, Trajectory(pan_px_per_s=(90.0, 15.0)))
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (128, HEIGHT))
    for k in range(15):
        y = np.clip(scene.radiance(round(k * 1e6 / 30)) / 2.0, 0, 1)  # the photo's range is about 0..1; sun clips
        srgb = np.where(y <= 0.0031308, 12.92 * y, 1.055 * y ** (1 / 2.4) - 0.055)
        writer.write(cv2.cvtColor((255 * srgb).astype(np.uint8), cv2.COLOR_GRAY2BGR))
    writer.release()
    return path


def main():
    out = output_dir(__doc__.splitlines()[0])
    clip = BIKES if BIKES.is_file() else synthetic_clip(out / "astronaut_30fps.avi")
    settings = {"sensor": "davis346", "crf": {"name": "srgb"}}
    recs = {}
    for mode in MODES:
        index = convert(clip, out / f"06_{mode}", settings=settings, height=HEIGHT, stop_s=STOP_S, upsample=mode,
                        overwrite=True, progress=False)
        recs[mode] = load(index.parent / f"{clip.stem}.h5")
        print(f"{mode:6s}: {recs[mode].events.size} events, {len(recs[mode].frames)} LDR frames, "
              f"{len(recs[mode].reference)} HDR reference frames -> {index.parent}")
    meta = recs["flow"].metadata["scene"]
    rate = meta["frame_rate_hz"]
    t_mid = round(4.5e6 / rate)  # the middle of the 5th input interval
    rec = recs["flow"]
    plt = pyplot()
    fig = plt.figure(figsize=(12, 5.4))
    grid = fig.add_gridspec(2, len(MODES) + 1, height_ratios=[1, 0.7])
    ax = fig.add_subplot(grid[0, 0])
    ax.imshow(rec.frames[len(rec.frames) // 2], cmap="gray", interpolation="nearest")
    ax.set_title(f"{clip.name}: LDR frame\n(synthetic camera)", fontsize=8)
    ax.axis("off")
    for k, mode in enumerate(MODES):
        ev = recs[mode].events
        ax = fig.add_subplot(grid[0, k + 1])
        ax.imshow(event_frame_rgb(event_frame(ev, rec.height, rec.width, t_mid - 5000, t_mid + 5000)),
                  interpolation="nearest")
        ax.set_title(f"{mode}: events {t_mid / 1e3:.0f} +- 5 ms\n({ev.size} in the clip)", fontsize=8)
        ax.axis("off")
    ax = fig.add_subplot(grid[1, :])
    for mode in MODES:
        t, on, off = event_rate(recs[mode].events, 1000, 0, recs[mode].events["t"][-1] + 1)
        ax.plot(t / 1e3, on + off, lw=0.8, label=mode)
    for k in range(int(STOP_S * rate) + 1):
        ax.axvline(k * 1e3 / rate, color="0.85", lw=0.5, zorder=0)
    ax.set_xlabel("time (ms); grey lines: input frames")
    ax.set_ylabel("events per second")
    ax.set_yscale("log")
    ax.legend(fontsize=8)
    print(f"input: {meta['input']['kind']} {meta['input']['sha256'][:16]}..., {rate:.2f} fps, "
          f"linearisation: {meta['linearisation']['method']}")
    print(f"wrote {save_figure(fig, out / '06_convert_video.png')}")


if __name__ == "__main__":
    main()
