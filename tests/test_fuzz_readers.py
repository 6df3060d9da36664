"""Fuzz suite: seeded mutants of files written by evsim's own writers, fed to generators.load.

Every outcome must be a Recording that satisfies every documented rule (checked here independently of
generators.formats.recording.validate_recording), or a DatasetFormatError naming the file; never another exception type,
never a hang (each case runs under a SIGALRM time bound). EVSIM_FUZZ_N sets the mutants per layout (default 40
in CI: about 250 cases; EVSIM_FUZZ_N=350 runs 2,000+). EVSIM_FUZZ_SEED shifts the seeds.
"""

from __future__ import annotations

import os
import signal
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from generators.formats import DatasetFormatError, export, load
from generators.formats.recording import Recording
from sim import EVENT_DTYPE

import fuzz_mutators as fm
from recordings import make_recording

pytestmark = pytest.mark.slow  # hundreds of mutated files: left out of the fast loop

N_PER_LAYOUT = int(os.environ.get("EVSIM_FUZZ_N", "40"))
SEED = int(os.environ.get("EVSIM_FUZZ_SEED", "0"))
CASE_TIMEOUT_S = 20
AEDAT4 = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "tonic_sample_dvxplorer.aedat4"


class Hang(BaseException):
    pass


@contextmanager
def time_bound(seconds: int):
    def on_alarm(signum, frame):
        raise Hang()

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def rule_violations(rec: Recording) -> list[str]:
    """The documented rules of a Recording (generators/recording.py), checked with plain numpy."""
    bad = []
    h, w = rec.height, rec.width
    if not (isinstance(h, (int, np.integer)) and isinstance(w, (int, np.integer)) and 0 < h <= 65536
            and 0 < w <= 65536):
        return [f"sensor size {h!r}x{w!r}"]
    ev = rec.events
    if not (isinstance(ev, np.ndarray) and ev.dtype == EVENT_DTYPE and ev.ndim == 1):
        return ["events dtype"]
    if ev.size:
        if (ev["x"] >= w).any() or (ev["y"] >= h).any():
            bad.append("event outside the sensor")
        if not np.isin(ev["p"], (-1, 1)).all():
            bad.append("polarity")
        if (np.diff(ev["t"]) < 0).any():
            bad.append("events unsorted")
        if np.abs(ev["t"]).max() > 2**62:
            bad.append("event time overflow")
    if rec.event_labels is not None:
        lab = np.asarray(rec.event_labels)
        if lab.shape != ev.shape or (lab.size and (lab.min() < 0 or lab.max() > 3)):
            bad.append("labels")
    if not (isinstance(rec.frame_bit_depth, (int, np.integer)) and 8 <= rec.frame_bit_depth <= 16):
        return bad + [f"bit depth {rec.frame_bit_depth!r}"]
    if rec.frames is not None:
        fr = np.asarray(rec.frames)
        if fr.ndim != 3 or fr.shape[1:] != (h, w) or fr.dtype.kind != "u" or fr.dtype.itemsize > 2:
            bad.append(f"frames {fr.dtype} {fr.shape}")
        elif fr.size and fr.max() >= 1 << rec.frame_bit_depth:
            bad.append("frame value beyond the bit depth")
        ts = [np.asarray(getattr(rec, k)) for k in ("frame_t_start_us", "frame_t_mid_us", "frame_t_end_us")]
        if any(t.shape != (fr.shape[0],) or t.dtype.kind not in "iu" for t in ts):
            bad.append("frame times shape/dtype")
        elif (ts[0] > ts[1]).any() or (ts[1] > ts[2]).any() or (np.diff(ts[1]) < 0).any():
            bad.append("exposure order")
        elif fr.shape[0] and max(np.abs(t).max() for t in ts) > 2**62:
            bad.append("frame time overflow")
    if rec.reference is not None:
        ref = np.asarray(rec.reference)
        t = np.asarray(rec.reference_t_us)
        if ref.ndim != 3 or ref.shape[1:] != (h, w) or ref.dtype.kind != "f" or t.shape != (ref.shape[0],):
            bad.append("reference shape")
        elif not np.isfinite(ref).all() or (ref < 0).any():
            bad.append("reference not finite >= 0")
        elif t.dtype.kind not in "iu" or (np.diff(t) < 0).any():
            bad.append("reference times")
    if rec.threshold_maps is not None:
        thr = np.asarray(rec.threshold_maps)
        if thr.shape != (2, h, w) or thr.dtype.kind != "f" or not np.isfinite(thr).all() or (thr <= 0).any():
            bad.append("threshold maps")
    if rec.crf is not None and not (isinstance(rec.crf, dict) and isinstance(rec.crf.get("name"), str)):
        bad.append("crf")
    if not isinstance(rec.metadata, dict):
        bad.append("metadata")
    return bad


