"""Interchange formats read back by their own ecosystems' readers: E2VID text (rpg_e2vid), tonic, Prophesee
EVT 3.0 / EVT 2.0 .raw and .dat (evlib, expelliarmus, Prophesee's toolbox), AEDAT4 (dv-processing, aedat)."""

from __future__ import annotations

import io
import tracemalloc
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from generators.formats import DatasetFormatError, ExportDropWarning, detect, export, from_tonic, load, to_tonic
from generators.formats.native import write_native
from generators.formats.prophesee import PropheseeWriter
from generators.formats.recording import Recording
from sim import EVENT_DTYPE, EvsimInputError

from recordings import T0, H, W, make_recording


def export_quietly(rec, path, fmt):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportDropWarning)
        return export(rec, path, fmt)


def long_stream(n=20_000, seed=1) -> np.ndarray:
    """Events over 60 s (several 2**24 us EVT 3.0 wraps) with a 25 s silence, on a 346x260 sensor."""
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 35_000_000, n))
    ev["t"][n // 2 :] += 25_000_000
    ev["t"][100:104] = ev["t"][100]
    ev["x"], ev["y"] = rng.integers(0, 346, n), rng.integers(0, 260, n)
    ev["p"] = rng.choice(np.array([-1, 1], np.int8), n)
    return ev


def long_recording() -> Recording:
    ev = long_stream()
    return Recording(events=ev, height=260, width=346, threshold_maps=np.full((2, 260, 346), 0.2, np.float32),
                     event_labels=np.zeros(ev.size, np.uint8), crf={"name": "linear", "params": {}},
                     metadata={"seed_entropy": 7})


# -- E2VID text ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["events.zip", "seq.txt"])
def test_e2vid_text_has_rpg_e2vids_header_and_reads_back(tmp_path, name, tiny_recording):
    # github.com/uzh-rpg/rpg_e2vid run_reconstruction.py reads "width height" from the first line; its
    # utils/event_readers.py then skips that line and splits each "t x y p" line (t seconds, p 1/0); a .zip must
    # hold exactly one text file.
    rec = tiny_recording
    dropped = export_quietly(rec, tmp_path / name, "e2vid-txt")
    assert "frames" in dropped and "event_labels" in dropped
    if name.endswith(".zip"):
        with zipfile.ZipFile(tmp_path / name) as z:
            assert len(z.namelist()) == 1
            lines = io.TextIOWrapper(z.open(z.namelist()[0]), encoding="ascii").read().splitlines()
    else:
        lines = (tmp_path / name).read_text().splitlines()
    width, height = (int(v) for v in lines[0].split(" "))
    assert (width, height) == (W, H)
    rows = [line.split(" ") for line in lines[1:]]
    assert len(rows) == rec.events.size  # no event lost to the header
    t = np.array([float(r[0]) for r in rows])
    np.testing.assert_array_equal(np.rint(t * 1e6).astype(np.int64), rec.events["t"])
    np.testing.assert_array_equal([int(r[3]) for r in rows], rec.events["p"] > 0)
    assert detect(tmp_path / name) == "e2vid-txt"
    back = load(tmp_path / name)
    assert (back.height, back.width) == (H, W)
    np.testing.assert_array_equal(back.events, rec.events)


def test_ecd_text_keeps_its_layout_and_bad_e2vid_text_is_a_clear_error(tmp_path, tiny_recording):
    rec = tiny_recording
    export(rec, tmp_path / "ij", "ijrr")
    first = (tmp_path / "ij" / "events.txt").read_text().splitlines()[0].split()
    assert len(first) == 4  # ECD: the first line is the first event, no header
    (tmp_path / "bad.txt").write_text("8 6\n0.000001 9 0 1\n")
    with pytest.raises(DatasetFormatError, match=r"bad\.txt: event coordinates exceed"):
        load(tmp_path / "bad.txt")


# -- tonic --------------------------------------------------------------------------------------------------------
def test_to_tonic_puts_off_events_in_tonics_off_channel(tiny_recording):
    tonic = pytest.importorskip("tonic")
    rec = tiny_recording
    frames = tonic.transforms.ToFrame(sensor_size=(W, H, 2), n_event_bins=1)(to_tonic(rec.events))
    off, on = rec.events["p"] < 0, rec.events["p"] > 0
    assert frames.shape == (1, 2, H, W)
    assert frames[0, 0].sum() == off.sum() and frames[0, 1].sum() == on.sum()
    np.testing.assert_array_equal(frames[0, 0], np.bincount(rec.events["y"][off].astype(np.int64) * W +
                                                            rec.events["x"][off], minlength=H * W).reshape(H, W))
    np.testing.assert_array_equal(from_tonic(to_tonic(rec.events)), rec.events)


# -- Prophesee ----------------------------------------------------------------------------------------------------
def _evlib_events(path):
    evlib = pytest.importorskip("evlib")
    df = evlib.load_events(str(path)).collect()
    return (df["t"].dt.total_microseconds().to_numpy(), df["x"].to_numpy(), df["y"].to_numpy(),
            df["polarity"].to_numpy())


def _expelliarmus_events(path, fmt):
    expelliarmus = pytest.importorskip("expelliarmus")
    a = expelliarmus.Wizard(encoding=fmt).read(str(path))
    return a["t"], a["x"], a["y"], np.where(a["p"] > 0, 1, -1)


def _faery_events(path):
    faery = pytest.importorskip("faery")
    a = faery.events_stream_from_file(path).to_array()
    return a["t"], a["x"], a["y"], np.where(a["on"], 1, -1)


def _dv_events(recording):
    """(t, x, y, p) of every event of a dv-processing MonoCameraRecording (iniVation's own reader)."""
    stores = []
    while (batch := recording.getNextEventBatch()) is not None:
        stores.append(batch.numpy())
    got = np.concatenate(stores)
    return got["timestamp"], got["x"], got["y"], np.where(got["polarity"] > 0, 1, -1)


def _toolbox_dat_events(path):
    """Prophesee's own numpy reader convention (github.com/prophesee-ai/prophesee-automotive-dataset-toolbox,
    src/io/dat_events_tools.py): '% ' header lines, 1 byte type, 1 byte size, then (u4 t, i4 packed x|y|p)."""
    data = path.read_bytes()
    pos = 0
    while data[pos : pos + 2] == b"% ":
        pos = data.index(b"\n", pos) + 1
    assert data[pos + 1] == 8  # event size
    d = np.frombuffer(data[pos + 2 :], dtype=[("t", "<u4"), ("_", "<i4")])
    return (d["t"].astype(np.int64), d["_"] & 16383, (d["_"] & 268419072) >> 14,
            np.where((d["_"] & 268435456) >> 28, 1, -1))


def _assert_same(cols, ev, offset=0):
    t, x, y, p = cols
    np.testing.assert_array_equal(np.asarray(t, np.int64), ev["t"] - offset)
    np.testing.assert_array_equal(x, ev["x"])
    np.testing.assert_array_equal(y, ev["y"])
    np.testing.assert_array_equal(p, ev["p"])


@pytest.mark.parametrize("fmt,name", [("evt3", "e.raw"), ("evt2", "e.raw"), ("dat", "e.dat")])
def test_prophesee_exports_read_back_exactly_by_independent_readers(tmp_path, fmt, name):
    # Word layouts as Prophesee's EVT 2.0 / EVT 3.0 format specs and the open-source Metavision decoder
    # (github.com/prophesee-ai/openeb, its evt3 decoder: a TIME_HIGH drop of >= 4085 steps is a 24-bit wrap) and
    # .dat as prophesee-automotive-dataset-toolbox src/io/dat_events_tools.py. The 60 s stream crosses three EVT 3.0
    # wraps and a 25 s silence. expelliarmus reads EVT 2.0 and .dat; its EVT 3.0 decoder
    # (open-neuromorphic/expelliarmus src/evt3.c) also counts every TIME_LOW decrease as one more TIME_HIGH step,
    # which disagrees with the spec on any stream longer than 4096 us, so EVT 3.0 is checked with evlib.
    rec = long_recording()
    ev = rec.events
    with pytest.warns(ExportDropWarning, match="leaves out threshold_maps, event_labels, crf, metadata"):
        dropped = export(rec, tmp_path / name, fmt)
    assert dropped == ["threshold_maps", "event_labels", "crf", "metadata"]
    if fmt == "evt3":
        _assert_same(_evlib_events(tmp_path / name), ev)
    elif fmt == "evt2":
        _assert_same(_evlib_events(tmp_path / name), ev)
        _assert_same(_expelliarmus_events(tmp_path / name, fmt), ev)
    else:
        _assert_same(_expelliarmus_events(tmp_path / name, fmt), ev)
        _assert_same(_toolbox_dat_events(tmp_path / name), ev)
        _assert_same(_faery_events(tmp_path / name), ev)  # faery reads CD-typed .dat files only
    assert detect(tmp_path / name) == fmt
    back = load(tmp_path / name)
    assert (back.height, back.width) == (260, 346)
    np.testing.assert_array_equal(back.events, ev)


@pytest.mark.parametrize("fmt", ["evt3", "evt2", "dat"])
def test_prophesee_times_past_the_formats_range_are_stored_from_a_recorded_offset(tmp_path, fmt):
    rec = make_recording()  # events start at T0, about 34 h: past every Prophesee time range
    assert rec.events["t"][0] >= T0 > 1 << 34
    path = tmp_path / ("e.dat" if fmt == "dat" else "e.raw")
    export_quietly(rec, path, fmt)
    offset = int(rec.events["t"][0]) // 1000 * 1000
    assert f"% evsim_t_offset_us {offset}\n".encode() in path.read_bytes()[:2000]
    assert b"% evsim_polarity 1=ON 0=OFF\n" in path.read_bytes()[:2000]
    reader = _expelliarmus_events(path, fmt) if fmt == "dat" else _evlib_events(path)
    _assert_same(reader, rec.events, offset)
    np.testing.assert_array_equal(load(path).events, rec.events)


def test_dat_header_and_event_type_are_prophesees_and_faerys_own_encoder_agrees(tmp_path):
    # Prophesee's DAT spec (docs.prophesee.ai/stable/data/file_formats/dat.html): "% Data file containing CD
    # events", Date YYYY-MM-DD HH:MM:SS, Version 2, Width, Height; then event type 0x0C (EventCd) and size 8.
    faery = pytest.importorskip("faery")
    ev = long_stream(3000)
    export_quietly(Recording(events=ev, height=260, width=346), tmp_path / "e.dat", "dat")
    data = (tmp_path / "e.dat").read_bytes()
    lines = data.split(b"\n")
    assert lines[:5] == [b"% Data file containing CD events", b"% Date 1970-01-01 00:00:00", b"% Version 2",
                         b"% Width 346", b"% Height 260"]
    body = data.index(b"\n", data.rindex(b"\n% ") + 1) + 1
    assert data[body : body + 2] == bytes([0x0C, 8])
    # faery's own DAT encoder (event type "cd") writes the same type byte and the same 8-byte events
    packet = np.zeros(ev.size, [("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("payload", "u1")])
    packet["t"], packet["x"], packet["y"], packet["payload"] = ev["t"], ev["x"], ev["y"], ev["p"] > 0
    with faery.dat.Encoder(tmp_path / "f.dat", "dat2", "cd", False, (346, 260)) as enc:
        enc.write(packet)
    theirs = (tmp_path / "f.dat").read_bytes()
    cut = theirs.index(bytes([0x0C, 8]), theirs.rindex(b"% "))
    assert theirs[cut:] == data[body:]
    np.testing.assert_array_equal(load(tmp_path / "f.dat").events, ev)


def test_dat_files_of_event_type_0_under_the_older_header_still_read(tmp_path):
    # earlier evsim .dat output: "% Data file containing Event2D events." and type 0 (Event2d), same layout
    ev = long_stream(500)
    export_quietly(Recording(events=ev, height=260, width=346), tmp_path / "new.dat", "dat")
    data = (tmp_path / "new.dat").read_bytes()
    old = data.replace(b"% Data file containing CD events\n", b"% Data file containing Event2D events.\n")
    at = old.index(bytes([0x0C, 8]), old.rindex(b"\n% "))
    (tmp_path / "old.dat").write_bytes(old[:at] + bytes([0, 8]) + old[at + 2 :])
    np.testing.assert_array_equal(load(tmp_path / "old.dat").events, ev)
    _assert_same(_expelliarmus_events(tmp_path / "old.dat", "dat"), ev)


def test_prophesee_export_from_a_native_file_streams_chunks_exactly(tmp_path):
    rec = long_recording()
    write_native(rec, tmp_path / "n.h5")
    for fmt in ("evt3", "evt2", "dat"):
        path = tmp_path / f"{fmt}.{'dat' if fmt == 'dat' else 'raw'}"
        with pytest.warns(ExportDropWarning, match="leaves out threshold_maps, event_labels, crf, metadata"):
            export(tmp_path / "n.h5", path, fmt)
        whole = tmp_path / f"whole_{path.name}"
        with PropheseeWriter(whole, fmt, 260, 346) as w:  # many small chunks give the same bytes
            for i in range(0, rec.events.size, 777):
                w.add_events(rec.events[i : i + 777])
        assert _strip_date(path.read_bytes()) == _strip_date(whole.read_bytes()), fmt
        np.testing.assert_array_equal(load(path).events, rec.events)


def test_prophesee_writer_memory_does_not_grow_with_the_stream(tmp_path):
    chunk = long_stream(50_000)

    def peak(n_chunks, fmt):
        tracemalloc.start()
        with PropheseeWriter(tmp_path / f"{fmt}{n_chunks}.raw", fmt, 260, 346) as w:
            for k in range(n_chunks):
                shifted = chunk.copy()
                shifted["t"] += k * 60_000_000
                w.add_events(shifted)
                del shifted
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return top

    for fmt in ("evt3", "evt2"):
        short, long = peak(2, fmt), peak(8, fmt)
        assert long < 1.2 * short, (fmt, short, long)


def _strip_date(data: bytes) -> bytes:
    return b"".join(line for line in data.split(b"\n") if not line.startswith(b"% Date"))


def test_prophesee_bad_files_are_clear_errors(tmp_path):
    (tmp_path / "x.raw").write_bytes(b"% camera something\n% end\n\x00\x80")
    with pytest.raises(DatasetFormatError, match=r"x\.raw: unknown layout"):
        load(tmp_path / "x.raw")
    export_quietly(make_recording(), tmp_path / "t.raw", "evt2")
    data = (tmp_path / "t.raw").read_bytes()
    (tmp_path / "t.raw").write_bytes(data[:-2])
    with pytest.raises(DatasetFormatError, match=r"t\.raw: truncated"):
        load(tmp_path / "t.raw")
    with pytest.raises(ValueError, match="sensors up to 2048"):
        PropheseeWriter(tmp_path / "big.raw", "evt3", 3000, 10)
    assert not (tmp_path / "big.raw").exists()


# -- AEDAT4 -------------------------------------------------------------------------------------------------------
def test_aedat4_export_reads_back_in_dv_processing_and_aedat(tmp_path, tiny_recording):
    # iniVation's convention (dv-processing's dv::Frame): a frame's timestamp is its exposure start and exposure
    # its duration; the aedat package reports them as exposure_begin_t / exposure_end_t, and the start and end of
    # frame readout (frame.fbs timestampStartOfFrame / EndOfFrame) as begin_t / end_t: the camera model's exposure
    # window too, as it has no readout time.
    dv = pytest.importorskip("dv_processing")
    aedat = pytest.importorskip("aedat")
    rec = tiny_recording
    with pytest.warns(ExportDropWarning, match="leaves out reference, threshold_maps, event_labels, crf, metadata"):
        export(rec, tmp_path / "r.aedat4", "aedat4")
    # iniVation's own reader
    r = dv.io.MonoCameraRecording(str(tmp_path / "r.aedat4"))
    assert r.getEventResolution() == (W, H) and r.getFrameResolution() == (W, H)
    _assert_same(_dv_events(r), rec.events)
    frames = []
    while (fr := r.getNextFrame()) is not None:
        frames.append(fr)
    assert len(frames) == rec.frames.shape[0]
    for i, fr in enumerate(frames):
        np.testing.assert_array_equal(fr.image.reshape(H, W), rec.frames[i])
        assert fr.timestamp == rec.frame_t_start_us[i]
        assert fr.exposure.total_seconds() * 1e6 == pytest.approx(rec.frame_t_end_us[i] - rec.frame_t_start_us[i])
    # the aedat package, and evsim's reader built on it
    packets = [p for p in aedat.Decoder(str(tmp_path / "r.aedat4"))]
    got = np.concatenate([p["events"] for p in packets if "events" in p])
    _assert_same((got["t"], got["x"], got["y"], np.where(got["on"], 1, -1)), rec.events)
    fr = [p["frame"] for p in packets if "frame" in p]
    np.testing.assert_array_equal([f["exposure_begin_t"] for f in fr], rec.frame_t_start_us)
    np.testing.assert_array_equal([f["exposure_end_t"] for f in fr], rec.frame_t_end_us)
    np.testing.assert_array_equal([f["t"] for f in fr], rec.frame_t_start_us)
    np.testing.assert_array_equal([f["begin_t"] for f in fr], rec.frame_t_start_us)
    np.testing.assert_array_equal([f["end_t"] for f in fr], rec.frame_t_end_us)
    np.testing.assert_array_equal(np.stack([f["pixels"] for f in fr]), rec.frames)
    _assert_same(_faery_events(tmp_path / "r.aedat4"), rec.events)  # faery reads the event stream too
    # packets in time order: each frame before the events that follow its exposure start
    order = [("frame", p["frame"]["t"]) if "frame" in p else ("events", p["events"]["t"][0]) for p in packets]
    assert [t for _, t in order] == sorted(t for _, t in order)
    back = load(tmp_path / "r.aedat4")
    np.testing.assert_array_equal(back.events, rec.events)
    np.testing.assert_array_equal(back.frames, rec.frames)
    np.testing.assert_array_equal(back.frame_t_start_us, rec.frame_t_start_us)
    np.testing.assert_array_equal(back.frame_t_mid_us, rec.frame_t_mid_us)


def test_aedat4_splits_events_into_packets_between_the_frames_and_refuses_what_int16_cannot_hold(tmp_path):
    """100 000 events: four EVTS packets of at most PACKET_EVENTS, the frames in between in time order; dv-processing
    reads them back whole, with the packet boundaries where the writer put them."""
    dv = pytest.importorskip("dv_processing")
    aedat = pytest.importorskip("aedat")
    from generators.formats.aedat4 import PACKET_EVENTS

    rec = make_recording(n_events=100_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportDropWarning)
        export(rec, tmp_path / "r.aedat4", "aedat4")
    packets = list(aedat.Decoder(str(tmp_path / "r.aedat4")))
    sizes = [len(p["events"]) for p in packets if "events" in p]
    assert sizes == [PACKET_EVENTS] * 3 + [100_000 - 3 * PACKET_EVENTS]
    order = [p["frame"]["t"] if "frame" in p else p["events"]["t"][0] for p in packets]
    assert order == sorted(order) and sum("frame" in p for p in packets) == rec.frames.shape[0]
    r = dv.io.MonoCameraRecording(str(tmp_path / "r.aedat4"))
    _assert_same(_dv_events(r), rec.events)
    wide = Recording(events=rec.events[:1], height=H, width=40_000)
    with pytest.raises(EvsimInputError, match="aedat4 holds sensors up to 32767x32767 pixels"):
        export(wide, tmp_path / "w.aedat4", "aedat4")
    assert not list(tmp_path.glob("*w.aedat4*"))


def test_evt3_reader_decodes_vector_words_as_metavision_cameras_write_them(tmp_path):
    # Cameras pack runs of pixels of one row and polarity in VECT_BASE_X + VECT_12 / VECT_8 words (Prophesee's
    # EVT 3.0 spec; expelliarmus src/evt3.c decodes them the same way): base x advances by 12 / 8 per word.
    words = [0x8000, 0x8001, 0x6005, 0x0007,  # time 4096 + 5 us, y = 7
             0x3800 | 100, 0x4000 | 0b100000000101, 0x5000 | 0b10000001,  # ON at x 100, 102, 111; 112, 119
             0x2000 | 3, 0x0008, 0x6009, 0x3000 | 20, 0x5000 | 0b1]  # OFF (3, 7); then OFF (20, 8) at 4096+9
    header = b"% evt 3.0\n% format EVT3;height=10;width=128\n% end\n"
    (tmp_path / "v.raw").write_bytes(header + np.array(words, "<u2").tobytes())
    rec = load(tmp_path / "v.raw")
    ev = rec.events
    np.testing.assert_array_equal(ev["x"], [100, 102, 111, 112, 119, 3, 20])
    np.testing.assert_array_equal(ev["y"], [7, 7, 7, 7, 7, 7, 8])
    np.testing.assert_array_equal(ev["p"], [1, 1, 1, 1, 1, -1, -1])
    np.testing.assert_array_equal(ev["t"], [4101] * 6 + [4105])
    _assert_same(_expelliarmus_events(tmp_path / "v.raw", "evt3"), ev)


REAL_AEDAT4 = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "tonic_sample_dvxplorer.aedat4"


@pytest.mark.parametrize("fmt,name", [("evt3", "r.raw"), ("evt2", "r.raw"), ("dat", "r.dat"), ("aedat4", "r.aedat4")])
def test_a_real_dvxplorer_recording_survives_every_event_export(tmp_path, fmt, name):
    # A real camera stream (Unix-time microseconds, bursts and ties) rather than a synthetic one.
    if not REAL_AEDAT4.is_file():
        pytest.skip("shared real data absent")
    pytest.importorskip("aedat")
    if fmt == "aedat4":
        pytest.importorskip("dv_processing")
    real = load(REAL_AEDAT4)
    export_quietly(real, tmp_path / name, fmt)
    back = load(tmp_path / name)
    np.testing.assert_array_equal(back.events, real.events)
    assert (back.height, back.width) == (real.height, real.width)
    if fmt in ("evt3", "evt2"):
        offset = int(real.events["t"][0]) // 1000 * 1000  # Unix time is past both ranges
        _assert_same(_evlib_events(tmp_path / name), real.events, offset)


def test_aedat4_export_of_a_recording_with_an_empty_frame_stack_holds_its_events(tmp_path):
    """Zero frames declare no frame stream: the writer takes the streams from the header dv-processing wrote."""
    pytest.importorskip("dv_processing")
    pytest.importorskip("aedat")
    rec = make_recording(n_events=500)
    empty = np.zeros(0, np.int64)
    rec = Recording(events=rec.events, height=H, width=W, frames=np.zeros((0, H, W), np.uint8),
                    frame_t_start_us=empty, frame_t_mid_us=empty, frame_t_end_us=empty)
    export(rec, tmp_path / "e.aedat4", "aedat4")
    back = load(tmp_path / "e.aedat4")
    np.testing.assert_array_equal(back.events, rec.events)
    assert back.frames is None
