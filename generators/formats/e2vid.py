"""The E2VID / event_cnn_minimal HDF5 layout, for learning-based reconstruction.

Layout (as read by event_cnn_minimal's data loaders):
    /events/xs, /events/ys (i2), /events/ts (f8, seconds), /events/ps (bool, True = ON)
    /images/image000000000 ... (u8, H x W) with attrs timestamp (s, mid-exposure), size (H, W),
        type "greyscale", event_idx = max(0, i - 1) with i the index of the first event with t >= timestamp
        (what event_utils' own writer, hdf5_packager.add_event_indices, stores)
    root attrs sensor_resolution (H, W), num_events, num_pos, num_neg, num_imgs, duration, t0, tk (seconds,
        t0 / tk = first / last event time)
evsim extras that other readers ignore: image attrs t_start_us, t_mid_us, t_end_us (i8); root attrs
evsim_metadata and evsim_crf (JSON); group /evsim with reference/images, reference/t_us, threshold_maps and
event_labels.
Precision: ts are float64 seconds; times read back as rint(ts * 1e6) microseconds, exact for |t| < 2**51 us
(about 71 years: Unix-time microseconds included). Integer ts (other tools' microseconds or nanoseconds) are
refused, not read as seconds. Frames are 8-bit by layout: deeper frames lose their low bits (frame >>
(bit_depth - 8)).

References (docs/models/references.md): Rebecq et al. 2021 [Rebecq2021], E2VID; Stoffregen et al. 2020
[Stoffregen2020], event_cnn_minimal.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from .atomic import atomic_path
from .common import (
    H5Output,
    append_rows,
    events_from_columns,
    fail,
    json_attr,
    open_h5,
    polarity_pm1,
    require,
    to_json,
)
from .native import recording_event_chunks
from .recording import Recording, validate_recording

_CHUNK = 1 << 16


def write_e2vid(rec: Recording, path: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write a Recording in the E2VID layout (atomically). event_source optionally yields (events, labels)."""
    validate_recording(rec)
    nf = 0 if rec.frames is None else rec.frames.shape[0]
    t_mid = np.asarray(rec.frame_t_mid_us if nf else [], dtype=np.int64)
    event_idx = np.zeros(nf, dtype=np.int64)
    with atomic_path(path) as tmp:  # a full disk: DiskFullError naming path
        out = H5Output(tmp)
        try:
            _write_e2vid_file(out, rec, nf, t_mid, event_idx, event_source)
        except BaseException:
            out.abort()
            raise
        out.close()


def _write_e2vid_file(out: H5Output, rec: Recording, nf: int, t_mid: np.ndarray, event_idx: np.ndarray,
                      event_source: Iterator | None) -> None:
    f = out.file
    ev = f.create_group("events")
    cols = {k: ev.create_dataset(k, (0,), dtype=dt, maxshape=(None,), chunks=(_CHUNK,), compression="gzip")
            for k, dt in (("xs", np.int16), ("ys", np.int16), ("ts", np.float64), ("ps", np.bool_))}
    labels_ds = None
    n = n_pos = 0
    t0 = tk = None
    for chunk, labels in event_source if event_source is not None else recording_event_chunks(rec):
        if chunk.size == 0:
            continue
        for k, v in (("xs", chunk["x"].astype(np.int16)), ("ys", chunk["y"].astype(np.int16)),
                     ("ts", chunk["t"] / 1e6), ("ps", chunk["p"] > 0)):
            append_rows(cols[k], v)
        if labels is not None:
            if labels_ds is None:
                labels_ds = f.create_dataset("evsim/event_labels", (0,), dtype=np.uint8, maxshape=(None,),
                                             chunks=(_CHUNK,), compression="gzip")
            append_rows(labels_ds, labels)
        out.check()  # a failed write (full disk) stops the export here
        event_idx += np.searchsorted(chunk["t"], t_mid, side="left")
        n += chunk.size
        n_pos += int(np.count_nonzero(chunk["p"] > 0))
        t0 = int(chunk["t"][0]) if t0 is None else t0
        tk = int(chunk["t"][-1])
    images = f.create_group("images")
    shift = rec.frame_bit_depth - 8
    for i in range(nf):
        img = rec.frames[i] >> shift if shift > 0 else rec.frames[i]
        ds = images.create_dataset(f"image{i:09d}", data=img.astype(np.uint8), compression="gzip")
        ds.attrs.update({"timestamp": t_mid[i] / 1e6, "size": img.shape, "type": "greyscale",
                         "event_idx": max(0, int(event_idx[i]) - 1), "t_start_us": int(rec.frame_t_start_us[i]),
                         "t_mid_us": int(t_mid[i]), "t_end_us": int(rec.frame_t_end_us[i])})
        out.check()
    t0 = t0 if t0 is not None else 0
    tk = tk if tk is not None else t0
    f.attrs.update({"sensor_resolution": (rec.height, rec.width), "num_events": n, "num_pos": n_pos,
                    "num_neg": n - n_pos, "num_imgs": nf, "duration": (tk - t0) / 1e6, "t0": t0 / 1e6,
                    "tk": tk / 1e6, "evsim_metadata": to_json(rec.metadata)})
    if rec.crf is not None:
        f.attrs["evsim_crf"] = to_json(rec.crf)
    if rec.reference is not None:
        refs = f.create_dataset("evsim/reference/images", (len(rec.reference), rec.height, rec.width),
                                dtype=np.float32, chunks=(1, rec.height, rec.width), compression="gzip")
        for i, img in enumerate(rec.reference):  # one image at a time (the reference may be a lazy dataset)
            refs[i] = img
            out.check()
        f.create_dataset("evsim/reference/t_us", data=np.asarray(rec.reference_t_us, dtype=np.int64))
    if rec.threshold_maps is not None:
        f.create_dataset("evsim/threshold_maps", data=rec.threshold_maps.astype(np.float32))


