"""The one-pixel panel: sliders for every knob of pixel_model.PixelSettings, one plot of the pixel over time
and the event counts (all, per polarity, per cause)."""

from __future__ import annotations

import time

import numpy as np
import panel as pn
from bokeh.models import ColumnDataSource, Range1d
from bokeh.plotting import figure

from .pixel_model import CRFS, PixelResult, PixelSettings, simulate_pixel
from .signals import SIGNALS, PixelTrace
from .widgets import count_html, explanation

TEXT = ("One DVS pixel and one LDR camera pixel watching the same light. The pixel low-passes its log intensity "
        "with a photoreceptor whose bandwidth grows with the light, and fires an ON (OFF) event each time that "
        "rises (falls) a contrast threshold above (below) its reference level, which then moves to the crossing; "
        "after an event it is blind for the refractory period. Shot noise fires random events, leak drifts the "
        "reference down. The LDR camera integrates the light over each exposure, adds shot and read noise and "
        "maps it through its CRF, clipping at full well. The AKF (purple, with its +-2 sqrt(P) band) integrates "
        "the events between frames and is pulled toward each frame as far as the frame can be trusted. Every "
        "number here comes from evsim's own models (sim.DVSEmulator, sim.LDRCamera, akf.reconstruct).")
EQUATION = ("ON event when L_f(t) - L_ref >= C_on, OFF when L_ref - L_f(t) >= C_off; "
            "L = log(I + I_d); tau(I) dL_f/dt = L - L_f with 1/(2 pi tau) = f_c (I + I_d) / I_full; "
            "frame y = CRF(clip(E T_exp g / full_well))")


