"""ked check on worker processes (ked_check.checkwork): the same rows and critical speeds as in one process,
which is the reference (the sequential check, itself tested against the campaign and the fine sweep); a
light check never starts them; a task's failure surfaces as in one process, a dead worker as one error
naming what it computed."""

from __future__ import annotations

import json
import os
from dataclasses import asdict

import pytest

from ked_check.check import check
from ked_check.checkwork import CheckWorkerError, CheckWorkers, Work, kept
from ked_check.critical import check_critical
from ked_quasi.massmodel import MassModel, default_payload


def _check(thesis, mm, rpms, workers):
    rows = check(thesis, "source", mm, rpms, workers=workers)
    crit, amp, rows = check_critical(rows, thesis, "source", mm, workers=workers)
    return json.dumps([asdict(r) for r in rows], sort_keys=True), crit, amp


def test_worker_processes_give_the_rows_and_critical_speeds_of_one_process(thesis, monkeypatch):
    # joints model, 150-600 rpm (critical speeds near 202, 320 and 512 rpm, docs/linear_model.md): with the
    # timings given (1 s a task, no start cost) every speed, every round of the sweep and the refinement of
    # its maxima go to 2 workers, which the spy sees; the answer is that of one process
    mm, rpms = MassModel("joints", payload=0.0), [150.0 + 50.0 * k for k in range(10)]
    alone = _check(thesis, mm, rpms, None)
    used = []
    original = CheckWorkers.map

    def spy(self, fn, calls, *args, **kwargs):
        used.append((fn.__name__, len(calls)))
        return original(self, fn, calls, *args, **kwargs)

    monkeypatch.setattr(CheckWorkers, "map", spy)
    with CheckWorkers(2, start_s=0.0) as workers:
        workers.speeds, workers.evaluations = Work(1.0, 1.0), Work(1.0, 1.0)
        spread = _check(thesis, mm, rpms, workers)
    assert spread == alone
    assert len(alone[1]) >= 2  # two maxima or more: their refinements are tasks of their own
    assert ("row_task", len(rpms)) in used and {"floquet_task", "refine_task"} <= {name for name, _ in used}


def test_a_light_check_stays_in_this_process(thesis):
    # the tip model solves a speed in some 0.02 s: the three speeds after the two timed ones, and the sweep,
    # would save far less than the workers' start-up
    with CheckWorkers(2) as workers:
        _check(thesis, MassModel("tip", payload=default_payload("tip")), [100.0, 125.0, 150.0, 175.0, 200.0],
               workers)
        assert not workers.started and workers.speeds.second < 0.5


def _refuse(x: int) -> float:
    raise ValueError(f"x: {x} is not allowed")


def _half_or_fail(x: int):
    if x == 3:
        return kept(lambda: _refuse(x))  # as a task function keeps a solver's refusal
    if x == 4:
        os._exit(1)  # as a segfault inside a solver
    return x / 2


def test_a_failing_task_raises_as_in_one_process_and_a_dead_worker_is_named():
    calls = [(1,), (2,), (3,)]
    with CheckWorkers(2) as workers:
        with pytest.raises(ValueError, match="^x: 3 is not allowed$"):
            workers.map(_half_or_fail, calls, ["one", "two", "three"])
        assert workers.map(_half_or_fail, [(1,), (2,)], ["one", "two"]) == [0.5, 1.0]
        with pytest.raises(CheckWorkerError, match="^four: the worker process died.*--workers 1"):
            workers.map(_half_or_fail, [(1,), (4,)], ["one", "four"])


def test_workers_are_validated():
    with pytest.raises(ValueError, match="workers"):
        CheckWorkers(0)
    with pytest.raises(ValueError, match="start_s"):
        CheckWorkers(2, start_s=float("nan"))
