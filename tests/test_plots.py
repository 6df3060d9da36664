"""evsim_app.plots: each figure is rendered from a tiny built-in sequence and checked for content, and the data
behind the pixel figure is checked against the ground truth of a noise-free sequence."""

import json
import os
import subprocess
import sys
import types
from pathlib import Path
from unittest.mock import MagicMock

import numpy as np
import pytest

# importorskip is fooled by the MagicMock that colour-science puts in sys.modules when matplotlib is missing
try:
    import matplotlib
except ImportError:
    matplotlib = None
if not isinstance(matplotlib, types.ModuleType):
    pytest.skip("matplotlib is not installed (pip install 'evsim[plot]')", allow_module_level=True)

import akf  # noqa: E402
from evsim_app.cli import main  # noqa: E402
from evsim_app.plots import (  # noqa: E402
    animate,
    event_frame,
    event_rate,
    load_recording,
    plot_compare,
    plot_crfs,
    plot_events,
    plot_hdr_recovery,
    plot_pixel,
    plot_sweep,
    prepare,
    time_surface,
)
from evsim_app.plots.common import MATPLOTLIB_HINT, PlotDependencyError, ToneMap  # noqa: E402
from evsim_app.plots.pixel import pixel_series  # noqa: E402
from generators.ahdr import generate_ahdr  # noqa: E402
from generators.config import build_scene, parse_config, to_ahdr_config  # noqa: E402
from generators.sweep import generate_sweep  # noqa: E402
from sim import EvsimInputError, make_events  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
H, W = 48, 64
PIXELS = [(32, 24), (10, 10), (20, 40)]  # pixels of the fixture with 15+ events each


def _settings(**over):
    data = {"seed": 0, "defaults": {"duration_s": 0.3, "height": H, "width": W, "sensor": "ideal",
                                    "crf": {"name": "gamma"}, "output": {"reference_rate_hz": 200.0}, **over},
            "sequence": [{"name": "pan", "scene": {"type": "builtin_image", "image": "astronaut",
                                                   "trajectory": {"pan_px_per_s": [30.0, 8.0]}}}]}
    return parse_config(data).sequences[0]


@pytest.fixture(scope="module")
def seq(tmp_path_factory):
    """A noise-free (ideal DVS) 48x64, 0.3 s pan over the built-in astronaut, gamma CRF, references at 200 Hz."""
    spec = _settings()
    s = spec.settings
    scene = build_scene(spec.scene, s["height"], s["width"], spec.duration_us)
    path = tmp_path_factory.mktemp("plots") / "pan.h5"
    generate_ahdr(scene, path, to_ahdr_config(s), 0, progress=False)
    return path


@pytest.fixture(scope="module")
def prep(seq):
    return prepare(load_recording(seq))


def assert_not_blank(path):
    """The image file exists and shows structure: pixel spread and many distinct colours."""
    import matplotlib.image as mpimg

    assert Path(path).is_file() and Path(path).stat().st_size > 1000
    img = mpimg.imread(path)[..., :3]
    assert img.std() > 0.05
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20


