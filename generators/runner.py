"""Running many independent tasks (one per sequence): serially, on a local Dask cluster, or on an existing one.

run_tasks(fn, tasks, workers=N | scheduler=ADDRESS) is the one mechanism behind `evsim generate`, the AHDR suite,
sweeps and `evsim evaluate`: every task is fn(*args, **kwargs), a pure function of its arguments, so where and in
which order it runs does not change its result.
- serial (neither workers nor scheduler): in this process, in order;
- workers=N: a dask.distributed LocalCluster of N worker processes (one task at a time each), started and
  stopped here;
- scheduler=ADDRESS: an existing Dask cluster (e.g. "tcp://host:8786"); its workers need evsim installed and the
  same files (inputs and output folder) at the same paths.
On a cluster, no more tasks are submitted at a time than it has worker threads (results come back in task order
whatever order they finish in). One progress bar counts the finished tasks. A task that raises does not stop the
others: its error comes back in its TaskOutcome (callers raise TasksFailed at the end); a full disk
(formats.atomic.is_disk_full) stops the run, raised by run_tasks. A task whose worker process dies is retried by
Dask on another worker (distributed.scheduler.allowed-failures, default 3), then reported as failed (KilledWorker).
Threads: in each worker, numba and OpenCV get cores // (dask threads on that host) threads (at least 1), so that
N workers do not oversubscribe the cores; BLAS/OpenMP pools of local workers get the same number.
Arguments shared by several tasks (the same object, e.g. one scene for a whole sweep) are sent to the cluster once.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import time
import traceback
import uuid
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from sim import EvsimInputError, OptionError

if TYPE_CHECKING:
    from distributed import LocalCluster

__all__ = ["run_tasks", "TaskOutcome", "TasksFailed", "local_cluster", "usable_cores"]

_THREAD_ENV = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_SIMPLE = (str, bytes, int, float, bool, type(None), os.PathLike)


@dataclass
class TaskOutcome:
    """What one task gave: its value, or its error.

    Attributes
    ----------
    name : str
        The task's name.
    value : object
        What the task returned (None when it failed).
    error : str or None
        Its error, "Type: message"; None when it succeeded (ok).
    traceback : str
        The error's traceback ("" when none).
    kind : str
        Of an error: "input" (sim.EvsimInputError), "lost" (its worker died), "bug" or "disk full".
    stats : dict
        "pid" (the process that ran it), "seconds" (wall clock, s), "rss_mb" and "peak_rss_mb" (resident memory of
        that process after the task, and its peak so far; MB).
    cli_error : str or None
        The error in command-line flags where it names options (sim.OptionError.cli_message), else None.
    """

    name: str
    value: object = None
    error: str | None = None
    traceback: str = ""
    kind: str = ""  # of an error: "input" (sim.EvsimInputError), "lost" (its worker died), "bug" or "disk full"
    stats: dict = field(default_factory=dict)
    cli_error: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


class TasksFailed(RuntimeError):
    """Some tasks failed, the others completed.

    Parameters
    ----------
    what : str
        What the tasks are, for the message (e.g. "sequences").
    failures : list of TaskOutcome
        The failed tasks' outcomes (attribute failures).
    n_tasks : int
        How many were run (attribute n_tasks).
    hint : str, optional
        The remedy, in keywords.
    cli_hint : str, optional
        The remedy in command-line flags: cli_message is the message with it in place of hint.
    """

    def __init__(self, what: str, failures: list[TaskOutcome], n_tasks: int, hint: str = "",
                 cli_hint: str | None = None):
        self.failures, self.n_tasks = failures, n_tasks

        def message(hint: str, cli: bool) -> str:
            lines = [f"{len(failures)} of {n_tasks} {what} failed{': ' + hint if hint else ''}"]
            return "\n".join(lines + [f"  {f.name}: {(cli and f.cli_error) or f.error}" for f in failures])

        super().__init__(message(hint, False))
        self.cli_message = message(hint if cli_hint is None else cli_hint, True)


def raise_failures(what: str, failures: list[TaskOutcome], n_tasks: int, hint: str = "",
                   cli_hint: str | None = None) -> None:
    """Raise for failed tasks: EvsimInputError when every task failed on bad input (nothing was done: the input
    is wrong, as a serial command would say), else TasksFailed (hint, cli_hint: the remedy in keywords and in
    command-line flags). Does nothing without failures."""
    if not failures:
        return
    if len(failures) == n_tasks and all(f.kind == "input" for f in failures):
        messages = {(f.error.split(": ", 1)[-1], (f.cli_error or f.error).split(": ", 1)[-1]) for f in failures}
        if len(messages) == 1:
            api, cli = (m if n_tasks == 1 else f"every one of the {what}: {m}" for m in messages.pop())
            raise EvsimInputError(api) if api == cli else OptionError(api, cli)
    raise TasksFailed(what, failures, n_tasks, hint, cli_hint)


def check_run_options(workers: int | None, scheduler: str | None) -> None:
    """Refuse (EvsimInputError) a bad workers count or workers together with scheduler."""
    if workers is not None and scheduler is not None:
        raise EvsimInputError("choose either workers (a local cluster) or scheduler (an existing one), not both")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise EvsimInputError(f"workers must be a positive number of processes, got {workers!r}")
    if scheduler is not None and not (isinstance(scheduler, str) and scheduler.strip()):
        raise EvsimInputError(f"scheduler must be a Dask scheduler address such as tcp://host:8786, got {scheduler!r}")


def run_tasks(fn: Callable, tasks: Sequence[tuple[str, tuple, dict]], *, workers: int | None = None,
              scheduler: str | None = None, progress: bool | None = True, desc: str = "sequences") -> list[TaskOutcome]:
    """Run fn(*args, **kwargs) for every task, serially or on a Dask cluster.

    Parameters
    ----------
    fn : callable
        The task function (picklable for a cluster).
    tasks : sequence of (str, tuple, dict)
        (name, args, kwargs) of every task.
    workers : int, optional
        Run on a local cluster of this many processes (local_cluster); default: here, serially.
    scheduler : str, optional
        The address of an existing Dask scheduler (e.g. tcp://host:8786) to run on instead.
    progress : bool or None, optional
        True (default) shows the bar, False hides it, None shows it on a terminal only.
    desc : str, optional
        The bar's label (default "sequences").

    Returns
    -------
    list of TaskOutcome
        The outcomes, in task order.
    """
    check_run_options(workers, scheduler)
    tasks = list(tasks)
    if not tasks:
        return []
    from tqdm.auto import tqdm

    with tqdm(total=len(tasks), unit="task", desc=desc, disable=(None if progress is None else not progress),
              leave=True) as bar:

        def done(outcome: TaskOutcome) -> TaskOutcome:
            bar.update(1)
            bar.set_postfix_str(outcome.name, refresh=False)
            if not outcome.ok and len(tasks) > 1:
                bar.write(f"{outcome.name}: failed: {outcome.error}", file=sys.stderr)
            return outcome

        if workers is None and scheduler is None:
            return [done(run_one(name, fn, args, kwargs, None)) for name, args, kwargs in tasks]
        with _client(workers, scheduler) as client:
            return _run_on(client, fn, tasks, done)


def run_one(name: str, fn: Callable, args: tuple, kwargs: dict, threads: int | None) -> TaskOutcome:
    """Run one task where this is called, catching its error.

    Parameters
    ----------
    name : str
        The task's name.
    fn : callable
        The task function.
    args : tuple
        Its positional arguments.
    kwargs : dict
        Its keyword arguments.
    threads : int or None
        In a worker: the numba/OpenCV threads to use; None here.

    Returns
    -------
    TaskOutcome
        Its outcome, with stats.
    """
    if threads is not None:  # in a worker process
        limit_threads(threads)
        _guard_resource_tracker()  # (a worker relaunches the tracker too when it was killed)
    t0 = time.perf_counter()
    try:
        outcome = TaskOutcome(name, value=fn(*args, **kwargs))
    except Exception as e:  # reported with the others at the end; KeyboardInterrupt and SystemExit go through
        from .formats.atomic import is_disk_full

        if is_disk_full(e):  # every later sequence would fail the same way: stop the run
            if threads is None:
                raise
            # in a worker: returned (raising would make Dask log it), raised by run_tasks
            return TaskOutcome(name, value=e, error=f"{type(e).__name__}: {e}", kind="disk full")
        cli = getattr(e, "cli_message", None)
        outcome = TaskOutcome(name, error=f"{type(e).__name__}: {e}", traceback=traceback.format_exc(),
                              kind="input" if isinstance(e, EvsimInputError) else "bug",
                              cli_error=None if cli is None else f"{type(e).__name__}: {cli}")
    outcome.stats = {"pid": os.getpid(), "seconds": time.perf_counter() - t0, "rss_mb": _rss_mb(),
                     "peak_rss_mb": _peak_rss_mb()}
    return outcome


def limit_threads(n: int) -> None:
    """Let numba's parallel kernels and OpenCV use n threads in the calling thread (numba's setting is per thread).

    Parameters
    ----------
    n : int
        Threads (at least 1; numba's at most NUMBA_NUM_THREADS).
    """
    import cv2
    import numba

    numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
    cv2.setNumThreads(int(n))


def usable_cores() -> int:
    """The cores this process may run on.

    Returns
    -------
    int
        Their number (its CPU affinity on Linux, else os.cpu_count()).
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _peak_rss_mb() -> float | None:
    try:
        import resource
    except ImportError:  # Windows
        return None
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux


def _rss_mb() -> float | None:
    """Resident memory of this process now (Linux /proc; None elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError, AttributeError):
        return None


@contextmanager
def local_cluster(workers: int) -> Iterator[LocalCluster]:
    """A dask.distributed LocalCluster of worker processes of one thread each, whose numba/OpenCV/BLAS pools share
    the cores (cores // workers threads each).

    Parameters
    ----------
    workers : int
        Worker processes.

    Yields
    ------
    LocalCluster
        The cluster, closed at the end of the with block.
    """

    import dask
    from distributed import LocalCluster

    _guard_resource_tracker()
    threads = str(max(1, usable_cores() // workers))
    # worker-saturation 1: a worker holds only the task it runs, so a worker that dies costs that task alone
    with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}), \
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                         silence_logs=logging.ERROR, env={k: threads for k in _THREAD_ENV}) as cluster:
        try:
            yield cluster
        except BaseException as e:
            if not isinstance(e, Exception):  # SIGTERM (the CLI's Terminated) or Ctrl-C: the workers go now,
                stop_child_processes(_worker_pids(cluster))  # with the temporaries of the tasks they were running
            raise


def _worker_pids(cluster) -> list[int]:
    """The pids of a LocalCluster's worker processes (started by its nannies)."""
    pids = []
    for nanny in getattr(cluster, "workers", {}).values():
        pid = getattr(getattr(getattr(nanny, "process", None), "process", None), "pid", None)
        if isinstance(pid, int):
            pids.append(pid)
    return pids


_QUIET_TRACKER = "ignore:resource_tracker:UserWarning"  # (its "leaked semaphores" and "relaunching" warnings)


def _guard_resource_tracker() -> None:
    """Keep multiprocessing's resource tracker quiet when it is killed (it is one of this process's children, and
    Dask's worker processes use the semaphores it tracks): the relaunched tracker does not know the semaphores
    registered with the dead one and printed a KeyError traceback for each one unregistered later (the
    semaphores themselves are unlinked all the same). Unregistering is sent only to the tracker that registered
    the name; the "relaunching" warning is not shown. Idempotent."""
    from multiprocessing import resource_tracker as rt

    if getattr(rt.unregister, "_evsim_guard", False):
        return
    tracker = rt._resource_tracker
    before = tracker._pid  # names registered before this guard: with this tracker (or none was running)
    registered_with: dict[tuple[str, str], int | None] = {}
    register, unregister = rt.register, rt.unregister

    def guarded_register(name: str, rtype: str) -> None:
        register(name, rtype)
        registered_with[name, rtype] = tracker._pid

    def guarded_unregister(name: str, rtype: str) -> None:
        pid = registered_with.pop((name, rtype), before)
        tracker.ensure_running()  # (relaunches a dead tracker: its pid changes)
        if pid == tracker._pid:
            unregister(name, rtype)

    guarded_unregister._evsim_guard = True
    rt.register, rt.unregister = guarded_register, guarded_unregister
    warnings.filterwarnings("ignore", message="resource_tracker: process died unexpectedly", category=UserWarning)
    # the same in the processes multiprocessing starts from here on (-W options), trackers included
    if _QUIET_TRACKER not in sys.warnoptions:
        sys.warnoptions.append(_QUIET_TRACKER)


@contextmanager
def _client(workers: int | None, scheduler: str | None):
    try:
        from distributed import Client
    except ImportError:
        raise EvsimInputError("running on workers needs dask.distributed: pip install 'dask[distributed]'") from None
    if workers is not None:
        with local_cluster(workers) as cluster, Client(cluster) as client:
            yield client
        return
    check_scheduler(scheduler)
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, ValueError, TypeError) as e:
        raise EvsimInputError(f"cannot connect to the Dask scheduler {scheduler!r}: {e}") from None
    with client:
        yield client


def check_scheduler(address: str, timeout_s: float = 2.0) -> None:
    """Refuse (EvsimInputError) a tcp:// scheduler address where nothing listens, nothing answers, or something
    that is not a Dask scheduler answers, within 2 * timeout_s seconds (connecting, then its answer): a Dask
    scheduler sends its handshake (a msgpack dict with "compression" and "python") as soon as a connection is
    made; Dask's own client would retry a closed port for its whole timeout and read a foreign service's bytes as
    a frame length ("Unable to allocate 3.07 EiB"). Other protocols (tls://, ucx://, ...) are left to Dask."""
    import socket
    import struct

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, loc = parse_address(address)
        host, port = parse_host_port(loc, 8786)
    except (ValueError, TypeError) as e:
        raise EvsimInputError(f"scheduler {address!r} is not an address such as tcp://host:8786: {e}") from None
    if scheme != "tcp":
        return
    where = f"the Dask scheduler {address!r}"
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as s:
            deadline = time.monotonic() + timeout_s
            head = _recv_exactly(s, 8, deadline)
            (n,) = struct.unpack("<Q", head) if len(head) == 8 else (0,)
            body = _recv_exactly(s, n, deadline) if 16 <= n <= 1 << 16 else b""
    except TimeoutError:
        raise EvsimInputError(f"cannot use {where}: no answer within {timeout_s:g} s (not a Dask scheduler, or "
                              "unreachable)") from None
    except OSError as e:  # refused (nothing listens there), unreachable, unknown host
        raise EvsimInputError(f"cannot connect to {where}: {e.strerror or e}") from None
    if b"compression" not in body or b"python" not in body:
        raise EvsimInputError(f"cannot use {where}: what answers there is not a Dask scheduler (no Dask handshake)")


def _recv_exactly(s, n: int, deadline: float) -> bytes:
    """Up to n bytes from socket s (fewer when the peer closes first); TimeoutError at the deadline."""
    data = b""
    while len(data) < n:
        s.settimeout(max(deadline - time.monotonic(), 1e-3))
        more = s.recv(n - len(data))
        if not more:
            break
        data += more
    return data


def _worker_threads(client) -> int:
    """numba/OpenCV threads per task: the fewest cores per dask thread over the cluster's hosts (at least 1)."""
    workers = client.scheduler_info(n_workers=-1)["workers"]
    cores = client.run(usable_cores)
    per_host: dict[str, list[int]] = {}
    for address, info in workers.items():
        host = per_host.setdefault(info.get("host", address), [0, 0])
        host[0] += int(info.get("nthreads", 1))
        host[1] = max(host[1], int(cores.get(address, 1)))
    return max(1, min((c // t for t, c in per_host.values()), default=1))


def _run_on(client, fn, tasks, done) -> list[TaskOutcome]:
    """Submit the tasks, no more at a time than the cluster has threads (so a worker holds only the task it runs,
    and a worker that dies costs that task alone), and collect them as they finish."""
    from distributed import as_completed

    threads = _worker_threads(client)
    scattered = _scatter_shared(client, tasks)
    run = uuid.uuid4().hex[:8]
    outcomes: list[TaskOutcome | None] = [None] * len(tasks)
    futures = {}

    def submit(i: int) -> None:
        name, args, kwargs = tasks[i]
        args = tuple(scattered.get(id(a), a) for a in args)
        future = client.submit(run_one, name, fn, args, kwargs, threads, key=f"evsim-{run}-{i}-{name}", pure=False)
        futures[future] = i
        running.add(future)

    pending = iter(range(len(tasks)))
    running = as_completed()
    for _ in range(min(len(tasks), max(1, sum(client.nthreads().values())))):
        submit(next(pending))
    for future in running:
        i = futures.pop(future)
        try:
            outcome = future.result()
        except Exception as e:  # the task's worker died (KilledWorker) or the cluster lost it
            outcome = TaskOutcome(tasks[i][0], error=f"{type(e).__name__}: {e}", kind="lost")
        if outcome.kind == "disk full":  # stops the run, as in a serial one
            raise outcome.value
        outcomes[i] = done(outcome)
        future.release()
        while len(futures) < max(1, sum(client.nthreads().values())):  # workers may have joined or left
            nxt = next(pending, None)
            if nxt is None:
                break
            submit(nxt)
    return outcomes


def _scatter_shared(client, tasks) -> dict:
    """{id(obj): future} for the non-trivial positional arguments that several tasks share (sent once)."""
    seen: dict[int, list] = {}
    for _, args, _ in tasks:
        for a in args:
            if not isinstance(a, _SIMPLE):
                seen.setdefault(id(a), [a, 0])[1] += 1
    shared = [obj for obj, n in seen.values() if n > 1]
    futures = client.scatter(shared, hash=False) if shared else []
    return {id(obj): f for obj, f in zip(shared, futures)}


# ----- stopping the worker processes at once (SIGTERM, Ctrl-C) ---------------------------------------------

def _descendants(root: int | None, pids: list[int]) -> list[int]:
    """The descendants of process `root` (if given) and the processes `pids` with theirs (Linux /proc), parents
    first."""
    parent: dict[int, int] = {}
    try:
        names = os.listdir("/proc")
    except OSError:
        return list(pids)
    for name in names:
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat", "rb") as f:
                    stat = f.read()
                parent[int(name)] = int(stat[stat.rindex(b")") + 2 :].split()[1])
            except (OSError, ValueError, IndexError):
                pass
    out = list(pids)
    seen = set(out) | {root}
    frontier = set(seen)
    while frontier:
        children = [p for p, pp in parent.items() if pp in frontier and p not in seen]
        out += children
        seen.update(children)
        frontier = set(children)
    return out


def _open_temporaries(pids: list[int]) -> set[str]:
    """The temporaries (atomic.temp_sibling's `.<name>.<host>-<pid>.<random>.tmp` files and folders) that
    processes `pids` have files open in (Linux /proc): a Dask worker's, which its own cleanup cannot remove
    (its task runs in a thread that no signal reaches)."""
    found = set()
    for pid in pids:
        try:
            fds = os.listdir(f"/proc/{pid}/fd")
        except OSError:
            continue
        for fd in fds:
            try:
                target = os.readlink(f"/proc/{pid}/fd/{fd}")
            except OSError:
                continue
            parts = target.split("/")
            for i, part in enumerate(parts):  # the outermost temporary on the path
                if part.startswith(".") and part.endswith(".tmp") and i > 0:
                    found.add("/".join(parts[: i + 1]))
                    break
    return found


def stop_child_processes(pids: list[int] | None = None) -> None:
    """Stop processes `pids` and their descendants, or (None) every descendant of this process (SIGTERM, then
    SIGKILL after 0.15 s: Dask's worker processes, writer children), and delete the temporaries they had files
    open in. multiprocessing's resource tracker is spared (it cleans up after the others). Linux: elsewhere only
    the pids given are signalled."""
    from .formats.atomic import discard

    tree = _descendants(os.getpid() if pids is None else None, pids or [])
    pids = [p for p in tree if p != _resource_tracker_pid()]
    temporaries = _open_temporaries(pids)
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in pids:
            try:
                os.kill(pid, sig)
            except OSError:
                pass
        deadline = time.monotonic() + 0.15
        while pids and time.monotonic() < deadline:
            pids = [p for p in pids if _running(p)]
            time.sleep(0.01)
        if not pids:
            break
    for p in temporaries:
        try:
            discard(p)
        except OSError:
            pass


def _resource_tracker_pid() -> int | None:
    """The pid of multiprocessing's resource tracker process, if this process has started one."""
    tracker = getattr(sys.modules.get("multiprocessing.resource_tracker"), "_resource_tracker", None)
    return getattr(tracker, "_pid", None)


def _running(pid: int) -> bool:
    try:
        done, _ = os.waitpid(pid, os.WNOHANG)  # reaps a child of ours
        if done:
            return False
    except ChildProcessError:  # a grandchild: gone from /proc (or a zombie) when it has ended
        pass
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
        return stat[stat.rindex(b")") + 2 :][:1] != b"Z"
    except OSError:
        return False
