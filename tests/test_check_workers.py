"""ked check on worker processes (compare.checkwork): the same rows and critical speeds as in one process,
which is the reference (the sequential check, itself tested against the campaign and the fine sweep); a
light check never starts them."""

from __future__ import annotations

import json
from dataclasses import asdict

import pytest

from compare.check import check
from compare.checkwork import CheckWorkers
from compare.critical import check_critical
from ked_quasi.massmodel import MassModel, default_payload


def _check(thesis, mm, rpms, workers):
    rows = check(thesis, "source", mm, rpms, workers=workers)
    crit, amp, rows = check_critical(rows, thesis, "source", mm, workers=workers)
    return json.dumps([asdict(r) for r in rows], sort_keys=True), crit, amp


def test_worker_processes_give_the_rows_and_critical_speeds_of_one_process(thesis):
    # joints model over a range with a critical speed (202 rpm): forced onto 2 workers (start cost 0 s),
    # the rows after the first two, the sweep's rounds and the refinement of its maxima run there
    mm, rpms = MassModel("joints", payload=0.0), [150.0, 200.0, 250.0, 300.0, 350.0]
    alone = _check(thesis, mm, rpms, None)
    with CheckWorkers(2, start_s=0.0) as workers:
        spread = _check(thesis, mm, rpms, workers)
        assert workers.started
    assert spread == alone
    assert alone[1]  # the range has a critical speed: the refinement ran on the workers too


def test_a_light_check_stays_in_this_process(thesis):
    # the tip model solves a speed in some 0.02 s: three speeds and their sweep are far below 2 s
    with CheckWorkers(2) as workers:
        _check(thesis, MassModel("tip", payload=default_payload("tip")), [100.0, 150.0, 200.0], workers)
        assert not workers.started and workers.speeds.second < 1.0


def test_workers_are_validated():
    with pytest.raises(ValueError, match="workers"):
        CheckWorkers(0)
