"""The demo's background compilation (evsim_app.precompile): its toy inputs must stay valid, since the child
runs silently and a failing one would only make the cold demo slow."""

import sys

import numpy as np

import crf_models
from evsim_app import precompile
from evsim_eval.evaluate import evaluate_recording
from generators.builtin import ahdr_suite_config
from generators.formats.recording import validate_recording


def test_toy_recording_is_valid_and_every_demo_method_reconstructs_it():
    rec = precompile.toy_recording()
    validate_recording(rec)
    scores, _ = evaluate_recording(rec)
    assert set(scores) >= {"akf", "cf", "frames"}
    assert all(np.isfinite(v) for row in scores.values() for v in row.values())


def test_toy_capture_runs_the_demo_camera():
    frames = precompile.toy_capture(ahdr_suite_config().camera, crf_models.get("window"))
    assert frames and all(f.image.dtype == np.uint8 and f.image.shape == (16, 16) for f in frames)
    assert all(f.image.max() > 0 for f in frames)  # a real exposure, not an empty buffer


def test_no_child_without_akf_or_with_cached_kernels(monkeypatch):
    monkeypatch.setitem(sys.modules, "akf", None)
    assert precompile.start_background_compile() is None
    monkeypatch.delitem(sys.modules, "akf")
    monkeypatch.setattr(precompile, "_akf_cached", lambda: True)
    assert precompile.start_background_compile() is None
