"""Issue 37's speed-ups change no output: the DVS's path for pixels with several crossings per interval
(sim.dvs_kernels._multi_events) gives the events and state of its general pixel path, dense events are pinned (the
counts of commit 06d684c, before that path; the same bits since the vectorised path for two crossings took most of
its pixels; hashes re-pinned when the filter's J and decay factor went to float32, which moved event times by 1-2
us), and a sampler read ahead on a thread of its own (generators.sampling.read_ahead) gives the samples of a plain
pass and passes on its errors, key frames asked for in any order are those made in order, consecutive key frames go
to the DVS without a copy, radiance_of_log's exp is float32-exact to one unit in the last place, and its blend
between key frames gives the exp of the blended log."""

import hashlib
import importlib.util
import threading
from pathlib import Path

import cv2
import numpy as np
import pytest

import sim
import sim.dvs_kernels as K
from generators.ahdr import _planes_in_a_row
from generators.sampling import AdaptiveSampler, read_ahead
from generators.scenes import Trajectory, VideoScene, builtin_image_scene
from generators.scenes.flow_interpolation import KEY_GROUP, FlowEstimator, radiance_of_log

BENCH = Path(__file__).resolve().parents[1] / "bench"
# speed 1.6 px per frame: about 34,000 of the pixel-intervals have several events
DENSE_HASHES = {"davis346": (127_972, "f1186482127258cc"), "noisy": (128_271, "d837874361c02b1b")}


def _texture(h: int, w: int, speed: float):
    spec = importlib.util.spec_from_file_location("_bench_dvs_37", BENCH / "bench_dvs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.TexturedScene(h, w, speed_px=speed)


@pytest.mark.parametrize("preset", sorted(DENSE_HASHES))
def test_dense_events_are_pinned(preset):
    frames = _texture(40, 56, 1.6).frames(0, 60)
    emu = sim.DVSEmulator(40, 56, sim.DVSParams.preset(preset), seed=7, return_labels=True)
    events, labels = emu.feed(frames, np.arange(60, dtype=np.int64) * 1000)
    h = hashlib.sha256()
    for a in (events, labels):
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.descr, a.shape)).encode())
        h.update(a.tobytes())
    assert (events.size, h.hexdigest()[:16]) == DENSE_HASHES[preset]


def test_multi_crossing_path_gives_the_events_and_state_of_the_general_pixel_path():
    """_multi_events against _pixel_events on the same pixels (no hot pixels, refractory > 0): several crossings,
    pixels blind at the interval's start, leak drift, and shot-noise clocks with and without an arrival."""
    rng = np.random.default_rng(11)
    w, t0, hf, refractory = 4000, np.int64(50_000), 1000.0, np.int64(100)
    f0 = rng.normal(0, 1, w)
    f1 = f0 + rng.normal(0, 1.5, w)  # up to several thresholds per interval
    G = np.zeros((11, w))
    G[0], G[1] = f0, f1
    G[2] = f0 + rng.uniform(-0.2, 0.2, w)  # reference
    G[3] = t0 - rng.uniform(0, 5e5, w)  # its reset time
    G[4] = rng.choice([0.0, 1e-7], w)  # leak drift
    G[5], G[6] = rng.uniform(0.1, 0.3, w), rng.uniform(0.1, 0.3, w)
    lam = rng.choice([0.0, 1e-4, 5e-3], w)  # per us: none, rare and frequent arrivals
    e_shot = rng.exponential(1.0, w)[None, :]
    last_t = np.where(rng.random(w) < 0.3, t0 - rng.integers(0, 100, w), K.NO_EVENT_US)  # 30 % blind at t0
    blind0 = last_t >= t0 - refractory
    G[7] = e_shot[0] - lam * hf
    G[9] = blind0
    G[10] = np.where(blind0, (last_t + refractory - t0).astype(float), 0.0)
    code = np.zeros(w, np.int64)
    mc_f, mc_i = np.empty((3, w)), np.empty((3, w), np.int64)
    mc_t, mc_l = np.empty((K._MULTI_MAX, w), np.int64), np.empty((K._MULTI_MAX, w), np.uint8)
    K._multi_events(0, t0, hf, refractory, w, np.arange(w), code, G, lam, e_shot, np.zeros((1, w), np.uint8),
                    mc_f, mc_i, mc_t, mc_l)
    taken = np.flatnonzero(code & 32)
    assert taken.size > 1000 and (mc_i[1, mc_i[2, taken]] > 1).sum() > 300  # many with several events
    words = np.empty(64, np.int64)
    for j in taken:
        es, eh, r, tr, lt, _, n = K._pixel_events(t0, hf, f0[j], f1[j], lam[j], 0.0, j, j, refractory, np.uint64(3),
                                                 e_shot[0, j], 1.0, G[2, j], G[3, j], last_t[j], np.uint64(0),
                                                 G[5, j], G[6, j], G[4, j], words, 0, words.size, 0)
        q = mc_i[2, j]
        assert n == mc_i[1, q]
        np.testing.assert_array_equal(t0 + (words[:n] & K.EV_DT_MASK), mc_t[:n, q])
        np.testing.assert_array_equal((words[:n] >> K.EV_LABEL_SHIFT) & 3, K.LABEL_LEAK * mc_l[:n, q])
        assert (r, tr, es, lt) == (mc_f[0, q], mc_f[1, q], mc_f[2, q], mc_t[n - 1, q])
    for j in np.flatnonzero(code == 0):  # left to _pixel_events: a noise arrival (a draw), or no event after all
        *_, draws, n = K._pixel_events(t0, hf, f0[j], f1[j], lam[j], 0.0, j, j, refractory, np.uint64(3),
                                       e_shot[0, j], 1.0, G[2, j], G[3, j], last_t[j], np.uint64(0), G[5, j], G[6, j],
                                       G[4, j], words, 0, words.size, 0)
        assert n == 0 or draws > 0 or n > K._MULTI_MAX


