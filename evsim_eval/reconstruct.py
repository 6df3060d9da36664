"""Reconstruction of every sequence of a dataset to files: linear float32 EXR frames with their timestamps
(`evsim reconstruct`), each method given what the evaluation protocols give it (evsim_eval.protocols).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

import akf
from generators.formats import load
from generators.formats.exr import write_exr_sequence
from generators.formats.recording import Recording
from sim import EvsimInputError, OptionError

from .choices import KALMAN_METHODS
from .protocols import check_frames, dataset_sequences, method_options_for, recording_contrast, recording_crf


def output_times(rec: Recording, times: str) -> np.ndarray:
    """int64 us output times for `times` (`evsim reconstruct --times`).

    Parameters
    ----------
    rec : Recording
        The recording.
    times : str
        "reference" (the reference times from the first exposure start on), "frames" (every frame's mid-exposure) or
        "fps:N" (N per second from the first exposure start to the last frame's exposure end).

    Returns
    -------
    numpy.ndarray
        int64 times (us).
    """
    check_frames(rec, 1, "reconstruction")
    start, end = int(rec.frame_t_start_us[0]), int(rec.frame_t_end_us[-1])
    if times == "reference":
        if rec.reference_t_us is None:
            why = "reference: the recording has no reference frames (use frames or fps:N)"
            raise OptionError(f"times={why}", f"--times {why}")
        return rec.reference_t_us[rec.reference_t_us >= start].astype(np.int64)
    if times == "frames":
        return rec.frame_t_mid_us.astype(np.int64)
    if times.startswith("fps:"):
        try:
            fps = float(times[4:])
        except ValueError:
            fps = math.nan
        if not (math.isfinite(fps) and fps > 0):
            why = f"{times!r}: fps:N needs a positive rate in Hz"
            raise OptionError(f"times={why}", f"--times {why}")
        return np.arange(start, end + 1, 1e6 / fps).round().astype(np.int64)
    raise OptionError(f"times={times!r}: one of reference, frames, fps:N", f"--times {times!r}: one of reference, "
                      "frames, fps:N")


def reconstruct_dataset(path: str | Path, out_dir: str | Path, *, method: str = "akf", times: str = "reference",
                        method_options: dict[str, Any] | None = None,
                        variance: bool = False) -> list[tuple[str, Path, int]]:
    """Reconstruct every sequence of a dataset with `method` and write float32 EXR folders (frame_NNNNNN.exr and
    timestamps.txt, see generators.formats.exr; values in x units, unclipped for the AKF and the smoother, see
    evsim_eval.protocols), atomically. One sequence: out_dir is its folder; several: out_dir/<name>/.

    Parameters
    ----------
    path : str or pathlib.Path
        The dataset (a file, an IJRR folder, a generated dataset folder or a folder of .h5 files).
    out_dir : str or pathlib.Path
        Where to write.
    method : str, optional
        An akf.METHODS name (default "akf").
    times : str, optional
        The output times, as output_times takes them (default "reference").
    method_options : dict, optional
        Keyword arguments of the method.
    variance : bool, optional
        Also write the state variance P (log^2 of log(I + I0)) as an EXR folder `variance` inside each sequence's
        folder (akf and aks only; default False).

    Returns
    -------
    list of tuple
        (name, folder, number of frames) of every sequence.
    """
    if method not in akf.METHODS:
        raise EvsimInputError(f"unknown method {method!r}; one of {', '.join(sorted(akf.METHODS))}")
    if variance and method not in KALMAN_METHODS:
        raise OptionError(f"variance=True: only {' and '.join(KALMAN_METHODS)} have a variance, not {method!r}",
                          f"--variance: only {' and '.join(KALMAN_METHODS)} have a variance, not --method {method}")
    sequences = dataset_sequences(path)
    written = []
    for name, file in sequences:
        rec = load(file)
        t = output_times(rec, times)
        if t.size == 0:
            raise EvsimInputError(f"{name}: no output time at or after the first exposure start")
        crf, _ = recording_crf(rec)
        options = method_options_for(rec, {method: method_options or {}}).get(method, {})
        if variance:
            options = {**options, "return_variance": True}
        result = akf.METHODS[method](rec.events, rec.frames, rec.frame_t_start_us, rec.frame_t_end_us, crf, t,
                                     contrast=recording_contrast(rec), bit_depth=rec.frame_bit_depth, **options)
        images, p = result if variance else (result, None)
        folder = Path(out_dir) if len(sequences) == 1 else Path(out_dir) / name
        write_exr_sequence(folder, images, t)
        if p is not None:
            write_exr_sequence(folder / "variance", p, t)
        written.append((name, folder, int(t.size)))
    return written
