"""Gaps in the event stream are missing data (sim.gaps): detected where the stream is busy or gated to the exposures,
and read by the AKF, the smoother and the complementary filter as unknown change, not as none.

Ground truth: a moving texture seen by an ideal DVS and a linear 8-bit camera (40 ms frames, 30 ms exposures), its
true radiance at 3 ms steps; two degraded copies of its events: (a) only those inside the exposures (an
exposure-gated export: 10 ms gaps), (b) random 10-20 ms holes (dropped packets).
"""

import numpy as np
import pytest

import akf
import crf_models
import sim
from evsim_eval import metrics, protocols
from generators.formats.recording import Recording
from sim.errors import InvalidParameterError

LINEAR = crf_models.get("linear")
H, W, DURATION, PERIOD, EXPOSURE, C = 24, 32, 800_000, 40_000, 30_000, 0.15


def _radiance(t_us):
    yy, xx = np.mgrid[0:H, 0:W].astype(float)
    t = t_us * 1e-6
    return np.exp(-1.2 + 0.8 * np.sin(0.45 * (xx - 25 * t)) * np.cos(0.3 * (yy + 10 * t)))


@pytest.fixture(scope="module")
def scene():
    times = np.arange(0, DURATION + 1, 250)
    dvs = sim.DVSParams.preset("ideal", pos_threshold=C, neg_threshold=C)
    events = sim.DVSEmulator(H, W, dvs, seed=0).feed(np.stack([_radiance(t) for t in times]), times)
    ts = np.arange(0, DURATION - PERIOD, PERIOD)
    te = ts + EXPOSURE
    exposed = [np.mean([_radiance(t) for t in np.linspace(s, e, 17)[:-1] + (e - s) / 32], axis=0)
               for s, e in zip(ts, te)]
    frames = np.stack([np.round(LINEAR.forward(x) * 255).astype(np.uint8) for x in exposed])
    out_t = np.arange(ts[0] + EXPOSURE // 2 + 1000, te[-1] - EXPOSURE // 2, 3_000)
    inside = np.zeros(events.size, bool)
    for s, e in zip(ts, te):
        inside |= (events["t"] >= s) & (events["t"] < e)
    rng = np.random.default_rng(1)
    holes, t = [], 20_000
    while t < DURATION - 30_000:
        d = int(rng.integers(10_000, 20_001))
        holes.append((t, t + d))
        t += d + int(rng.integers(40_000, 80_000))
    holes = np.array(holes, np.int64)
    dropped = np.ones(events.size, bool)
    for a, b in holes:
        dropped &= (events["t"] < a) | (events["t"] >= b)
    return {"events": events, "gated": events[inside], "dropped": events[dropped], "holes": holes, "frames": frames,
            "ts": ts, "te": te, "out_t": out_t, "truth": np.stack([_radiance(t) for t in out_t])}


def _score(images, truth):
    return (float(np.mean([metrics.mse(a, b) for a, b in zip(images, truth)])),
            float(np.mean([metrics.ssim(a, b) for a, b in zip(images, truth)])))


def _akf(scene, events, **kw):
    return akf.reconstruct(events, scene["frames"], scene["ts"], scene["te"], LINEAR, scene["out_t"], contrast=C,
                           max_intensity=1.0, **kw)


def test_the_gaps_found_are_the_true_holes(scene):
    assert sim.find_gaps(scene["events"], scene["ts"], scene["te"]).shape == (0, 2)
    gated = sim.find_gaps(scene["gated"], scene["ts"], scene["te"])
    np.testing.assert_array_equal(gated, np.stack([scene["te"][:-1], scene["ts"][1:]], axis=1))
    # without the exposures only the busy-stream rule: every hole, bounded by the events around it (16 per ms)
    assert sim.find_gaps(scene["gated"]).shape[0] == len(scene["ts"]) - 1
    found = sim.find_gaps(scene["dropped"], scene["ts"], scene["te"])
    assert found.shape == scene["holes"].shape
    early, late = scene["holes"][:, 0] - found[:, 0], found[:, 1] - scene["holes"][:, 1]  # the events around it
    assert np.all((early >= 0) & (early < 1000)) and np.all((late >= 0) & (late < 1000)), (found, scene["holes"])


@pytest.mark.parametrize("degraded", ["gated", "dropped"])
def test_the_akf_on_a_stream_with_gaps_stays_near_the_complete_one_and_beats_frames_only(scene, degraded):
    truth = scene["truth"]
    complete = _score(_akf(scene, scene["events"]), truth)
    with_gaps = _score(_akf(scene, scene[degraded]), truth)
    as_no_change = _score(_akf(scene, scene[degraded], gaps_us="none"), truth)
    frames = _score(akf.frames_only(scene["events"], scene["frames"], scene["ts"], scene["te"], LINEAR,
                                    scene["out_t"]), truth)
    assert with_gaps[0] <= 1.25 * complete[0], (with_gaps, complete)
    assert with_gaps[0] <= frames[0] and with_gaps[1] >= frames[1], (with_gaps, frames)
    # reading the gaps as no change costs the AKF (the failure this fixes)
    assert as_no_change[0] > 1.2 * with_gaps[0] and as_no_change[1] < with_gaps[1], (as_no_change, with_gaps)
    smoothed = _score(akf.reconstruct_smoothed(scene[degraded], scene["frames"], scene["ts"], scene["te"], LINEAR,
                                               scene["out_t"], contrast=C, max_intensity=1.0), truth)
    assert smoothed[0] <= frames[0] and smoothed[1] >= frames[1], (smoothed, frames)


@pytest.mark.parametrize("degraded", ["gated", "dropped"])
def test_the_complementary_filter_lets_the_next_frame_take_over_after_a_gap(scene, degraded):
    def cf(**kw):
        return _score(akf.complementary_filter(scene[degraded], scene["frames"], scene["ts"], scene["te"], LINEAR,
                                               scene["out_t"], contrast=C, **kw), scene["truth"])
    with_gaps, as_no_change = cf(), cf(gaps_us="none")
    assert with_gaps[0] < 0.5 * as_no_change[0] and with_gaps[1] > as_no_change[1], (with_gaps, as_no_change)


def test_a_complete_stream_has_no_gaps_and_the_same_result_as_with_gaps_disabled(scene):
    ev, fr, ts, te, out_t = scene["events"], scene["frames"], scene["ts"], scene["te"], scene["out_t"]
    np.testing.assert_array_equal(_akf(scene, ev), _akf(scene, ev, gaps_us="none"))
    np.testing.assert_array_equal(akf.complementary_filter(ev, fr, ts, te, LINEAR, out_t, contrast=C),
                                  akf.complementary_filter(ev, fr, ts, te, LINEAR, out_t, contrast=C, gaps_us="none"))
    # a quiet noisy stream (background activity only) is no busy stream: its long empty spans are not gaps
    rng = np.random.default_rng(0)
    quiet = sim.make_events(np.sort(rng.integers(0, 2_000_000, 300)), rng.integers(0, W, 300),
                            rng.integers(0, H, 300), rng.choice([-1, 1], 300))
    assert sim.find_gaps(quiet).shape == (0, 2)


def test_explicit_gaps_are_taken_as_given_and_checked(scene):
    ev = scene["gated"]
    detected = sim.find_gaps(ev, scene["ts"], scene["te"])
    np.testing.assert_array_equal(_akf(scene, ev), _akf(scene, ev, gaps_us=detected))
    np.testing.assert_array_equal(sim.resolve_gaps(np.array([[5, 9], [0, 6]]), ev, [0], [1]), [[0, 9]])
    for bad in ("all", np.array([[3, 3]]), np.array([1.0, 2.0])):
        with pytest.raises(InvalidParameterError, match="gaps_us"):
            _akf(scene, ev, gaps_us=bad)


def test_the_evaluation_notes_name_the_gaps_and_the_methods_get_them(scene):
    nf = scene["frames"].shape[0]
    rec = Recording(events=scene["gated"], height=H, width=W, frames=scene["frames"], frame_t_start_us=scene["ts"],
                    frame_t_mid_us=(scene["ts"] + scene["te"]) // 2, frame_t_end_us=scene["te"], crf={"name": "linear"},
                    metadata={"config": {"dvs": {"pos_threshold": C, "neg_threshold": C}}})
    case, notes = protocols.recording_case(rec, "interleave")
    gap_notes = [n for n in notes if "read as missing data" in n]
    assert len(gap_notes) == 1 and gap_notes[0].startswith(f"events: {nf - 1} gaps (")
    for name in protocols.GAP_METHODS:
        assert case.options[name]["gaps_us"].shape == (nf - 1, 2)
    complete = Recording(**{**rec.__dict__, "events": scene["events"]})
    _, notes = protocols.recording_case(complete, "interleave")
    assert not [n for n in notes if "missing data" in n]


def test_find_gaps_reads_the_event_times_in_place():
    """Detection costs no copy of the times (the AKF and the CFs run it by default on every call: a copy was 8 bytes
    per event, 60 MiB of bench_akf's 10 M events), and finds both kinds of gap in a long stream."""
    import tracemalloc

    n = 2_000_000
    t = np.arange(n, dtype=np.int64) * 2  # 500k events/s
    t[n // 2:] += 50_000  # a 50 ms hole in a busy stream
    events = np.zeros(n, sim.EVENT_DTYPE)
    events["t"], events["p"] = t, 1
    starts = np.arange(0, int(t[-1]), 10_000)
    gated = events[(events["t"] % 10_000) < 8_000]  # only the events inside 8 ms exposures every 10 ms
    sim.find_gaps(events[:1000], starts[:3], starts[:3] + 8_000)  # (compiled outside the measurement)
    tracemalloc.start()
    busy = sim.find_gaps(events)
    exposures = sim.find_gaps(gated, starts, starts + 8_000)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 1 << 20, peak  # 16 MB for one copy of the times
    np.testing.assert_array_equal(busy, [[t[n // 2 - 1] + 1, t[n // 2]]])
    assert exposures.shape[0] > 300 and np.all(exposures[:, 1] - exposures[:, 0] <= 2_000 + 50_000)
