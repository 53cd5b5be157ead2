"""Crash safety: SIGKILL a running campaign (parent and workers) at random moments, then resume.

After every kill the results file must open, verify clean, and hold each stored scene exactly once
and complete; rerunning must skip what is stored and finish the rest.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time

import pytest

from compare import store
from compare.config import parse_config
from compare.runner import run_campaign

from .conftest import QUICK_DYNAMIC

CONFIG = """
[campaign]
name = "killme"
step_deg = 30.0
n_modes = 2
[grid]
mechanisms = ["source", "cognate"]
mass_models = ["extender", "joints"]
rpm = [30.0, 45.0, 60.0, 75.0]
""" + QUICK_DYNAMIC


def _start(cfg_file, out):
    cmd = [sys.executable, "-c", "from ked_cli.main import main; main()", "run", str(cfg_file), "--out", str(out),
           "--workers", "1", "--no-figures", "--no-progress"]
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)


def _kill(proc):
    try:
        os.killpg(proc.pid, signal.SIGKILL)  # the campaign's own process group: parent and its workers
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


def _stored(out) -> dict[str, str]:
    try:
        return store.stored_status(out)
    except OSError:
        return {}


def test_sigkill_mid_run_then_resume(tmp_path):
    cfg_file = tmp_path / "kill.toml"
    cfg_file.write_text(CONFIG)
    out = tmp_path / "kill.h5"
    expected = {s.key for s in parse_config(CONFIG).scenes()}
    rng = random.Random(5)
    seen_counts = []
    for _ in range(2):  # two kills at random moments, then a clean resume
        before = set(_stored(out))
        proc = _start(cfg_file, out)
        deadline = time.monotonic() + 180
        while len(_stored(out)) <= len(before) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        time.sleep(rng.uniform(0.0, 0.6))  # kill at an arbitrary moment (possibly mid-commit)
        finished = proc.poll() is not None
        _kill(proc)
        if finished and proc.returncode != 0:
            pytest.fail(f"campaign subprocess failed: {proc.stderr.read().decode()[-2000:]}")
        assert len(_stored(out)) > len(before), "no scene was stored before the kill"
        assert store.verify(out) == [], "results file damaged by SIGKILL"
        stored = _stored(out)
        assert set(stored) <= expected
        assert before <= set(stored), "a previously stored scene vanished"
        seen_counts.append(len(stored))
        if finished:
            break
    assert seen_counts[0] < len(expected), "campaign finished before it could be killed; make it longer"

    n_before = len(_stored(out))
    summary = run_campaign(parse_config(CONFIG), out, workers=2, progress=False)
    assert summary.skipped == n_before and summary.ok + summary.failed == len(expected) - n_before
    assert store.verify(out) == []
    results = store.read_scenes(out)
    assert sorted(r.key for r in results) == sorted(expected)  # every scene exactly once
    assert all(r.ok for r in results)


def test_killed_writer_leaves_only_ignorable_temp_files(tmp_path):
    """A temp file left by a writer killed mid-transaction is not the results file and is cleaned up."""
    cfg_file = tmp_path / "kill.toml"
    cfg_file.write_text(CONFIG)
    out = tmp_path / "kill.h5"
    stale = out.with_name(out.name + store.TMP_MARK + "12345-abcdef01")
    stale.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)  # looks like the start of an HDF5 file
    store.record_run(out, CONFIG, "killme", 0)
    assert store.verify(out) == [] and store.stale_temp_files(out) == [stale]
    run_campaign(parse_config(CONFIG.replace("[30.0, 45.0, 60.0, 75.0]", "[30.0]")), out, workers=1,
                 progress=False)
    assert not stale.exists()