def test_pixel_figure_data_against_ground_truth(prep, tmp_path):
    rec = prep.rec
    cam = rec.metadata["config"]["camera"]
    # exposure == reference exposure, so x = radiance * reference_fill / reference_radiance
    assert prep.to_x == pytest.approx(cam["reference_fill"] / cam["reference_radiance"], rel=1e-12)
    i0 = akf.AKFParams().i0
    inside, total = 0, 0
    for k, (x, y) in enumerate(PIXELS):
        out = tmp_path / f"pixel_{x}_{y}.png"
        s = plot_pixel(prep, x, y, out, n_times=400)
        if k == 0:
            assert_not_blank(out)
        # the true log intensity is the reference at its own times, in the filter's log(x + I0) units
        np.testing.assert_array_equal(s.reference_t_us, rec.reference_t_us)
        truth = np.log(rec.reference[:, y, x].astype(np.float64) * prep.to_x + i0)
        np.testing.assert_allclose(s.true_log, truth, rtol=1e-12)
        # ideal DVS: the truth never leaves (level - C_off, level + C_on) of the rebuilt reference level, in the
        # pixel's own log units log(radiance + I_d) (they differ from log(x + I0) where x is near I0)
        dvs = rec.metadata["config"]["dvs"]
        dvs_log = np.log(rec.reference[:, y, x].astype(np.float64) + dvs["dark_fraction"] * dvs["full_illumination"])
        c_on, c_off = rec.threshold_maps[:, y, x]
        level = s.dvs_level[np.searchsorted(s.dvs_level_t_us, s.reference_t_us, side="right") - 1]
        level = level - s.dvs_level[0] + dvs_log[0]
        assert np.all(dvs_log - level < c_on + 1e-6) and np.all(level - dvs_log < c_off + 1e-6)
        assert s.event_t_us.size >= 15
        # the 3x3-block reconstruction is exactly the full-frame one at this pixel (same output times) without
        # the contrast calibration, whose carried per-pixel scale shrinks toward a calibration pooled over the
        # image: the block's pool is not the frame's (up to 0.11 log apart at (10, 10) with calibration)
        plain = akf.AKFParams(calibrate=False, smooth_range=0.0)  # the pixel plot shows the unsmoothed filter
        block = pixel_series(prep, x, y, n_times=400, params=plain)
        full = akf.reconstruct(*prep.reconstruct_args(), block.t_us, contrast=prep.contrast,
                               bit_depth=rec.frame_bit_depth, params=plain)
        np.testing.assert_allclose(block.akf, np.log(full[:, y, x].astype(np.float64) + i0), atol=1e-5)
        # the +-2 sqrt(P) band holds the (interpolated) truth between the first and last frame
        mid = (s.t_us > rec.frame_t_mid_us[0]) & (s.t_us < rec.frame_t_mid_us[-1])
        truth = np.interp(s.t_us, s.reference_t_us, s.true_log)
        inside += int(np.sum(np.abs(truth - s.akf)[mid] <= 2 * s.akf_std[mid]))
        total += int(mid.sum())
        # the LDR samples are the CRF inverse of the frames, drawn over their exposure windows
        np.testing.assert_allclose(s.frame_log, np.log(prep.crf.inverse(rec.frames[:, y, x] / 255.0) + i0))
        np.testing.assert_array_equal(s.frame_t_end_us - s.frame_t_start_us, 10_000)
        # the frames' recorded range (equal exposures: [CRF^-1(0), CRF^-1(1)] = [0, 1] x for the gamma CRF), and a
        # y span that holds the truth wherever it is, above the frames' top included
        np.testing.assert_allclose(s.frame_range_log, np.log(np.array([[0.0, 1.0]] * s.frame_log.size) + i0))
        lo, hi = s.log_span()
        assert lo < min(s.true_log.min(), s.akf.min(), np.log(i0)) and hi > max(s.true_log.max(), s.akf.max())
    # the reference's brightest pixel stays 1.4..32 x, above the frames' top throughout: still inside the span
    s = pixel_series(prep, 48, 3, n_times=50)
    lo, hi = s.log_span()
    assert s.true_log.min() > np.log(1.4) and lo < np.log(i0) and hi > s.true_log.max() > np.log(30)
    assert inside / total > 0.5  # "most samples" (about 0.67 with the AKF defaults of this version)


def test_pixel_rejects_pixels_off_the_sensor(prep, tmp_path):
    with pytest.raises(EvsimInputError, match="outside the 64x48 sensor"):
        plot_pixel(prep, W, 0, tmp_path / "p.png")
    assert not (tmp_path / "p.png").exists()


def test_event_frame_time_surface_and_rate_on_known_events():
    ev = make_events([100, 200, 300, 400, 450], [1, 1, 2, 0, 1], [0, 0, 1, 1, 0], [1, -1, 1, 1, 1])
    counts = event_frame(ev, 2, 3, 150, 450)  # t in [150, 450): events 1, 2, 3
    assert counts[0].tolist() == [[0, 0, 0], [1, 0, 1]] and counts[1].tolist() == [[0, 1, 0], [0, 0, 0]]
    ts = time_surface(ev, 2, 3, 460, 100.0)
    assert ts[0, 1] == pytest.approx(np.exp(-0.1))  # latest event at (1, 0) is the ON at 450 (not the OFF)
    assert ts[1, 2] == pytest.approx(np.exp(-1.6)) and ts[1, 0] == pytest.approx(np.exp(-0.6))
    assert ts[0, 0] == 0 and ts[0, 2] == 0
    start, on, off = event_rate(ev, 200, 0, 600)
    assert start.tolist() == [0, 200, 400]
    assert on.tolist() == [5000.0, 5000.0, 10000.0] and off.tolist() == [0.0, 5000.0, 0.0]