def test_radiance_of_log_is_exp_minus_eps_clipped():
    log = np.random.default_rng(0).normal(-3, 3, (70, 33)).astype(np.float32)
    out = radiance_of_log(log, 0.01)
    assert out.dtype == np.float32 and out.min() >= 0
    np.testing.assert_allclose(out, np.maximum(np.exp(log.astype(np.float64)) - 0.01, 0), rtol=1e-6, atol=1e-9)


def test_radiance_of_log_exp_is_within_one_float32_ulp_over_its_range():
    log = np.linspace(-87.0, 88.0, 200_003, dtype=np.float32).reshape(1, -1)
    exact = np.exp(log.astype(np.float64))
    rel = np.abs(radiance_of_log(log, 0.0) / exact - 1)
    assert rel.max() <= np.finfo(np.float32).eps, rel.max()


def test_radiance_between_keys_is_the_exp_of_the_blended_log():
    rng = np.random.default_rng(5)
    log0 = cv2.GaussianBlur(rng.normal(0, 1.5, (40, 56)).astype(np.float32), (0, 0), 2)
    pair = FlowEstimator((-4.0, 4.0), scale=1.0).pair(log0, np.roll(log0, 5, axis=1))
    for a in (0.0, 0.37 / pair.n_keys, 0.5, 1.0 - 1e-4, 1.0):  # at keys and between them (a 30 fps clip's samples)
        blend = pair.log_at(a).astype(np.float64)
        rel = np.abs(pair.radiance_at(a, 0.01).astype(np.float64) / (np.exp(blend) - 0.01) - 1)
        assert rel.max() < 4 * np.abs(blend).max() * np.finfo(np.float32).eps, (a, rel.max())  # a few ulp of the log
    linear = radiance_of_log(log0, 0.01, log0 + 1.0, 0.25)  # a linear blend between frames
    np.testing.assert_allclose(linear, np.exp(log0.astype(np.float64) + 0.25) - 0.01, rtol=2e-6)


def test_keys_asked_for_in_any_order_equal_keys_made_in_order():
    rng = np.random.default_rng(3)
    log0 = cv2.GaussianBlur(rng.normal(0, 1, (40, 56)).astype(np.float32), (0, 0), 2)
    log1 = np.roll(log0, 6, axis=1)  # 6 px of motion: 12 keys at 0.5 px per key
    pair = FlowEstimator((-3.0, 3.0), scale=1.0).pair(log0, log1)
    assert pair.n_keys > KEY_GROUP
    in_order = FlowEstimator((-3.0, 3.0), scale=1.0).pair(log0, log1)
    expected = [in_order.key(j) for j in range(in_order.n_keys + 1)]
    for j in (pair.n_keys - 1, 3, 1, 9, 0, pair.n_keys):  # a later group first: the groups before it are made too
        np.testing.assert_array_equal(pair.key(j), expected[j])


def test_a_sampler_read_ahead_gives_the_samples_of_a_plain_pass(tmp_path):
    h, w, fps = 48, 64, 24.0
    scene = builtin_image_scene(h, w, 300_001, Trajectory(pan_px_per_s=(120.0, 30.0)))
    clip = tmp_path / "clip.npy"
    np.save(clip, np.stack([scene.radiance(int(t)) for t in np.arange(0, 300_001, 1e6 / fps)]).astype(np.float32))
    ahead = list(read_ahead(AdaptiveSampler(VideoScene(clip, fps=fps), threshold=0.2), 3))
    plain = list(AdaptiveSampler(VideoScene(clip, fps=fps), threshold=0.2))
    assert len(ahead) == len(plain) > 10
    for (t, img), (t_plain, img_plain) in zip(ahead, plain):
        assert t == t_plain
        np.testing.assert_array_equal(img, img_plain)


def test_read_ahead_raises_the_producers_error_in_order_and_stops_when_closed():
    def items():
        yield from range(5)
        raise ValueError("frame 5 is unreadable")

    got = []
    with pytest.raises(ValueError, match="frame 5 is unreadable"):
        for item in read_ahead(items(), 2):
            got.append(item)
    assert got == [0, 1, 2, 3, 4]
    produced = []

    def endless():
        while True:
            produced.append(len(produced))
            yield produced[-1]

    reader = read_ahead(endless(), 4)
    assert [next(reader) for _ in range(3)] == [0, 1, 2]
    reader.close()  # the producer stops: it made at most depth + 1 items beyond those taken, and its thread is gone
    assert len(produced) <= 3 + 4 + 1
    assert not any(t.name == "evsim-samples" for t in threading.enumerate())


def test_consecutive_key_planes_go_to_the_dvs_without_a_copy():
    group = np.arange(5 * 3 * 4, dtype=np.float32).reshape(5, 3, 4)
    run = _planes_in_a_row(list(group[1:4]))
    assert run is not None and np.shares_memory(run, group) and np.array_equal(run, group[1:4])
    assert _planes_in_a_row([group[1], group[3]]) is None  # a gap
    assert _planes_in_a_row([group[2], group[1]]) is None  # out of order
    assert _planes_in_a_row([group[1], group[2].copy()]) is None  # another array
    assert _planes_in_a_row([group[0][:, :2], group[1][:, :2]]) is None  # not whole planes
    alone = np.ones((3, 4), np.float32)
    assert np.shares_memory(_planes_in_a_row([alone]), alone)
