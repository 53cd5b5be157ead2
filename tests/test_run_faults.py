"""Faults around a running campaign, through the real command line in subprocesses: repeated
signals, a hang-up, Ctrl-C while the workers start, a disk that fills, kill -9 while figures are
drawn, peers that are not a Dask scheduler, a script without a main guard, figure directories that
hold the user's own files, and odd paths (FIFOs, symlink loops).  Each must end promptly, in one line
without a traceback, with a non-zero exit status, and keep everything committed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from compare import store

from .test_edges import SLOW, _alive, _children, _cmdline

KED = [sys.executable, "-m", "ked_cli"]


def _start(args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen([*KED, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _workers_of(proc: subprocess.Popen, n: int, until: Path | None = None, limit_s: float = 120) -> set[int]:
    """The spawned worker processes of ``proc`` once ``n`` exist (and ``until`` exists, if given)."""
    deadline = time.monotonic() + limit_s
    workers: set[int] = set()
    while time.monotonic() < deadline and not (len(workers) >= n and (until is None or until.exists())):
        workers |= {c for c in _children(proc.pid) if "spawn_main" in _cmdline(c)}
        time.sleep(0.05)
    return workers


def _gone(pids: set[int], limit_s: float = 10) -> bool:
    t0 = time.monotonic()
    while any(_alive(p) for p in pids) and time.monotonic() - t0 < limit_s:
        time.sleep(0.1)
    return not any(_alive(p) for p in pids)


def _finish(proc: subprocess.Popen, limit_s: float = 60) -> tuple[str, str]:
    """Output of ``proc``; a process still running after ``limit_s`` hangs: kill it, fail the test."""
    try:
        return proc.communicate(timeout=limit_s)
    except subprocess.TimeoutExpired:
        for c in _children(proc.pid):
            os.kill(c, signal.SIGKILL)
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"hangs: still running {limit_s:g} s after the signal; stderr: {err[-800:]}")


# -- signals ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sigs", [(signal.SIGINT, signal.SIGINT), (signal.SIGTERM, signal.SIGTERM),
                                  (signal.SIGHUP,)], ids=["int-int", "term-term", "hup"])
def test_repeated_signals_or_hangup_end_the_run_promptly_and_keep_the_commits(tmp_path, sigs):
    cfg = tmp_path / "signals.toml"
    cfg.write_text(SLOW)
    out = tmp_path / "signals.h5"
    proc = _start(["run", str(cfg), "--out", str(out), "--workers", "2", "--no-progress", "--no-figures"])
    workers = _workers_of(proc, 2, until=out)
    assert workers, "no worker process started"
    time.sleep(1.0)  # the workers are computing
    for s in sigs:
        proc.send_signal(s)
        time.sleep(0.3)
    _, err = _finish(proc)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("ked: interrupted"), err
    assert _gone(workers), "worker processes outlived ked run"
    assert store.verify(out) == []  # what was committed stays, readable (a rerun resumes from it)


def test_ctrl_c_while_the_workers_start_prints_no_child_traceback(tmp_path):
    # a terminal's Ctrl-C goes to the whole process group: the parent and its starting workers
    cfg = tmp_path / "signals.toml"
    cfg.write_text(SLOW)
    out = tmp_path / "start.h5"
    proc = _start(["run", str(cfg), "--out", str(out), "--workers", "2", "--no-progress", "--no-figures"],
                  start_new_session=True)
    workers = _workers_of(proc, 1)
    assert workers, "no worker process started"
    os.killpg(proc.pid, signal.SIGINT)
    _, err = _finish(proc)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Fatal Python error" not in err, err
    assert len(err.strip().splitlines()) == 1 and err.strip().startswith("ked: interrupted"), err
    assert _gone(workers)
