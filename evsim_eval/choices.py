"""Import-free names and defaults of the evaluation layer: the `evsim evaluate` parser and the evaluators read them
from here (so `evsim --help` loads no reconstruction code); evsim_eval.evaluate.check_request validates them."""

__all__ = ["PROTOCOLS", "DEFAULT_METHODS", "DEFAULT_METRICS", "TUNE_FRACTION", "TUNE_METRIC"]

#: reference: score against the HDR reference frames; interleave: feed every second frame and score on the others
PROTOCOLS = ("reference", "interleave")
#: the methods `evsim evaluate` scores unless told otherwise (akf.METHODS names)
DEFAULT_METHODS = ("akf", "aks", "cf", "frames")
#: the paper's [0, 1] protocol, raw MSE, log-domain MSE and PU21 SSIM (each table states its normalisation)
DEFAULT_METRICS = ("mse01", "ssim01", "mse", "log_mse", "pu21_ssim")
TUNE_FRACTION = 1 / 3  # the tuning split: the first third of every sequence's scored frames
#: the metric the tuning minimises unless told otherwise
TUNE_METRIC = "mse01"
