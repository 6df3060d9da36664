"""The event container: a structured numpy array with fields t (int64 us), x, y (uint16), p (int8, -1/+1)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from .errors import EvsimInputError, UnsortedEventsError
from .lazy import lazy_njit

if TYPE_CHECKING:
    import numpy.typing as npt

#: the event record: t (int64 microseconds), x and y (uint16 pixels), p (int8 polarity, +1 ON or -1 OFF)
EVENT_DTYPE = np.dtype([("t", np.int64), ("x", np.uint16), ("y", np.uint16), ("p", np.int8)])


MAX_TIME_US = 1 << 62  # |t| bound of every time (about 146,000 years): differences never overflow int64


def check_times_us(t: npt.ArrayLike, name: str = "t_us") -> npt.NDArray[np.int64]:
    """Integer microsecond times as int64, refusing values an int64 cast would wrap (uint64 >= 2**63) and any
    |t| > 2**62 us (differences of two such times could overflow).

    Parameters
    ----------
    t : array_like
        Integer times (us); a float or other non-integer dtype raises EvsimInputError.
    name : str, optional
        Their name, for the error message (default "t_us").

    Returns
    -------
    numpy.ndarray
        The times as int64 us.
    """
    t = np.asarray(t)
    if t.size and t.dtype.kind not in "iu":
        raise EvsimInputError(f"{name} must be integer microseconds, got dtype {t.dtype}")
    if t.size and (int(t.max()) > MAX_TIME_US or int(t.min()) < -MAX_TIME_US):
        raise EvsimInputError(f"{name} outside +-2**62 us: {int(t.min())}..{int(t.max())}")
    return t.astype(np.int64)


def empty_events(n: int = 0) -> np.ndarray:
    """A zero-filled event array of length n.

    Parameters
    ----------
    n : int, optional
        Number of events (default 0).

    Returns
    -------
    numpy.ndarray
        (n,) EVENT_DTYPE array of zeros.
    """
    return np.zeros(n, dtype=EVENT_DTYPE)


def make_events(t: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike, p: npt.ArrayLike) -> np.ndarray:
    """Build an event array from column arrays (t in microseconds, p in {-1, +1}).

    Parameters
    ----------
    t : array_like
        (n,) integer times, int64 us.
    x, y : array_like
        (n,) integer pixel coordinates in 0..65535.
    p : array_like
        (n,) polarities, +1 (ON) or -1 (OFF).

    Returns
    -------
    numpy.ndarray
        (n,) EVENT_DTYPE array, in the given order (not necessarily time-sorted).
    """
    t = np.asarray(t)
    n = t.shape[0]
    ev = empty_events(n)
    for name, col in (("t", t), ("x", x), ("y", y), ("p", p)):
        col = np.asarray(col)
        if col.shape != (n,):
            raise EvsimInputError(f"event column {name!r} has shape {col.shape}, expected ({n},)")
        if name == "t":
            col = check_times_us(col, "event times") if col.dtype.kind in "iu" else col
        elif name in "xy" and col.size and (col.dtype.kind not in "iu" or col.min() < 0 or col.max() > 65535):
            raise EvsimInputError(f"event column {name!r} must be integers in 0..65535")
        ev[name] = col
    validate_events(ev, require_sorted=False)
    return ev


def validate_events(events: np.ndarray, *, require_sorted: bool = True, name: str = "events") -> np.ndarray:
    """Check an event array at an API boundary and return it unchanged.

    Raises EvsimInputError when the dtype is not EVENT_DTYPE or a polarity is not -1/+1, and
    UnsortedEventsError (naming the first offending index) when require_sorted and t decreases.

    Parameters
    ----------
    events : numpy.ndarray
        The events to check, one-dimensional.
    require_sorted : bool, optional
        Also require non-decreasing times (default True).
    name : str, optional
        Their name, for the error messages (default "events").

    Returns
    -------
    numpy.ndarray
        events itself.
    """
    if not isinstance(events, np.ndarray) or events.dtype != EVENT_DTYPE:
        got = getattr(events, "dtype", type(events).__name__)
        raise EvsimInputError(f"{name} must be a numpy array of sim.EVENT_DTYPE, got {got}")
    if events.ndim != 1:
        raise EvsimInputError(f"{name} must be one-dimensional, got shape {events.shape}")
    if events.size == 0:  # nothing to check (and no kernel to compile: `evsim info` loads no numba)
        return events
    bad = _first_bad_polarity(events["p"])
    if bad >= 0:
        raise EvsimInputError(f"{name}: polarity must be -1 or +1, got {events['p'][bad]} at index {bad}")
    if require_sorted:
        i = first_unsorted_index(events)
        if i >= 0:
            raise UnsortedEventsError(
                f"{name} are not sorted by time: t[{i}]={events['t'][i]} < t[{i - 1}]={events['t'][i - 1]} us"
            )
    return events


def first_unsorted_index(events: np.ndarray) -> int:
    """Index of the first event whose time is earlier than its predecessor's, or -1 when sorted.

    Parameters
    ----------
    events : numpy.ndarray
        EVENT_DTYPE events.

    Returns
    -------
    int
        The index, or -1.
    """
    return _first_decrease(events["t"])


# The field views events["t"], events["p"] are strided: these kernels read them in place, where numpy would first
# copy the column (np.diff, np.searchsorted).
@lazy_njit(cache=True)
def _first_decrease(t) -> int:
    for i in range(1, t.size):
        if t[i] < t[i - 1]:
            return i
    return -1


@lazy_njit(cache=True)
def _first_bad_polarity(p) -> int:
    n = p.size
    for s in range(0, n, 4096):  # a branch-free test per block, the search only in a bad block (5x faster)
        e = min(s + 4096, n)
        bad = False
        for i in range(s, e):
            bad |= np.int64(p[i]) * np.int64(p[i]) != 1
        if bad:
            for i in range(s, e):
                if p[i] != 1 and p[i] != -1:
                    return i
    return -1


@lazy_njit(cache=True)
def _search_left(t, value) -> int:
    """The first index i of the non-decreasing t with t[i] >= value (binary search)."""
    lo, hi = 0, t.size
    while lo < hi:
        mid = (lo + hi) // 2
        if t[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


def is_sorted(events: np.ndarray) -> bool:
    """True when event times never decrease.

    Parameters
    ----------
    events : numpy.ndarray
        EVENT_DTYPE events.

    Returns
    -------
    bool
        Whether t is non-decreasing.
    """
    return first_unsorted_index(events) < 0


def concatenate(chunks: Iterable[np.ndarray], *, sort: bool = False) -> np.ndarray:
    """Join event arrays. With sort=True the result is stably sorted by time (ties keep input order).

    Parameters
    ----------
    chunks : iterable of numpy.ndarray
        EVENT_DTYPE arrays (validated, not required sorted).
    sort : bool, optional
        Sort the result by time (default False: input order).

    Returns
    -------
    numpy.ndarray
        One EVENT_DTYPE array (empty for no chunks).
    """
    chunks = [validate_events(c, require_sorted=False) for c in chunks]
    ev = np.concatenate(chunks) if chunks else empty_events()
    if sort:
        ev = ev[np.argsort(ev["t"], kind="stable")]
    return ev


def slice_time(events: np.ndarray, t_start_us: int, t_end_us: int) -> np.ndarray:
    """The events with t_start_us <= t < t_end_us of a time-sorted array (a view, found by binary search).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted EVENT_DTYPE events.
    t_start_us, t_end_us : int
        The half-open window [t_start_us, t_end_us), int64 us; t_end_us < t_start_us raises EvsimInputError.

    Returns
    -------
    numpy.ndarray
        A view of events.
    """
    if t_end_us < t_start_us:
        raise EvsimInputError(f"slice_time: t_end_us={t_end_us} is before t_start_us={t_start_us}")
    t = events["t"]
    return events[_search_left(t, t_start_us):_search_left(t, t_end_us)]
