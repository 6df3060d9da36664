"""Native HDF5 layout: exact round trip, streaming, ms_to_idx, atomicity and clear errors."""

from __future__ import annotations

import tracemalloc

import h5py
import numpy as np
import pytest

import generators
from generators.formats import DatasetFormatError, NativeWriter, detect, export, load
from generators.formats.native import iter_native_events, read_native, write_native
from sim import EVENT_DTYPE, EvsimInputError, TimeOrderError, UnsortedEventsError

from recordings import H, W, assert_recordings_equal, files_in, make_recording


@pytest.mark.parametrize("bit_depth", [8, 12])
def test_round_trip_is_exact(tmp_path, bit_depth):
    rec = make_recording(bit_depth=bit_depth)
    path = tmp_path / "seq.h5"
    write_native(rec, path)
    assert detect(path) == "native"
    back = generators.load(path)
    assert_recordings_equal(rec, back)
    assert back.frames.dtype == (np.uint8 if bit_depth == 8 else np.uint16)


def test_layout_is_dsec_like(tmp_path, tiny_recording):
    rec = tiny_recording
    write_native(rec, tmp_path / "seq.h5")
    with h5py.File(tmp_path / "seq.h5") as f:
        assert {k: f["events"][k].dtype.str for k in "txyp"} == {"t": "<i8", "x": "<u2", "y": "<u2", "p": "|u1"}
        assert f["events/t"].compression == "gzip" and f["events/t"].maxshape == (None,)
        # byte-shuffled before gzip (a filter every HDF5 reader has): smaller and faster for int64 / float32
        assert f["events/t"].shuffle and f["reference/images"].shuffle
        # DSEC convention: stored t is relative to t_offset (first event time floored to a millisecond).
        assert f["t_offset"][()] == rec.events["t"][0] // 1000 * 1000
        np.testing.assert_array_equal(f["events/t"][()] + f["t_offset"][()], rec.events["t"])
        ms = f["ms_to_idx"][()]
        np.testing.assert_array_equal(ms, brute_ms_to_idx(f["events/t"][()]))
        assert f.attrs["height"] == H and f.attrs["width"] == W


