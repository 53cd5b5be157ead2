"""Results files that describe themselves: every column's description and unit against what is stored,
HDF5 dimension scales read by xarray (h5netcdf engine) as named dimensions, and ``compare.open_results``
round-tripping every stored history and table column.

The file is a real small campaign (quasi-static and linear solvers, 30 deg grid: a few seconds), written by
``run_campaign`` through the store's commits (each one copies and repacks the file).
"""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from compare import h5dims, h5layout, store, tables
from compare.config import parse_config
from compare.runner import run_campaign

xr = pytest.importorskip("xarray")
pd = pytest.importorskip("pandas")
pytest.importorskip("h5netcdf")

CONFIG = """
[campaign]
name = "labelled"
step_deg = 30.0
n_modes = 2
solvers = ["quasi_static", "linear"]
[grid]
mass_models = ["tip", "distributed"]
rpm = [60.0, 600.0]
"""
TABLE_NAMES = ("runs", "scene_table", "solution_table", "metric_table")
ALLOWED_UNITS = {"", "1", "row", "m", "rad", "rad/s", "rev/min", "Hz", "Pa", "m^2", "m^4", "kg", "kg/m^3", "deg",
                 "s"}
"""SI units of the schema (docs/hdf5_schema.md): "" text, "1" dimensionless, "row" the row's units column."""
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("labelled") / "labelled.h5"
    summary = run_campaign(parse_config(CONFIG), out, workers=1, progress=False)
    # the tip-mass scene at 600 rpm fails in the linear solver (a Floquet multiplier above 1: parametric
    # resonance), so the file holds a failed scene with the quasi-static histories only
    assert (summary.ok, summary.failed) == (3, 1) and store.verify(out) == []
    return out


def _text(v) -> str:
    return v.decode("utf-8") if isinstance(v, bytes) else str(v)


