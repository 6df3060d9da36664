"""The real-data panel's computation: a real DAVIS346 recording from the project's shared data beside its
simulation from its own frames (evsim_eval.calibrate.RecordingSimulation, as `evsim calibrate` simulates it), with
a chosen sensor, and the realism scores of that simulation (evsim_eval.realism).

The recording's upsampled radiance is prepared once (a few seconds) and each sensor's simulation and scores are
cached. Without ../shared (a checkout on its own) `shared_recording()` is None and the panel says so.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import sim

#: the recording: a static DAVIS346 over a road with passing cars (MIT; see ../shared/data/README.md)
RECORDING = Path("data") / "events" / "davis346_road" / "davis346_road.aedat4"
WINDOW_S = (0.4, 2.32)  # the scored window (s from the first exposure), as docs/guide/calibrate.md scores it
#: sensors to compare: label -> DVS preset
SENSORS = {"davis346_road (calibrated to this recording)": "davis346_road",
           "davis346 (the uncalibrated guess)": "davis346"}
VIEW_WINDOW_US = 20_000  # events accumulated per view (us)


def shared_folder() -> Path:
    """The project's shared material: ../shared beside the checkout (may be absent)."""
    return Path(__file__).resolve().parents[3] / "shared"


def shared_recording() -> Path | None:
    """The real recording's path, or None when the shared data is not there."""
    path = shared_folder() / RECORDING
    return path if path.is_file() else None


@dataclass
class RealComparison:
    """One sensor against the recording: real and simulated events (sim.EVENT_DTYPE, the recording's time base),
    the sensor's DVSParams, the realism table rows (statistic, real, simulated, score) and the scores dict;
    origin_us: the recording's first exposure start; height, width: the sensor size."""

    real: np.ndarray
    simulated: np.ndarray
    params: sim.DVSParams
    rows: list
    scores: dict
    origin_us: int
    height: int
    width: int

    def counts(self, events: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(ON, OFF) (H, W) event counts over VIEW_WINDOW_US starting t_s seconds after the origin."""
        t0 = self.origin_us + int(t_s * 1e6)
        sel = events[(events["t"] >= t0) & (events["t"] < t0 + VIEW_WINDOW_US)]
        flat = sel["y"].astype(np.int64) * self.width + sel["x"]
        n = self.height * self.width
        return tuple(np.bincount(flat[m], minlength=n).reshape(self.height, self.width)
                     for m in (sel["p"] > 0, sel["p"] < 0))


@functools.lru_cache(maxsize=1)
def _prepared(path: Path):
    from evsim_eval.calibrate import RecordingSimulation
    from evsim_eval.realism import measure_recording
    from generators.formats import load

    rec = load(path)
    return rec, RecordingSimulation(path, recording=rec), measure_recording(rec, WINDOW_S)


@functools.lru_cache(maxsize=4)
def compare_sensor(preset: str, path: Path | None = None) -> RealComparison:
    """Simulate the shared recording (or `path`) with DVS preset `preset` and score it (cached per preset)."""
    from evsim_eval.realism import compare, measure
    from evsim_eval.realism.comparison import table_rows

    path = path or shared_recording()
    if path is None:
        raise sim.EvsimInputError(f"the shared recording {RECORDING} is not in {shared_folder()}")
    rec, simulation, real_stats = _prepared(path)
    params = simulation.params(sim.DVSParams.preset(preset))
    events = simulation.simulate(params)
    comparison = compare(real_stats, measure(events, like=real_stats))
    return RealComparison(real=rec.events, simulated=events, params=params, rows=table_rows(comparison),
                          scores=comparison.scores, origin_us=int(real_stats.origin_us), height=rec.height,
                          width=rec.width)
