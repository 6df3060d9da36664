"""The reconstruction panel: AKF, complementary filter and frames only on a generated sequence, with a time slider,
tone-mapped images, log-error maps and the contrast threshold the AKF is told (reconstruction_model)."""

from __future__ import annotations

import panel as pn

from . import reconstruction_model as model
from .images import error_rgba, grey_rgba
from .widgets import explanation, image_figure

TEXT = ("Three ways back to HDR video from what the sensors recorded, on a generated sequence (the astronaut photo "
        "made HDR, panned under a DAVIS346-like sensor and a gamma-CRF camera whose frames clip the brightest "
        "parts). Frames only shows the nearest frame through the inverse CRF; the complementary filter (CF) "
        "integrates the events and pulls toward the frames with a fixed gain; the AKF weighs each frame by how "
        "much it can be trusted (not at all where it clips) and each event by its noise model. Slide through "
        "time, then tell the AKF a wrong contrast threshold: every event then moves the estimate by the wrong "
        "step and the error maps (red: too bright, blue: too dark) fill with streaks along the motion.")
EQUATION = ("AKF: between frames  L_hat += p C  per event,  P += Q;  at a frame  K = P / (P + R(y)),  "
            "L_hat += K (L_frame - L_hat),  P = (1 - K) P;   CF:  dL_hat/dt = events - alpha (L_hat - L_frame)")
ERROR_SPAN = 2.0  # log units at which the error maps saturate (a factor e^2)
SCALE = 2  # display magnification of the small sequence


class ReconstructionPanel:
    """The reconstruction panel; `view` is the Panel layout. The sequence is generated on first display."""

    def __init__(self):
        self.time = pn.widgets.IntSlider(label="time (reference frame index)", start=0, end=1, value=0)
        self.scale = pn.widgets.FloatSlider(label="contrast the AKF is told / the sensor's (1 = right)", start=0.5,
                                            end=2.0, step=0.1, value=1.0)
        for w in (self.time, self.scale):
            w.param.watch(self._changed, "value_throttled")
        h, w = model.HEIGHT, model.WIDTH
        names = ["reference (HDR)", "LDR frame", "AKF", "CF", "frames only"]
        self.figs = {n: image_figure(n, w, h, SCALE) for n in names}
        self.errors = {m: image_figure(f"{m}: log error", w, h, SCALE) for m in model.METHODS}
        self.scores = pn.pane.HTML("", sizing_mode="stretch_width")
        self.started = False
        grid = pn.Column(pn.Row(*(f for f, _ in self.figs.values())), pn.Row(*(f for f, _ in self.errors.values())))
        self.view = pn.Column(explanation("Reconstruction", TEXT, EQUATION),
                              pn.Row(pn.Column(self.time, self.scale, width=330), pn.Column(self.scores, grid)),
                              name="Reconstruction")

    def start(self) -> None:
        """Generate the sequence and show its middle (on first display; about 10 s the first time)."""
        if not self.started:
            self.started = True
            n = model.reference_times().size
            self.time.end, self.time.value = n - 1, n // 2
            self.update()

    def _changed(self, _event) -> None:
        self.update()

    def update(self) -> None:
        """Refresh the images, error maps and scores at the chosen time and contrast."""
        s = model.snapshot(self.time.value, self.scale.value)
        shown = {"reference (HDR)": s.reference, "AKF": s.images["akf"], "CF": s.images["cf"],
                 "frames only": s.images["frames"]}
        for name, image in shown.items():
            self.figs[name][1].data = {"image": [grey_rgba(s.tone(image))]}
        self.figs["LDR frame"][1].data = {"image": [grey_rgba(s.ldr)]}
        for m in model.METHODS:
            self.errors[m][1].data = {"image": [error_rgba(s.log_error[m], ERROR_SPAN)]}
        self.scores.object = ("<p>at " + f"{s.t_us / 1e3:.0f} ms, log RMSE (lower is better): "
                              + ", ".join(f"{m} <b id='rmse-{m}'>{v:.3f}</b>" for m, v in s.rmse.items())
                              + f"; {s.tone.describe()}</p>")
