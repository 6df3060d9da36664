"""When a wrapping time counter may read a value after another: the rule of every Prophesee reader and of the
AEDAT 2.0 reader (the counters wrap from the top of their range to its bottom). Plain numpy, so that the readers
import it without numba; the EVT 3.0 decoder compiles it into its kernel (prophesee_kernels).
"""

from __future__ import annotations

import numpy as np

WRAP_WINDOW = 256  # a wrap moves time forward by at most 1/WRAP_WINDOW of the counter's range (see time_step_ok)


def time_step_ok(prev: int | np.ndarray, new: int | np.ndarray, period: int) -> bool | np.ndarray:
    """Whether a time counter of range `period` may read `new` after `prev`: the one rule of every Prophesee reader
    (the 32-bit .dat event time, the 28-bit EVT 2.0 and the 12-bit EVT 3.0 TIME_HIGH).

    With m = period // WRAP_WINDOW (EVT 3.0: 16 TIME_HIGH steps, 65.5 ms; EVT 2.0: 67.1 s; .dat: 16.8 s):
    new >= prev is time moving forward by new - prev, which must be less than period - m; new < prev is a wrap,
    from the top of the range to its bottom, moving time forward by new + period - prev, which must be at most m.
    Anything else is a time that goes back (a step back, or across zero: from near the bottom of the range to
    near its top), i.e. a corrupt file. So one corrupt value cannot pass for a wrap: a value just below an early
    time reads as near the top, and the step to it is refused. Works on ints and numpy arrays alike (in numba
    kernels as _time_step_ok). Metavision's EVT 3.0 decoder counts a wrap for a drop of at least 4085 of 4096
    steps, which this rule accepts too.

    Parameters
    ----------
    prev, new : int or numpy.ndarray
        The counter's previous and new values, in [0, period) (counter ticks).
    period : int
        The counter's range (ticks).

    Returns
    -------
    bool or numpy.ndarray
        Whether each step is allowed (time forward, or a wrap).
    """
    m = period // WRAP_WINDOW
    return ((new >= prev) & (new - prev < period - m)) | ((new < prev) & (prev - new >= period - m))
