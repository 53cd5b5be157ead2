"""The one executor of the harness: a function over a list of tasks, in worker processes.

:func:`run_tasks` runs a function over tasks on local worker processes (``concurrent.futures.ProcessPoolExecutor``,
spawned, one BLAS thread each, dying with this process; :class:`LocalPool` keeps them for several rounds) or on a
Dask distributed cluster (``scheduler`` = its address, checked within :data:`SCHEDULER_TIMEOUT_S`), and hands every
finished result to a callback in this process, which commits it.  A task whose worker process dies is isolated
and becomes a record made by ``crashed``; workers that cannot start, or a task that raises in a local worker, are
a failure of the run.  It knows nothing of campaigns, scenes or files: the campaign runner
(:mod:`compare.runner`), the atlas, the design check's workers and the figures use it.
"""

from __future__ import annotations

import asyncio
import concurrent.futures as cf
import multiprocessing
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

from compare.stopping import POLL_S, raise_if_stopped

T = TypeVar("T")
R = TypeVar("R")


class WorkerStartError(RuntimeError):
    """The local worker processes could not start: nothing was computed (a failure of the run)."""


class WorkerError(RuntimeError):
    """A local worker failed outside the solvers (a failure of the run, not a property of a scene)."""


WORKER_START_HINT = ("if a Python script calls run_campaign (or run_scenes, run_tasks, run_atlas), call it under "
                     "`if __name__ == \"__main__\":` (every worker process imports the script)")


_STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


@contextmanager
def _start_children_quietly() -> Iterator[None]:
    """Start child processes with SIGINT blocked: a Ctrl-C at the terminal (sent to the whole process
    group) then cannot kill a child half-way through its interpreter start-up with a traceback; the
    children ignore SIGINT once started (:func:`worker_init`), and this process gets a Ctrl-C that
    arrived meanwhile as soon as the children exist."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextmanager
def _signals_ignored() -> Iterator[None]:
    """Ignore SIGINT/SIGTERM/SIGHUP inside (in the main thread): a second Ctrl-C cannot interrupt the
    cleanup that the first one started."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, signal.SIG_IGN) for s in _STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def kill_pool(pool: cf.ProcessPoolExecutor) -> None:
    """Stop a process pool now, whatever its workers are doing: kill them, then shut it down (prompt,
    as nothing is left to wait for).  Signals are ignored meanwhile."""
    with _signals_ignored():
        for proc in list((getattr(pool, "_processes", None) or {}).values()):
            try:
                proc.kill()
            except (OSError, ValueError, AttributeError):
                pass
        pool.shutdown(wait=True, cancel_futures=True)


def worker_init() -> None:
    """In every local worker process (campaign and figure pools): die with the parent (no orphans
    after kill -9 of ``ked run`` or ``ked plot``), and leave SIGINT/SIGTERM handling to the parent."""
    import multiprocessing

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # blocked at birth: see _start_children_quietly
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    parent_process = multiprocessing.parent_process()
    parent = parent_process.pid if parent_process is not None else os.getppid()
    if os.getppid() != parent:  # the parent died while this worker was starting
        os._exit(1)

    def watch() -> None:  # portable fallback: the parent is gone when we are re-parented
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


_worker_init = worker_init  # the name older pickles and callers use


def exit_if_starting_worker() -> None:
    """In a spawned worker that is importing a script which starts a run without a main guard: end it
    quietly now (it cannot start; the parent reports it once, with the fix, :data:`WORKER_START_HINT`).
    Called first by every entry point that starts workers."""
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        os._exit(3)


def _ready() -> int:
    """A no-op task: the worker started (its interpreter, the main module and the initializer)."""
    return os.getpid()


