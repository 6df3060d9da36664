"""Interrupted runs: SIGTERM and kill -9 at seeded random points of `evsim generate` (also --overwrite) and
`evsim reconstruct`, run as subprocesses of this worktree's CLI.

After SIGTERM no temporary file remains (the writers' cleanup runs: exit 143). After either signal, every file at
a final path is whole: each native .h5 loads as a valid Recording, each EXR folder reads back, and a native
temporary file left by kill -9 is refused by the reader (it lacks the completion attribute set on close); the
next run over the same folder removes the dead run's temporaries.
EVSIM_KILL_RUNS (default 1) repeats each scenario with further kill points.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from evsim_eval.protocols import dataset_sequences
from generators.formats import DatasetFormatError, load
from generators.formats.exr import read_exr_sequence

pytestmark = pytest.mark.slow  # signals and full disks sent to CLI subprocesses: left out of the fast loop

ROOT = Path(__file__).resolve().parents[1]
RUNS = int(os.environ.get("EVSIM_KILL_RUNS", "1"))
SMALL = ["--duration-s", "0.3", "--height", "24", "--width", "32", "--no-progress"]


def cli(*args) -> list[str]:
    return [sys.executable, "-m", "evsim_app.cli", *map(str, args)]


def start_and_kill(cmd, watch: Path, sig: int, rng) -> int:
    """Start cmd, wait until a temporary file appears under `watch` (writing has begun), wait a random further
    0..1.5 s, send `sig`; return the exit code (0 when it finished first)."""
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline and not list(watch.rglob(".*.tmp")):
        time.sleep(0.01)
    time.sleep(float(rng.uniform(0, 1.5)))
    if proc.poll() is None:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode in (0, 128 + sig, -sig), err.decode()[-2000:]
    return proc.returncode


def temporaries(folder: Path) -> list[Path]:
    return sorted(folder.rglob(".*.tmp"))


def assert_final_paths_whole(folder: Path) -> None:
    for p in folder.rglob("*.h5"):
        if not p.name.startswith("."):
            rec = load(p)  # raises if the file is incomplete or invalid
            assert rec.height == 24 and rec.width == 32
    for ts in folder.rglob("timestamps.txt"):
        if not any(part.startswith(".") for part in ts.relative_to(folder).parts):
            images, t = read_exr_sequence(ts.parent)
            assert images.shape[0] == t.size > 0 and np.isfinite(images).all()


def assert_index_consistent(folder: Path) -> None:
    """A folder with index.json holds every file it lists, whole, with the seed it lists (a run killed after
    writing index.json, its last write, has finished its dataset; one killed before leaves no index.json)."""
    index_path = folder / "index.json"
    if not index_path.exists():
        return
    index = json.loads(index_path.read_text())
    for entry in index["sequences"]:
        rec = load(folder / entry["file"])
        assert rec.metadata["seed"] == entry["seed"], entry["name"]
        if "export" in entry:
            assert (folder / entry["export"]).exists(), entry["export"]


def assert_leftover_natives_refused(folder: Path) -> None:
    for tmp in temporaries(folder):
        if tmp.is_file() and ".h5." in tmp.name and "_e2vid" not in tmp.name:
            with pytest.raises(DatasetFormatError):
                load(tmp)


def test_interrupted_generate_overwrite_and_reconstruct_leave_nothing_that_looks_complete(tmp_path):
    gen = ("generate", "ahdr", "--scene", "checkerboard", "--format", "e2vid", *SMALL)
    for run in range(RUNS):
        rng = np.random.default_rng([12, run])
        # generate, SIGTERM: exit 143, no temporaries, no index.json (written last) unless it finished
        out = tmp_path / f"term{run}"
        code = start_and_kill(cli(*gen, "--out", out), tmp_path, signal.SIGTERM, rng)
        assert temporaries(tmp_path) == [], f"exit {code}"
        assert_final_paths_whole(out)
        assert_index_consistent(out)
        # generate, kill -9: final paths whole, leftover native temporaries refused by the reader
        out = tmp_path / f"kill{run}"
        start_and_kill(cli(*gen, "--out", out), tmp_path, signal.SIGKILL, rng)
        assert_final_paths_whole(out)
        assert_leftover_natives_refused(out)
        assert_index_consistent(out)
        # the next run over that folder completes and removes the dead run's temporaries
        subprocess.run(cli(*gen, "--out", out, "--overwrite"), cwd=ROOT, check=True, capture_output=True)
        assert temporaries(tmp_path) == [] and (out / "index.json").is_file()
        # generate --overwrite over the complete dataset, SIGTERM
        start_and_kill(cli(*gen, "--out", out, "--overwrite", "--seed", run + 1), tmp_path, signal.SIGTERM, rng)
        assert temporaries(tmp_path) == []
        assert_final_paths_whole(out)
        assert_index_consistent(out)  # never the old seeds' index over new files
        # reconstruct, SIGTERM: the --out folder appears whole or not at all
        rec_out = tmp_path / f"rec{run}"
        start_and_kill(cli("reconstruct", out, "--out", rec_out, "--times", "fps:200"), tmp_path, signal.SIGTERM,
                       rng)
        assert temporaries(tmp_path) == []
        if rec_out.exists():  # renamed into place whole (a signal after the rename may still end the process)
            n_sequences = len(dataset_sequences(out))  # out may lack index.json after the killed --overwrite
            assert len(list(rec_out.rglob("timestamps.txt"))) == n_sequences
            assert_final_paths_whole(rec_out)


def test_full_disk_is_a_clear_error_with_nothing_left(tmp_path):
    """A file-size limit (RLIMIT_FSIZE, EFBIG: how a full disk looks to the writer without one) makes the native
    writer fail mid-file: exit 2 with a message, no traceback-and-segfault, no temporary or partial file."""
    import resource

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    out = tmp_path / "d"
    r = subprocess.run(cli("generate", "ahdr", "--scene", "astronaut_pan", "--out", out, *SMALL), cwd=ROOT,
                       preexec_fn=limit, capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, r.stderr[-2000:]
    assert f"evsim: error: cannot write {out / 'astronaut_pan.h5'}: file too large" in r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr
    assert temporaries(tmp_path) == [] and not out.exists()  # the folder it made is removed: nothing looks begun
