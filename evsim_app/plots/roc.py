"""ROC curves of event denoisers against evsim's per-event labels (`evsim plot roc DATASET`).

DATASET is a labelled dataset (scored with evsim_eval.denoisers.evaluate_denoise_dataset, filters only) or the JSON
that `evsim evaluate DATASET --task denoise --json FILE` wrote. One panel per noise kind (all noise, then shot, leak
and hot where the data has such events): TPR on signal events against FPR on that kind's events, one curve per
filter through its parameter values (the default value ringed), between (0, 0) and (1, 1), with its AUC in the
legend. With several sequences the event counts are pooled before the rates are taken.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from sim import EVENT_LABELS, EvsimInputError

from .common import pyplot, read_json, save_figure


def load_roc_result(source: str | Path, filters: Sequence[str] | None = None) -> dict:
    """The denoising result of a JSON file written by `evsim evaluate --task denoise --json`, or computed from a
    dataset (filters only, no reconstruction).

    Parameters
    ----------
    source : str or pathlib.Path
        A .json result, or a dataset.
    filters : sequence of str, optional
        The filters to keep (or to run); default all.

    Returns
    -------
    dict
        The result, as evaluate_denoise_dataset gives it (JSON nulls back to NaN).
    """
    source = Path(source)
    if source.suffix.lower() == ".json":
        result = read_json(source, f"{source}: no such file")
        if not isinstance(result, dict) or "sequences" not in result or "filters" not in result:
            raise EvsimInputError(f"{source}: not the JSON of `evsim evaluate --task denoise`")
        if filters is not None:
            unknown = [f for f in filters if f not in result["filters"]]
            if unknown:
                raise EvsimInputError(f"{source} has no scores of {', '.join(unknown)}; it has "
                                      f"{', '.join(result['filters'])}")
            result = {**result, "filters": {f: result["filters"][f] for f in filters}}
        return _nan_from_null(result)
    from evsim_eval.denoisers import evaluate_denoise_dataset

    return evaluate_denoise_dataset(source, filters=filters, reconstruct=False)[0]


def _nan_from_null(obj):
    if isinstance(obj, dict):
        return {k: _nan_from_null(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_nan_from_null(v) for v in obj]
    return float("nan") if obj is None else obj


def plot_roc(result: dict, out: str | Path, *, title: str | None = None) -> dict:
    """Draw the ROC panels of an evaluate_denoise_dataset result into `out`.

    Parameters
    ----------
    result : dict
        The result (load_roc_result).
    out : str or pathlib.Path
        The image file.
    title : str, optional
        The figure's title.

    Returns
    -------
    dict
        {filter: {kind: AUC}} of the points pooled over the sequences (kind: "all" or a noise type). With several
        sequences this is not evsim evaluate's AUC, the mean of each sequence's: the legend gives both.
    """
    from evsim_eval.denoisers import pooled_points, roc_auc

    names = list(result["filters"])
    if not names or not result["sequences"]:
        raise EvsimInputError("nothing to plot: no filter or no sequence in the result")
    pooled = {n: pooled_points(result, n) for n in names}
    first = pooled[names[0]][0]
    kinds = ["all"] + [t for t in EVENT_LABELS[1:] if first[t] > 0]
    plt = pyplot()
    fig, axes = plt.subplots(1, len(kinds), figsize=(3.9 * len(kinds), 3.9), squeeze=False)
    aucs = {n: {} for n in names}
    n_seq = len(result["sequences"])
    mean = result.get("mean_auc", {})
    for ax, kind in zip(axes[0], kinds):
        key = "fpr" if kind == "all" else f"fpr_{kind}"
        for n in names:
            pts = sorted(pooled[n], key=lambda p: (p[key], p["tpr"]))
            fpr, tpr = [p[key] for p in pts], [p["tpr"] for p in pts]
            aucs[n][kind] = roc_auc(fpr, tpr)
            label = f"{n} (AUC {aucs[n][kind]:.3f})"
            if n_seq > 1:
                label = f"{n} (pooled AUC {aucs[n][kind]:.3f}" + (
                    f", mean over sequences {mean[n][kind]:.3f})" if kind in mean.get(n, {}) else ")")
            line, = ax.plot([0.0, *fpr, 1.0], [0.0, *tpr, 1.0], marker="o", ms=3, lw=1.2, label=label)
            default = result["filters"][n]["default"]
            for p in pts:
                if abs(p["value"] - default) <= 1e-9 * max(1.0, abs(default)):
                    ax.plot(p[key], p["tpr"], "o", ms=8, mfc="none", color=line.get_color())
        ax.plot([0, 1], [0, 1], ":", color="0.6", lw=0.8)
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel(f"FPR ({'all noise' if kind == 'all' else kind + ' events'} kept)")
        ax.set_title("all noise" if kind == "all" else kind, fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    axes[0, 0].set_ylabel("TPR (signal events kept)")
    fig.suptitle(title or (f"{n_seq} sequences pooled; ringed: each filter's default parameter" if n_seq > 1
                           else f"{next(iter(result['sequences']))}; ringed: each filter's default parameter"),
                 fontsize=9)
    save_figure(fig, out)
    return aucs
