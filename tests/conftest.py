"""Shared fixtures: a tiny recording with every field set, and a tiny generated dataset of two sequences.

Tests marked `slow` (subprocesses, Dask clusters, fuzzing, kill tests) are left out of the fast loop:
`python -m pytest -m "not slow"`; `.ci/run` runs everything.
"""

from __future__ import annotations

import pytest

from generators.formats.recording import Recording

from recordings import generate_tiny, make_recording


@pytest.fixture
def tiny_recording() -> Recording:
    """recordings.make_recording(): 6x8 pixels, events with ties, 4 frames, 3 HDR references, every field set."""
    return make_recording()


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory):
    """A folder of two generated sequences, a.h5 (seed 0) and b.h5 (seed 1): see recordings.generate_tiny."""
    d = tmp_path_factory.mktemp("tiny_dataset")
    generate_tiny(d / "a.h5", 0)
    generate_tiny(d / "b.h5", 1)
    return d