def default_workers() -> int:
    """Worker processes used when none are given, and the most any local pool starts: the CPUs available to
    this process (the tasks are CPU-bound: more processes than CPUs only share them)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


# One BLAS/OpenMP thread per worker process: the parallelism is across scenes (as on Dask workers,
# whose nannies set the same variables); nested threads would oversubscribe the cores.
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextmanager
def _single_threaded_children() -> Iterator[None]:
    """Set the thread-count variables (unless the user set them) for processes spawned inside."""
    added = [v for v in _THREAD_VARS if v not in os.environ]
    for v in added:
        os.environ[v] = "1"
    try:
        yield
    finally:
        for v in added:
            os.environ.pop(v, None)


SCHEDULER_TIMEOUT_S = 10.0
"""How long ``--scheduler ADDRESS`` waits for the scheduler to answer."""


WORKER_WAIT_S = float(os.environ.get("KED_WORKER_WAIT_S", "120"))
"""How long a run on a Dask cluster waits without any worker (none joined yet, or every one left) before it
stops, saying so [s]; the environment variable ``KED_WORKER_WAIT_S`` sets it."""
CLUSTER_POLL_S = 1.0
"""How often a run on a Dask cluster looks at the cluster while it waits for results [s]."""


class SchedulerError(ValueError):
    """The Dask scheduler address is malformed or nothing answers there."""


def probe_scheduler(address: str, timeout_s: float = SCHEDULER_TIMEOUT_S) -> None:
    """Check that ``address`` is a TCP scheduler address something listens on, before any Dask client
    exists (a client that cannot connect lingers and times out again at exit)."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    hint = "give the address printed by `dask scheduler`, e.g. tcp://127.0.0.1:8786"
    try:
        scheme, loc = parse_address(address if "://" in address else f"tcp://{address}")
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as exc:
        raise SchedulerError(f"--scheduler {address!r}: not a scheduler address ({exc}); {hint}") from None
    if scheme not in ("tcp", "tls"):
        return  # other transports (inproc, ucx): left to the client
    try:
        socket.create_connection((host, int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise SchedulerError(f"--scheduler {address!r}: no scheduler answers there within {timeout_s:g} s "
                             f"({exc.strerror or exc}); {hint}") from None
    full = address if "://" in address else f"tcp://{address}"
    try:
        identity = asyncio.run(asyncio.wait_for(_identity(full, timeout_s), timeout_s))
    except (OSError, asyncio.TimeoutError, EOFError, ValueError, TypeError) as exc:
        what = "no answer" if isinstance(exc, asyncio.TimeoutError) else type(exc).__name__
        raise SchedulerError(f"--scheduler {address!r}: something listens there but is not a Dask scheduler "
                             f"({what} to the Dask handshake within {timeout_s:g} s); {hint}") from None
    if not isinstance(identity, dict) or identity.get("type") != "Scheduler":
        raise SchedulerError(f"--scheduler {address!r}: the service there is not a Dask scheduler; {hint}")


async def _identity(address: str, timeout_s: float) -> Any:
    """The peer's answer to Dask's ``identity`` request (the Dask handshake first): a scheduler says
    ``{"type": "Scheduler", ...}``.  Every step is bounded by the caller's timeout, whatever the peer
    is (an HTTP server answers garbage, a silent socket never answers)."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout_s)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


class _LocalBackend:
    """Process pool on this machine (spawned workers, one BLAS thread each, dying with this process)."""

    def __init__(self, workers: int):
        ctx = multiprocessing.get_context("spawn")
        self.pool = cf.ProcessPoolExecutor(max_workers=min(workers, default_workers()), mp_context=ctx,
                                           initializer=worker_init)
        self.futures: list[Any] = []
        try:
            with _single_threaded_children(), _start_children_quietly():  # workers are spawned on submit
                probe = self.pool.submit(_ready)
            probe.result()  # a worker that cannot start breaks the pool before any task is given out
        except cf.process.BrokenProcessPool:
            self.abort()
            raise WorkerStartError(f"the worker processes could not start (each exited before taking any "
                                   f"work), so nothing was computed; {WORKER_START_HINT}") from None
        except BaseException:
            self.abort()
            raise

    def submit_all(self, fn: Callable[..., Any], calls: dict[Any, tuple[Any, ...]]) -> dict[Any, Any]:
        """Submit ``fn(*args)`` for every task -> args of ``calls``; returns future -> task."""
        with _single_threaded_children(), _start_children_quietly():
            out = {self.pool.submit(fn, *a): t for t, a in calls.items()}
        self.futures += list(out)
        return out

    def cancel(self) -> None:
        """Cancel the tasks not started yet (running ones finish and are still delivered)."""
        for f in self.futures:
            f.cancel()

    def batches(self, futures: Iterable[Any]) -> Iterator[list[Any]]:
        """Completed futures, grouped: everything finished by the time the previous group is handled."""
        pending = set(futures)
        while pending:
            done, pending = cf.wait(pending, timeout=POLL_S, return_when=cf.FIRST_COMPLETED)
            raise_if_stopped()
            if done:
                yield list(done)

    def result(self, fut: Any) -> Any:
        """The task's result; :data:`_LOST` if the pool broke (a worker died: the task is not attributable)."""
        try:
            return fut.result()
        except cf.process.BrokenProcessPool:
            return _LOST
        except cf.CancelledError:
            raise
        except Exception as exc:  # the task functions keep their own failures in their results
            raise WorkerError(f"a worker process failed outside the solvers ({type(exc).__name__}: "
                              f"{str(exc).strip()[:300]})") from exc

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

    def abort(self) -> None:
        """Stop at once (interrupt, failure): kill the workers; what they were computing is lost."""
        kill_pool(self.pool)


class _DaskBackend:
    """Dask distributed cluster at ``address`` (scheduler address, e.g. ``tcp://host:8786``)."""

    def __init__(self, address: str, timeout_s: float = SCHEDULER_TIMEOUT_S):
        from distributed import Client

        probe_scheduler(address, timeout_s)
        try:
            self.client = Client(address, set_as_default=False, timeout=timeout_s)
        except (OSError, TimeoutError, ValueError) as exc:
            raise SchedulerError(f"--scheduler {address!r}: the Dask scheduler did not answer within {timeout_s:g} s "
                                 f"({type(exc).__name__})") from None
        self.address = address
        self.futures: list[Any] = []
        self._no_workers_since: float | None = None
        self.check_workers()

    def check_workers(self) -> None:
        """Raise :class:`SchedulerError` once the cluster has had no worker for :data:`WORKER_WAIT_S`."""
        if self.client.scheduler_info().get("workers"):
            self._no_workers_since = None
            return
        now = time.monotonic()
        if self._no_workers_since is None:
            self._no_workers_since = now
        if now - self._no_workers_since >= WORKER_WAIT_S:  # the caller stops the run (cancels, closes)
            raise SchedulerError(f"--scheduler {self.address!r}: no Dask worker on this cluster for "
                                 f"{WORKER_WAIT_S:g} s (waiting for one to take the tasks); start one with "
                                 f"`dask worker {self.address}`")

    def submit_all(self, fn: Callable[..., Any], calls: dict[Any, tuple[Any, ...]]) -> dict[Any, Any]:
        # unique task keys: never reuse a result another run left on a long-lived cluster
        name = getattr(fn, "__name__", "task")
        out = {self.client.submit(fn, *a, key=f"ked-{name}-{uuid.uuid4().hex}", pure=False): t
               for t, a in calls.items()}
        self.futures += list(out)
        return out

    def cancel(self) -> None:
        self.client.cancel([f for f in self.futures if not f.done()])

    def batches(self, futures: Iterable[Any]) -> Iterator[list[Any]]:
        """Finished futures as they come, looking at the cluster every :data:`CLUSTER_POLL_S` while none does: a
        cluster without workers ends the run (:meth:`check_workers`) instead of a wait without end."""
        from distributed import as_completed

        ready = as_completed(list(futures), loop=self.client.loop)
        looked = time.monotonic()
        while not ready.is_empty():
            if ready.has_ready():
                yield ready.next_batch(block=False)
            elif time.monotonic() - looked >= CLUSTER_POLL_S:
                self.check_workers()
                looked = time.monotonic()
            else:
                time.sleep(0.02)

    def result(self, fut: Any) -> Any:
        return fut.result()

    def close(self) -> None:
        self.client.close()

    def abort(self) -> None:
        self.cancel()
        self.close()


_LOST = object()
"""A local task's result when its worker process died (the pool broke): rerun it, see :func:`run_tasks`."""


def crash_reason(exc: BaseException | None) -> str:
    """Why a task gave no result: its worker process died (``exc`` None), or the task failed on the
    cluster outside the task function (a Dask ``KilledWorker``, ...)."""
    return "the worker process died while computing it" if exc is None else f"{type(exc).__name__}: {exc}"


def _drain(backend: Any, futures: dict[Any, Any], deliver: Callable[[list[tuple[Any, Any]]], None],
           crashed: Callable[[Any, BaseException | None], Any]) -> list[Any]:
    """Deliver results as they complete; returns the tasks lost to a broken local pool."""
    lost: list[Any] = []
    for done in backend.batches(futures):
        raise_if_stopped()  # a stop whose KeyboardInterrupt was lost (see compare.stopping)
        batch = []
        for fut in done:
            if fut.cancelled():
                continue  # cancelled after the caller asked to stop: never started, nothing computed
            task = futures[fut]
            try:
                r = backend.result(fut)
            except WorkerError:
                raise
            except Exception as exc:  # the task failed outside its function on the cluster (KilledWorker, ...)
                r = crashed(task, exc)
            if r is _LOST:
                lost.append(task)
            else:
                batch.append((task, r))
        if batch:
            deliver(batch)
    return lost


def _isolate(fn: Callable[..., Any], calls: dict[Any, tuple[Any, ...]],
             deliver: Callable[[list[tuple[Any, Any]]], None],
             crashed: Callable[[Any, BaseException | None], Any]) -> None:
    """After a worker process died twice (a crash inside a task breaks the whole pool, so the culprit is
    unknown): run each task alone in a fresh single-worker pool; one that kills its worker again is
    delivered as ``crashed(task, None)``."""
    for task, a in calls.items():
        iso = _LocalBackend(1)
        try:
            (fut,) = iso.submit_all(fn, {task: a})
            r = iso.result(fut)
        except BaseException:
            iso.abort()
            raise
        iso.close()
        deliver([(task, crashed(task, None) if r is _LOST else r)])


def _one(task: Any) -> tuple[Any, ...]:
    return (task,)


class LocalPool:
    """Local worker processes kept for several :func:`run_tasks` calls (``pool=``): started at the first
    call that uses them (their start-up, an interpreter and the harness's imports each, is what a short run
    pays; measured ~0.8 s for 2 workers on this project's 2-core machine), stopped when the ``with`` block
    ends (killed if it ends by an exception).  A pool that broke (a worker died) or whose run was
    interrupted is dropped; the next call starts a fresh one."""

    def __init__(self, workers: int):
        if workers < 1:
            raise ValueError(f"workers: at least 1; got {workers}")
        self.workers = workers
        self._backend: _LocalBackend | None = None

    @property
    def started(self) -> bool:
        """True while worker processes are running."""
        return self._backend is not None

    def backend(self) -> _LocalBackend:
        """The running workers (started now if none are, or if a worker died since the last call)."""
        if self._backend is not None and getattr(self._backend.pool, "_broken", False):
            self.drop()
        if self._backend is None:
            self._backend = _LocalBackend(self.workers)
        return self._backend

    def backend_if_started(self) -> _LocalBackend | None:
        """The running workers, or None (nothing is started)."""
        return self._backend

    def drop(self, abort: bool = False) -> None:
        """Stop the workers (``abort``: kill them now); the next :meth:`backend` starts new ones."""
        backend, self._backend = self._backend, None
        if backend is not None and abort:
            backend.abort()
        elif backend is not None:
            backend.close()

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        self.drop(abort=kind is not None)


def run_tasks(tasks: Sequence[T], fn: Callable[..., R], *, workers: int | None = None, scheduler: str | None = None,
              on_result: Callable[[list[tuple[T, R]]], bool | None],
              crashed: Callable[[T, BaseException | None], R], args: Callable[[T], tuple[Any, ...]] = _one,
              on_ready: Callable[[], None] | None = None, pool: LocalPool | None = None) -> int:
    """Compute ``fn(*args(task))`` for every task (default ``fn(task)``) and hand the results to
    ``on_result`` in this process as they finish: a list of (task, result), everything finished since
    the previous call (the commit callback).  ``on_result`` returning True stops the run: the tasks not
    started are cancelled; running ones finish and are still delivered.

    Where: ``scheduler`` (a Dask scheduler address, probed within :data:`SCHEDULER_TIMEOUT_S`, else
    :class:`SchedulerError`), else ``workers`` local processes (default: the available CPUs; at most one
    per task).  Local workers are spawned and import the caller's main module: a script must run this
    under ``if __name__ == "__main__":``, otherwise :class:`WorkerStartError` is raised before any task.
    ``on_ready`` runs once the workers are there, before any task is given out (write nothing before).
    ``pool``: local workers kept between calls (:class:`LocalPool`; ``workers`` is then its size).

    Crash isolation: a local worker that dies (a segfault inside a task) breaks the pool; its tasks run
    again in a fresh pool, then one by one, and a task that kills its worker alone is delivered as
    ``crashed(task, None)``; on a cluster a task lost outside ``fn`` is delivered as ``crashed(task,
    exception)``.  A task that raises in a local worker is a failure of the run (:class:`WorkerError`):
    task functions keep their own failures in their results.  On an interrupt or any failure the workers
    are stopped at once (what was delivered stays delivered).  Returns the number of tasks that gave no
    result (cancelled after a stop)."""
    exit_if_starting_worker()
    if not tasks:
        return 0
    calls = {i: args(t) for i, t in enumerate(tasks)}  # by index: tasks need not be hashable
    stopped: list[bool] = []

    def local(n: int) -> _LocalBackend:
        return _LocalBackend(min(workers or default_workers(), n))

    def crash(i: int, exc: BaseException | None) -> R:
        return crashed(tasks[i], exc)

    kept = pool is not None and not scheduler  # the workers outlive this call
    backend: Any = _DaskBackend(scheduler) if scheduler else pool.backend() if kept else local(len(calls))

    def deliver(batch: list[tuple[int, Any]]) -> None:
        if on_result([(tasks[i], r) for i, r in batch]) and not stopped:
            stopped.append(True)
            if backend is not None:
                backend.cancel()

    try:
        if on_ready is not None:
            on_ready()
        lost = _drain(backend, backend.submit_all(fn, calls), deliver, crash)
        if not kept:
            backend.close()
        elif lost or stopped:  # broken, or with cancelled tasks of this call: not kept
            pool.drop()
        else:
            backend.futures.clear()
        backend = None
        if lost and not stopped:  # a worker died: rerun its pool's tasks in a fresh pool, then one by one
            backend = local(len(lost))
            lost = _drain(backend, backend.submit_all(fn, {i: calls[i] for i in lost}), deliver, crash)
            backend.close()
            backend = None
            if lost and not stopped:
                _isolate(fn, {i: calls[i] for i in lost}, deliver, crash)
                lost = []
    except BaseException:  # interrupt, failure: stop the workers now (what is delivered stays)
        if kept and backend is pool.backend_if_started():
            pool.drop(abort=True)
        elif backend is not None:
            backend.abort()
        raise
    return len(lost)
