"""Fuzz suite: seeded mutants of files written by evsim's own writers, fed to generators.load (and EXR folders to
generators.formats.exr.read_exr_sequence).

Every outcome must be a Recording that satisfies every documented rule (checked here independently of
generators.formats.recording.validate_recording), or a DatasetFormatError naming the file; never another exception
type, never a crash, never a hang (cases run in a forked child, killed after CASE_TIMEOUT_S), and never a time
span (of the events, the frames' mid-exposure times or the reference) that grows by more than the original file's
own span: what a misread wrap or offset does. Every reader gets byte-level or structural mutants and time-order
mutants (a time that goes back, a reversed block, a time that jumps ahead, a Prophesee wrap word that goes back);
the formats with a field to mutate get field mutants that must be refused (polarity, coordinates, units:
fuzz_mutators.mutate_fields); the streaming reader (open_event_stream) gets every mutant of the formats it streams.
EVSIM_FUZZ_N sets the mutants per layout (default 40 in CI: 1,720 cases, about 15 s; EVSIM_FUZZ_N=400 runs 17,200
in about 2 minutes). EVSIM_FUZZ_SEED shifts the seeds."""

from __future__ import annotations

import os
import pickle
import select
import signal
import struct
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from generators.formats import DatasetFormatError, export, load
from generators.formats.exr import read_exr_sequence
from generators.formats.recording import Recording
from generators.formats.streaming import open_event_stream
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
    """SIGALRM after `seconds`: ends a case stuck in Python code (one stuck inside a C library needs run_case's
    child process)."""
    def on_alarm(signum, frame):
        raise Hang()

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


class CaseWorker:
    """A forked child that runs cases one after another (forking once per case costs more than the cases): a case
    that takes longer than `timeout` is a 'hang' and the child is killed (this ends a case stuck inside HDF5 or
    another C library, where SIGALRM cannot); a child that dies of a signal (a segfault or abort in a native
    library) gives 'crash: signal N'. The next case starts a new child. Without fork, cases run in this process."""

    def __init__(self, fn, timeout: float):
        self.fn, self.timeout, self.pid = fn, timeout, None

    def _start(self) -> None:
        req_r, req_w = os.pipe()
        res_r, res_w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: serve cases until the request pipe closes; leave without the parent's cleanup
            try:
                os.close(req_w)
                os.close(res_r)
                with os.fdopen(req_r, "rb") as req, os.fdopen(res_w, "wb") as res:
                    while True:
                        try:
                            args = pickle.load(req)
                        except EOFError:
                            break
                        try:
                            out = self.fn(*args)
                        except BaseException as e:  # noqa: BLE001 - reported to the parent
                            out = f"harness error {type(e).__name__}: {e}"
                        data = out.encode("utf-8", "replace")
                        res.write(struct.pack("<I", len(data)) + data)
                        res.flush()
            finally:
                os._exit(0)
        os.close(req_r)
        os.close(res_w)
        self.pid, self.req, self.res = pid, os.fdopen(req_w, "wb"), res_r

    def stop(self, kill: bool = False) -> int:
        """End the child; returns its wait status."""
        if kill:
            os.kill(self.pid, signal.SIGKILL)
        self.req.close()
        os.close(self.res)
        _, status = os.waitpid(self.pid, 0)
        self.pid = None
        return status

    def _read(self, n: int) -> bytes:
        data = b""
        while len(data) < n and (chunk := os.read(self.res, n - len(data))):
            data += chunk
        return data

    def __call__(self, *args) -> str:
        if not hasattr(os, "fork"):
            return self.fn(*args)
        if self.pid is None:
            self._start()
        try:
            pickle.dump(args, self.req)
            self.req.flush()
        except BrokenPipeError:
            return f"crash: signal {os.WTERMSIG(self.stop())}"
        if not select.select([self.res], [], [], self.timeout)[0]:
            self.stop(kill=True)
            return "hang"
        head = self._read(4)
        if len(head) < 4:  # the child died
            status = self.stop()
            return f"crash: signal {os.WTERMSIG(status)}" if os.WIFSIGNALED(status) else "crash: child exited"
        return self._read(struct.unpack("<I", head)[0]).decode()


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


def spans(rec: Recording) -> dict[str, int]:
    """Time spans (us) of a Recording's time series: events, frames (mid-exposure times) and reference frames.
    (An exposure window may be as long as the rules allow: its bounds are not a series.)"""
    out = {}
    if rec.events.size:
        out["events"] = int(rec.events["t"].max()) - int(rec.events["t"].min())
    if rec.frames is not None and len(rec.frames):
        out["frames"] = int(np.max(rec.frame_t_mid_us)) - int(np.min(rec.frame_t_mid_us))
    if rec.reference is not None and len(rec.reference):
        out["reference"] = int(np.max(rec.reference_t_us)) - int(np.min(rec.reference_t_us))
    return out


