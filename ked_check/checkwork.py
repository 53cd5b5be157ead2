"""Where a design check's solves run: in this process, or on local worker processes once the work is
worth their start (:class:`CheckWorkers`).

A check over several speeds (``ked check --rpm-range``) is a list of independent scenes, then a
critical-speed sweep whose rounds of Floquet evaluations are independent too (:mod:`ked_check.critical`).
Worker processes cost a start-up: ~0.8 s for 2 on this project's 2-core machine (an interpreter and the
harness's imports each), plus each worker's first task, which pays what the first task here paid on top of
the next (caches of the linkage; Exudyn's import, ~1 s, in a confirmed check).  So the first two tasks of
each kind (a speed, a sweep evaluation) are timed here, and the rest goes to the workers only where the
time it saves, (tasks) x (the second's time) x (1 - 1 / workers), exceeds :data:`POOL_START_S` plus the
first task's extra time: a check of a light model (a tip mass: some 0.02 s a speed) stays in this
process.  The workers run on :func:`compare.runner.run_tasks` (one
:class:`LocalPool`, kept from the speeds to the sweep).  Each task computes what the sequential check
computes, with the same code: the rows, the critical speeds and every number printed are the same (a
test compares them).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from compare.executor import LocalPool

POOL_START_S = 1.0
"""What starting the pool of workers costs a check [s]: 0.8 s measured for two on this project's 2-core
machine (their first tasks' extra cost is measured per check, see the module docstring)."""


class CheckWorkerError(RuntimeError):
    """A worker process of a check died while computing (a crash in a solver): the message names what."""


@dataclass(frozen=True)
class _Failed:
    """A task's failure kept as data (``kind``: the exception's type name, or "crashed" where the worker
    process died): the check raises it in this process as the sequential check would."""

    message: str
    kind: str = "ValueError"


@dataclass
class Work:
    """One kind of task of a check (a speed, a sweep evaluation): the wall times [s] of the first two,
    computed in this process (NaN until then)."""

    first: float = math.nan
    second: float = math.nan

    @property
    def timed_enough(self) -> bool:
        return math.isfinite(self.second)

    def timed(self, compute: Callable[[], Any]) -> Any:
        """compute(), timed if it is one of the first two."""
        t0 = time.perf_counter()
        out = compute()
        seconds = time.perf_counter() - t0
        if not math.isfinite(self.first):
            self.first = seconds
        elif not self.timed_enough:
            self.second = seconds
        return out


class CheckWorkers:
    """Worker processes for one check (a context manager): ``workers`` of them at most (1: none; None: the
    available CPUs), started when :meth:`worth` says so, stopped at the end of the ``with`` block.
    ``speeds``, ``evaluations``: the two kinds of work (:class:`Work`), each timed on its first two tasks
    here."""

    def __init__(self, workers: int | None = None, start_s: float = POOL_START_S):
        if workers is not None and workers < 1:
            raise ValueError(f"workers: at least 1; got {workers}")
        if not start_s >= 0.0:
            raise ValueError(f"start_s: a time >= 0 [s]; got {start_s}")
        self._workers = workers
        self.start_s = start_s
        self.speeds, self.evaluations = Work(), Work()
        self._pool: LocalPool | None = None

    @property
    def started(self) -> bool:
        """True once worker processes were started for this check."""
        return self._pool is not None

    @property
    def workers(self) -> int:
        """How many worker processes at most (the available CPUs, or fewer if given)."""
        from compare.executor import default_workers  # only once workers are considered: it imports h5py

        self._workers = min(self._workers or default_workers(), default_workers())
        return self._workers

    def __enter__(self) -> CheckWorkers:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        if self._pool is not None:
            self._pool.drop(abort=kind is not None)
            self._pool = None

    def worth(self, work: Work, tasks: int, per_task: float = 1.0) -> bool:
        """Whether ``tasks`` more tasks go to the workers, each ``per_task`` tasks of ``work`` long: more
        than one, and the workers run already, or the first two of ``work`` were timed and the time the
        workers would save, ``tasks`` x ``per_task`` x the second's time x (1 - 1 / w), w = min(workers,
        ``tasks``), exceeds ``start_s`` (default :data:`POOL_START_S`) plus the first's extra time (each
        worker's first task pays it too)."""
        if tasks < 2:
            return False
        if self._pool is not None:
            return True
        if not work.timed_enough:
            return False
        saved, cost = tasks * per_task * work.second, self.start_s + max(work.first - work.second, 0.0)
        if saved <= cost:  # not even with unlimited workers (and the CPUs are not looked up)
            return False
        w = min(self.workers, tasks)
        return w >= 2 and saved * (1.0 - 1.0 / w) > cost

    def map(self, fn: Callable[..., Any], calls: Sequence[tuple[Any, ...]], names: Sequence[str],
            on_each: Callable[[int, Any], None] | None = None, cost: Sequence[float] | None = None) -> list[Any]:
        """[fn(*c) for c in calls] on the workers (started now if need be; where they cannot start, here),
        in the order of ``calls``; ``names``: what each call computes (for a message); ``on_each(i,
        result)`` as each finishes; ``cost``: a guess of each call's relative cost (the costliest are given
        out first, so that no worker is left with a long one at the end).  A task's failure is raised here
        as the sequential check would raise it (``ValueError``, ``MemoryError``), a worker that died as
        :class:`CheckWorkerError` naming the call."""
        from compare.executor import LocalPool, WorkerStartError, crash_reason, run_tasks

        out: list[Any] = [None] * len(calls)

        def deliver(batch: list[tuple[int, Any]]) -> None:
            for i, r in batch:
                out[i] = r
                if on_each is not None and not isinstance(r, _Failed):
                    on_each(i, r)

        if self._pool is None:
            self._pool = LocalPool(min(self.workers, max(len(calls), 2)))
        try:
            self._pool.backend()  # started now: where worker processes cannot start, the check runs here
        except (WorkerStartError, OSError):
            self._pool, self._workers = None, 1
            deliver([(i, fn(*c)) for i, c in enumerate(calls)])
        else:
            order = sorted(range(len(calls)), key=lambda i: -cost[i]) if cost is not None else list(range(len(calls)))
            run_tasks(order, fn, args=lambda i: calls[i], workers=self._pool.workers, pool=self._pool,
                      on_result=deliver, crashed=lambda i, exc: _Failed(crash_reason(exc), "crashed"))
        for i, r in enumerate(out):
            if isinstance(r, _Failed):
                if r.kind == "crashed":
                    raise CheckWorkerError(f"{names[i]}: {r.message}; rerun with --workers 1 to compute it in "
                                           "one process")
                raise (MemoryError if r.kind == "MemoryError" else ValueError)(r.message)
        return out


def kept(compute: Callable[[], Any]) -> Any:
    """compute() on a worker as in the sequential check (one BLAS thread), its ``ValueError`` or
    ``MemoryError`` kept as data (:class:`_Failed`) for :meth:`CheckWorkers.map` to raise."""
    from ked_linear.solver import single_threaded_blas

    try:
        with single_threaded_blas():
            return compute()
    except (ValueError, MemoryError) as exc:
        return _Failed(str(exc), type(exc).__name__)
