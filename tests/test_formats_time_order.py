"""Readers and time order (issue 27): a time that goes back is a DatasetFormatError naming the file and where,
unless it is a wrap of a Prophesee counter from the top of its range to its bottom (prophesee_kernels.time_step_ok);
genuine wraps of long recordings load exactly. Also the checks around them: the .dat event type and header keys,
the EXR sequence reader, E2VID text detection and panics of the AEDAT4 decoder."""

from __future__ import annotations

import re
import warnings
import zipfile

import numpy as np
import pytest

from generators.formats import DatasetFormatError, detect, export, load
from generators.formats.exr import read_exr_sequence, write_exr, write_exr_sequence
from generators.formats.prophesee import iter_prophesee_events
from generators.formats.prophesee_kernels import WRAP_WINDOW, time_step_ok
from generators.formats.recording import Recording
from sim import EVENT_DTYPE, EvsimInputError

from recordings import make_recording

H, W = 6, 8
DAT_EVENT = np.dtype([("t", "<u4"), ("xyp", "<u4")])


def events_at(t) -> np.ndarray:
    t = np.asarray(t, np.int64)
    ev = np.zeros(t.size, EVENT_DTYPE)
    ev["t"] = t
    ev["x"] = np.arange(t.size) % W
    ev["y"] = (np.arange(t.size) // W) % H
    ev["p"] = np.where(np.arange(t.size) % 3, 1, -1)
    return ev


def short_recording(n=2000) -> Recording:
    """2.5 s of events from t = 1000 us: offset 0 in every Prophesee format."""
    rng = np.random.default_rng(1)
    return Recording(events=events_at(1000 + np.sort(rng.integers(0, 2_500_000, n))), height=H, width=W)


def exported(rec: Recording, path, fmt):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        export(rec, path, fmt)
    return path


def dat_split(path) -> tuple[bytes, np.ndarray]:
    """(bytes before the events, the events as (u4 t, u4 xyp)) of a .dat file."""
    data = path.read_bytes()
    pos = 0
    while data[pos : pos + 1] == b"%":
        pos = data.index(b"\n", pos) + 1
    return data[: pos + 2], np.frombuffer(data[pos + 2 :], DAT_EVENT).copy()


def camera_dat(path, t_raw, *, ev_type=0, header=f"% Height {H}\n% Width {W}\n") -> None:
    """A .dat file as a camera writes it: no evsim keys, raw 32-bit times (which wrap)."""
    d = np.zeros(len(t_raw), DAT_EVENT)
    d["t"] = np.asarray(t_raw, np.uint64) & 0xFFFF_FFFF
    ev = events_at(np.zeros(len(t_raw)))
    d["xyp"] = ev["x"].astype(np.uint32) | (ev["y"].astype(np.uint32) << 14) | ((ev["p"] > 0).astype(np.uint32) << 28)
    path.write_bytes(("% Data file containing CD events\n% Version 2\n" + header).encode() + bytes([ev_type, 8]) +
                     d.tobytes())


def raw_split(path, word) -> tuple[bytes, np.ndarray]:
    data = path.read_bytes()
    end = data.index(b"% end\n") + 6
    return data[:end], np.frombuffer(data[end:], word).copy()


def error_at(path, match) -> tuple[str, int]:
    """The DatasetFormatError message of load(path), which must name the file and a byte position."""
    with pytest.raises(DatasetFormatError, match=match) as e:
        load(path)
    msg = str(e.value)
    assert str(path) in msg
    return msg, int(re.search(r"at byte (\d+)", msg).group(1))


# -- the rule ---------------------------------------------------------------------------------------------------
def test_the_wrap_rule_accepts_only_top_to_bottom_and_no_step_back_across_zero():
    p, m = 4096, 4096 // WRAP_WINDOW
    assert time_step_ok(4095, 0, p) and time_step_ok(p - 10, m - 10, p)  # forward by exactly m across the top
    assert not time_step_ok(p - 10, m - 9, p)  # forward by m + 1: refused
    assert not time_step_ok(300, 297, p)  # a step back
    assert not time_step_ok(5, p - 3, p)  # a step back across zero: from the bottom to the top
    assert time_step_ok(5, p - m + 4, p) and time_step_ok(7, 7, p)  # forward by less than p - m
    t = np.array([0, 10, 4085, 3, 4095, 4094])  # the numpy form gives the same answers
    np.testing.assert_array_equal(time_step_ok(t[:-1], t[1:], p), [True, True, True, False, False])


# -- .dat --------------------------------------------------------------------------------------------------------
def test_dat_one_corrupt_event_time_is_an_error_at_its_byte_not_71_minutes_later(tmp_path):
    rec = short_recording()
    path = exported(rec, tmp_path / "a.dat", "dat")
    head, d = dat_split(path)
    d["t"][1000] += 2_000_000  # one event jumps 2 s ahead: the next then goes back
    (tmp_path / "b.dat").write_bytes(head + d.tobytes())
    msg, at = error_at(tmp_path / "b.dat", "time goes back")
    assert at == len(head) + 8 * 1001 and "goes back" in msg
    _, d = dat_split(path)
    d["t"][1000] = d["t"][999] - 1  # one event 1 us earlier than the one before
    (tmp_path / "c.dat").write_bytes(head + d.tobytes())
    assert error_at(tmp_path / "c.dat", "time goes back")[1] == len(head) + 8 * 1000


def test_dat_reversed_block_is_an_error(tmp_path):
    path = exported(short_recording(), tmp_path / "a.dat", "dat")
    head, d = dat_split(path)
    d[500:600] = d[500:600][::-1].copy()
    (tmp_path / "b.dat").write_bytes(head + d.tobytes())
    assert error_at(tmp_path / "b.dat", "goes back")[1] == len(head) + 8 * 501


def test_dat_time_just_below_an_early_one_is_a_step_back_across_zero_not_a_wrap(tmp_path):
    # a time before 0, stored in 32 bits, reads as near the top of the range; the next event then looks like a wrap
    path = exported(short_recording(), tmp_path / "a.dat", "dat")
    head, d = dat_split(path)
    d["t"][1] = 2**32 - 500  # the 32-bit form of t[0] - (t[0] + 500): 500 us before 0
    (tmp_path / "b.dat").write_bytes(head + d.tobytes())
    msg, at = error_at(tmp_path / "b.dat", "back across zero")
    assert at == len(head) + 8


def test_a_dat_recording_longer_than_the_32_bit_range_loads_exactly(tmp_path):
    # 3.5 wraps of the 32-bit time (4 h 10 min), an event a second, as a camera writes it
    t = np.arange(0, int(3.5 * 2**32), 1_000_000, dtype=np.int64) + 7
    camera_dat(tmp_path / "long.dat", t)
    back = load(tmp_path / "long.dat")
    np.testing.assert_array_equal(back.events["t"], t)
    chunks = list(iter_prophesee_events(tmp_path / "long.dat", size=7))  # wraps across chunk boundaries too
    np.testing.assert_array_equal(np.concatenate(chunks)["t"], t)


def test_dat_wrap_moves_time_forward_by_at_most_a_256th_of_the_range(tmp_path):
    top = 2**32 - 10
    camera_dat(tmp_path / "edge.dat", [top - 5, top, top + 2**24])  # forward by exactly 2**24 us across the wrap
    np.testing.assert_array_equal(load(tmp_path / "edge.dat").events["t"], [top - 5, top, top + 2**24])
    camera_dat(tmp_path / "past.dat", [top - 5, top, top + 2**24 + 1])
    error_at(tmp_path / "past.dat", "goes back")


def test_dat_writer_refuses_a_silence_that_readers_would_take_for_time_going_back(tmp_path):
    with pytest.raises(EvsimInputError, match="silence"):
        exported(Recording(events=events_at([5, 2**32 - 3]), height=H, width=W), tmp_path / "s.dat", "dat")
    assert list(tmp_path.iterdir()) == []
    ok = events_at([5, 2**32 - 2**24 - 1000])  # a silence of 71.3 min minus 1 ms is still written and read
    np.testing.assert_array_equal(load(exported(Recording(events=ok, height=H, width=W), tmp_path / "o.dat",
                                                "dat")).events, ok)


def test_dat_event_type_and_size_are_checked(tmp_path):
    t = np.arange(10) * 1000
    camera_dat(tmp_path / "cd.dat", t, ev_type=12)  # EventCD: the same 8-byte layout as Event2D
    np.testing.assert_array_equal(load(tmp_path / "cd.dat").events["t"], t)
    camera_dat(tmp_path / "trig.dat", t, ev_type=14)  # external triggers: not CD events
    with pytest.raises(DatasetFormatError, match=r"trig\.dat: \.dat event type 14"):
        load(tmp_path / "trig.dat")
    data = (tmp_path / "cd.dat").read_bytes()
    i = data.index(bytes([12, 8]))
    (tmp_path / "big.dat").write_bytes(data[:i] + bytes([0, 16]) + data[i + 2 :])
    with pytest.raises(DatasetFormatError, match="16 bytes"):
        load(tmp_path / "big.dat")
    (tmp_path / "cut.dat").write_bytes(data[: i + 1])
    with pytest.raises(DatasetFormatError, match="no event type and size"):
        load(tmp_path / "cut.dat")


@pytest.mark.parametrize("key, value, match", [
    ("Height", "abc", "'Height': expected an integer"),
    ("Height", "0", "'Height': 0 outside 1..16384"),
    ("Width", "99999", "'Width': 99999 outside"),
    ("evsim_t_offset_us", "nan", "'evsim_t_offset_us': expected an integer"),
    ("evsim_t_offset_us", str(2**63), "'evsim_t_offset_us'"),
    ("evsim_layout_version", "7", "'evsim_layout_version': 7 outside 1..1"),
])
def test_dat_header_keys_the_reader_relies_on_are_checked(tmp_path, key, value, match):
    path = exported(make_recording(n_events=50), tmp_path / "a.dat", "dat")
    assert load(path).events.size == 50  # evsim's own output loads
    data = path.read_bytes()
    line = re.search(rb"% " + key.encode() + rb" [^\n]*\n", data).group(0)
    path.write_bytes(data.replace(line, f"% {key} {value}\n".encode()))
    with pytest.raises(DatasetFormatError, match=match) as e:
        load(path)
    assert "a.dat" in str(e.value)


def test_raw_header_sizes_are_checked(tmp_path):
    path = exported(make_recording(n_events=50), tmp_path / "a.raw", "evt3")
    data = path.read_bytes()
    path.write_bytes(data.replace(f"height={H};".encode(), b"height=x;"))
    with pytest.raises(DatasetFormatError, match="'format': expected an integer, got 'x'"):
        load(path)


# -- EVT 3.0 -----------------------------------------------------------------------------------------------------
def test_evt3_time_high_that_goes_back_is_an_error_at_its_byte(tmp_path):
    path = exported(short_recording(), tmp_path / "a.raw", "evt3")
    head, w = raw_split(path, "<u2")
    th = np.flatnonzero(w >> 12 == 0x8)
    k = len(th) // 2
    i, low = int(th[k]), int(w[th[k - 1]]) & 0xFFF
    assert 200 < low < 2000
    for back, where in ((1, i), (3, i), (200, i), (2000, th[k + 1])):
        bad = w.copy()
        bad[i] = 0x8000 | (low - back) % 4096
        (tmp_path / "b.raw").write_bytes(head + bad.tobytes())
        msg, at = error_at(tmp_path / "b.raw", "TIME_HIGH")
        # 2000 steps back from low < 2000 reads as a step forward (12-bit values): the next TIME_HIGH goes back
        assert at == len(head) + 2 * int(where), back


def test_evt3_time_high_jump_from_the_bottom_to_the_top_is_not_a_wrap(tmp_path):
    path = exported(short_recording(), tmp_path / "a.raw", "evt3")
    head, w = raw_split(path, "<u2")
    i = int(np.flatnonzero(w >> 12 == 0x8)[2])  # an early TIME_HIGH, near the bottom of the range
    assert w[i] & 0xFFF < 16
    w[i] = 0x8FFF
    (tmp_path / "b.raw").write_bytes(head + w.tobytes())
    assert error_at(tmp_path / "b.raw", "back across zero")[1] == len(head) + 2 * i


def test_evt3_event_earlier_than_the_one_before_is_an_error(tmp_path):
    path = exported(short_recording(), tmp_path / "a.raw", "evt3")
    head, w = raw_split(path, "<u2")
    tl = np.flatnonzero(w >> 12 == 0x6)
    k = next(int(j) for j in tl[10:] if w[j] & 0xFFF > 0 and w[j - 1] >> 12 != 0x8)  # a TIME_LOW within a time high
    w[k] = 0x6000  # time low 0: its events are earlier than the previous ones
    (tmp_path / "b.raw").write_bytes(head + w.tobytes())
    msg, at = error_at(tmp_path / "b.raw", "an event at")
    assert len(head) + 2 * k < at <= len(head) + 2 * (k + 3)  # at the first event word after it


def test_a_long_evt3_recording_loads_exactly(tmp_path):
    # evsim's writer: 40 s (two wraps of the 24-bit time) with a 20 s silence
    t = np.concatenate([np.arange(0, 10_000_000, 3_001), 30_000_000 + np.arange(0, 10_000_000, 2_999)])
    rec = Recording(events=events_at(t), height=H, width=W)
    np.testing.assert_array_equal(load(exported(rec, tmp_path / "a.raw", "evt3")).events, rec.events)
    # a camera's stream: a TIME_HIGH word every 4096 us straight through two wraps (4095 -> 0), one event each
    words = []
    for k in range(2 * 4096 + 100):
        words += [0x8000 | (k & 0xFFF), 0x6000 | 7, 0x0000 | 1, 0x2800 | 2]
    (tmp_path / "c.raw").write_bytes(f"% evt 3.0\n% format EVT3;height={H};width={W}\n% end\n".encode() +
                                     np.array(words, "<u2").tobytes())
    np.testing.assert_array_equal(load(tmp_path / "c.raw").events["t"], np.arange(2 * 4096 + 100) * 4096 + 7)


# -- EVT 2.0 -----------------------------------------------------------------------------------------------------
def test_evt2_time_high_that_goes_back_is_an_error_at_its_byte(tmp_path):
    path = exported(short_recording(), tmp_path / "a.raw", "evt2")
    head, w = raw_split(path, "<u4")
    th = np.flatnonzero(w >> 28 == 0x8)
    i = int(th[len(th) // 2])
    w[i] = (0x8 << 28) | (int(w[th[th.searchsorted(i) - 1]]) & 0x0FFF_FFFF) - 5
    (tmp_path / "b.raw").write_bytes(head + w.tobytes())
    assert error_at(tmp_path / "b.raw", "TIME_HIGH")[1] == len(head) + 4 * i


def test_a_long_evt2_recording_loads_exactly(tmp_path):
    # a camera's stream longer than 2**34 us (4.8 h): TIME_HIGH (28 bits of 64 us) wraps once, an event a second
    t = np.arange(0, 2**34 + 3_600_000_000, 1_000_000, dtype=np.int64) + 5
    th = t >> 6
    words = np.empty(2 * t.size, np.uint32)
    words[0::2] = (0x8 << 28) | (th & 0x0FFF_FFFF).astype(np.uint32)
    words[1::2] = (0x1 << 28) | ((t & 63).astype(np.uint32) << 22) | (3 << 11) | 2
    (tmp_path / "l.raw").write_bytes(f"% evt 2.0\n% format EVT2;height={H};width={W}\n% end\n".encode() +
                                     words.astype("<u4").tobytes())
    np.testing.assert_array_equal(load(tmp_path / "l.raw").events["t"], t)
    # evsim's writer: long silences (a TIME_HIGH word at least every 67 s) and a start 4.7 h after 0
    t = np.array([5, 10, 3_000_000_000, 3_000_000_001, 17_000_000_000, 17_100_000_000])
    rec = Recording(events=events_at(t), height=H, width=W)
    np.testing.assert_array_equal(load(exported(rec, tmp_path / "w.raw", "evt2")).events, rec.events)


# -- EXR sequence ------------------------------------------------------------------------------------------------
def _exr_folder(tmp_path, images=None, t=(0, 1000, 2000)):
    images = np.ones((len(t), 3, 4), np.float32) if images is None else images
    write_exr_sequence(tmp_path / "ref", images, np.array(t))
    return tmp_path / "ref"


def test_exr_sequence_refuses_decreasing_times(tmp_path):
    d = _exr_folder(tmp_path)
    times = d / "timestamps.txt"
    times.write_text(times.read_text().replace("1000 frame_000001", "2500 frame_000001"))
    with pytest.raises(DatasetFormatError, match=r"timestamps\.txt: line 4: time 2000 us is before .* 2500 us"):
        read_exr_sequence(d)
    times.write_text(times.read_text().replace("2500 frame_000001", f"{2**63} frame_000001"))
    with pytest.raises(DatasetFormatError, match="outside"):
        read_exr_sequence(d)
    times.write_bytes(b"\xff\xfe0 frame_000000.exr\n")
    with pytest.raises(DatasetFormatError, match="timestamps.txt: unreadable"):
        read_exr_sequence(d)


@pytest.mark.parametrize("value, match", [(np.nan, "NaN or infinite"), (np.inf, "NaN or infinite"),
                                          (-0.5, ">= 0: found -0.5")])
def test_exr_sequence_refuses_nan_infinite_or_negative_pixels(tmp_path, value, match):
    d = _exr_folder(tmp_path)
    img = np.ones((3, 4), np.float32)
    img[1, 2] = value
    import OpenEXR  # write_exr refuses such images: write one as another tool would

    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"Y": img}).write(str(d / "frame_000001.exr"))
    with pytest.raises(DatasetFormatError, match=rf"frame_000001\.exr: pixels must be .*{re.escape(match)}"):
        read_exr_sequence(d)


def test_ijrr_reference_with_negative_radiance_is_refused_by_load(tmp_path):
    rec = make_recording()
    exported(rec, tmp_path / "ij", "ijrr")
    write_exr(tmp_path / "ij" / "reference" / "frame_000002.exr", -np.ones((H, W), np.float32))
    with pytest.raises(DatasetFormatError, match="frame_000002.exr: pixels must be radiance >= 0"):
        load(tmp_path / "ij")


# -- E2VID text detection ----------------------------------------------------------------------------------------
def test_e2vid_zip_with_two_members_gets_the_readers_message(tmp_path):
    with zipfile.ZipFile(tmp_path / "ev.zip", "w") as z:
        z.writestr("a.txt", "8 6\n0.000001 1 2 1\n")
        z.writestr("b.txt", "8 6\n")
    with pytest.raises(DatasetFormatError, match=r"ev\.zip: .*E2VID .zip holds one text file, found 2 members"):
        load(tmp_path / "ev.zip")


def test_e2vid_text_with_a_byte_order_mark_gets_the_readers_message(tmp_path):
    (tmp_path / "ev.txt").write_bytes(b"\xef\xbb\xbf8 6\n0.000001 1 2 1\n")
    with pytest.raises(DatasetFormatError, match=r"ev\.txt: .*UTF-8 byte-order mark"):
        detect(tmp_path / "ev.txt")
    (tmp_path / "four.txt").write_text("0.1 1 2 1\n")
    with pytest.raises(DatasetFormatError, match="first line must be 'width height', got '0.1 1 2 1'"):
        load(tmp_path / "four.txt")
    (tmp_path / "ok.txt").write_bytes(b"8 6\n0.000001 1 2 1\n")
    assert detect(tmp_path / "ok.txt") == "e2vid-txt" and load(tmp_path / "ok.txt").events["t"].tolist() == [1]


def test_ijrr_events_txt_is_still_read_with_its_folder(tmp_path):
    rec = make_recording(n_events=40)
    rec.events["t"] -= rec.events["t"][0]
    exported(rec, tmp_path / "ij", "ijrr")
    assert detect(tmp_path / "ij" / "events.txt") == "ijrr"


# -- AEDAT4 ------------------------------------------------------------------------------------------------------
def _aedat4_file(tmp_path):
    pytest.importorskip("aedat")
    pytest.importorskip("dv_processing")
    return exported(make_recording(n_events=300), tmp_path / "a.aedat4", "aedat4")


def test_aedat4_decoder_panic_is_a_dataset_format_error(tmp_path):
    path = _aedat4_file(tmp_path)
    data = bytearray(path.read_bytes())
    data[14] = 0  # a byte of the header's length field: the aedat decoder (Rust) panics on it
    path.write_bytes(bytes(data))
    with pytest.raises(DatasetFormatError, match=r"a\.aedat4: unreadable AEDAT4 file .*out of range"):
        load(path)


def test_aedat4_reader_lets_keyboard_interrupt_through(tmp_path, monkeypatch):
    import aedat

    path = _aedat4_file(tmp_path)

    def interrupted(*_):
        raise KeyboardInterrupt

    monkeypatch.setattr(aedat, "Decoder", interrupted)
    with pytest.raises(KeyboardInterrupt):
        load(path)


def test_ijrr_threshold_maps_with_a_corrupt_npy_header_is_a_dataset_format_error(tmp_path):
    # numpy parses the header with tokenize: an unbalanced bracket raises tokenize.TokenError (not a ValueError)
    exported(make_recording(), tmp_path / "ij", "ijrr")
    npy = tmp_path / "ij" / "threshold_maps.npy"
    data = npy.read_bytes()
    i = data.index(b"(2, 6, 8)") + 8
    npy.write_bytes(data[:i] + b"," + data[i + 1 :])
    with pytest.raises(DatasetFormatError, match=r"threshold_maps\.npy: not a readable \.npy array .*TokenError"):
        load(tmp_path / "ij")