def exr_violations(out) -> list[str]:
    """The documented rules of what read_exr_sequence returns: (R, H, W) float32 radiance, finite and >= 0, and
    (R,) int64 times that never decrease."""
    images, t = out
    if not (isinstance(images, np.ndarray) and images.dtype == np.float32 and images.ndim == 3):
        return ["images dtype/shape"]
    if not (isinstance(t, np.ndarray) and t.dtype == np.int64 and t.shape == (images.shape[0],)):
        return ["times dtype/shape"]
    bad = []
    if (np.diff(t) < 0).any():
        bad.append("times decrease")
    if not np.isfinite(images).all() or (images < 0).any():
        bad.append("pixels not finite >= 0")
    return bad


def exr_spans(out) -> dict[str, int]:
    _, t = out
    return {"reference": int(t.max()) - int(t.min())} if t.size else {}


STREAM_CHUNK = 37  # events per chunk of the streaming reader here: small and odd, so that checks cross chunks


def read_stream(path: Path) -> Recording:
    """Every event of open_event_stream(path) (the reader of plots and videos, chunk by chunk), as a Recording."""
    stream = open_event_stream(path, size=STREAM_CHUNK)
    chunks = list(stream.chunks())
    events = np.concatenate(chunks) if chunks else np.zeros(0, EVENT_DTYPE)
    return Recording(events=events, height=stream.height, width=stream.width)


# what each reader is: (read, rules, spans)
READERS = {"load": (load, rule_violations, spans), "exr": (read_exr_sequence, exr_violations, exr_spans),
           "stream": (read_stream, rule_violations, spans)}


def run_case(path: Path, own: dict[str, int] | None = None, reader: str = "load", must_refuse: bool = False) -> str:
    """'valid', 'error' (DatasetFormatError naming the file), or a failure description ('hang' past
    CASE_TIMEOUT_S, a crash, an undocumented exception, a silent acceptance). own: the time spans of the original
    file, which a valid outcome's must not exceed by more than themselves; must_refuse: the mutant holds a value
    the format does not allow (a field mutant), so a valid outcome is a silent acceptance."""
    return _WORKER(path, own, reader, must_refuse)


def _case(path: Path, own: dict[str, int] | None, reader: str, must_refuse: bool) -> str:
    read, rules, time_spans = READERS[reader]
    try:
        with time_bound(CASE_TIMEOUT_S):
            out = read(path)
    except Hang:
        return "hang"
    except DatasetFormatError as e:
        return "error" if str(path.parent) in str(e) or path.name in str(e) else f"error not naming the file: {e}"
    except Exception as e:  # noqa: BLE001 - the point of the test
        return f"undocumented {type(e).__name__}: {e}"
    try:
        bad = rules(out)
        if not bad and own:
            got = time_spans(out)
            bad = [f"{k} time span grew from {own[k]} to {got[k]} us" for k in own if got.get(k, 0) > 2 * own[k]]
    except Exception as e:  # noqa: BLE001 - content so broken that plain numpy checks fail on it
        bad = [f"unusable content ({type(e).__name__}: {e})"]
    if not bad and must_refuse:
        bad = ["a mutant that must be refused was read"]
    return "valid" if not bad else f"silent acceptance: {', '.join(bad)}"


_WORKER = CaseWorker(_case, CASE_TIMEOUT_S)


@pytest.fixture(scope="module", autouse=True)
def _case_worker():
    yield
    if _WORKER.pid is not None:
        _WORKER.stop()


def _misbehave(how: str) -> str:
    if how == "spin":
        while True:
            pass
    if how == "die":  # as a segfault or abort in a native library ends the process
        os.kill(os.getpid(), signal.SIGKILL)
    return f"done {how}"


def test_the_case_worker_reports_hangs_and_crashes_and_goes_on():
    worker = CaseWorker(_misbehave, timeout=1)
    assert worker("a") == "done a"
    assert worker("spin") == "hang"
    assert worker("die") == f"crash: signal {int(signal.SIGKILL)}"
    assert worker("b") == "done b"
    worker.stop()


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
        export(rec, d / "exr", "exr")
    for p in (d / "native.h5", d / "e2vid.h5", d / "ijrr", d / "akf.mat", *(d / n for n in EVENTS_ONLY)):
        assert run_case(p) == "valid", p
    assert run_case(d / "exr", reader="exr") == "valid"
    return d


EVENTS_ONLY = {"evt3.raw": "evt3", "evt2.raw": "evt2", "td.dat": "dat", "events.txt.zip": "e2vid-txt",
               "e2vid.txt": "e2vid-txt", "jaer.aedat2": "aedat2"}
