"""Nothing damaged passes as valid: `ked inspect --verify` recomputes what a file stores and checks every
table, `ked merge` carries only the scenes that verify, and every file the harness writes (campaign, study
and atlas files) is read and verified by `ked inspect`.  Real files: a small campaign computed by the
command line (quasi-static and linear solvers, two speeds: about a second), damaged with plain h5py; the
committed atlas file.  Each case here passed as valid (or merged as "ok") before its fix.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from compare import store, tables
from tests.test_campaign_store import edit_rows
from tests.test_store_faults import DATA, config, ked, one_line, run, verify_ok

ROOT = Path(__file__).resolve().parents[1]
ATLAS = ROOT / "results" / "atlas" / "atlas.h5"


@pytest.fixture(scope="module")
def current(tmp_path_factory) -> Path:
    """A valid results file of two quasi-static + linear scenes (60 and 90 rpm)."""
    d = tmp_path_factory.mktemp("verify")
    res = run(config(d, "cur"), d / "cur.h5")
    assert res.returncode == 0, res.stderr
    return d / "cur.h5"


@pytest.fixture(scope="module")
def other(tmp_path_factory) -> Path:
    """A valid results file of one scene the first one does not hold (120 rpm): a merge's destination."""
    d = tmp_path_factory.mktemp("dest")
    res = run(config(d, "dest", rpm=[120.0]), d / "dest.h5")
    assert res.returncode == 0, res.stderr
    return d / "dest.h5"


def damaged(current: Path, tmp: Path, name: str, damage) -> tuple[Path, str]:
    """A copy of ``current`` with ``damage(file, key)`` done to its first scene; (file, that key)."""
    f = tmp / f"{name}.h5"
    shutil.copyfile(current, f)
    with h5py.File(f, "r+") as h:
        key = sorted(h["scenes"])[0]
        damage(h, key)
    return f, key


def scale_history(h: h5py.File, key: str) -> None:
    """The linear reference's histories changed after the fact (x 3): the stored metrics still say what
    the computed histories gave."""
    ds = h["scenes"][key]["solutions"]["linear"]
    ds[...] = 3.0 * ds[()]


def invert_pair_holds(h: h5py.File, key: str) -> None:
    col = h["metric_table"]["pair_holds"]
    col[...] = 1 - col[()]


def widen_warnings(h: h5py.File, key: str) -> None:
    """A text column replaced by a (rows, 3) number column: every reader copes, a writer cannot append."""
    g = h["scene_table"]
    n = int(g.attrs["rows"])
    attrs = dict(g["warnings"].attrs)
    del g["warnings"]
    g.create_dataset("warnings", data=np.zeros((n, 3))).attrs.update(attrs)


# -- --verify: every table, recomputed ------------------------------------------------------------------------


@pytest.mark.parametrize("name, damage, words", [
    ("pair_holds", lambda h, key: invert_pair_holds(h, key), "differ from the histories (pair_holds)"),
    ("no_runs", lambda h, key: h.__delitem__("runs"), "missing table /runs"),
    ("no_column", lambda h, key: h["scene_table"].__delitem__("mass_model"), "missing column(s) mass_model"),
    ("no_such_run", lambda h, key: edit_rows(h, "scene_table", key, run=7), "run 7 of /scene_table is not in /runs"),
    ("unwritable", widen_warnings, "a write into this file fails"),
    ("frequencies", lambda h, key: h["scenes"][key]["natural_frequencies"].__setitem__(
        Ellipsis, 2.0 * h["scenes"][key]["natural_frequencies"][()]), "is not 2 pi x the lowest stored first"),
])
def test_verify_finds_damage_to_every_table(current, tmp_path, name, damage, words):
    """Every stored pair_holds inverted (a reader without the harness would get inverted verdicts; the
    verdict recomputed from the stored histories says which is right), the run records deleted, a column
    of the scene table deleted, a scene of a run that does not exist, a column a writer cannot append to,
    natural frequencies changed after the fact (omega1_min = 2 pi min f1 no longer holds)."""
    f, _ = damaged(current, tmp_path, name, damage)
    res = ked("inspect", str(f), "--verify")
    assert res.returncode == 1 and "INVALID" in res.stdout, res.stdout + res.stderr
    assert any(words in line for line in res.stdout.splitlines() if line.startswith("PROBLEM")), res.stdout


