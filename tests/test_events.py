import numpy as np
import pytest

import sim


def _events(ts):
    n = len(ts)
    return sim.make_events(ts, np.arange(n) % 5, np.arange(n) % 3, np.where(np.arange(n) % 2, 1, -1))


def test_dtype_fields_and_types():
    assert sim.EVENT_DTYPE.names == ("t", "x", "y", "p")
    assert sim.EVENT_DTYPE["t"] == np.int64 and sim.EVENT_DTYPE["p"] == np.int8
    assert sim.EVENT_DTYPE["x"] == np.uint16 and sim.EVENT_DTYPE["y"] == np.uint16


def test_slice_time_is_half_open_and_exact():
    ev = _events([0, 5, 10, 10, 15, 20])
    s = sim.slice_time(ev, 10, 20)
    assert list(s["t"]) == [10, 10, 15]
    assert sim.slice_time(ev, 21, 30).size == 0


def test_concatenate_sort_is_stable():
    a = _events([0, 10, 20])
    b = _events([5, 10, 25])
    b["x"] = 99
    c = sim.concatenate([a, b], sort=True)
    assert list(c["t"]) == [0, 5, 10, 10, 20, 25]
    assert sim.is_sorted(c)
    # the tie at t=10 keeps input order: a's event before b's
    ties = c[c["t"] == 10]
    assert ties["x"][0] != 99 and ties["x"][1] == 99


def test_unsorted_detected_with_index():
    ev = _events([0, 10, 5, 20])
    assert not sim.is_sorted(ev)
    assert sim.first_unsorted_index(ev) == 2
    with pytest.raises(sim.UnsortedEventsError, match=r"t\[2\]=5"):
        sim.validate_events(ev)


def test_bad_polarity_and_dtype_rejected():
    with pytest.raises(sim.EvsimInputError, match="polarity"):
        sim.make_events([0], [0], [0], [0])
    with pytest.raises(sim.EvsimInputError, match="EVENT_DTYPE"):
        sim.validate_events(np.zeros(3))
