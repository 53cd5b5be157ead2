"""Results lost or overwritten: the store under other solver lists, concurrent merges, mislabelled and
damaged files, read-only files as root; through the real command line in subprocesses on real files.

Every case here failed before its fix (a file lost solutions or scenes, or a command ended in a
traceback or wrote into a file it must leave alone).
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from compare import h5layout, h5legacy, store
from tests.test_campaign_store import edit_rows

BASE = """
[campaign]
name = "faults"
step_deg = 30.0
n_modes = 1
solvers = {solvers}
[grid]
mass_models = ["tip"]
rpm = {rpm}
[dynamic]
steps_per_cycle = 72
"""


def config(tmp: Path, name: str, solvers=("quasi_static", "linear"), rpm=(60.0, 90.0)) -> Path:
    p = tmp / f"{name}.toml"
    p.write_text(BASE.format(solvers=list(solvers).__repr__().replace("'", '"'), rpm=list(rpm)))
    return p


def ked(*args: str, timeout: float = 180, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ked_cli", *args], capture_output=True, text=True,
                          timeout=timeout, **kw)


def run(cfg: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    res = ked("run", str(cfg), "--out", str(out), "--workers", "1", "--no-figures", "--no-progress", *extra)
    return res


def one_line(res: subprocess.CompletedProcess, *words: str) -> str:
    """The command failed with one line on stderr, no traceback, naming ``words``."""
    assert res.returncode != 0, res.stdout[-500:]
    err = res.stderr.strip()
    assert "Traceback" not in err + res.stdout, err
    assert len(err.splitlines()) == 1, err
    for w in words:
        assert w in err, (w, err)
    return err


def histories(path: Path) -> dict[str, dict[str, dict[str, np.ndarray]]]:
    """key -> solver -> component -> history, read through the store."""
    return {r.key: {n: s.deflection for n, s in r.solutions.items()} for r in store.read_scenes(path)}


def verify_ok(path: Path) -> None:
    res = ked("inspect", str(path), "--verify")
    assert res.returncode == 0, res.stdout + res.stderr


# -- a rerun with another solver list keeps the solutions of the solvers not requested --------------------


def test_rerun_with_other_solvers_keeps_stored_solutions(tmp_path):
    out = tmp_path / "r.h5"
    first = run(config(tmp_path, "qd", ("quasi_static", "dynamic"), rpm=[60.0]), out)
    assert first.returncode == 0, first.stderr
    before = histories(out)
    assert all("dynamic" in v for v in before.values())
    second = run(config(tmp_path, "ql", ("quasi_static", "linear"), rpm=[60.0]), out)
    assert second.returncode == 0, second.stderr
    after = histories(out)
    assert set(after) == set(before)
    for key, sols in before.items():
        assert set(after[key]) == {"quasi_static", "dynamic", "linear"}, after[key].keys()
        for solver, comps in sols.items():  # the stored numbers, unchanged
            for c, h in comps.items():
                np.testing.assert_array_equal(after[key][solver][c], h)
    for r in store.read_scenes(out):  # every pair of the three solvers, the verdict against the reference
        assert set(r.metrics) == {"quasi_static_vs_linear", "quasi_static_vs_dynamic", "linear_vs_dynamic"}
        assert r.reference == "dynamic"
    verify_ok(out)


# -- ked merge holds the writer lock -----------------------------------------------------------------------


def split_into_files(src: Path, tmp: Path) -> list[Path]:
    """One results file per scene of ``src`` (written through the store, as a rescue file is)."""
    out = []
    for r in store.read_scenes(src):
        p = tmp / f"one-{r.key}.h5"
        run_no = store.record_run(p, "", "split", 1)
        store.commit(p, [r], run_no)
        out.append(p)
    return out


@pytest.fixture(scope="module")
def many(tmp_path_factory) -> Path:
    """A results file of 16 quasi-static scenes (quick)."""
    d = tmp_path_factory.mktemp("many")
    res = run(config(d, "many", ("quasi_static",), rpm=[30.0 + 5 * i for i in range(16)]), d / "many.h5")
    assert res.returncode == 0, res.stderr
    return d / "many.h5"


def test_concurrent_merges_keep_every_scene(many, tmp_path):
    srcs = split_into_files(many, tmp_path)
    dest = tmp_path / "dest.h5"
    procs = [subprocess.Popen([sys.executable, "-m", "ked_cli", "merge", str(s), str(dest)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for s in srcs]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    assert set(store.stored_status(dest)) == set(store.stored_status(many))  # every merge's scene is there
    assert store.file_info(dest)["n_runs"] == len(srcs)
    verify_ok(dest)


def test_merge_while_run_writes_loses_nothing(many, tmp_path):
    srcs = split_into_files(many, tmp_path)[:6]
    dest = tmp_path / "dest.h5"
    cfg = config(tmp_path, "busy", ("quasi_static", "linear"), rpm=[61.0, 62.0, 63.0, 64.0])
    writer = subprocess.Popen([sys.executable, "-m", "ked_cli", "run", str(cfg), "--out", str(dest), "--workers", "1",
                               "--no-figures", "--no-progress"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    lock = dest.with_name(dest.name + ".lock")
    while not lock.exists() and writer.poll() is None:  # the run has started writing
        time.sleep(0.02)
    merges = [subprocess.Popen([sys.executable, "-m", "ked_cli", "merge", str(s), str(dest)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True) for s in srcs]
    outs = [p.communicate(timeout=300) for p in merges]
    assert writer.wait(timeout=300) == 0, writer.stderr.read()
    assert all(p.returncode == 0 for p in merges), outs
    stored = store.stored_status(dest)
    merged = {k for s in srcs for k in store.stored_status(s)}
    assert merged <= set(stored)
    assert len(stored) == len(merged) + 4  # and the run's four scenes
    verify_ok(dest)


# -- an upgrade carries everything over or refuses -----------------------------------------------------------


@pytest.fixture(scope="module")
def current(tmp_path_factory) -> Path:
    """A results file of the current layout: two quasi-static + linear scenes."""
    d = tmp_path_factory.mktemp("current")
    res = run(config(d, "cur"), d / "cur.h5")
    assert res.returncode == 0, res.stderr
    return d / "cur.h5"


@pytest.mark.parametrize("label", [1, 2, 3])
def test_understated_schema_version_is_refused_not_upgraded(current, tmp_path, label):
    f = tmp_path / "mislabelled.h5"
    f.write_bytes(current.read_bytes())
    with h5py.File(f, "r+") as h:  # the layout is newer than the attribute says
        h.attrs["schema_version"] = label
    before = f.read_bytes()
    res = run(config(tmp_path, "more", rpm=[60.0, 90.0, 120.0]), f)
    one_line(res, str(f))
    assert f.read_bytes() == before  # nothing dropped, nothing rewritten
    assert not list(tmp_path.glob("mislabelled.h5.tmp-*"))


DATA = Path(__file__).resolve().parent / "data"
"""schema_v<N>.h5: real files of the older layouts, scene groups copied verbatim from committed results of
those versions (v1, v2: the regression reference; v3: the stability study with its /study tables, two
failed scenes, and a validity scene whose two linear solutions produced no histories)."""


def content(path: Path) -> tuple[dict, dict]:
    """What a reader sees: every scene's detail (as `ked inspect FILE SCENE --json` prints it, parsed) and the
    file attributes (without the schema version)."""
    import json

    from compare.inspect import scene_detail
    from ked_cli.options import json_text

    scenes = {r.key: json.loads(json_text(scene_detail(r), default=str)) for r in store.read_scenes(path)}
    info = {k: v for k, v in store.file_info(path).items() if k != "schema_version"}
    return scenes, info


def raw_numbers(path: Path) -> dict[str, np.ndarray]:
    """Every stored history and array, read with plain h5py (any layout): scene/solver/component -> values."""
    out = {}
    with h5py.File(path, "r") as h:
        for key, g in h["scenes"].items():
            for name in ("crank_angle", "coupler_point", "natural_frequencies"):
                out[f"{key}/{name}"] = g[name][()]
            sols = g["solutions"] if "solutions" in g else {n: g[n] for n in ("quasi_static", "dynamic") if n in g}
            for solver, s in sols.items():
                if isinstance(s, h5py.Dataset):
                    comps = [c for c in s.attrs["components"].split(",") if c]
                    out.update({f"{key}/{solver}/{c}": s[()][:, i] for i, c in enumerate(comps)})
                else:
                    out.update({f"{key}/{solver}/{c}": ds[()] for c, ds in s.items()})
    return out


@pytest.mark.parametrize("version", [1, 2, 3])
def test_upgrade_of_an_older_layout_keeps_every_number(tmp_path, version):
    """A real file of each older layout upgraded: what readers see is unchanged, every history equal."""
    f = tmp_path / f"v{version}.h5"
    f.write_bytes((DATA / f"schema_v{version}.h5").read_bytes())
    before, numbers = content(f), raw_numbers(f)
    with h5py.File(f, "r") as h:
        rows_before = {k: h5legacy.stored_metric_rows(g, version) for k, g in h["scenes"].items()}
        has_study = "study" in h
    assert store.upgrade(f) and store.verify(f) == []
    assert content(f) == before and len(before[0]) == len(rows_before)
    after = raw_numbers(f)
    assert set(after) == set(numbers) or version == 3  # v3: the (0, 0) solutions are no datasets now
    for k, v in numbers.items():
        if v.size:
            np.testing.assert_array_equal(after[k], v)
    with h5py.File(f, "r") as h:
        assert h.attrs["schema_version"] == store.SCHEMA_VERSION == 5
        view = h5layout.TableFile(h)
        for key, rows in rows_before.items():  # every stored metric number kept (v1 stored fewer fields)
            new = view.metric_rows(key)
            assert {k: {n: new[k][n] for n in row} for k, row in rows.items()} == rows
    if has_study:  # the study tables, copied as they are
        from ked_research import study_io

        old_tables, new_tables = study_io.read_tables(DATA / f"schema_v{version}.h5"), study_io.read_tables(f)
        assert old_tables[1] == new_tables[1] and old_tables[0].keys() == new_tables[0].keys()
        for name, cols in old_tables[0].items():
            for col, v in cols.items():
                np.testing.assert_array_equal(new_tables[0][name][col], v)
    assert not store.upgrade(f)  # once


def test_upgrade_through_ked_run_then_more_scenes(tmp_path):
    """`ked run` into a version-2 file: upgraded first, the old scenes kept as they were, new ones added."""
    f = tmp_path / "v2.h5"
    f.write_bytes((DATA / "schema_v2.h5").read_bytes())
    before = content(f)[0]
    res = run(config(tmp_path, "more", rpm=[60.0, 90.0]), f)
    assert res.returncode == 0, res.stderr
    after = content(f)[0]
    assert set(before) < set(after) and all(after[k] == v for k, v in before.items())
    verify_ok(f)


# -- a commit that fails on a damaged file saves the computed scenes -------------------------------------------


def damaged_copy(src: Path, tmp: Path) -> tuple[Path, object]:
    """A copy of ``src`` with 4 flipped bytes that the readers tolerate but that a commit of a new scene
    trips over (HDF5 finds the damage only when it rewrites that metadata), and that scene."""
    from compare.scenes import SpeedSpec

    r0 = store.read_scenes(src)[0]
    probe = dataclasses.replace(r0, spec=dataclasses.replace(r0.spec, speed=SpeedSpec("rpm", 77.0)))
    data = src.read_bytes()
    for off in range(0, len(data) - 4, 23):
        p = tmp / "damaged.h5"
        p.write_bytes(data[:off] + bytes(b ^ 0xFF for b in data[off:off + 4]) + data[off + 4:])
        try:
            store.read_scenes(p)
            store.file_info(p)
        except Exception:
            continue
        trial = tmp / "trial.h5"
        trial.write_bytes(p.read_bytes())
        try:
            store.commit(trial, [probe], 0)
        except Exception:  # the damage this test needs
            return p, probe
    raise AssertionError("no such damage found")


def test_failed_commit_on_damaged_file_is_a_commit_error_naming_the_file(current, tmp_path):
    """The runner saves the computed scenes in a rescue file on every CommitError (and only then):
    HDF5's own errors from a damaged file must arrive as one."""
    f, scene = damaged_copy(current, tmp_path)
    assert ked("inspect", str(f)).returncode == 0  # the damage is tolerated by the reader
    before = f.read_bytes()
    with pytest.raises(store.CommitError) as err:
        store.commit(f, [scene], 0)
    assert str(f) in str(err.value) and "\n" not in str(err.value)
    assert f.read_bytes() == before
    assert not list(tmp_path.glob("damaged.h5.tmp-*"))


