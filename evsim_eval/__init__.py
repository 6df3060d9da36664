"""Evaluation and benchmarking above generation.

- `evaluate_dataset` (every sequence of a dataset, tuned or not, serially or on workers) and `evaluate_recording`
  (one recording), returning `DatasetScores`; `recording_case` (what a protocol gives every method: an
  akf.evaluate.Case); `reconstruct_dataset` (EXR frames of every sequence); `format_table`, `write_json`;
- `evaluate_denoise_dataset`: event denoisers scored against the per-event labels (ROC, AUC) and the
  reconstructions on denoised events.
Defaults and choices: `evsim_eval.choices`. Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {
    "DatasetScores": "evaluate", "evaluate_dataset": "evaluate", "evaluate_recording": "evaluate",
    "recording_case": "protocols",
    "reconstruct_dataset": "reconstruct",
    "format_table": "tables", "write_json": "tables",
    "evaluate_denoise_dataset": "denoisers",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
