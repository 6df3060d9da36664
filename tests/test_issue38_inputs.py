"""Nothing wrong gets in (issue 38): polarity values, the streaming reader, folders where files go, numbers that
break the maths, foreign text on stderr, API parameters, and the arguable cases of docs/guide/bad-input.md."""

from __future__ import annotations

import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from generators.formats import DatasetFormatError, export, load

from recordings import make_recording


def _export(rec, path, fmt: str, **kw) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # parts the format cannot hold
        export(rec, path, fmt, **kw)


# ----- polarity values ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("values", [(4, 2), (0.5, 1.0), (1, 7), (-2, 1)])
def test_e2vid_polarity_outside_its_encodings_is_refused(tmp_path, values):
    path = tmp_path / "e.h5"
    _export(make_recording(), path, "e2vid")
    with h5py.File(path, "a") as f:
        n = f["events/ps"].shape[0]
        del f["events/ps"]
        f["events/ps"] = np.resize(np.array(values, np.float64 if 0.5 in values else np.int64), n)
    with pytest.raises(DatasetFormatError, match=r"e\.h5: event polarity must be 0/1 or -1/\+1 \(0 and -1 are OFF\)"):
        load(path)


@pytest.mark.parametrize("value, found", [(0.5, "-1, 0.5, 1"), (7.0, "-1, 1, 7"), (-3.0, "-3, -1, 1")])
def test_akf_mat_polarity_outside_its_encodings_is_refused_and_zero_one_read(tmp_path, value, found):
    path = tmp_path / "a.mat"
    rec = make_recording()
    _export(rec, path, "akf-mat")
    m = {k: v for k, v in scipy.io.loadmat(path).items() if not k.startswith("__")}
    m["events"][5, 3] = value
    scipy.io.savemat(path, m)
    with pytest.raises(DatasetFormatError, match=rf"a\.mat: event polarity .*found values {found}$"):
        load(path)
    m["events"][:, 3] = (rec.events["p"] > 0).astype(np.float64)  # the 0/1 encoding: read
    scipy.io.savemat(path, m)
    np.testing.assert_array_equal(load(path).events["p"], rec.events["p"])


# ----- the streaming reader checks what load() checks ------------------------------------------------------------

def _evt2_with_event_at(path, x: int) -> None:
    """An EVT 2.0 file whose header says 64x48 and whose events hold one at column x (written as a 1024-wide
    sensor, then the header's width rewritten in place)."""
    rec = make_recording()
    rec.events["x"][100] = x
    rec.height, rec.width = 48, 1024
    for name in ("frames", "frame_t_start_us", "frame_t_mid_us", "frame_t_end_us", "reference", "reference_t_us",
                 "threshold_maps"):
        setattr(rec, name, None)
    _export(rec, path, "evt2")
    data = path.read_bytes()
    assert data.count(b"width=1024") == 1 and data.count(b"geometry 1024x48") == 1
    path.write_bytes(data.replace(b"width=1024", b"width=0064").replace(b"geometry 1024x48", b"geometry 0064x48"))


@pytest.mark.parametrize("x", [1000, 70])
def test_plot_video_refuses_an_event_outside_the_sensor(tmp_path, capsys, x):
    from evsim_app.cli import main

    src = tmp_path / "e.raw"
    _evt2_with_event_at(src, x)
    code = main(["plot", "events", str(src), "--video", str(tmp_path / "v.mp4")])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert lines[-1].startswith(f"evsim: error: {src}: ") and f"outside the 64x48 sensor (max x {x}" in lines[-1]
    assert not (tmp_path / "v.mp4").exists()


def test_every_stream_refuses_what_load_refuses(tmp_path):
    from generators.formats.streaming import open_event_stream

    src = tmp_path / "e.raw"
    _evt2_with_event_at(src, 70)
    with pytest.raises(DatasetFormatError, match="outside the 64x48 sensor"):
        load(src)
    stream = open_event_stream(src, size=64)
    for read in (lambda: list(stream.chunks()), lambda: stream.window(0, 2**40), lambda: stream.count):
        with pytest.raises(DatasetFormatError, match=r"e\.raw: .*outside the 64x48 sensor \(max x 70"):
            read()


