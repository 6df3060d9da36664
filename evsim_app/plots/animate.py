"""Animated output: events against the AKF reconstruction over time (`evsim plot events DATASET --animate out.gif`).

Each animation frame at time t shows the event frame over [t - dt, t) (dt the spacing of the animation frames) next
to the AKF reconstruction at t and, when the file has one, the HDR reference nearest t; images are tone-mapped with
common.ToneMap (the global log map, its range from the middle reference frame, else from the middle reconstruction,
its floor at least 1e-3 of the frames' top). GIF is written with
matplotlib's PillowWriter (pillow ships with matplotlib); MP4 needs ffmpeg on the PATH (PlotDependencyError
otherwise). The file is written to a temporary sibling and renamed into place.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from generators.formats.atomic import commit
from sim import EvsimInputError

from .common import PlotDependencyError, Prepared, ToneMap, pyplot
from .events import event_frame, event_frame_rgb

if TYPE_CHECKING:
    from akf.params import AKFParams

FORMATS = (".gif", ".mp4")


def check_output(out: str | Path) -> None:
    """EvsimInputError unless `out` ends in .gif or .mp4; PlotDependencyError for .mp4 without ffmpeg.

    Parameters
    ----------
    out : str or pathlib.Path
        The animation file.
    """
    _writer(Path(out).suffix.lower(), 10.0)


def _writer(suffix: str, fps: float):
    if suffix not in FORMATS:
        raise EvsimInputError(f"animation file must end in {' or '.join(FORMATS)}, got suffix {suffix!r}")
    pyplot()
    from matplotlib import animation

    if suffix == ".gif":
        return animation.PillowWriter(fps=fps)
    if not animation.writers.is_available("ffmpeg"):
        raise PlotDependencyError("MP4 output needs ffmpeg on the PATH (not found); write a .gif instead")
    return animation.FFMpegWriter(fps=fps)


def animate(prep: Prepared, out: str | Path, *, n_frames: int = 40, fps: float = 10.0,
            params: AKFParams | None = None) -> dict:
    """Write the animation to `out` (.gif or .mp4) over the span of the LDR frames.

    Parameters
    ----------
    prep : Prepared
        The recording.
    out : str or pathlib.Path
        The animation file (.gif, or .mp4 with ffmpeg).
    n_frames : int, optional
        Animation frames, >= 2, evenly spaced over the LDR frames' span (default 40).
    fps : float, optional
        Animation frame rate (frames per second; default 10).
    params : AKFParams, optional
        The AKF's parameters (default AKFParams()).

    Returns
    -------
    dict
        {"times_us": the animation frames' times (int64 us), "path": the file written}.
    """
    import akf

    out = Path(out)
    writer = _writer(out.suffix.lower(), fps)
    if n_frames < 2:
        raise EvsimInputError(f"an animation needs at least 2 frames, got {n_frames}")
    rec = prep.rec
    t0, t1 = int(rec.frame_t_start_us[0]), int(rec.frame_t_end_us[-1])
    times = np.linspace(t0, t1, n_frames + 1).astype(np.int64)[1:]
    dt = int(times[1] - times[0])
    recon = akf.reconstruct(*prep.reconstruct_args(), times, contrast=prep.contrast, bit_depth=rec.frame_bit_depth,
                            leak_rate_hz=prep.leak_rate_hz, params=params or akf.AKFParams())
    ref = prep.reference_x
    tone = ToneMap.from_reference(ref[ref.shape[0] // 2] if ref is not None else recon[n_frames // 2],
                                  frames_top=float(prep.frames_range()[1][0]))
    plt = pyplot()
    from matplotlib import animation

    panels = 3 if ref is not None else 2
    fig, axes = plt.subplots(1, panels, figsize=(3.4 * panels, 3.3))
    blank = np.zeros((rec.height, rec.width))
    im_ev = axes[0].imshow(event_frame_rgb(np.zeros((2, rec.height, rec.width))), interpolation="nearest")
    im_rec = axes[1].imshow(blank, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    im_ref = axes[2].imshow(blank, cmap="gray", vmin=0, vmax=1, interpolation="nearest") if ref is not None else None
    for ax, title in zip(axes, ("events (ON red, OFF blue)", "AKF reconstruction", "HDR reference (nearest)")):
        ax.set_title(title, fontsize=9)
        ax.axis("off")
    label = fig.suptitle("", fontsize=9)

    def draw(j):
        t = int(times[j])
        im_ev.set_data(event_frame_rgb(event_frame(rec.events, rec.height, rec.width, t - dt, t)))
        im_rec.set_data(tone(recon[j]))
        if im_ref is not None:
            im_ref.set_data(tone(ref[int(np.argmin(np.abs(rec.reference_t_us - t)))]))
        label.set_text(f"t = {t / 1e3:.1f} ms (events over the last {dt / 1e3:.1f} ms)")
        return [im_ev, im_rec, label] + ([im_ref] if im_ref is not None else [])

    anim = animation.FuncAnimation(fig, draw, frames=n_frames, blit=False)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=out.suffix, dir=out.parent)  # writers need the suffix
    os.close(fd)
    try:
        anim.save(tmp, writer=writer)
        commit(Path(tmp), out)  # with the mode a plain open() gives (mkstemp's file is private, 0600)
    finally:
        plt.close(fig)
        Path(tmp).unlink(missing_ok=True)
    return {"times_us": times, "path": out}
