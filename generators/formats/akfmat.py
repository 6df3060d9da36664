"""The AKF authors' MATLAB input (.mat), as loaded by their akf_reconstruction.m.

Variables (MATLAB conventions: 1-based pixel indices, column-major images):
    events      N x 4 double [t_us, x + 1, y + 1, p (+1 ON / -1 OFF)]
    image       H x W x F uint8 frames
    time_image  F x 1 double, mid-exposure times (us);  exposure F x 1 double, exposure durations (us)
                (columns: their deblur_edge_left.m indexes time_image(i, 1))
    im_height, im_width   sensor size;  ct   nominal contrast threshold (log units)
    f_Q         256 x 1 double, 1/Rbar indexed by pixel value z + 1 (z = 0..255)
    post_process          output normalisation selector of their code (written as 1: min-max)
evsim extras (ignored by their code): evsim_metadata, evsim_crf (JSON text), evsim_frame_t_start_us,
evsim_frame_t_end_us (F x 1), evsim_reference (H x W x R single), evsim_reference_t_us (R x 1),
evsim_threshold_maps (H x W x 2 single), evsim_event_labels (N x 1). Every vector is a column. Files written
before (1 x F rows) still read: vectors are read whatever their orientation.
Precision: event and frame times are doubles in microseconds (exact below 2**53 us). Frames are 8-bit by layout:
deeper frames lose their low bits. Without the evsim extras, t_start = t_mid - exposure // 2 and
t_end = t_start + exposure. The .mat is MATLAB v5 (scipy.io.savemat, 2 GB per variable: about 67 M events);
reading also accepts v7.3 (HDF5) files.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from sim import EvsimInputError

from .atomic import atomic_path
from .common import events_from_columns, fail, open_h5, polarity_pm1, to_json
from .recording import MAX_TIME_US, Recording, validate_recording

REQUIRED = ("events", "image", "time_image", "exposure", "im_height", "im_width")
# The authors' frame noise table is f_Q = max(w(z), 0.09) * 7e5 with the Robertson weight w: i.e.
# Rbar = sigma_im2 / w with sigma_im2 = 1 / 7e5, saturated at sigma_im2 / 0.09. The same scale is used with a CRF.
SIGMA_IM2 = 1.0 / 7e5
_MAT_DESCRIPTION = b"MATLAB 5.0 MAT-file, written by evsim".ljust(116)  # the v5 header's 116-byte text field
MAX_VARIANCE = SIGMA_IM2 / 0.09


def authors_f_q() -> np.ndarray:
    """The authors' 256-entry f_Q table: max(exp(-4 (z - 127.5)^2 / 127.5^2), 0.09) * 7e5."""
    z = np.arange(256, dtype=np.float64)
    return np.maximum(np.exp(-4.0 * (z - 127.5) ** 2 / 127.5**2), 0.09) / SIGMA_IM2


def f_q_from_crf(crf: dict) -> np.ndarray:
    """1 / Rbar(z) for z = 0..255 from a recorded CRF ({"name", "params"}) through crf_models' frame variance."""
    import crf_models

    curve = crf_models.get(crf["name"], **crf.get("params", {}))
    return 1.0 / curve.variance(np.arange(256) / 255.0, SIGMA_IM2, MAX_VARIANCE)


def _find_thresholds(meta) -> float | None:
    """Mean of pos_threshold / neg_threshold found anywhere in nested metadata."""
    if isinstance(meta, dict):
        if "pos_threshold" in meta and "neg_threshold" in meta:
            return 0.5 * (float(meta["pos_threshold"]) + float(meta["neg_threshold"]))
        for v in meta.values():
            found = _find_thresholds(v)
            if found is not None:
                return found
    return None


def resolve_ct(rec: Recording) -> float:
    """The nominal contrast threshold: mean of the threshold maps, else of pos/neg_threshold in the metadata."""
    if rec.threshold_maps is not None:
        return float(np.mean(rec.threshold_maps))
    ct = _find_thresholds(rec.metadata)
    if ct is None:
        raise EvsimInputError("akf-mat needs a contrast threshold: pass ct=..., or record threshold maps or "
                              "pos_threshold/neg_threshold in the metadata")
    return ct


