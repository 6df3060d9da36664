"""Real recording (DVXplorer AEDAT4 from ../shared/data): read it and carry it exactly through every layout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from evsim_app.info import describe
from generators.formats import DatasetFormatError, ExportDropWarning, export, load

from recordings import assert_recordings_equal

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
AEDAT4 = DATA / "events" / "tonic_sample_dvxplorer.aedat4"


@pytest.fixture(scope="module")
def real():
    pytest.importorskip("aedat", reason="the optional 'aedat' package reads AEDAT4")
    if not AEDAT4.is_file():
        pytest.skip(f"real data absent: {AEDAT4}")
    return load(AEDAT4)


def test_real_aedat4_matches_its_documented_content(real):
    # ../shared/data/README.md: DVXplorer (320x240), 111,954 events over 0.59 s, no frames.
    assert (real.width, real.height) == (320, 240)
    assert real.events.size == 111_954 and real.frames is None
    span_s = (real.events["t"][-1] - real.events["t"][0]) / 1e6
    assert span_s == pytest.approx(0.59, abs=0.005)
    assert real.events["t"][0] > 1_500_000_000 * 10**6  # Unix-time microseconds, kept exact in int64
    assert 0.2 < np.mean(real.events["p"] > 0) < 0.8  # both polarities present
    d = describe(AEDAT4)
    assert d["events"]["count"] == 111_954 and d["events"]["rate_hz"] == pytest.approx(111_954 / span_s)


@pytest.mark.parametrize("fmt,name", [("native", "r.h5"), ("e2vid", "r.h5"), ("ijrr", "r")])
def test_real_events_survive_every_layout_exactly(real, tmp_path, fmt, name):
    export(real, tmp_path / name, fmt)
    assert_recordings_equal(real, load(tmp_path / name))


def test_real_events_through_the_akf_mat(real, tmp_path):
    rec = load(AEDAT4)
    # The .mat layout needs frames: give it two blank ones around the recording.
    t0, t1 = int(rec.events["t"][0]), int(rec.events["t"][-1])
    rec.frames = np.zeros((2, rec.height, rec.width), np.uint8)
    rec.frame_t_start_us, rec.frame_t_end_us = np.array([t0, t1 - 1000]), np.array([t0 + 1000, t1])
    rec.frame_t_mid_us = rec.frame_t_start_us + 500
    export(rec, tmp_path / "r.mat", "akf-mat", ct=0.2)
    np.testing.assert_array_equal(load(tmp_path / "r.mat").events, real.events)


def test_truncated_aedat4_is_a_clear_error(real, tmp_path):
    cut = tmp_path / "cut.aedat4"
    cut.write_bytes(AEDAT4.read_bytes()[:100_000])
    with pytest.raises(DatasetFormatError, match=r"cut\.aedat4: unreadable AEDAT4"):
        load(cut)


ROAD = DATA / "events" / "davis346_road" / "davis346_road.aedat4"


def test_a_real_davis346_recording_keeps_its_frame_windows_in_aedat4_and_its_events_in_aedat2(tmp_path):
    # ../shared/data/README.md: 59 APS frames with a fixed 500 us exposure (begin/end per frame), 78,830 events.
    aedat = pytest.importorskip("aedat")
    pytest.importorskip("dv_processing")
    tonic_io = pytest.importorskip("tonic.io")
    if not ROAD.is_file():
        pytest.skip(f"real data absent: {ROAD}")
    road = load(ROAD)
    assert road.frames.shape == (59, 260, 346) and road.events.size == 78_830
    np.testing.assert_array_equal(road.frame_t_end_us - road.frame_t_start_us, 500)
    with pytest.warns(ExportDropWarning, match="leaves out metadata"):
        export(road, tmp_path / "r.aedat4", "aedat4")
    frames = [p["frame"] for p in aedat.Decoder(str(tmp_path / "r.aedat4")) if "frame" in p]
    for key, want in (("t", road.frame_t_start_us), ("begin_t", road.frame_t_start_us),
                      ("end_t", road.frame_t_end_us), ("exposure_begin_t", road.frame_t_start_us),
                      ("exposure_end_t", road.frame_t_end_us)):
        np.testing.assert_array_equal([f[key] for f in frames], want, err_msg=key)
    np.testing.assert_array_equal(np.stack([f["pixels"] for f in frames]), road.frames)
    back = load(tmp_path / "r.aedat4")
    np.testing.assert_array_equal(back.events, road.events)
    # AEDAT 2.0 of the same camera's size: what tonic's DAVIS346 reader reads is the recording's events, times
    # relative to the offset the header records (the recording's times are Unix microseconds)
    with pytest.warns(ExportDropWarning, match="leaves out frames, metadata"):
        export(road, tmp_path / "r.aedat2", "aedat2")
    _, _, xytp = tonic_io.read_davis_346(str(tmp_path / "r.aedat2"))
    offset = int(road.events["t"][0]) // 1000 * 1000
    np.testing.assert_array_equal(xytp["t"].astype(np.int64), road.events["t"] - offset)
    np.testing.assert_array_equal(xytp["x"], road.events["x"])
    np.testing.assert_array_equal(xytp["y"], road.events["y"])
    np.testing.assert_array_equal(np.where(xytp["p"] > 0, 1, -1), road.events["p"])
    np.testing.assert_array_equal(load(tmp_path / "r.aedat2").events, road.events)
