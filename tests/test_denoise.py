"""Event denoisers (sim.denoise) scored against the emulator's per-event labels (evsim_eval.denoisers): the TPR/FPR
arithmetic on a hand-made stream, the hot-pixel filter against the emulator's hot-pixel mask, the correlation
filter's ROC under rising shot noise, the library wrappers against the libraries, and the CLI / plot / sweep."""

import importlib.util
import json
import math
import sys
import types

import numpy as np
import pytest

import sim
from evsim_eval.denoisers import filter_roc, rates, roc_auc
from sim import EvsimInputError, make_events
from sim.denoise import (
    FILTERS,
    CorrelationFilter,
    DenoiseDependencyError,
    correlation_filter,
    hot_pixel_filter,
    hot_pixel_map,
    keep_mask,
)

H, W = 32, 48


def _moving_square(n_frames: int, dt_us: int, *, speed_px_per_s: float = 60.0):
    """(frames, times): a static horizontal gradient (0.2..1) with a bright 8x8 square (20) moving right across
    rows 12..19: the camera and most of the scene are still."""
    times = np.arange(n_frames, dtype=np.int64) * dt_us
    base = np.tile(np.linspace(0.2, 1.0, W), (H, 1))
    frames = np.repeat(base[None], n_frames, axis=0).copy()
    xx = np.arange(W) + 0.5
    for k, t in enumerate(times):
        x0 = 2 + speed_px_per_s * t * 1e-6
        cover = np.clip(np.minimum(xx + 0.5, x0 + 8) - np.maximum(xx - 0.5, x0), 0, 1)  # exact pixel coverage
        frames[k, 12:20] = frames[k, 12:20] * (1 - cover) + 20.0 * cover
    return frames, times


# ----- arithmetic on hand-made streams -----------------------------------------------------------------------------

def test_rates_and_auc_on_a_hand_made_labelled_stream():
    labels = np.array([0, 0, 0, 0, 1, 1, 2, 3, 3, 3], np.uint8)
    keep = np.array([1, 1, 1, 0, 1, 0, 0, 1, 0, 0], bool)
    r = rates(labels, keep)
    assert (r["signal"], r["kept_signal"], r["noise"], r["kept_noise"]) == (4, 3, 6, 2)
    assert r["tpr"] == 0.75 and r["fpr"] == pytest.approx(2 / 6)
    assert (r["fpr_shot"], r["fpr_leak"], r["fpr_hot"]) == (0.5, 0.0, pytest.approx(1 / 3))
    assert math.isnan(rates(np.zeros(3, np.uint8), np.ones(3, bool))["fpr"])  # no noise: undefined, not 0
    # ROC through (0.2, 0.6) and (0.5, 0.9) between (0, 0) and (1, 1):
    # 0.2 * 0.3 + 0.3 * 0.75 + 0.5 * 0.95 = 0.76, whatever order the points come in
    assert roc_auc([0.5, 0.2], [0.9, 0.6]) == pytest.approx(0.76)
    assert roc_auc([0.0], [1.0]) == pytest.approx(1.0) and roc_auc([0.3], [0.3]) == pytest.approx(0.5)
    with pytest.raises(EvsimInputError, match="shape"):
        rates(labels, keep[:-1])