def write_akf_mat(rec: Recording, path: str | Path, *, ct: float | None = None, f_q: np.ndarray | None = None) -> None:
    """Write a Recording as the AKF authors' .mat (atomically). ct defaults to resolve_ct(rec); f_q to the CRF's
    1/Rbar (f_q_from_crf) when the recording has a CRF, else the authors' table."""
    validate_recording(rec)
    if rec.frames is None or rec.frames.shape[0] == 0:
        raise EvsimInputError("akf-mat needs frames: the recording has none")
    ct = resolve_ct(rec) if ct is None else float(ct)
    f_q = np.asarray(f_q if f_q is not None else (f_q_from_crf(rec.crf) if rec.crf else authors_f_q()), np.float64)
    if f_q.shape != (256,):
        raise EvsimInputError(f"f_Q must have 256 entries, got shape {f_q.shape}")
    ev = rec.events
    shift = rec.frame_bit_depth - 8
    frames = rec.frames >> shift if shift > 0 else rec.frames
    t_start = np.asarray(rec.frame_t_start_us, np.int64)
    t_end = np.asarray(rec.frame_t_end_us, np.int64)
    data = {
        "events": np.column_stack([ev["t"], ev["x"] + 1.0, ev["y"] + 1.0, ev["p"]]).astype(np.float64),
        "image": np.ascontiguousarray(frames.transpose(1, 2, 0), dtype=np.uint8),
        "time_image": _column(np.asarray(rec.frame_t_mid_us, np.float64)),
        "exposure": _column((t_end - t_start).astype(np.float64)),
        "im_height": float(rec.height), "im_width": float(rec.width), "ct": ct, "f_Q": _column(f_q),
        "post_process": 1.0,
        "evsim_metadata": to_json(rec.metadata), "evsim_crf": to_json(rec.crf),
        "evsim_frame_t_start_us": _column(t_start), "evsim_frame_t_end_us": _column(t_end),
    }
    if rec.reference is not None:
        data["evsim_reference"] = np.asarray(rec.reference, np.float32).transpose(1, 2, 0)
        data["evsim_reference_t_us"] = _column(np.asarray(rec.reference_t_us, np.int64))
    if rec.threshold_maps is not None:
        data["evsim_threshold_maps"] = np.asarray(rec.threshold_maps, np.float32).transpose(1, 2, 0)
    if rec.event_labels is not None:
        data["evsim_event_labels"] = _column(np.asarray(rec.event_labels, np.uint8))
    with atomic_path(path) as tmp:
        import scipy.io  # (here: `evsim info` and the other readers need not load scipy.io)

        scipy.io.savemat(tmp, data, do_compression=True, oned_as="column")
        with open(tmp, "r+b") as f:  # a fixed header text (scipy's holds the time of writing): the same file
            f.write(_MAT_DESCRIPTION)  # for the same recording, so that its SHA-256 can be checked against a rerun


def _column(v: np.ndarray) -> np.ndarray:
    """A vector as an N x 1 MATLAB column (the authors' code indexes time_image(i, 1))."""
    return np.asarray(v).reshape(-1, 1)


def _load_mat(path: Path) -> dict:
    if not path.is_file():
        raise fail(path, "no such file")
    if h5py.is_hdf5(path):  # MATLAB v7.3 files are HDF5, with arrays stored transposed
        with open_h5(path) as f:
            return {k: f[k][()].T for k in f if isinstance(f[k], h5py.Dataset)}
    import scipy.io

    try:
        return scipy.io.loadmat(path)
    except (scipy.io.matlab.MatReadError, ValueError, OSError, TypeError) as e:
        raise fail(path, f"not a readable MATLAB .mat file (truncated or corrupt?): {e}") from e


def _us(path, name: str, v) -> np.ndarray:
    """A MATLAB time vector (double or integer microseconds) as int64, refusing NaN and overflowing values."""
    a = np.asarray(v).ravel()
    if a.dtype.kind not in "iuf" or (a.dtype.kind == "f" and not np.isfinite(a).all()):
        raise fail(path, f"{name} must hold finite numbers, got {a.dtype}")
    if a.size and np.abs(a.astype(np.float64)).max() > MAX_TIME_US:
        raise fail(path, f"{name} outside +-2**62 us")
    return np.rint(a).astype(np.int64)