def test_ked_run_on_a_file_with_flipped_bytes_loses_nothing(current, tmp_path):
    """Damage that `ked inspect` tolerates, then `ked run` with one more scene, through the command line:
    the run either stores the new scene (the commit's in-memory rewrite carries the file over) or ends with
    one line naming the file, the file unchanged, and the computed scene in the rescue file the line names;
    never a traceback.  (Before: an h5py OSError in the commit, no rescue file, a message without the file.)"""
    data = current.read_bytes()
    cfg = config(tmp_path, "more", rpm=[60.0, 90.0, 77.0])
    tried = 0
    for off in range(64, len(data) - 4, 509):
        f = tmp_path / f"flipped{off}.h5"
        f.write_bytes(data[:off] + bytes(b ^ 0xFF for b in data[off:off + 4]) + data[off + 4:])
        if ked("inspect", str(f)).returncode != 0:  # damage the reader reports is not this case
            f.unlink()
            continue
        before = f.read_bytes()
        res = run(cfg, f)
        assert "Traceback" not in res.stdout + res.stderr, res.stderr
        if res.returncode == 0:
            assert len(store.read_scenes(f)) == 3 and store.verify(f) == []
        else:
            line = res.stderr.strip().splitlines()[-1]
            assert res.returncode == 1 and line.startswith("ked: ") and str(f) in line, res.stderr
            assert f.read_bytes() == before
            if "are kept in " in line:  # computed, then the commit failed: the scene is in the rescue file
                rescue = Path(line.split("are kept in ")[1].split(";")[0])
                assert [r.spec.speed.value for r in store.read_scenes(rescue)] == [77.0]
        tried += 1
        if tried == 4:
            break
    assert tried == 4


