"""Executors: where trials run. This process, local worker processes, or a Ray cluster.

An executor maps a picklable function over items and yields `(item, result)` pairs as they finish, in any
order. If the process running an item dies (killed, out of memory, a crash in native code, a lost node), the
item is run again on a fresh worker; after `attempts` deaths it is yielded with a `WorkerLost` instead of a
result, which the runner logs as a `failed` trial. An exception raised by the function itself is not a
death: it is raised in the driver (the runner's `TrialWorker` turns its own exceptions into failed rows).

Stopping: when the consumer stops (an exception, KeyboardInterrupt, SIGTERM turned into an exception by the
CLI, or closing the generator), the executor stops its workers before the exception leaves it: local worker
processes are terminated and joined; Ray tasks are cancelled (their worker processes killed) and the executor
disconnects from Ray, which stops a local Ray instance it started. Local workers ignore SIGINT (a Ctrl-C
reaches the whole process group; the driver alone decides) and die with the driver even if it is killed
outright (Linux parent-death signal).

- `SerialExecutor`: this process; no isolation, so a death is the driver's death.
- `ProcessExecutor(workers)`: local spawned processes, one item at a time each, so a death is attributed to
  exactly the item its worker was running; each keeps its temporary files in a folder the driver removes
  once the process is gone, so a killed worker leaves none behind.
- `RayExecutor(address=None)`: Ray tasks (local Ray by default, an existing cluster with an address); Ray
  reruns a task whose worker died (`max_retries`); results return through Ray's object store to the driver.
  Ray is an optional dependency (`pip install 'entangle-bench[cluster]'`).
"""

from __future__ import annotations

import collections
import contextlib
import ctypes
import importlib.util
import multiprocessing
import multiprocessing.connection
import os
import shutil
import signal
import sys
import tempfile
import threading
import traceback
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

from entangle_bench.errors import ParameterError

T = TypeVar("T")
R = TypeVar("R")

#: Attempts per item: the first run and one retry after a worker death.
ATTEMPTS = 2
EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class WorkerLost:
    """An item whose worker died on every attempt: why, in words."""

    reason: str


class Executor(Protocol):
    """Runs a function over items, yielding (item, result or WorkerLost) as they finish (any order)."""

    def map_unordered(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[T, R | WorkerLost]]:
        """Yield (item, fn(item)) for every item; (item, WorkerLost) if its worker died on every attempt."""
        ...


class SerialExecutor:
    """Runs everything in this process, in order (debugging, tests, one worker)."""

    def map_unordered(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[T, R | WorkerLost]]:
        """Yield (item, fn(item)) in order."""
        for item in items:
            yield item, fn(item)


class WorkerError(RuntimeError):
    """The function raised in a worker process; the message holds the worker's traceback."""


def _die_with_parent(parent: int) -> None:
    """Ask Linux to SIGKILL this process when its parent exits; exit now if the parent is already gone."""
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:
        os._exit(1)


