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
others: its error comes back in its TaskOutcome (callers raise TasksFailed at the end). A task whose worker process
dies is retried by Dask on another worker (distributed.scheduler.allowed-failures, default 3), then reported as
failed (KilledWorker).
Threads: in each worker, numba and OpenCV get cores // (dask threads on that host) threads (at least 1), so that
N workers do not oversubscribe the cores; BLAS/OpenMP pools of local workers get the same number.
Arguments shared by several tasks (the same object, e.g. one scene for a whole sweep) are sent to the cluster once.
"""

from __future__ import annotations

import logging
import os
import sys
import time
import traceback
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from tqdm.auto import tqdm

from sim import EvsimInputError

if TYPE_CHECKING:
    from distributed import LocalCluster

__all__ = ["run_tasks", "TaskOutcome", "TasksFailed", "local_cluster", "usable_cores"]

_THREAD_ENV = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_SIMPLE = (str, bytes, int, float, bool, type(None), os.PathLike)


@dataclass
class TaskOutcome:
    """What one task gave: its value, or its error ("Type: message") and traceback. stats: pid (the process that
    ran it), seconds (wall clock), rss_mb and peak_rss_mb (resident memory of that process after the task, and its
    peak so far; MB)."""

    name: str
    value: object = None
    error: str | None = None
    traceback: str = ""
    kind: str = ""  # of an error: "input" (sim.EvsimInputError), "lost" (its worker died) or "bug"
    stats: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.error is None


class TasksFailed(RuntimeError):
    """Some tasks failed, the others completed. failures: their TaskOutcomes; n_tasks: how many were run."""

    def __init__(self, what: str, failures: list[TaskOutcome], n_tasks: int, hint: str = ""):
        self.failures, self.n_tasks = failures, n_tasks
        lines = [f"{len(failures)} of {n_tasks} {what} failed{': ' + hint if hint else ''}"]
        lines += [f"  {f.name}: {f.error}" for f in failures]
        super().__init__("\n".join(lines))


def raise_failures(what: str, failures: list[TaskOutcome], n_tasks: int, hint: str = "") -> None:
    """Raise for failed tasks: EvsimInputError when every task failed on bad input (nothing was done: the input
    is wrong, as a serial command would say), else TasksFailed. Does nothing without failures."""
    if not failures:
        return
    if len(failures) == n_tasks and all(f.kind == "input" for f in failures):
        messages = {f.error.split(": ", 1)[-1] for f in failures}
        if len(messages) == 1:
            raise EvsimInputError(messages.pop() if n_tasks == 1 else f"every one of the {what}: {messages.pop()}")
    raise TasksFailed(what, failures, n_tasks, hint)


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
    """Run fn(*args, **kwargs) for every (name, args, kwargs) of tasks; return their TaskOutcomes in task order.

    progress: True shows the bar, False hides it, None shows it on a terminal only.
    """
    check_run_options(workers, scheduler)
    tasks = list(tasks)
    if not tasks:
        return []
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
    """Run one task where this is called (in a worker: with `threads` numba/OpenCV threads), catching its error."""
    if threads is not None:
        limit_threads(threads)
    t0 = time.perf_counter()
    try:
        outcome = TaskOutcome(name, value=fn(*args, **kwargs))
    except Exception as e:  # reported with the others at the end; KeyboardInterrupt and SystemExit go through
        from .formats.atomic import is_disk_full

        if is_disk_full(e):  # every later sequence would fail the same way: stop the run
            raise
        outcome = TaskOutcome(name, error=f"{type(e).__name__}: {e}", traceback=traceback.format_exc(),
                              kind="input" if isinstance(e, EvsimInputError) else "bug")
    outcome.stats = {"pid": os.getpid(), "seconds": time.perf_counter() - t0, "rss_mb": _rss_mb(),
                     "peak_rss_mb": _peak_rss_mb()}
    return outcome


def limit_threads(n: int) -> None:
    """Let numba's parallel kernels and OpenCV use n threads in the calling thread (numba's setting is per thread)."""
    import cv2
    import numba

    numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
    cv2.setNumThreads(int(n))


def usable_cores() -> int:
    """The cores this process may run on."""
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
    """A dask.distributed LocalCluster of `workers` processes of one thread each, whose numba/OpenCV/BLAS pools
    share the cores (cores // workers threads each); yields the cluster."""

    import dask
    from distributed import LocalCluster

    threads = str(max(1, usable_cores() // workers))
    # worker-saturation 1: a worker holds only the task it runs, so a worker that dies costs that task alone
    with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}), \
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                         silence_logs=logging.ERROR, env={k: threads for k in _THREAD_ENV}) as cluster:
        yield cluster


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
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, ValueError, TypeError) as e:
        raise EvsimInputError(f"cannot connect to the Dask scheduler {scheduler!r}: {e}") from None
    with client:
        yield client


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
