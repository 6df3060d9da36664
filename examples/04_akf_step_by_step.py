"""The Asynchronous Kalman Filter step by step on a built-in AHDR sequence (the paper's setting: a DAVIS346-like
event sensor and an LDR camera behind the clipping "window" CRF, over an HDR scene).

1. what the sensors give: event frames, time surfaces and the event rate (04_events.png);
2. one well-exposed and one saturated pixel over time: the true log intensity, the DVS reference level and its
   events, the LDR samples through the inverse CRF, the augmented frame (EDI-deblurred frames joined by events),
   the AKF estimate with its +-2 sqrt(P) band and the complementary filter (04_pixel_*.png);
3. the whole image: LDR input, AKF, complementary filter, frames only and the HDR reference, with error maps and the
   Kalman gain (04_compare.png);
4. events against the reconstruction over time (04_events_vs_akf.gif).

Run: python examples/04_akf_step_by_step.py [--out FOLDER]
"""

import numpy as np
from _shared import builtin_sequence, output_dir

from evsim_app.plots import animate, load_recording, plot_compare, plot_events, plot_pixel, prepare


def main():
    out = output_dir(__doc__.splitlines()[0])
    path = builtin_sequence(out / "04_sequence.h5", sensor="davis346", crf="window")
    prep = prepare(load_recording(path))
    rec = prep.rec
    print(f"1. {rec.events.size} events and {rec.frames.shape[0]} frames of {rec.width}x{rec.height} px")
    plot_events(rec, out / "04_events.png", window_ms=10)
    # a pixel whose first frame is mid-grey, and the brightest pixel of the first reference frame
    counts = np.bincount(rec.events["y"].astype(np.int64) * rec.width + rec.events["x"],
                         minlength=rec.width * rec.height).reshape(rec.height, rec.width)
    mid = np.abs(rec.frames[0].astype(float) - 128) + 1000 * (counts < 10)
    picks = {"well_exposed": np.unravel_index(np.argmin(mid), mid.shape),
             "saturated": np.unravel_index(np.argmax(rec.reference[0]), mid.shape)}
    for name, (y, x) in picks.items():
        s = plot_pixel(prep, int(x), int(y), out / f"04_pixel_{name}.png")
        print(f"2. {name} pixel (x={x}, y={y}): {s.event_t_us.size} events, "
              f"{int(s.frame_clipped.sum())}/{s.frame_clipped.size} frames clipped")
    res = plot_compare(prep, out / "04_compare.png")
    print(f"3. at {res['t_us'] / 1e3:g} ms, PU21-PSNR: "
          + ", ".join(f"{m} {v:.2f} dB" for m, v in res["pu21_psnr"].items()))
    animate(prep, out / "04_events_vs_akf.gif", n_frames=20)
    print(f"4. wrote the figures and the animation to {out}")


if __name__ == "__main__":
    main()
