"""HDF5 store: round trip, atomic commits, verification (synthetic results, no solvers)."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from compare import h5file, store, tables
from compare.metrics import all_pairs
from compare.results import RunStats, SceneResult
from compare.scenes import SceneSpec, SpeedSpec
from compare.solvers import Solution
from ked_quasi import MassModel
from tests.conftest import small_fourbar

THETA = np.arange(12) * (2 * np.pi / 12)
F1 = 20 + np.cos(THETA)
"""[Hz] the synthetic first natural frequency over the cycle; omega1_min = 2 pi min F1 (as the harness
computes it, and --verify recomputes it)."""
OMEGA1_MIN = 2 * np.pi * float(F1.min())


def spec(rpm: float = 300.0, outputs=("dx", "dy", "rotation")) -> SceneSpec:
    return SceneSpec(
        linkage=small_fourbar(),
        mechanism="source", mass_model=MassModel("tip", payload=1.0), speed=SpeedSpec("rpm", rpm),
        stiffness_scale=1.0, damping_ratio=0.02, direction="ccw", step_deg=30.0, n_modes=2,
        outputs=tuple(outputs), tolerance=0.1, dynamic=(("damping_ratio", 0.02),),
    )


def ok_result(rpm: float = 300.0, outputs=("dx", "dy", "rotation")) -> SceneResult:
    s = spec(rpm, outputs)
    qs = {c: (i + 1) * 1e-3 * np.sin(THETA) for i, c in enumerate(outputs)}
    dyn = {c: 1.05 * v for c, v in qs.items()}
    solutions = {
        "quasi_static": Solution("quasi_static", "ok", qs, stats={"wall_s": 0.01}, fidelity=0),
        "dynamic": Solution("dynamic", "ok", dyn, settings={"damping_ratio": 0.02, "damping_reference_hz": None,
                                                            "sparse": False, "steps_per_cycle": 72},
                            stats={"wall_s": 3.0, "steps": 400, "cycles": 4, "converged": True}, fidelity=10),
    }
    return SceneResult(
        spec=s, status="ok", rpm=rpm, omega1_min=OMEGA1_MIN, crank_angle=THETA,
        coupler_point=np.column_stack([np.cos(THETA), np.sin(THETA)]),
        natural_frequencies=np.column_stack([F1, 50 + np.sin(THETA)]), solutions=solutions,
        metrics=all_pairs(THETA, {"quasi_static": qs, "dynamic": dyn}, {"quasi_static": 0, "dynamic": 10},
                          omega=rpm * np.pi / 30, omega1_min=OMEGA1_MIN, tolerance=0.1),
        stats=RunStats(1.0, 6.5, "host:1", "2026-01-01T00:00:00+00:00"),
    )


def failed_result() -> SceneResult:
    sols = {"quasi_static": Solution("quasi_static", "ok", {"dx": np.zeros(12)}),
            "dynamic": Solution("dynamic", "failed", message="Newton iteration did not converge",
                                error_type="SimulationError", failure_class="numerical")}
    return SceneResult(spec=spec(1000.0, outputs=("dx",)), status="failed", stage="dynamic",
                       error_type="SimulationError", message="Newton iteration did not converge", rpm=1000.0,
                       crank_angle=THETA, solutions=sols, failure_class="numerical")


def test_round_trip_preserves_everything(tmp_path):
    f = tmp_path / "r.h5"
    store.record_run(f, "[campaign]\nname='t'\n", "t", 2)
    a, b = ok_result(), failed_result()
    store.commit(f, [a, b], run=0)
    assert store.stored_status(f) == {a.key: "ok", b.key: "failed"}
    ra, rb = (store.read_scenes(f, [k])[0] for k in (a.key, b.key))
    assert ra.spec == a.spec and ra.key == a.key and ra.status == "ok"
    for side in ("quasi_static", "dynamic"):
        for c in ("dx", "dy", "rotation"):
            np.testing.assert_array_equal(getattr(ra, side)[c], getattr(a, side)[c])
    np.testing.assert_array_equal(ra.natural_frequencies, a.natural_frequencies)
    assert ra.metrics == a.metrics  # recomputed on reading from the stored histories
    assert ra.stats == a.stats
    assert ra.dynamic_settings == a.dynamic_settings
    assert ra.solutions["dynamic"].stats == a.solutions["dynamic"].stats
    assert rb.status == "failed" and rb.stage == "dynamic" and "Newton" in rb.message and rb.verdict is None
    assert rb.failure_class == "numerical" and rb.solutions["dynamic"].failure_class == "numerical"
    assert store.verify(f) == []


def test_only_requested_outputs_are_stored(tmp_path):
    f = tmp_path / "r.h5"
    store.record_run(f, "", "t", 1)
    r = ok_result(outputs=("dy",))
    store.commit(f, [r])
    with h5py.File(f, "r") as h:
        g = h["scenes"][r.key]
        assert g["solutions/quasi_static"].attrs["components"] == "dy" == g["solutions/dynamic"].attrs["components"]
        assert g["solutions/dynamic"].shape == (12, 1)
        assert g["solutions/dynamic"].attrs["units"] == "m"
        mine = h["metric_table/key"][()] == r.key.encode()  # the tables, read with plain h5py
        assert {c.decode() for c in h["metric_table/component"][()][mine]} == {"dy"}
        row = list(h["scene_table/key"][()]).index(r.key.encode())
        assert h["scene_table/crank_m"][row] == 0.1 and h["scene_table/crank_m"].attrs["units"] == "m"
    assert store.verify(f) == []


def test_file_attributes_and_run_records(tmp_path):
    f = tmp_path / "r.h5"
    store.record_run(f, "text one", "first", 3)
    created = store.file_info(f)["created_utc"]
    assert store.record_run(f, "text two", "second", 4) == 1
    info = store.file_info(f)
    assert info["schema"] == store.SCHEMA and info["created_utc"] == created
    assert info["campaign_config"] == "text two" and info["n_runs"] == 2
    for k in ("harness_version", "exudyn_version", "numpy_version", "git_commit"):
        assert k in info


def test_failed_transaction_leaves_file_untouched(tmp_path):
    f = tmp_path / "r.h5"
    store.record_run(f, "", "t", 1)
    store.commit(f, [ok_result(100.0)])
    before = f.read_bytes()
    with pytest.raises(RuntimeError):
        with store.transaction(f) as h:
            h.create_group("scenes/garbage")
            raise RuntimeError("crash in the middle of a write")
    assert f.read_bytes() == before
    assert store.stale_temp_files(f) == []


def test_replacing_a_scene_keeps_it_exactly_once(tmp_path):
    f = tmp_path / "r.h5"
    store.record_run(f, "", "t", 1)
    store.commit(f, [failed_result()])
    store.commit(f, [failed_result()])
    assert len(store.read_scenes(f)) == 1


def replace_solution(g, solver, cut, components):
    """Damage: the solution dataset of ``solver`` replaced by ``cut`` of its data, attributes kept."""
    old = g["solutions"][solver]
    data, attrs = cut(old[()]), dict(old.attrs)
    del g["solutions"][solver]
    new = g["solutions"].create_dataset(solver, data=data)
    new.attrs.update({**attrs, "components": components})


def edit_rows(h: h5py.File, table: str, scene: str, **changes) -> None:
    """Damage: the rows of scene key ``scene`` in ``table`` changed (column -> new value; key=None deletes
    the rows), the table rewritten with its column types."""
    cols, kinds = tables.read_table(h[table]), tables.kinds_of(h[table])
    mine = cols["key"] == scene
    for col, value in changes.items():
        if value is None:
            cols = {c: v[~mine] for c, v in cols.items()}
            mine = mine[~mine]
        else:
            cols[col] = cols[col].copy()
            cols[col][mine] = value
    tables.write_table(h, table, cols, kinds=kinds)


def test_verify_detects_damage_and_readers_skip_incomplete_groups(tmp_path):
    good = tmp_path / "good.h5"
    store.record_run(good, "", "t", 1)
    r = ok_result()
    store.commit(good, [r])
    cases = {
        "incomplete": lambda h: edit_rows(h, "scene_table", r.key, complete=0),
        "content key": lambda h: edit_rows(h, "scene_table", r.key, json=spec(123.0).canonical_json()),
        "missing history dynamic/dx": lambda h: replace_solution(h["scenes"][r.key], "dynamic", lambda d: d[:, 1:],
                                                                 "dy,rotation"),
        "shape": lambda h: replace_solution(h["scenes"][r.key], "quasi_static", lambda d: d[:1], "dx,dy,rotation"),
        "differ from the histories": lambda h: edit_rows(h, "metric_table", r.key, holds=0),
        "no row in /scene_table": lambda h: h["scenes"].create_group("0123456789abcdef"),
    }
    for words, damage in cases.items():
        bad = tmp_path / f"bad_{words.split()[0]}.h5"
        shutil.copyfile(good, bad)
        with h5py.File(bad, "a") as h:
            damage(h)
        problems = store.verify(bad)
        assert any(words in p for p in problems), (words, problems)
    assert store.read_scenes(tmp_path / "bad_incomplete.h5") == []
    not_hdf5 = tmp_path / "x.h5"
    not_hdf5.write_bytes(b"garbage")
    assert "cannot open" in store.verify(not_hdf5)[0]


def test_stale_temp_files_are_ignored_and_cleaned(tmp_path):
    f = tmp_path / "r.h5"
    store.record_run(f, "", "t", 1)
    stale = tmp_path / "r.h5.tmp-99999-deadbeef"
    stale.write_bytes(b"half-written")
    assert store.stale_temp_files(f) == [stale]
    assert store.verify(f) == []
    assert store.remove_stale_temp_files(f) == 1 and not stale.exists()


def test_second_writer_is_refused_while_a_campaign_writes(tmp_path):
    from compare.config import parse_config
    from compare.runner import run_campaign

    f = tmp_path / "r.h5"
    with store.writer_lock(f):
        with pytest.raises(store.LockedError, match="another process"):
            run_campaign(parse_config(""), f, workers=1, progress=False)
    assert not f.exists()
    assert not (tmp_path / "r.h5.lock").exists()


def test_many_small_commits_keep_the_file_compact(tmp_path):
    """Each commit rewrites the tables; the space they leave is reused or, past a quarter of the file,
    the commit rewrites the file compactly: 60 one-scene commits end within 1.4x of a fresh rewrite
    of the same content (before: 40 kB of free space more per commit)."""
    f = tmp_path / "r.h5"
    store.record_run(f, "", "t", 60)
    for i in range(60):
        store.commit(f, [ok_result(100.0 + i)])
    assert len(store.stored_status(f)) == 60 and store.verify(f) == []
    fresh = tmp_path / "fresh.h5"
    h5file._repack(shutil.copyfile(f, fresh))  # the same objects copied into a new file
    assert f.stat().st_size <= 1.4 * fresh.stat().st_size, (f.stat().st_size, fresh.stat().st_size)
