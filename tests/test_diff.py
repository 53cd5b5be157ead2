"""`ked diff` and the tolerances / expectations behind it, against real campaign files.

The baseline is a real campaign (thesis linkage, quasi-static and linear solvers: no Exudyn, about a second);
each perturbation copies it and edits one thing with h5py, the way a changed code or machine would change a
stored answer.  What each test expects follows from the perturbation: a history scaled by 1.01 drifts by 1 % of
its peak (beyond the 1e-9 of the `same` tier); a verdict flips when the quasi-static history is scaled so that its
error crosses the 10 % tolerance; a removed, failed or NaN scene is a failure by definition.
"""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from compare import store
from compare.config import ConfigError, parse_config
from compare.diff import diff_files, diff_results, format_report
from compare.expect import Expectations, check_expectations
from compare.runner import run_campaign
from compare.tolerances import DEFAULTS, parse_tolerances
from ked_cli.main import cli

CAMPAIGN = """
[campaign]
name = "small"
step_deg = 30.0
n_modes = 2
solvers = ["quasi_static", "linear"]
[grid]
mass_models = ["extender", "tip"]
rpm = [60.0, 300.0]
"""
EXT300 = "source/extender/300rpm/k1/z0.02/ccw"  # quasi-static error 9 % of the linear reference: holds
TIP60 = "source/tip/60rpm/k1/z0.02/ccw"


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    d = tmp_path_factory.mktemp("diff")
    out = d / "base.h5"
    run_campaign(parse_config(CAMPAIGN), out, workers=1, progress=False)
    return out


def _copy(baseline, tmp_path, name="new.h5"):
    p = tmp_path / name
    shutil.copy(baseline, p)
    return p


def _row(f, label):
    return [x.decode() for x in f["scene_table/label"][()]].index(label)


def _key(f, label):
    return f["scene_table/key"][_row(f, label)].decode()


def _set_column(f, name, i, value):
    """Set one cell of a fixed-width text column, widening the column where the value is longer."""
    ds = f[f"scene_table/{name}"]
    data = [x.decode() for x in ds[()]]
    data[i] = value
    attrs = dict(ds.attrs)
    del f[f"scene_table/{name}"]
    new = f.create_dataset(f"scene_table/{name}", data=np.array([x.encode() for x in data]))
    new.attrs.update(attrs)


def _diff(base, new, *args):
    return CliRunner().invoke(cli, ["diff", str(base), str(new), *args])


def _failures(rep):
    return {(s.label, c.check, c.solver, c.quantity) for s in rep.scenes for c in s.checks if not c.passed}


def test_identical_rerun_passes(baseline, tmp_path):
    rerun = tmp_path / "rerun.h5"
    run_campaign(parse_config(CAMPAIGN), rerun, workers=1, progress=False)
    rep = diff_files(baseline, rerun)
    assert rep.passed, format_report(rep)
    assert rep.counts()["matched_by_key"] == 4
    res = _diff(baseline, rerun)
    assert res.exit_code == 0 and "PASS: 4 of 4" in res.output
    # scenes stored identically are judged from the tables: the same checks as reading them in full
    full = diff_results(store.read_scenes(baseline), store.read_scenes(rerun))
    assert {(c.scene, c.check, c.solver, c.quantity, c.bound, c.tier, c.passed) for s in rep.scenes
            for c in s.checks} == {(c.scene, c.check, c.solver, c.quantity, c.bound, c.tier, c.passed)
                                   for s in full.scenes for c in s.checks}