class PixelPanel:
    """The one-pixel panel (see pixel_model); `view` is the Panel layout. trace: a real pixel for the
    "recording" signal (signals.recording_pixel), or None."""

    def __init__(self, trace: PixelTrace | None = None):
        self.trace = trace
        d = PixelSettings()
        self.w = {
            "signal": pn.widgets.Select(label="signal", options=[*SIGNALS] + (["recording"] if trace else []),
                                        value=d.signal),
            "light": pn.widgets.FloatSlider(label="light (fraction of full illumination)", start=0.01, end=1.0,
                                            step=0.01, value=d.light),
            "pos_threshold": pn.widgets.FloatSlider(label="ON threshold C_on (log units)", start=0.05, end=1.0,
                                                    step=0.05, value=d.pos_threshold),
            "neg_threshold": pn.widgets.FloatSlider(label="OFF threshold C_off (log units)", start=0.05, end=1.0,
                                                    step=0.05, value=d.neg_threshold),
            "threshold_sigma": pn.widgets.FloatSlider(label="threshold mismatch sigma (log units)", start=0.0,
                                                      end=0.1, step=0.01, value=d.threshold_sigma),
            "refractory_us": pn.widgets.IntSlider(label="refractory period (us)", start=0, end=20_000, step=100,
                                                  value=d.refractory_us),
            "cutoff_hz": pn.widgets.FloatSlider(label="photoreceptor bandwidth at full light (Hz, 0 = ideal)",
                                                start=0.0, end=1000.0, step=10.0, value=d.cutoff_hz),
            "shot_noise_hz": pn.widgets.FloatSlider(label="shot noise (Hz)", start=0.0, end=20.0, step=0.5,
                                                    value=d.shot_noise_hz),
            "leak_hz": pn.widgets.FloatSlider(label="leak (Hz)", start=0.0, end=10.0, step=0.5, value=d.leak_hz),
            "exposure_us": pn.widgets.IntSlider(label="LDR exposure (us)", start=500, end=30_000, step=500,
                                                value=d.exposure_us),
            "crf": pn.widgets.Select(label="LDR camera response (CRF)", options=list(CRFS), value=d.crf),
            "seed": pn.widgets.IntSlider(label="seed (mismatch and noise draw)", start=0, end=20, value=d.seed),
        }
        for w in self.w.values():
            w.param.watch(self._changed, "value_throttled" if hasattr(w, "value_throttled") else "value")
        self.sources = {name: ColumnDataSource() for name in ("input", "lf", "ref", "on", "off", "frames", "akf")}
        self.plot = self._figure()
        self.counts = pn.pane.HTML("", sizing_mode="stretch_width")
        self.last_update_ms = 0.0
        self.update()
        controls = pn.Column(*self.w.values(), width=330)
        self.view = pn.Column(explanation("One pixel", TEXT, EQUATION),
                              pn.Row(controls, pn.Column(self.counts, self.plot)), name="One pixel")

    def settings(self) -> PixelSettings:
        """The settings the widgets show."""
        return PixelSettings(**{k: w.value for k, w in self.w.items()})

    def _changed(self, _event) -> None:
        self.update()

    def _figure(self) -> figure:
        fig = figure(height=430, width=820, x_axis_label="time (ms)", y_axis_label="log(I + I_d)",
                     tools="xpan,xwheel_zoom,reset", toolbar_location="right", y_range=Range1d(-3, 2))
        s = self.sources
        fig.varea(x="t", y1="lo", y2="hi", source=s["akf"], color="purple", alpha=0.15, legend_label="AKF +-2 sqrt(P)")
        fig.line(x="t", y="v", source=s["input"], color="black", line_width=1.5, legend_label="input log(I + I_d)")
        fig.line(x="t", y="v", source=s["lf"], color="green", legend_label="photoreceptor L_f")
        fig.step(x="t", y="v", source=s["ref"], color="grey", mode="after", legend_label="reference level")
        fig.scatter(x="t", y="v", source=s["on"], marker="triangle", color="red", size=7, legend_label="ON")
        fig.scatter(x="t", y="v", source=s["off"], marker="inverted_triangle", color="blue", size=7,
                    legend_label="OFF")
        fig.segment(x0="t0", x1="t1", y0="v", y1="v", source=s["frames"], color="orange", line_width=5,
                    alpha="alpha", legend_label="LDR frames (CRF^-1; faint: clipped)")
        fig.line(x="t", y="v", source=s["akf"], color="purple", line_width=1.5, legend_label="AKF estimate")
        fig.legend.location = "bottom_left"
        fig.legend.label_text_font_size = "8pt"
        fig.legend.click_policy = "hide"
        return fig

    def update(self) -> None:
        """Recompute the pixel and refresh the plot and the counts (one message to the browser)."""
        start = time.perf_counter()
        r = simulate_pixel(self.settings(), self.trace)
        compute_ms = 1e3 * (time.perf_counter() - start)
        with pn.io.hold():
            self._publish(r, compute_ms)
        self.last_update_ms = 1e3 * (time.perf_counter() - start)

    def _publish(self, r: PixelResult, compute_ms: float) -> None:
        """Fill the plot's data sources and the counts from a PixelResult."""
        ms = 1e-3
        s = self.sources
        if not np.array_equal(s["input"].data.get("v", []), r.log_input):  # the signal, 5001 points: only if new
            s["input"].data = {"t": r.t_us * ms, "v": r.log_input}
        ref_at = np.interp(r.events["t"], r.trace_t_us, r.reference)
        on = r.events["p"] > 0
        s["lf"].data = {"t": r.trace_t_us * ms, "v": r.photoreceptor}
        s["ref"].data = {"t": r.trace_t_us * ms, "v": r.reference}
        s["on"].data = {"t": r.events["t"][on] * ms, "v": ref_at[on]}
        s["off"].data = {"t": r.events["t"][~on] * ms, "v": ref_at[~on]}
        s["frames"].data = {"t0": r.frame_t_start_us * ms, "t1": r.frame_t_end_us * ms, "v": r.frame_log,
                            "alpha": np.where(r.frame_clipped, 0.3, 0.9)}
        s["akf"].data = {"t": r.akf_t_us * ms, "v": r.akf_log, "lo": r.akf_log - 2 * r.akf_std,
                         "hi": r.akf_log + 2 * r.akf_std}
        values = np.concatenate([r.log_input, r.frame_log, r.akf_log])
        lo, hi = float(np.min(values)), float(np.max(values))
        pad = 0.1 * max(hi - lo, 1.0)
        self.plot.y_range.start, self.plot.y_range.end = lo - pad, hi + pad
        c = r.counts
        self.counts.object = count_html(
            "pixel-events", "events", r.n_events,
            f" (ON {c['ON']}, OFF {c['OFF']}); noise events: <b id='pixel-noise'>{r.n_noise_events}</b> "
            f"(shot {c['shot']}, leak {c['leak']}); frames: {r.frame_dn.size}, clipped {int(r.frame_clipped.sum())}"
            f" &middot; <span style='color:#888'>computed in {compute_ms:.0f} ms</span>")
