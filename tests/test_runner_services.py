"""What --scheduler and --workers meet besides a healthy Dask cluster (generators.runner): a closed port, a TCP
service that is not Dask (one that answers garbage, one that answers nothing), and a killed child process of a
local cluster's run (multiprocessing's resource tracker).

All servers here listen on the loopback interface only and live for the test.
"""

from __future__ import annotations

import glob
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

from generators.runner import check_scheduler, run_tasks  # noqa: E402
from sim import EvsimInputError  # noqa: E402

pytestmark = pytest.mark.slow  # local TCP services, a Dask cluster and subprocesses: left out of the fast loop

ROOT = Path(__file__).resolve().parents[1]


def _square(x: int) -> int:
    return x * x


class Server:
    """A loopback TCP server that sends `payload` to every connection, then holds it open for `hold` seconds."""

    def __init__(self, payload: bytes, hold: float = 10.0):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.payload, self.hold, self.stop = payload, hold, threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        while not self.stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            with conn:
                if self.payload:
                    conn.sendall(self.payload)
                self.stop.wait(self.hold)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=5)
        self.sock.close()


@pytest.fixture
def closed_port() -> str:
    s = socket.create_server(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return f"tcp://127.0.0.1:{port}"


@pytest.mark.parametrize("payload, said", [
    (b"SSH-2.0-OpenSSH_9.2p1\r\n", "not a Dask scheduler"),  # read by Dask as a frame of 3.07 EiB
    (b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n", "not a Dask scheduler"),
    (b"\x10\x00\x00\x00\x00\x00\x00\x00" + bytes(16), "not a Dask scheduler"),  # a plausible length, no handshake
    (b"", "no answer within 2 s"),
], ids=["ssh", "http", "framed-garbage", "silent"])
def test_a_foreign_service_is_refused_within_five_seconds(payload, said):
    server = Server(payload)
    try:
        t0 = time.monotonic()
        with pytest.raises(EvsimInputError, match=f"cannot use the Dask scheduler '{server.address}': .*{said}"):
            run_tasks(_square, [("a", (2,), {})], scheduler=server.address, progress=False)
        assert time.monotonic() - t0 < 5
    finally:
        server.close()


def test_a_closed_port_is_refused_at_once(closed_port):
    t0 = time.monotonic()
    with pytest.raises(EvsimInputError, match=f"cannot connect to the Dask scheduler '{closed_port}': Connection "
                                              "refused"):
        run_tasks(_square, [("a", (2,), {})], scheduler=closed_port, progress=False)
    assert time.monotonic() - t0 < 5


def test_a_dask_scheduler_passes_the_check_and_runs_the_tasks():
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                  dashboard_address=":0") as cluster:
        check_scheduler(cluster.scheduler_address)
        outcomes = run_tasks(_square, [("a", (3,), {}), ("b", (4,), {})], scheduler=cluster.scheduler_address,
                             progress=False)
    assert [o.value for o in outcomes] == [9, 16]


def test_an_address_that_is_not_one_is_refused():
    with pytest.raises(EvsimInputError, match="tcp://host:8786"):
        check_scheduler("tcp://127.0.0.1:notaport")


def _child_running(parent: int, needle: str) -> int | None:
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                stat = f.read()
            with open(f"/proc/{name}/cmdline", "rb") as f:
                cmd = f.read().decode(errors="replace")
        except OSError:
            continue
        if int(stat[stat.rindex(b")") + 2 :].split()[1]) == parent and needle in cmd:
            return int(name)
    return None


def test_a_killed_resource_tracker_leaves_no_tracebacks(tmp_path):
    """Killing one of a --workers run's child processes, multiprocessing's resource tracker, mid-run: the run
    completes (exit 0) and nothing but its own output is printed (its relaunched successor printed a KeyError
    traceback for every semaphore unregistered later)."""
    out = tmp_path / "d"
    proc = subprocess.Popen([sys.executable, "-m", "evsim_app", "generate", "ahdr", "--duration-s", "0.2", "--height",
                             "24", "--width", "32", "--no-progress", "--workers", "2", "--out", str(out)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and proc.poll() is None and time.monotonic() < deadline:
        if glob.glob(str(out / ".*.tmp")):  # the workers are writing
            killed = _child_running(proc.pid, "resource_tracker")
            if killed:
                os.kill(killed, signal.SIGKILL)
        time.sleep(0.01)
    stdout, stderr = proc.communicate(timeout=600)
    assert killed, "the run ended before its resource tracker could be killed"
    assert proc.returncode == 0, stderr[-3000:]
    assert stderr == "", stderr[-3000:]
    assert "wrote 7 sequence(s)" in stdout and (out / "index.json").is_file()  # (the built-in set)
