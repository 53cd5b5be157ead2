"""The project's own regression reference (results/reference/) on the machinery of `ked diff`: rerun the
committed campaign and compare it with the stored results by the tolerances and expectations of its config.

Tolerances (results/reference/reference.toml, [tolerances]): the `same` tier of compare.tolerances (round-off)
for the quasi-static and linear answers, 0.2 % of the peak for the Exudyn answer (its steady_tol); every verdict
and status unchanged.  Expectations: the quasi-static answer holds below r = 0.1 and fails in the four fast
joints / distributed scenes (regression pins of the findings).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import pytest

from compare import store
from compare.config import load_config
from compare.diff import format_report
from compare.reference import check, rerun

REFERENCE = Path(__file__).resolve().parents[1] / "results" / "reference"


def test_committed_reference_is_valid_and_meets_its_expectations():
    h5 = REFERENCE / "reference.h5"
    assert store.verify(h5) == []
    cfg = load_config(REFERENCE / "reference.toml")
    assert {s.key for s in cfg.scenes()} == set(store.stored_status(h5)), "reference.toml and reference.h5 differ"
    assert set(store.stored_status(h5).values()) == {"ok"}
    rep = check(REFERENCE, h5)
    assert rep.passed and rep.counts()["matched_by_key"] == 12, format_report(rep)
    assert {r.verdict.holds for r in store.read_scenes(h5)} == {True, False}, "both verdicts should be pinned"


def test_rerun_reproduces_the_reference(tmp_path):
    rep = check(REFERENCE, rerun(REFERENCE, tmp_path / "rerun.h5", workers=2))
    assert rep.passed, format_report(rep)


def test_the_check_detects_a_changed_answer(tmp_path):
    new = tmp_path / "changed.h5"
    new.write_bytes((REFERENCE / "reference.h5").read_bytes())
    label = "source/extender/240rpm/k1/z0.02/ccw"  # quasi-static error 5.1 %: x 1.5 makes it fail
    with h5py.File(new, "r+") as f:
        labels = [x.decode() for x in f["scene_table/label"][()]]
        key = f["scene_table/key"][labels.index(label)].decode()
        ds = f[f"scenes/{key}/solutions/dynamic"]
        ds[...] = ds[()] * 1.5
    rep = check(REFERENCE, new)
    fails = {(s.label, c.check, c.solver) for s in rep.scenes for c in s.failures}
    assert (label, "history", "dynamic") in fails and (label, "verdict", "quasi_static") in fails
    assert [(v.scene, v.quantity) for v in rep.violations] == [(label, "verdict_error")]


@pytest.mark.parametrize("table", ["tolerances", "expect"])
def test_reference_config_states_its_tables(table):
    assert getattr(load_config(REFERENCE / "reference.toml"), table)
