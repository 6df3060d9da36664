"""Evaluation and benchmarking above generation.

- `evaluate_dataset` (every sequence of a dataset, tuned or not, serially or on workers) and `evaluate_recording`
  (one recording), returning `DatasetScores`; `recording_case` (what a protocol gives every method: an
  evsim_eval.scoring.Case); `reconstruct_dataset` (EXR frames of every sequence); `format_table`, `write_json`;
- `evaluate_denoise_dataset`: event denoisers scored against the per-event labels (ROC, AUC) and the
  reconstructions on denoised events.
- scoring one sequence: `evaluate_sequence` (evsim_eval.scoring: the `Case` every protocol and the tuning objective
  score through); metrics: `log_rmse` (full range), `mse`, `psnr`, `ssim`, `mse01`, `ssim01` (clipped at a white),
  `log_mse`, `pu21_encode`, `pu21_psnr`, `pu21_ssim`, `score`, `METRICS` (by name), `NORMALISATION` (how each one
  normalises) (evsim_eval.metrics); tuning: `tune`, `Tuned`, `SEARCH_SPACES` (evsim_eval.tuning); the pixel and time
  classes of per-class scores (evsim_eval.pixel_classes); exposure-matched averaging (evsim_eval.exposure).
Defaults and choices: `evsim_eval.choices`. Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {
    "DatasetScores": "evaluate", "evaluate_dataset": "evaluate", "evaluate_recording": "evaluate",
    "recording_case": "protocols",
    "reconstruct_dataset": "reconstruct",
    "format_table": "tables", "write_json": "tables",
    "evaluate_denoise_dataset": "denoisers",
    "evaluate_sequence": "scoring",
    **dict.fromkeys(("log_rmse", "mse", "psnr", "ssim", "mse01", "ssim01", "log_mse", "pu21_encode", "pu21_psnr",
                     "pu21_ssim", "score", "METRICS", "NORMALISATION"), "metrics"),
    "tune": "tuning", "Tuned": "tuning", "SEARCH_SPACES": "tuning",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
