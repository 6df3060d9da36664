"""Full disks: every writer and export, on a real full file system (a tmpfs of 1 MiB, where this machine lets the
tests mount one: root) and under a file size limit (RLIMIT_FSIZE, which always runs), raises DiskFullError naming
the output's final path, leaves no file (temporary or partial) behind, and does not crash the process (HDF5 2.0
segfaulted, dv-processing aborted); the CLI exits 2 with one line blaming the output, no traceback.

Each case runs in a subprocess (a crash there is a failed test, not a dead test run).
"""

from __future__ import annotations

import errno
import json
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from generators.choices import EXPORT_FORMATS
from generators.dataset import EXPORT_SUFFIX

pytestmark = pytest.mark.slow  # subprocesses and mounts

ROOT = Path(__file__).resolve().parents[1]
FREE = 8192  # bytes left on the full file system (every output here is larger)
LIMIT = 2048  # RLIMIT_FSIZE, bytes per file (every output here has a larger file: an EXR frame is about 3 kB)
EXPORTS = [f for f in EXPORT_FORMATS if f != "native"] + ["exr"]
CRASH_SIGNS = ("Traceback", "Exception ignored", "terminate called", "Segmentation fault", "Fatal Python error")

WRITE_ALL = """
import json, sys, warnings
from pathlib import Path
from generators.formats import export, load
from generators.formats.atomic import DiskFullError
from generators.formats.native import write_native
warnings.simplefilter("ignore")
src, out, names = Path(sys.argv[1]), Path(sys.argv[2]), json.loads(sys.argv[3])
results = {}
def attempt(key, target, write):
    try:
        write()
        results[key] = ["written"]
    except DiskFullError as e:
        results[key] = ["DiskFullError", e.errno, e.filename, str(e)]
    except BaseException as e:
        results[key] = ["other", type(e).__name__, str(e)[-300:]]
rec = load(src)
attempt("native writer", out / "w.h5", lambda: write_native(rec, out / "w.h5"))
for fmt, name in names.items():
    attempt(fmt, out / name, lambda: export(src, out / name, fmt))
print(json.dumps(results))
"""


def out_name(fmt: str) -> str:
    return "x_exr" if fmt == "exr" else f"x{EXPORT_SUFFIX[fmt]}"


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> Path:
    """A native file of about 150 kB (every export of it is larger than FREE)."""
    from evsim_app.cli import main

    out = tmp_path_factory.mktemp("src")
    assert main(["generate", "ahdr", "--scene", "astronaut_pan", "--duration-s", "0.3", "--height", "24", "--width",
                 "32", "--labels", "--no-progress", "--out", str(out / "d")]) == 0
    return out / "d" / "astronaut_pan.h5"


@pytest.fixture
def full_tmpfs(tmp_path):
    """A mounted 1 MiB tmpfs, filled up to FREE bytes; skipped where mounting is not allowed."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mnt)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({r.stderr.strip()}); test_*_file_size_limit covers full disks")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def fill(mnt: Path, leave: int) -> Path:
    """Fill the file system of mnt with one file, leaving `leave` bytes (to a page) free."""
    filler = mnt / "filler"
    with open(filler, "wb") as f:
        try:
            while True:
                f.write(bytes(1 << 16))
                f.flush()
        except OSError as e:
            assert e.errno == errno.ENOSPC
    with open(filler, "r+b") as f:  # (the failed write's buffer is dropped with the file object)
        f.truncate(max(0, filler.stat().st_size - leave))
    return filler


def limit_file_size():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, LIMIT))


def write_everything(source: Path, out: Path, preexec_fn=None) -> dict:
    names = {fmt: out_name(fmt) for fmt in EXPORTS}
    r = subprocess.run([sys.executable, "-c", WRITE_ALL, str(source), str(out), json.dumps(names)], cwd=ROOT,
                       capture_output=True, text=True, timeout=600, preexec_fn=preexec_fn)
    assert r.returncode == 0, r.stderr[-3000:]
    assert not any(s in r.stderr for s in CRASH_SIGNS), r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def assert_each_blames_its_output(results: dict, out: Path, code: int) -> None:
    assert set(results) == {"native writer", *EXPORTS}
    for key, result in results.items():
        name = "w.h5" if key == "native writer" else out_name(key)
        assert result[0] == "DiskFullError", (key, result)
        assert result[1] == code and result[2] == str(out / name), (key, result)
        assert result[3].startswith(f"cannot write {out / name}: ") and "nothing was written" in result[3]


def test_every_writer_on_a_full_tmpfs_raises_disk_full_naming_the_output(source, full_tmpfs):
    filler = fill(full_tmpfs, FREE)
    out = full_tmpfs / "out"
    out.mkdir()
    results = write_everything(source, out)
    assert_each_blames_its_output(results, out, errno.ENOSPC)
    assert sorted(p.name for p in full_tmpfs.rglob("*")) == ["filler", "out"]  # no temporary, no partial file
    filler.unlink()  # and the space is free again: nothing unlinked-but-open was kept
    assert (full_tmpfs / "probe").write_bytes(bytes(900_000)) == 900_000


def test_every_writer_under_a_file_size_limit_raises_disk_full_naming_the_output(source, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    results = write_everything(source, out, preexec_fn=limit_file_size)
    assert_each_blames_its_output(results, out, errno.EFBIG)
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("fmt", ["e2vid", "aedat4"])
def test_cli_export_to_a_full_disk_exits_2_blaming_the_export(source, full_tmpfs, fmt):
    """The native file fits, its export does not (e2vid segfaulted, aedat4 aborted and left a hidden folder, the
    others blamed the input as "truncated or corrupt")."""
    fill(full_tmpfs, source.stat().st_size + 32768)
    out = full_tmpfs / "d"
    r = subprocess.run([sys.executable, "-m", "evsim_app", "generate", "ahdr", "--scene", "astronaut_pan",
                        "--duration-s", "0.3", "--height", "24", "--width", "32", "--labels", "--no-progress",
                        "--format", fmt, "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=600)
    export = out / f"astronaut_pan{EXPORT_SUFFIX[fmt]}"
    assert r.returncode == 2, r.stderr[-3000:]
    assert r.stderr.strip() == (f"evsim: error: cannot write {export}: disk full (no space left on device) "
                                "(nothing was written in its place)")
    assert sorted(p.name for p in out.iterdir()) == ["astronaut_pan.h5"]  # whole; no export, no temporary
