"""Calibration to a real sensor: fit the DVS model to a real hybrid recording by simulating its own frames.

- `calibrate(path, window_s)` -> `Calibration` (fitted DVSParams, the frames' black level and read noise, the
  realism scores of the preset and of the fit, timing): evsim_eval.calibrate.fit;
- `RecordingSimulation`: a recording's frames upsampled once (as `evsim convert` does), simulated many times;
- `estimate_thresholds(recording, frames)` -> `ThresholdEstimate`: the thresholds and log offset of a recording
  without recorded ones by calibrate's first stage (what `evsim evaluate` uses): evsim_eval.calibrate.thresholds;
- `fit_table(cal)`, `sensor_of(cal, name)`, `write_calibration(cal, path)`: the report and the sensor file;
- `calibrate_events_only(path)` -> `EventsOnlyCalibration` for a recording without frames (calibrate dispatches to
  it): noise per polarity, hot pixels, refractory period, timestamps; thresholds from the preset or given;
  `events_only_table`, `events_only_sensor`, `write_events_only`: evsim_eval.calibrate.events_only.
Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {
    "Calibration": "fit", "calibrate": "fit", "loss_of": "fit",
    "RecordingSimulation": "simulation", "InputSettings": "simulation",
    "estimate_thresholds": "thresholds", "ThresholdEstimate": "thresholds",
    "fit_table": "report", "sensor_of": "report", "write_calibration": "report",
    "EventsOnlyCalibration": "events_only", "calibrate_events_only": "events_only",
    "events_only_table": "events_only", "events_only_sensor": "events_only", "write_events_only": "events_only",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
