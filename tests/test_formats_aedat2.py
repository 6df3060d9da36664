"""AEDAT 2.0 (jAER, DAVIS address layout): what tonic's DAVIS346 reader and a decoder written from jAER's own
constants read back, int32 time wraps, the first-byte rule, and clear errors on bad files."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from generators.formats import EXPORT_FORMATS, DatasetFormatError, ExportDropWarning, detect, export, load
from generators.formats.aedat2 import Aedat2Writer
from generators.formats.native import write_native
from generators.formats.recording import Recording
from sim import EVENT_DTYPE

from recordings import T0, make_recording

H346, W346 = 260, 346


def stream(n=20_000, seed=1, span_us=35_000_000) -> np.ndarray:
    """Events over 60 s with a 25 s silence and ties, on a 346x260 sensor."""
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, span_us, n))
    ev["t"][n // 2 :] += 25_000_000
    ev["t"][n // 4 : n // 4 + 4] = ev["t"][n // 4]
    ev["x"], ev["y"] = rng.integers(0, W346, n), rng.integers(0, H346, n)
    ev["p"] = rng.choice(np.array([-1, 1], np.int8), n)
    return ev


def write(ev, path, height=H346, width=W346):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportDropWarning)
        export(Recording(events=ev, height=height, width=width), path, "aedat2")


def jaer_decode(path, size_x=W346, size_y=H346):
    """A decoder written from jAER's constants (eu.seebetter.ini.chips.DavisChip: YSHIFT 22, YMASK 511 << 22,
    XSHIFT 12, XMASK 1023 << 12, POLMASK 1 << 11, ADDRESS_TYPE_MASK 0x80000000, EXTERNAL_INPUT_EVENT_ADDR 1 << 10)
    and its DavisEventExtractor (x = sizeX - 1 - x field, y = y field, origin at the bottom left): header lines
    start with '#' (net.sf.jaer.eventio.AEFileInputStream), then big-endian int32 address and timestamp."""
    data = path.read_bytes()
    pos = 0
    while data[pos : pos + 1] == b"#":
        pos = data.index(b"\n", pos) + 1
    d = np.frombuffer(data[pos:], dtype=">i4").reshape(-1, 2)
    a, ts = d[:, 0].astype(np.int64) & 0xFFFFFFFF, d[:, 1].astype(np.int64)
    dvs = ((a & 0x80000000) == 0) & ((a & (1 << 10)) == 0)
    a, ts = a[dvs], ts[dvs]
    x_jaer = size_x - 1 - ((a & (1023 << 12)) >> 12)
    y_jaer = (a & (511 << 22)) >> 22
    on = (a & (1 << 11)) != 0
    return ts, x_jaer, size_y - 1 - y_jaer, np.where(on, 1, -1)  # image rows count down from the top


def assert_same(cols, ev, t=None):
    tt, x, y, p = cols
    np.testing.assert_array_equal(np.asarray(tt, np.int64), ev["t"] if t is None else t)
    np.testing.assert_array_equal(x, ev["x"])
    np.testing.assert_array_equal(y, ev["y"])
    np.testing.assert_array_equal(p, ev["p"])


def test_aedat2_is_an_export_format_and_the_davis346_layout_reads_back_in_tonic_and_from_jaers_constants(tmp_path):
    assert "aedat2" in EXPORT_FORMATS
    tonic_io = pytest.importorskip("tonic.io")
    ev = stream()
    write(ev, tmp_path / "e.aedat2")
    data = (tmp_path / "e.aedat2").read_bytes()
    assert data.startswith(b"#!AER-DAT2.0\r\n")
    assert b"# AEChip: eu.seebetter.ini.chips.davis.Davis346B\r\n" in data[:2000]
    assert b"# End Of ASCII Header\r\n" in data[:2000]
    # tonic's DAVIS346 AEDAT 2.0 reader (tonic.io.read_davis_346, masks "taken from jAER")
    shape, _, xytp = tonic_io.read_davis_346(str(tmp_path / "e.aedat2"))
    assert shape == (W346, H346)
    assert_same((xytp["t"], xytp["x"], xytp["y"], np.where(xytp["p"] > 0, 1, -1)), ev)
    assert_same(jaer_decode(tmp_path / "e.aedat2"), ev)
    assert detect(tmp_path / "e.aedat2") == "aedat2"
    back = load(tmp_path / "e.aedat2")
    assert (back.height, back.width) == (H346, W346)
    np.testing.assert_array_equal(back.events, ev)


def test_one_event_has_the_address_jaers_fields_give(tmp_path):
    # ON at column 0, row 0 (top left) of a DAVIS346: jAER x = 0 -> x field 345, jAER y (up) = 259 -> y field 259
    ev = np.zeros(1, EVENT_DTYPE)
    ev["t"], ev["p"] = 7, 1
    write(ev, tmp_path / "one.aedat2")
    data = (tmp_path / "one.aedat2").read_bytes()
    assert data[-8:] == (259 << 22 | 345 << 12 | 1 << 11).to_bytes(4, "big") + (7).to_bytes(4, "big")
    assert data[-8:-4].hex() == "40d59800"


def test_int32_times_wrap_as_jaers_do_and_read_back_exactly(tmp_path):
    # 3 hours: the unsigned 32-bit time wraps twice (jAER: every 2**32 us, about 71.6 min)
    rng = np.random.default_rng(3)
    n = 12_000
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 3 * 3_600_000_000, n))
    assert np.diff(ev["t"]).max() < 16_000_000
    ev["x"], ev["y"], ev["p"] = rng.integers(0, 346, n), rng.integers(0, 260, n), 1
    write(ev, tmp_path / "long.aedat2")
    t, x, y, p = jaer_decode(tmp_path / "long.aedat2")
    np.testing.assert_array_equal(t & 0xFFFFFFFF, ev["t"] & 0xFFFFFFFF)  # what the file holds: the time mod 2**32
    assert (np.diff(t & 0xFFFFFFFF) < 0).sum() == 2
    np.testing.assert_array_equal(load(tmp_path / "long.aedat2").events, ev)


def test_times_past_int32_are_stored_from_a_recorded_offset(tmp_path):
    rec = make_recording()  # starts at about 34 h
    with pytest.warns(ExportDropWarning, match="aedat2 export holds events"):
        export(rec, tmp_path / "r.aedat2", "aedat2")
    offset = int(rec.events["t"][0]) // 1000 * 1000
    assert f"# evsim_t_offset_us {offset}\r\n".encode() in (tmp_path / "r.aedat2").read_bytes()[:2000]
    t, *_ = jaer_decode(tmp_path / "r.aedat2", rec.width, rec.height)
    np.testing.assert_array_equal(t, rec.events["t"] - offset)
    assert T0 > 1 << 31
    np.testing.assert_array_equal(load(tmp_path / "r.aedat2").events, rec.events)


def test_the_first_data_byte_is_never_a_comment_character(tmp_path):
    # y field 140..143 puts 0x23 ('#') in the address's first byte: readers would take the event for a header line
    tonic_io = pytest.importorskip("tonic.io")
    row = H346 - 1 - 141
    ev = np.zeros(3, EVENT_DTYPE)
    ev["t"], ev["x"], ev["y"], ev["p"] = [5, 5, 9], [3, 4, 5], [row, 0, row], [1, -1, 1]
    write(ev, tmp_path / "tie.aedat2")  # a tie at the first time: the other event goes first
    back = load(tmp_path / "tie.aedat2").events
    assert back[0]["y"] == 0 and sorted(back[:2]["x"].tolist()) == [3, 4]
    _, _, xytp = tonic_io.read_davis_346(str(tmp_path / "tie.aedat2"))
    assert xytp.size == 3 and sorted(xytp["x"].tolist()) == [3, 4, 5]
    single = ev[[0, 2]]
    write(single, tmp_path / "one.aedat2")  # no tie: an external-input (special) event goes first
    data = (tmp_path / "one.aedat2").read_bytes()
    first = data.index(b"# End Of ASCII Header\r\n") + len(b"# End Of ASCII Header\r\n")
    assert data[first] != 0x23 and data[first : first + 4] == (1 << 10).to_bytes(4, "big")
    np.testing.assert_array_equal(load(tmp_path / "one.aedat2").events, single)
    assert load(tmp_path / "one.aedat2").metadata["source"]["skipped_words"]["special"] == 1
    assert_same(jaer_decode(tmp_path / "one.aedat2"), single)


def test_aps_samples_of_a_real_davis_file_are_skipped(tmp_path):
    ev = stream(50)
    write(ev, tmp_path / "e.aedat2")
    data = bytearray((tmp_path / "e.aedat2").read_bytes())
    cut = len(data) - 8 * 10
    aps = (0x80000000 | 5 << 22 | 7 << 12 | 1 << 10 | 512).to_bytes(4, "big") + bytes(4)  # at t = 0: not read
    (tmp_path / "aps.aedat2").write_bytes(bytes(data[:cut]) + aps + bytes(data[cut:]))
    rec = load(tmp_path / "aps.aedat2")
    np.testing.assert_array_equal(rec.events, ev)
    assert rec.metadata["source"]["skipped_words"] == {"special": 0, "aps_imu": 1}


def test_export_from_a_native_file_streams_the_same_bytes(tmp_path):
    ev = stream()
    write_native(Recording(events=ev, height=H346, width=W346), tmp_path / "n.h5")
    export(tmp_path / "n.h5", tmp_path / "a.aedat2", "aedat2")
    with Aedat2Writer(tmp_path / "b.aedat2", H346, W346) as w:
        for i in range(0, ev.size, 777):
            w.add_events(ev[i : i + 777])
    assert (tmp_path / "a.aedat2").read_bytes() == (tmp_path / "b.aedat2").read_bytes()


def test_bad_aedat2_input_is_a_clear_error(tmp_path):
    ev = stream(100)
    write(ev, tmp_path / "e.aedat2")
    data = (tmp_path / "e.aedat2").read_bytes()
    (tmp_path / "cut.aedat2").write_bytes(data[:-3])
    with pytest.raises(DatasetFormatError, match=r"cut\.aedat2: truncated: 5 trailing bytes"):
        load(tmp_path / "cut.aedat2")
    (tmp_path / "dvs128.aedat").write_bytes(b"#!AER-DAT2.0\r\n# AEChip: ch.unizh.ini.jaer.chip.retina.DVS128\r\n"
                                            + bytes(8))
    with pytest.raises(DatasetFormatError, match="only the DAVIS address layout"):
        load(tmp_path / "dvs128.aedat")
    (tmp_path / "nosize.aedat").write_bytes(b"#!AER-DAT2.0\r\n" + bytes(8))
    with pytest.raises(DatasetFormatError, match="sensor size unknown"):
        load(tmp_path / "nosize.aedat")
    (tmp_path / "v3.aedat").write_bytes(b"#!AER-DAT3.1\r\n" + bytes(8))
    with pytest.raises(DatasetFormatError, match=r"v3\.aedat: unknown layout.*AER-DAT3\.1"):
        load(tmp_path / "v3.aedat")
    back = bytearray(data)
    back[-4:] = (0).to_bytes(4, "big")  # the last event's time drops to 0: not a wrap
    (tmp_path / "back.aedat2").write_bytes(bytes(back))
    with pytest.raises(DatasetFormatError, match=r"back\.aedat2: time goes back at byte"):
        load(tmp_path / "back.aedat2")
    with pytest.raises(ValueError, match="up to 1024x512"):
        Aedat2Writer(tmp_path / "big.aedat2", 720, 1280)
    assert not (tmp_path / "big.aedat2").exists()
    gap = ev[:2].copy()
    gap["t"] = [0, 4_290_000_000]
    with pytest.raises(ValueError, match="cannot hold a silence"):
        write(gap, tmp_path / "gap.aedat2")
    assert not (tmp_path / "gap.aedat2").exists()