def test_plot_events_and_animation(seq, prep, tmp_path):
    rec = prep.rec
    res = plot_events(rec, tmp_path / "events.svg", at_ms=[100, 250], window_ms=5)
    assert (tmp_path / "events.svg").read_text().lstrip().startswith("<?xml")
    res = plot_events(rec, tmp_path / "events.png", at_ms=[100, 250], window_ms=5)
    assert_not_blank(tmp_path / "events.png")
    assert res["times_us"] == [100_000, 250_000]
    n = np.sum((rec.events["t"] >= 95_000) & (rec.events["t"] < 100_000))
    assert res["frames"][0].sum() == n > 0
    assert res["rate"][1].sum() + res["rate"][2].sum() == pytest.approx(rec.events.size * 1e6 / (
        res["rate"][0][1] - res["rate"][0][0]))
    with pytest.raises(EvsimInputError, match="outside the events' span"):
        plot_events(rec, tmp_path / "bad.png", at_ms=[900])
    from PIL import Image

    out = animate(prep, tmp_path / "anim.gif", n_frames=4)
    umask = os.umask(0)
    os.umask(umask)
    assert out["path"].stat().st_mode & 0o777 == 0o666 & ~umask  # readable as every other output, not private
    with Image.open(out["path"]) as gif:
        assert gif.n_frames == 4
        frame = np.asarray(gif.convert("RGB"), float)
    assert frame.std() > 10
    with pytest.raises(EvsimInputError, match=".gif or .mp4"):
        animate(prep, tmp_path / "anim.avi")


def test_plot_compare_images_and_scores(prep, tmp_path):
    rec = prep.rec
    t = int(rec.frame_t_mid_us[4])  # a reference frame lies at every mid-exposure time
    res = plot_compare(prep, tmp_path / "compare.png", t_us=t + 1)
    assert_not_blank(tmp_path / "compare.png")
    assert res["t_us"] == t and res["frame_index"] == 4
    r = int(np.flatnonzero(rec.reference_t_us == t)[0])
    np.testing.assert_allclose(res["reference"], rec.reference[r] * prep.to_x)
    # frames-only at a frame's mid-exposure time is that frame through the inverse CRF
    np.testing.assert_allclose(res["images"]["frames"], prep.crf.inverse(rec.frames[4] / 255.0), rtol=1e-6)
    assert np.all(res["gain"] > 0) and set(res["pu21_psnr"]) == {"akf", "cf", "frames"}
    # one tone map for every panel, from the reference and the frames' top (CRF^-1(1) = 1 x for the gamma CRF)
    tone = res["tone_map"]
    assert tone == ToneMap.from_reference(res["reference"], frames_top=1.0)
    assert res["frames_range"] == (0.0, 1.0)
    np.testing.assert_array_equal(res["shown"]["reference"], tone(res["reference"]))
    for m, image in res["images"].items():
        np.testing.assert_array_equal(res["shown"][m], tone(image))
        np.testing.assert_allclose(res["log_error"][m], np.log(np.maximum(image, tone.floor))
                                   - np.log(np.maximum(res["reference"], tone.floor)))
    # the reference reaches 32 x, far above the frames' top: its highlights keep their grey steps
    bright = res["reference"] > 2.0
    assert bright.sum() > 50 and np.ptp(res["shown"]["reference"][bright]) > 0.2


def test_plot_sweep_scores_every_point_once(tmp_path):
    spec = _settings(duration_s=0.2, height=16, width=20)
    s = spec.settings
    scene = build_scene({"type": "moving_edge"}, s["height"], s["width"], spec.duration_us)
    generate_sweep(scene, tmp_path / "sw", {"shot_noise_hz": [0.0, 50.0]}, to_ahdr_config(s), 1, progress=False)
    rows = plot_sweep(tmp_path / "sw", tmp_path / "sweep.png", metric="pu21_psnr")
    assert_not_blank(tmp_path / "sweep.png")
    assert [r["point"] for r in rows] == [{"shot_noise_hz": 0.0}, {"shot_noise_hz": 50.0}]
    cache = tmp_path / "sw" / "sweep_metrics.json"
    assert json.loads(cache.read_text())["sequences"] == rows
    before = cache.stat().st_mtime_ns
    again = plot_sweep(tmp_path / "sw", tmp_path / "sweep2.png", metric="pu21_psnr")
    assert again == rows and cache.stat().st_mtime_ns == before  # served from the cache
    both = plot_sweep(tmp_path / "sw", tmp_path / "sweep3.png", metric="mse")  # adds the missing metric
    assert all(set(r["scores"]["akf"]) == {"pu21_psnr", "mse"} for r in both)
    assert [r["scores"]["cf"]["pu21_psnr"] for r in both] == [r["scores"]["cf"]["pu21_psnr"] for r in rows]
    # regenerating the sweep in place (another seed) invalidates the cached scores of its files
    generate_sweep(scene, tmp_path / "sw", {"shot_noise_hz": [0.0, 50.0]}, to_ahdr_config(s), 2, overwrite=True,
                   progress=False)
    fresh = plot_sweep(tmp_path / "sw", tmp_path / "sweep4.png", metric="pu21_psnr")
    assert all(set(r["scores"]["akf"]) == {"pu21_psnr"} for r in fresh)
    assert fresh[1]["scores"]["akf"]["pu21_psnr"] != rows[1]["scores"]["akf"]["pu21_psnr"]
    with pytest.raises(EvsimInputError, match="no index.json"):
        plot_sweep(tmp_path, tmp_path / "x.png")