# -- compact files ------------------------------------------------------------------------------------------

RESULTS = Path(__file__).resolve().parents[1] / "results"
LIMIT_BYTES = 5_000_000
ATLAS_LIMIT_BYTES = 10_000_000
"""The atlas holds 1000 linkages x 8 families x 18 speed ratios (twice the 500 of the first atlas, 3.5 MB)."""


def test_committed_results_files_are_compact_and_valid():
    """Every committed results file (campaign, study and atlas files) under 5 MB (the atlas under 10 MB) and
    at most 3x the bytes of the arrays it holds (numbers, and text by its length; schema version 3 had files
    at 7x: one group and ~30 attributes per scene); every campaign file passes the check of `ked inspect --verify`."""
    files = sorted(RESULTS.rglob("*.h5"))
    assert len(files) >= 16
    for f in files:
        limit = ATLAS_LIMIT_BYTES if f.name == "atlas.h5" else LIMIT_BYTES
        assert f.stat().st_size <= limit, (f, f.stat().st_size)
        assert store.size_ratio(f) <= 3.0, (f, store.size_ratio(f))
        with h5py.File(f, "r") as h:
            campaign = h.attrs.get("schema") == store.SCHEMA
        if campaign:
            assert store.verify(f) == [], f
            with h5py.File(f, "r") as h:
                assert h.attrs["schema_version"] == store.SCHEMA_VERSION, f
    res = ked("inspect", str(RESULTS / "reference" / "reference.h5"), "--verify")
    assert res.returncode == 0 and "valid" in res.stdout, res.stdout + res.stderr


