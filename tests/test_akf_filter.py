"""akf.reconstruct end to end on small inputs: closed-form variance and gain without events, exactness of
publishing, convergence to the true log intensity with an ideal sensor, and input validation. Tests of the per-pixel
filter turn the output smoothing off (smooth_range=0: akf.smoothing mixes neighbouring pixels)."""

import numpy as np
import pytest

import akf
import crf_models
import sim
from akf.noise import frame_measurement
from sim.errors import EvsimInputError, InvalidParameterError, TimeOrderError, UnsortedEventsError

LINEAR = crf_models.get("linear")


def _static(h=3, w=4, n=4, value=100, period=40_000, exposure=8_000):
    frames = np.full((n, h, w), value, np.uint8)
    frames[:, 0, 0] = 255  # one clipped pixel
    ts = np.arange(n) * period
    return frames, ts, ts + exposure


def test_static_scene_without_events_has_closed_form_variance_and_gain():
    frames, ts, te = _static()
    times = np.array([0, 3_999, 4_000, 5_000, 30_000, 71_000, 200_000])
    for frame_update in (False, True):
        params = akf.AKFParams(frame_update=frame_update, smooth_range=0.0)
        img, P, K = akf.reconstruct(sim.empty_events(), frames, ts, te, LINEAR, times, params=params,
                                    return_variance=True, return_gain=True)
        meas = frame_measurement(frames[0] / 255.0, LINEAR, params)
        R = meas.r
        info = 1 / params.p0 + (times[:, None, None] - ts[0]) * 1e-6 / R[None]  # eq. 20, constant R
        # a clipped pixel sits at its clip level, which says only that the truth is at or beyond it: P stays p0
        info = np.where(meas.clipped[None], 1 / params.p0, info)
        if frame_update:  # each frame passed (mid-exposure at or before t) adds 1 / R_frame where it is not clipped,
            # R_frame the frame's own noise: noise-free 8-bit frames, so their quantisation, 1/12 DN^2
            r_frame = (1 / 12 / 255**2) / (meas.intensity + params.i0) ** 2
            passed = np.searchsorted((ts + te) / 2, times, side="right")
            info = info + np.where(meas.clipped, 0, 1)[None] * passed[:, None, None] / r_frame[None]
        np.testing.assert_allclose(P, 1 / info, rtol=1e-5)
        np.testing.assert_allclose(K, (1 / info) / R[None], rtol=1e-5)  # eq. 18 (the continuous measurement's R)
        # the state stays at the (bias-corrected) frame log: I = exp(L^F) - I0
        np.testing.assert_allclose(img, np.broadcast_to(np.exp(meas.log) - params.i0, img.shape), rtol=1e-6)
        assert img[0, 1, 1] == pytest.approx(100 / 255, rel=1e-5)
        # the clipped pixel has the saturated variance: its gain is max_variance / sigma_im2 times smaller
        assert meas.rbar[0, 0] == params.max_variance and meas.rbar[1, 1] == params.sigma_im2


def _clipping_scene():
    """A texture panned at 40 px/s whose log radiance spans 3 log units, so pixels move in and out of the AHDR
    window CRF's unclipped range; noise-free events (c = 0.1) and 8-bit frames exposed for 4 ms every 33 ms."""
    h, w, dur = 24, 32, 400_000
    yy, xx = np.mgrid[0:h, 0:w].astype(float)

    def radiance(t_us):
        t = t_us * 1e-6
        return np.exp(-1.3 + 1.5 * np.sin(0.3 * (xx - 40 * t)) * np.cos(0.2 * (yy + 10 * t)))

    times = np.arange(0, dur + 1, 250)
    dvs = sim.DVSParams.preset("ideal", pos_threshold=0.1, neg_threshold=0.1)
    events = sim.DVSEmulator(h, w, dvs, seed=0).feed(np.stack([radiance(t) for t in times]), times)
    ts = np.arange(0, dur - 10_000, 33_000)
    te = ts + 4_000
    frames = np.stack([np.round(WINDOW.forward(np.mean([radiance(t) for t in np.linspace(s, e, 8, endpoint=False)
                                                        + (e - s) / 16], axis=0)) * 255).astype(np.uint8)
                       for s, e in zip(ts, te)])
    return radiance, events, frames, ts, te