def test_a_column_a_writer_cannot_append_to_is_what_ked_run_meets(current, tmp_path):
    """The damage `--verify` reports as unwritable is damage `ked run` trips over (it saves the new scene
    elsewhere and names the file): the trial write of verify is the write of a run."""
    f, _ = damaged(current, tmp_path, "unwritable", widen_warnings)
    res = run(config(tmp_path, "more", rpm=[60.0, 90.0, 77.0]), f)
    assert res.returncode == 1 and str(f) in res.stderr, res.stdout + res.stderr


@pytest.mark.parametrize("label", [1, 3])
def test_a_label_that_contradicts_the_layout_is_refused_not_shown_empty(current, other, tmp_path, label):
    """A current file whose schema_version says 1 or 3: one line naming the file and the contradiction
    from inspect, --verify and merge (before: "0 scenes", "0 scene(s) added", exit 0)."""
    f, _ = damaged(current, tmp_path, f"label{label}", lambda h, key: h.attrs.__setitem__("schema_version", label))
    one_line(ked("inspect", str(f)), str(f), f"schema version label {label} contradicts the layout")
    res = ked("inspect", str(f), "--verify")
    assert res.returncode == 1 and f"label {label} contradicts the layout" in res.stdout, res.stdout
    dest = tmp_path / "dest.h5"
    shutil.copyfile(other, dest)
    before = dest.read_bytes()
    one_line(ked("merge", str(f), str(dest)), str(f), "contradicts the layout")
    assert dest.read_bytes() == before


def test_an_older_layouts_runs_are_checked_too(tmp_path):
    """A real version-3 file: its /runs deleted, or a scene of a run it does not record, is invalid."""
    for name, damage, words in (("no_runs", lambda h: h.__delitem__("runs"), "missing group /runs"),
                                ("no_run", lambda h: h["runs"].__delitem__("0006"), "run 6 is not in /runs")):
        f = tmp_path / f"{name}.h5"
        shutil.copyfile(DATA / "schema_v3.h5", f)
        assert store.verify(f) == []
        with h5py.File(f, "r+") as h:
            damage(h)
        assert any(words in p for p in store.verify(f)), (name, store.verify(f))


def test_a_version_2_file_labelled_1_is_refused(tmp_path):
    """A real version-2 file whose label says 1: read as version 1 its scenes have no solutions (before:
    merged as "2 scene(s) added")."""
    f = tmp_path / "v2as1.h5"
    shutil.copyfile(DATA / "schema_v2.h5", f)
    with h5py.File(f, "r+") as h:
        h.attrs["schema_version"] = 1
    dest = tmp_path / "dest.h5"
    one_line(ked("merge", str(f), str(dest)), str(f), "contradicts the layout")
    assert not dest.exists()
    assert any("contradicts the layout" in p for p in store.verify(f))


# -- merge: only what verifies ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name, damage, words", [
    ("history", scale_history, "differ from the histories"),
    ("status", lambda h, key: edit_rows(h, "scene_table", key, status="bogus"), "unknown status 'bogus'"),
])
def test_merge_carries_only_scenes_that_verify(current, other, tmp_path, name, damage, words):
    """A scene whose reference history was changed after the fact (its own file: INVALID) or whose status
    is unknown is refused by the merge with one line naming it and why, exit 1; the scene that verifies is
    carried; the destination stays valid and never shows the altered scene's verdict (before: merged as
    "ok", the destination valid, the verdict recomputed from the changed history)."""
    src, bad = damaged(current, tmp_path, name, damage)
    assert store.verify(src)  # INVALID in its own file
    dest = tmp_path / "dest.h5"
    shutil.copyfile(other, dest)
    res = ked("merge", str(src), str(dest))
    assert res.returncode == 1, res.stdout + res.stderr
    refused = [line for line in res.stderr.splitlines() if line.startswith("ked: refused scene")]
    assert len(refused) == 1 and bad in refused[0] and words in refused[0], res.stderr
    assert "1 scene(s) added" in res.stdout and "1 refused" in res.stdout, res.stdout
    stored = store.stored_status(dest)
    assert bad not in stored and len(stored) == 2, stored
    verify_ok(dest)
    shown = ked("inspect", str(dest))
    assert shown.returncode == 0 and bad[:8] not in shown.stdout, shown.stdout