def test_correlation_filter_on_a_hand_made_stream():
    #          t     x   y   label   supported by (window 1000 us)
    rows = [(0, 5, 5, 0),        # -            (nothing before it)
            (100, 6, 5, 0),      # (5, 5) at 0
            (900, 5, 5, 0),      # (6, 5) at 100
            (5000, 20, 20, 1),   # -            (isolated shot event)
            (5050, 20, 20, 3),   # -            (its own pixel never supports it)
            (6000, 21, 19, 2),   # (20, 20) at 5050 (a diagonal neighbour, 950 us before)
            (7100, 0, 0, 1),     # -            (corner pixel, alone)
            (8000, 6, 6, 0)]     # -            ((5, 5) and (6, 5) fired 7100 and 7900 us before)
    t, x, y, lab = (np.array(c) for c in zip(*rows))
    ev = make_events(t, x, y, np.ones(t.size, np.int8))
    labels = lab.astype(np.uint8)
    np.testing.assert_array_equal(correlation_filter(ev, 24, 24, 1000), [0, 1, 1, 0, 0, 1, 0, 0])
    np.testing.assert_array_equal(correlation_filter(ev, 24, 24, 949), [0, 1, 1, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(correlation_filter(ev, 24, 24, 8000, support=2), [0, 0, 0, 0, 0, 0, 0, 1])
    # streaming in chunks gives the same mask as one call
    f = CorrelationFilter(24, 24, 1000)
    np.testing.assert_array_equal(np.concatenate([f(ev[:4]), f(ev[4:])]), [0, 1, 1, 0, 0, 1, 0, 0])
    roc = filter_roc(ev, labels, 24, 24, "correlation", [100, 1000])
    (p100, p1000) = roc["points"]
    assert (p100["tpr"], p100["fpr"]) == (0.25, 0.0)
    assert (p1000["tpr"], p1000["fpr"], p1000["fpr_leak"], p1000["fpr_shot"]) == (0.5, 0.25, 1.0, 0.0)
    # ROC (0, 0.25), (0.25, 0.5) -> 0.25 * 0.375 + 0.75 * 0.75 = 0.65625
    assert roc["auc"]["all"] == pytest.approx(0.65625)
    with pytest.raises(EvsimInputError, match="sensor size"):
        correlation_filter(ev, 8, 8, 1000)
    with pytest.raises(sim.InvalidParameterError, match="support"):
        correlation_filter(ev, 24, 24, 1000, support=9)


# ----- ground truth from the emulator ----------------------------------------------------------------------------

def test_hot_pixel_filter_finds_the_emulator_hot_pixels_on_a_static_scene():
    frames, times = _moving_square(501, 2000)  # 1 s; only hot pixels add noise
    params = sim.DVSParams.preset("ideal", hot_pixel_fraction=0.005, hot_pixel_hz=50.0)
    emu = sim.DVSEmulator(H, W, params, seed=4, return_labels=True)
    ev, labels = emu.feed(frames, times)
    hot = emu.hot_pixel_mask
    assert hot.sum() == 8 and hot[12:20].any()  # some hot pixels lie on the moving square's path
    assert np.sum(labels == 3) > 300 and np.sum(labels == 0) > 3000
    np.testing.assert_array_equal(hot_pixel_map(ev, H, W), hot)
    r = rates(labels, hot_pixel_filter(ev, H, W))
    assert 1 - r["fpr_hot"] >= 0.99 and r["tpr"] >= 0.99
    # the threshold acts: above the hot pixels' rate nothing is flagged
    assert keep_mask(ev, H, W, "hot_pixel", 1000).all()


@pytest.fixture(scope="module")
def shot_noise_rocs():
    """Correlation-filter ROCs of the moving square under shot noise only, at 2, 20 and 200 Hz per pixel."""
    frames, times = _moving_square(151, 2000)  # 0.3 s
    out = {}
    for hz in (2.0, 20.0, 200.0):
        params = sim.DVSParams.preset("ideal", shot_noise_hz=hz)
        ev, labels = sim.emulate(frames, times, params, seed=1, return_labels=True)
        assert set(np.unique(labels)) == {0, 1}
        out[hz] = filter_roc(ev, labels, H, W, "correlation")
    return out


def test_correlation_roc_is_monotone_and_its_auc_falls_as_shot_noise_rises(shot_noise_rocs):
    aucs = []
    for hz, roc in shot_noise_rocs.items():
        tpr = np.array([p["tpr"] for p in roc["points"]])
        fpr = np.array([p["fpr_shot"] for p in roc["points"]])
        # a longer window keeps a superset of the events: TPR and FPR never fall along the grid
        assert np.all(np.diff(tpr) >= 0) and np.all(np.diff(fpr) >= 0), hz
        assert fpr[0] < 0.5 * tpr[0] < 0.45 and tpr[-1] > 0.99
        assert roc["auc"]["all"] == roc["auc"]["shot"]
        aucs.append(roc["auc"]["all"])
    assert aucs[0] > 0.9 and aucs[0] > aucs[1] + 0.01 > aucs[2] + 0.02, aucs


# ----- the libraries, on the same events ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def noisy_events():
    frames, times = _moving_square(101, 2000)
    params = sim.DVSParams.preset("noisy", shot_noise_hz=20.0)
    return sim.emulate(frames, times, params, seed=2, return_labels=True)


@pytest.mark.parametrize("name", ["dv_ba", "dv_knoise", "dv_fast_decay"])
def test_dv_processing_wrappers_keep_what_the_library_keeps(name, noisy_events):
    dv = pytest.importorskip("dv_processing")
    ev, _ = noisy_events
    value = FILTERS[name].default
    keep = keep_mask(ev, H, W, name, value)
    store = dv.EventStore()
    for t, x, y, p in zip(ev["t"].tolist(), ev["x"].tolist(), ev["y"].tolist(), ev["p"].tolist()):
        store.push_back(t, x, y, p > 0)
    make = {"dv_ba": dv.noise.BackgroundActivityNoiseFilter, "dv_knoise": dv.noise.KNoiseFilter,
            "dv_fast_decay": dv.noise.FastDecayNoiseFilter}[name]
    import datetime

    lib = make((W, H), datetime.timedelta(microseconds=value))
    lib.accept(store)
    out = lib.generateEvents().numpy()
    assert 0.05 * ev.size < keep.sum() < ev.size  # the filter acts on these events
    np.testing.assert_array_equal(out["timestamp"], ev["t"][keep])
    np.testing.assert_array_equal(out["x"], ev["x"][keep])
    np.testing.assert_array_equal(out["y"], ev["y"][keep])
    np.testing.assert_array_equal(out["polarity"], ev["p"][keep] > 0)


def test_evsim_correlation_filter_agrees_with_dv_background_activity(noisy_events):
    pytest.importorskip("dv_processing")
    ev, _ = noisy_events
    same = correlation_filter(ev, H, W, 2000) == keep_mask(ev, H, W, "dv_ba", 2000)
    assert same.mean() > 0.99  # the same algorithm: 8 neighbours, the pixel itself excluded


def test_tonic_wrapper_keeps_what_tonic_keeps(noisy_events):
    transforms = pytest.importorskip("tonic.transforms")
    ev, _ = noisy_events
    keep = keep_mask(ev, H, W, "tonic_denoise", 5000)
    out = transforms.Denoise(filter_time=5000)(ev)
    assert 0.05 * ev.size < keep.sum() < ev.size
    np.testing.assert_array_equal(out, ev[keep])


def test_missing_library_names_the_extra(monkeypatch, noisy_events):
    ev, _ = noisy_events
    monkeypatch.setitem(sys.modules, "dv_processing", None)  # import raises ImportError
    monkeypatch.setitem(sys.modules, "tonic.functional", None)
    for name in ("dv_ba", "tonic_denoise"):
        with pytest.raises(DenoiseDependencyError, match=r"evsim\[denoise\]"):
            keep_mask(ev, H, W, name)


# ----- datasets, CLI, plots and sweeps ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def labelled_dataset(tmp_path_factory):
    from generators.ahdr import AHDRConfig
    from generators.dataset import write_index, write_sequence
    from generators.scenes import MovingEdge

    out = tmp_path_factory.mktemp("dn")
    cfg = AHDRConfig(dvs=sim.DVSParams.preset("noisy", hot_pixel_fraction=0.01),
                     camera=sim.CameraParams(fps=50.0, exposure_us=2000), labels=True, compression="lzf")
    entry = write_sequence(out, "edge", MovingEdge(16, 20, 100_000, speed_px_per_s=100.0), cfg,
                           np.random.SeedSequence(3), "native", progress=False)
    write_index(out, {"generator": "ahdr", "sequences": [entry]})
    return out


def test_evaluate_task_denoise_prints_and_writes_scores(labelled_dataset, tmp_path, capsys):
    from evsim_app.cli import main
    from evsim_eval.evaluate import evaluate_recording
    from generators.formats import load

    js = tmp_path / "dn.json"
    assert main(["evaluate", str(labelled_dataset), "--task", "denoise", "--filters", "correlation,hot_pixel",
                 "--methods", "akf,cf", "--metrics", "mse", "--json", str(js), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "window_us=2000" in text and "AUC" in text and "correlation(window_us=2000)" in text
    result = json.loads(js.read_text())
    seq = result["sequences"]["edge"]
    rec = load(labelled_dataset / "edge.h5")
    assert seq["events"]["signal"] + seq["events"]["noise"] == rec.events.size
    assert [p["value"] for p in seq["roc"]["correlation"]["points"]] == list(FILTERS["correlation"].grid)
    assert 0.5 < seq["roc"]["correlation"]["auc"]["all"] <= 1.0
    # the raw row is exactly the reconstruction evaluation; the denoised row is the same code on fewer events
    raw = evaluate_recording(rec, methods=("akf", "cf"), metrics=("mse",))[0]
    assert seq["reconstruction"]["raw"] == raw
    assert set(seq["reconstruction"]) == {"raw", "correlation(window_us=2000)", "hot_pixel(threshold_hz=20)"}


def test_evaluate_task_denoise_needs_labels(tmp_path, capsys):
    from evsim_app.cli import main
    from generators.ahdr import AHDRConfig, generate_ahdr
    from generators.scenes import MovingEdge

    cfg = AHDRConfig(dvs=sim.DVSParams.preset("ideal"), camera=sim.CameraParams(fps=50.0, exposure_us=2000))
    generate_ahdr(MovingEdge(8, 8, 50_000), tmp_path / "nolab.h5", cfg, seed=0)
    assert main(["evaluate", str(tmp_path / "nolab.h5"), "--task", "denoise", "--no-progress"]) == 2
    assert "--labels" in capsys.readouterr().err
    assert main(["evaluate", str(tmp_path / "nolab.h5"), "--task", "denoise", "--filters", "nope"]) == 2


def _has_matplotlib() -> bool:
    return importlib.util.find_spec("matplotlib") is not None and isinstance(
        sys.modules.get("matplotlib", types.ModuleType("m")), types.ModuleType)


@pytest.mark.skipif(not _has_matplotlib(), reason="matplotlib is not installed (pip install 'evsim[plot]')")
def test_plot_roc_and_auc_sweep(labelled_dataset, tmp_path):
    from evsim_app.cli import main
    from evsim_app.plots.sweep import sweep_metrics
    from generators.ahdr import AHDRConfig
    from generators.scenes import MovingEdge
    from generators.sweep import generate_sweep

    out = tmp_path / "roc.png"
    assert main(["plot", "roc", str(labelled_dataset), "--filters", "correlation", "hot_pixel",
                 "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
    # AUC against the swept shot-noise rate: it falls as the rate rises
    cfg = AHDRConfig(dvs=sim.DVSParams.preset("ideal"), camera=sim.CameraParams(fps=50.0, exposure_us=2000),
                     labels=True, compression="lzf")
    generate_sweep(MovingEdge(16, 20, 100_000, speed_px_per_s=100.0), tmp_path / "sw",
                   {"shot_noise_hz": [5.0, 500.0]}, cfg, seed=1, progress=False)
    rows = sweep_metrics(tmp_path / "sw", ("correlation",), "auc")
    low, high = (r["scores"]["correlation"]["auc"] for r in rows)
    assert low > high + 0.02
    assert main(["plot", "sweep", str(tmp_path / "sw"), "--metric", "auc", "--out", str(tmp_path / "s.png"),
                 "--no-progress"]) == 0


@pytest.mark.skipif(not _has_matplotlib(), reason="matplotlib is not installed (pip install 'evsim[plot]')")
def test_plot_roc_of_several_sequences_names_the_pooled_and_the_mean_auc(tmp_path, capsys):
    from evsim_app.cli import main
    from generators.ahdr import AHDRConfig
    from generators.dataset import write_index, write_sequence
    from generators.scenes import MovingEdge

    cfg = AHDRConfig(dvs=sim.DVSParams.preset("noisy"), camera=sim.CameraParams(fps=50.0, exposure_us=2000),
                     labels=True, compression="lzf")
    entries = [write_sequence(tmp_path, name, MovingEdge(16, 20, 100_000, speed_px_per_s=speed), cfg,
                              np.random.SeedSequence(seed), "native", progress=False)
               for name, speed, seed in (("slow", 40.0, 1), ("fast", 300.0, 2))]
    write_index(tmp_path, {"generator": "ahdr", "sequences": entries})
    js = tmp_path / "dn.json"
    assert main(["evaluate", str(tmp_path), "--task", "denoise", "--filters", "correlation", "--no-reconstruct",
                 "--json", str(js), "--no-progress"]) == 0
    mean = json.loads(js.read_text())["mean_auc"]["correlation"]["all"]
    capsys.readouterr()
    assert main(["plot", "roc", str(js), "--out", str(tmp_path / "roc.png")]) == 0
    out = capsys.readouterr().out
    assert "the 2 sequences' points pooled: correlation " in out
    assert f"mean of the sequences' AUCs, as evsim evaluate reports: correlation {mean:.3f}" in out
