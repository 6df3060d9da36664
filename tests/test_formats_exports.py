"""Export profiles (E2VID HDF5, IJRR text, AKF .mat, OpenEXR): layout, round trips, real-style inputs, errors."""

from __future__ import annotations

import json

import cv2
import h5py
import numpy as np
import pytest
import scipy.io

import crf_models
from generators.formats import DatasetFormatError, detect, export, load
from generators.formats.akfmat import authors_f_q, read_akf_mat
from generators.formats.exr import read_exr, read_exr_sequence, write_exr
from generators.formats.ijrr import seconds_text
from generators.formats.native import write_native
from sim import EvsimInputError

from recordings import T0, H, W, assert_recordings_equal, files_in, make_recording


# -- E2VID ------------------------------------------------------------------------------------------------------
def test_e2vid_layout_matches_event_cnn_minimal(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "e.h5", "e2vid")
    ev = rec.events
    with h5py.File(tmp_path / "e.h5") as f:
        assert {k: f["events"][k].dtype.str for k in ("xs", "ys", "ts", "ps")} == {
            "xs": "<i2", "ys": "<i2", "ts": "<f8", "ps": "|b1"}
        np.testing.assert_array_equal(f["events/ps"][()], ev["p"] > 0)
        a = f.attrs
        assert tuple(a["sensor_resolution"]) == (H, W) and a["num_imgs"] == 4
        assert (a["num_events"], a["num_pos"], a["num_neg"]) == (ev.size, (ev["p"] > 0).sum(), (ev["p"] < 0).sum())
        assert a["t0"] == ev["t"][0] / 1e6 and a["tk"] == ev["t"][-1] / 1e6
        assert a["duration"] == pytest.approx((ev["t"][-1] - ev["t"][0]) / 1e6, abs=1e-9)
        names = sorted(f["images"])
        assert names[0] == "image000000000" and len(names) == 4
        for i, name in enumerate(names):
            img = f["images"][name]
            assert img.dtype == np.uint8 and tuple(img.attrs["size"]) == (H, W)
            assert img.attrs["timestamp"] == rec.frame_t_mid_us[i] / 1e6
            # event_idx as event_utils' own writer stores it (github.com/TimoStoff/event_utils,
            # lib/data_formats/event_packagers.py, hdf5_packager.add_event_indices): one before the first
            # event at or after the frame's timestamp, max(0, i - 1).
            first = np.searchsorted(ev["t"], rec.frame_t_mid_us[i], side="left")
            assert img.attrs["event_idx"] == max(0, first - 1)


def test_e2vid_round_trip_is_exact_after_rounding_seconds_to_microseconds(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "e.h5", "e2vid")
    assert detect(tmp_path / "e.h5") == "e2vid"
    assert_recordings_equal(rec, load(tmp_path / "e.h5"))
    # The stored float64 seconds themselves are within half a microsecond of the truth at T0 ~ 1.2e5 s.
    with h5py.File(tmp_path / "e.h5") as f:
        assert np.max(np.abs(f["events/ts"][()] * 1e6 - rec.events["t"])) < 0.5


def test_e2vid_reduces_deep_frames_to_8_bits(tmp_path):
    rec = make_recording(bit_depth=12)
    export(rec, tmp_path / "e.h5", "e2vid")
    back = load(tmp_path / "e.h5")
    assert back.frame_bit_depth == 8
    np.testing.assert_array_equal(back.frames, (rec.frames >> 4).astype(np.uint8))
    assert_recordings_equal(rec, back, skip=("frames", "frame_bit_depth"))


def test_e2vid_reads_foreign_files_without_evsim_extras(tmp_path):
    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["events/xs"] = np.array([1, 2], np.int16)
        f["events/ys"] = np.array([0, 3], np.int16)
        f["events/ts"] = np.array([0.5, 1.25])
        f["events/ps"] = np.array([1, 0], np.uint8)
        f["images/image000000000"] = np.full((4, 5), 7, np.uint8)
        f["images/image000000000"].attrs["timestamp"] = 1.0
    rec = load(tmp_path / "foreign.h5")
    assert (rec.height, rec.width) == (4, 5)
    np.testing.assert_array_equal(rec.events["t"], [500_000, 1_250_000])
    np.testing.assert_array_equal(rec.events["p"], [1, -1])
    np.testing.assert_array_equal(rec.frame_t_start_us, [1_000_000])
    assert rec.reference is None and rec.crf is None and rec.metadata == {}