WINDOW = crf_models.get("window")


def test_noise_free_akf_matches_a_well_exposed_frame_within_its_noise_at_the_frame_time():
    """At each frame's mid-exposure time, in the pixels the frame measures (not clipped), the noise-free AKF is
    within the frame's own noise of the frame (read_noise_dn=0: noise-free frames, so their quantisation), and as
    close to the true log radiance as the frame; the paper's filter (continuous measurement only) is tens of
    sigmas (sqrt(R) of eq. 9) away where pixels leave a clipped region."""
    radiance, events, frames, ts, te = _clipping_scene()
    tau = (ts + te) // 2
    ks = np.arange(3, len(ts) - 1)
    for frame_update in (True, False):
        params = akf.AKFParams(i0=1e-4, frame_update=frame_update, read_noise_dn=0.0)
        out = akf.reconstruct(events, frames, ts, te, WINDOW, tau[ks], params=params, contrast=0.1)
        sigmas, err, frame_err = [], [], []
        for img, k in zip(out, ks):
            meas = frame_measurement(frames[k] / 255.0, WINDOW, params)
            well = ~meas.clipped
            truth = np.log(radiance(tau[k]) + params.i0)
            noise = akf.frame_noise.frame_log_variance(frames[k] / 255.0, WINDOW, 0.0, i0=params.i0) \
                if frame_update else meas.r  # the frame's own (quantisation), or eq. 9's R
            sigmas.append((np.abs(np.log(img + params.i0) - meas.log) / np.sqrt(noise))[well])
            err.append(np.abs(np.log(img + params.i0) - truth)[well])
            frame_err.append(np.abs(meas.log - truth)[well])
        sigmas, err, frame_err = map(np.concatenate, (sigmas, err, frame_err))
        assert sigmas.size > 3000
        if frame_update:
            assert sigmas.max() < 1.0
            assert err.mean() < 1.5 * frame_err.mean()
        else:
            assert np.percentile(sigmas, 95) > 20 and err.mean() > 20 * frame_err.mean()


def test_frames_of_different_exposure_share_frame_0_units():
    """A static scene seen with alternating 2 ms / 8 ms exposures: CRF^-1 is scaled by T_0 / T_k, so every method
    reports the same intensity throughout (the long frames' DN are four times larger)."""
    frames = np.array([np.full((2, 3), 40), np.full((2, 3), 160)] * 2, np.uint8)
    ts = np.arange(4) * 30_000
    te = ts + np.array([2_000, 8_000, 2_000, 8_000])
    times = np.array([1_000, 20_000, 34_000, 61_000, 99_000])
    for method, fn in akf.METHODS.items():
        out = fn(sim.empty_events(), frames, ts, te, LINEAR, times)
        np.testing.assert_allclose(out, 40 / 255, rtol=2e-4, err_msg=method)


def _moving_scene(h=12, w=16, dur=400_000, c=0.2, threshold_sigma=0.0):
    yy, xx = np.mgrid[0:h, 0:w].astype(float)

    def radiance(t_us):
        t = t_us * 1e-6
        return np.exp(-1.2 + 0.8 * np.sin(0.45 * (xx - 25 * t)) * np.cos(0.3 * (yy + 10 * t)))

    times = np.arange(0, dur + 1, 250)
    dvs = sim.DVSParams.preset("ideal", pos_threshold=c, neg_threshold=c, threshold_sigma=threshold_sigma)
    emulator = sim.DVSEmulator(h, w, dvs, seed=0)
    events = emulator.feed(np.stack([radiance(t) for t in times]), times)
    ts = np.arange(0, dur - 10_000, 20_000)
    te = ts + 4_000
    frames = []
    for s, e in zip(ts, te):
        sub = np.mean([radiance(t) for t in np.linspace(s, e, 9)[:-1] + (e - s) / 16], axis=0)
        frames.append(np.round(LINEAR.forward(sub) * 65535).astype(np.uint16))
    if threshold_sigma:
        return radiance, events, np.stack(frames), ts, te, emulator.threshold_map
    return radiance, events, np.stack(frames), ts, te


@pytest.fixture(scope="module")
def moving():
    return _moving_scene()


