"""Images for the browser: RGBA arrays (Bokeh's image_rgba, packed uint32, bottom row first) of grey images,
event counts and signed errors."""

from __future__ import annotations

import numpy as np

ON_RGB, OFF_RGB = (220, 40, 40), (40, 80, 220)  # ON events red, OFF blue, on white


def _pack(rgb: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 -> (H, W) uint32 RGBA, opaque, flipped so that row 0 is drawn on top."""
    h, w, _ = rgb.shape
    out = np.empty((h, w, 4), np.uint8)
    out[..., :3] = rgb
    out[..., 3] = 255
    return out[::-1].copy().view(np.uint32).reshape(h, w)


def grey_rgba(values: np.ndarray) -> np.ndarray:
    """Display values in [0, 1] (clipped) as grey."""
    g = np.round(np.clip(values, 0.0, 1.0) * 255).astype(np.uint8)
    return _pack(np.repeat(g[..., None], 3, axis=2))


def events_rgba(on: np.ndarray, off: np.ndarray) -> np.ndarray:
    """Per-pixel ON and OFF counts as the usual DVS view: white where none, red where ON dominates, blue where
    OFF does, darker with more events (saturating at 3)."""
    net = on.astype(np.float64) - off
    strength = np.clip(np.abs(net) / 3.0, 0.0, 1.0)[..., None]
    colour = np.where((net > 0)[..., None], np.array(ON_RGB, float), np.array(OFF_RGB, float))
    rgb = 255.0 * (1 - strength) + colour * strength
    return _pack(np.round(rgb).astype(np.uint8))


def error_rgba(error: np.ndarray, span: float) -> np.ndarray:
    """A signed error as a diverging map: blue below 0, white at 0, red above, saturating at +-span."""
    v = np.clip(np.asarray(error, np.float64) / span, -1.0, 1.0)[..., None]
    red, blue = np.array([200.0, 30.0, 30.0]), np.array([30.0, 60.0, 200.0])
    rgb = np.where(v > 0, 255.0 + v * (red - 255.0), 255.0 - v * (blue - 255.0))
    return _pack(np.round(rgb).astype(np.uint8))