# -- IJRR -------------------------------------------------------------------------------------------------------
def test_ijrr_text_is_exact_microseconds(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "ij", "ijrr")
    lines = (tmp_path / "ij" / "events.txt").read_text().splitlines()
    e = rec.events[0]
    assert lines[0] == f"{e['t'] // 10**6}.{e['t'] % 10**6:06d} {e['x']} {e['y']} {int(e['p'] > 0)}"
    assert len(lines) == rec.events.size
    img_lines = (tmp_path / "ij" / "images.txt").read_text().splitlines()
    assert img_lines[1] == f"{seconds_text(rec.frame_t_mid_us[1])} images/frame_00000001.png"
    assert seconds_text(-1) == "-0.000001" and seconds_text(1_500_000) == "1.500000"
    exp = (tmp_path / "ij" / "exposures.txt").read_text().splitlines()
    assert exp[2] == f"{seconds_text(rec.frame_t_start_us[2])} {seconds_text(rec.frame_t_end_us[2])}"


@pytest.mark.parametrize("bit_depth", [8, 16])
def test_ijrr_round_trip_is_exact(tmp_path, bit_depth):
    rec = make_recording(bit_depth=bit_depth)
    export(rec, tmp_path / "ij", "ijrr")
    assert detect(tmp_path / "ij") == "ijrr" and detect(tmp_path / "ij" / "events.txt") == "ijrr"
    assert_recordings_equal(rec, load(tmp_path / "ij"))
    png = cv2.imread(str(tmp_path / "ij" / "images" / "frame_00000000.png"), cv2.IMREAD_UNCHANGED)
    assert png.dtype == (np.uint8 if bit_depth == 8 else np.uint16)


def test_ijrr_reads_the_original_dataset_layout(tmp_path):
    """As published: 9-decimal seconds, no exposures, no evsim extras, extra files present, RGB-free PNGs."""
    d = tmp_path / "shapes_rotation"
    (d / "images").mkdir(parents=True)
    (d / "events.txt").write_text("0.000000000 33 39 1\n0.000011000 158 145 1\n0.000050000 88 143 0\n"
                                  "1468939993.067416000 3 5 0\n")
    (d / "calib.txt").write_text("199.092366542 198.82882047 132.192071378 110.712660011 0 0 0 0 0\n")
    for i in range(2):
        cv2.imwrite(str(d / "images" / f"frame_{i:08d}.png"), np.full((180, 240), 10 * i, np.uint8))
    (d / "images.txt").write_text("0.000000000 images/frame_00000000.png\n0.044065000 images/frame_00000001.png\n")
    rec = load(d)
    np.testing.assert_array_equal(rec.events["t"], [0, 11, 50, 1_468_939_993_067_416])
    np.testing.assert_array_equal(rec.events["p"], [1, 1, -1, -1])
    assert (rec.height, rec.width) == (180, 240) and rec.frames.shape == (2, 180, 240)
    np.testing.assert_array_equal(rec.frame_t_mid_us, [0, 44_065])
    np.testing.assert_array_equal(rec.frame_t_start_us, rec.frame_t_mid_us)  # exposure unknown
    assert rec.frame_bit_depth == 8 and rec.event_labels is None and rec.crf is None


def test_ijrr_errors_name_the_file_and_line_problem(tmp_path):
    d = tmp_path / "bad"
    d.mkdir()
    (d / "events.txt").write_text("0.1 1 2 1\n0.2 1 2\n")
    with pytest.raises(DatasetFormatError, match="events.txt: malformed line"):
        load(d)
    (d / "events.txt").write_text("0.1 1 2 1\n0.05 1 2 1\n")
    with pytest.raises(DatasetFormatError, match="events.txt.*not sorted"):
        load(d)
    (d / "events.txt").write_text("0.1 1 2 1\n")
    (d / "images.txt").write_text("0.1 images/frame_00000000.png\n")
    with pytest.raises(DatasetFormatError, match="frame_00000000.png: missing or unreadable image"):
        load(d)


