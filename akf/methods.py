"""The reconstruction methods by name: the AKF, the smoother and the baselines, with one signature (what evaluation,
tuning and the command line look methods up in)."""

from __future__ import annotations

from .baselines import BASELINES
from .filter import reconstruct
from .smoother import reconstruct_smoothed

__all__ = ["METHODS"]

#: name -> callable(events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, *, contrast,
#: bit_depth, **method options) -> float32 (T, H, W) linear intensity
METHODS = {"akf": reconstruct, "aks": reconstruct_smoothed, **BASELINES}