def test_plot_crfs_curves(tmp_path):
    data = plot_crfs(tmp_path / "crf.png")
    assert_not_blank(tmp_path / "crf.png")
    x, y, w = data["linear"]
    np.testing.assert_allclose(y, x)  # y = x
    np.testing.assert_allclose(w[1:-1], 1.0)  # constant certainty away from the clipped ends
    assert "tabulated" not in data  # needs a table


def test_tone_map_shows_detail_above_the_frames_top():
    # frames record 0.13..0.36 x (the AHDR window CRF); the left half of the reference lies inside that range, the
    # right half holds all its detail above it: stripes of 10 x and 100 x and a ramp from 3 x to 300 x
    frames_top = 0.36
    ref = np.empty((40, 80))
    ref[:, :40] = np.linspace(0.13, 0.36, 40)
    ref[:20, 40:] = np.where(np.arange(40) % 4 < 2, 10.0, 100.0)
    ref[20:, 40:] = np.geomspace(3.0, 300.0, 40)
    tone = ToneMap.from_reference(ref, frames_top=frames_top)
    assert tone.floor == pytest.approx(np.percentile(ref, 1)) and tone.top == pytest.approx(np.percentile(ref, 99.9))
    shown = tone(ref)
    stripes, ramp = shown[:20, 40:], shown[20:, 40:]
    assert stripes.max() - stripes.min() > 0.25  # 10 x and 100 x: a quarter of the grey range apart
    assert np.all(np.diff(ramp[0]) > 0)  # every step of the ramp is a distinct grey
    assert np.all(shown[:, :40] < stripes.min())  # the frames' range below every highlight
    # equal ratios, equal grey steps; nothing assumes images <= 1 x; below the floor is black, above the top white
    v = tone(np.array([0.0, tone.floor, 2.0, 4.0, 8.0, tone.top, 1e7]))
    assert v[0] == v[1] == 0 and v[-1] == v[-2] == 1
    assert v[3] - v[2] == pytest.approx(v[4] - v[3])
    # the log error: a factor 2 too bright reads log 2 wherever both images are above the floor
    np.testing.assert_allclose(tone.log_error(2 * ref, ref), np.log(2))
    # a reference with black pixels: the floor is 1e-3 of the frames' top, not 0
    dark = np.zeros((10, 10))
    dark[0, :5] = 50.0
    assert ToneMap.from_reference(dark, frames_top=frames_top).floor == pytest.approx(1e-3 * frames_top)
    with pytest.raises(EvsimInputError, match="no positive value"):
        ToneMap.from_reference(dark * 0)
    with pytest.raises(EvsimInputError, match="0 < floor < top"):
        ToneMap(1.0, 1.0)


def _oracle(prep, factor):
    """A method for akf.METHODS returning factor times the reference nearest each output time (x units)."""
    def method(events, frames, t_start, t_end, crf, times, *, contrast, bit_depth):
        idx = [int(np.argmin(np.abs(prep.rec.reference_t_us - t))) for t in times]
        return factor * prep.reference_x[idx]  # float64, so that factor 1 is the reference exactly
    return method


