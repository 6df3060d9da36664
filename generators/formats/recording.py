"""The in-memory form of one sequence: what readers return and what exporters take."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.errors import EvsimInputError, OptionError
from sim.events import MAX_TIME_US  # |t| bound of every time: 2**62 us, so differences never overflow int64


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


def missing_part_error(message: str, rec: Recording, part: str,
                       remedy: tuple[str, str] | None = None) -> EvsimInputError:
    """The error `message` saying that rec lacks `part` ("frames" or "reference"). When rec's generator was asked
    not to write it (generators.ahdr.AHDRConfig.outputs, recorded in the metadata), a sim.OptionError that says how
    to get it: in keywords (str) and in command-line flags (cli_message); else `remedy` (in keywords, in flags)
    when given, else a plain EvsimInputError."""
    config = rec.metadata.get("config") if isinstance(rec.metadata, dict) else None
    outputs = config.get("outputs") if isinstance(config, dict) else None
    if isinstance(outputs, list) and part not in outputs:
        asked = [str(o) for o in outputs]
        return OptionError(f"{message} (it was generated with outputs {', '.join(asked)}: generate or convert it "
                           "again with outputs events, frames, reference)",
                           f"{message} (it was generated with --outputs {','.join(asked)}: generate or convert it "
                           "again with --outputs events,frames,reference)")
    if remedy is not None:
        return OptionError(f"{message} ({remedy[0]})", f"{message} ({remedy[1]})")
    return EvsimInputError(message)


# ----- validation ----------------------------------------------------------------------------------------------

MAX_SENSOR_PX = 1 << 16  # event coordinates are uint16: a sensor side is at most 65536 pixels
N_EVENT_LABELS = 4  # 0 signal, 1 shot, 2 leak, 3 hot


def _fail(msg: str):
    from sim import EvsimInputError

    return EvsimInputError(f"invalid recording: {msg}")


def _int_times(name: str, t, n: int | None = None, per: str = "frame") -> np.ndarray:
    """Check a time array: one-dimensional (n entries when given), integer, |t| <= MAX_TIME_US."""
    t = np.asarray(t)
    if t.ndim != 1 or (n is not None and t.shape[0] != n):
        raise _fail(f"{name} must have one entry per {per} ({n}), got shape {t.shape}")
    if t.size and t.dtype.kind not in "iu":
        raise _fail(f"{name} must be integer microseconds, got {t.dtype}")
    if t.size and (int(t.max()) > MAX_TIME_US or int(t.min()) < -MAX_TIME_US):
        raise _fail(f"{name} outside +-2**62 us (corrupt or overflowing times): {int(t.min())}..{int(t.max())}")
    return t


def _shape_dtype(images) -> tuple[tuple[int, ...], np.dtype]:
    if hasattr(images, "shape") and hasattr(images, "dtype"):
        return tuple(images.shape), np.dtype(images.dtype)
    a = np.asarray(images)
    return a.shape, a.dtype


def validate_recording(rec: Recording) -> Recording:
    """Check every documented rule of a Recording and return it unchanged; sim.EvsimInputError naming the rule.

    Rules: sensor size 1..65536 pixels per side; events valid (sim.EVENT_DTYPE, p in {-1, +1}, time-sorted, inside
    the sensor, |t| <= 2**62 us); labels one uint per event, in 0..3; frames unsigned (F, H, W) of uint8 (bit
    depth 8) or uint16 (9..16) with values < 2**frame_bit_depth and exposure times t_start <= t_mid <= t_end with
    t_mid non-decreasing; reference float (R, H, W), finite and >= 0, with non-decreasing times; threshold maps
    float (2, H, W), finite and > 0; crf None or {"name": str, "params": dict}; metadata a dict. Frames and
    reference that are lazy (HDF5 datasets) are checked for shape and dtype only, not value by value.

    Parameters
    ----------
    rec : Recording
        The recording to check.

    Returns
    -------
    Recording
        rec, unchanged.
    """
    from sim import EvsimInputError, validate_events

    h, w = rec.height, rec.width
    for name, v in (("height", h), ("width", w)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= MAX_SENSOR_PX:
            raise _fail(f"sensor {name} must be an integer in 1..{MAX_SENSOR_PX} pixels, got {v!r}")
    try:
        validate_events(rec.events, name="events")
    except EvsimInputError as e:
        raise _fail(str(e)) from None
    ev = rec.events
    if ev.size:
        if int(ev["x"].max()) >= w or int(ev["y"].max()) >= h:
            raise _fail(f"event coordinates outside the {w}x{h} sensor (max x {int(ev['x'].max())}, "
                        f"max y {int(ev['y'].max())})")
        _int_times("event times", ev["t"][[0, -1]])
    if rec.event_labels is not None:
        lab = np.asarray(rec.event_labels)
        if lab.shape != ev.shape or (lab.size and lab.dtype.kind not in "iu"):
            raise _fail(f"event labels must be one integer per event ({ev.size}), got {lab.dtype} {lab.shape}")
        if lab.size and (int(lab.min()) < 0 or int(lab.max()) >= N_EVENT_LABELS):
            raise _fail(f"event labels must be in 0..{N_EVENT_LABELS - 1}, got {int(lab.min())}..{int(lab.max())}")
    depth = rec.frame_bit_depth
    if isinstance(depth, bool) or not isinstance(depth, (int, np.integer)) or not 8 <= depth <= 16:
        raise _fail(f"frame_bit_depth must be an integer in 8..16, got {depth!r}")
    if rec.frames is not None:
        shape, dtype = _shape_dtype(rec.frames)
        want = np.uint8 if depth == 8 else np.uint16
        if len(shape) != 3 or shape[1:] != (h, w) or dtype != want:
            raise _fail(f"frames must be {np.dtype(want)} (F, {h}, {w}) for bit depth {depth}, got {dtype} {shape}")
        if isinstance(rec.frames, np.ndarray) and rec.frames.size and int(rec.frames.max()) >= 1 << depth:
            raise _fail(f"frame value {int(rec.frames.max())} exceeds the {depth}-bit range")
        t0, tm, t1 = (_int_times(n, getattr(rec, n), shape[0])
                      for n in ("frame_t_start_us", "frame_t_mid_us", "frame_t_end_us"))
        bad = np.flatnonzero((t0 > tm) | (tm > t1))
        if bad.size:
            i = int(bad[0])
            raise _fail(f"frame {i}: exposure must satisfy t_start <= t_mid <= t_end, got {int(t0[i])}, "
                        f"{int(tm[i])}, {int(t1[i])} us")
        if np.any(np.diff(tm) < 0):
            raise _fail("frame mid-exposure times must not decrease")
    if rec.reference is not None:
        shape, dtype = _shape_dtype(rec.reference)
        if len(shape) != 3 or shape[1:] != (h, w) or dtype.kind != "f":
            raise _fail(f"reference must be float (R, {h}, {w}), got {dtype} {shape}")
        t = _int_times("reference_t_us", rec.reference_t_us, shape[0], "reference frame")
        if np.any(np.diff(t) < 0):
            raise _fail("reference times must not decrease")
        if isinstance(rec.reference, np.ndarray) and rec.reference.size:
            if not np.isfinite(rec.reference).all() or rec.reference.min() < 0:
                raise _fail("reference radiance must be finite and >= 0")
    elif rec.reference_t_us is not None and np.size(rec.reference_t_us):
        raise _fail("reference times without reference frames")
    if rec.threshold_maps is not None:
        thr = np.asarray(rec.threshold_maps)
        if thr.shape != (2, h, w) or thr.dtype.kind != "f":
            raise _fail(f"threshold maps must be float (2, {h}, {w}), got {thr.dtype} {thr.shape}")
        if not (np.isfinite(thr).all() and thr.min() > 0):
            raise _fail("threshold maps must be finite and > 0 (log units)")
    crf = rec.crf
    if crf is not None and not (isinstance(crf, dict) and isinstance(crf.get("name"), str)
                                and isinstance(crf.get("params", {}), dict)):
        raise _fail(f"crf must be {{'name': str, 'params': dict}}, got {crf!r:.200}")
    if not isinstance(rec.metadata, dict):
        raise _fail(f"metadata must be a dict, got {type(rec.metadata).__name__}")
    return rec
