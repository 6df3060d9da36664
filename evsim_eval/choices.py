"""Import-free names and defaults of the evaluation layer: the `evsim evaluate` parser and the evaluators read them
from here (so `evsim --help` loads no reconstruction code); evsim_eval.evaluate.check_request validates them."""

__all__ = ["PROTOCOLS", "KALMAN_METHODS", "DEFAULT_METHODS", "DEFAULT_METRICS", "TUNE_FRACTION", "TUNE_METRIC",
           "DEMO_SIZE"]

#: reference: score against the HDR reference frames; interleave: feed every second frame and score on the others
PROTOCOLS = ("reference", "interleave")
#: the Kalman methods (akf.METHODS names): the filter and the smoother, which take the AKF's options (leak rate,
#: AKFParams) and can return their state variance
KALMAN_METHODS = ("akf", "aks")
#: the methods `evsim evaluate` scores unless told otherwise (akf.METHODS names)
DEFAULT_METHODS = ("akf", "aks", "cf", "frames")
#: protocol -> the metrics `evsim evaluate` scores unless told otherwise (each table states its normalisation).
#: reference (an HDR truth): the full-range scores first, log_rmse and PU21 PSNR/SSIM over the whole reference, then
#: the paper's [0, 1] metrics (clipped at the white, for parity with its numbers), raw MSE and log-domain MSE;
#: interleave (the truth a held-out LDR frame, clipped already): the paper's [0, 1] metrics first, then raw MSE,
#: log-domain MSE, PU21 SSIM and log_rmse
DEFAULT_METRICS = {"reference": ("log_rmse", "pu21_psnr", "pu21_ssim", "mse01", "ssim01", "mse", "log_mse"),
                   "interleave": ("mse01", "ssim01", "mse", "log_mse", "pu21_ssim", "log_rmse")}
TUNE_FRACTION = 1 / 3  # the tuning split: the first third of every sequence's scored frames
#: protocol -> the metric the tuning minimises unless told otherwise: the full-range log_rmse against an HDR
#: reference, the paper's mse01 against held-out frames
TUNE_METRIC = {"reference": "log_rmse", "interleave": "mse01"}

#: the demo sequence's size, height and width in pixels (evsim_eval.demo, `evsim demo`)
DEMO_SIZE = (90, 120)