@pytest.mark.parametrize("name, damage, words", [
    ("no_pair_holds", lambda h, key: h["metric_table"].__delitem__("pair_holds"), "missing column(s) pair_holds"),
    ("no_runs", lambda h, key: h.__delitem__("runs"), "missing table /runs"),
])
def test_merge_from_a_file_with_damaged_tables_merges_nothing(current, other, tmp_path, name, damage, words):
    """Damage of a table (not of one scene): one line naming the file and the problem, DEST unchanged."""
    src, _ = damaged(current, tmp_path, name, damage)
    dest = tmp_path / "dest.h5"
    shutil.copyfile(other, dest)
    before = dest.read_bytes()
    one_line(ked("merge", str(src), str(dest)), str(src), words)
    assert dest.read_bytes() == before


def test_merge_of_a_valid_file_says_nothing_refused(current, other, tmp_path):
    dest = tmp_path / "dest.h5"
    shutil.copyfile(other, dest)
    res = ked("merge", str(current), str(dest))
    assert res.returncode == 0 and "2 scene(s) added" in res.stdout and "refused" not in res.stdout + res.stderr
    verify_ok(dest)


def test_merge_help_states_what_is_refused_and_the_exit_status():
    res = ked("merge", "--help")
    assert res.returncode == 0 and "--verify" in res.stdout and "status 1" in res.stdout, res.stdout


# -- every file the harness writes is readable and verifiable ---------------------------------------------------


def test_the_atlas_file_is_verified_and_summarised():
    """The harness's own atlas (before: "not a ked-harness results file" from --verify, an error from inspect)."""
    res = ked("inspect", str(ATLAS), "--verify")
    assert res.returncode == 0 and "valid, atlas file" in res.stdout, res.stdout + res.stderr
    shown = ked("inspect", str(ATLAS))
    assert shown.returncode == 0 and "linkages drawn" in shown.stdout, shown.stdout + shown.stderr
    data = json.loads(ked("inspect", str(ATLAS), "--json").stdout)
    with h5py.File(ATLAS, "r") as h:  # the summary's counts, read independently with plain h5py
        assert data["linkages"] == int(h["linkages"].attrs["rows"])
        assert data["families"] == int(h["families"].attrs["rows"])
        assert sum(data["ratio_points_by_code"].values()) == h["families/code"].size


@pytest.mark.parametrize("name, damage, words", [
    ("short_column", lambda h: _truncate(h["families"], "history_error"), "/families/history_error"),
    ("bad_code", lambda h: h["families/code"].__setitem__((0, 0), 9), "/families/code"),
    ("no_ratios", lambda h: h.attrs.__delitem__("ratios"), "missing file attribute 'ratios'"),
])
def test_a_damaged_atlas_file_is_invalid(tmp_path, name, damage, words):
    f = tmp_path / f"{name}.h5"
    shutil.copyfile(ATLAS, f)
    with h5py.File(f, "r+") as h:
        damage(h)
    res = ked("inspect", str(f), "--verify")
    assert res.returncode == 1 and "INVALID" in res.stdout and words in res.stdout, res.stdout + res.stderr


def _truncate(g: h5py.Group, col: str) -> None:
    data, attrs = g[col][()][:-1], dict(g[col].attrs)
    del g[col]
    g.create_dataset(col, data=data).attrs.update(attrs)


def test_study_tables_are_checked(tmp_path):
    """A study file's /study tables are part of what --verify checks (a column shorter than its table)."""
    f = tmp_path / "study.h5"
    shutil.copyfile(ROOT / "results" / "studies" / "stability.h5", f)
    assert store.verify(f) == []
    with h5py.File(f, "r+") as h:
        name = sorted(h["study"])[0]
        _truncate(h["study"][name], sorted(tables.read_table(h["study"][name]))[0])
    assert any(p.startswith(f"/study/{name}/") for p in store.verify(f)), store.verify(f)
