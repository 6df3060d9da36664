"""Dataset evaluation as one task per sequence (generators.runner): serially, on local workers or on a cluster.

evaluate_sequence_file(file, ...) is the task: evsim_eval.evaluate.evaluate_recording of the loaded file.
evaluate_dataset_tasks gathers the tasks' tables into evaluate_dataset's result, {method: {sequence: {metric:
value}, "mean": {metric: value}}}, the mean taken over the sequences scored; sequences that failed come back
separately, so the caller reports them with the scores of the others.
"""

from __future__ import annotations

from .evaluate import (DEFAULT_METHODS, DEFAULT_METRICS, add_means, check_request, dataset_sequences,
                         evaluate_recording)
from generators.formats import load
from generators.runner import TaskOutcome, run_tasks


def evaluate_sequence_file(file, *, protocol: str, methods, metrics, method_options) -> tuple[dict, str]:
    """One sequence as a task: ({method: {metric: value}}, note) of evaluate_recording(load(file), ...)."""
    return evaluate_recording(load(file), protocol=protocol, methods=methods, metrics=metrics,
                              method_options=method_options)


def evaluate_dataset_tasks(path, *, protocol: str = "reference", methods=DEFAULT_METHODS, metrics=DEFAULT_METRICS,
                           method_options=None, workers: int | None = None, scheduler: str | None = None,
                           progress: bool | None = None) -> tuple[dict, list[str], list[TaskOutcome]]:
    """Score every sequence of a dataset, one task each: (result as evaluate_dataset's, notes, failures)."""
    check_request(protocol, methods, metrics)  # refused once here rather than by every task
    sequences = dataset_sequences(path)
    options = {"protocol": protocol, "methods": tuple(methods), "metrics": tuple(metrics),
               "method_options": method_options}
    tasks = [(name, (file.resolve(),), options) for name, file in sequences]
    outcomes = run_tasks(evaluate_sequence_file, tasks, workers=workers, scheduler=scheduler, progress=progress,
                         desc="evaluating")
    result = {m: {} for m in methods}
    notes = []
    for outcome in outcomes:
        if not outcome.ok:
            continue
        table, note = outcome.value
        if note:
            notes.append(f"{outcome.name}: {note}")
        for m in methods:
            result[m][outcome.name] = table[m]
    return add_means(result, metrics), notes, [o for o in outcomes if not o.ok]