def test_ideal_sensor_converges_to_the_true_log_intensity():
    """Exact 16-bit frames and noise-free events of threshold c = 0.05: the estimate stays within the events'
    quantisation of the true log intensity (events cannot report sub-threshold changes), and below the error of
    integrating the same events from the first frame."""
    c = 0.05
    radiance, events, frames, ts, te = _moving_scene(c=c)
    i0 = 1e-4  # the emulator's dark level: events report changes of log(I + 1e-4)
    times = np.arange(100_000, 380_000, 10_000)
    truth = np.log(np.stack([radiance(t) for t in times]) + i0)
    out = akf.reconstruct(events, frames, ts, te, LINEAR, times, params=akf.AKFParams(i0=i0, smooth_range=0.0),
                          bit_depth=16, contrast=c)
    err = np.abs(np.log(out + i0) - truth)
    assert err.mean() < 0.4 * c
    assert np.percentile(err, 99) < 1.5 * c
    direct = akf.direct_integration(events, frames, ts, te, LINEAR, times, bit_depth=16, contrast=c, i0=i0)
    assert err.mean() < 0.75 * np.abs(np.log(direct + i0) - truth).mean()


def test_per_pixel_threshold_maps_reduce_the_error():
    """Thresholds with 0.05 mismatch around 0.2: the sensor's true (2, H, W) maps beat the nominal 0.2 (the event
    model alone: without the frame update, which resets the events' error at every exact 16-bit frame)."""
    radiance, events, frames, ts, te, cmap = _moving_scene(threshold_sigma=0.05)
    times = np.arange(100_000, 380_000, 10_000)
    truth = np.log(np.stack([radiance(t) for t in times]) + 1e-4)

    def err(contrast, calibrate):
        params = akf.AKFParams(i0=1e-4, calibrate=calibrate, frame_update=False, smooth_range=0.0)
        out = akf.reconstruct(events, frames, ts, te, LINEAR, times, params=params, bit_depth=16, contrast=contrast)
        return np.abs(np.log(out + 1e-4) - truth).mean()

    assert err(cmap, False) < 0.9 * err(0.2, False)


def test_the_flat_field_reads_the_thresholds_from_the_event_counts():
    """The moving scene with thresholds of 0.05 mismatch around 0.2: each pixel's count against its neighbourhood's
    (akf.flat_field.count_scales) recovers its ON and OFF thresholds, correlated above 0.6 with the emulator's true
    maps (measured 0.66 and 0.73), and brings the mean threshold error below the nominal 0.2's by a fifth."""
    from akf.flat_field import count_scales

    _, events, frames, _, _, cmap = _moving_scene(threshold_sigma=0.05)
    scales = count_scales(events, frames.shape[1:], (0.5, 2.0))
    for s, true in zip(scales, cmap):
        assert np.corrcoef(s, true.ravel())[0, 1] > 0.6
        assert np.abs(0.2 * s - true.ravel()).mean() < 0.8 * np.abs(0.2 - true).mean()
    # where the frames measure the pixels (no clipped frame here), they correct the mismatch: the filter takes the
    # nominal thresholds there, bit for bit
    _, events, frames, ts, te, _ = _moving_scene(threshold_sigma=0.05)
    with_ff, without = (akf.reconstruct(events, frames, ts, te, LINEAR, [200_000], bit_depth=16, contrast=0.2,
                                        params=akf.AKFParams(flat_field=ff)) for ff in (True, False))
    np.testing.assert_array_equal(with_ff, without)

def test_publishing_does_not_change_the_trajectory(moving):
    _, events, frames, ts, te = moving
    dense = akf.reconstruct(events, frames, ts, te, LINEAR, np.arange(3_000, 300_001, 1_000), bit_depth=16)
    sparse = akf.reconstruct(events, frames, ts, te, LINEAR, [150_000, 300_000], bit_depth=16)
    np.testing.assert_allclose(sparse[0], dense[147], rtol=1e-5)
    np.testing.assert_allclose(sparse[1], dense[-1], rtol=1e-5)