def _text(v) -> str:
    return str(np.asarray(v).ravel()[0]) if np.asarray(v).size else ""


def read_akf_mat(path: str | Path) -> Recording:
    """Read an AKF .mat (the authors' example datasets or ours) into a Recording.

    ct, f_Q and post_process go to metadata["akf_mat"]. Polarity 1 is ON, 0 or -1 OFF; other values are refused.
    """
    path = Path(path)
    m = _load_mat(path)
    missing = [k for k in REQUIRED if k not in m]
    if missing:
        raise fail(path, f"missing variable(s) {', '.join(missing)} (AKF .mat needs {', '.join(REQUIRED)})")
    ev = np.asarray(m["events"], dtype=np.float64)
    if ev.ndim != 2 or (ev.size and ev.shape[1] != 4):
        raise fail(path, f"events must be N x 4 [t_us, x+1, y+1, p], got shape {ev.shape}")
    ev = ev.reshape(-1, 4)
    events = events_from_columns(path, np.rint(ev[:, 0]).astype(np.int64), ev[:, 1] - 1, ev[:, 2] - 1,
                                 polarity_pm1(path, ev[:, 3]))
    h, w = int(np.asarray(m["im_height"]).ravel()[0]), int(np.asarray(m["im_width"]).ravel()[0])
    image = np.asarray(m["image"])
    if image.ndim == 2:
        image = image[:, :, None]
    if image.ndim != 3 or image.shape[:2] != (h, w):
        raise fail(path, f"image must be {h} x {w} x F, got shape {image.shape}")
    if image.dtype.kind not in "biuf" or (image.dtype.kind == "f" and not np.isfinite(image).all()):
        raise fail(path, f"image must hold finite numbers, got {image.dtype}")
    if image.size and (image.min() < 0 or image.max() > 255):
        raise fail(path, f"image values must be 8-bit (0..255), got {image.min()}..{image.max()}")
    frames = np.ascontiguousarray(np.rint(image).astype(np.uint8).transpose(2, 0, 1))
    nf = frames.shape[0]
    t_mid, exposure = (_us(path, k, m[k]) for k in ("time_image", "exposure"))
    if exposure.size == 1:
        exposure = np.full(nf, exposure[0])
    if t_mid.size != nf or exposure.size < nf:
        raise fail(path, f"{nf} images but {t_mid.size} time_image and {exposure.size} exposure entries")
    exposure = exposure[:nf]  # the authors' sample files sometimes carry a longer exposure vector
    if "evsim_frame_t_start_us" in m:
        t_start, t_end = (_us(path, k, m[k]) for k in ("evsim_frame_t_start_us", "evsim_frame_t_end_us"))
    else:
        t_start = t_mid - exposure // 2
        t_end = t_start + exposure
    akf = {k: np.asarray(m[k]).ravel().tolist() if np.asarray(m[k]).size > 1 else float(np.asarray(m[k]).ravel()[0])
           for k in ("ct", "f_Q", "post_process") if k in m}
    metadata = json.loads(_text(m["evsim_metadata"])) if "evsim_metadata" in m else {}
    metadata["akf_mat"] = akf
    ref = m.get("evsim_reference")
    thr = m.get("evsim_threshold_maps")
    return Recording(
        events=events, height=h, width=w, frames=frames, frame_t_start_us=t_start, frame_t_mid_us=t_mid,
        frame_t_end_us=t_end, frame_bit_depth=8,
        reference=None if ref is None else np.ascontiguousarray(np.atleast_3d(ref).transpose(2, 0, 1)),
        reference_t_us=None if ref is None else _us(path, "evsim_reference_t_us", m["evsim_reference_t_us"]),
        crf=json.loads(_text(m["evsim_crf"])) if "evsim_crf" in m else None,
        threshold_maps=None if thr is None else np.ascontiguousarray(thr.transpose(2, 0, 1)),
        event_labels=None if "evsim_event_labels" not in m else np.asarray(m["evsim_event_labels"]).ravel(),
        metadata=metadata,
    )
