"""Where a campaign's tasks run: this process, a pool of local processes,
or a Dask distributed cluster.

Every engine maps one function over ``(index, task)`` pairs and yields
``(index, row, cpu_s, wall_s)`` as tasks finish, in whatever order they
finish; ``cpu_s`` is the task's own CPU time in the thread that ran it and
``wall_s`` its time from start to end there (more than ``cpu_s`` when the
machine's cores are shared), the figures ``bench campaign`` subtracts from
the engine's time to find its overhead.

Faults: a local worker process that dies breaks its whole pool
(``BrokenProcessPool``: every unfinished future fails at once), so the
pool engine keeps what finished, starts a new pool and resubmits only the
indices it has no row for. Dask's scheduler already re-runs a task whose
worker was lost. The runner keys rows by index, so a task run twice is
still one row.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
import uuid
from typing import Callable, Iterable, Iterator, Optional

#: A pool that breaks this many times in a row without finishing a single
#: task is not going to: a task that kills its worker every time.
MAX_BARREN_RESTARTS = 3

#: Thread pools of the numeric libraries, capped to one in every worker:
#: parallelism comes from the tasks, and a reduction split over threads
#: could round differently from one split to the next.
SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                     "NUMBA_NUM_THREADS": "1"}


class EngineError(RuntimeError):
    """An engine that cannot start or cannot go on; one line for the user."""


def single_thread(threads: int = 1) -> int:
    """numba's thread pool to ``threads`` in this process (the environment
    reaches only processes started after it is set); the count it had."""
    try:
        import numba

        before = numba.get_num_threads()
        if before != threads:
            numba.set_num_threads(threads)
        return before
    except (ImportError, ValueError):  # pragma: no cover - numba is a dependency
        return threads


def call(fn: Callable, index: int, task) -> tuple:
    """Run one task where the engine put it: ``(index, fn(task), cpu_s, wall_s)``.

    The task runs on one thread; the thread count is given back after it
    (this process may be the caller's, whose batches use every core)."""
    before = single_thread()
    try:
        start = time.thread_time()
        wall = time.perf_counter()
        row = fn(task)
        return index, row, time.thread_time() - start, time.perf_counter() - wall
    finally:
        single_thread(before)


def _worker_start() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    single_thread()


@contextlib.contextmanager
def _environment(values: dict) -> Iterator[None]:
    """``values`` in the environment for the processes started in the block."""
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Worker processes started in the block ignore Ctrl-C.

    Ctrl-C reaches the whole process group: the command stops its workers
    itself, and each must not print its own traceback meanwhile. A process
    that starts with SIGINT ignored keeps it ignored (Python installs its
    KeyboardInterrupt handler only over the default), including the
    workers a Dask nanny starts again later."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class Engine:
    """What every engine offers the runner."""

    name = "engine"
    workers = 1

    def start(self) -> None:
        """Bring the workers up (a pool, a cluster connection)."""

    def map_unordered(self, fn: Callable, items: Iterable[tuple[int, object]]) -> Iterator[tuple]:
        raise NotImplementedError

    def close(self) -> None:
        """Stop what ``start`` started; safe to call twice."""

    def describe(self) -> str:
        return self.name

    running = False

    def __enter__(self) -> "Engine":
        self.start()
        self.running = True
        return self

    def __exit__(self, *exc) -> None:
        self.running = False
        self.close()

    @contextlib.contextmanager
    def session(self) -> Iterator["Engine"]:
        """Started for the block unless already running (a bench that runs
        several campaigns on one engine keeps it up between them)."""
        if self.running:
            yield self
            return
        with self:
            yield self


class InProcess(Engine):
    """One worker: this process, one task after another."""

    name = "local"
    workers = 1

    def map_unordered(self, fn, items):
        for index, task in items:
            yield call(fn, index, task)

    def describe(self) -> str:
        return "1 local process"


class ProcessPool(Engine):
    """``workers`` local processes (spawned: numba's threads make a forked
    child unsafe), each single-threaded."""

    name = "local"

    def __init__(self, workers: int, notice: Callable[[str], None] = lambda line: None) -> None:
        if workers < 2:
            raise ValueError("workers must be at least 2 for a pool, got %r" % workers)
        self.workers = workers
        self.notice = notice
        self.restarts = 0
        self._pool = None

    def describe(self) -> str:
        return "%d local processes" % self.workers

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # the children inherit the environment as it is when they start:
        # numpy's BLAS reads its thread count only at import
        with _environment(SINGLE_THREAD_ENV), _sigint_ignored():
            pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                       initializer=_worker_start)
            # start every worker now, while the environment is set
            started = [pool.submit(os.getpid) for _ in range(self.workers)]
        for f in started:
            f.result()
        return pool

    def start(self) -> None:
        if self._pool is None:
            self._pool = self._new_pool()

    def pids(self) -> list[int]:
        """The worker processes' ids (tests kill one)."""
        return sorted(self._pool._processes) if self._pool is not None else []

    def map_unordered(self, fn, items):
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        pending = dict(items)
        barren = 0
        while pending:
            self.start()
            futures = {self._pool.submit(call, fn, i, t): i for i, t in pending.items()}
            finished_any = False
            broken = False
            waiting = set(futures)
            while waiting and not broken:
                done, waiting = wait(waiting, return_when=FIRST_COMPLETED)
                for f in done:
                    try:
                        out = f.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    pending.pop(out[0], None)
                    finished_any = True
                    yield out
            if not broken:
                continue
            # what finished before the break still counts; the rest is redone
            for f in waiting:
                if f.done() and not f.cancelled() and f.exception() is None:
                    out = f.result()
                    if out[0] in pending:
                        pending.pop(out[0])
                        finished_any = True
                        yield out
            self._kill()
            self.restarts += 1
            barren = 0 if finished_any else barren + 1
            if barren >= MAX_BARREN_RESTARTS:
                raise EngineError("local worker processes died %d times in a row without finishing a task "
                                  "(%d tasks left)" % (barren, len(pending)))
            self.notice("a worker process died: %d unfinished task(s) resubmitted to a new pool of %d"
                        % (len(pending), self.workers))

    def _kill(self) -> None:
        pool, self._pool = self._pool, None
        if pool is None:
            return
        # ProcessPoolExecutor lets running tasks finish on shutdown (3.14
        # adds terminate_workers); an interrupted campaign must stop now
        for p in list(getattr(pool, "_processes", {}).values()):
            try:
                p.terminate()
            except (OSError, AttributeError):
                pass
        pool.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        self._kill()


