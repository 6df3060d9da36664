"""Issue 27, item 5: every --out / --config path case and every API case that was silently accepted (or raised
an undocumented exception) is a documented error naming the offending path or parameter; tiny inputs convert.

CLI cases run in this process (evsim_app.cli.main) and check the exit code 2, one "evsim: error:" line naming the
path and the problem, no traceback, and that nothing was written in the output's place.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import numpy as np
import pytest

import akf
import crf_models
import sim
from akf.params import AKFParams
from evsim_app.cli import main
from evsim_eval import metrics
from generators import load
from generators.config import load_config
from generators.scenes import Checkerboard, ImageMotionScene, MovingEdge, RotatingDisk, SunPatch, Trajectory
from generators.scenes.flow_interpolation import DIS_MIN_SIDE, FlowEstimator
from sim import EvsimInputError, InvalidParameterError

SMALL = ["--duration-s", "0.05", "--height", "8", "--width", "10", "--no-progress"]
GENERATE = ["generate", "ahdr", "--scene", "moving_edge", "--sensor", "ideal", *SMALL]
CONFIG = """[defaults]
duration_s = 0.05
height = 8
width = 10
sensor = "ideal"
[[sequence]]
name = "edge"
scene = { type = "moving_edge", speed_px_per_s = 60.0 }
"""


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("evsim: error: "), err
    return lines[0]


def _run_config(tmp_path, capsys, config: str, *must_name: str) -> str:
    out = tmp_path / "out"
    assert main(["generate", "ahdr", "--config", config, "--out", str(out), "--no-progress"]) == 2
    line = _one_error_line(capsys)
    for text in must_name:
        assert text in line, line
    assert not out.exists()  # refused before anything was written
    return line


# ----- --config ---------------------------------------------------------------------------------------------

def test_config_dangling_symlink(tmp_path, capsys):
    (tmp_path / "c.toml").symlink_to(tmp_path / "gone.toml")
    _run_config(tmp_path, capsys, str(tmp_path / "c.toml"), str(tmp_path / "c.toml"), "symbolic link",
                str(tmp_path / "gone.toml"), "does not exist")


def test_config_under_a_regular_file(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    _run_config(tmp_path, capsys, str(tmp_path / "f" / "c.toml"), str(tmp_path / "f"), "is a file, not a folder")


def test_config_that_is_a_folder(tmp_path, capsys):
    (tmp_path / "d").mkdir()
    _run_config(tmp_path, capsys, str(tmp_path / "d"), str(tmp_path / "d"), "is a folder, not a file")


def test_config_that_is_a_binary_file(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_bytes(bytes(np.random.default_rng(0).integers(128, 256, 300, dtype=np.uint8)))
    _run_config(tmp_path, capsys, str(path), str(path), "not UTF-8", "offset 0")


def test_config_with_invalid_utf8(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_bytes(b"seed = 1\n# caf\xe9\n")
    _run_config(tmp_path, capsys, str(path), str(path), "not UTF-8", "0xe9", "offset 14")


def test_config_that_does_not_exist(tmp_path, capsys):
    _run_config(tmp_path, capsys, str(tmp_path / "nope.toml"), str(tmp_path / "nope.toml"), "not found")


def test_config_that_is_empty_text(tmp_path, capsys):
    _run_config(tmp_path, capsys, "", "--config is empty")


def test_config_that_is_a_fifo_does_not_block(tmp_path, capsys):
    fifo = tmp_path / "c.toml"
    os.mkfifo(fifo)

    def feed():  # should the FIFO ever be opened, a valid configuration arrives and the test fails instead of hanging
        with open(fifo, "w") as f:
            f.write(CONFIG)

    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    _run_config(tmp_path, capsys, str(fifo), str(fifo), "not a regular file")
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # let the writer finish (its text fits the pipe's buffer)
    writer.join(timeout=10)
    os.close(reader)
    assert not writer.is_alive()


@pytest.mark.skipif(not Path("/dev/null").is_char_device(), reason="no /dev/null")
def test_config_that_is_a_device(tmp_path, capsys):
    _run_config(tmp_path, capsys, "/dev/null", "/dev/null", "not a regular file")


def test_config_that_cannot_be_read(tmp_path, capsys, monkeypatch):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG)
    if os.geteuid() != 0:  # a real unreadable file (root reads any file)
        path.chmod(0)
        _run_config(tmp_path, capsys, str(path), str(path), "Permission denied")
        path.chmod(0o644)
    real = Path.read_bytes

    def denied(self):
        if self == path:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self)

    monkeypatch.setattr(Path, "read_bytes", denied)
    _run_config(tmp_path, capsys, str(path), str(path), "cannot be read", "Permission denied")


def test_config_with_a_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "c.toml"
    path.write_bytes(b"\xef\xbb\xbf" + CONFIG.encode())
    assert [s.name for s in load_config(path).sequences] == ["edge"]


# ----- --out ------------------------------------------------------------------------------------------------

def _run_out(capsys, argv: list[str], *must_name: str) -> str:
    assert main(argv) == 2
    line = _one_error_line(capsys)
    for text in must_name:
        assert text in line, line
    return line


def test_out_empty_is_refused_and_the_current_folder_untouched(tmp_path, capsys, monkeypatch, tiny_dataset):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "keep.txt").write_text("precious")
    _run_out(capsys, [*GENERATE, "--out", ""], "--out is empty")
    _run_out(capsys, [*GENERATE, "--out", "", "--overwrite"], "--out is empty")
    _run_out(capsys, ["reconstruct", str(tiny_dataset / "a.h5"), "--out", "", "--overwrite", "--method", "frames"],
             "--out is empty")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.txt"]


def test_out_dangling_symlink(tmp_path, capsys, tiny_dataset):
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "gone")
    for argv in ([*GENERATE, "--out", str(link)],
                 ["reconstruct", str(tiny_dataset / "a.h5"), "--out", str(link), "--method", "frames"]):
        _run_out(capsys, argv, str(link), "symbolic link", "does not exist")
    assert link.is_symlink() and not (tmp_path / "gone").exists()


def test_out_under_a_regular_file(tmp_path, capsys):
    (tmp_path / "f").write_text("precious")
    _run_out(capsys, [*GENERATE, "--out", str(tmp_path / "f" / "sub")], str(tmp_path / "f"), "is a file, not a folder")
    assert (tmp_path / "f").read_text() == "precious"


def test_out_that_is_an_existing_file(tmp_path, capsys, tiny_dataset):
    f = tmp_path / "f"
    f.write_text("precious")
    _run_out(capsys, [*GENERATE, "--out", str(f), "--overwrite"], str(f), "not a folder")
    _run_out(capsys, ["convert", str(tiny_dataset), "--out", str(f), "--overwrite"], str(f), "not a folder")
    assert f.read_text() == "precious"


@pytest.mark.skipif(not Path("/dev/null").is_char_device(), reason="no /dev/null")
def test_out_that_is_a_device(capsys):
    _run_out(capsys, [*GENERATE, "--out", "/dev/null"], "/dev/null", "not a folder")


def test_out_with_a_name_too_long(tmp_path, capsys):
    _run_out(capsys, [*GENERATE, "--out", str(tmp_path / ("a" * 300))], "300 bytes", "255")
    assert list(tmp_path.iterdir()) == []


def test_out_where_nothing_can_be_created(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(os, "access", lambda path, mode: Path(path) != tmp_path)  # as a read-only mount answers
    _run_out(capsys, [*GENERATE, "--out", str(tmp_path / "new" / "out")], str(tmp_path), "not writable")
    _run_out(capsys, [*GENERATE, "--out", str(tmp_path)], str(tmp_path), "not writable")
    assert list(tmp_path.iterdir()) == []


def test_file_outputs_that_are_folders(tmp_path, capsys, tiny_dataset):
    (tmp_path / "d").mkdir()
    _run_out(capsys, ["evaluate", str(tiny_dataset / "a.h5"), "--json", str(tmp_path / "d")], str(tmp_path / "d"),
             "is a folder, not a file")
    _run_out(capsys, ["plot", "events", str(tiny_dataset / "a.h5"), "--out", str(tmp_path / "d")],
             str(tmp_path / "d"), "is a folder, not a file")


# ----- CLI inputs -------------------------------------------------------------------------------------------

def test_negative_npy_image_is_refused(tmp_path, capsys):
    img = np.full((20, 30), 0.5)
    img[5:10, 5:10] = -0.2  # far below rounding noise
    np.save(tmp_path / "x.npy", img)
    _run_out(capsys, ["generate", "ahdr", "--image", str(tmp_path / "x.npy"), "--out", str(tmp_path / "o"), *SMALL],
             str(tmp_path / "x.npy"), "negative radiance down to -0.2")
    assert not list((tmp_path / "o").glob("*"))  # no file (the scene is built by the sequence's task)
    # rounding noise of a merged EXR (1e-4 of the maximum) is clipped to 0, as documented
    np.save(tmp_path / "y.npy", np.where(img < 0, -5e-5, img))
    assert main(["generate", "ahdr", "--image", str(tmp_path / "y.npy"), "--out", str(tmp_path / "o"), *SMALL]) == 0


@pytest.mark.parametrize("array, match", [(np.ones((20, 30), complex), "complex128"),
                                          (np.ones((20, 30), bool), "dtype bool")])
def test_npy_image_of_non_real_values_is_refused(tmp_path, capsys, array, match):
    np.save(tmp_path / "x.npy", array)
    _run_out(capsys, ["generate", "ahdr", "--image", str(tmp_path / "x.npy"), "--out", str(tmp_path / "o"), *SMALL],
             str(tmp_path / "x.npy"), match)


def test_toml_crf_table_without_a_name(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.replace('sensor = "ideal"', 'sensor = "ideal"\ncrf = { params = { gamma = 2.0 } }'))
    _run_config(tmp_path, capsys, str(path), str(path), "defaults.crf.name", "missing")
    path.write_text(CONFIG.replace('sensor = "ideal"', 'sensor = "ideal"\ncrf = { name = "gama" }'))
    _run_config(tmp_path, capsys, str(path), "defaults.crf", "unknown CRF 'gama'")


def test_negative_sweep_value(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG + "[sweep]\nshot_noise_hz = [0.0, -2.0]\n")
    # refused when the configuration is read, also by `generate ahdr`, which does not run the sweep
    _run_config(tmp_path, capsys, str(path), "sweep.shot_noise_hz[1]", ">= 0", "-2.0")
    _run_out(capsys, ["generate", "sweep", "--scene", "moving_edge", "--out", str(tmp_path / "o"),
                      "--leak-hz", "0.1", "-0.5", *SMALL], "sweep.leak_hz[1]", "-0.5")
    _run_out(capsys, ["generate", "sweep", "--scene", "moving_edge", "--out", str(tmp_path / "o"),
                      "--hot-pixel-fraction", "1.5", *SMALL], "sweep.hot_pixel_fraction[0]", "[0, 1]")
    assert not (tmp_path / "o").exists()


# ----- API cases --------------------------------------------------------------------------------------------

def _akf_inputs():
    rng = np.random.default_rng(0)
    frames = rng.integers(50, 200, (3, 6, 8)).astype(np.uint8)
    t0 = np.array([0, 10_000, 20_000])
    ev = sim.make_events([5000, 15000], [1, 2], [1, 2], [1, -1])
    return ev, frames, t0, t0 + 1000, crf_models.get("linear")


EV, FRAMES, TS, TE, CRF = _akf_inputs()
IMG = np.full((8, 8), 0.5)
REF = np.linspace(0.1, 1.0, 64).reshape(8, 8)


def _reconstruct(**kw):
    return akf.reconstruct(EV, FRAMES, TS, TE, CRF, [20_500], **kw)


def _cf(**kw):
    return akf.complementary_filter(EV, FRAMES, TS, TE, CRF, [20_500], **kw)


# (what, call, exception, text the message must hold)
API_CASES = [
    ("akf contrast as a string", lambda: _reconstruct(contrast="0.2"), InvalidParameterError, "contrast"),
    ("akf contrast bool", lambda: _reconstruct(contrast=True), InvalidParameterError, "contrast"),
    ("akf contrast numpy bool", lambda: _reconstruct(contrast=np.bool_(True)), InvalidParameterError, "contrast"),
    ("akf contrast complex", lambda: _reconstruct(contrast=0.2 + 0.1j), InvalidParameterError, "contrast"),
    ("akf contrast object array", lambda: _reconstruct(contrast=np.array([0.2, "x"], object)),
     InvalidParameterError, "contrast"),
    ("akf max_intensity bool", lambda: _reconstruct(max_intensity=True), InvalidParameterError, "max_intensity"),
    ("akf bit_depth bool", lambda: _reconstruct(bit_depth=True), InvalidParameterError, "bit_depth"),
    ("cf contrast as a string", lambda: _cf(contrast="0.2"), InvalidParameterError, "contrast"),
    ("cf crossover_hz as a string", lambda: _cf(crossover_hz="1"), InvalidParameterError, "crossover_hz"),
    ("cf crossover_hz bool", lambda: _cf(crossover_hz=True), InvalidParameterError, "crossover_hz"),
    ("cf alpha complex", lambda: _cf(alpha=1j), InvalidParameterError, "alpha"),
    ("cf i0 negative", lambda: _cf(i0=-1e-3), InvalidParameterError, "i0"),
    ("direct i0 zero", lambda: akf.direct_integration(EV, FRAMES, TS, TE, CRF, [20_500], i0=0.0),
     InvalidParameterError, "i0"),
    ("AKFParams sigma_proc2 = 0", lambda: AKFParams(sigma_proc2=0.0), InvalidParameterError, "sigma_proc2"),
    ("AKFParams sigma_iso2 = 0", lambda: AKFParams(sigma_iso2=0.0), InvalidParameterError, "sigma_iso2"),
    ("AKFParams sigma_ref2 < 0", lambda: AKFParams(sigma_ref2=-0.1), InvalidParameterError, "sigma_ref2"),
    ("AKFParams sigma_im2 bool", lambda: AKFParams(sigma_im2=True), InvalidParameterError, "sigma_im2"),
    ("AKFParams max_variance < sigma_im2", lambda: AKFParams(max_variance=1e-7), InvalidParameterError,
     "max_variance"),
    ("AKFParams calib_scale_range scalar", lambda: AKFParams(calib_scale_range=0.0), InvalidParameterError,
     "calib_scale_range"),
    ("AKFParams calib_scale_range of 3", lambda: AKFParams(calib_scale_range=(0.5, 1.0, 2.0)),
     InvalidParameterError, "calib_scale_range"),
    ("AKFParams calib_scale_range strings", lambda: AKFParams(calib_scale_range=("a", "b")), InvalidParameterError,
     "calib_scale_range[0]"),
    ("AKFParams rho_bar_us fractional", lambda: AKFParams(rho_bar_us=1.5), InvalidParameterError, "rho_bar_us"),
    ("AKFParams calib_min_events fractional", lambda: AKFParams(calib_min_events=2.5), InvalidParameterError,
     "calib_min_events"),
    ("metrics on a negative image", lambda: metrics.mse(-IMG, REF), EvsimInputError, "the image has -0.5"),
    ("metrics on a negative reference", lambda: metrics.psnr(IMG, REF - 0.5), EvsimInputError, "the reference"),
    ("metrics on a NaN image", lambda: metrics.ssim(np.where(IMG > 0, np.nan, IMG), REF), EvsimInputError,
     "the image holds NaN"),
    ("metrics on a complex image", lambda: metrics.log_mse(IMG + 1j, REF), EvsimInputError, "complex128"),
    ("metrics on a bool image", lambda: metrics.mse01(IMG > 0, REF), EvsimInputError, "dtype bool"),
    ("psnr data_range negative", lambda: metrics.psnr(IMG, REF, data_range=-1.0), InvalidParameterError,
     "data_range"),
    ("ssim data_range bool", lambda: metrics.ssim(IMG, REF, data_range=True), InvalidParameterError, "data_range"),
    ("mse01 white as a string", lambda: metrics.mse01(IMG, REF, white="1"), InvalidParameterError, "white"),
    ("pu21 luminance_scale negative", lambda: metrics.pu21_ssim(IMG, REF, luminance_scale=-100.0),
     InvalidParameterError, "luminance_scale"),
    ("LDRCamera height bool", lambda: sim.LDRCamera(True, 4, sim.CameraParams(), CRF), InvalidParameterError,
     "height"),
    ("LDRCamera width numpy bool", lambda: sim.LDRCamera(4, np.bool_(True), sim.CameraParams(), CRF),
     InvalidParameterError, "width"),
    ("LDRCamera.expose complex radiance",
     lambda: sim.LDRCamera(4, 4, sim.CameraParams(), CRF).expose(np.ones((4, 4), complex), 1000),
     EvsimInputError, "radiance"),
    ("LDRCamera.expose object radiance",
     lambda: sim.LDRCamera(4, 4, sim.CameraParams(), CRF).expose(np.ones((4, 4), object), 1000),
     EvsimInputError, "radiance"),
    ("DVSEmulator height bool", lambda: sim.DVSEmulator(True, 4), InvalidParameterError, "height"),
    ("DVSEmulator width fractional", lambda: sim.DVSEmulator(4, 2.5), InvalidParameterError, "width"),
    ("DVSParams threshold bool", lambda: sim.DVSParams(pos_threshold=True), InvalidParameterError, "pos_threshold"),
    ("DVSParams refractory numpy bool", lambda: sim.DVSParams(refractory_us=np.bool_(True)), InvalidParameterError,
     "refractory_us"),
    ("CameraParams fps bool", lambda: sim.CameraParams(fps=True), InvalidParameterError, "fps"),
    ("CameraParams fps as a string", lambda: sim.CameraParams(fps="30"), InvalidParameterError, "fps"),
    ("CameraParams fps complex", lambda: sim.CameraParams(fps=30j), InvalidParameterError, "fps"),
    ("CameraParams n_subframes bool", lambda: sim.CameraParams(n_subframes=True), InvalidParameterError,
     "n_subframes"),
    ("CameraParams reference_fill as a string", lambda: sim.CameraParams(reference_fill="0.5"),
     InvalidParameterError, "reference_fill"),
    ("CameraParams reference_exposure_us NaN", lambda: sim.CameraParams(reference_exposure_us=float("nan")),
     InvalidParameterError, "reference_exposure_us"),
    ("CameraParams noise as a number", lambda: sim.CameraParams(noise=0), InvalidParameterError, "noise"),
    ("CameraParams frame_times_us scalar", lambda: sim.CameraParams(frame_times_us=5000), InvalidParameterError,
     "frame_times_us"),
    ("CameraParams exposure_us None", lambda: sim.CameraParams(exposure_us=None), InvalidParameterError,
     "exposure_us"),
    ("MovingEdge level beyond float32", lambda: MovingEdge(8, 8, 1000, high=1e300), InvalidParameterError, "high"),
    ("MovingEdge height bool", lambda: MovingEdge(True, 8, 1000), InvalidParameterError, "height"),
    ("MovingEdge duration bool", lambda: MovingEdge(8, 8, True), InvalidParameterError, "duration_us"),
    ("MovingEdge speed as a string", lambda: MovingEdge(8, 8, 1000, speed_px_per_s="100"), InvalidParameterError,
     "speed_px_per_s"),
    ("Checkerboard height numpy bool", lambda: Checkerboard(np.bool_(True), 8, 1000), InvalidParameterError,
     "height"),
    ("Checkerboard square as a string", lambda: Checkerboard(8, 8, 1000, square_px="4"), InvalidParameterError,
     "square_px"),
    ("RotatingDisk sectors bool", lambda: RotatingDisk(8, 8, 1000, sectors=True), InvalidParameterError, "sectors"),
    ("SunPatch velocity of 3", lambda: SunPatch(8, 8, 1000, velocity_px_per_s=(1.0, 2.0, 3.0)),
     InvalidParameterError, "velocity_px_per_s"),
    ("ImageMotionScene complex radiance", lambda: ImageMotionScene(np.ones((8, 8), complex), 1000),
     EvsimInputError, "complex128"),
    ("ImageMotionScene object image", lambda: ImageMotionScene(np.ones((8, 8), object), 1000), EvsimInputError,
     "object"),
    ("ImageMotionScene negative radiance", lambda: ImageMotionScene(-np.ones((8, 8)), 1000), EvsimInputError,
     "negative radiance"),
    ("ImageMotionScene height bool", lambda: ImageMotionScene(np.ones((8, 8)), 1000, height=True),
     InvalidParameterError, "height"),
    ("Trajectory pan bool", lambda: Trajectory(pan_px_per_s=(True, 0.0)), InvalidParameterError, "pan_px_per_s[0]"),
    ("Trajectory zoom as a string", lambda: Trajectory(zoom_per_s="1"), InvalidParameterError, "zoom_per_s"),
    ("FlowEstimator scale as a string", lambda: FlowEstimator((0.0, 1.0), scale="0.5"), InvalidParameterError,
     "flow scale"),
]


@pytest.mark.parametrize("what, call, error, name", API_CASES, ids=[c[0] for c in API_CASES])
def test_api_case_is_a_documented_error_naming_the_parameter(what, call, error, name):
    with pytest.raises(error) as info:
        call()
    assert name in str(info.value), str(info.value)


@pytest.mark.parametrize("value, match", [("true", "bool True"), ('"2"', "str '2'"), ("nan", "float nan")])
def test_crf_parameters_that_are_not_numbers(tmp_path, capsys, value, match):
    with pytest.raises(crf_models.CRFError, match=f"gamma must be a finite number, got {match}"):
        crf_models.get("gamma", gamma=__import__("tomllib").loads(f"v = {value}")["v"])
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.replace('sensor = "ideal"', f'sensor = "ideal"\ncrf = {{ name = "gamma", params = '
                                                       f'{{ gamma = {value} }} }}'))
    _run_config(tmp_path, capsys, str(path), "defaults.crf", "gamma must be a finite number")


def test_valid_values_of_the_same_kinds_still_work():
    """The checks refuse kinds, not values: numpy numbers, ints for floats, lists for pairs are accepted."""
    assert sim.DVSParams(refractory_us=np.int64(5)).refractory_us == 5
    assert type(sim.DVSParams(refractory_us=np.int64(5)).refractory_us) is int  # JSON-serialisable
    assert AKFParams(calib_scale_range=[0.5, 2]).calib_scale_range == (0.5, 2.0)
    assert AKFParams(rho_bar_us=np.int32(3000), sigma_im2=np.float32(1e-6)).rho_bar_us == 3000
    assert sim.LDRCamera(np.int64(4), 4, sim.CameraParams(fps=np.float64(25)), CRF).height == 4
    assert MovingEdge(np.int16(8), 8, np.int64(1000), speed_px_per_s=np.float32(10)).speed == 10.0
    out = _reconstruct(contrast=np.array([0.2, 0.25]))
    assert out.shape == (1, 6, 8) and np.all(np.isfinite(out)) and out.min() >= 0
    assert metrics.mse(REF, REF) == 0.0 and metrics.log_mse(np.zeros((8, 8)), np.zeros((8, 8))) == 0.0


# ----- tiny inputs ------------------------------------------------------------------------------------------

def _moving_bar(n: int, h: int, w: int) -> list[np.ndarray]:
    """n gray frames of h x w with a bright column at x = k in frame k (constant background)."""
    frames = []
    for k in range(n):
        img = np.full((h, w), 60, np.uint8)
        img[:, k] = 250
        frames.append(img)
    return frames


def _check_bar_moves_right(rec, columns) -> None:
    """ON events at a column come when the bar arrives there: their mean time grows column after column."""
    ev = rec.events
    on = ev[ev["p"] > 0]
    times = [on["t"][on["x"] == x].mean() for x in columns]
    assert all(np.isfinite(times)), times
    assert np.all(np.diff(times) > 0), times


def test_convert_a_tiny_image_folder(tmp_path, capsys):
    import cv2

    folder = tmp_path / "tiny"
    folder.mkdir()
    for k, img in enumerate(_moving_bar(6, 6, 9)):
        cv2.imwrite(str(folder / f"f{k:03d}.png"), img)
    assert main(["convert", str(folder), "--fps", "30", "--sensor", "ideal", "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0
    rec = load(tmp_path / "o" / "tiny.h5")
    assert (rec.height, rec.width) == (6, 9)
    _check_bar_moves_right(rec, range(1, 5))
    note = rec.metadata["scene"]["upsample"]["note"]
    assert "9x6 px" in note and f"{DIS_MIN_SIDE} px" in note and "padded" in note


def test_convert_a_tiny_video(tmp_path):
    import cv2

    path = tmp_path / "tiny.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (10, 8))
    for img in _moving_bar(10, 8, 10):
        writer.write(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    writer.release()
    assert main(["convert", str(path), "--sensor", "ideal", "--out", str(tmp_path / "o"), "--no-progress"]) == 0
    rec = load(tmp_path / "o" / "tiny.h5")
    assert (rec.height, rec.width) == (8, 10)
    _check_bar_moves_right(rec, range(2, 8))
    assert "padded" in rec.metadata["scene"]["upsample"]["note"]


def test_dis_flow_scale_rises_to_its_minimum_size():
    est = FlowEstimator((0.0, 1.0), scale=0.5)
    assert est.flow_size((260, 346)) == (130, 173) and est.flow_note((260, 346)) is None  # the usual case
    assert est.flow_size((20, 30)) == (12, 18)  # 0.5 would give 10 x 15, below DIS's 12
    assert "18x12 px" in est.flow_note((20, 30))  # width x height, as the other notes
    assert est.flow_size((6, 9)) == (6, 9)  # full size, padded inside flow()
    rng = np.random.default_rng(0)
    a = (rng.random((6, 9)) * 255).astype(np.uint8)
    f = est.flow(a, np.roll(a, 1, axis=1))
    assert f.shape == (6, 9, 2) and np.all(np.isfinite(f))
    assert FlowEstimator((0.0, 1.0), method="farneback").flow_note((6, 9)) is None  # any size
