"""The real-data panel: a real DAVIS346 recording's events beside its simulation with a chosen sensor, and the
realism scores (real_model). Without the shared data it says what is missing."""

from __future__ import annotations

import html

import panel as pn

from . import real_model as model
from .images import events_rgba
from .widgets import explanation, image_figure

TEXT = ("A real DAVIS346 recording (a static camera over a road, cars passing) beside evsim's simulation of it. "
        "The simulation starts from the recording's own APS frames, upsampled in time, and runs either the "
        "sensor `evsim calibrate` fitted to this recording or the uncalibrated davis346 guess. The realism "
        "scores compare the statistics a real sensor is known by: event counts per polarity, noise on static "
        "pixels, where the events fall, their rate over time and the intervals between a pixel's events "
        "(x1 and 0 are perfect).")
EQUATION = ("count ratio = N_sim / N_real;  per-pixel correlation = corr(n_sim(x, y), n_real(x, y));  "
            "interval L1 = sum |p_sim(dt) - p_real(dt)|")


class RealPanel:
    """The real-data panel; `view` is the Panel layout. The simulation runs on first display."""

    def __init__(self):
        self.path = model.shared_recording()
        self.sensor = pn.widgets.Select(label="sensor", options=list(model.SENSORS))
        self.time = pn.widgets.FloatSlider(label="time (s from the first frame)", start=model.WINDOW_S[0],
                                           end=model.WINDOW_S[1] - model.VIEW_WINDOW_US * 1e-6, step=0.02,
                                           value=1.0)
        self.sensor.param.watch(self._changed, "value")
        self.time.param.watch(self._changed, "value_throttled")
        self.real_fig, self.real_src = image_figure("real events", 346, 260)
        self.sim_fig, self.sim_src = image_figure("simulated events", 346, 260)
        self.table = pn.pane.HTML("", sizing_mode="stretch_width")
        self.started = False
        head = explanation("Real data", TEXT, EQUATION)
        if self.path is None:
            body = pn.pane.HTML(f"<p id='real-missing'><b>No real recording here.</b> This panel reads "
                                f"{html.escape(str(model.RECORDING))} from the project's shared data, expected at "
                                f"{html.escape(str(model.shared_folder()))}, which this checkout does not have. The "
                                "other panels need nothing from it.</p>")
        else:
            body = pn.Row(pn.Column(self.sensor, self.time, width=330),
                          pn.Column(pn.Row(self.real_fig, self.sim_fig), self.table))
        self.view = pn.Column(head, body, name="Real data")

    def start(self) -> None:
        """Simulate and score on first display (a few seconds), if the recording is there."""
        if not self.started and self.path is not None:
            self.started = True
            self.update()

    def _changed(self, _event) -> None:
        if self.started:
            self.update()

    def update(self) -> None:
        """Refresh both event views and the realism table for the chosen sensor and time."""
        c = model.compare_sensor(model.SENSORS[self.sensor.value], self.path)
        self.real_src.data = {"image": [events_rgba(*c.counts(c.real, self.time.value))]}
        self.sim_src.data = {"image": [events_rgba(*c.counts(c.simulated, self.time.value))]}
        rows = "".join(f"<tr><td>{html.escape(a)}</td><td>{b}</td><td>{s}</td><td><b>{k}</b></td></tr>"
                       for a, b, s, k in c.rows)
        self.table.object = ("<table style='font-size:0.9em'><tr><th>statistic</th><th>real</th><th>simulated</th>"
                             f"<th>score</th></tr>{rows}</table>")