def test_image_at_t_includes_events_before_t_only():
    frames, ts, te = _static(n=2, period=100_000)
    ev = sim.make_events([50_000], [2], [1], [1])
    out = akf.reconstruct(ev, frames, ts, te, LINEAR, [50_000, 50_001],
                         params=akf.AKFParams(calibrate=False, smooth_range=0.0, flat_field=False))
    jump = np.log(out[1, 1, 2] + 1e-3) - np.log(out[0, 1, 2] + 1e-3)
    assert jump == pytest.approx(0.2, abs=1e-4)  # the state steps by c at the event (eq. 15)
    np.testing.assert_allclose(out[1, 1, 3], out[0, 1, 3], rtol=1e-6)


def test_input_validation():
    frames, ts, te = _static()
    ev = sim.empty_events()
    with pytest.raises(UnsortedEventsError):
        akf.reconstruct(sim.make_events([5, 1], [0, 0], [0, 0], [1, 1]), frames, ts, te, LINEAR, [10])
    with pytest.raises(EvsimInputError, match="unsigned"):
        akf.reconstruct(ev, frames.astype(np.float32), ts, te, LINEAR, [10])
    with pytest.raises(TimeOrderError, match="before the first exposure"):
        akf.reconstruct(ev, frames, ts + 10, te + 10, LINEAR, [0])
    with pytest.raises(TimeOrderError, match="before frame"):
        akf.reconstruct(ev, frames, ts, ts + 50_000, LINEAR, [10])
    with pytest.raises(TimeOrderError, match="non-decreasing"):
        akf.reconstruct(ev, frames, ts, te, LINEAR, [20, 10])
    with pytest.raises(InvalidParameterError, match="contrast"):
        akf.reconstruct(ev, frames, ts, te, LINEAR, [10], contrast=-0.2)
    with pytest.raises(EvsimInputError, match="exceed the frame size"):
        akf.reconstruct(sim.make_events([1], [4], [0], [1]), frames, ts, te, LINEAR, [10])
    with pytest.raises(EvsimInputError, match="bit_depth"):
        akf.reconstruct(ev, frames.astype(np.uint16) * 64, ts, te, LINEAR, [10], bit_depth=8)
    with pytest.raises(InvalidParameterError, match="p0"):
        akf.AKFParams(p0=0.0)
    with pytest.raises(InvalidParameterError, match="calib_scale_range"):
        akf.AKFParams(calib_scale_range=(1.5, 2.0))


def test_clipped_frames_are_one_sided_measurements():
    """Frame 0 well exposed, frames 1 and 2 clipped high. Events raise pixel 0 to 0.6 and pixel 1 to 1.2 log units
    above frame 0: after frame 1's exposure the measurement is the clip level, which pixel 1's state exceeds
    (consistent with a clipped frame, which says nothing more: state and variance stay) and pixel 0's state does not
    (impossible: pulled with R * sigma_im2 / max_variance, the closed form of eqs. 17 and 20:
    L - A = (L1 - A) / (1 + P1 dt / R_eff))."""
    params = akf.AKFParams(smooth_range=0.0, flat_field=False)  # the given thresholds, not read from the counts
    frames = np.array([[[100, 100]], [[255, 255]], [[255, 255]]], np.uint8)
    ts = np.array([0, 50_000, 200_000])
    te = ts + 5_000
    t_ev = [20_000, 20_010, 20_020, 20_030, 20_040, 20_050]
    ev = sim.make_events(t_ev[:3] + t_ev, [0] * 3 + [1] * 6, [0] * 9, [1] * 9)
    ev = ev[np.argsort(ev["t"], kind="stable")]
    t1, t2 = 60_000, 61_000
    img, P = akf.reconstruct(ev, frames, ts, te, LINEAR, [30_000, t1, t2], params=params, return_variance=True,
                             max_intensity=None)  # pixel 1 runs above the full well (x = 1.3)
    clip = frame_measurement(frames[1] / 255.0, LINEAR, params)
    A, R = clip.log[0], clip.r[0]
    L = np.log(img[:, 0] + params.i0)
    lf0 = frame_measurement(frames[0] / 255.0, LINEAR, params).log[0]
    np.testing.assert_allclose(L[0] - lf0, [0.6, 1.2], atol=1e-3)  # forward from frame 0 (frame 1 is clipped)
    assert L[1, 0] < A[0] < L[1, 1]
    dt = (t2 - t1) * 1e-6
    strong = params.sigma_im2 / params.max_variance
    expected = (L[1, 0] - A[0]) / (1 + P[1, 0, 0] * dt / (R[0] * strong))
    assert L[2, 0] - A[0] == pytest.approx(expected, rel=1e-3, abs=1e-6)
    assert (img[2, 0, 1], P[2, 0, 1]) == (img[1, 0, 1], P[1, 0, 1])  # no pull toward a level it is consistent with
    # by t1 (5 ms after the clipped exposure) the impossible state is mostly corrected, the consistent one kept
    gap0, gap1 = L[:2] - A
    assert abs(gap1[0]) < 0.25 * abs(gap0[0]) and gap1[1] > 0.5 * gap0[1]


