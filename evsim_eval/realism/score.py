"""The realism score of one recording against another: what `evsim evaluate REAL --task realism --against SIM`
runs."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from generators.formats import load
from sim import EvsimInputError

from ..protocols import dataset_sequences
from .comparison import Comparison, compare
from .stats import cut, measure, measure_recording, same_clock, shifted


def score_recordings(real: object, sim: object, window_s: tuple[float, float] | None = None) -> Comparison:
    """compare of two generators.formats Recordings, with the real frames' pixel classes. Both are scored on the
    windows where both have events: coverage gaps of either are cut out of both.

    Parameters
    ----------
    real, sim : Recording
        The real recording and the simulation.
    window_s : tuple of float, optional
        (start, end) seconds from each one's origin (see measure_recording); default: the real recording's whole
        event stream.

    Returns
    -------
    Comparison
        The realism scores.
    """
    real_stats = measure_recording(real, window_s)
    sim_stats = measure_recording(sim, like=real_stats,
                                  origin_us=real_stats.origin_us if same_clock(real, sim) else None)
    if sim_stats.gaps_us.size:  # the simulation misses time the real recording covers: score both without it
        windows = cut(real_stats.windows_us, shifted(sim_stats, real_stats.origin_us).gaps_us)
        again = measure(real.events, windows, height=real.height, width=real.width, masks=real_stats.masks)
        real_stats = replace(again, gaps_us=real_stats.gaps_us, notes=real_stats.notes,
                             origin_us=real_stats.origin_us)
        again = measure(sim.events, like=shifted(real_stats, sim_stats.origin_us))
        sim_stats = replace(again, gaps_us=sim_stats.gaps_us, notes=sim_stats.notes)
    return compare(real_stats, sim_stats)


def load_one(path: str | Path, what: str = "the recording") -> object:
    """The Recording at path: a file or IJRR folder evsim reads, or a dataset folder of exactly one sequence (what
    `evsim convert` writes for one clip); EvsimInputError naming `what` otherwise.

    Parameters
    ----------
    path : str or pathlib.Path
        The recording.
    what : str, optional
        What it is, for the error message (default "the recording").

    Returns
    -------
    Recording
        The recording.
    """
    sequences = dataset_sequences(path)
    if len(sequences) != 1:
        raise EvsimInputError(f"{what} {path} holds {len(sequences)} sequences: give one recording")
    return load(sequences[0][1])