def is_e2vid(f: h5py.File) -> bool:
    return "events/ts" in f


def read_e2vid(path: str | Path) -> Recording:
    """Read an E2VID-layout HDF5 file (ours or event_cnn_minimal's) into a Recording."""
    with open_h5(path) as f:
        require(f, path, ["events/xs", "events/ys", "events/ts", "events/ps"])
        ev = f["events"]
        ts = ev["ts"][()]
        if ts.dtype.kind in "iu":  # 2e5 would be 55 hours: tools that store integers mean us or ns, never seconds
            raise fail(path, f"events/ts holds integers ({ts.dtype}), where the E2VID layout stores float seconds: "
                             "the unit is not guessed; store seconds as float (ts / 1e6 for microseconds)")
        t = np.rint(ts * 1e6).astype(np.int64)
        events = events_from_columns(path, t, ev["xs"][()], ev["ys"][()], polarity_pm1(path, ev["ps"][()]))
        names = sorted(f["images"].keys()) if "images" in f else []
        frames = np.stack([f["images"][k][()] for k in names]) if names else None
        if "sensor_resolution" in f.attrs:
            h, w = (int(s) for s in f.attrs["sensor_resolution"])
        elif frames is not None:
            h, w = frames.shape[1:]
        else:
            raise fail(path, "sensor size unknown: no sensor_resolution attribute and no images")
        times = {k: [] for k in ("t_start_us", "t_mid_us", "t_end_us")}
        for k in names:
            a = f["images"][k].attrs
            if "timestamp" not in a:
                raise fail(path, f"image {k} has no timestamp attribute")
            mid = int(a["t_mid_us"]) if "t_mid_us" in a else int(np.rint(a["timestamp"] * 1e6))
            for key in times:
                times[key].append(int(a[key]) if key in a else mid)
        g = f["evsim"] if "evsim" in f else {}
        has_ref = "reference" in g
        return Recording(
            events=events, height=h, width=w, frames=frames,
            frame_t_start_us=np.array(times["t_start_us"], np.int64) if names else None,
            frame_t_mid_us=np.array(times["t_mid_us"], np.int64) if names else None,
            frame_t_end_us=np.array(times["t_end_us"], np.int64) if names else None,
            frame_bit_depth=8,
            reference=g["reference/images"][()] if has_ref else None,
            reference_t_us=g["reference/t_us"][()] if has_ref else None,
            crf=json_attr(f, "evsim_crf"),
            threshold_maps=g["threshold_maps"][()] if "threshold_maps" in g else None,
            event_labels=g["event_labels"][()] if "event_labels" in g else None,
            metadata=json_attr(f, "evsim_metadata", {}),
        )
