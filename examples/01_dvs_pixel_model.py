"""The DVS pixel model, one pixel at a time: log intensity, photoreceptor output, reference level and events.

A single pixel sees I(t) = I_mean * exp(0.8 sin(2 pi 4 t)) with a +1 log step at 0.25 s. Three sensors are compared:
an ideal pixel (events every time the log moves by the threshold C = 0.2 from the reference level), the same pixel
in dim light with a photoreceptor bandwidth of 300 Hz at full illumination (the low-pass lags and smooths the log),
and a pixel with a 20 ms refractory period (crossings during the dead time are lost and the reference is reset).
The emulator's own state (sim.DVSEmulator.log_intensity / reference_log) is read after every input sample.

Run: python examples/01_dvs_pixel_model.py [--out FOLDER]
"""

import numpy as np
from _shared import output_dir

import sim
from evsim_app.plots.common import OFF_COLOUR, ON_COLOUR, pyplot, save_figure

DT_US, DURATION_US = 200, 500_000
CASES = [
    ("ideal pixel", 1.0, sim.DVSParams.preset("ideal")),
    ("dim light, 300 Hz photoreceptor at full light", 0.02, sim.DVSParams.preset("ideal", cutoff_hz=300.0)),
    ("20 ms refractory period", 1.0, sim.DVSParams.preset("ideal", refractory_us=20_000)),
]


def radiance(t_us, mean):
    t = t_us * 1e-6
    return mean * np.exp(0.8 * np.sin(2 * np.pi * 4 * t) + 1.0 * (t >= 0.25))


def run(mean, params):
    """Feed the pixel sample by sample; return times, true log, photoreceptor log, reference level and events."""
    emu = sim.DVSEmulator(1, 1, params, seed=0)
    times = np.arange(0, DURATION_US + 1, DT_US, dtype=np.int64)
    lf, ref, events = [], [], []
    for t in times:
        events.append(emu.feed(np.full((1, 1), radiance(t, mean), np.float32), t))
        lf.append(emu.log_intensity[0, 0])
        ref.append(emu.reference_log[0, 0])
    dark = params.dark_fraction * params.full_illumination
    true = np.log(radiance(times, mean).astype(np.float32) + dark)
    return times, true, np.array(lf), np.array(ref), np.concatenate(events)


def main():
    out = output_dir(__doc__.splitlines()[0])
    plt = pyplot()
    fig, axes = plt.subplots(len(CASES), 1, figsize=(10, 8), sharex=True)
    for ax, (title, mean, params) in zip(axes, CASES):
        t, true, lf, ref, ev = run(mean, params)
        ms = t / 1e3
        ax.plot(ms, true, "k-", lw=1.2, label="log(I + I_d) (input)")
        ax.plot(ms, lf, color="tab:green", lw=1.2, label="photoreceptor output Lf")
        ax.step(ms, ref, where="post", color="0.5", lw=1, label="reference level")
        for p, colour in ((1, ON_COLOUR), (-1, OFF_COLOUR)):
            sel = ev[ev["p"] == p]
            level = np.interp(sel["t"], t, ref)
            ax.plot(sel["t"] / 1e3, level, "^" if p > 0 else "v", color=colour, ms=4,
                    label=f"{'ON' if p > 0 else 'OFF'} events ({sel.size})")
        ax.set_title(f"{title}: C = {params.pos_threshold}, I_mean = {mean:g}", fontsize=9)
        ax.set_ylabel("log units")
        ax.legend(fontsize=7, loc="upper left", ncol=3)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (ms)")
    path = save_figure(fig, out / "01_dvs_pixel_model.png")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