def test_history_scaled_by_one_percent_fails_naming_scene_and_quantity(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        ds = f[f"scenes/{_key(f, TIP60)}/solutions/linear"]
        comps = ds.attrs["components"].split(",")
        data = ds[()]
        data[:, comps.index("dy")] *= 1.01
        ds[...] = data
    rep = diff_files(baseline, new)
    assert not rep.passed
    hist = [c for s in rep.scenes for c in s.checks if c.check == "history" and not c.passed]
    assert [(c.scene, c.solver, c.quantity) for c in hist] == [(TIP60, "linear", "dy")]
    assert hist[0].value == pytest.approx(0.01, rel=1e-9)  # max|1.01 h - h| / max|h| = 0.01
    res = _diff(baseline, new)
    assert res.exit_code == 1
    assert TIP60[:30] in res.output and "linear/dy" in res.output
    assert all(len(line) <= 100 for line in res.output.splitlines())


def test_verdict_flip_fails(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        ds = f[f"scenes/{_key(f, EXT300)}/solutions/quasi_static"]
        ds[...] = ds[()] * 0.8  # 9 % error -> at least 20 % - 9 % x 0.8 > 10 %: the verdict flips to fails
    rep = diff_files(baseline, new)
    flips = [c for s in rep.scenes for c in s.checks if c.check == "verdict" and not c.passed]
    assert [(c.scene, c.quantity, c.value) for c in flips] == [(EXT300, "quasi_static_vs_linear", "holds -> fails")]
    assert rep.failed_scenes[0].label == EXT300
    assert _diff(baseline, new).exit_code == 1


def test_removed_scene_fails_as_missing(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        f["scene_table/complete"][_row(f, TIP60)] = 0  # an incomplete scene is not a scene of the file
    rep = diff_files(baseline, new)
    assert _failures(rep) == {(TIP60, "missing", "", "scene")}
    res = _diff(new, baseline)  # the other way round: the scene is added
    assert res.exit_code == 1 and "added" in res.output


def test_failed_scene_fails_on_status(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        _set_column(f, "status", _row(f, EXT300), "failed")
    rep = diff_files(baseline, new)
    assert (EXT300, "status", "", "scene") in _failures(rep)
    assert {s for s, *_ in _failures(rep)} == {EXT300}


def test_nan_fails_naming_solver_and_component(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        ds = f[f"scenes/{_key(f, TIP60)}/solutions/quasi_static"]
        data = ds[()]
        data[3, ds.attrs["components"].split(",").index("dx")] = np.nan
        ds[...] = data
    rep = diff_files(baseline, new)
    fails = _failures(rep)
    assert (TIP60, "finite", "quasi_static", "dx") in fails
    assert (TIP60, "status", "", "scene") in fails  # the reader withholds a damaged scene's verdict


def test_expectation_violated_names_scene_quantity_value_and_bound(baseline, tmp_path):
    tol = tmp_path / "tol.toml"
    tol.write_text(f"[expect]\nverdict_error_below = {{ tip = 0.05 }}\nholds = [\"{EXT300}\"]\n")
    res = _diff(baseline, baseline, "--tolerances", str(tol), "--json")
    assert res.exit_code == 1
    out = json.loads(res.output)
    v = {(e["scene"], e["quantity"]) for e in out["expectations"]}
    # the tip mass at 60 rpm: 6.1 % (> 5 %); at 300 rpm: 99.9 %; the extender scene holds as expected
    assert v == {(TIP60, "verdict_error"), ("source/tip/300rpm/k1/z0.02/ccw", "verdict_error")}
    e = next(e for e in out["expectations"] if e["scene"] == TIP60)
    assert e["value"] > 0.05 and "< 0.05" in e["bound"] and TIP60 in e["message"]


def test_expectations_api_and_inspect(baseline):
    results = store.read_scenes(baseline)
    assert check_expectations(results, Expectations(holds_below_speed_ratio=0.2)) == []  # r <= 0.111 all hold
    bad = check_expectations(results, Expectations(holds_below_speed_ratio=1.0))
    assert [(v.scene, v.quantity) for v in bad] == [("source/tip/300rpm/k1/z0.02/ccw", "verdict_error")]
    assert check_expectations(results, Expectations(fails=("nonexistent/scene",)))[0].value == "scene not in the file"


def test_junit_xml_one_case_per_scene_and_check(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        f["scene_table/complete"][_row(f, TIP60)] = 0
    xml = tmp_path / "junit.xml"
    assert _diff(baseline, new, "--junit", str(xml)).exit_code == 1
    suite = ET.parse(xml).getroot().find("testsuite")
    cases = suite.findall("testcase")
    labels = {c.get("classname") for c in cases}
    assert labels == {r.spec.label for r in store.read_scenes(baseline)}
    assert len({(c.get("classname"), c.get("name")) for c in cases}) == len(cases)  # one case per scene and check
    failed = [c for c in cases if c.find("failure") is not None]
    assert [(c.get("classname"), c.get("name")) for c in failed] == [(TIP60, "missing scene")]
    assert int(suite.get("tests")) == len(cases) and int(suite.get("failures")) == 1


def test_figures_of_drifted_scenes(baseline, tmp_path):
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        ds = f[f"scenes/{_key(f, TIP60)}/solutions/linear"]
        ds[...] = ds[()] * 1.01
    figs = tmp_path / "figs"
    assert _diff(baseline, new, "--figures", str(figs)).exit_code == 1
    index = json.loads((figs / "diff_index.json").read_text())
    assert [v["label"] for v in index.values()] == [TIP60]
    png = figs / next(iter(index))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (figs / "mine.png").write_bytes(b"x")
    (figs / next(iter(index))).unlink()
    (figs / next(iter(index))).write_bytes(b"user")  # listed in the index: ours to redraw
    assert _diff(baseline, new, "--figures", str(figs)).exit_code == 1
    assert (figs / "mine.png").read_bytes() == b"x"


def test_tolerances_table_and_bad_input(baseline, tmp_path):
    cfg = parse_config(CAMPAIGN + "[tolerances.same.linear]\nhistory = 0.02\n")
    assert cfg.tolerances.bounds("same", "linear").history == 0.02
    assert cfg.tolerances.bounds("same", "quasi_static") == DEFAULTS["same"]["quasi_static"]
    with pytest.raises(ConfigError, match="tolerances.same.linear.history: must be a finite number"):
        parse_config(CAMPAIGN + "[tolerances.same.linear]\nhistory = -1.0\n")
    _, problems = parse_tolerances({"exact": {}})
    assert problems == ["tolerances.exact: unknown tier (allowed: same, physics)"]
    # a 1 % drift passes under a looser `same` tolerance given as a file
    new = _copy(baseline, tmp_path)
    with h5py.File(new, "r+") as f:
        ds = f[f"scenes/{_key(f, TIP60)}/solutions/linear"]
        ds[...] = ds[()] * 1.01
    tol = tmp_path / "tol.toml"
    tol.write_text("[tolerances.same.linear]\nhistory = 0.02\nverdict_error = 0.02\n")
    assert _diff(baseline, new, "--tolerances", str(tol)).exit_code == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("[tolerances.same.linear]\nhistroy = 0.02\n")
    res = _diff(baseline, new, "--tolerances", str(bad))
    assert res.exit_code == 2 and "histroy: unknown key" in res.output
    res = _diff(tol, new)
    assert res.exit_code == 2 and "cannot be read as HDF5" in res.output


def test_help_documents_every_option_and_exit_status():
    res = CliRunner().invoke(cli, ["diff", "--help"])
    for opt in ("--tolerances", "--json", "--junit", "--figures", "Exit status: 0", "1 a check failed", "2 bad input"):
        assert opt in res.output


def test_physics_tier_matches_exudyn_settings_by_physical_scene(tmp_path):
    """Two Exudyn step sizes of one benign scene (extender mass, 60 rpm, r = 0.02): matched by physical scene,
    the steps named, the dynamic solver judged by the `physics` tier (their difference is above round-off,
    so the `same` tier would fail it), the quasi-static solver (unchanged settings) by `same`."""
    files = []
    for steps in (360, 720):
        cfg = parse_config(f"""
[campaign]
step_deg = 30.0
n_modes = 2
solvers = ["quasi_static", "dynamic"]
[grid]
mass_models = ["extender"]
rpm = [60.0]
[dynamic]
element = "ancf"
elements_per_link = 2
steps_per_cycle = {steps}
""")
        files.append(tmp_path / f"s{steps}.h5")
        run_campaign(cfg, files[-1], workers=1, progress=False)
    rep = diff_files(*files)
    (s,) = rep.scenes
    assert s.match == "physical" and s.settings_differ == ("dynamic.steps_per_cycle: 360 -> 720",)
    assert dict(s.tiers) == {"dynamic": "physics", "quasi_static": "same"}
    dyn = [c for c in s.checks if c.check == "history" and c.solver == "dynamic"]
    assert all(c.passed and c.tier == "physics" for c in dyn)
    assert max(c.value for c in dyn) > DEFAULTS["same"]["dynamic"].history
    assert rep.passed
    res = _diff(*files)
    assert res.exit_code == 0 and "matched by physical scene" in res.output and "steps_per_cycle" in res.output


def test_run_and_inspect_check_the_expect_table(tmp_path):
    """The extender mass at 300 rpm has a 9 % quasi-static error (against the linear answer, 20 lumps per link): an
    expectation of 5 % is violated, one of r < 0.2 holding is met (the scenes below r = 0.2 hold, the table of
    `ked run` shows it)."""
    cfg = tmp_path / "e.toml"
    cfg.write_text(CAMPAIGN + "[expect]\nholds_below_speed_ratio = 0.2\nverdict_error_below = { extender = 0.05 }\n")
    out = tmp_path / "e.h5"
    runner = CliRunner()
    res = runner.invoke(cli, ["run", str(cfg), "--out", str(out), "--no-progress", "--no-figures", "--workers", "1"])
    assert res.exit_code == 1, res.output
    assert f"EXPECT {EXT300}: verdict_error = 0.0903" in res.output and "expected < 0.05" in res.output
    assert "expectations: 1 violated" in res.output
    res = runner.invoke(cli, ["inspect", str(out), "--expect", "--json"])
    assert res.exit_code == 1
    (v,) = json.loads(res.output)["violations"]
    assert (v["scene"], v["quantity"], v["bound"]) == (EXT300, "verdict_error", "< 0.05 (extender)")
    assert v["value"] == pytest.approx(0.0903, abs=5e-4)  # pin: 20 lumps per link
    with pytest.raises(ConfigError, match="expect.verdict_error_below.tipp: unknown mass model"):
        parse_config(CAMPAIGN + "[expect]\nverdict_error_below = { tipp = 0.05 }\n")


def test_inspect_expect_without_a_table_is_bad_input(baseline):
    res = CliRunner().invoke(cli, ["inspect", str(baseline), "--expect"])
    assert res.exit_code == 2 and "no [expect] table" in res.output


def test_diff_reads_the_tables_stored_in_new(tmp_path):
    """Without --tolerances, the [tolerances] table of the campaign config stored in NEW applies: a 1 % drift of
    the linear answer passes a stated 2 %, fails the default round-off bound (--tolerances of an empty table)."""
    out = tmp_path / "t.h5"
    run_campaign(parse_config(CAMPAIGN + "[tolerances.same.linear]\nhistory = 0.02\nverdict_error = 0.02\n"), out,
                 workers=1, progress=False)
    new = _copy(out, tmp_path, "t_new.h5")
    with h5py.File(new, "r+") as f:
        ds = f[f"scenes/{_key(f, TIP60)}/solutions/linear"]
        ds[...] = ds[()] * 1.01
    assert _diff(out, new).exit_code == 0
    plain = tmp_path / "plain.toml"
    plain.write_text("[tolerances]\n")
    assert _diff(out, new, "--tolerances", str(plain)).exit_code == 1


def test_expect_naming_a_scene_outside_the_grid_is_refused_at_load():
    with pytest.raises(ConfigError, match=r"expect.fails\[0\]: 'source/tip/301rpm' is not a scene of the grid"):
        parse_config(CAMPAIGN + "[expect]\nfails = [\"source/tip/301rpm\"]\n")
    assert parse_config(CAMPAIGN + f"[expect]\nholds = [\"{EXT300}\"]\n").expect.holds == (EXT300,)


def test_another_crank_angle_grid_is_matched_by_physical_scene_and_judged_by_verdicts(baseline, tmp_path):
    """step_deg 30 -> 20: the same physical scenes; histories on other grids are not compared point by point,
    the verdict errors are, by the `physics` tier (against the linear model: 3.12 points; sampled every 20 instead
    of 30 deg the errors moved by at most 0.48 points: a regression pin of this campaign)."""
    other = tmp_path / "step20.h5"
    run_campaign(parse_config(CAMPAIGN.replace("step_deg = 30.0", "step_deg = 20.0")), other, workers=1,
                 progress=False)
    rep = diff_files(baseline, other)
    assert rep.counts()["matched_by_physical"] == 4
    assert all("step_deg: 30.0 -> 20.0" in s.settings_differ for s in rep.scenes)
    grid = [c for s in rep.scenes for c in s.checks if c.check == "history"]
    assert grid and all(c.quantity == "grid" and c.passed for c in grid)
    moved = [c for s in rep.scenes for c in s.checks if c.check == "verdict_error"]
    assert all(c.tier == "physics" and c.bound == 0.0312 for c in moved)
    assert max(c.value for c in moved) < 0.006 and rep.passed
