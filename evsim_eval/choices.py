"""Import-free names and defaults of the evaluation layer: the `evsim evaluate` parser and the evaluators read them
from here (so `evsim --help` loads no reconstruction code); evsim_eval.evaluate.check_request validates them."""

PROTOCOLS = ("reference", "interleave")
DEFAULT_METHODS = ("akf", "cf", "frames")
#: the paper's [0, 1] protocol, raw MSE, log-domain MSE and PU21 SSIM (each table states its normalisation)
DEFAULT_METRICS = ("mse01", "ssim01", "mse", "log_mse", "pu21_ssim")
TUNE_FRACTION = 1 / 3  # the tuning split: the first third of every sequence's scored frames
TUNE_METRIC = "mse01"
