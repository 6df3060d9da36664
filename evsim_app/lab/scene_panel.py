"""The scene panel: the DVS event view and the LDR frame of one scene side by side at 346x260, noise types toggled
one by one, and the event rate (scene_model)."""

from __future__ import annotations

import time

import panel as pn
from bokeh.models import ColumnDataSource
from bokeh.plotting import figure

from .images import events_rgba, grey_rgba
from .pixel_model import CRFS
from .scene_model import (
    DURATION_US,
    HEIGHT,
    NOISE_TYPES,
    SCENES,
    WIDTH,
    WINDOW_US,
    SceneResult,
    SceneSettings,
    simulate_scene,
)
from .widgets import count_html, explanation, image_figure

TEXT = ("The same sensor pair over a whole scene: every pixel of a 346x260 DVS runs the model of the one-pixel "
        f"panel, and the view shows the events of the last {WINDOW_US // 1000} ms (ON red, OFF blue) beside the LDR "
        "frame exposed up to the same moment. Raise the threshold and edges thin out; turn the noise types on one "
        "by one and watch the background fill with shot noise, leak events and a few hot pixels firing at 50 Hz; "
        "lengthen the exposure and the frame blurs while the events stay sharp. The event rate counts every "
        "event; the noise count, those the model labels as noise.")
EQUATION = ("event rate r(t) ~ sum over pixels |d/dt log I(x, t)| / C  =  |grad log I . v| / C per pixel "
            "(brightness constancy), plus N_pixels (shot + leak rates) + hot pixels")


class ScenePanel:
    """The scene panel (see scene_model); `view` is the Panel layout. photo: an image file offered as a scene."""

    def __init__(self, photo: str | None = None):
        d = SceneSettings()
        self.w = {
            "scene": pn.widgets.Select(label="scene", options=[*SCENES] + ([photo] if photo else []), value=d.scene),
            "speed_px_per_s": pn.widgets.FloatSlider(label="motion (px/s, or deg/s for the disk)", start=0.0,
                                                     end=800.0, step=50.0, value=d.speed_px_per_s),
            "threshold": pn.widgets.FloatSlider(label="contrast threshold C (log units)", start=0.05, end=1.0,
                                                step=0.05, value=d.threshold),
            "refractory_us": pn.widgets.IntSlider(label="refractory period (us)", start=0, end=10_000, step=100,
                                                  value=d.refractory_us),
            "cutoff_hz": pn.widgets.FloatSlider(label="photoreceptor bandwidth at full light (Hz, 0 = ideal)",
                                                start=0.0, end=1000.0, step=50.0, value=d.cutoff_hz),
            "noise": pn.widgets.CheckButtonGroup(label="noise", options=list(NOISE_TYPES), value=list(d.noise),
                                                 orientation="vertical"),
            "exposure_us": pn.widgets.IntSlider(label="LDR exposure (us)", start=500, end=40_000, step=500,
                                                value=d.exposure_us),
            "crf": pn.widgets.Select(label="LDR camera response (CRF)", options=list(CRFS), value=d.crf),
        }
        for w in self.w.values():
            w.param.watch(self._changed, "value_throttled" if hasattr(w, "value_throttled") else "value")
        self.events_fig, self.events_src = image_figure(f"DVS events, last {WINDOW_US // 1000} ms", WIDTH, HEIGHT)
        self.frame_fig, self.frame_src = image_figure("LDR frame", WIDTH, HEIGHT)
        self.rate_src = ColumnDataSource({"t": [], "r": []})
        self.rate_fig = figure(title="event rate", height=200, width=2 * WIDTH + 10, x_axis_label="time (ms)",
                               y_axis_label="events per second", toolbar_location=None, tools="")
        self.rate_fig.line(x="t", y="r", source=self.rate_src, line_width=2)
        self.counts = pn.pane.HTML("", sizing_mode="stretch_width")
        self.last_update_ms = 0.0
        self.started = False
        controls = pn.Column(*self.w.values(), width=330)
        self.view = pn.Column(explanation("A sensor over a scene", TEXT, EQUATION),
                              pn.Row(controls, pn.Column(self.counts, pn.Row(self.events_fig, self.frame_fig),
                                                         self.rate_fig)), name="Sensor over a scene")

    def settings(self) -> SceneSettings:
        """The settings the widgets show."""
        values = {k: w.value for k, w in self.w.items()}
        values["noise"] = tuple(values["noise"])
        return SceneSettings(**values)

    def _changed(self, _event) -> None:
        self.update()

    def start(self) -> None:
        """Compute the first view (on first display: rendering the scene takes a few seconds)."""
        if not self.started:
            self.started = True
            self.update()

    def update(self) -> None:
        """Re-emulate the scene with the widgets' settings and refresh the views."""
        start = time.perf_counter()
        r = simulate_scene(self.settings())
        with pn.io.hold():  # one message to the browser for all the changes
            self._publish(r, 1e3 * (time.perf_counter() - start))
        self.last_update_ms = 1e3 * (time.perf_counter() - start)

    def _publish(self, r: SceneResult, compute_ms: float) -> None:
        """Fill the images, the rate plot and the counts from a SceneResult."""
        self.events_src.data = {"image": [events_rgba(r.on, r.off)]}
        self.frame_src.data = {"image": [grey_rgba(r.frame / r.max_dn)]}
        self.rate_src.data = {"t": r.rate_t_us * 1e-3, "r": r.rate_hz}
        self.counts.object = count_html(
            "scene-events", f"events in {DURATION_US // 1000} ms", r.n_events,
            f"; noise events: {r.n_noise}; mean rate {r.n_events / (DURATION_US * 1e-6) / 1e6:.2f} M events/s"
            f" &middot; <span style='color:#888'>computed in {compute_ms:.0f} ms</span>")