def test_ijrr_export_is_atomic_at_folder_level(tmp_path, monkeypatch, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "ij", "ijrr")
    before = {p.name: p.read_bytes() for p in (tmp_path / "ij").iterdir() if p.is_file()}
    calls, real_imencode = [], cv2.imencode

    def imencode_fails_on_the_third_frame(ext, img):
        calls.append(ext)
        return real_imencode(ext, img) if len(calls) < 3 else (False, None)

    monkeypatch.setattr(cv2, "imencode", imencode_fails_on_the_third_frame)  # (ijrr imports cv2 on first use)
    with pytest.raises(OSError, match="could not write"):
        export(make_recording(seed=1), tmp_path / "ij", "ijrr")
    monkeypatch.undo()
    assert len(calls) == 3
    assert files_in(tmp_path) == ["ij"]
    assert {p.name: p.read_bytes() for p in (tmp_path / "ij").iterdir() if p.is_file()} == before
    negative = make_recording()
    negative.events["t"] -= T0 + 1_000_000
    assert negative.events["t"][0] < 0
    with pytest.raises(EvsimInputError, match="non-negative"):
        export(negative, tmp_path / "neg", "ijrr")
    assert files_in(tmp_path) == ["ij"]
    inconsistent = make_recording()
    inconsistent.frames = inconsistent.frames[:2]
    with pytest.raises(EvsimInputError, match="frame_t_start_us must have one entry per frame"):
        export(inconsistent, tmp_path / "bad", "ijrr")


# -- AKF .mat ---------------------------------------------------------------------------------------------------
def test_akf_mat_variables_follow_the_authors_conventions(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "a.mat", "akf-mat")
    m = scipy.io.loadmat(tmp_path / "a.mat")
    ev = rec.events
    np.testing.assert_array_equal(m["events"], np.column_stack([ev["t"], ev["x"] + 1, ev["y"] + 1, ev["p"]]))
    assert m["events"][0, 1:3].tolist() == [W, H]  # far corner, 1-based
    assert m["image"].shape == (H, W, 4) and m["image"].dtype == np.uint8
    np.testing.assert_array_equal(m["image"][:, :, 2], rec.frames[2])
    np.testing.assert_array_equal(m["time_image"].ravel(), rec.frame_t_mid_us)
    np.testing.assert_array_equal(m["exposure"].ravel(), rec.frame_t_end_us - rec.frame_t_start_us)
    assert (m["im_height"].item(), m["im_width"].item()) == (H, W)
    assert m["ct"].item() == pytest.approx(rec.threshold_maps.mean(), rel=1e-6)
    assert m["f_Q"].shape == (256, 1)


def test_akf_mat_vectors_are_the_columns_the_authors_code_indexes(tmp_path, tiny_recording):
    # github.com/ziweiWWANG/AKF, deblur_edge_left.m: t1 = time_image(img_idx_now, 1) - exposure/2 for every frame
    # from the second on; with a 1 x F row this is "time_image(2,_): out of bound". akf_reconstruction.m indexes
    # exposure(i) and f_Q(z + 1) linearly, which columns satisfy too.
    rec = tiny_recording
    export(rec, tmp_path / "a.mat", "akf-mat")
    m = scipy.io.loadmat(tmp_path / "a.mat")
    nf = rec.frames.shape[0]
    for name in ("time_image", "exposure", "evsim_frame_t_start_us", "evsim_frame_t_end_us"):
        assert m[name].shape == (nf, 1), name
    for i in range(1, nf + 1):  # MATLAB's time_image(i, 1), 1-based
        assert m["time_image"][i - 1, 0] == rec.frame_t_mid_us[i - 1]
    assert m["evsim_event_labels"].shape == (rec.events.size, 1)
    assert m["evsim_reference_t_us"].shape == (rec.reference.shape[0], 1)
    # files written before (1 x F rows) still read the same
    rows = {k: (v.T if isinstance(v, np.ndarray) and v.ndim == 2 and v.shape[1] == 1 and k != "events" else v)
            for k, v in m.items() if not k.startswith("__")}
    scipy.io.savemat(tmp_path / "old.mat", rows)
    old, new = read_akf_mat(tmp_path / "old.mat"), read_akf_mat(tmp_path / "a.mat")
    assert old.metadata == new.metadata
    assert_recordings_equal(new, old, skip=("metadata",))


def test_akf_mat_round_trip_is_exact(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "a.mat", "akf-mat")
    assert detect(tmp_path / "a.mat") == "akf-mat"
    back = load(tmp_path / "a.mat")
    assert_recordings_equal(rec, back, skip=("metadata",))
    akf = back.metadata.pop("akf_mat")
    assert back.metadata == rec.metadata
    assert akf["ct"] == pytest.approx(rec.threshold_maps.mean(), rel=1e-6) and len(akf["f_Q"]) == 256