def _dask():
    try:
        import distributed
    except ImportError as exc:
        raise EngineError("--cluster needs Dask: pip install 'dask[distributed]' (%s)" % exc)
    return distributed


class DaskCluster(Engine):
    """A Dask distributed scheduler: ``tcp://HOST:PORT`` of a running one
    (``dask scheduler``, ``dask worker``), or ``local:N``, a LocalCluster of
    N single-threaded worker processes started here (its dashboard link is
    told through ``notice``)."""

    name = "dask"

    def __init__(self, address: str, notice: Callable[[str], None] = lambda line: None,
                 connect_timeout_s: float = 10.0) -> None:
        self.address = address
        self.notice = notice
        self.timeout = connect_timeout_s
        self.local = address.startswith("local:")
        self.workers = int(address[len("local:"):]) if self.local else 0
        self.client = None
        self.cluster = None
        self.dashboard = None

    def describe(self) -> str:
        if self.local:
            return "Dask LocalCluster of %d workers" % self.workers
        return "Dask scheduler %s (%d workers)" % (self.address, self.workers)

    def start(self) -> None:
        if self.client is not None:
            return
        distributed = _dask()
        import logging

        # the scheduler's and workers' own info lines would bury ours
        for name in ("distributed", "distributed.scheduler", "distributed.nanny", "distributed.worker",
                     "distributed.core", "distributed.http.proxy"):
            logging.getLogger(name).setLevel(logging.ERROR)
        if self.local:
            try:
                # its workers' own log lines too: a Ctrl-C cancels their tasks, which they would report
                with _sigint_ignored(), _environment({"DASK_LOGGING__DISTRIBUTED": "error"}):
                    self.cluster = distributed.LocalCluster(n_workers=self.workers, threads_per_worker=1,
                                                            processes=True, host="127.0.0.1",
                                                            dashboard_address="127.0.0.1:0")
            except Exception as exc:  # noqa: BLE001 - whatever stops it, one line
                raise EngineError("could not start a Dask LocalCluster of %d workers: %s" % (self.workers, exc))
            self.client = distributed.Client(self.cluster)
            self.dashboard = self.client.dashboard_link
            self.notice("Dask LocalCluster of %d workers, dashboard %s%s" % (
                self.workers, self.dashboard, "" if _has_bokeh() else " (its pages need bokeh: pip install bokeh)"))
        else:
            try:
                self.client = distributed.Client(self.address, timeout=self.timeout)
            except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, CommClosedError...
                raise EngineError("no Dask scheduler answers at %s: %s" % (self.address, str(exc).splitlines()[0]
                                                                           if str(exc) else type(exc).__name__))
            self.workers = len(self.client.scheduler_info().get("workers", {}))
            if self.workers == 0:
                self.notice("the Dask scheduler at %s has no workers yet: tasks wait for one" % self.address)
        self.restarts = 0

    def map_unordered(self, fn, items):
        distributed = _dask()
        tag = uuid.uuid4().hex[:8]
        futures = [self.client.submit(call, fn, i, t, key="roboray-%s-%d" % (tag, i), pure=False)
                   for i, t in items]
        try:
            for f in distributed.as_completed(futures):
                try:
                    yield f.result()
                except distributed.KilledWorker as exc:
                    raise EngineError("Dask gave a task up after its workers died repeatedly: %s" % exc)
                finally:
                    f.release()
        finally:
            for f in futures:
                f.cancel()

    def close(self) -> None:
        client, self.client = self.client, None
        cluster, self.cluster = self.cluster, None
        if client is not None:
            try:
                client.close()
            except Exception:  # noqa: BLE001 - a scheduler already gone
                pass
        if cluster is not None:
            try:
                cluster.close()
            except Exception:  # noqa: BLE001
                pass


