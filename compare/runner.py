"""Run a campaign: plan (skip stored scenes), execute in parallel, commit each result atomically.

Backends: a local ``concurrent.futures.ProcessPoolExecutor`` (default) or a Dask distributed cluster
(``scheduler`` = its address).  Both execute :func:`compare.execute.run_scene`; only this (parent)
process writes the results file, after every completion (all results finished by then are committed
together in one atomic file replacement, see :mod:`compare.store`).  A SIGKILL therefore loses only
the scenes still being computed.
"""

from __future__ import annotations

import asyncio
import concurrent.futures as cf
import multiprocessing
import os
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare import solvers, store
from compare.config import CampaignConfig
from compare.execute import run_scene
from compare.results import STATUS_FAILED, STATUS_OK, RunStats, SceneResult
from compare.scenes import SceneSpec, canonical_json
from compare.solvers import Solution


@dataclass(frozen=True)
class Job:
    """A scene to compute, with the stored solutions it keeps (solver name -> solution)."""

    spec: SceneSpec
    reuse: dict[str, Solution]


@dataclass(frozen=True)
class Plan:
    """Scenes of a campaign split into those to compute and those already stored (by key)."""

    jobs: tuple[Job, ...]
    skipped: tuple[SceneSpec, ...]

    @property
    def todo(self) -> tuple[SceneSpec, ...]:
        return tuple(j.spec for j in self.jobs)


@dataclass(frozen=True)
class CampaignSummary:
    """Outcome of one :func:`run_campaign` call.  ``wall_s`` [s] of the whole call."""

    out: Path
    total: int
    skipped: int
    ok: int
    failed: int
    lost: int
    wall_s: float
    keys: tuple[str, ...]


def plan(scenes: Iterable[SceneSpec], stored: dict[str, str], retry_failed: bool = False,
         solutions: dict[str, dict[str, Solution]] | None = None) -> Plan:
    """Pure: which scenes still need computing given ``stored`` (key -> status) and the stored
    ``solutions`` (key -> solver -> solution).  A stored scene is computed again when ``retry_failed``
    and it failed (its successful solutions are kept), or when it lacks a requested solver (all its
    stored solutions are kept); otherwise it is skipped."""
    solutions = solutions or {}
    jobs, skipped = [], []
    for s in scenes:
        status, have = stored.get(s.key), solutions.get(s.key, {})
        mine = {n: sol for n, sol in have.items() if n in s.solvers}
        if status is None:
            jobs.append(Job(s, {}))
        elif retry_failed and status != STATUS_OK:
            jobs.append(Job(s, {n: sol for n, sol in mine.items() if sol.ok}))
        elif have and any(n not in have for n in s.solvers):
            jobs.append(Job(s, mine))
        else:
            skipped.append(s)
    return Plan(tuple(jobs), tuple(skipped))


class SettingsMismatchError(ValueError):
    """Stored scenes were computed with other resolved Exudyn settings than the current ones."""


def resolved_settings(spec: SceneSpec, solver: str) -> dict[str, Any]:
    """The settings the current code would use for ``solver`` on ``spec`` (as stored: JSON values)."""
    import json

    from compare.execute import settings_of

    sv = solvers.get(solver)
    return json.loads(canonical_json(sv.settings_dict(settings_of(sv, spec))))


def settings_diff(old: dict[str, Any], new: dict[str, Any], legacy: dict[str, Any]) -> dict[str, tuple[Any, Any]]:
    """Fields whose stored value differs from the current one; a field the stored settings lack (it
    was added later) counts as its ``legacy`` value, the one that reproduces the older behaviour."""
    old = {**{k: v for k, v in legacy.items() if k in new}, **old}
    return {k: (old.get(k), new.get(k)) for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)}