def test_f_q_is_the_authors_table_for_robertson_and_floored_where_the_crf_clips(tmp_path, tiny_recording):
    rec = tiny_recording
    rec.crf = {"name": "gamma", "params": {"gamma": 2.2, "weighting": "robertson"}}
    export(rec, tmp_path / "r.mat", "akf-mat")
    z = np.arange(256)
    authors = np.maximum(np.exp(-4 * (z - 127.5) ** 2 / 127.5**2), 0.09) * 7e5
    np.testing.assert_allclose(authors_f_q(), authors, rtol=1e-12)
    np.testing.assert_allclose(scipy.io.loadmat(tmp_path / "r.mat")["f_Q"].ravel(), authors, rtol=1e-9)
    # The AHDR window CRF clips at 0 and 255: those responses carry no information, f_Q hits its floor
    # 0.09 * 7e5; inside, 1/Rbar = 7e5 * f^w(y) where that exceeds the floor.
    rec.crf = {"name": "window", "params": {"low": 100.0, "high": 160.0}}
    export(rec, tmp_path / "w.mat", "akf-mat")
    f_q = scipy.io.loadmat(tmp_path / "w.mat")["f_Q"].ravel()
    assert f_q[0] == pytest.approx(0.09 * 7e5) and f_q[255] == pytest.approx(0.09 * 7e5)
    w = crf_models.get("window", low=100.0, high=160.0).weight(z / 255)
    np.testing.assert_allclose(f_q[1:255], np.maximum(w[1:255], 0.09) * 7e5, rtol=1e-9)
    rec.crf = None
    export(rec, tmp_path / "n.mat", "akf-mat")
    np.testing.assert_allclose(scipy.io.loadmat(tmp_path / "n.mat")["f_Q"].ravel(), authors, rtol=1e-9)


def test_akf_mat_reads_the_authors_sample_layout(tmp_path):
    """Their datasets: doubles everywhere, column vectors, a longer exposure vector, polarity 0/1, extra
    variables; and MATLAB v7.3 (HDF5, transposed) files."""
    ev = np.array([[1000, 1, 1, 1], [1500, 3, 2, 0], [2500, 3, 2, -1]], np.float64)
    image = np.stack([np.full((2, 3), 5.0), np.full((2, 3), 250.0)], axis=2)
    data = {"events": ev, "image": image, "time_image": np.array([[1200.0], [2200.0]]),
            "exposure": np.array([[400.0, 401.0, 999.0]]), "im_height": 2.0, "im_width": 3.0, "ct": 0.15,
            "f_Q": authors_f_q(), "post_process": 2.0}
    scipy.io.savemat(tmp_path / "city.mat", data)
    with h5py.File(tmp_path / "v73.mat", "w", userblock_size=512) as f:
        for k, v in data.items():
            f[k] = np.asarray(v).T
    with open(tmp_path / "v73.mat", "r+b") as fh:  # the MATLAB 7.3 header in the HDF5 user block
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(116) + bytes(8) + b"\x00\x02IM")
    for name in ("city.mat", "v73.mat"):
        rec = read_akf_mat(tmp_path / name)
        np.testing.assert_array_equal(rec.events["t"], [1000, 1500, 2500])
        np.testing.assert_array_equal(rec.events["x"], [0, 2, 2])
        np.testing.assert_array_equal(rec.events["y"], [0, 1, 1])
        np.testing.assert_array_equal(rec.events["p"], [1, -1, -1])
        assert rec.frames.shape == (2, 2, 3) and rec.frames[1, 0, 0] == 250
        np.testing.assert_array_equal(rec.frame_t_start_us, [1000, 2000])
        np.testing.assert_array_equal(rec.frame_t_end_us, [1400, 2401])
        assert rec.metadata["akf_mat"]["ct"] == 0.15 and rec.metadata["akf_mat"]["post_process"] == 2.0


