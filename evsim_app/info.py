"""What a dataset holds: `describe(path)` gathers it, `format_description(d)` prints it (used by `evsim info`).

Native files are checked as load() checks them, without reading their images, and their events are summarised
from the event summary their writer records (checked against the file's event count and first and last times:
generators.formats.native.event_summary), else by streaming them (memory stays flat); other layouts are loaded.
A folder of sequences (a dataset folder with index.json, a folder written by `evsim export`, a `evsim reconstruct`
output with one folder per sequence) is described sequence by sequence.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from generators.choices import EXPORT_FILE, INDEX_FILE, MANIFEST_SUFFIX
from generators.exports import folder_sequences
from generators.formats import detect, load
from generators.formats.native import (
    event_summary,
    iter_native_events,
    open_native_images,
    recording_event_chunks,
)
from generators.formats.recording import Recording
from sim.dvs_params import PRESETS

LABEL_NAMES = ("signal", "shot", "leak", "hot")


def describe(path: str | Path) -> dict:
    """Summary of a dataset in any readable layout: what `evsim info` prints. Raises DatasetFormatError for
    unreadable files.

    Parameters
    ----------
    path : str or Path
        A file or folder in any layout generators.formats.load reads, or a folder of sequences.

    Returns
    -------
    dict
        JSON-serialisable (times in microseconds, rates in Hz, durations in s): path, layout, height, width
        (pixels), duration_s, t_start_us, t_end_us, events {count, on, off, rate_hz, t_first_us, t_last_us,
        labels}, frames {count, bit_depth, rate_hz, exposure_us {min, mean, max}} or None, reference {count,
        t_first_us, t_last_us} or None, threshold_maps {on_mean, off_mean} (log units) or None, crf, seed_entropy,
        generator, input (a converted video: path, capture_fps, rate_from, resize, linearisation, conditioning) or
        None, lighting (a scene under flickering light: flicker_hz, depth, phase_rad, rise_fraction) or None,
        sensor_model (the sensor's record: name, file, provenance, ...), dvs_changes ({field: value} of the DVS
        fields the run set over that sensor's, auto-resolved illumination aside), packages, outputs (what the
        generator was asked to write, or None). A folder of sequences gives {path, layout: "folder", index:
        whether it has index.json, sequences: [one such dict each]}.
    """
    path = Path(path)
    sequences = folder_sequences(path)
    if sequences is not None:
        return {"path": str(path), "layout": "folder", "index": (path / INDEX_FILE).is_file(),
                "kind": _folder_kind(path), "sequences": [describe(file) for _, file in sequences]}
    layout = detect(path)
    if layout == "native":
        # checked as load() checks the file (sensor size, frames, reference, thresholds, crf, metadata) without
        # reading its images; the events counted from the file's event summary when that agrees with the file,
        # else streamed (each chunk checked)
        with open_native_images(path) as rec:
            h, w, crf, meta, thr, frames, ref_t = _fields(rec)
        summary = event_summary(path)
        chunks = iter_native_events(path) if summary is None else None
    else:
        rec = load(path)
        h, w, crf, meta, thr, frames, ref_t = _fields(rec)
        chunks = recording_event_chunks(rec)
    ev = _event_stats(chunks) if chunks is not None else _summary_stats(summary)
    spans = [(ev["t_first_us"], ev["t_last_us"])] if ev["count"] else []
    if frames is not None:
        spans.append((int(frames["t_start_us"].min()), int(frames["t_end_us"].max())))
    if ref_t.size:
        spans.append((int(ref_t.min()), int(ref_t.max())))
    t0 = min((s[0] for s in spans), default=0)
    t1 = max((s[1] for s in spans), default=0)
    duration_s = (t1 - t0) / 1e6
    ev["rate_hz"] = ev["count"] / duration_s if duration_s > 0 else None
    seed = meta.get("seed")
    return {
        "path": str(path), "layout": layout, "height": h, "width": w,
        "duration_s": duration_s, "t_start_us": t0, "t_end_us": t1, "events": ev,
        "frames": None if frames is None else _frame_stats(frames),
        "reference": {"count": int(ref_t.size), "t_first_us": int(ref_t.min()), "t_last_us": int(ref_t.max())}
        if ref_t.size else None,
        "threshold_maps": None if thr is None else {"on_mean": float(thr[0].mean()), "off_mean": float(thr[1].mean())},
        "crf": crf,
        "seed_entropy": seed.get("entropy") if isinstance(seed, dict) else seed,
        "generator": meta.get("generator"),
        "input": _video_input(meta.get("scene")),
        "lighting": meta["scene"].get("lighting") if isinstance(meta.get("scene"), dict) else None,
        "sensor_model": (meta.get("config") or {}).get("sensor") or None,
        "dvs_changes": _dvs_changes(meta.get("config")),
        "packages": meta.get("packages"),
        "outputs": meta.get("config", {}).get("outputs") if isinstance(meta.get("config"), dict) else None,
    }


def _dvs_changes(config: object) -> dict:
    """{field: value} of the DVS fields of a generator's config that differ from its sensor's (the base preset with
    the sensor file's [dvs] table); full_illumination is left out where the run resolved it from the scene."""
    if not isinstance(config, dict) or not isinstance(config.get("dvs"), dict):
        return {}
    sensor = config.get("sensor") if isinstance(config.get("sensor"), dict) else {}
    base = PRESETS.get(sensor.get("base") or sensor.get("name") or "davis346")
    if base is None:
        return {}
    expected = {**dataclasses.asdict(base), **(sensor.get("dvs") or {})}
    skip = {"full_illumination"} if config.get("auto_illumination") else set()
    return {k: v for k, v in config["dvs"].items()
            if k in expected and k not in skip and not _same(v, expected[k])}


def _same(a: object, b: object) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=0.0)
    return a == b


