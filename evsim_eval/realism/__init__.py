"""How real simulated events are: statistics of an event stream and their comparison with a real recording's.

- `measure(events, windows_us, height=, width=, masks=)` -> `RealismStats` (counts per polarity and pixel, noise
  rates on quiet and dark static pixels, 10 ms rate curve, same-pixel interval histogram, events per passage);
  `measure(sim_events, like=real_stats)` measures a simulation on a real recording's windows and pixel classes;
  `measure_recording(recording, window_s)` does it for a generators.formats Recording, with its frames' pixel
  classes (`frame_masks` -> `FrameMasks`) and coverage gaps cut out;
- `compare(real_stats, sim_stats)` -> `Comparison` (scores, their seed noise, notes); `format_comparison`,
  `write_comparison_json`; `score_recordings(real, sim, window_s)` for two Recordings, `load_one(path)` to read one.
Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {
    "RealismStats": "stats", "measure": "stats", "measure_recording": "stats", "shifted": "stats",
    "recording_origin_us": "stats", "RATE_BIN_US": "stats", "PASSAGE_GAP_US": "stats",
    "INTERVAL_EDGES_US": "stats",
    "FrameMasks": "masks", "frame_masks": "masks",
    "Comparison": "comparison", "compare": "comparison", "format_comparison": "comparison",
    "write_comparison_json": "comparison", "PERFECT": "comparison",
    "score_recordings": "score", "load_one": "score",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
