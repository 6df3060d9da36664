"""Scoring reconstruction methods on every sequence of a dataset: one evaluator (the paper's Table 1 and
supplementary Table 2).

evaluate_dataset tunes, when asked, in this process (the search scores every sequence for each setting), then
scores every sequence as one task of generators.runner: serially, on local workers or on a Dask cluster, with the
same result. The per-sequence task is evaluate_sequence_file: evaluate_recording of the loaded file. What every
method gets and what it is scored against is the protocol's (evsim_eval.protocols), scored by evsim_eval.scoring.Case:
exposure-matched against held-out frames unless exposure_matched=False, and per pixel/time class
(evsim_eval.pixel_classes) as "metric@class" beside every per-pixel metric.

Metrics default to the protocol's (evsim_eval.choices.DEFAULT_METRICS: full-range log_rmse and PU21 first against
an HDR reference, the paper's clipped [0, 1] metrics first against held-out frames).

Tuning (tune=True, `evsim evaluate --tune`): the tuning split is the first tune_fraction of every sequence's scored
times; evsim_eval.tuning.tune_cases searches each method's parameters once for the whole dataset on that split (mean
over
the sequences of tune_metric, by default the protocol's TUNE_METRIC: log_rmse against an HDR reference, mse01
against held-out frames), and every method (tuned or without parameters) is then scored on the rest only.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from generators.formats import load
from generators.formats.recording import Recording
from generators.runner import TaskOutcome, raise_failures, run_tasks
from sim import EvsimInputError, OptionError

from . import metrics as metrics_module
from . import scoring
from .choices import DEFAULT_METHODS, DEFAULT_METRICS, PROTOCOLS, TUNE_FRACTION, TUNE_METRIC
from .protocols import dataset_sequences, recording_case
from .tuning import describe_setting, tune_cases


class DatasetScores(NamedTuple):
    """What evaluate_dataset gives.

    Attributes
    ----------
    table : dict
        {method: {sequence: {metric: value}, "mean": {metric: value}}} (the mean over the sequences scored).
    notes : list of str
        Notes on the assumptions made.
    tuning : dict
        {method: setting} (empty without tuning).
    failures : list of TaskOutcome
        The sequences that failed (empty unless strict=False).
    """

    table: dict
    notes: list
    tuning: dict
    failures: list


def request_defaults(protocol: str, metrics: Iterable[str] | None = None, tune_metric: str | None = None
                     ) -> tuple[tuple[str, ...], str]:
    """(metrics, tuning metric) of a request: the protocol's DEFAULT_METRICS and TUNE_METRIC
    (evsim_eval.choices) where None; EvsimInputError naming an unknown protocol."""
    if protocol not in PROTOCOLS:
        raise EvsimInputError(f"unknown protocol {protocol!r}; one of {', '.join(PROTOCOLS)}")
    return (DEFAULT_METRICS[protocol] if metrics is None else tuple(metrics),
            TUNE_METRIC[protocol] if tune_metric is None else tune_metric)


def check_request(protocol: str, methods: Iterable[str], metrics: Iterable[str] | None = None,
                  tune_metric: str | None = None, tune_fraction: float = TUNE_FRACTION) -> None:
    """EvsimInputError naming an unknown protocol, method, metric or tuning metric (None: the protocol's defaults),
    or a tuning fraction outside (0, 1)."""
    metrics, tune_metric = request_defaults(protocol, metrics, tune_metric)
    scoring.check_names(methods, metrics)
    if tune_metric not in metrics_module.METRICS:
        raise EvsimInputError(f"unknown tuning metric {tune_metric!r}; one of {', '.join(metrics_module.METRICS)}")
    if not 0 < tune_fraction < 1:
        raise EvsimInputError(f"the tuning fraction must lie in (0, 1), got {tune_fraction}")


def split_times(n: int, tune_fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The declared tuning split of n scored times: the first ceil(tune_fraction * n) (at least 1) tune, the rest
    are scored (at least 1)."""
    if n < 2:
        why = f"needs at least 2 scored frames per sequence, one has {n}"
        raise OptionError(f"tuning (tune=True) {why}", f"--tune {why}")
    k = min(max(int(math.ceil(tune_fraction * n)), 1), n - 1)
    return np.arange(k), np.arange(k, n)


def evaluate_recording(rec: Recording, *, protocol: str = "reference", methods: Sequence[str] = DEFAULT_METHODS,
                       metrics: Sequence[str] | None = None,
                       method_options: dict[str, dict[str, Any]] | None = None, tuning: dict | None = None,
                       tune_fraction: float = TUNE_FRACTION, exposure_matched: bool = True,
                       by_class: bool = False, sensor: str | None = None) -> tuple[dict, str]:
    """Score methods on one recording.

    Every scored time, or, with tuning ({method: setting} from the tuning search), each method with its setting
    on the times after the tuning split only.

    Parameters
    ----------
    rec : Recording
        The recording (generators.formats.load).
    protocol : {"reference", "interleave"}, optional
        Score against the HDR reference frames, or feed every second frame and score on the others (default
        "reference").
    methods : sequence of str, optional
        akf.METHODS names (default DEFAULT_METHODS).
    metrics : sequence of str, optional
        Metric names; None gives the protocol's (evsim_eval.choices.DEFAULT_METRICS).
    method_options : dict, optional
        {method: {keyword: value}} passed to that method.
    tuning : dict, optional
        {method: setting} from the tuning search; None: no tuning, every scored time.
    tune_fraction : float, optional
        The tuning split's share of the scored times (default TUNE_FRACTION, 1/3).
    exposure_matched : bool, optional
        See recording_case (default True).
    by_class : bool, optional
        Also the per-class scores "metric@class" and shares "share@class" (evsim_eval.scoring.Case.scores; default
        False).
    sensor : str, optional
        A sensor file or preset whose thresholds a recording without recorded ones gets
        (protocols.recording_contrast_or_estimate).

    Returns
    -------
    table : dict
        {method: {metric: value}}.
    notes : str
        Notes joined by "; ".
    """
    metrics = request_defaults(protocol, metrics)[0]
    check_request(protocol, methods, metrics, tune_fraction=tune_fraction)
    case, notes = recording_case(rec, protocol, method_options, exposure_matched, sensor)
    sel = np.arange(case.times.size) if tuning is None else split_times(case.times.size, tune_fraction)[1]
    table = {m: case.scores(case.run(m, sel, (tuning or {}).get(m)), sel, metrics, by_class) for m in methods}
    return table, "; ".join(notes)


def evaluate_sequence_file(file: str | Path, **options: Any) -> tuple[dict, str]:
    """One sequence as a task: evaluate_recording(load(file), **options).

    Parameters
    ----------
    file : str or pathlib.Path
        A recording file.
    **options
        evaluate_recording's keyword arguments.

    Returns
    -------
    table : dict
        {method: {metric: value}}.
    notes : str
        Notes joined by "; ".
    """
    return evaluate_recording(load(file), **options)


def add_means(result: dict) -> dict:
    """Add {"mean": {key: mean over the sequences}} to every method of {method: {sequence: {key: value}}} that
    scored any sequence (NaN values, empty pixel classes, left out; NaN when every one is); returns result.
    A root-mean metric (evsim_eval.metrics.ROOT_MEAN: log_rmse, and its per-class keys "log_rmse@class") has the root
    mean square over the sequences as its mean, the RMSE of sequences of one size pooled, as its per-sequence
    values pool their frames.

    Parameters
    ----------
    result : dict
        {method: {sequence: {key: value}}}, changed in place.

    Returns
    -------
    dict
        result.
    """
    for rows in result.values():
        if rows:
            keys = list(next(iter(rows.values())))
            means = {}
            for k in keys:
                values = np.array([r[k] for r in rows.values() if k in r and not math.isnan(r[k])])
                if not values.size:
                    means[k] = math.nan
                elif k.split("@")[0] in metrics_module.ROOT_MEAN:
                    means[k] = float(np.sqrt(np.mean(values**2)))
                else:
                    means[k] = float(np.mean(values))
            rows["mean"] = means
    return result


def tune_dataset(sequences: Iterable[tuple[str, str | Path]], *, protocol: str, methods: Iterable[str],
                 method_options: dict[str, dict[str, Any]] | None, tune_fraction: float, tune_metric: str,
                 progress: Callable[..., object] | None = None, exposure_matched: bool = True,
                 sensor: str | None = None) -> tuple[dict, list[str]]:
    """({method: setting}, notes): the tuning search of every method over the tuning split of every sequence
    ((name, file) pairs), in this process, scored as the evaluation scores (exposure_matched); the objective is the
    mean of tune_metric over the sequences (evsim_eval.tuning.tune_cases)."""
    cases = [recording_case(load(file), protocol, method_options, exposure_matched, sensor)[0] for _, file in sequences]
    selections = [split_times(case.times.size, tune_fraction)[0] for case in cases]
    settings = {}
    for m in methods:
        tuned = tune_cases(m, cases, selections, tune_metric)
        settings[m] = tuned.setting
        if progress:
            progress(f"tuned {m}: {describe_setting(tuned.setting)} ({len(tuned.trials)} trials)")
    notes = [f"tuning: parameters searched per method on the first {tune_fraction:.0%} of every sequence's scored "
             f"frames (mean {tune_metric}), scores on the rest"]
    return settings, notes + [f"tuned {m}: {describe_setting(s)}" for m, s in settings.items()]


def evaluate_dataset(path: str | Path, *, protocol: str = "reference", methods: Iterable[str] = DEFAULT_METHODS,
                     metrics: Iterable[str] | None = None, method_options: dict[str, dict[str, Any]] | None = None,
                     tune: bool = False, tune_fraction: float = TUNE_FRACTION, tune_metric: str | None = None,
                     workers: int | None = None, scheduler: str | None = None, progress: bool | None = None,
                     strict: bool = True, exposure_matched: bool = True, by_class: bool = True,
                     sensor: str | None = None) -> DatasetScores:
    """Score every sequence of a dataset (a file, an IJRR folder, a generated dataset folder or a folder of .h5
    files), one task per sequence on generators.runner; with tune, the methods' parameters are searched first (see the
    module).

    Parameters
    ----------
    path : str or pathlib.Path
        The dataset.
    protocol : {"reference", "interleave"}, optional
        As evaluate_recording's (default "reference").
    methods : iterable of str, optional
        akf.METHODS names (default DEFAULT_METHODS).
    metrics : iterable of str, optional
        Metric names; None gives the protocol's (evsim_eval.choices.DEFAULT_METRICS).
    method_options : dict, optional
        {method: {keyword: value}} passed to that method.
    tune : bool, optional
        Search the methods' parameters first (default False).
    tune_fraction : float, optional
        The tuning split's share of every sequence's scored times (default TUNE_FRACTION, 1/3).
    tune_metric : str, optional
        The tuning objective; None gives the protocol's (evsim_eval.choices.TUNE_METRIC).
    workers : int, optional
        N local processes (None: see scheduler).
    scheduler : str, optional
        ADDRESS of a Dask cluster; with neither, this process.
    progress : bool, optional
        The tuning's messages and the tasks' progress bar, on stderr: True shows both, False neither, None the
        messages and, on a terminal only, the bar.
    strict : bool, optional
        Raise when sequences fail (default True; EvsimInputError when every one failed on the same bad input, else
        generators.runner.TasksFailed); with strict=False they come back in DatasetScores.failures and the table holds
        the others.
    exposure_matched : bool, optional
        With protocol "interleave", reconstructions averaged over each held-out frame's exposure window (default
        True; else at its mid-exposure time).
    by_class : bool, optional
        Also the per-class scores (evaluate_recording; default True).
    sensor : str, optional
        See evaluate_recording.

    Returns
    -------
    DatasetScores
        The table with its means, the notes, the tuning and the failures.
    """
    methods = tuple(methods)
    metrics, tune_metric = request_defaults(protocol, metrics, tune_metric)
    check_request(protocol, methods, metrics, tune_metric, tune_fraction)
    sequences = dataset_sequences(path)
    tuning, notes = {}, []
    if tune:
        say = None if progress is False else (lambda text: print(text, file=sys.stderr))
        tuning, notes = tune_dataset(sequences, protocol=protocol, methods=methods, method_options=method_options,
                                     tune_fraction=tune_fraction, tune_metric=tune_metric, progress=say,
                                     exposure_matched=exposure_matched, sensor=sensor)
    options = {"protocol": protocol, "methods": methods, "metrics": metrics, "method_options": method_options,
               "tuning": tuning if tune else None, "tune_fraction": tune_fraction,
               "exposure_matched": exposure_matched, "by_class": by_class, "sensor": sensor}
    tasks = [(name, (Path(file).resolve(),), options) for name, file in sequences]
    outcomes = run_tasks(evaluate_sequence_file, tasks, workers=workers, scheduler=scheduler, progress=progress,
                         desc="evaluating")
    failures: list[TaskOutcome] = [o for o in outcomes if not o.ok]
    if strict:
        raise_failures("sequences", failures, len(outcomes))
    table = {m: {} for m in methods}
    sequence_notes = []
    for outcome in outcomes:
        if outcome.ok:
            scores, note = outcome.value
            sequence_notes += [f"{outcome.name}: {note}"] if note else []
            for m in methods:
                table[m][outcome.name] = scores[m]
    return DatasetScores(add_means(table), sequence_notes + notes, tuning, failures)
