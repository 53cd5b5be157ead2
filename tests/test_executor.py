"""The one executor (compare.runner.run_tasks) on real spawned worker processes, and the campaign's one
read of the store.  Expected values are plain arithmetic (the task squares its number), independent of
the executor."""

from __future__ import annotations

import os

import pytest

from compare import h5layout, store
from compare.config import parse_config
from compare.runner import LocalPool, WorkerError, run_campaign, run_tasks

from .test_edges import QS


def _square(x: int) -> int:
    return x * x


def _square_or_die(x: int) -> int:
    if x == 3:
        os._exit(1)  # as a segfault inside a solver: the worker process is gone
    return x * x


def _square_or_raise(x: int) -> int:
    if x == 2:
        raise ArithmeticError("a bug outside the solvers")
    return x * x


def _collect(tasks, fn, **kw):
    got: dict[int, object] = {}

    def on_result(batch):
        for task, r in batch:
            assert task not in got  # every task is delivered once
            got[task] = r

    left = run_tasks(tasks, fn, on_result=on_result, crashed=lambda task, exc: ("crashed", task, exc), **kw)
    return got, left


def test_every_task_is_delivered_once_with_its_result():
    got, left = _collect(list(range(7)), _square, workers=2)
    assert left == 0 and got == {x: x * x for x in range(7)}


def test_a_task_that_kills_its_worker_becomes_a_crash_record_and_the_rest_complete():
    # the pool breaks, its tasks rerun in a fresh pool (which breaks again), then one by one: only the
    # culprit is a crash record (exception None: the worker died), every other task has its result
    got, left = _collect(list(range(6)), _square_or_die, workers=2)
    assert left == 0
    assert got.pop(3) == ("crashed", 3, None)
    assert got == {x: x * x for x in range(6) if x != 3}


def test_a_task_raising_in_a_local_worker_fails_the_run():
    with pytest.raises(WorkerError, match="ArithmeticError"):
        _collect([1, 2, 3], _square_or_raise, workers=1)


def _pid(x: int) -> int:
    return os.getpid()


def test_a_kept_pool_serves_several_runs_with_the_same_workers_and_survives_a_crash():
    # one start-up for several calls (the design check's speeds, then its sweep): the same worker
    # processes answer both runs; a run whose worker dies drops the broken pool and the next call starts
    # a fresh one; the pool's workers are gone after the with block
    with LocalPool(2) as pool:
        first, _ = _collect(list(range(6)), _pid, workers=2, pool=pool)
        second, _ = _collect(list(range(6)), _pid, workers=2, pool=pool)
        assert set(second.values()) <= set(first.values()) and os.getpid() not in first.values()
        got, left = _collect(list(range(6)), _square_or_die, workers=2, pool=pool)
        assert left == 0 and got.pop(3) == ("crashed", 3, None) and got == {x: x * x for x in range(6) if x != 3}
        assert not pool.started  # the broken pool was dropped
        third, _ = _collect(list(range(4)), _pid, workers=2, pool=pool)
        assert not set(third.values()) & set(first.values())
        procs = list(pool.backend().pool._processes.values())
    assert not pool.started and procs and not any(p.is_alive() for p in procs)


def test_on_result_asking_to_stop_cancels_the_tasks_not_started():
    seen: list[int] = []

    def stop_at_once(batch):
        seen.extend(t for t, _ in batch)
        return True

    left = run_tasks(list(range(40)), _square, workers=1, on_result=stop_at_once, crashed=lambda t, e: None)
    assert 1 <= len(seen) < 40 and left == 0  # cancelled tasks were never started: nothing lost
    assert len(seen) == len(set(seen))


def test_a_run_reads_the_stored_scenes_once(tmp_path, monkeypatch):
    """The plan is made once, under the writer lock: every stored scene of the campaign is read once
    (before: four reads of the store, two plans)."""
    out = tmp_path / "once.h5"
    run_campaign(parse_config(QS), out, workers=1, progress=False)  # 4 scenes stored
    more = parse_config(QS.replace("rpm = [60.0, 90.0]", "rpm = [60.0, 90.0, 120.0]"))  # 2 new scenes
    reads: list[str] = []
    real = h5layout.TableFile.read_scene  # version 4: scenes are read through the file's tables

    def counting(self, key):
        reads.append(key)
        return real(self, key)

    monkeypatch.setattr(h5layout.TableFile, "read_scene", counting)
    summary = run_campaign(more, out, workers=1, progress=False)
    assert (summary.skipped, summary.ok) == (4, 2)
    assert sorted(reads) == sorted(set(reads)) and len(reads) == 4  # each stored scene once
    assert len(store.read_scenes(out)) == 6