def test_native_column_stream_refuses_coordinates_outside_the_sensor(tmp_path):
    from generators.formats.native import iter_native_columns

    path = tmp_path / "n.h5"
    _export(make_recording(), path, "native")
    with h5py.File(path, "a") as f:
        f["events/x"][7] = 8  # the sensor is 8 wide
    with pytest.raises(DatasetFormatError, match=r"n\.h5: event coordinates outside the 8x6 sensor \(max x 8"):
        list(iter_native_columns(path, ("t", "x")))


# ----- folders where files go ------------------------------------------------------------------------------------

@pytest.mark.parametrize("entry, flags", [("index.json", ["--overwrite"]), ("moving_edge.h5", ["--overwrite"]),
                                          ("moving_edge.manifest.json", ["--resume"]),
                                          ("moving_edge_e2vid.h5", ["--overwrite", "--format", "e2vid"])])
def test_a_folder_where_generate_writes_a_file_is_refused_before_work(tmp_path, capsys, entry, flags):
    from evsim_app.cli import main

    out = tmp_path / "o"
    (out / entry).mkdir(parents=True)
    code = main(["generate", "ahdr", "--scene", "moving_edge", "--duration-s", "0.1", "--height", "16", "--width",
                 "20", "--out", str(out), "--no-progress", *flags])
    err = capsys.readouterr().err
    assert code == 2 and err.strip() == (f"evsim: error: {out / entry} is a folder where this run writes a file: "
                                         "remove it or choose another output folder")
    assert sorted(p.name for p in out.iterdir()) == [entry]  # nothing written


def test_a_folder_named_as_the_video_is_refused_before_work(tmp_path, capsys):
    from evsim_app.cli import main

    src = tmp_path / "e.h5"
    _export(make_recording(), src, "native")
    (tmp_path / "v.mp4").mkdir()
    code = main(["plot", "events", str(src), "--video", str(tmp_path / "v.mp4")])
    err = capsys.readouterr().err
    assert code == 2 and err == f"evsim: error: --video {tmp_path / 'v.mp4'} is a folder, not a file\n"


# ----- numbers that break the maths ------------------------------------------------------------------------------

@pytest.mark.parametrize("bad, good, match", [
    ({"zoom_per_s": 1e6}, {"zoom_per_s": 499.0}, r"zoom_per_s 1e\+06 over 0.1 s magnifies by e\^1e\+05: .* must be "
                                                 r"in -36.89..500 per second"),
    ({"zoom_per_s": -200.0}, {"zoom_per_s": -36.0}, r"by e\^-20: .*up to e\^-3.69 \(beyond, the whole image"),
    ({"pan_px_per_s": (1e12, 0.0)}, {"pan_px_per_s": (1e8, 0.0)}, r"travels 1e\+11 output pixels.*most 1e\+07"),
    ({"shake_px": 1e12}, {"shake_px": 1e7}, r"with a shake of 1e\+12 pixels"),
])
def test_image_motion_outside_what_renders_is_refused_with_the_range(bad, good, match):
    import sim
    from generators.scenes import ImageMotionScene, Trajectory

    image = np.random.default_rng(0).uniform(0.1, 1, (64, 80)).astype(np.float32)
    with pytest.raises(sim.OptionError, match=match):
        ImageMotionScene(image, 100_000, Trajectory(**bad), height=16, width=20)
    scene = ImageMotionScene(image, 100_000, Trajectory(**good), height=16, width=20)  # inside the range: renders
    assert np.isfinite(scene.radiance(100_000)).all()