def _worker_main(conn: multiprocessing.connection.Connection, fn: Callable[[Any], Any], parent: int,
                 scratch: str) -> None:
    """A worker process: run fn on each (index, item) received, send (index, ok, result) back; None stops.
    Its temporary files go under `scratch`, which the driver removes once the process is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's; one pending since start-up is dropped
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    _die_with_parent(parent)
    tempfile.tempdir = os.environ["TMPDIR"] = scratch
    while True:
        try:
            message = conn.recv()
        except EOFError:  # the driver is gone
            return
        if message is None:
            return
        index, item = message
        try:
            reply = (index, True, fn(item))
        except Exception:
            reply = (index, False, traceback.format_exc())
        conn.send(reply)


@contextlib.contextmanager
def _sigint_held() -> Iterator[None]:
    """Block SIGINT in this thread while the block runs (main thread only; elsewhere a no-op).

    A process started inside inherits the blocked mask through exec, so a Ctrl-C while it starts up stays pending
    there until the worker ignores SIGINT; the driver gets a Ctrl-C that arrived meanwhile when the block ends,
    instead of losing it.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _death_reason(exitcode: int | None) -> str:
    """Words for a worker process's exit code."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exited with code {exitcode}"


class _Worker:
    """One local worker process and its end of the pipe; `job` is the (index, item) it is running."""

    def __init__(self, context: Any, fn: Callable[[Any], Any]):
        self.conn, child = context.Pipe()
        # The process's temporary folder, removed with the process: a killed worker leaves no files behind.
        self.scratch = tempfile.mkdtemp(prefix="entangle-bench-worker-")
        self.process = context.Process(target=_worker_main, args=(child, fn, os.getpid(), self.scratch), daemon=True)
        with _sigint_held():  # inherited through exec: a Ctrl-C while the worker starts up is the driver's
            self.process.start()
        child.close()
        self.job: tuple[int, Any] | None = None

    def send(self, job: tuple[int, Any]) -> None:
        """Give the worker a job; a worker that has died is noticed by the executor's wait."""
        self.job = job
        try:
            self.conn.send(job)
        except OSError:  # BrokenPipeError: the process is gone; its sentinel says so
            pass

    def stop(self) -> None:
        """Terminate the process (SIGTERM, then SIGKILL), reap it and remove its temporary folder."""
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(5.0)
            if self.process.is_alive():
                self.process.kill()
        self.process.join()
        self.conn.close()
        shutil.rmtree(self.scratch, ignore_errors=True)


class ProcessExecutor:
    """Local worker processes (spawned; one MuJoCo simulation per core), each running one item at a time."""

    def __init__(self, workers: int, attempts: int = ATTEMPTS):
        if workers < 1:
            raise ParameterError(f"workers = {workers} must be at least 1")
        self.workers, self.attempts = workers, attempts

    def map_unordered(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[T, R | WorkerLost]]:
        """Yield (item, result) as workers finish; a worker that dies is replaced and its item retried."""
        context = multiprocessing.get_context("spawn")
        items = list(items)
        pending = collections.deque(range(len(items)))
        deaths: collections.Counter[int] = collections.Counter()
        pool: list[_Worker] = []
        try:
            while pending or any(w.job is not None for w in pool):
                while pending and len(pool) < self.workers:
                    pool.append(_Worker(context, fn))
                for worker in pool:
                    if worker.job is None and pending:
                        index = pending.popleft()
                        worker.send((index, items[index]))
                busy = [w for w in pool if w.job is not None]
                waitables = [w.conn for w in busy] + [w.process.sentinel for w in busy]
                ready = set(multiprocessing.connection.wait(waitables))
                for worker in busy:
                    index = worker.job[0]
                    reply = None
                    if worker.conn in ready:
                        try:
                            reply = worker.conn.recv()
                        except (EOFError, OSError):
                            reply = None
                    elif worker.process.sentinel not in ready:
                        continue
                    if reply is None:  # the process died while running the item
                        worker.process.join()
                        reason = _death_reason(worker.process.exitcode)
                        worker.stop()
                        pool.remove(worker)
                        deaths[index] += 1
                        if deaths[index] < self.attempts:
                            pending.appendleft(index)
                        else:
                            yield items[index], WorkerLost(f"worker process died ({reason}) on each of "
                                                           f"{self.attempts} attempts")
                        continue
                    worker.job = None
                    _, ok, result = reply
                    if not ok:
                        raise WorkerError(f"item {index} raised in a worker process:\n{result}")
                    yield items[index], result
        finally:
            for worker in pool:
                worker.stop()


