"""Evaluation results as text and JSON: the paper's Table 1 layout, one sequence's method-by-metric table, and
the JSON file of `evsim evaluate --json`."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path

from generators.formats.atomic import write_text_atomic

from . import metrics as metrics_module
from .exposure import MAX_SAMPLES, MIN_SAMPLES, SAMPLES_PER_EVENT
from .pixel_classes import CLIP_MARGIN_DN, FLAT_STD
from .protocols import FRAMES_TOP, UNITS, WHITE

#: what each pixel or time class holds (evsim_eval.pixel_classes), printed with the per-class blocks
CLASS_MEANING = {
    "well": "well-exposed in both nearest input frames",
    "high": f"clipped high in a nearest input frame (within {CLIP_MARGIN_DN} DN of the CRF's top)",
    "low": f"clipped low in a nearest input frame (within {CLIP_MARGIN_DN} DN of the CRF's bottom), not high",
    "flat": f"truth locally flat (7x7 std of clip(I / white, 0, 1) < {FLAT_STD})",
    "textured": "truth not flat",
    "below_range": "truth below the frames' range (under CRF^-1(0) of the longest exposure: black in every frame)",
    "in_range": "truth inside the range the frames can record",
    "above_range": "truth above the frames' top (over CRF^-1(1) of the shortest exposure: clipped in every frame)",
    "at_frames": "scored times inside an input frame's exposure",
    "between": "scored times between input frames' exposures",
}
#: the per-pixel metrics whose class blocks the table prints, when scored (the JSON has every per-pixel metric's):
#: the full-range log_rmse and the paper's clipped [0, 1] metrics
CLASS_BLOCKS = ("log_rmse", "mse01", "ssim01")


def scoring_mode(protocol: str, exposure_matched: bool = True) -> str:
    """What a table's scores compare, in one line."""
    if protocol != "interleave":
        return "point-in-time: each reconstruction at the reference time against the sharp HDR reference"
    if exposure_matched:
        return (f"exposure-matched: each reconstruction averaged in linear x over the held-out frame's exposure "
                f"window ({MIN_SAMPLES}..{MAX_SAMPLES} midpoint samples, {SAMPLES_PER_EVENT} per event of the "
                f"busiest pixels; evsim_eval.exposure), then clipped to the frame's range; --point-scoring: at "
                f"mid-exposure")
    return "point-in-time: each reconstruction at the held-out frame's mid-exposure time (--point-scoring)"


def _split(keys: Iterable[str]) -> tuple[list[str], list[str], list[str]]:
    """(metrics, per-class metrics, classes) of a score row's keys ("metric", "metric@class", "share@class")."""
    keys = list(keys)
    plain = [k for k in keys if "@" not in k]
    by_class = list(dict.fromkeys(k.split("@")[0] for k in keys if "@" in k and not k.startswith("share@")))
    classes = list(dict.fromkeys(k.split("@")[1] for k in keys if k.startswith("share@")))
    return plain, by_class, classes


def format_table(result: dict, protocol: str = "reference", notes: Iterable[str] = (),
                 exposure_matched: bool = True) -> str:
    """The paper's Table 1 layout: one block per metric, a row per sequence and the mean, a column per method (the
    header of a metric clipped at the [0, 1] protocol's white says "(clipped)"); then, when the scores have them,
    one block per CLASS_BLOCKS metric scored (else per per-pixel metric) with a row per sequence and
    pixel/range/time class (the class's share of the scored pixels in brackets).

    Parameters
    ----------
    result : dict
        {method: {sequence: {metric: value, "metric@class": value, "share@class": share}, "mean": {...}}}.
    protocol : str, optional
        The evaluation protocol, a key of UNITS (default "reference"): it sets the units line and the white rule.
    notes : iterable of str, optional
        Lines printed as "note: ..." under the header.
    exposure_matched : bool, optional
        Whether held-out frames were scored exposure-matched (default True), for the scoring line.

    Returns
    -------
    str
        The table, lines joined by newlines.
    """
    methods = list(result)
    sequences = list(result[methods[0]])
    metrics, by_class, classes = _split(result[methods[0]][sequences[0]])
    labels = {m: f"{m} (clipped)" if m in metrics_module.NEEDS_WHITE else m for m in metrics}
    width = max(12, *(len(s) + 2 for s in sequences), *(len(label) + 2 for label in labels.values()))
    lines = [f"units: {UNITS[protocol]}", f"scoring: {scoring_mode(protocol, exposure_matched)}",
             *(f"note: {n}" for n in notes)]
    for metric in metrics:
        rule = (WHITE[protocol] if metric in metrics_module.NEEDS_WHITE
                else FRAMES_TOP if metric in metrics_module.NEEDS_TOP else "")
        lines += ["", f"{metric}: {metrics_module.NORMALISATION[metric]}{rule}",
                  f"{labels[metric]:<{width}}" + "".join(f"{m:>14}" for m in methods)]
        for seq in sequences:
            lines.append(f"{seq:<{width}}" + "".join(f"{_fmt(result[m][seq][metric]):>14}" for m in methods))
    shown = [m for m in by_class if m in CLASS_BLOCKS] or by_class
    classes = [c for c in classes if any(result[methods[0]][s][f"share@{c}"] > 0 for s in sequences)]
    rows = [s for s in sequences if s != "mean" or len(sequences) > 2]  # one sequence: its mean is itself
    if shown and classes:
        lines += ["", "pixel and time classes (a class's score pools its pixels over the scored times; its share of "
                      "the scored pixels in brackets; every per-pixel metric's classes are in the JSON):",
                  *(f"  {c}: {CLASS_MEANING.get(c, c)}" for c in classes)]
        cw = max(len(f"{s} {c} (100%)") for s in rows for c in classes) + 2
        for metric in shown:
            label = f"{metric} (clipped)" if metric in metrics_module.NEEDS_WHITE else metric
            lines += ["", f"{label} by class", f"{metric:<{cw}}" + "".join(f"{m:>14}" for m in methods)]
            for seq in rows:
                for c in classes:
                    label = f"{seq} {c} ({_percent(result[methods[0]][seq][f'share@{c}'])})"
                    lines.append(f"{label:<{cw}}" + "".join(f"{_fmt(result[m][seq][f'{metric}@{c}']):>14}"
                                                            for m in methods))
    return "\n".join(lines)


