"""
Converting a video into events and frames
==========================================

`evsim convert` (`generators.convert.convert`) turns an ordinary video into a hybrid event/frame dataset: the clip
is linearised (inverse sRGB for 8-bit video), upsampled in time, and run through the same pipeline as
`evsim generate` (DVS emulator, LDR camera, HDR reference). A 30 fps video is far too coarse in time for an event
sensor, so how the frames are upsampled matters:

- "none" holds each input frame: every event fires at the frame times, in bursts;
- "linear" cross-fades in log radiance: moving edges fade out at one place and in at the next;
- "flow" interpolates along the optical flow: edges move, and events follow them.

The clip here is made from the built-in astronaut photo under a pan (15 frames at 30 fps, written as an 8-bit
AVI, as a camera would); ``python examples/06_convert_video.py --video CLIP --out FOLDER`` converts your own.
"""

# %%
# The clip and the three conversions
# ----------------------------------
# The DVS is the davis346 preset, the LDR camera uses the sRGB curve; the first 0.4 s of the clip are used, area
# resized to 96 rows.

import cv2
import numpy as np
from _shared import example_args

from evsim_app.plots.common import pyplot, save_figure
from evsim_app.plots.events import event_frame, event_frame_rgb, event_rate
from generators.convert import convert
from generators.formats import load
from generators.scenes import Trajectory, builtin_image_scene

args = example_args("Converting a video into events and frames", video=True)
out = args.out
HEIGHT, STOP_S = 96, 0.4
MODES = ("none", "linear", "flow")


def synthetic_clip(path):
    """A 30 fps 8-bit AVI of the astronaut scene panning at 90 px/s (sRGB-encoded, as a camera would write)."""
    scene = builtin_image_scene(HEIGHT, 128, 500_000, Trajectory(pan_px_per_s=(90.0, 15.0)))
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (128, HEIGHT))
    for k in range(15):
        y = np.clip(scene.radiance(round(k * 1e6 / 30)) / 2.0, 0, 1)  # the photo's range is about 0..1; sun clips
        srgb = np.where(y <= 0.0031308, 12.92 * y, 1.055 * y ** (1 / 2.4) - 0.055)
        writer.write(cv2.cvtColor((255 * srgb).astype(np.uint8), cv2.COLOR_GRAY2BGR))
    writer.release()
    return path


clip = args.video or synthetic_clip(out / "astronaut_30fps.avi")
# convert writes the events only unless asked: the LDR frames and the HDR reference are drawn below
settings = {"sensor": "davis346", "crf": {"name": "srgb"}, "output": {"outputs": ["events", "frames", "reference"]}}
recs = {}
for mode in MODES:
    index = convert(clip, out / f"06_{mode}", settings=settings, height=HEIGHT, stop_s=STOP_S, upsample=mode,
                    overwrite=True, progress=False)
    recs[mode] = load(index.parent / f"{clip.stem}.h5")
    print(f"{mode:6s}: {recs[mode].events.size} events, {len(recs[mode].frames)} LDR frames, "
          f"{len(recs[mode].reference)} HDR reference frames")
meta = recs["flow"].metadata["scene"]
print(f"input: {meta['input']['kind']}, {meta['frame_rate_hz']:.2f} fps, "
      f"linearisation: {meta['linearisation']['method']}")

# %%
# Events between two input frames
# -------------------------------
# Left: an LDR frame of the synthetic camera. Then the events of a 10 ms window in the middle of an input
# interval for each mode (ON red, OFF blue), and below, the event rate in 1 ms bins, with the input frames as grey
# lines.

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
print(f"wrote {save_figure(fig, out / '06_convert_video.png')}")

# %%
# Holding frames ("none") leaves the middle of each interval empty and fires everything at the frame times;
# "linear" fires all through the interval but at both the old and the new position of each edge; "flow" fires
# along the moving edges. Each converted sequence records its input (path and sha256), frame rate, linearisation
# and upsampling in its metadata (``generators.load(path).metadata["scene"]``).
