"""
How a DVS pixel fires
=====================

One pixel of the event-camera emulator (`sim.DVSEmulator`) at a time: its log intensity, its photoreceptor output,
its reference level and the events it fires.

The pixel sees I(t) = I_mean exp(0.8 sin(2 pi 4 t)) with a step of +1 in log intensity at t = 0.25 s, sampled
every 200 us. It fires an ON event each time its (filtered) log intensity rises by the contrast threshold C = 0.2
above its reference level, and an OFF event each time it falls by C below it; the reference then moves to the
level of the crossing. Three pixels are compared:

- an ideal pixel: events exactly at every threshold crossing;
- the same pixel in dim light (2 % of full illumination), with a photoreceptor bandwidth of 300 Hz at full
  illumination: the bandwidth scales with the light, so the low-pass lags and smooths the log intensity and the
  events come late, and fewer;
- a pixel with a 20 ms refractory period: crossings during the dead time after each event are lost, and when the
  pixel wakes its reference is reset to the current level.

The emulator's own state (`DVSEmulator.log_intensity`, `DVSEmulator.reference_log`) is read after every input
sample. Run it yourself: ``python examples/01_dvs_pixel_model.py --out FOLDER``.
"""

# %%
# The input and the three sensors
# -------------------------------
# `sim.DVSParams.preset("ideal")` is a pixel without mismatch, noise, bandwidth limit or refractory period; the
# other two change one field each.

import numpy as np
from _shared import output_dir

import sim
from evsim_app.plots.common import OFF_COLOUR, ON_COLOUR, pyplot, save_figure

out = output_dir("How a DVS pixel fires")
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


# %%
# Events against the log intensity
# --------------------------------
# Black: the input log(I + I_d) (I_d, the dark current as radiance, keeps the log finite); green: the
# photoreceptor output the pixel compares; grey: the reference level; triangles: ON (up) and OFF (down) events,
# drawn at the reference level they set.

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
    print(f"{title}: {np.sum(ev['p'] > 0)} ON and {np.sum(ev['p'] < 0)} OFF events")
    ax.set_title(f"{title}: C = {params.pos_threshold}, I_mean = {mean:g}", fontsize=9)
    ax.set_ylabel("log units")
    ax.legend(fontsize=7, loc="upper left", ncol=3)
    ax.grid(alpha=0.3)
axes[-1].set_xlabel("time (ms)")
path = save_figure(fig, out / "01_dvs_pixel_model.png")
print(f"wrote {path}")

# %%
# In dim light the photoreceptor's time constant grows as the light falls, so the output (green) lags the input
# and flattens its peaks: the pixel fires later, and the step at 250 ms comes out as a train of ON events spread
# over about 20 ms. The ideal pixel reports that step as a burst of five ON events within one input sample
# (0.2 ms). The pixel with the refractory period fires once, is blind for 20 ms and then resets its reference to
# the level of that moment, so the rest of the step is never reported.
