"""The pytest plugin (ked_pytest, entry point pytest11) and its runnable example (examples/regression).

The example runs in a subprocess, in a copy, as a user's CI would: it passes against its committed baseline, fails
after one history of the baseline is scaled by 1.01 (a 1 % drift, beyond the `same` tier's 1e-8 of the example's
[tolerances] table) naming the scene and the quantity, and passes again after --ked-regen refreshed the baseline.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from compare import store
from ked_pytest import assert_agreement, assert_matches_baseline

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "regression"
SCENE = "source/distributed/1200rpm/k1/z0.02/ccw"


def _pytest(where: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(where), *args],
                          cwd=where, capture_output=True, text=True, timeout=600)


def test_example_passes_fails_after_a_perturbation_and_passes_after_regen(tmp_path):
    ex = tmp_path / "regression"
    shutil.copytree(EXAMPLE, ex)
    first = _pytest(ex)
    assert first.returncode == 0, first.stdout + first.stderr
    baseline = ex / "baseline" / "my_linkage.h5"
    with h5py.File(baseline, "r+") as f:
        labels = [x.decode() for x in f["scene_table/label"][()]]
        key = f["scene_table/key"][labels.index(SCENE)].decode()
        ds = f[f"scenes/{key}/solutions/linear"]
        ds[...] = ds[()] * 1.01
    drifted = _pytest(ex)
    assert drifted.returncode == 1
    # the baseline scaled by 1.01: |new - base| / |base| = 0.01 / 1.01 = 0.9901 % of its peak
    assert f"{SCENE}: history linear/dx: 0.9901 %" in drifted.stdout, drifted.stdout
    assert "test_matches_baseline" in drifted.stdout and "--ked-regen" in drifted.stdout
    regen = _pytest(ex, "--ked-regen")
    assert regen.returncode == 0, regen.stdout
    again = _pytest(ex)
    assert again.returncode == 0, again.stdout


def test_assert_agreement_names_scene_quantity_value_and_bound():
    new = EXAMPLE / "baseline" / "my_linkage.h5"
    assert_agreement(new, holds_below_speed_ratio=0.08, holds=[SCENE])
    with pytest.raises(AssertionError) as exc:
        assert_agreement(new, verdict_error_below={"distributed": 0.01})
    # the distributed mass at 1200 rpm: 1.6 % quasi-static error (the example's table), above 1 %
    assert f"{SCENE}: verdict_error = 0.01" in str(exc.value) and "expected < 0.01 (distributed)" in str(exc.value)


def test_missing_baseline_fails_and_regen_never_overwrites_a_foreign_file(tmp_path):
    new = EXAMPLE / "baseline" / "my_linkage.h5"
    with pytest.raises(AssertionError, match="no baseline .*--ked-regen"):
        assert_matches_baseline(new, tmp_path / "absent.h5")
    mine = tmp_path / "mine.h5"
    mine.write_text("the user's own file")
    with pytest.raises(store.StoreError):
        assert_matches_baseline(new, mine, regen=True)
    assert mine.read_text() == "the user's own file"
    assert_matches_baseline(new, tmp_path / "sub" / "b.h5", regen=True)
    assert_matches_baseline(new, tmp_path / "sub" / "b.h5")
