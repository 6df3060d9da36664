"""HDR reconstruction: frame augmentation, the Asynchronous Kalman Filter, baselines and metrics."""