def brute_ms_to_idx(t: np.ndarray) -> np.ndarray:
    """The definition: entry k = index of the first event with t >= k * 1000 us, k = 0 .. t_last // 1000 + 1."""
    ks = np.arange(t[-1] // 1000 + 2) * 1000
    return np.array([np.flatnonzero(t >= k)[0] if np.any(t >= k) else t.size for k in ks])


def test_streamed_chunks_give_the_same_file_and_exact_ms_to_idx(tmp_path):
    rng = np.random.default_rng(1)
    n = 20_000
    ev = np.zeros(n, EVENT_DTYPE)
    # Gaps of several milliseconds without events, bursts within one millisecond, chunk boundaries inside a ms.
    ev["t"] = np.sort(np.concatenate([rng.integers(0, 3_000, n // 2), rng.integers(9_000, 15_500, n - n // 2)]))
    ev["x"], ev["y"], ev["p"] = rng.integers(0, W, n), rng.integers(0, H, n), 1
    cuts = np.sort(rng.choice(np.arange(1, n), 37, replace=False))
    with NativeWriter(tmp_path / "a.h5", H, W, metadata={}) as w:
        for chunk in np.split(ev, cuts):
            w.add_events(chunk)
        w.add_events(ev[:0])  # empty chunks are fine
    with h5py.File(tmp_path / "a.h5") as f:
        ms, t_offset = f["ms_to_idx"][()], f["t_offset"][()]
    assert t_offset == 0
    np.testing.assert_array_equal(ms, brute_ms_to_idx(ev["t"]))
    np.testing.assert_array_equal(load(tmp_path / "a.h5").events, ev)


def test_writer_memory_does_not_grow_with_the_stream(tmp_path):
    chunk_n, n_chunks = 100_000, 20
    rng = np.random.default_rng(2)
    chunk = np.zeros(chunk_n, EVENT_DTYPE)
    chunk["x"], chunk["y"], chunk["p"] = rng.integers(0, W, chunk_n), rng.integers(0, H, chunk_n), -1
    tracemalloc.start()
    try:
        with NativeWriter(tmp_path / "big.h5", H, W, metadata={}, compression="lzf") as w:
            for i in range(n_chunks):
                chunk["t"] = i * 1_000_000 + np.arange(chunk_n) * 10
                w.add_events(chunk)
                if i == 1:
                    tracemalloc.reset_peak()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    total_bytes = chunk_n * n_chunks * EVENT_DTYPE.itemsize  # 26 MB if it were held
    assert peak < total_bytes / 5, f"peak {peak / 1e6:.1f} MB while streaming {total_bytes / 1e6:.0f} MB"
    with h5py.File(tmp_path / "big.h5") as f:
        assert f["events/t"].shape == (chunk_n * n_chunks,)
        assert f["ms_to_idx"][1000] == chunk_n  # first event at t >= 1 s opens the second chunk


def test_chunks_out_of_order_and_bad_inputs_are_rejected(tmp_path):
    ev = np.zeros(3, EVENT_DTYPE)
    ev["t"], ev["p"] = [10, 20, 30], 1
    with NativeWriter(tmp_path / "x.h5", H, W, metadata={}) as w:
        w.add_events(ev)
        with pytest.raises(UnsortedEventsError, match="before the previous chunk"):
            w.add_events(ev)
        with pytest.raises(EvsimInputError, match="labels"):
            late = ev.copy()
            late["t"] += 100
            w.add_events(late, np.zeros(3, np.uint8))
        bad = ev.copy()
        bad["t"] += 1000
        bad["x"][0] = W
        with pytest.raises(EvsimInputError, match="sensor size"):
            w.add_events(bad)
        with pytest.raises(TimeOrderError):
            w.add_frame(np.zeros((H, W), np.uint8), 10, 5, 20)
        with pytest.raises(EvsimInputError, match="8-bit"):
            w.add_frame(np.full((H, W), 256, np.uint16), 0, 1, 2)
        with pytest.raises(EvsimInputError, match="finite"):
            w.add_reference(np.full((H, W), np.nan, np.float32), 0)


def test_exception_inside_writer_leaves_no_file_and_no_temp(tmp_path):
    path = tmp_path / "seq.h5"
    with pytest.raises(RuntimeError, match="generator failed"):
        with NativeWriter(path, H, W, metadata={}) as w:
            w.add_events(make_recording().events)
            raise RuntimeError("generator failed")
    assert files_in(tmp_path) == []


def test_existing_file_is_untouched_on_failure_and_replaced_on_success(tmp_path, tiny_recording):
    path = tmp_path / "seq.h5"
    rec = tiny_recording
    write_native(rec, path)
    before = path.read_bytes()
    with pytest.raises(RuntimeError):
        with NativeWriter(path, H, W, metadata={"new": True}):
            raise RuntimeError("interrupted")
    assert path.read_bytes() == before and files_in(tmp_path) == ["seq.h5"]
    with NativeWriter(path, H, W, metadata={"new": True}):
        pass
    assert load(path).metadata == {"new": True} and load(path).events.size == 0
    assert files_in(tmp_path) == ["seq.h5"]


def test_truncated_file_is_a_clear_error(tmp_path):
    path = tmp_path / "seq.h5"
    write_native(make_recording(), path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(DatasetFormatError, match=r"seq\.h5.*(truncated|unknown layout)"):
        load(path)
    with pytest.raises(DatasetFormatError, match=r"seq\.h5.*truncated"):
        read_native(path)


def test_missing_dataset_is_a_clear_error(tmp_path):
    path = tmp_path / "seq.h5"
    write_native(make_recording(), path)
    with h5py.File(path, "a") as f:
        del f["frames/t_mid_us"]
    with pytest.raises(DatasetFormatError, match=r"seq\.h5: missing dataset\(s\) frames/t_mid_us"):
        load(path)


def test_missing_path_and_unknown_layouts_are_clear_errors(tmp_path):
    with pytest.raises(DatasetFormatError, match="nope.h5: no such file"):
        load(tmp_path / "nope.h5")
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(DatasetFormatError, match="notes.txt: unknown layout"):
        load(tmp_path / "notes.txt")
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["data"] = np.arange(3)
    with pytest.raises(DatasetFormatError, match="other.h5: unknown layout: HDF5"):
        load(tmp_path / "other.h5")
    (tmp_path / "empty_dir").mkdir()
    with pytest.raises(DatasetFormatError, match="empty_dir: unknown layout"):
        load(tmp_path / "empty_dir")


def test_export_native_to_native_streams_and_is_exact(tmp_path, tiny_recording):
    rec = tiny_recording
    write_native(rec, tmp_path / "a.h5")
    export(tmp_path / "a.h5", tmp_path / "b.h5", "native")
    assert_recordings_equal(rec, load(tmp_path / "b.h5"))
    with pytest.raises(EvsimInputError, match="unknown format"):
        export(rec, tmp_path / "c", "tiff")


def test_polarity_is_stored_as_dsec_stores_it_and_old_files_still_load(tmp_path, tiny_recording):
    # DSEC (github.com/uzh-rpg/DSEC, scripts/dataset/representations.py) builds its voxel grid with
    # value = 2 * pol - 1 from the stored events/p: stored 0/1, OFF must become -1 there, never -3.
    rec = tiny_recording
    write_native(rec, tmp_path / "seq.h5")
    with h5py.File(tmp_path / "seq.h5") as f:
        p = f["events/p"][()]
        assert f.attrs["format_version"] == 2 and p.dtype == np.uint8
        np.testing.assert_array_equal(2 * p.astype(np.int64) - 1, rec.events["p"])
    assert_recordings_equal(rec, read_native(tmp_path / "seq.h5"))
    # A file written before the fix (layout version 1: int8 -1/+1) reads the same.
    with h5py.File(tmp_path / "seq.h5", "a") as f:
        del f["events/p"]
        f["events/p"] = rec.events["p"].astype(np.int8)
        f.attrs["format_version"] = 1
    assert_recordings_equal(rec, read_native(tmp_path / "seq.h5"))
    chunks = list(iter_native_events(tmp_path / "seq.h5", size=1000))
    np.testing.assert_array_equal(np.concatenate([c for c, _ in chunks])["p"], rec.events["p"])


def test_chunks_compressed_by_the_writer_decode_through_hdf5s_own_filters(tmp_path):
    # The writer deflates whole chunks itself (ISA-L) and stores them directly; HDF5's standard shuffle + deflate
    # filters must decode them to exactly what an uncompressed or lzf file holds, across whole and ragged chunks.
    rng = np.random.default_rng(4)
    n = 2 * (1 << 16) + 12_345
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 4_000_000, n))
    ev["x"], ev["y"], ev["p"] = rng.integers(0, W, n), rng.integers(0, H, n), rng.choice([-1, 1], n)
    labels = rng.integers(0, 4, n).astype(np.uint8)
    cuts = np.sort(rng.choice(np.arange(1, n), 9, replace=False))
    refs = rng.uniform(0, 10, (3, H, W)).astype(np.float32)
    contents = {}
    for compression in ("gzip", "lzf", None):
        path = tmp_path / f"{compression}.h5"
        with NativeWriter(path, H, W, metadata={}, compression=compression) as w:
            for chunk, lab in zip(np.split(ev, cuts), np.split(labels, cuts)):
                w.add_events(chunk, lab)
            for k in range(3):
                w.add_reference(refs[k], k)
                w.add_frame(np.full((H, W), k, np.uint8), 10 * k, 10 * k + 1, 10 * k + 2)
        with h5py.File(path) as f:
            contents[compression] = {k: f[k][()] for k in ("events/t", "events/x", "events/y", "events/p",
                                                           "events/label", "ms_to_idx", "reference/images",
                                                           "frames/images", "frames/t_mid_us", "reference/t_us")}
            if compression == "gzip":
                assert f["events/t"].compression == "gzip" and f["events/t"].shuffle
                assert f["events/t"].id.get_chunk_info(0).size < (1 << 16) * 8 / 3  # really deflated
    assert contents["gzip"]["events/t"].size == n
    for key, value in contents[None].items():
        np.testing.assert_array_equal(contents["gzip"][key], value, err_msg=key)
        np.testing.assert_array_equal(contents["lzf"][key], value, err_msg=key)
    np.testing.assert_array_equal(load(tmp_path / "gzip.h5").events, ev)
