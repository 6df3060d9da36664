"""`evsim info` data: describe() against a recording whose statistics are known exactly."""

from __future__ import annotations

import numpy as np
import pytest

from evsim_app.info import describe, format_description
from generators.formats import DatasetFormatError, export
from generators.formats.recording import Recording
from sim import make_events


def known_recording() -> Recording:
    """1000 events every 1 ms from t = 5 ms (every 4th OFF), 26 frames at 25 Hz with 10 ms exposures centred
    on 0, 40, ..., 1000 ms, 2 reference frames; everything spans [-5, 1005] ms."""
    n = 1000
    t = 5_000 + np.arange(n, dtype=np.int64) * 1000
    p = np.where(np.arange(n) % 4 == 0, -1, 1)
    mid = np.arange(26, dtype=np.int64) * 40_000
    return Recording(
        events=make_events(t, np.arange(n) % 4, np.arange(n) % 3, p), height=3, width=4,
        frames=np.zeros((26, 3, 4), np.uint16), frame_t_start_us=mid - 5_000, frame_t_mid_us=mid,
        frame_t_end_us=mid + 5_000, frame_bit_depth=10,
        reference=np.ones((2, 3, 4), np.float32), reference_t_us=np.array([0, 1_000_000]),
        crf={"name": "gamma", "params": {"gamma": 2.2}}, threshold_maps=np.stack([np.full((3, 4), 0.2),
                                                                                   np.full((3, 4), 0.3)]),
        event_labels=(np.arange(n) % 2).astype(np.uint8),
        metadata={"generator": "ahdr", "seed": {"entropy": 1234, "spawn_key": [0]}, "packages": {"numpy": "2"}},
    )


@pytest.mark.parametrize("fmt,name", [("native", "a.h5"), ("ijrr", "ij"), ("e2vid", "e.h5")])
def test_describe_reports_the_known_statistics(tmp_path, fmt, name):
    export(known_recording(), tmp_path / name, fmt)
    d = describe(tmp_path / name)
    assert d["layout"] == fmt and (d["height"], d["width"]) == (3, 4)
    assert (d["t_start_us"], d["t_end_us"]) == (-5_000, 1_005_000)
    assert d["duration_s"] == pytest.approx(1.01)
    ev = d["events"]
    assert (ev["count"], ev["on"], ev["off"]) == (1000, 750, 250)
    assert (ev["t_first_us"], ev["t_last_us"]) == (5_000, 1_004_000)
    assert ev["rate_hz"] == pytest.approx(1000 / 1.01)
    assert ev["labels"] == {"signal": 500, "shot": 500, "leak": 0, "hot": 0}
    fr = d["frames"]
    assert fr["count"] == 26 and fr["rate_hz"] == pytest.approx(25.0)
    assert fr["exposure_us"] == {"min": 10_000, "mean": 10_000.0, "max": 10_000}
    assert fr["bit_depth"] == (8 if fmt == "e2vid" else 10)
    assert d["reference"] == {"count": 2, "t_first_us": 0, "t_last_us": 1_000_000}
    assert d["threshold_maps"] == pytest.approx({"on_mean": 0.2, "off_mean": 0.3})
    assert d["crf"]["name"] == "gamma" and d["seed_entropy"] == 1234 and d["generator"] == "ahdr"
    text = format_description(d)
    for needle in ("4 x 3 px", "1000 (ON 750, OFF 250)", "26 at 25 Hz", "seed        1234", "gamma"):
        assert needle in text


def test_describe_without_frames_and_bad_path(tmp_path):
    rec = known_recording()
    rec.frames = rec.frame_t_start_us = rec.frame_t_mid_us = rec.frame_t_end_us = None
    rec.reference = rec.reference_t_us = None
    export(rec, tmp_path / "a.h5", "native")
    d = describe(tmp_path / "a.h5")
    assert d["frames"] is None and d["reference"] is None
    assert d["duration_s"] == pytest.approx(0.999)
    assert "frames      none" in format_description(d)
    with pytest.raises(DatasetFormatError, match="missing.h5: no such file"):
        describe(tmp_path / "missing.h5")


def test_info_names_the_dvs_fields_a_run_set_over_its_sensor(tmp_path, capsys):
    """`--dvs` changes are part of the model: info lists them after the sensor's name; a plain run lists none."""
    from evsim_app.cli import main

    small = ["--scene", "moving_edge", "--duration-s", "0.05", "--height", "8", "--width", "10", "--no-progress"]
    for name, extra in (("plain", []), ("changed", ["--sensor", "davis346_road", "--dvs",
                                                     "pos_threshold=0.25,dead_pixel_fraction=0.1"])):
        assert main(["generate", "ahdr", *small, *extra, "--out", str(tmp_path / name)]) == 0
    capsys.readouterr()
    plain = format_description(describe(tmp_path / "plain" / "moving_edge.h5"))
    assert "  model       davis346 (preset)\n" in plain + "\n" and "DVS changed" not in plain
    changed = describe(tmp_path / "changed" / "moving_edge.h5")
    assert changed["dvs_changes"] == {"pos_threshold": 0.25, "dead_pixel_fraction": 0.1}
    assert "model       davis346_road (preset); DVS changed dead_pixel_fraction=0.1, pos_threshold=0.25" in \
        format_description(changed)
