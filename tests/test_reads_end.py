"""Reads that always end, and SIGTERM within a second.

A native file whose global heap (where HDF5 keeps variable-length strings: the format, metadata and crf
attributes) is zeroed made HDF5 spin forever inside H5Aread, holding the GIL: load() and `evsim info` never
returned and ignored SIGTERM. generators.formats.common.probe_h5 reads the structure in a forked child first.
"""

from __future__ import annotations

import faulthandler
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from generators.formats import DatasetFormatError, common, load

ROOT = Path(__file__).resolve().parents[1]


def zeroed_global_heap(src: Path, dst: Path) -> Path:
    """A copy of src with zeros over its global heap collection's objects (its signature and size kept: 4 KiB of
    zeros written at the collection's start + 16)."""
    data = bytearray(src.read_bytes())
    at = data.find(b"GCOL")
    assert at > 0, "no global heap collection (no variable-length attribute?)"
    size = int.from_bytes(data[at + 8 : at + 16], "little")  # the collection's size, header included
    data[at + 16 : at + size] = bytes(size - 16)
    dst.write_bytes(bytes(data))
    return dst


@pytest.fixture(scope="module")
def native(tmp_path_factory) -> Path:
    from evsim_app.cli import main

    out = tmp_path_factory.mktemp("native")
    assert main(["generate", "ahdr", "--scene", "checkerboard", "--duration-s", "0.2", "--height", "16", "--width",
                 "20", "--no-progress", "--out", str(out / "d")]) == 0
    return out / "d" / "checkerboard.h5"


def test_a_zeroed_global_heap_is_refused_within_the_stall_bound(native, tmp_path, monkeypatch):
    monkeypatch.setattr(common, "PROBE_STALL_S", 1.0)
    bad = zeroed_global_heap(native, tmp_path / "bad.h5")
    t0 = time.monotonic()
    with pytest.raises(DatasetFormatError, match="corrupt HDF5 metadata: reading the file's structure made no "
                                                 "progress for 1 s"):
        load(bad)
    assert time.monotonic() - t0 < 5
    assert load(native).events.size > 0  # the intact file still loads (probed once, then remembered)


def test_the_probe_reports_a_crash_of_the_hdf5_library(native, monkeypatch):
    """What the child dies of (a segfault inside HDF5 on some corrupt files) is a DatasetFormatError here."""
    def crash(path, tick):
        faulthandler.disable()  # (pytest's: no stack dump from the child)
        os.kill(os.getpid(), signal.SIGSEGV)

    monkeypatch.setattr(common, "_walk_h5", crash)
    common._PROBED.clear()
    with pytest.raises(DatasetFormatError, match=r"the HDF5 library crashed reading the file's structure \(signal "
                                                 f"{int(signal.SIGSEGV)}\\)"):
        load(native)


def test_probe_results_are_remembered_per_file_version(native, tmp_path, monkeypatch):
    walks = []
    real = common._walk_h5
    monkeypatch.setattr(common, "_walk_h5", lambda path, tick: (walks.append(path), real(path, tick)))
    copy = tmp_path / "c.h5"
    copy.write_bytes(native.read_bytes())
    load(copy)
    load(copy)
    assert len(walks) == 0  # (walked in the child: this process's list stays empty) ...
    key = (copy.stat().st_dev, copy.stat().st_ino, copy.stat().st_size, copy.stat().st_mtime_ns)
    assert key in common._PROBED  # ... and remembered
    os.utime(copy, ns=(0, 0))  # a changed file is probed again
    key2 = (copy.stat().st_dev, copy.stat().st_ino, copy.stat().st_size, copy.stat().st_mtime_ns)
    assert key2 not in common._PROBED
    load(copy)
    assert key2 in common._PROBED


# ----- SIGTERM --------------------------------------------------------------------------------------------

def children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            return [int(c) for c in f.read().split()]
    except OSError:
        return []


@pytest.mark.slow
def test_evsim_info_on_the_corrupt_file_exits_2_and_ends_within_a_second_of_sigterm(native, tmp_path):
    bad = zeroed_global_heap(native, tmp_path / "bad.h5")
    r = subprocess.run([sys.executable, "-m", "evsim_app", "info", str(bad)], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.startswith(f"evsim: error: {bad}: corrupt HDF5 metadata"), r.stderr
    assert "Traceback" not in r.stderr
    proc = subprocess.Popen([sys.executable, "-m", "evsim_app", "info", str(bad)], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not children(proc.pid) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)  # until the probe (HDF5 spinning in a child) runs
    assert proc.poll() is None
    time.sleep(0.3)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143 and time.monotonic() - t0 < 1.0, (proc.returncode, time.monotonic() - t0, err)
    assert err.strip() == "evsim: terminated (SIGTERM); temporary files removed"


STUCK_IN_C = """
import ctypes, signal, sys
from evsim_app import cli, info_command
from generators.formats.atomic import temp_sibling

def stuck(args):  # the main thread inside one long C call that releases the GIL (as HDF5 and numba kernels do)
    tmp = temp_sibling(__import__("pathlib").Path(sys.argv[1]))
    print(tmp, flush=True)
    signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGTERM])  # (so the signal cannot end the call early)
    ctypes.CDLL(None).sleep(30)
    return 0

info_command.run = stuck
sys.exit(cli.main(["info", "x"]))
"""


@pytest.mark.slow
def test_sigterm_ends_the_cli_within_a_second_while_the_main_thread_is_inside_a_c_call(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", STUCK_IN_C, str(tmp_path / "out.h5")], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    tmp = Path(proc.stdout.readline().strip())
    assert tmp.exists()
    time.sleep(0.3)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143 and time.monotonic() - t0 < 1.0, (proc.returncode, time.monotonic() - t0, err)
    assert err.strip() == "evsim: terminated (SIGTERM); temporary files removed"
    assert not tmp.exists()