def test_akf_mat_errors(tmp_path):
    scipy.io.savemat(tmp_path / "partial.mat", {"events": np.zeros((0, 4)), "image": np.zeros((2, 2, 1))})
    with pytest.raises(DatasetFormatError, match=r"partial\.mat: missing variable\(s\) time_image, exposure, "
                                                 r"im_height, im_width"):
        load(tmp_path / "partial.mat")
    export(make_recording(), tmp_path / "a.mat", "akf-mat")
    data = (tmp_path / "a.mat").read_bytes()
    (tmp_path / "a.mat").write_bytes(data[: len(data) // 2])
    with pytest.raises(DatasetFormatError, match=r"a\.mat: not a readable MATLAB"):
        load(tmp_path / "a.mat")
    no_ct = make_recording()
    no_ct.threshold_maps, no_ct.metadata = None, {}
    with pytest.raises(EvsimInputError, match="contrast threshold"):
        export(no_ct, tmp_path / "b.mat", "akf-mat")
    export(no_ct, tmp_path / "b.mat", "akf-mat", ct=0.25)
    assert scipy.io.loadmat(tmp_path / "b.mat")["ct"].item() == 0.25


# -- OpenEXR ----------------------------------------------------------------------------------------------------
def test_exr_reference_sequence_round_trip(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "ref", "exr")
    images, t = read_exr_sequence(tmp_path / "ref")
    np.testing.assert_array_equal(images, rec.reference)  # float32: lossless
    np.testing.assert_array_equal(t, rec.reference_t_us)  # sidecar text: exact int64 microseconds
    export(rec, tmp_path / "half", "exr", half=True)
    images16, _ = read_exr_sequence(tmp_path / "half")
    np.testing.assert_allclose(images16, rec.reference, rtol=2**-11)  # half: 11-bit significand
    no_ref = make_recording()
    no_ref.reference = None
    with pytest.raises(EvsimInputError, match="reference"):
        export(no_ref, tmp_path / "none", "exr")


def test_exr_errors(tmp_path):
    with pytest.raises(DatasetFormatError, match="x.exr: no such file"):
        read_exr(tmp_path / "x.exr")
    write_exr(tmp_path / "a.exr", np.ones((3, 4), np.float32))
    data = (tmp_path / "a.exr").read_bytes()
    (tmp_path / "b.exr").write_bytes(data[: len(data) // 2])
    with pytest.raises(DatasetFormatError, match="b.exr: not a readable OpenEXR"):
        read_exr(tmp_path / "b.exr")
    with pytest.raises(DatasetFormatError, match="timestamps.txt"):
        read_exr_sequence(tmp_path)


# -- export from a native file ----------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt,name", [("e2vid", "e.h5"), ("ijrr", "ij"), ("akf-mat", "a.mat")])
def test_export_from_native_file_equals_export_from_recording(tmp_path, fmt, name, tiny_recording):
    rec = tiny_recording
    write_native(rec, tmp_path / "n.h5")
    export(tmp_path / "n.h5", tmp_path / name, fmt)
    back = load(tmp_path / name)
    assert_recordings_equal(rec, back, skip=("metadata",))
    back.metadata.pop("akf_mat", None)
    assert back.metadata == rec.metadata
    assert json.loads(json.dumps(back.metadata)) == back.metadata


@pytest.mark.parametrize("fmt,name", [("native", "b.h5"), ("e2vid", "e.h5"), ("ijrr", "ij"), ("exr", "ref")])
def test_export_from_native_file_reads_one_image_at_a_time(tmp_path, monkeypatch, fmt, name, tiny_recording):
    """Memory stays flat in the sequence length: frames and reference images are read singly from the file."""
    rec = tiny_recording
    write_native(rec, tmp_path / "n.h5")
    reads = []
    getitem = h5py.Dataset.__getitem__

    def spy(self, key):
        out = getitem(self, key)
        if self.name.endswith("/images"):
            reads.append(np.shape(out))
        return out

    monkeypatch.setattr(h5py.Dataset, "__getitem__", spy)
    export(tmp_path / "n.h5", tmp_path / name, fmt)
    monkeypatch.undo()
    image = (rec.height, rec.width)
    expected = (0 if fmt == "exr" else rec.frames.shape[0]) + rec.reference.shape[0]
    assert reads and all(shape == image for shape in reads) and len(reads) == expected
    if fmt == "exr":
        np.testing.assert_array_equal(read_exr_sequence(tmp_path / name)[0], rec.reference)
    else:
        assert_recordings_equal(rec, load(tmp_path / name), skip=("metadata",))


def test_exr_sequence_is_atomic_at_folder_level(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "ref", "exr")
    before = {p.name: p.read_bytes() for p in (tmp_path / "ref").iterdir()}
    bad = make_recording()
    bad.reference[2, 0, 0] = np.inf  # the third frame fails after two were written
    with pytest.raises(EvsimInputError, match="finite"):
        export(bad, tmp_path / "ref", "exr")
    with pytest.raises(EvsimInputError, match="finite"):
        export(bad, tmp_path / "new", "exr")
    assert files_in(tmp_path) == ["ref"]
    assert {p.name: p.read_bytes() for p in (tmp_path / "ref").iterdir()} == before


@pytest.mark.parametrize("damage", ["truncate", "drop_ps"])
def test_damaged_e2vid_files_are_clear_errors(tmp_path, damage):
    path = tmp_path / "e.h5"
    export(make_recording(), path, "e2vid")
    if damage == "truncate":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
        match = r"e\.h5: .*truncated"
    else:
        with h5py.File(path, "a") as f:
            del f["events/ps"]
        match = r"e\.h5: missing dataset\(s\) events/ps"
    with pytest.raises(DatasetFormatError, match=match):
        load(path)