class RayExecutor:
    """Ray tasks: an existing cluster at `address` ('auto', 'HOST:PORT', 'ray://...'), else at RAY_ADDRESS, else
    a new local Ray instance with `num_cpus` CPUs.

    At most `window` tasks are in flight at once (default: twice the cluster's CPUs), so a sweep of 10^5 trials
    neither floods the scheduler nor holds all results. Each task needs one CPU. Results travel back through
    Ray's object store; workers write nothing into the output folder. If Ray was not initialized, the executor
    starts it (`ray.init(address)`) and shuts it down when done or interrupted.
    """

    def __init__(self, address: str | None = None, attempts: int = ATTEMPTS, window: int | None = None,
                 num_cpus: int | None = None):
        self.address, self.attempts, self.window, self.num_cpus = address, attempts, window, num_cpus

    def _init(self) -> bool:
        """Connect to (or start) Ray unless it is up; return whether this call started it."""
        import ray

        if ray.is_initialized():
            return False
        handler = signal.getsignal(signal.SIGTERM)
        # No address: RAY_ADDRESS if set, else a new local instance ("local"; plain ray.init() would join any
        # Ray it finds on this machine, even a stale one).
        address = self.address or os.environ.get("RAY_ADDRESS") or "local"
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": True}
        if address == "local":
            kwargs["num_cpus"] = self.num_cpus
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            where = "a new local Ray instance" if address == "local" else f"the Ray cluster at {address}"
            hint = ""
            if address not in ("local", "auto") and "RAY_AUTH_MODE" not in os.environ:
                hint = ("; clusters started with `ray start` use token authentication, which Ray enables for "
                        "an explicit address only with RAY_AUTH_MODE=token and the cluster's token (RAY_AUTH_TOKEN "
                        "or ~/.ray/auth_token); on a node of the cluster, --address auto finds both")
            raise ParameterError(f"cannot start or reach {where}: {exc}{hint}") from None
        finally:
            if handler is not None:  # ray.init replaces the driver's SIGTERM handler with sys.exit
                signal.signal(signal.SIGTERM, handler)
        return True

    def map_unordered(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[T, R | WorkerLost]]:
        """Yield (item, result) as Ray tasks finish; Ray reruns a task whose worker died (attempts - 1 times)."""
        import ray
        from ray import exceptions as rex

        items = list(items)
        if not items:
            return
        started = self._init()
        refs: dict[Any, int] = {}
        try:
            remote = ray.remote(num_cpus=1, max_retries=self.attempts - 1, retry_exceptions=False)(_call)
            fn_ref = ray.put(fn)
            window = self.window or max(2, 2 * int(ray.cluster_resources().get("CPU", 1)))
            queue = collections.deque(range(len(items)))
            while queue or refs:
                while queue and len(refs) < window:
                    index = queue.popleft()
                    refs[remote.remote(fn_ref, items[index])] = index
                (ref,), _ = ray.wait(list(refs), num_returns=1)
                index = refs.pop(ref)
                try:
                    result = ray.get(ref)
                except rex.RayTaskError as exc:  # the function raised: not a death
                    raise WorkerError(f"item {index} raised in a Ray task:\n{exc}") from None
                except rex.RayError as exc:  # the worker or its node died on every attempt
                    first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
                    yield items[index], WorkerLost(f"Ray worker died on each of {self.attempts} attempts "
                                                   f"({type(exc).__name__}: {first})")
                    continue
                yield items[index], result
        finally:
            if started:  # our own local instance: shutting it down kills its workers
                ray.shutdown()
            else:  # a shared cluster: stop our tasks only (cancelling while Ray also tears down can abort Ray 2.60)
                for ref in refs:
                    ray.cancel(ref, force=True)


def _call(fn: Callable[[T], R], item: T) -> R:
    """Run fn(item) in a Ray worker."""
    return fn(item)


def make_executor(workers: int, kind: str = "local", address: str | None = None) -> Executor:
    """The executor for `kind` (EXECUTORS).

    local: this process for one worker, else `workers` processes. ray: the cluster at `address`, or a new local
    Ray instance with `workers` CPUs.
    """
    if kind not in EXECUTORS:
        raise ParameterError(f"executor {kind!r} is not one of {list(EXECUTORS)}")
    if workers < 1:
        raise ParameterError(f"workers = {workers} must be at least 1")
    if kind == "ray":
        if importlib.util.find_spec("ray") is None:
            raise ParameterError("--executor ray needs Ray, an optional dependency: "
                                 "pip install 'entangle-bench[cluster]'")
        return RayExecutor(address, num_cpus=None if address else workers)
    if address is not None:
        raise ParameterError("--address is for --executor ray")
    return SerialExecutor() if workers == 1 else ProcessExecutor(workers)