def run_case(path: Path) -> str:
    """'valid', 'error' (DatasetFormatError naming the file), or a failure description."""
    try:
        with time_bound(CASE_TIMEOUT_S):
            rec = load(path)
    except Hang:
        return "hang"
    except DatasetFormatError as e:
        return "error" if str(path.parent) in str(e) or path.name in str(e) else f"error not naming the file: {e}"
    except Exception as e:  # noqa: BLE001 - the point of the test
        return f"undocumented {type(e).__name__}: {e}"
    try:
        bad = rule_violations(rec)
    except Exception as e:  # noqa: BLE001 - content so broken that plain numpy checks fail on it
        bad = [f"unusable content ({type(e).__name__}: {e})"]
    return "valid" if not bad else f"silent acceptance: {', '.join(bad)}"


@pytest.fixture(scope="module")
def originals(tmp_path_factory):
    d = tmp_path_factory.mktemp("originals")
    rec = make_recording(n_events=300)
    rec.events["t"] -= rec.events["t"][0] - 1000  # IJRR stores non-negative times
    for name in ("frame_t_start_us", "frame_t_mid_us", "frame_t_end_us", "reference_t_us"):
        setattr(rec, name, getattr(rec, name) - 123_456_789_012 + 1000)
    export(rec, d / "native.h5", "native")
    export(rec, d / "e2vid.h5", "e2vid")
    export(rec, d / "ijrr", "ijrr")
    export(rec, d / "akf.mat", "akf-mat")
    with pytest.warns(UserWarning):  # events-only formats say what they leave out
        for name, fmt in EVENTS_ONLY.items():
            export(rec, d / name, fmt)
    for p in (d / "native.h5", d / "e2vid.h5", d / "ijrr", d / "akf.mat", *(d / n for n in EVENTS_ONLY)):
        assert run_case(p) == "valid", p
    return d


EVENTS_ONLY = {"evt3.raw": "evt3", "evt2.raw": "evt2", "td.dat": "dat", "events.txt.zip": "e2vid-txt",
               "e2vid.txt": "e2vid-txt"}
LAYOUTS = {
    "native-structure": ("native.h5", fm.mutate_h5),
    "native-bytes": ("native.h5", fm.mutate_bytes),
    "e2vid-structure": ("e2vid.h5", fm.mutate_h5),
    "e2vid-bytes": ("e2vid.h5", fm.mutate_bytes),
    "ijrr+exr": ("ijrr", fm.mutate_folder),
    "akf-mat-structure": ("akf.mat", fm.mutate_mat),
    "akf-mat-bytes": ("akf.mat", fm.mutate_bytes),
    "evt3-bytes": ("evt3.raw", fm.mutate_bytes),
    "evt2-bytes": ("evt2.raw", fm.mutate_bytes),
    "dat-bytes": ("td.dat", fm.mutate_bytes),
    "e2vid-txt-zip-bytes": ("events.txt.zip", fm.mutate_bytes),
    "e2vid-txt-text": ("e2vid.txt", fm.mutate_text),
}


def fuzz(originals: Path, work: Path, layout: str, n: int) -> Counter:
    source, mutate = LAYOUTS[layout]
    outcomes, failures = Counter(), []
    for i in range(n):
        rng = np.random.default_rng([SEED, i, sum(map(ord, layout))])
        target = fm.copy_input(originals / source, work / f"{layout}_{i}{Path(source).suffix}")
        desc = mutate(target, rng)
        if rng.random() < 0.3:  # a second mutation on top, for combinations
            desc += "; " + mutate(target, rng)
        out = run_case(target)
        outcomes[out.split(":")[0]] += 1
        if out not in ("valid", "error"):
            failures.append(f"{layout} #{i} ({desc}): {out}")
    assert not failures, "\n".join(failures[:20])
    print(f"{layout}: {dict(outcomes)}")
    return outcomes


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_mutated_files_load_valid_or_raise_dataset_format_error(originals, tmp_path, layout):
    outcomes = fuzz(originals, tmp_path, layout, N_PER_LAYOUT)
    assert outcomes["error"] > 0  # the mutator does reach the readers' checks


