"""A results file whose last 4 kB were zeroed (a torn write, a bad sector): every command that would write
into it or read it for a merge ends in one line naming the file and saying it is damaged, exit 1, and leaves
both files as they were (before: "internal error" without the file's name)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

QS = """
[campaign]
name = "tail"
solvers = ["quasi_static"]
[grid]
mass_models = ["tip"]
rpm = [60.0, 90.0]
"""


def ked(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ked_cli", *args], capture_output=True, text=True, timeout=300)


def test_a_file_with_a_zeroed_tail_is_named_as_damaged(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(QS)
    good, bad = tmp_path / "good.h5", tmp_path / "bad.h5"
    assert ked("run", str(cfg), "--out", str(good), "--no-figures", "--no-progress").returncode == 0
    bad.write_bytes(good.read_bytes())
    with open(bad, "r+b") as f:
        f.seek(os.path.getsize(bad) - 4096)
        f.write(b"\0" * 4096)
    more = tmp_path / "more.toml"
    more.write_text(QS.replace("90.0]", "90.0, 120.0]"))
    before = {p: Path(p).read_bytes() for p in (good, bad)}
    for args in (("run", str(more), "--out", str(bad), "--no-figures", "--no-progress"),
                 ("merge", str(bad), str(good)), ("merge", str(good), str(bad))):
        res = ked(*args)
        err = res.stderr.strip().splitlines()
        assert res.returncode == 1 and "Traceback" not in res.stderr, (args, res.stderr)
        assert len(err) == 1 and str(bad) in err[0] and "damaged" in err[0], (args, err)
    assert {p: Path(p).read_bytes() for p in (good, bad)} == before
