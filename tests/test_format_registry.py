"""The format registry (generators.formats.registry) is the one place that knows the formats: every name the CLI
offers has a record whose recogniser, reader and writer exist, detect() finds each format it writes, and the scenes'
recording detector agrees with load() (an AKF .mat recording is a scene input like any other)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from generators.choices import EXPORT_FORMATS, FORMATS
from generators.exports import export_suffix
from generators.formats import HOLDS, detect, export, load
from generators.formats.registry import ALL_PARTS, REGISTRY, format_record, resolve
from generators.scenes.recording_frames import is_recording
from generators.scenes.video import open_frames

from recordings import make_recording


def test_every_format_has_one_record_whose_functions_resolve():
    assert FORMATS == tuple(f.name for f in REGISTRY) and len(set(FORMATS)) == len(FORMATS)
    assert set(EXPORT_FORMATS) == set(FORMATS) - {"exr"}
    for f in REGISTRY:
        for ref in (f.recognise, f.read, f.write):
            assert callable(resolve(ref)), (f.name, ref)
        assert set(f.holds) <= set(ALL_PARTS) and HOLDS[f.name] == f.holds


@pytest.mark.parametrize("fmt", [f for f in FORMATS if f != "aedat4"])  # aedat4: an optional writer (dv-processing)
def test_detect_recognises_what_export_writes_and_load_reads_it_back(tmp_path, fmt):
    rec = make_recording()
    out = tmp_path / f"x{export_suffix(fmt)}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the parts a format cannot hold
        export(rec, out, fmt)
    assert detect(out) == fmt
    back = load(out)
    if "events" in format_record(fmt).holds:
        np.testing.assert_array_equal(back.events["x"], rec.events["x"])
    else:
        assert back.events.size == 0 and back.reference.shape == rec.reference.shape


def test_a_recording_in_any_format_with_frames_is_a_scene_input(tmp_path):
    rec = make_recording()
    for fmt in ("native", "e2vid", "akf-mat", "ijrr"):
        out = tmp_path / f"x{export_suffix(fmt)}"
        export(rec, out, fmt)
        assert is_recording(out), fmt
        frames = open_frames(out)
        assert frames.size == rec.frames.shape[1:], fmt
    (tmp_path / "clip.mp4").write_bytes(b"")
    assert not is_recording(tmp_path / "clip.mp4")