def test_mutated_aedat4_loads_valid_or_raises(tmp_path):
    pytest.importorskip("aedat")
    if not AEDAT4.is_file():
        pytest.skip("no shared AEDAT4 sample")
    fm.copy_input(AEDAT4, tmp_path / "sample.aedat4")
    assert run_case(tmp_path / "sample.aedat4") == "valid"
    LAYOUTS["aedat4-bytes"] = ("sample.aedat4", fm.mutate_bytes)
    try:
        fuzz(tmp_path, tmp_path, "aedat4-bytes", max(5, N_PER_LAYOUT // 2))
    finally:
        del LAYOUTS["aedat4-bytes"]


# ----- regression tests: the reproductions of issue 12 ---------------------------------------------------------

def _native(originals, tmp_path, edit) -> Path:
    import h5py

    p = fm.copy_input(originals / "native.h5", tmp_path / "n.h5")
    with h5py.File(p, "r+") as f:
        edit(f)
    return p


@pytest.mark.parametrize("edit, match", [
    (lambda f: f.attrs.__setitem__("width", 0), "width"),
    (lambda f: f.attrs.__setitem__("height", -3), "height"),
    (lambda f: f.attrs.__setitem__("metadata", "{not json"), "metadata"),
    (lambda f: f.attrs.__setitem__("height", float("nan")), "n.h5"),
    (lambda f: f["t_offset"].__setitem__((), 2**63 - 10), "offset"),
    (lambda f: f["frames/t_end_us"].__setitem__(0, -5), "exposure"),
    (lambda f: f["reference/images"].__setitem__((0, 0, 0), np.nan), "finite"),
    (lambda f: f["threshold_maps"].__setitem__((0, 0, 0), np.nan), "threshold"),
    (lambda f: f["events/label"].__setitem__(0, 9), "labels"),
    (lambda f: f["events/x"].__setitem__(0, 500), "sensor"),
    (lambda f: f.attrs.__delitem__("format"), "incomplete"),
])
def test_native_reproductions_raise_dataset_format_error(originals, tmp_path, edit, match):
    p = _native(originals, tmp_path, edit)
    with pytest.raises(DatasetFormatError, match=match) as e:
        load(p)
    assert "n.h5" in str(e.value)


def test_native_coordinates_are_not_cast_unchecked(originals, tmp_path):
    import h5py

    for value in (-1, np.nan):
        p = _native(originals, tmp_path, lambda f: None)
        with h5py.File(p, "r+") as f:
            x = f["events/x"][()].astype(np.float64)
            x[3] = value
            del f["events/x"]
            f.create_dataset("events/x", data=x)
        with pytest.raises(DatasetFormatError, match="column x"):
            load(p)
        p.unlink()


def test_native_uint64_times_beyond_int64_are_refused(originals, tmp_path):
    import h5py

    p = _native(originals, tmp_path, lambda f: None)
    with h5py.File(p, "r+") as f:
        t = f["events/t"][()].astype(np.uint64)
        t[-1] = 2**63 + 5
        del f["events/t"]
        f.create_dataset("events/t", data=t)
    with pytest.raises(DatasetFormatError, match="column t"):
        load(p)


def test_streaming_readers_validate_too(originals, tmp_path):
    from generators.formats.native import iter_native_events, open_native_images

    p = _native(originals, tmp_path, lambda f: f["events/y"].__setitem__(5, 60000))
    with pytest.raises(DatasetFormatError, match="sensor"):
        list(iter_native_events(p))
    q = _native(originals, tmp_path / "..", lambda f: f["frames/t_start_us"].__setitem__(1, 10**15))
    with pytest.raises(DatasetFormatError, match="exposure"), open_native_images(q):
        pass


def test_evsim_info_and_evaluate_refuse_a_zero_width_file(originals, tmp_path):
    from evsim_app.cli import main

    p = _native(originals, tmp_path, lambda f: f.attrs.__setitem__("width", 0))
    assert main(["info", str(p)]) == 2
    assert main(["evaluate", str(p), "--methods", "frames"]) == 2