def test_output_never_exceeds_the_representable_bound():
    """Frames clipped high after frame 0; 12 ON events at 0.2 raise the pixel 2.4 log units above frame 0's
    100 / 255 (x = 4.3 unbounded, the default): a given max_intensity bounds the output at every time, as the
    lower bound 0 always does."""
    frames = np.array([[[100, 100]], [[255, 255]], [[255, 255]], [[255, 255]]], np.uint8)
    ts = np.array([0, 50_000, 100_000, 150_000])
    ev = sim.make_events(np.arange(12) * 1_000 + 20_000, [0] * 12, [0] * 12, [1] * 12)
    times = np.arange(0, 200_000, 5_000)
    params = akf.AKFParams(flat_field=False)  # two pixels: no neighbourhood to read thresholds from
    free = akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, times, params=params)
    assert free[:, 0, 0].max() > 3.0  # the unbounded filter does run above the full well here
    bounded = akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, times, params=params, max_intensity=1.0)
    assert bounded.max() <= 1.0 and bounded.min() >= 0.0
    np.testing.assert_array_equal(bounded, np.clip(free, 0.0, 1.0))  # a bound on the output, nothing else
    assert akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, times, max_intensity=0.5).max() <= 0.5
    with pytest.raises(InvalidParameterError, match="max_intensity"):
        akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, times, max_intensity=-1.0)


def test_isolated_event_in_a_clipped_region_keeps_its_level():
    """The AHDR window CRF, a region clipped high in every frame, ON events at the centre pixel at 105 and 205 ms,
    its 8 neighbours silent since the start. At the second event (eq. 2, no refractory term: 100 ms > rho_bar)
    P1 = P(t_e) + sigma_proc2 * 0.100 s (since the pixel's own last event) + sigma_iso2 * 0.205 s (since the latest
    neighbour event; the pixel itself excluded). Above the clip the state is consistent with the clipped frames,
    which say only that the truth is at or above the clip level: state and variance stay until the next event."""
    params = akf.AKFParams(smooth_range=0.0, flat_field=False)  # the given thresholds, not read from the counts
    window = crf_models.get("window")
    frames = np.full((9, 3, 3), 255, np.uint8)
    ts = np.arange(9) * 50_000
    t_e = 205_000
    ev = sim.make_events([105_000, t_e], [1, 1], [1, 1], [1, 1])
    times = [t_e, t_e + 1, t_e + 100_000]
    img, P = akf.reconstruct(ev, frames, ts, ts + 5_000, window, times, params=params, return_variance=True)
    clip = frame_measurement(frames[0] / 255.0, window, params)
    A = clip.log[1, 1]
    L = np.log(img[:, 1, 1] + params.i0)
    q = params.sigma_proc2 * 0.100 + params.sigma_iso2 * (t_e - ts[0]) * 1e-6
    assert P[1, 1, 1] == pytest.approx(P[0, 1, 1] + q, rel=1e-3)
    assert L[1] - L[0] == pytest.approx(0.2, abs=1e-4)  # the full step is applied (eq. 15)
    assert L[1] > A
    assert (img[2, 1, 1], P[2, 1, 1]) == (img[1, 1, 1], P[1, 1, 1])
    # the neighbours never moved
    np.testing.assert_allclose(np.delete(img[2].ravel(), 4), np.exp(A) - params.i0, rtol=1e-6)