def test_hdr_figure_methods_by_name_unbounded_outputs(prep, tmp_path, monkeypatch):
    # methods are called through akf.METHODS by name; outputs far above 1 x are drawn through the same tone map
    monkeypatch.setitem(akf.METHODS, "exact", _oracle(prep, 1.0))
    monkeypatch.setitem(akf.METHODS, "bright", _oracle(prep, 1000.0))
    res = plot_hdr_recovery(prep, tmp_path / "hdr.png", methods=["frames", "exact", "bright"], label="pan")
    assert_not_blank(tmp_path / "hdr.png")
    assert res["gain"] is None and list(res["images"]) == ["frames", "exact", "bright"]
    assert res["images"]["bright"].max() > 1e4
    np.testing.assert_array_equal(res["shown"]["exact"], res["shown"]["reference"])  # same mapping on both
    assert np.all(res["log_error"]["exact"] == 0)
    tone = res["tone_map"]
    lit = res["reference"] > tone.floor
    np.testing.assert_allclose(res["log_error"]["bright"][lit], np.log(1000.0), rtol=1e-5)
    # frames only never exceeds the frames' top, so it is below the reference wherever the reference is brighter
    hi = res["frames_range"][1]
    above = res["reference"] > 2 * hi
    assert above.sum() > 50 and np.all(res["shown"]["frames"][above] < res["shown"]["reference"][above])
    with pytest.raises(EvsimInputError, match="no methods"):
        plot_hdr_recovery(prep, tmp_path / "none.png", methods=[])


def test_make_hdr_figure_script(seq, tmp_path, monkeypatch, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_hdr_figure", ROOT / "docs" / "make_hdr_figure.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.default_methods() == ["frames", "akf"] + (["aks"] if "aks" in akf.METHODS else [])
    monkeypatch.setitem(akf.METHODS, "aks", akf.METHODS["frames"])
    assert script.default_methods() == ["frames", "akf", "aks"]
    assert script.main([str(seq), str(tmp_path / "fig.png"), "--methods", "frames", "cf", "--at-ms", "100"]) == 0
    assert_not_blank(tmp_path / "fig.png")
    assert "t = 100 ms" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        script.main([str(tmp_path / "none.h5"), str(tmp_path / "x.png")])
    assert e.value.code == 2 and "dataset not found" in capsys.readouterr().err


def test_missing_matplotlib_gives_the_install_hint(monkeypatch):
    from evsim_app.plots.common import pyplot

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes `import matplotlib` raise ImportError
    with pytest.raises(PlotDependencyError, match=r"pip install 'evsim\[plot\]'"):
        pyplot()
    # what colour-science leaves in sys.modules when matplotlib is missing
    monkeypatch.setitem(sys.modules, "matplotlib", MagicMock())
    with pytest.raises(PlotDependencyError, match=r"pip install 'evsim\[plot\]'"):
        pyplot()
    assert issubclass(PlotDependencyError, EvsimInputError)


@pytest.mark.slow  # a subprocess
def test_cli_without_matplotlib_exits_2_with_the_hint(seq):
    code = ("import sys; sys.modules['matplotlib'] = None\n"
            "import evsim_app.plots\n"
            "from evsim_app.cli import main\n"
            f"sys.exit(main(['plot', 'events', {str(seq)!r}]))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 2 and MATPLOTLIB_HINT in r.stderr and "Traceback" not in r.stderr


def test_cli_plot_commands(seq, tmp_path, capsys):
    out = tmp_path / "pix.png"
    assert main(["plot", "pixel", str(seq), "--x", "5", "--y", "7", "--n-times", "200", "--out", str(out)]) == 0
    assert_not_blank(out)
    assert main(["plot", "compare", str(seq), "--out", str(tmp_path / "cmp.png")]) == 0
    assert_not_blank(tmp_path / "cmp.png")
    capsys.readouterr()
    bad = [
        (["plot", "pixel", str(seq), "--x", "64", "--y", "0"], "outside the 64x48 sensor"),
        (["plot", "pixel", str(tmp_path / "none.h5"), "--x", "1", "--y", "1"], "dataset not found"),
        (["plot", "events", str(seq), "--window-ms", "0"], "--window-ms must be > 0"),
        (["plot", "events", str(seq), "--animate", str(tmp_path / "a.avi")], ".gif or .mp4"),
        (["plot", "compare", str(seq), "--methods", "magic"], "unknown method"),
        (["plot", "sweep", str(tmp_path)], "no index.json"),
    ]
    for argv, message in bad:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("evsim: error:") and message in err and "Traceback" not in err
    assert main(["plot", "pixel", str(seq), "--x", "1"]) == 2  # argparse: --y is required