def _fields(rec: Recording) -> tuple:
    """height, width, crf, metadata, threshold maps, frame times {t_start_us, t_mid_us, t_end_us, bit_depth} (None
    without frames) and reference times (empty without reference) of a checked Recording."""
    frames = None if rec.frames is None else {"t_start_us": rec.frame_t_start_us, "t_mid_us": rec.frame_t_mid_us,
                                               "t_end_us": rec.frame_t_end_us, "bit_depth": rec.frame_bit_depth}
    if frames is not None and np.size(frames["t_mid_us"]) == 0:
        frames = None
    ref_t = np.asarray(rec.reference_t_us) if rec.reference is not None else np.zeros(0, np.int64)
    return rec.height, rec.width, rec.crf, rec.metadata, rec.threshold_maps, frames, ref_t


def _video_input(scene) -> dict | None:
    """What a converted video's frames meant (the video scene's metadata): capture rate and its source, resize
    policy, linearisation, conditioning; None for other scenes."""
    if not isinstance(scene, dict) or "capture_fps" not in scene:
        return None
    inp = scene.get("input", {})
    return {"path": inp.get("path"), "capture_fps": scene["capture_fps"],
            "rate_from": inp.get("from", "timestamps" if "timestamps" in inp else None),
            "resize": scene.get("resize", {}).get("policy"),
            "linearisation": scene.get("linearisation", {}).get("method"),
            "conditioning": scene.get("conditioning", {}).get("mode")}
def _summary_stats(summary: dict) -> dict:
    """The event statistics of a native file's recorded summary (as _event_stats gives them)."""
    n, on, labels = summary["count"], summary["on"], summary["labels"]
    if labels is not None:
        labels = {(LABEL_NAMES[i] if i < len(LABEL_NAMES) else str(i)): int(c) for i, c in enumerate(labels)}
    return {"count": n, "on": on, "off": n - on, "rate_hz": None, "t_first_us": summary["t_first_us"] if n else None,
            "t_last_us": summary["t_last_us"] if n else None, "labels": labels}


def _event_stats(chunks) -> dict:
    n = on = 0
    first = last = None
    label_counts = None
    for events, labels in chunks:
        if events.size == 0:
            continue
        n += events.size
        on += int(np.count_nonzero(events["p"] > 0))
        first = int(events["t"][0]) if first is None else first
        last = int(events["t"][-1])
        if labels is not None:
            c = np.bincount(labels, minlength=len(LABEL_NAMES))
            label_counts = c if label_counts is None else label_counts + c
    labels = None
    if label_counts is not None:
        labels = {(LABEL_NAMES[i] if i < len(LABEL_NAMES) else str(i)): int(c) for i, c in enumerate(label_counts)}
    return {"count": n, "on": on, "off": n - on, "rate_hz": None, "t_first_us": first, "t_last_us": last,
            "labels": labels}


def _frame_stats(frames: dict) -> dict:
    mid = np.asarray(frames["t_mid_us"], np.int64)
    exposure = np.asarray(frames["t_end_us"], np.int64) - np.asarray(frames["t_start_us"], np.int64)
    span = int(mid[-1] - mid[0])
    return {"count": int(mid.size), "bit_depth": frames["bit_depth"],
            "rate_hz": (mid.size - 1) / (span / 1e6) if span > 0 else None,
            "exposure_us": {"min": int(exposure.min()), "mean": float(exposure.mean()), "max": int(exposure.max())}}