# -- a read-only file stays untouched, also for root -----------------------------------------------------------


def test_read_only_results_file_is_not_replaced_even_by_root(current, tmp_path):
    """os.access says yes to root for any file; mode 444 still means: leave it alone."""
    f = tmp_path / "ro.h5"
    f.write_bytes(current.read_bytes())
    f.chmod(0o444)
    before = f.read_bytes()
    res = run(config(tmp_path, "more", rpm=[60.0, 90.0, 120.0]), f)
    one_line(res, str(f), "read-only")
    merge = ked("merge", str(current), str(f))
    one_line(merge, str(f), "read-only")
    assert f.read_bytes() == before and (f.stat().st_mode & 0o777) == 0o444


# -- ked inspect --verify reports damage (and nothing else) ------------------------------------------------------


def damage_copy(current: Path, tmp: Path, name: str, damage) -> Path:
    """A copy of ``current`` with ``damage(file, key)`` done to its first scene."""
    f = tmp / f"{name}.h5"
    f.write_bytes(current.read_bytes())
    with h5py.File(f, "r+") as h:
        damage(h, sorted(h["scenes"])[0])
    return f


def drop_column(g, solver: str, component: str) -> None:
    """The stored history ``solver/component`` deleted (the rest of the solution kept)."""
    ds = g["solutions"][solver]
    comps = ds.attrs["components"].split(",")
    keep = [i for i, c in enumerate(comps) if c != component]
    data, attrs = ds[()][:, keep], dict(ds.attrs)
    del g["solutions"][solver]
    new = g["solutions"].create_dataset(solver, data=data)
    new.attrs.update({**attrs, "components": ",".join(comps[i] for i in keep),
                      "units": ",".join(attrs["units"].split(",")[i] for i in keep)})