# layout: (original, mutator, reader)
LAYOUTS = {
    "native-structure": ("native.h5", fm.mutate_h5, "load"),
    "native-bytes": ("native.h5", fm.mutate_bytes, "load"),
    "native-time": ("native.h5", fm.mutate_time_h5, "load"),
    "e2vid-structure": ("e2vid.h5", fm.mutate_h5, "load"),
    "e2vid-bytes": ("e2vid.h5", fm.mutate_bytes, "load"),
    "e2vid-time": ("e2vid.h5", fm.mutate_time_h5, "load"),
    "ijrr+exr": ("ijrr", fm.mutate_folder, "load"),
    "ijrr-time": ("ijrr", fm.mutate_time_folder, "load"),
    "akf-mat-structure": ("akf.mat", fm.mutate_mat, "load"),
    "akf-mat-bytes": ("akf.mat", fm.mutate_bytes, "load"),
    "akf-mat-time": ("akf.mat", fm.mutate_time_mat, "load"),
    "evt3-bytes": ("evt3.raw", fm.mutate_bytes, "load"),
    "evt3-time": ("evt3.raw", fm.mutate_time_prophesee, "load"),
    "evt2-bytes": ("evt2.raw", fm.mutate_bytes, "load"),
    "evt2-time": ("evt2.raw", fm.mutate_time_prophesee, "load"),
    "dat-bytes": ("td.dat", fm.mutate_bytes, "load"),
    "dat-time": ("td.dat", fm.mutate_time_prophesee, "load"),
    "aedat2-bytes": ("jaer.aedat2", fm.mutate_bytes, "load"),
    "e2vid-txt-zip-bytes": ("events.txt.zip", fm.mutate_bytes, "load"),
    "e2vid-txt-zip-time": ("events.txt.zip", fm.mutate_time_e2vid_text, "load"),
    "e2vid-txt-text": ("e2vid.txt", fm.mutate_text, "load"),
    "e2vid-txt-time": ("e2vid.txt", fm.mutate_time_e2vid_text, "load"),
    "exr-sequence": ("exr", fm.mutate_folder, "exr"),
    "exr-sequence-time": ("exr", fm.mutate_time_folder, "exr"),
    # polarity, coordinate and unit fields (fm.mutate_fields): every mutant must be refused
    "e2vid-fields": ("e2vid.h5", fm.mutate_fields, "load"),
    "akf-mat-fields": ("akf.mat", fm.mutate_fields, "load"),
    "evt3-fields": ("evt3.raw", fm.mutate_fields, "load"),
    "evt2-fields": ("evt2.raw", fm.mutate_fields, "load"),
    "dat-fields": ("td.dat", fm.mutate_fields, "load"),
    "aedat2-fields": ("jaer.aedat2", fm.mutate_fields, "load"),
}
# the streaming reader (open_event_stream, chunk by chunk) gets every mutant of the layouts it streams
LAYOUTS.update({f"{name}-stream": (source, mutate, "stream") for name, (source, mutate, _) in list(LAYOUTS.items())
                if name.split("-")[0] in ("evt3", "evt2", "dat", "aedat2")})


def fuzz(originals: Path, work: Path, layout: str, n: int) -> Counter:
    source, mutate, reader = LAYOUTS[layout]
    read, _, time_spans = READERS[reader]
    own = time_spans(read(originals / source))
    outcomes, failures = Counter(), []
    for i in range(n):
        rng = np.random.default_rng([SEED, i, sum(map(ord, layout))])
        target = fm.copy_input(originals / source, work / f"{layout}_{i}{Path(source).suffix}")
        desc = mutate(target, rng)
        if rng.random() < 0.3 and "-time" not in layout:  # a second mutation on top, for combinations
            # (time-order mutants carry one corruption: two can build a valid file whose last time is later)
            desc += "; " + mutate(target, rng)
        out = run_case(target, own, reader, must_refuse="-fields" in layout)
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
    LAYOUTS["aedat4-bytes"] = ("sample.aedat4", fm.mutate_bytes, "load")
    try:
        outcomes = fuzz(tmp_path, tmp_path, "aedat4-bytes", N_PER_LAYOUT)
    finally:
        del LAYOUTS["aedat4-bytes"]
    assert outcomes["error"] > 0


def test_aedat4_with_times_out_of_order_raises(tmp_path):
    # an uncompressed AEDAT4 file (dv-processing, one event packet), whose event times the mutator rewrites
    pytest.importorskip("aedat")
    dv = pytest.importorskip("dv_processing")
    ev = make_recording(n_events=300).events
    config = dv.io.MonoCameraWriter.Config("evsim-fuzz")
    config.addEventStream((8, 6))
    config.compression = dv.CompressionType.NONE
    writer = dv.io.MonoCameraWriter(str(tmp_path / "plain.aedat4"), config)
    store = dv.EventStore()
    for t, x, y, p in zip(ev["t"].tolist(), ev["x"].tolist(), ev["y"].tolist(), (ev["p"] > 0).tolist()):
        store.push_back(t, x, y, p)
    writer.writeEvents(store)
    del writer
    np.testing.assert_array_equal(fm.aedat4_event_times(tmp_path / "plain.aedat4")[0], ev["t"])
    LAYOUTS["aedat4-time"] = ("plain.aedat4", fm.mutate_time_aedat4, "load")
    try:
        outcomes = fuzz(tmp_path, tmp_path, "aedat4-time", N_PER_LAYOUT)
    finally:
        del LAYOUTS["aedat4-time"]
    assert outcomes["error"] > 0


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
    assert main(["info", str(p)]) == 2  # its event summary agrees with its events: the sensor size is still checked
    assert main(["evaluate", str(p), "--methods", "frames"]) == 2
    from generators.formats.streaming import open_event_stream  # the stream plots and videos read

    with pytest.raises(DatasetFormatError, match="sensor width must be an integer in 1"):
        open_event_stream(p)
