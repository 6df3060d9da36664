"""Event denoisers scored against evsim's per-event labels (`evsim evaluate DATASET --task denoise`).

evsim labels every event it makes (sim.EVENT_LABELS: signal, shot, leak, hot; stored by files written with
labels, e.g. `evsim generate ... --labels`), which is the ground truth denoising needs. For a filter's keep-mask
(sim.denoise):
- TPR (true-positive rate) = kept signal events / signal events;
- FPR (false-positive rate) = kept noise events / noise events, for all noise and per type (shot, leak, hot);
a rate is NaN when there is no event of its kind. Sweeping a filter's main parameter over its grid (larger keeps
more) gives the ROC points (FPR, TPR); the ROC curve joins them, sorted by FPR, between (0, 0) (drop everything)
and (1, 1) (keep everything), and AUC is the area under it (trapezoids; 1 = perfect, 0.5 = chance). AUC per noise
type uses that type's FPR.

Denoise-then-reconstruct: every filter at its default parameter (what a user without labels would run) removes
events, and evsim_eval.evaluate.evaluate_recording scores the AKF and the baselines on what remains, in the same
table as on the raw events.

References (docs/models/references.md): Fawcett 2006 [Fawcett2006], ROC analysis; the filters' sources: Delbruck 2008
[Delbruck2008], Guo and Delbruck 2022 [Guo2022] (sim.denoise).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from generators.formats import load
from generators.formats.atomic import write_text_atomic
from generators.formats.recording import Recording
from sim import EVENT_LABELS, EvsimInputError, OptionError
from sim.denoise import DENOISE_EXTRA_HINT, FILTERS, DenoiseDependencyError, filter_available, get_filter

from .evaluate import evaluate_recording
from .protocols import dataset_sequences

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

NOISE_TYPES = EVENT_LABELS[1:]  # ("shot", "leak", "hot")
DEFAULT_RECONSTRUCT_METRICS = ("mse", "ssim")


# ----- the arithmetic -------------------------------------------------------------------------------------------

def rates(labels: ArrayLike, keep: ArrayLike) -> dict:
    """Counts and rates of one keep-mask: {"signal", "kept_signal", "tpr", "noise", "kept_noise", "fpr", and per
    noise type T: T, "kept_T", "fpr_T"} (counts are event numbers; rates NaN without events of their kind)."""
    labels, keep = np.asarray(labels), np.asarray(keep, bool)
    if labels.shape != keep.shape:
        raise EvsimInputError(f"labels {labels.shape} and keep-mask {keep.shape} differ in shape")
    n_types = len(EVENT_LABELS)
    if labels.size and int(labels.max()) >= n_types:
        raise EvsimInputError(f"event labels must be in 0..{n_types - 1} ({', '.join(EVENT_LABELS)})")
    total = np.bincount(labels, minlength=n_types)
    kept = np.bincount(labels[keep], minlength=n_types)
    out = {"signal": int(total[0]), "kept_signal": int(kept[0]), "tpr": _ratio(kept[0], total[0]),
           "noise": int(total[1:].sum()), "kept_noise": int(kept[1:].sum()),
           "fpr": _ratio(kept[1:].sum(), total[1:].sum())}
    for code, name in enumerate(NOISE_TYPES, start=1):
        out[name], out[f"kept_{name}"], out[f"fpr_{name}"] = int(total[code]), int(kept[code]), \
            _ratio(kept[code], total[code])
    return out


def _ratio(a, b) -> float:
    return float(a) / float(b) if b else math.nan


def roc_auc(fpr: ArrayLike, tpr: ArrayLike) -> float:
    """Area under the ROC curve through the points (fpr, tpr), sorted by fpr, from (0, 0) to (1, 1); NaN when a
    rate is NaN."""
    fpr, tpr = np.asarray(fpr, float), np.asarray(tpr, float)
    if np.isnan(fpr).any() or np.isnan(tpr).any():
        return math.nan
    order = np.lexsort((tpr, fpr))
    x = np.concatenate([[0.0], fpr[order], [1.0]])
    y = np.concatenate([[0.0], tpr[order], [1.0]])
    return float(np.sum(np.diff(x) * (y[1:] + y[:-1]) / 2))


def roc_from_points(points: list[dict]) -> dict:
    """{"all": AUC over all noise, and one per noise type} of ROC points (dicts of rates())."""
    tpr = [p["tpr"] for p in points]
    out = {"all": roc_auc([p["fpr"] for p in points], tpr)}
    out.update({t: roc_auc([p[f"fpr_{t}"] for p in points], tpr) for t in NOISE_TYPES})
    return out


def filter_roc(events: np.ndarray, labels: ArrayLike, height: int, width: int, name: str,
               values: Iterable[float] | None = None, **options: Any) -> dict:
    """ROC of filter `name` over its main parameter: {"filter", "param", "unit", "points": [{"value", **rates}],
    "auc": roc_from_points(...)}; values default to FILTERS[name].grid."""
    f = get_filter(name)
    values = f.grid if values is None else tuple(values)
    if not values:
        raise EvsimInputError(f"{name}: no parameter value to sweep")
    points = [{"value": float(v), **rates(labels, f.run(events, height, width, v, **options))} for v in values]
    return {"filter": name, "param": f.param, "unit": f.unit, "points": points, "auc": roc_from_points(points)}


# ----- recordings and datasets ----------------------------------------------------------------------------------

def resolve_filters(filters: Sequence[str] | None = None) -> tuple[list[str], list[str]]:
    """(filters to run, notes). None: every registered filter whose library is installed (the others noted);
    names given explicitly must be known and installed (DenoiseDependencyError names the extra otherwise)."""
    if filters is None:
        run = [n for n in FILTERS if filter_available(n)]
        notes = [f"{n} skipped: needs {FILTERS[n].library} ({DENOISE_EXTRA_HINT})" for n in FILTERS if n not in run]
        return run, notes
    for n in filters:
        if not filter_available(n):  # raises for unknown names
            raise DenoiseDependencyError(f"filter {n} runs {FILTERS[n].library}, which is not installed: "
                                         f"{DENOISE_EXTRA_HINT}")
    return list(filters), []


def labelled(rec: Recording, what: str = "the recording") -> np.ndarray:
    """rec.event_labels, checked against the events; EvsimInputError when the file carries none."""
    if rec.event_labels is None:
        missing = f"{what} has no per-event labels: generate it with per-event labels"
        raise OptionError(f"{missing} (AHDRConfig(labels=True))", f"{missing} (evsim generate ... --labels)")
    labels = np.asarray(rec.event_labels)
    if labels.shape != rec.events.shape:
        raise EvsimInputError(f"{what}: {labels.size} labels for {rec.events.size} events")
    return labels


def score_recording(rec: Recording, filters: Sequence[str] | None = None,
                    values: dict[str, Sequence[float]] | None = None, *, progress: bool = False) -> dict:
    """{filter: filter_roc(...)} on one labelled recording; values: {filter: values} replacing the grids."""
    labels = labelled(rec)
    names, _ = resolve_filters(filters)
    out = {}
    for name in names:
        if progress:
            print(f"  {name}: {len(FILTERS[name].grid if name not in (values or {}) else values[name])} values on "
                  f"{rec.events.size} events", file=sys.stderr, flush=True)
        out[name] = filter_roc(rec.events, labels, rec.height, rec.width, name, (values or {}).get(name))
    return out


def denoised(rec: Recording, keep: np.ndarray) -> Recording:
    """The recording with only the kept events (and their labels).

    Parameters
    ----------
    rec : Recording
        The recording.
    keep : numpy.ndarray
        bool keep-mask, one per event.

    Returns
    -------
    Recording
        A copy with the kept events.
    """
    labels = None if rec.event_labels is None else rec.event_labels[keep]
    return dataclasses.replace(rec, events=rec.events[keep], event_labels=labels)


def reconstruct_denoised(rec: Recording, filters: Sequence[str] | None = None, *, protocol: str = "reference",
                         methods: Iterable[str] = ("akf", "cf"), metrics: Iterable[str] = DEFAULT_RECONSTRUCT_METRICS,
                         method_options: dict[str, dict[str, Any]] | None = None) -> dict:
    """{row: {method: {metric: value}}}: row "raw" on all events, then "<filter>(<param>=<default>)" on the
    events each filter keeps at its default parameter (evsim_eval.evaluate.evaluate_recording, same protocol).

    Parameters
    ----------
    rec : Recording
        The recording.
    filters : sequence of str, optional
        sim.denoise.FILTERS names (None: every filter whose library is installed, see resolve_filters).
    protocol : {"reference", "interleave"}, optional
        The evaluation protocol (default "reference").
    methods : iterable of str, optional
        akf.METHODS names (default "akf", "cf").
    metrics : iterable of str, optional
        Metric names (default DEFAULT_RECONSTRUCT_METRICS).
    method_options : dict, optional
        {method: {keyword: value}} passed to that method.

    Returns
    -------
    dict
        {row: {method: {metric: value}}}.
    """
    names, _ = resolve_filters(filters)
    kw = {"protocol": protocol, "methods": tuple(methods), "metrics": tuple(metrics), "method_options": method_options}
    rows = {"raw": evaluate_recording(rec, **kw)[0]}
    for name in names:
        f = FILTERS[name]
        keep = f.run(rec.events, rec.height, rec.width, f.default)
        rows[f"{name}({f.param}={f.default:g})"] = evaluate_recording(denoised(rec, keep), **kw)[0]
    return rows


def evaluate_denoise_dataset(path: str | Path, *, filters: Sequence[str] | None = None,
                             values: dict[str, Sequence[float]] | None = None, reconstruct: bool = True,
                             protocol: str = "reference", methods: Sequence[str] = ("akf", "cf"),
                             metrics: Sequence[str] = DEFAULT_RECONSTRUCT_METRICS,
                             method_options: dict[str, dict[str, Any]] | None = None,
                             progress: bool = False) -> tuple[dict, list[str]]:
    """Score filters on every sequence of a dataset (and, with reconstruct, the methods on denoised events).

    Parameters
    ----------
    path : str or pathlib.Path
        The dataset (its events need noise labels).
    filters : sequence of str, optional
        sim.denoise.FILTERS names (None: every filter whose library is installed).
    values : dict, optional
        {filter: main-parameter values} to sweep instead of each filter's grid.
    reconstruct : bool, optional
        Also score the methods on the events each filter keeps (default True).
    protocol, methods, metrics, method_options
        As reconstruct_denoised's.
    progress : bool, optional
        Print progress to stderr (default False).

    Returns
    -------
    result : dict
        {"filters": {name: {"param", "unit", "default", "library", "summary"}}, "sequences": {sequence: {"events":
        rates of keeping all, "roc": {filter: filter_roc}, "reconstruction": {row: {method: {metric}}}}},
        "mean_auc": {filter: {"all" or a noise type: mean AUC over the sequences}}}.
    notes : list of str
        Notes on the filters used.
    """
    names, notes = resolve_filters(filters)
    result = {"filters": {n: {"param": FILTERS[n].param, "unit": FILTERS[n].unit, "default": FILTERS[n].default,
                              "library": FILTERS[n].library, "summary": FILTERS[n].summary} for n in names},
              "sequences": {}, "mean_auc": {}}
    for name, file in dataset_sequences(path):
        if progress:
            print(f"{name}: scoring {len(names)} filters", file=sys.stderr, flush=True)
        rec = load(file)
        labels = labelled(rec, str(file))
        entry = {"events": rates(labels, np.ones(labels.size, bool)),
                 "roc": score_recording(rec, names, values, progress=progress)}
        if reconstruct:
            if progress:
                print(f"{name}: reconstructing raw and denoised events", file=sys.stderr, flush=True)
            entry["reconstruction"] = reconstruct_denoised(rec, names, protocol=protocol, methods=methods,
                                                           metrics=metrics, method_options=method_options)
        result["sequences"][name] = entry
    for n in names:
        aucs = [s["roc"][n]["auc"] for s in result["sequences"].values()]
        result["mean_auc"][n] = {k: _nanmean([a[k] for a in aucs]) for k in ("all", *NOISE_TYPES)}
    return result, notes


def _nanmean(values) -> float:
    v = [x for x in values if not math.isnan(x)]
    return float(np.mean(v)) if v else math.nan


def sequence_aucs(path: str | Path, filters: Sequence[str] | None = None) -> dict:
    """{filter: {"auc": AUC over all noise, "auc_<type>": ...}} of one labelled sequence file (for sweeps)."""
    rec = load(path)
    return {n: {"auc" if k == "all" else f"auc_{k}": v for k, v in r["auc"].items()}
            for n, r in score_recording(rec, filters).items()}


def pooled_points(result: dict, name: str) -> list[dict]:
    """ROC points of filter `name` with the event counts of every sequence of an evaluate_denoise_dataset result
    added up (so the rates weigh every event alike)."""
    per_seq = [s["roc"][name]["points"] for s in result["sequences"].values()]
    pooled = []
    for group in zip(*per_seq):
        counts = {k: sum(p[k] for p in group) for k in group[0] if k != "value" and not k.startswith(("tpr", "fpr"))}
        point = {"value": group[0]["value"], **counts, "tpr": _ratio(counts["kept_signal"], counts["signal"]),
                 "fpr": _ratio(counts["kept_noise"], counts["noise"])}
        point.update({f"fpr_{t}": _ratio(counts[f"kept_{t}"], counts[t]) for t in NOISE_TYPES})
        pooled.append(point)
    return pooled


# ----- output ---------------------------------------------------------------------------------------------------

def _f(v, digits: int = 3) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def format_denoise_table(result: dict, notes: Iterable[str] = ()) -> str:
    """Per sequence: the ROC points of every filter (TPR, FPR overall and per noise type), its AUCs, and the
    reconstruction scores on raw and denoised events; then the mean AUC over the sequences."""
    lines = [*(f"note: {n}" for n in notes)]
    cols = ("tpr", "fpr", *(f"fpr_{t}" for t in NOISE_TYPES))
    for seq, entry in result["sequences"].items():
        ev = entry["events"]
        n = ev["signal"] + ev["noise"]
        mix = ", ".join(f"{k} {ev[k]}" for k in ("signal", *NOISE_TYPES))
        lines += ["", f"== {seq}: {n} events ({mix})",
                  f"{'filter':<15}{'parameter':>22}" + "".join(f"{c.upper().replace('_', ' '):>10}" for c in cols)]
        for name, roc in entry["roc"].items():
            for p in roc["points"]:
                lines.append(f"{name:<15}{roc['param'] + '=' + format(p['value'], 'g'):>22}"
                             + "".join(f"{_f(p[c]):>10}" for c in cols))
        lines += ["", f"{'AUC':<15}" + "".join(f"{k:>10}" for k in ("all", *NOISE_TYPES))]
        for name, roc in entry["roc"].items():
            lines.append(f"{name:<15}" + "".join(f"{_f(roc['auc'][k]):>10}" for k in ("all", *NOISE_TYPES)))
        rows = entry.get("reconstruction")
        if rows:
            methods = list(rows["raw"])
            metrics = list(rows["raw"][methods[0]])
            width = max(len(r) for r in rows) + 2
            for metric in metrics:
                lines += ["", f"{'events -> ' + metric:<{width}}" + "".join(f"{m:>12}" for m in methods)]
                for row, table in rows.items():
                    lines.append(f"{row:<{width}}" + "".join(f"{table[m][metric]:>12.4g}" for m in methods))
    if result["mean_auc"]:
        lines += ["", f"mean AUC over {len(result['sequences'])} sequence(s)",
                  f"{'filter':<15}" + "".join(f"{k:>10}" for k in ("all", *NOISE_TYPES))]
        for name, auc in result["mean_auc"].items():
            lines.append(f"{name:<15}" + "".join(f"{_f(auc[k]):>10}" for k in ("all", *NOISE_TYPES)))
    return "\n".join(lines)


def _clean(obj):
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None if math.isnan(obj) else str(obj)
    return obj


def write_denoise_json(result: dict, path: str | Path) -> None:
    """The evaluate_denoise_dataset result as JSON, atomically (NaN as null, inf as "inf")."""
    write_text_atomic(path, json.dumps(_clean(result), indent=2) + "\n")
