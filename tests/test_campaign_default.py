"""The README's main-job command: `ked run` with no arguments (slow: the full default campaign)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from compare import store
from compare.config import load_config


@pytest.mark.slow
def test_ked_run_without_arguments(tmp_path):
    cmd = [sys.executable, "-c", "from ked_cli.main import main; main()", "run", "--no-progress"]
    res = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=1200)
    assert res.returncode == 0, res.stderr[-2000:]
    out = tmp_path / "ked_results" / "thesis-default.h5"
    assert store.verify(out) == []
    results = store.read_scenes(out)
    assert len(results) == len(load_config(None).scenes())
    assert sum(r.ok for r in results) >= len(results) - 2
    assert "verdict" in res.stdout and "quasi-static holds in" in res.stdout
    figs = list((tmp_path / "ked_results" / "thesis-default_figures").glob("*.png"))
    assert len(figs) == len(results) + 1
    again = subprocess.run(cmd + ["--no-figures"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and f"{len(results)} skipped" in again.stdout
