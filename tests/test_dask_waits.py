"""Every wait on a Dask cluster has a limit and says what it waits for: a scheduler without any worker, or
whose workers all left during a run, ends the run with one line instead of a wait without end."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from compare import executor as runner

distributed = pytest.importorskip("distributed")


def _slow(x: int) -> int:
    time.sleep(0.5)
    return x


def test_a_scheduler_without_workers_is_given_up_after_the_wait_limit(monkeypatch):
    monkeypatch.setattr(runner, "WORKER_WAIT_S", 3.0)
    with distributed.LocalCluster(n_workers=0, dashboard_address=None, silence_logs=40) as cluster:
        t0 = time.monotonic()
        with pytest.raises(runner.SchedulerError, match="no Dask worker on this cluster for 3 s"):
            runner.run_tasks([1, 2], _slow, scheduler=cluster.scheduler_address, on_result=lambda b: None,
                             crashed=lambda t, e: None)
        assert time.monotonic() - t0 < 120  # generous: a limit, not a timing


def test_workers_that_all_leave_mid_run_end_it(monkeypatch):
    monkeypatch.setattr(runner, "WORKER_WAIT_S", 3.0)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster:
        got: list[int] = []

        def on_result(batch: list) -> None:
            got.extend(r for _, r in batch)
            if len(got) == 1:
                cluster.scale(0)  # the only worker leaves after the first result

        with pytest.raises(runner.SchedulerError, match="no Dask worker"):
            runner.run_tasks(list(range(40)), _slow, scheduler=cluster.scheduler_address, on_result=on_result,
                             crashed=lambda t, e: None)
        assert 1 <= len(got) < 40


def test_ked_run_on_a_scheduler_without_workers_says_so_in_a_line(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[campaign]\nname = "w"\nsolvers = ["quasi_static"]\n[grid]\nmass_models = ["tip"]\nrpm = [60.0]\n')
    with distributed.LocalCluster(n_workers=0, dashboard_address=None, silence_logs=40) as cluster:
        res = subprocess.run([sys.executable, "-m", "ked_cli", "run", str(cfg), "--out", str(tmp_path / "w.h5"),
                              "--scheduler", cluster.scheduler_address, "--no-figures", "--no-progress"],
                             capture_output=True, text=True, timeout=300,
                             env={**__import__("os").environ, "KED_WORKER_WAIT_S": "3"})
    assert res.returncode != 0 and "Traceback" not in res.stderr, res.stderr
    last = res.stderr.strip().splitlines()[-1]  # after the campaign's header line: one line saying why
    assert last.startswith("ked: ") and "no Dask worker" in last and cluster.scheduler_address in last, res.stderr