def check_stored_settings(specs: Iterable[SceneSpec], stored: dict[str, dict[str, Solution]]) -> None:
    """Refuse to resume onto stored solutions computed with other resolved settings than the current
    code would use.  A scene's content key hashes only the settings given explicitly, so a solution
    computed under older defaults would otherwise be silently reused."""
    problems = []
    for spec in specs:
        for name, sol in stored.get(spec.key, {}).items():
            if name not in spec.solvers or not sol.settings:
                continue
            diff = settings_diff(sol.settings, resolved_settings(spec, name), solvers.get(name).legacy_defaults())
            if diff:
                fields = ", ".join(f"{k}: stored {a!r} -> now {b!r}" for k, (a, b) in diff.items())
                problems.append(f"{spec.label} [{spec.key}] {name}: {fields}")
    if problems:
        shown = "\n  ".join(problems[:5]) + (f"\n  ... and {len(problems) - 5} more" if len(problems) > 5 else "")
        raise SettingsMismatchError(
            f"{len(problems)} stored solution(s) were computed with other settings than the current "
            f"defaults would give; resuming would mix them:\n  {shown}\n"
            "Write to a new --out file, or pin these settings in the config (e.g. its [dynamic] table).")


def _rescued(exc: store.CommitError, unsaved: list[SceneResult], out: Path, config: CampaignConfig) -> Exception:
    """The error to raise after a failed commit, once the scenes computed in this run are saved."""
    if not unsaved:
        return exc
    try:
        path = store.rescue(unsaved, out, config.text, config.name)
    except store.CommitError as exc2:
        return store.CommitError(f"{exc}; {exc2}")
    return store.CommitError(
        f"{exc}. The {len(unsaved)} scene(s) computed in this run are kept in {path}; once {out} can be written "
        f"again, `ked merge {path} {out}` adds them, and rerunning the campaign resumes the rest.")


class WorkerStartError(RuntimeError):
    """The local worker processes could not start: nothing was computed (a failure of the run)."""


class WorkerError(RuntimeError):
    """A local worker failed outside the solvers (a failure of the run, not a property of a scene)."""


WORKER_START_HINT = ("if a Python script calls run_campaign, call it under `if __name__ == \"__main__\":` "
                     "(every worker process imports the script)")


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


def _ready() -> int:
    """A no-op task: the worker started (its interpreter, the main module and the initializer)."""
    return os.getpid()


