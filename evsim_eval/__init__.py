"""Evaluation and benchmarking above generation: reconstruction protocols on recordings and datasets, the tuning
protocol, reconstruction to files, and the scoring of event denoisers."""