def _not_asked(d: dict, part: str) -> str:
    """" (not among its outputs: ...)" when the file was generated without `part`, else ""."""
    outputs = d.get("outputs")
    if isinstance(outputs, list) and part not in outputs:
        return f" (generated with --outputs {','.join(outputs)})"
    return ""


def _folder_kind(path: Path) -> str:
    """What a folder of sequences is: a dataset (its index.json), an `evsim export` (its export.json), a
    generate/convert run that did not finish (complete sequences' manifests and no index.json) or a folder."""
    if (path / INDEX_FILE).is_file():
        return "dataset folder"
    if (path / EXPORT_FILE).is_file():
        try:
            record = json.loads((path / EXPORT_FILE).read_text())
            return f"evsim export to {record['format']} of {record['source']}"
        except (OSError, ValueError, KeyError, TypeError):
            return "evsim export (its export.json is unreadable)"
    if any(path.glob(f"*{MANIFEST_SUFFIX}")):
        return (f"a generate/convert run that did not finish (no {INDEX_FILE}; the same command with --resume "
                "completes it)")
    return f"a folder of sequences, no {INDEX_FILE}"


def format_description(d: dict) -> str:
    """A human-readable rendering of describe()'s dictionary.

    Parameters
    ----------
    d : dict
        What describe() returns.

    Returns
    -------
    str
        Multi-line text (what `evsim info` prints).
    """
    if "sequences" in d:
        n = len(d["sequences"])
        head = f"{d['path']} ({d['kind']}, {n} sequence{'s' * (n != 1)})"
        return "\n\n".join([head] + [format_description(s) for s in d["sequences"]])
    ev = d["events"]
    lines = [
        f"{d['path']} ({d['layout']})",
        f"  sensor      {d['width']} x {d['height']} px",
        f"  duration    {d['duration_s']:.6f} s  [{d['t_start_us']} .. {d['t_end_us']}] us",
        f"  events      {ev['count']} (ON {ev['on']}, OFF {ev['off']})"
        + (f", {ev['rate_hz']:,.0f} ev/s" if ev["rate_hz"] else ""),
    ]
    if ev["labels"]:
        lines.append("  labels      " + ", ".join(f"{k} {v}" for k, v in ev["labels"].items()))
    fr = d["frames"]
    if fr:
        e = fr["exposure_us"]
        rate = f" at {fr['rate_hz']:.4g} Hz" if fr["rate_hz"] else ""
        lines.append(f"  frames      {fr['count']}{rate}, {fr['bit_depth']}-bit, exposure "
                     f"{e['min']} / {e['mean']:.1f} / {e['max']} us (min/mean/max)")
    else:
        lines.append("  frames      none" + _not_asked(d, "frames"))
    ref = d["reference"]
    lines.append(f"  reference   {ref['count']} HDR frames [{ref['t_first_us']} .. {ref['t_last_us']}] us" if ref
                 else "  reference   none" + _not_asked(d, "reference"))
    if d["threshold_maps"]:
        t = d["threshold_maps"]
        lines.append(f"  thresholds  ON mean {t['on_mean']:.4f}, OFF mean {t['off_mean']:.4f} (log units)")
    crf = d["crf"]
    lines.append(f"  CRF         {crf['name']} {crf.get('params', {})}" if crf else "  CRF         unknown")
    model = d.get("sensor_model")
    if model:
        changes = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                            for k, v in sorted(d.get("dvs_changes", {}).items()))
        lines.append(f"  model       {model.get('name')} ({model.get('file') or 'preset'})"
                     + (f"; DVS changed {changes}" if changes else ""))
    if d["generator"]:
        lines.append(f"  generator   {d['generator']}")
    if d.get("input"):
        i = d["input"]
        lines.append(f"  input       {i['path']}: captured at {i['capture_fps']:.6g} fps ({i['rate_from']}), resize "
                     f"{i['resize']}, conditioning {i['conditioning']}")
        lines.append(f"  linearised  {i['linearisation']}")
    if d.get("lighting"):
        light = d["lighting"]
        lines.append(f"  lighting    flicker {light['flicker_hz']:g} Hz, depth {light['depth']:g}, phase "
                     f"{light['phase_rad']:g} rad, rising over {light.get('rise_fraction', 0.5):g} of the period")
    if d["seed_entropy"] is not None:
        lines.append(f"  seed        {d['seed_entropy']} (SeedSequence entropy)")
    if d["packages"]:
        lines.append("  packages    " + ", ".join(f"{k} {v}" for k, v in d["packages"].items()))
    return "\n".join(lines)