def default_workers() -> int:
    """Worker processes used when none are given: the CPUs available to this process."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _worker_crashed(spec: SceneSpec, exc: BaseException | None) -> SceneResult:
    if exc is None:
        error_type, message = "WorkerCrashed", "the worker process died while computing this scene"
    else:
        error_type, message = type(exc).__name__, f"worker failed while computing the scene: {exc}"
    return SceneResult(spec=spec, status=STATUS_FAILED, stage="worker", error_type=error_type,
                       message=message[:2000], failure_class="numerical", stats=RunStats(finished_utc=store.utc_now()))


def _drain(backend: Any, futures: dict[Any, Job],
           store_batch: Callable[[list[SceneResult]], None]) -> list[Job]:
    """Store results as they complete; returns the jobs lost to a broken local pool."""
    lost: list[Job] = []
    for done in backend.batches(futures):
        batch = []
        for fut in done:
            if fut.cancelled():
                continue  # cancelled after a failed commit: never started, nothing computed
            try:
                r = backend.result(fut)
            except WorkerError:
                raise
            except Exception as exc:  # the task itself failed outside run_scene (Dask KilledWorker, ...)
                r = _worker_crashed(futures[fut].spec, exc)
            if r is None:
                lost.append(futures[fut])
            else:
                batch.append(r)
        if batch:
            store_batch(batch)
    return lost


def _isolate(jobs: list[Job], store_batch: Callable[[list[SceneResult]], None]) -> list[Job]:
    """After a worker process died (a crash inside a solver breaks the whole pool, so the culprit is
    unknown): rerun each scene in a fresh single-worker pool; one that kills its worker again is
    stored as failed (stage "worker", WorkerCrashed).  Returns the scenes still lost (none)."""
    for job in jobs:
        iso = _LocalBackend(1)
        try:
            (fut,) = iso.submit_all([job])
            r = iso.result(fut)
        except BaseException:
            iso.abort()
            raise
        else:
            iso.close()
        store_batch([r if r is not None else _worker_crashed(job.spec, None)])
    return []


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


def _args(job: Job) -> tuple[SceneSpec, tuple[solvers.Solver, ...], dict[str, Solution]]:
    """Arguments of :func:`compare.execute.run_scene` for a job (solvers travel by reference)."""
    return job.spec, tuple(solvers.get(n) for n in job.spec.solvers), job.reuse


class _LocalBackend:
    """Process pool on this machine (spawned workers, one BLAS thread each)."""

    def __init__(self, workers: int):
        ctx = multiprocessing.get_context("spawn")
        self.workers = workers
        self.pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=worker_init)
        self.futures: list[Any] = []
        try:
            with _single_threaded_children(), _start_children_quietly():  # workers are spawned on submit
                probe = self.pool.submit(_ready)
            probe.result()  # a worker that cannot start breaks the pool before any scene is given out
        except cf.process.BrokenProcessPool:
            self.abort()
            raise WorkerStartError(f"the worker processes could not start (each exited before taking any "
                                   f"work), so nothing was computed; {WORKER_START_HINT}") from None
        except BaseException:
            self.abort()
            raise

    def submit_all(self, jobs: Iterable[Job]) -> dict[Any, Job]:
        with _single_threaded_children(), _start_children_quietly():
            out = {self.pool.submit(run_scene, *_args(j)): j for j in jobs}
        self.futures += list(out)
        return out

    def cancel(self) -> None:
        """Cancel the scenes not started yet (running ones finish and are still delivered)."""
        for f in self.futures:
            f.cancel()

    def batches(self, futures: Iterable[Any]) -> Iterator[list[Any]]:
        """Completed futures, grouped: everything finished by the time the previous group is stored."""
        pending = set(futures)
        while pending:
            done, pending = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
            yield list(done)

    def result(self, fut: Any) -> SceneResult | None:
        """The scene's result; ``None`` if the pool broke (scene not attributable, not stored)."""
        try:
            return fut.result()
        except cf.process.BrokenProcessPool:
            return None
        except cf.CancelledError:
            raise
        except Exception as exc:  # run_scene keeps solver failures in its result: this is outside them
            raise WorkerError(f"a worker process failed outside the solvers ({type(exc).__name__}: "
                              f"{str(exc).strip()[:300]})") from exc

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

    def abort(self) -> None:
        """Stop at once (interrupt, failure): kill the workers; what they were computing is lost."""
        kill_pool(self.pool)


SCHEDULER_TIMEOUT_S = 10.0
"""How long ``--scheduler ADDRESS`` waits for the scheduler to answer."""


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
        self.futures: list[Any] = []

    def submit_all(self, jobs: Iterable[Job]) -> dict[Any, Job]:
        # unique task keys: never reuse a result another campaign left on a long-lived cluster
        out = {self.client.submit(run_scene, *_args(j), key=f"ked-scene-{j.spec.key}-{uuid.uuid4().hex[:8]}",
                                  pure=False): j for j in jobs}
        self.futures += list(out)
        return out

    def cancel(self) -> None:
        self.client.cancel([f for f in self.futures if not f.done()])

    def batches(self, futures: Iterable[Any]) -> Iterator[list[Any]]:
        from distributed import as_completed

        yield from as_completed(list(futures), loop=self.client.loop).batches()

    def result(self, fut: Any) -> SceneResult | None:
        return fut.result()

    def close(self) -> None:
        self.client.close()

    def abort(self) -> None:
        self.cancel()
        self.close()