def _has_bokeh() -> bool:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return False
    return True


def make_engine(workers: Optional[int] = None, cluster: Optional[str] = None,
                notice: Callable[[str], None] = lambda line: None) -> Engine:
    """The engine of ``--workers``/``--cluster``: a cluster when one is
    given, else ``workers`` local processes (this process alone for one;
    default: one per CPU)."""
    if cluster is not None:
        if workers is not None:
            raise ValueError("--workers counts local processes; a --cluster brings its own workers")
        parse_cluster(cluster)
        return DaskCluster(cluster, notice=notice)
    n = workers if workers is not None else (os.cpu_count() or 1)
    return InProcess() if n <= 1 else ProcessPool(n, notice=notice)


def parse_cluster(text: str) -> str:
    """``tcp://HOST:PORT`` or ``local:N``; ValueError naming the problem."""
    if text.startswith("local:"):
        n = text[len("local:"):]
        if not n.isdigit() or int(n) < 1:
            raise ValueError("--cluster %r: local:N needs a whole number of workers, at least 1" % text)
        return text
    if text.startswith("tcp://"):
        host, _, port = text[len("tcp://"):].rpartition(":")
        if host and port.isdigit() and 0 < int(port) < 65536:
            return text
    raise ValueError("--cluster %r: give tcp://HOST:PORT (a running dask scheduler) or local:N" % text)


def stderr_notice(prog: str = "roboray-sim") -> Callable[[str], None]:
    """A notice as one line on stderr (above a progress bar, if one is up)."""

    def notice(line: str) -> None:
        try:
            from tqdm import tqdm

            tqdm.write("%s: %s" % (prog, line), file=sys.stderr)
        except ImportError:  # pragma: no cover - tqdm is a dependency
            sys.stderr.write("%s: %s\n" % (prog, line))

    return notice