def _percent(share: float) -> str:
    return "-" if math.isnan(share) else f"{100 * share:.0f}%"


def format_scores(table: dict) -> str:
    """One sequence's {method: {metric: value}} as a method-by-metric table (evsim demo's metrics.txt); per-class
    entries are left out.

    Parameters
    ----------
    table : dict
        {method: {metric: value}}.

    Returns
    -------
    str
        The table.
    """
    metrics = _split(next(iter(table.values())))[0]
    lines = ["method    " + "".join(f"{m:>12}" for m in metrics)]
    for method, row in table.items():
        lines.append(f"{method:<10}" + "".join(f"{_fmt(row[m]):>12}" for m in metrics))
    return "\n".join(lines)


def _fmt(v: float) -> str:
    return "inf" if math.isinf(v) else "-" if math.isnan(v) else f"{v:.4g}"


def _json_value(v: float) -> float | str | None:
    return str(v) if math.isinf(v) else None if math.isnan(v) else v


def write_json(result: dict, path: str | Path, tuning: dict | None = None, scoring: dict | None = None) -> None:
    """{method: {sequence: {metric: value, "metric@class": value, "share@class": share}, "mean": {...}}} as JSON,
    atomically (inf as the string "inf", an empty class's NaN as null).

    Parameters
    ----------
    result : dict
        The scores, as format_table takes them.
    path : str or pathlib.Path
        The file to write.
    tuning : dict, optional
        {method: setting} (DatasetScores.tuning of evsim_eval.evaluate): a top-level "tuning" entry.
    scoring : dict, optional
        What the scores compare (scoring_record): a top-level "scoring" entry.
    """
    clean = {m: {s: {k: _json_value(v) for k, v in row.items()} for s, row in seqs.items()}
             for m, seqs in result.items()}
    if tuning:
        clean["tuning"] = tuning
    if scoring:
        clean["scoring"] = scoring
    write_text_atomic(path, json.dumps(clean, indent=2) + "\n")


def scoring_record(protocol: str, exposure_matched: bool = True, notes: Iterable[str] = ()) -> dict:
    """The JSON's "scoring" entry: protocol, scoring mode (scoring_mode), units, the [0, 1] metrics' white rule,
    the frames' top rule (log_rmse's floor), what each class holds, and the notes (each sequence's white and
    frames' range among them).

    Parameters
    ----------
    protocol : str
        The evaluation protocol, a key of UNITS.
    exposure_matched : bool, optional
        Whether held-out frames were scored exposure-matched (default True).
    notes : iterable of str, optional
        The notes.

    Returns
    -------
    dict
        The entry.
    """
    return {"protocol": protocol, "mode": scoring_mode(protocol, exposure_matched),
            "exposure_matched": bool(exposure_matched and protocol == "interleave"), "units": UNITS[protocol],
            "white": WHITE[protocol].strip(" ()"), "frames_top": FRAMES_TOP.strip(" ()"), "classes": CLASS_MEANING,
            "notes": list(notes)}
