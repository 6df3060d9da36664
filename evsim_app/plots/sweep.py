"""Reconstruction error (or a denoiser's ROC AUC) against each swept noise parameter (`evsim plot sweep RESULTS`).

RESULTS is a folder written by `evsim generate sweep` (generators.sweep): index.json lists one sequence per grid
point with its parameters. Each sequence is scored with evsim_eval.evaluate.evaluate_recording (protocol
"reference": the reference frames strictly between the first and last LDR frame, in the CRF's units) for the
requested metric, or, for the AUC metrics (auc over all noise, auc_shot, auc_leak, auc_hot; the sweep must be
written with --labels), with evsim_eval.denoisers for each denoising filter named as a method; the scores are
cached per method and metric in RESULTS/sweep_metrics.json (written atomically) and reused. With several swept
parameters, each panel shows the mean over the other parameters' values at each value, with min..max error bars.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from generators.dataset import INDEX_FILE
from generators.formats.atomic import write_text_atomic
from sim import EvsimInputError

from .common import load_recording, pyplot, read_json, save_figure

METRICS_FILE = "sweep_metrics.json"
DEFAULT_METHODS = ("akf", "cf", "frames")
AUC_METRICS = ("auc", "auc_shot", "auc_leak", "auc_hot")  # denoisers' ROC AUC (evsim_eval.denoisers)
DEFAULT_FILTERS = ("correlation", "hot_pixel")  # the methods of an AUC sweep by default (evsim's own filters)


def read_index(results: str | Path) -> dict:
    """The sweep's index.json; EvsimInputError when the folder is not a sweep's output."""
    path = Path(results) / INDEX_FILE
    index = read_json(path, f"{results}: no {INDEX_FILE}; expected the folder written by `evsim generate sweep`")
    if not isinstance(index, dict) or index.get("generator") != "sweep" or "grid" not in index:
        generator = index.get("generator") if isinstance(index, dict) else None
        raise EvsimInputError(f"{path}: not a sweep index (generator {generator!r}); "
                              "use the output folder of `evsim generate sweep`")
    return index


def score_sequence(path: str | Path, methods: Iterable[str] = DEFAULT_METHODS,
                   metrics: Sequence[str] = ("mse",)) -> dict:
    """{method: {metric: value}} of one sequence file (evsim_eval.evaluate, protocol "reference"), or, for
    AUC_METRICS, {filter: {auc metric: value}} of the denoising filters named by methods (evsim_eval.denoisers)."""
    if any(m in AUC_METRICS for m in metrics):
        from evsim_eval.denoisers import sequence_aucs

        return {f: {m: scores[m] for m in metrics} for f, scores in sequence_aucs(path, tuple(methods)).items()}
    from evsim_eval.evaluate import evaluate_recording

    return evaluate_recording(load_recording(path), methods=tuple(methods), metrics=tuple(metrics))[0]


def sweep_metrics(results: str | Path, methods: Sequence[str] = DEFAULT_METHODS, metric: str = "mse", *,
                  recompute: bool = False, progress: bool = False) -> list[dict]:
    """Per grid point {"name", "stamp", "point", "scores": {method: {metric: value}}}; scores come from the cache
    when it has them for the same file (name, size, modification time), the missing ones are computed and added.

    Parameters
    ----------
    results : str or pathlib.Path
        A sweep's output folder (generators.generate_sweep).
    methods : sequence of str, optional
        akf.METHODS names, or denoising filters for an AUC metric (default DEFAULT_METHODS).
    metric : str, optional
        The metric (default "mse").
    recompute : bool, optional
        Ignore the cache (default False).
    progress : bool, optional
        Print progress (default False).

    Returns
    -------
    list of dict
        One row per grid point.
    """
    results = Path(results)
    index = read_index(results)
    cache_path = results / METRICS_FILE
    cached = {}
    if cache_path.is_file() and not recompute:
        cached = {e["name"]: e for e in json.loads(cache_path.read_text())["sequences"]}
    rows, changed = [], False
    for n, entry in enumerate(index["sequences"]):
        st = (results / entry["file"]).stat()
        stamp = [entry["file"], st.st_size, st.st_mtime_ns]  # a regenerated file invalidates its scores
        row = cached.get(entry["name"])
        if row is None or row.get("stamp") != stamp:
            row = {"name": entry["name"], "stamp": stamp, "point": entry["sweep_point"], "scores": {}}
        missing = [m for m in methods if metric not in row["scores"].get(m, {})]
        if missing:
            if progress:
                print(f"[{n + 1}/{len(index['sequences'])}] scoring {entry['file']}", flush=True)
            for m, scores in score_sequence(results / entry["file"], missing, (metric,)).items():
                row["scores"].setdefault(m, {}).update(scores)
            changed = True
        rows.append(row)
    if changed:
        write_text_atomic(cache_path, json.dumps({"sequences": rows}, indent=2))
    return rows


def aggregate(rows: list[dict], key: str, method: str,
              metric: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(values, mean, min, max) of metric over the grid points, grouped by the value of parameter `key`.

    Parameters
    ----------
    rows : list of dict
        sweep_metrics' rows.
    key : str
        The swept parameter.
    method : str
        The method.
    metric : str
        The metric.

    Returns
    -------
    tuple of numpy.ndarray
        (values, mean, min, max), one entry per parameter value.
    """
    values = sorted({r["point"][key] for r in rows})
    groups = [[r["scores"][method][metric] for r in rows if r["point"][key] == v] for v in values]
    return (np.array(values, float), np.array([np.mean(g) for g in groups]), np.array([min(g) for g in groups]),
            np.array([max(g) for g in groups]))


def plot_sweep(results: str | Path, out: str | Path, *, methods: Sequence[str] = DEFAULT_METHODS, metric: str = "mse",
               recompute: bool = False, progress: bool = False) -> list[dict]:
    """One panel per swept parameter: metric against its value, one line per method, into `out`; returns the rows.

    Parameters
    ----------
    results : str or pathlib.Path
        A sweep's output folder.
    out : str or pathlib.Path
        The image file.
    methods, metric, recompute, progress
        As sweep_metrics'.

    Returns
    -------
    list of dict
        sweep_metrics' rows.
    """
    import evsim_eval

    if metric not in evsim_eval.METRICS and metric not in AUC_METRICS:
        raise EvsimInputError(f"unknown metric {metric!r}; one of {', '.join((*evsim_eval.METRICS, *AUC_METRICS))}")
    index = read_index(results)
    rows = sweep_metrics(results, methods, metric, recompute=recompute, progress=progress)
    keys = list(index["grid"])
    plt = pyplot()
    fig, axes = plt.subplots(1, len(keys), figsize=(4.2 * len(keys), 3.6), squeeze=False)
    for ax, key in zip(axes[0], keys):
        for method in methods:
            v, mean, lo, hi = aggregate(rows, key, method, metric)
            ax.errorbar(v, mean, yerr=[mean - lo, hi - mean], marker="o", capsize=3, label=method)
        ax.set_xlabel(key)
        ax.set_ylabel(metric + (" (lower is better)" if metric == "mse" else " (higher is better)"))
        if metric == "mse":
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    if len(keys) > 1:
        fig.suptitle("mean over the other swept parameters (bars: min..max)", fontsize=9)
    save_figure(fig, out)
    return rows
