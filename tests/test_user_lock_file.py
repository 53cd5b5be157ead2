"""The harness writes only into files it created: a user's own file named like the writer lock
(``<out>.lock``) is neither used as the lock nor deleted; the command says what is in the way."""

from __future__ import annotations

import subprocess
import sys

import pytest

from compare import store


def test_a_users_file_named_like_the_lock_is_left_alone(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[campaign]\nname = "c"\nsolvers = ["quasi_static"]\n[grid]\nmass_models = ["tip"]\nrpm = [60.0]\n')
    mine = tmp_path / "r.h5.lock"
    mine.write_text("my notes about r.h5\n")
    res = subprocess.run([sys.executable, "-m", "ked_cli", "run", str(cfg), "--out", str(tmp_path / "r.h5"),
                          "--no-figures", "--no-progress"], capture_output=True, text=True, timeout=300)
    assert res.returncode != 0 and "Traceback" not in res.stderr, res.stderr
    assert str(mine) in res.stderr.strip().splitlines()[-1], res.stderr
    assert mine.read_text() == "my notes about r.h5\n"  # untouched, still there


def test_the_harness_lock_is_marked_and_removed(tmp_path):
    out = tmp_path / "r.h5"
    lock = tmp_path / "r.h5.lock"
    with store.writer_lock(out):
        assert lock.read_bytes().startswith(store.LOCK_MARK)
    assert not lock.exists()
    # a lock a killed harness process left behind carries the mark: the next writer takes it over
    lock.write_bytes(store.LOCK_MARK + b"12345\n")
    with store.writer_lock(out):
        pass
    assert not lock.exists()
    lock.write_text("someone else's\n")
    with pytest.raises(store.CommitError, match="did not make"), store.writer_lock(out):
        pass
    assert lock.read_text() == "someone else's\n"