def test_row_blocks_on_threads_give_the_one_block_result_bit_for_bit(monkeypatch):
    """The filter runs pixel rows in blocks on parallel threads; each block keeps its own copy of the neighbouring
    rows' last event times (Q_iso reads the 3x3 neighbourhood across block edges). Random-walk events crossing the
    block edges, clipped frames and the leak model: 5 blocks of 16 rows give exactly the 1-block output."""
    import numba

    h, w, n = 80, 24, 60_000
    rng = np.random.default_rng(3)
    walk = np.cumsum(rng.integers(-1, 2, (n, 2)), axis=0) + [w // 2, h // 2]
    events = sim.make_events(np.sort(rng.integers(0, 300_000, n)), walk[:, 0] % w, walk[:, 1] % h,
                             rng.choice([-1, 1], n))
    yy, xx = np.mgrid[0:h, 0:w]
    ts = np.arange(0, 290_000, 30_000)
    frames = np.stack([((xx * 11 + yy * 3 + k * 7) % 256) for k in range(ts.size)]).astype(np.uint8)
    crf = crf_models.get("window")
    times = np.arange(5_000, 300_000, 21_000)
    runs = []
    for threads in (1, 5):
        monkeypatch.setattr(numba, "get_num_threads", lambda t=threads: t)  # plain threads: any count works
        monkeypatch.setattr(numba, "set_num_threads", lambda t: None)
        runs.append(akf.reconstruct(events, frames, ts, ts + 6_000, crf, times, leak_rate_hz=0.3,
                                    return_variance=True, return_gain=True))
    assert akf.filter._Blocks(h, w, 0).rows == [0, 16, 32, 48, 64, 80]  # (monkeypatched: 5 threads)
    for one, five in zip(*runs):
        np.testing.assert_array_equal(one, five)


def test_output_smoothing_averages_event_speckle_where_frames_are_clipped_and_keeps_edges_and_frames():
    """Left half: a flat surface brightening by 1 log unit, clipped in every frame, seen by pixels with 3 %
    threshold mismatch (their event counts differ: speckle); right half: a dark surface the frames measure; a
    3.7 log edge between. The smoothing cuts the speckle (std of the log estimate on the flat half) by more than
    2x without moving its mean, keeps the edge within 0.05 log, and leaves the well-exposed half bit for bit."""
    h, w, dur = 20, 24, 300_000
    left = np.zeros((h, w), bool)
    left[:, : w // 2] = True

    def radiance(t_us):
        return np.where(left, np.exp(t_us / dur), 0.05)

    times = np.arange(0, dur + 1, 500)
    dvs = sim.DVSParams.preset("ideal", threshold_sigma=0.03)
    events = sim.DVSEmulator(h, w, dvs, seed=1).feed(np.stack([radiance(t) for t in times]), times)
    ts = np.arange(0, dur - 20_000, 33_000)
    te = ts + 5_000
    frames = np.stack([np.round(LINEAR.forward(np.mean([radiance(t) for t in np.linspace(s, e, 8)], 0)) * 255)
                       .astype(np.uint8) for s, e in zip(ts, te)])
    assert (frames[:, left] == 255).all() and (frames[:, ~left] < 255).all()
    t = [int(ts[-1]) - 5_000]
    flat = left.copy()
    flat[:, w // 2 - 3:] = False  # away from the edge
    logs = {}
    for smooth_range in (0.0, 1.0):
        out = akf.reconstruct(events, frames, ts, te, LINEAR, t, params=akf.AKFParams(smooth_range=smooth_range),
                              max_intensity=None)[0]
        logs[smooth_range] = (out, np.log(out + 1e-3))
    (raw, raw_log), (smooth, smooth_log) = logs[0.0], logs[1.0]
    assert smooth_log[flat].std() < 0.5 * raw_log[flat].std()
    assert abs(smooth_log[flat].mean() - raw_log[flat].mean()) < 0.01
    edge = smooth_log[:, w // 2 - 1].mean() - smooth_log[:, w // 2].mean()
    assert edge == pytest.approx(raw_log[:, w // 2 - 1].mean() - raw_log[:, w // 2].mean(), abs=0.05)
    np.testing.assert_array_equal(smooth[~left], raw[~left])