def _vector_error(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """The vector verdict from its definition (docs/hdf5_schema.md): max_k |d_a,k - d_b,k| / max_k |d_b,k|,
    d = (dx, dy) the deflection vector of P, |.| the Euclidean norm."""
    da, db = np.column_stack([a["dx"], a["dy"]]), np.column_stack([b["dx"], b["dy"]])
    return float(np.max(np.linalg.norm(da - db, axis=1)) / np.max(np.linalg.norm(db, axis=1)))


def _histories(f: h5py.File, key: str) -> dict[str, dict[str, np.ndarray]]:
    out = {}
    for solver, ds in f["scenes"][key]["solutions"].items():
        comps = _text(ds.attrs["components"]).split(",")
        out[solver] = {c: ds[()][:, i] for i, c in enumerate(comps)}
    return out


def test_every_column_is_described_with_a_unit_of_the_schema(campaign):
    with h5py.File(campaign, "r") as f:
        for name in TABLE_NAMES:
            declared = h5layout._COLUMNS[name]
            for col, ds in tables.column_items(f[name]):
                units, description = _text(ds.attrs["units"]), _text(ds.attrs["description"])
                where = f"/{name}/{col}"
                assert description.strip(), where
                assert "older layout" not in description, (where, description)  # a fresh file carries nothing
                assert units in ALLOWED_UNITS, (where, units)
                assert (units == "") == (ds.dtype.kind in "OS"), (where, units, ds.dtype)  # "" only for text
                assert (units, description) == declared[col], where  # what the code declares
        for g in f["scenes"].values():
            for name in ("crank_angle", "coupler_point", "natural_frequencies"):
                assert (_text(g[name].attrs["units"]), _text(g[name].attrs["description"])) == h5layout.ARRAYS[name]
            for solver, ds in g["solutions"].items():
                comps = _text(ds.attrs["components"]).split(",")
                assert _text(ds.attrs["units"]).split(",") == [{"dx": "m", "dy": "m", "rotation": "rad"}[c]
                                                               for c in comps]
                assert solver in _text(ds.attrs["description"])


def test_verdict_columns_hold_and_describe_the_vector_verdict(campaign):
    """verdict_error recomputed from the stored histories (the vector (dx, dy) error, its definition written
    out here) in every row of every pair; pair_holds is it below the tolerance; the descriptions say so."""
    checked = 0
    with h5py.File(campaign, "r") as f:
        m = tables.read_table(f["metric_table"])
        for name, words in (("verdict_error", "deflection vector (dx, dy)"), ("pair_holds", "verdict_error")):
            description = _text(f["metric_table"][name].attrs["description"])
            assert words in description and "every scalar component" not in description, description
        assert "rotation" not in _text(f["metric_table/verdict_error"].attrs["description"]).split(";")[0]
        for i, key in enumerate(m["key"]):
            h = _histories(f, key)
            want = _vector_error(h[m["solver"][i]], h[m["reference"][i]])
            assert m["verdict_error"][i] == pytest.approx(want, rel=1e-12, abs=0.0), (key, m["component"][i])
            assert bool(m["pair_holds"][i]) == (want < m["tolerance"][i])
            checked += 1
    assert checked == 3 * 4  # 3 ok scenes x 1 pair x (dx, dy, rotation, vector)


def test_older_verdict_rows_are_described_as_such_after_an_upgrade(tmp_path):
    """A version-1 file stores the worst of dx, dy, rotation in its pair columns; the upgrade keeps those
    numbers and the description names them (rows whose verdict_error differs from the vector row's)."""
    f = tmp_path / "v1.h5"
    shutil.copyfile(DATA / "schema_v1.h5", f)
    assert store.upgrade(f) and store.verify(f) == []
    with h5py.File(f, "r") as h:
        m = tables.read_table(h["metric_table"])
        vec = {(k, s, r): e for k, s, r, c, e in zip(m["key"], m["solver"], m["reference"], m["component"],
                                                     m["history_error"]) if c == "vector"}
        older = sum(v != vec[(k, s, r)] for k, s, r, v in zip(m["key"], m["solver"], m["reference"],
                                                                m["verdict_error"]))
        assert older > 0
        for name in ("verdict_error", "pair_holds"):
            assert f"{older} of {len(m['key'])} rows" in _text(h["metric_table"][name].attrs["description"])
        assert "older layout" not in _text(h["runs/harness_version"].attrs["description"])


def _all_groups(path: Path) -> list[str]:
    with h5py.File(path, "r") as f:
        keys = list(f["scenes"])
    return [*TABLE_NAMES, *(f"scenes/{k}" for k in keys), *(f"scenes/{k}/solutions" for k in keys)]


def test_xarray_reads_named_dimensions_and_a_crank_angle_coordinate(campaign):
    for group in _all_groups(campaign):
        with xr.open_dataset(campaign, group=group, engine="h5netcdf") as ds:
            assert not [d for d in ds.sizes if str(d).startswith("phony_dim")], (group, dict(ds.sizes))
    with h5py.File(campaign, "r") as f:
        key = next(iter(f["scenes"]))
        theta = f["scenes"][key]["crank_angle"][()]
        dy = _histories(f, key)["linear"]["dy"]
        n_scenes = int(f["scene_table"].attrs["rows"])
    with xr.open_dataset(campaign, group=f"scenes/{key}", engine="h5netcdf") as ds:
        assert ds["crank_angle"].attrs["units"] == "rad"
        np.testing.assert_array_equal(ds["crank_angle"].values, theta)
        assert ds["natural_frequencies"].dims == ("crank_angle", "mode")
        assert ds["coupler_point"].dims == ("crank_angle", "xy") and list(ds["xy"].values) == ["x", "y"]
        assert list(ds["component"].values) == ["dx", "dy", "rotation"]
    with xr.open_dataset(campaign, group=f"scenes/{key}/solutions", engine="h5netcdf") as ds:
        assert ds["linear"].dims == ("crank_angle", "component")
        np.testing.assert_array_equal(ds["linear"].values[:, 1], dy)
    with xr.open_dataset(campaign, group="scene_table", engine="h5netcdf") as ds:
        assert ds.sizes["scene"] == n_scenes and ds["youngs_modulus_Pa"].dims == ("scene", "link")
        assert ds["crank_pivot_m"].dims == ("scene", "xy")
    with xr.open_dataset(campaign, engine="h5netcdf") as ds:  # the inner dimensions' labels, at the root
        assert list(ds["link"].values) == ["crank", "coupler", "extender", "follower"]
        assert list(ds["xy"].values) == ["x", "y"]
    with h5py.File(campaign, "r") as f:  # a reader of the layout before the scales sees only columns
        for name in TABLE_NAMES:
            n = int(f[name].attrs["rows"])
            assert all(ds.shape[0] == n and "units" in ds.attrs for ds in f[name].values()), name


def test_an_upgraded_older_file_gets_the_dimensions(tmp_path):
    f = tmp_path / "v3.h5"
    shutil.copyfile(DATA / "schema_v3.h5", f)
    assert store.upgrade(f) and store.verify(f) == []
    for group in _all_groups(f):
        with xr.open_dataset(f, group=group, engine="h5netcdf") as ds:
            assert not [d for d in ds.sizes if str(d).startswith("phony_dim")], (group, dict(ds.sizes))


def test_open_results_round_trips_every_history_and_table_column(campaign):
    from compare import open_results

    res = open_results(campaign)
    with h5py.File(campaign, "r") as f:
        for name, df in (("scene_table", res.scenes), ("solution_table", res.solutions),
                         ("metric_table", res.metrics), ("runs", res.runs)):
            stored = tables.read_table(f[name])
            assert set(df.columns) == set(stored) and len(df) == tables.n_rows(f[name]), name
            for col, values in stored.items():
                got = np.array(df[col].tolist()) if values.ndim > 1 else df[col].to_numpy()
                if values.dtype.kind == "O":
                    assert list(got) == list(values), (name, col)
                else:
                    np.testing.assert_array_equal(got, values, err_msg=f"{name}/{col}")
                assert df.attrs["units"][col] == _text(f[name][col].attrs["units"])
        h = res.histories
        keys = [_text(k) for k in f["scene_table/key"][()]]
        assert list(h["scene"].values) == keys
        stored_histories = 0
        for key in keys:
            g = f["scenes"][key]
            theta = g["crank_angle"][()]
            at = h.sel(scene=key, crank_angle=theta)
            for solver, comps in _histories(f, key).items():
                for c, values in comps.items():
                    np.testing.assert_array_equal(at[c].sel(solver=solver).values, values)
                    stored_histories += 1
            np.testing.assert_array_equal(at["coupler_point"].values, g["coupler_point"][()])
            np.testing.assert_array_equal(at["natural_frequencies"].values, g["natural_frequencies"][()])
        assert stored_histories == (3 * 2 + 1) * 3  # the failed scene: quasi-static only
        failed = [k for k, s in zip(keys, f["scene_table/status"][()]) if s == b"failed"]
        assert len(failed) == 1 and np.isnan(h["dx"].sel(scene=failed[0], solver="linear").values).all()
        row = tables.read_table(f["scene_table"])
        for col in ("mechanism", "mass_model", "rpm", "damping_ratio", "stiffness_scale", "direction"):
            assert list(h[col].values) == list(row[col]), col
        ratio = row["rpm"] * (math.pi / 30) / row["omega1_min_rad_s"]
        np.testing.assert_allclose(h["speed_ratio"].values, ratio, rtol=1e-15)
        np.testing.assert_array_equal(h["youngs_modulus_Pa"].values, row["youngs_modulus_Pa"])
    assert h["dy"].attrs["units"] == "m" and h["rotation"].attrs["units"] == "rad"


def test_open_results_without_the_extra_names_it(campaign, monkeypatch):
    from compare import open_results

    monkeypatch.setitem(sys.modules, "xarray", None)  # as if not installed: importing it raises ImportError
    with pytest.raises(ImportError) as err:
        open_results(campaign)
    assert "ked-harness[xarray]" in str(err.value) and "\n" not in str(err.value)


def test_open_results_refuses_an_older_layout_in_one_line(tmp_path):
    from compare import open_results

    f = tmp_path / "v2.h5"
    shutil.copyfile(DATA / "schema_v2.h5", f)
    with pytest.raises(store.StoreError, match="schema version 2") as err:
        open_results(f)
    assert "\n" not in str(err.value)


def _strip_dimensions(path: Path) -> None:
    """Make ``path`` a version-4 file as written before the dimension scales: no scales, no attachments."""
    with h5py.File(path, "r+") as f:
        for name in TABLE_NAMES:
            for d in tables.dimension_names(f[name]):
                del f[name][d]
            del f[name].attrs[tables.DIMENSIONS]
        for d in h5dims.INNER_DIMENSIONS:
            del f[d]
        for g in f["scenes"].values():
            for d in ("component", "xy", "mode"):
                if d in g:
                    del g[d]

        def drop(_name, obj):
            if isinstance(obj, h5py.Dataset):
                for a in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME"):
                    if a in obj.attrs:
                        del obj.attrs[a]
        f.visititems(drop)


def test_a_version_4_file_without_dimension_scales_reads_and_gets_them_at_its_next_commit(campaign, tmp_path):
    f = tmp_path / "before.h5"
    shutil.copyfile(campaign, f)
    _strip_dimensions(f)
    with h5py.File(f, "r") as h:
        assert not any("CLASS" in ds.attrs for ds in h["scene_table"].values())
    key = next(k for k, s in store.stored_status(f).items() if s == "ok")
    with xr.open_dataset(f, group=f"scenes/{key}", engine="h5netcdf", phony_dims="sort") as ds:
        assert any(str(d).startswith("phony_dim") for d in ds.sizes)  # what readers saw before
    assert store.verify(f) == []
    before = store.read_scenes(f)
    assert [r.metrics for r in before] == [r.metrics for r in store.read_scenes(campaign)]
    from compare import open_results

    a, b = open_results(f), open_results(campaign)
    assert a.histories.identical(b.histories) and a.metrics.equals(b.metrics)
    store.commit(f, before[:1])  # the next commit (here: a scene rewritten as it was)
    assert store.verify(f) == []
    for group in _all_groups(f):
        with xr.open_dataset(f, group=group, engine="h5netcdf") as ds:
            assert not [d for d in ds.sizes if str(d).startswith("phony_dim")], (group, dict(ds.sizes))


def test_scenes_of_different_crank_grids_share_one_crank_angle_coordinate(tmp_path):
    """A 30 deg and a 15 deg scene: the coordinate is the union grid (24 angles), the coarse scene's
    histories sit on every second angle, NaN between (no interpolation)."""
    import dataclasses

    from compare import open_results
    from tests.test_campaign_store import ok_result, spec

    coarse = ok_result(300.0)
    theta = np.arange(24) * (2 * np.pi / 24)
    qs = {c: (i + 1) * 1e-3 * np.cos(theta) for i, c in enumerate(("dx", "dy", "rotation"))}
    fine = dataclasses.replace(
        ok_result(400.0), spec=dataclasses.replace(spec(400.0), step_deg=15.0), crank_angle=theta,
        coupler_point=np.column_stack([np.cos(theta), np.sin(theta)]),
        natural_frequencies=np.column_stack([20 + np.cos(theta), 50 + np.sin(theta)]), metrics={},
        solutions={"quasi_static": dataclasses.replace(coarse.solutions["quasi_static"], deflection=qs)})
    f = tmp_path / "grids.h5"
    store.record_run(f, "", "t", 2)
    store.commit(f, [coarse, fine])
    h = open_results(f).histories
    np.testing.assert_allclose(h["crank_angle"].values, theta, rtol=0, atol=1e-12)
    dx = h["dx"].sel(solver="quasi_static")
    np.testing.assert_array_equal(dx.sel(scene=fine.key).values, qs["dx"])
    c = dx.sel(scene=coarse.key).values
    np.testing.assert_array_equal(c[::2], coarse.solutions["quasi_static"].deflection["dx"])
    assert np.isnan(c[1::2]).all()
    assert np.isnan(h["dx"].sel(scene=fine.key, solver="dynamic").values).all()  # a solver it did not run


def test_ked_inspect_verify_passes_on_the_file(campaign):
    from click.testing import CliRunner

    from ked_cli.main import cli

    res = CliRunner().invoke(cli, ["inspect", str(campaign), "--verify"])
    assert res.exit_code == 0, res.output


def test_units_of_study_and_atlas_columns_follow_the_convention(tmp_path):
    """A table written without declared units (the study and atlas tables): the unit the name states, "1"
    for another number, "" for text."""
    with h5py.File(tmp_path / "t.h5", "w") as f:
        tables.write_table(f, "t", {"rpm": [60.0], "wall_s": [1.0], "error": [0.1], "ok": [True], "lumps": [5],
                                    "label": ["a"]}, integers=True)
        got = {c: _text(ds.attrs["units"]) for c, ds in f["t"].items()}
    assert got == {"rpm": "rev/min", "wall_s": "s", "error": "1", "ok": "1", "lumps": "1", "label": ""}


def test_open_results_leaves_incomplete_scenes_out_of_the_histories(campaign, tmp_path):
    """As every reader of the harness: a scene row without complete = 1 is not a result (its table row is
    still in the DataFrame, as stored)."""
    from compare import open_results
    from tests.test_campaign_store import edit_rows

    f = tmp_path / "incomplete.h5"
    shutil.copyfile(campaign, f)
    key = sorted(store.stored_status(f))[0]
    with h5py.File(f, "r+") as h:
        edit_rows(h, "scene_table", key, complete=0)
    res = open_results(f)
    assert key not in list(res.histories["scene"].values) and res.histories.sizes["scene"] == 3
    assert key in list(res.scenes["key"]) and len(res.scenes) == 4
