"""DVS emulator API: determinism and chunking invariance, threshold maps, entry points, and input errors."""

import sys

import numba
import numpy as np
import pytest

import sim
from sim.dvs_kernels import ST_LOG

H, W = 18, 22


def moving_scene(n=60, seed=0):
    """An HDR blob pattern drifting across the sensor, 1 ms frames, and its times."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:H, 0:W]
    t = np.arange(n)
    cx, cy = rng.uniform(0, W, 5), rng.uniform(0, H, 5)
    log_i = sum(3 * np.exp(-((xx - cx[i] - 0.3 * t[:, None, None]) ** 2 + (yy - cy[i]) ** 2) / 8) for i in range(5))
    return np.exp(log_i - 4).astype(np.float32), (t * 1000 + 5000).astype(np.int64)


NOISY = sim.DVSParams.preset("noisy", shot_noise_hz=50.0, hot_pixel_fraction=0.02)


def as_bytes(result):
    events, labels = result
    return events.tobytes() + labels.tobytes()


def test_same_seed_bit_identical_and_chunking_invariant():
    frames, times = moving_scene()
    whole = sim.emulate(frames, times, NOISY, seed=7, return_labels=True)
    assert whole[0].size > 500 and set(np.unique(whole[1])) == {0, 1, 2, 3}
    assert as_bytes(whole) == as_bytes(sim.emulate(frames, times, NOISY, seed=7, return_labels=True))
    emu = sim.DVSEmulator(H, W, NOISY, seed=7, return_labels=True)
    per_frame = [emu.feed(f, t) for f, t in zip(frames, times)]
    joined = (np.concatenate([p[0] for p in per_frame]), np.concatenate([p[1] for p in per_frame]))
    assert as_bytes(joined) == as_bytes(whole)
    emu = sim.DVSEmulator(H, W, NOISY, seed=np.random.SeedSequence(7), return_labels=True)
    cuts = [0, 1, 2, 17, 18, 45, 60]
    chunks = [emu.feed(frames[a:b], times[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    joined = (np.concatenate([c[0] for c in chunks]), np.concatenate([c[1] for c in chunks]))
    assert as_bytes(joined) == as_bytes(whole)
    assert as_bytes(sim.emulate(frames, times, NOISY, seed=8, return_labels=True)) != as_bytes(whole)


def test_iterator_inputs_match_array_input():
    frames, times = moving_scene()
    whole = sim.emulate(frames, times, NOISY, seed=1)
    assert sim.emulate(iter(frames), times, NOISY, seed=1).tobytes() == whole.tobytes()
    pairs = ((f, t) for f, t in zip(frames, times))
    assert sim.emulate(pairs, None, NOISY, seed=1).tobytes() == whole.tobytes()


def test_thread_count_does_not_change_events():
    frames, times = moving_scene()
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = sim.emulate(frames, times, NOISY, seed=2, return_labels=True)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = sim.emulate(frames, times, NOISY, seed=2, return_labels=True)
    finally:
        numba.set_num_threads(before)
    assert as_bytes(one) == as_bytes(many)


def test_events_sorted_by_time_then_row_then_column_within_frame_interval():
    frames, times = moving_scene()
    events = sim.emulate(frames, times, NOISY, seed=3)
    order = np.lexsort((events["x"], events["y"], events["t"]))
    np.testing.assert_array_equal(order, np.arange(events.size))
    assert events["t"].min() > times[0] and events["t"].max() <= times[-1]


def test_small_buffers_spill_rows_without_changing_events():
    """Rows outgrowing the first event buffer continue in buffers of their own (grown as often as needed) and are
    gathered from the spill: the same events and state as a roomy run."""
    frames, times = moving_scene()
    a = sim.DVSEmulator(H, W, NOISY, seed=4)
    a.feed(frames[:5], times[:5])
    a._row_rate = 0.0  # buffers of 16 events per row: busy rows outgrow them
    b = sim.DVSEmulator(H, W, NOISY, seed=4)
    b.feed(frames[:5], times[:5])
    b._row_rate = 100.0
    assert a.feed(frames[5:], times[5:]).tobytes() == b.feed(frames[5:], times[5:]).tobytes()
    for x, y in zip(a._state, b._state):
        np.testing.assert_array_equal(x, y)


def test_a_row_outgrowing_its_buffer_many_times_in_one_interval_keeps_every_event():
    """A 50x brightness step with no refractory: each pixel fires floor(ln 50 / C) = 19 ON events within one frame
    interval (its own _pixel_events path), so rows sized for 16 events outgrow their buffer several times."""
    ideal = sim.DVSParams.preset("ideal")
    rng = np.random.default_rng(3)
    base = np.exp(rng.uniform(-2, 2, (40, 64))).astype(np.float32)
    frames, times = np.stack([base, base, base * 50]), np.array([0, 1000, 2000], dtype=np.int64)
    out = []
    for row_rate in (0.0, 4096.0):  # buffers of 16 events per row, or room for all
        emu = sim.DVSEmulator(40, 64, ideal, seed=1, return_labels=True)
        emu.feed(frames[:2], times[:2])
        emu._row_rate = row_rate
        out.append((as_bytes(emu.feed(frames[2], times[2])), emu._state))
    assert out[0][0] == out[1][0]
    for a, b in zip(out[0][1], out[1][1]):
        np.testing.assert_array_equal(a, b)
    events = sim.emulate(frames, times, ideal, seed=1)
    assert events.size == 40 * 64 * int(np.log(50) / 0.2) and np.all(events["p"] == 1)
    assert events.tobytes() == out[0][0][:events.nbytes]


def test_single_frame_feeds_at_high_event_rates_match_one_stack():
    """Frame by frame, the emulating threads count their rows' event times (spilled rows included) for one
    counting sort: the same events as one stack, on one thread or several."""
    rng = np.random.default_rng(5)
    frames = np.exp(rng.uniform(-3, 3, (6, 128, 64))).astype(np.float32)  # several events per pixel and frame
    times = np.arange(6, dtype=np.int64) * 1000
    whole = sim.emulate(frames, times, NOISY, seed=5, return_labels=True)
    before = numba.get_num_threads()
    try:
        for threads in (1, numba.config.NUMBA_NUM_THREADS):
            numba.set_num_threads(threads)
            emu = sim.DVSEmulator(128, 64, NOISY, seed=5, return_labels=True)  # two row parts (64 rows)
            parts = [emu.feed(frames[0], times[0])]
            for k in range(1, 6):
                if k == 4:  # buffers of 121 events per row (~166 needed): rows overflow and spill
                    emu._row_rate = 70.0
                parts.append(emu.feed(frames[k], times[k]))
            joined = (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))
            assert whole[0].size > 6 * 4096
            assert as_bytes(joined) == as_bytes(whole)
    finally:
        numba.set_num_threads(before)


def test_an_exception_a_signal_handler_raises_while_numba_boxes_arrays_surfaces_as_itself():
    """Numba boxes returned arrays with Python code, where a signal handler's exception (Ctrl-C, the CLI's SIGTERM)
    would come out as a SystemError: the emulator's kernel calls re-raise the handler's exception itself."""
    import signal

    from numba import njit

    from sim.dvs import _returning_arrays

    @njit(nogil=True)
    def two_arrays(n):
        a = np.empty(n)
        for i in range(n):
            a[i] = 0.5 * i
        return a[:2], np.zeros(3, dtype=np.int64)

    class Stop(Exception):
        pass

    def handler(*_):
        raise Stop

    two_arrays(10)
    previous = signal.signal(signal.SIGALRM, handler)
    try:
        for k in range(20):  # a bare call gives SystemError in most of these
            with pytest.raises(Stop):  # (the timer set inside: on a loaded machine it may fire before the loop)
                signal.setitimer(signal.ITIMER_REAL, 2e-4 + 2e-5 * k)
                while True:
                    _returning_arrays(two_arrays, 20000)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    with pytest.raises(SystemError):  # other SystemErrors pass unchanged
        _returning_arrays(lambda: (_ for _ in ()).throw(SystemError("other")))


def test_in_parallel_runs_every_part_once_and_reraises():
    from sim.parallel import in_parallel

    seen = []
    in_parallel(lambda a, b: seen.extend(range(a, b)), 103, 5, per_thread=3)
    assert sorted(seen) == list(range(103))

    def fail(a, b):
        if a > 0:
            raise KeyError(a)

    if numba.get_num_threads() > 1:
        with pytest.raises(KeyError):
            in_parallel(fail, 100, 1, per_thread=2)


def test_threshold_map_spread_and_separate_on_off():
    params = sim.DVSParams(pos_threshold=0.25, neg_threshold=0.15, threshold_sigma=0.03)
    emu = sim.DVSEmulator(100, 120, params, seed=0)
    c_on, c_off = emu.threshold_map.astype(np.float64)
    n = c_on.size
    assert emu.threshold_map.shape == (2, 100, 120) and emu.threshold_map.dtype == np.float32
    assert abs(c_on.mean() - 0.25) < 5 * 0.03 / np.sqrt(n)
    assert abs(c_off.mean() - 0.15) < 5 * 0.03 / np.sqrt(n)
    for c in (c_on, c_off):
        assert c.std() == pytest.approx(0.03, abs=5 * 0.03 / np.sqrt(2 * n))
    assert abs(np.corrcoef(c_on.ravel(), c_off.ravel())[0, 1]) < 5 / np.sqrt(n)
    wide = sim.DVSEmulator(50, 50, params.replace(threshold_sigma=0.2, min_threshold=0.05), seed=0).threshold_map
    assert wide.min() == np.float32(0.05) and np.mean(wide == np.float32(0.05)) > 0.05


def test_state_is_inspectable():
    frames, times = moving_scene(5)
    params = sim.DVSParams.preset("ideal")
    emu = sim.DVSEmulator(H, W, params, seed=0)
    assert emu.time_us is None
    assert emu.feed(frames[0], times[0]).size == 0  # the first frame only initialises
    np.testing.assert_allclose(emu.reference_log, np.log(frames[0].astype(np.float64) + 1e-4))
    events = emu.feed(frames[1:], times[1:])
    assert emu.time_us == times[-1]
    last = emu.last_event_us
    fired = np.zeros((H, W), bool)
    fired[events["y"], events["x"]] = True
    assert np.all(last[~fired] == sim.NO_EVENT_US)
    latest = np.full((H, W), sim.NO_EVENT_US)
    np.maximum.at(latest, (events["y"], events["x"]), events["t"])
    np.testing.assert_array_equal(last, latest)
    assert np.all(np.abs(emu.log_intensity - emu.reference_log) < 0.2 + 1e-6)


def test_integer_radiance_accepted_as_float():
    frames, times = moving_scene(10)
    ints = np.round(frames * 1000).astype(np.uint16)
    a = sim.emulate(ints, times, NOISY, seed=0)
    b = sim.emulate(ints.astype(np.float64), times, NOISY, seed=0)
    assert a.tobytes() == b.tobytes()


def test_cli_demo_call_works():
    frames, times = moving_scene(20)
    events = sim.emulate(np.broadcast_to(frames[:1], frames.shape), times, sim.DVSParams.preset("davis346"), seed=0)
    assert events.dtype == sim.EVENT_DTYPE


@pytest.mark.parametrize(
    "bad, message",
    [
        (np.nan, "NaN"),
        (np.inf, "infinite"),
        (-1.0, "negative"),
    ],
)
def test_bad_radiance_values(bad, message):
    emu = sim.DVSEmulator(4, 5, seed=0)
    frame = np.ones((4, 5))
    emu.feed(frame, 0)
    frame[2, 3] = bad
    with pytest.raises(sim.EvsimInputError, match=message):
        emu.feed(frame, 10)
    assert emu.time_us == 0
    emu.feed(np.ones((4, 5)), 10)  # the emulator is still usable after a rejected frame


@pytest.mark.parametrize(
    "radiance, t",
    [
        (np.ones((5, 4)), 0),  # transposed
        (np.ones((2, 4, 5)), 0),  # stack with a scalar time
        (np.ones((2, 4, 5)), np.array([0, 1, 2])),  # times do not match frames
        (np.ones((4, 5), dtype=complex), 0),
        (np.ones((4, 5), dtype=object), 0),
        (np.ones((4, 5), dtype=bool), 0),
        (np.ones((4, 5)), 1.5),  # time not integer microseconds
    ],
)
def test_bad_shape_dtype_or_time_type(radiance, t):
    with pytest.raises(sim.EvsimInputError):
        sim.DVSEmulator(4, 5, seed=0).feed(radiance, t)


def test_time_not_strictly_increasing():
    emu = sim.DVSEmulator(4, 5, seed=0)
    with pytest.raises(sim.TimeOrderError, match="strictly increasing"):
        emu.feed(np.ones((3, 4, 5)), np.array([0, 10, 10]))
    emu.feed(np.ones((4, 5)), 100)
    with pytest.raises(sim.TimeOrderError, match="previous frame time"):
        emu.feed(np.ones((4, 5)), 100)
    with pytest.raises(sim.TimeOrderError):
        emu.feed(np.ones((2, 4, 5)), np.array([50, 200]))


@pytest.mark.parametrize(
    "field, value",
    [
        ("pos_threshold", 0.0),
        ("neg_threshold", -0.1),
        ("threshold_sigma", -0.01),
        ("min_threshold", 0.0),
        ("refractory_us", -1),
        ("refractory_us", 2.5),
        ("cutoff_hz", -1.0),
        ("full_illumination", 0.0),
        ("dark_fraction", 0.0),
        ("shot_noise_hz", -1.0),
        ("dark_shot_noise_hz", -1.0),
        ("leak_hz", float("nan")),
        ("leak_spread", -0.5),
        ("hot_pixel_fraction", 1.5),
        ("hot_pixel_hz", float("inf")),
    ],
)
def test_invalid_parameters(field, value):
    with pytest.raises(sim.InvalidParameterError, match=field):
        sim.DVSParams(**{field: value})


def test_invalid_preset_size_and_seed():
    with pytest.raises(sim.InvalidParameterError, match="unknown DVS preset"):
        sim.DVSParams.preset("davis999")
    with pytest.raises(sim.InvalidParameterError, match="width"):
        sim.DVSEmulator(4, 0)
    with pytest.raises(sim.InvalidParameterError, match="seed"):
        sim.DVSEmulator(4, 4, seed=-3)
    assert set(sim.DVS_PRESETS) >= {"ideal", "davis346", "noisy"}
    ideal = sim.DVSParams.preset("ideal")
    assert ideal.refractory_us == 0 and ideal.threshold_sigma == 0 and ideal.shot_noise_hz == 0


def test_iterator_and_source_inputs_checked_and_equivalent():
    frames, times = moving_scene(12)
    with pytest.raises(sim.EvsimInputError, match="fewer frames"):
        sim.emulate(iter(frames), np.r_[times, times[-1] + 1], NOISY, seed=0)
    with pytest.raises(sim.EvsimInputError, match="more frames"):
        sim.emulate(iter(frames), times[:-1], NOISY, seed=0)
    swapped = frames.astype(frames.dtype.newbyteorder(">"))  # other byte orders are converted
    assert sim.emulate(swapped, times, NOISY, seed=0).tobytes() == sim.emulate(frames, times, NOISY, seed=0).tobytes()

    class Source:
        height, width, duration_us = H, W, int(times[-1])

        def radiance(self, t_us):
            return frames[int(np.flatnonzero(times == t_us)[0])]

        def max_speed_px_per_s(self):
            return 300.0

    via_source = sim.emulate_source(Source(), times, NOISY, seed=0, return_labels=True)
    assert as_bytes(via_source) == as_bytes(sim.emulate(frames, times, NOISY, seed=0, return_labels=True))


def test_refractory_never_violated_on_moving_scene_with_all_noise():
    frames, times = moving_scene()
    params = NOISY.replace(refractory_us=700)
    events, labels = sim.emulate(frames, times, params, seed=5, return_labels=True)
    assert np.count_nonzero(labels == 0) > 200 and np.count_nonzero(labels != 0) > 50
    ev = events[np.lexsort((events["t"], events["x"], events["y"]))]
    same = (np.diff(ev["y"].astype(int)) == 0) & (np.diff(ev["x"].astype(int)) == 0)
    gaps = np.diff(ev["t"])[same]
    assert 700 <= gaps.min() < 1000  # the dead time binds but is never crossed


def _emulate_small(_):
    frames = np.random.default_rng(0).random((5, 60, 80)).astype(np.float32)
    return sim.emulate(frames, np.arange(5) * 1000).view(np.uint8).tobytes()


@pytest.mark.skipif(sys.platform == "win32", reason="fork start method")
def test_emulator_runs_in_a_forked_child_after_the_parent_used_its_threads():
    import multiprocessing

    parent = _emulate_small(0)  # the parent's row threads exist now; a forked child must not wait for them
    with multiprocessing.get_context("fork").Pool(1) as pool:
        child = pool.map_async(_emulate_small, [0]).get(timeout=120)[0]
    assert child == parent


def test_log_input_gives_the_events_of_radiance_input_and_mixes_with_it():
    """feed_log(log(radiance + dark_level)) is feed(radiance) with the log taken (float32 input, its exp the
    photocurrent: within a float32 ulp of it), so nearly every event is the same; the two may alternate."""
    frames, times = moving_scene(n=120)
    frames = frames * 50
    params = sim.DVSParams.preset("noisy", full_illumination=float(frames.max()))
    plain = sim.DVSEmulator(H, W, params, 3, return_labels=True)
    events, labels = plain.feed(frames, times)
    logs = np.log(frames.astype(np.float64) + plain.dark_level).astype(np.float32)
    mixed = sim.DVSEmulator(H, W, params, 3, return_labels=True)
    parts = [mixed.feed_log(logs[:50], times[:50]), mixed.feed(frames[50:80], times[50:80]),
             mixed.feed_log(logs[80:], times[80:])]
    got = np.concatenate([p[0] for p in parts])
    assert events.size > 2000 and abs(got.size / events.size - 1) < 2e-3
    same = np.isin(events[["t", "x", "y", "p"]], got[["t", "x", "y", "p"]])
    assert same.mean() > 0.995
    np.testing.assert_allclose(mixed.log_intensity, plain.log_intensity, atol=1e-6)


def test_log_input_errors_name_the_log():
    dvs = sim.DVSEmulator(H, W, sim.DVSParams(full_illumination=10.0), 0)
    good = np.full((H, W), np.log(5.0 + dvs.dark_level), np.float32)
    bad = good.copy()
    bad[2, 3] = np.nan
    with pytest.raises(sim.EvsimInputError, match=r"log_radiance has NaN values, first in frame 0 at \(y=2, x=3\)"):
        dvs.feed_log(bad, 0)
    bad[2, 3] = np.log(dvs.dark_level) - 0.01
    with pytest.raises(sim.EvsimInputError, match=r"below log\(dark_level\).*negative radiance"):
        dvs.feed_log(bad, 0)
    bad[2, 3] = np.log(dvs.dark_level) - 1e-6  # float32 rounding of log(0 + dark_level): radiance 0
    dvs.feed_log(bad, 0)
    assert dvs.time_us == 0


def test_log_input_unchecked_gives_the_checked_events_and_skips_only_the_check():
    frames, times = moving_scene(n=40)
    params = sim.DVSParams.preset("noisy", full_illumination=float(frames.max()))
    checked, unchecked = (sim.DVSEmulator(H, W, params, 5) for _ in range(2))
    logs = np.log(frames.astype(np.float64) + checked.dark_level).astype(np.float32)
    a, b = checked.feed_log(logs, times), unchecked.feed_log(logs, times, check_finite=False)
    assert a.size > 500 and np.array_equal(a, b)
    below = np.full((H, W), np.log(unchecked.dark_level) - 1.0, np.float32)  # taken as the floor, not an error
    unchecked.feed_log(below, int(times[-1]) + 1000, check_finite=False)
    with pytest.raises(sim.EvsimInputError, match="below log"):
        checked.feed_log(below, int(times[-1]) + 1000)
    np.testing.assert_allclose(unchecked._state[ST_LOG], np.log(unchecked.dark_level), atol=1e-6)  # the log response
    with pytest.raises(sim.InvalidParameterError, match="check_finite must be True or False, got 'no'"):
        unchecked.feed_log(logs[0], int(times[-1]) + 2000, check_finite="no")  # (a truthy string: it would check)