@pytest.mark.parametrize("name, damage, words", [
    ("no_metrics", lambda h, key: edit_rows(h, "metric_table", key, key=None), "missing metrics"),
    ("rpm_inf", lambda h, key: edit_rows(h, "scene_table", key, rpm=np.inf), "rpm inf"),
    ("no_dy", lambda h, key: drop_column(h["scenes"][key], "linear", "dy"), "history linear/dy missing"),
])
def test_verify_rejects_damage_and_inspect_never_shows_it_as_valid(current, tmp_path, name, damage, words):
    f = damage_copy(current, tmp_path, name, damage)
    res = ked("inspect", str(f), "--verify")
    assert res.returncode == 1 and words in res.stdout and "INVALID" in res.stdout, res.stdout + res.stderr
    shown = ked("inspect", str(f))
    assert shown.returncode == 0, shown.stderr
    if name != "no_metrics":  # the stored numbers are incomplete: no verdict, the scene marked damaged
        assert "2 scenes: 1 ok, 1 failed (1 damaged)" in shown.stdout, shown.stdout


def test_verify_survives_flipped_bytes_and_names_the_file(current, tmp_path):
    data = current.read_bytes()
    f = tmp_path / "flipped.h5"
    shown = []
    for off in range(0, len(data) - 4, 97):  # in-process: verify never raises on damage
        f.write_bytes(data[:off] + bytes(b ^ 0xFF for b in data[off:off + 4]) + data[off + 4:])
        problems = store.verify(f)
        if any("unreadable" in p for p in problems) and len(shown) < 3:
            shown.append(off)
    for off in shown:  # and through the command line: exit 1, the file named, no traceback
        f.write_bytes(data[:off] + bytes(b ^ 0xFF for b in data[off:off + 4]) + data[off + 4:])
        res = ked("inspect", str(f), "--verify")
        assert res.returncode == 1 and "Traceback" not in res.stdout + res.stderr, res.stderr
        assert all(str(f) in line for line in res.stdout.splitlines() if "unreadable" in line), res.stdout


def test_verify_does_not_call_a_live_writers_temp_file_stale(current, tmp_path):
    f = tmp_path / "live.h5"
    f.write_bytes(current.read_bytes())
    tmp = f.with_name(f.name + store.TMP_MARK + "12345-abcdef01")
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time\nfrom compare import store\n"
                               f"with store.writer_lock({str(f)!r}):\n    print('locked', flush=True)\n"
                               "    sys.stdin.readline()"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        tmp.write_bytes(b"being written")
        res = ked("inspect", str(f), "--verify")
        assert res.returncode == 0 and "stale" not in res.stdout, res.stdout
    finally:
        holder.communicate("\n", timeout=30)
    res = ked("inspect", str(f), "--verify")  # the writer is gone: now it is stale
    assert "stale" in res.stdout, res.stdout
