"""Worker counts are capped at what the machine can use: a pool never starts more local processes than
the CPUs available to the process (the tasks are CPU-bound), and the command line says so once."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from compare.runner import default_workers, run_tasks


def _pid(_: int) -> int:
    time.sleep(0.05)
    return os.getpid()


def test_a_pool_asked_for_1000_workers_starts_at_most_the_cpus():
    # expected: at most len(sched_getaffinity) distinct worker processes over 40 tasks, whatever was asked
    pids: set[int] = set()
    run_tasks(list(range(40)), _pid, workers=1000, on_result=lambda batch: pids.update(r for _, r in batch),
              crashed=lambda t, e: -1)
    assert 1 <= len(pids) <= default_workers(), (len(pids), default_workers())


def test_the_command_line_says_the_workers_are_capped(tmp_path):
    cpus = default_workers()
    res = subprocess.run([sys.executable, "-m", "ked_cli", "check", "--mass-model", "tip", "--rpm", "100",
                          "--workers", str(cpus + 998)], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert f"--workers {cpus + 998}: at most {cpus} local worker processes" in res.stderr
    assert "Traceback" not in res.stderr