def test_generate_zoom_that_breaks_the_maths_is_a_usage_error(tmp_path, capsys):
    from evsim_app.cli import main

    np.save(tmp_path / "P.npy", np.random.default_rng(0).uniform(0.1, 1, (64, 80)).astype(np.float32))
    code = main(["generate", "ahdr", "--image", str(tmp_path / "P.npy"), "--zoom", "1e6", "--duration-s", "0.1",
                 "--height", "16", "--width", "20", "--out", str(tmp_path / "o"), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("evsim: error: --zoom 1e+06 (trajectory.zoom_per_s) over 0.1 s") \
        and err.endswith("so it must be in -36.89..500 per second") and "\n" not in err


# ----- foreign text on stderr ------------------------------------------------------------------------------------

AEDAT4 = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "tonic_sample_dvxplorer.aedat4"


@pytest.mark.skipif(not AEDAT4.is_file(), reason="needs the shared AEDAT4 sample")
def test_a_decoder_panic_prints_only_evsims_line(tmp_path, capfd, monkeypatch):
    pytest.importorskip("aedat")
    from evsim_app.cli import main

    data = bytearray(AEDAT4.read_bytes())
    data[249] = 0x94  # inside the XML header: not UTF-8, where the decoder's XML parser panics
    bad = tmp_path / "bad.aedat4"
    bad.write_bytes(bytes(data))
    monkeypatch.setenv("RUST_BACKTRACE", "1")
    assert main(["info", str(bad)]) == 2
    err = capfd.readouterr().err
    assert err.startswith(f"evsim: error: {bad}: unreadable AEDAT4 file (corrupt?): the aedat decoder failed: ") \
        and err.count("\n") == 1, err


# ----- API parameters ----------------------------------------------------------------------------------------------

def test_preset_overrides_that_are_not_fields_are_named_with_a_suggestion():
    import sim

    with pytest.raises(sim.InvalidParameterError, match=r"DVSParams.preset: unknown DVSParams field 'bogus'; allowed: "
                                                        r"pos_threshold, "):
        sim.DVSParams.preset("davis346", bogus=1)
    with pytest.raises(sim.InvalidParameterError, match=r"unknown DVSParams field 'pos_treshold' \(did you mean "
                                                        r"'pos_threshold'\?\)"):
        sim.DVSParams.preset("davis346", pos_treshold=0.2)
    with pytest.raises(sim.InvalidParameterError, match=r"CameraParams.preset: unknown CameraParams field 'exposure' "
                                                        r"\(did you mean 'exposure_us'\?\)"):
        sim.CameraParams.preset("ideal", exposure=3)


def test_capture_of_complex_radiance_is_refused():
    import crf_models
    from sim import CameraParams, EvsimInputError, LDRCamera

    class Complex:
        height, width, duration_us = 4, 5, 100_000

        def radiance(self, t_us):
            return np.full((4, 5), 0.5 + 0.5j)

        def max_speed_px_per_s(self):
            return 0.0

    camera = LDRCamera(4, 5, CameraParams(), crf_models.get("linear"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not a numpy ComplexWarning: evsim's error
        with pytest.raises(EvsimInputError, match=r"source.radiance\(\d+\) must hold real numbers .* complex128"):
            next(camera.capture(Complex()))


@pytest.mark.parametrize("time", ["--5", "²"])
def test_exr_timestamps_line_that_int_cannot_read_names_the_file_and_line(tmp_path, time):
    from generators.formats.exr import read_exr_sequence, write_exr

    write_exr(tmp_path / "frame.exr", np.ones((3, 4), np.float32))
    (tmp_path / "timestamps.txt").write_text(f"# t_us file\n{time} frame.exr\n")
    with pytest.raises(DatasetFormatError, match=r"timestamps.txt: line 2: expected 't_us file_name'"):
        read_exr_sequence(tmp_path)


# ----- the arguable cases (docs/guide/bad-input.md, "Arguable input") -----------------------------------------------

def test_e2vid_integer_times_are_refused_not_read_as_seconds(tmp_path):
    path = tmp_path / "e.h5"
    rec = make_recording()
    _export(rec, path, "e2vid")
    with h5py.File(path, "a") as f:
        del f["events/ts"]
        f["events/ts"] = rec.events["t"] - rec.events["t"][0]  # int64 microseconds: 2.5e6 would be 29 days
    with pytest.raises(DatasetFormatError, match=r"e\.h5: events/ts holds integers \(int64\), where the E2VID layout "
                                                 r"stores float seconds: the unit is not guessed"):
        load(path)


@pytest.mark.parametrize("fmt", ["evt3", "evt2"])
def test_a_long_silence_in_an_evt_stream_is_read_with_a_note(tmp_path, fmt):
    from generators.formats import ReaderNoteWarning
    from generators.formats.streaming import open_event_stream

    rec = make_recording()
    rec.events["t"][-1] += 40_000_000  # the last event 40 s after the others: a TIME_HIGH jump on disk
    path = tmp_path / "e.raw"
    _export(rec, path, fmt)
    with pytest.warns(ReaderNoteWarning, match=r"e\.raw: no events for 40 s before the one at "
                                                rf"{rec.events['t'][-1]} us: read as a pause"):
        np.testing.assert_array_equal(load(path).events["t"], rec.events["t"])
    with pytest.warns(ReaderNoteWarning, match="read as a pause"):
        assert open_event_stream(path, size=256).t_range == (rec.events["t"][0], rec.events["t"][-1])


@pytest.mark.parametrize("fmt, suffix, line, value", [
    ("evt3", "raw", b"% evsim_time_base us", b"% evsim_time_base ns"),
    ("dat", "dat", b"% evsim_polarity 1=ON 0=OFF", b"% evsim_polarity 0=ON 1=OFF"),
    ("aedat2", "aedat2", b"# evsim_time_base us", b"# evsim_time_base ms"),
])
def test_evsims_own_header_keys_are_read_back(tmp_path, fmt, suffix, line, value):
    path = tmp_path / f"e.{suffix}"
    _export(make_recording(), path, fmt)
    data = path.read_bytes()
    assert data.count(line) == 1
    path.write_bytes(data.replace(line, value))
    key = line.split()[1].decode()
    with pytest.raises(DatasetFormatError, match=rf"header key {key}: '{value.split(maxsplit=2)[2].decode()}', where "
                                                 "evsim writes and reads only"):
        load(path)


def test_aedat2_chip_line_of_another_layout_is_refused_beside_evsims_geometry(tmp_path):
    path = tmp_path / "e.aedat2"
    _export(make_recording(), path, "aedat2")
    head, sep, rest = path.read_bytes().partition(b"\r\n")
    path.write_bytes(head + sep + b"# AEChip: ch.unizh.ini.jaer.chip.retina.DVS128\r\n" + rest)
    with pytest.raises(DatasetFormatError, match=r"AEChip ch.unizh.ini.jaer.chip.retina.DVS128: only the DAVIS"):
        load(path)
    path.write_bytes(head + sep + b"# AEChip: eu.seebetter.ini.chips.davis.Davis346B\r\n" + rest)
    with pytest.raises(DatasetFormatError, match=r"header keys disagree: AEChip .*Davis346B is 346x260, "
                                                 r"evsim_geometry says 8x6"):
        load(path)


def test_dat_polarity_field_other_than_zero_or_one_is_refused(tmp_path):
    path = tmp_path / "e.dat"
    _export(make_recording(), path, "dat")
    data = bytearray(path.read_bytes())
    start = len(data) - 3000 * 8  # the events: 8 bytes each, at the end
    data[start + 8 * 10 + 7] = (data[start + 8 * 10 + 7] & 0x0F) | (3 << 4)  # event 10's p (bits 31..28) = 3
    path.write_bytes(bytes(data))
    with pytest.raises(DatasetFormatError, match=r"e\.dat: event polarity must be 0/1 or -1/\+1 .*values 0, 1, 3"):
        load(path)


def test_evt2_word_of_an_undefined_type_is_refused(tmp_path):
    path = tmp_path / "e.raw"
    _export(make_recording(), path, "evt2")
    data = bytearray(path.read_bytes())
    w = np.frombuffer(bytes(data[-4 * 100:]), "<u4").copy()
    i = int(np.flatnonzero((w >> 28) <= 1)[0])  # a CD word: its type nibble (the polarity) becomes 0x3
    w[i] = (int(w[i]) & 0x0FFF_FFFF) | (0x3 << 28)
    data[-4 * 100:] = w.tobytes()
    path.write_bytes(bytes(data))
    with pytest.raises(DatasetFormatError, match=r"e\.raw: EVT 2\.0 word of undefined type 0x3 at byte \d+"):
        load(path)


def test_a_corrupt_ijrr_image_prints_only_evsims_line(tmp_path, capfd):
    from evsim_app.cli import main

    folder = tmp_path / "ijrr"
    _export(make_recording(), folder, "ijrr")
    png = sorted((folder / "images").glob("*.png"))[1]
    data = bytearray(png.read_bytes())
    at = data.index(b"IDAT") + 8
    data[at : at + 8] = b"\xff" * 8  # inside the compressed pixels: libpng's "incorrect data check" and the like
    png.write_bytes(bytes(data))
    assert main(["info", str(folder)]) == 2
    err = capfd.readouterr().err
    assert err.startswith(f"evsim: error: {png}: missing or unreadable image") and err.count("\n") == 1, err


def test_a_corrupt_exr_frame_prints_only_evsims_line(tmp_path, capfd):
    from evsim_app.cli import main
    from generators.formats.exr import write_exr_sequence

    folder = tmp_path / "exr"
    write_exr_sequence(folder, np.ones((2, 6, 8), np.float32), np.array([0, 1000]))
    frame = sorted(folder.glob("*.exr"))[1]
    data = bytearray(frame.read_bytes())
    data[-7] ^= 0xFF  # inside the compressed pixels: OpenEXR prints "Warning: ... Unable to run decoder" on stdout
    frame.write_bytes(bytes(data))
    assert main(["info", str(folder)]) == 2
    out, err = capfd.readouterr()
    assert out == "" and err.startswith(f"evsim: error: {frame}: not a readable OpenEXR file") \
        and err.count("\n") == 1, (out, err)


def test_evt3_word_of_an_undefined_type_is_refused(tmp_path):
    path = tmp_path / "e.raw"
    _export(make_recording(), path, "evt3")
    data = bytearray(path.read_bytes())
    data[-2 * 50 + 1] = (data[-2 * 50 + 1] & 0x0F) | 0x90  # a word near the end: type 0x9
    path.write_bytes(bytes(data))
    with pytest.raises(DatasetFormatError, match=r"e\.raw: EVT 3\.0 word of undefined type 0x9 at byte \d+"):
        load(path)


@pytest.mark.parametrize("suffix", [".png", ".exr"])
def test_a_corrupt_scene_image_prints_only_evsims_line(tmp_path, capfd, suffix):
    """generate ahdr --image of a corrupt PNG (libpng's complaints) or EXR (OpenEXR's warnings on stdout): only
    evsim's own line, exit 2."""
    import cv2

    from evsim_app.cli import main
    from generators.formats.exr import write_exr_sequence

    image = tmp_path / f"photo{suffix}"
    if suffix == ".png":
        cv2.imwrite(str(image), (np.arange(64 * 48) % 251).reshape(48, 64).astype(np.uint8))
        data = bytearray(image.read_bytes())
        at = data.index(b"IDAT") + 8
        data[at: at + 8] = b"\xff" * 8
    else:
        write_exr_sequence(tmp_path / "seq", np.ones((1, 48, 64), np.float32), np.array([0]))
        data = bytearray((tmp_path / "seq" / "frame_000000.exr").read_bytes())
        data[-7] ^= 0xFF
    image.write_bytes(bytes(data))
    capfd.readouterr()
    code = main(["generate", "ahdr", "--image", str(image), "--duration-s", "0.1", "--out", str(tmp_path / "o"),
                 "--no-progress"])
    out, err = capfd.readouterr()
    assert code == 2 and err.startswith("evsim: error: ") and err.count("\n") == 1, (code, out, err)
    assert str(image) in err and "Warning" not in out and "libpng" not in out + err


def test_a_truncated_video_prints_only_evsims_line(tmp_path, capfd):
    """convert of an MP4 cut after 100 bytes: FFmpeg's "moov atom not found" stays off stderr, evsim's line says it
    (exit 2)."""
    import cv2

    from evsim_app.cli import main

    whole = tmp_path / "whole.mp4"
    writer = cv2.VideoWriter(str(whole), cv2.VideoWriter_fourcc(*"mp4v"), 25, (64, 48))
    for k in range(5):
        writer.write(np.full((48, 64, 3), 40 * k, np.uint8))
    writer.release()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole.read_bytes()[:100])
    capfd.readouterr()
    code = main(["convert", str(cut), "--out", str(tmp_path / "o"), "--no-progress"])
    out, err = capfd.readouterr()
    assert code == 2 and err.startswith(f"evsim: error: {cut}: cannot open as a video") and err.count("\n") == 1, \
        (code, out, err)