def run_campaign(
    config: CampaignConfig,
    out: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    on_result: Callable[[SceneResult], None] | None = None,
    on_start: Callable[[Plan], None] | None = None,
) -> CampaignSummary:
    """Run every scene of ``config`` not yet stored in ``out`` and store the results there.

    ``workers``: local worker processes (default: available CPUs; ignored with ``scheduler``).  They are
    spawned and import the caller's main module, so a script must call this under
    ``if __name__ == "__main__":``; otherwise :class:`WorkerStartError` is raised and nothing is stored.
    ``retry_failed``: recompute stored failed scenes too.  ``progress``: tqdm bar on stderr.
    Raises :class:`compare.store.LockedError` if another campaign is writing ``out``.
    """
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # a spawned worker importing a script that calls this function without a main guard: the
        # worker cannot start; end it quietly (the parent reports it once, with the fix)
        os._exit(3)
    t0 = time.perf_counter()
    out = store.target(out)
    store.check_ours(out)
    scenes = config.scenes()
    stored = store.stored_solutions(out)
    p = plan(scenes, store.stored_status(out), retry_failed, stored)
    check_stored_settings(scenes, stored)
    if not p.jobs:  # nothing to compute: nothing is written (works on a read-only file system)
        return CampaignSummary(out=out, total=len(scenes), skipped=len(p.skipped), ok=0, failed=0, lost=0,
                               wall_s=time.perf_counter() - t0, keys=tuple(s.key for s in scenes))
    store.check_writable(out)
    with store.writer_lock(out):
        return _run_locked(config, out, workers=workers, scheduler=scheduler, retry_failed=retry_failed,
                           progress=progress, on_result=on_result, on_start=on_start)


def _run_locked(config: CampaignConfig, out: Path, *, workers: int | None, scheduler: str | None,
                retry_failed: bool, progress: bool, on_result: Callable[[SceneResult], None] | None,
                on_start: Callable[[Plan], None] | None = None) -> CampaignSummary:
    from tqdm import tqdm

    t0 = time.perf_counter()
    scenes = config.scenes()
    stored = store.stored_solutions(out)
    p = plan(scenes, store.stored_status(out), retry_failed, stored)
    check_stored_settings(scenes, stored)
    counts = {STATUS_OK: 0, STATUS_FAILED: 0}
    lost: list[Job] = []
    unsaved: list[SceneResult] = []
    failure: list[store.CommitError] = []
    if p.jobs:  # nothing to compute: nothing is written
        # the workers first: an unreachable scheduler, or workers that cannot start, are reported before
        # anything is written
        backend: Any = (_DaskBackend(scheduler) if scheduler
                        else _LocalBackend(min(workers or default_workers(), len(p.jobs))))
        bar = None
        try:
            store.remove_stale_temp_files(out)
            run = store.record_run(out, config.text, config.name, len(scenes))
            if on_start is not None:
                on_start(p)
            bar = tqdm(total=len(p.jobs), unit="scene", desc=config.name, disable=not progress,
                       file=sys.stderr, dynamic_ncols=True, smoothing=0.1)
            bar.set_postfix(ok=0, failed=0, skipped=len(p.skipped))

            def store_batch(batch: list[SceneResult]) -> None:
                if not failure:
                    try:
                        store.commit(out, batch, run)
                    except store.CommitError as exc:  # keep what is computed; stop starting new scenes
                        failure.append(exc)
                        if backend is not None:
                            backend.cancel()
                if failure:
                    unsaved.extend(batch)
                for r in batch:
                    counts[STATUS_OK if r.status == STATUS_OK else STATUS_FAILED] += 1
                    if on_result is not None:
                        on_result(r)
                bar.set_postfix(ok=counts[STATUS_OK], failed=counts[STATUS_FAILED], skipped=len(p.skipped),
                                refresh=False)
                bar.update(len(batch))

            lost = _drain(backend, backend.submit_all(p.jobs), store_batch)
            backend.close()
            backend = None
            if lost and not scheduler and not failure:  # a worker died: retry in a fresh pool, then one by one
                backend = _LocalBackend(min(workers or default_workers(), len(lost)))
                lost = _drain(backend, backend.submit_all(lost), store_batch)
                backend.close()
                backend = None
                if lost:
                    lost = _isolate(lost, store_batch)
        except BaseException:  # interrupt, failure: stop the workers now (what is committed stays)
            if backend is not None:
                backend.abort()
            raise
        finally:
            if bar is not None:
                bar.close()
    if failure:
        raise _rescued(failure[0], unsaved, out, config)
    ok, failed = counts[STATUS_OK], counts[STATUS_FAILED]
    return CampaignSummary(
        out=out,
        total=len(scenes),
        skipped=len(p.skipped),
        ok=ok,
        failed=failed,
        lost=len(lost),
        wall_s=time.perf_counter() - t0,
        keys=tuple(s.key for s in scenes),
    )
