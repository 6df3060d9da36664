"""The in-memory form of one sequence: what readers return and what exporters take."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Recording:
    """One hybrid event/frame sequence with optional ground truth.

    events: sim.EVENT_DTYPE array sorted by t (microseconds).
    height, width: sensor size in pixels.
    frames: (F, H, W) unsigned integer LDR images (camera response after the CRF, quantised), or None.
    frame_t_start_us, frame_t_mid_us, frame_t_end_us: (F,) int64 exposure start / middle / end, microseconds.
    frame_bit_depth: bits per frame sample (8..16).
    reference: (R, H, W) float32 linear HDR radiance ground truth, or None; reference_t_us: (R,) int64.
    crf: {"name": str, "params": {...}} so that crf_models.get(name, **params) rebuilds the CRF, or None.
    threshold_maps: (2, H, W) float32 ON and OFF contrast thresholds (log units), or None.
    event_labels: (N,) uint8 per-event label (0 signal, 1 shot, 2 leak, 3 hot), or None.
    metadata: JSON-serialisable dict: resolved configuration, seed entropy, package versions, ...
    """

    events: np.ndarray
    height: int
    width: int
    frames: np.ndarray | None = None
    frame_t_start_us: np.ndarray | None = None
    frame_t_mid_us: np.ndarray | None = None
    frame_t_end_us: np.ndarray | None = None
    frame_bit_depth: int = 8
    reference: np.ndarray | None = None
    reference_t_us: np.ndarray | None = None
    crf: dict | None = None
    threshold_maps: np.ndarray | None = None
    event_labels: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)
