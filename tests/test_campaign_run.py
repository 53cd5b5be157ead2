"""Campaign runner with the real solvers: parallel run, resume, failing scene, CLI run/inspect/plot.

Scenes are kept quick: 30 deg crank grid, coarse Exudyn settings, low speed.
"""

from __future__ import annotations

import json
import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from compare import store
from compare.config import parse_config
from compare.runner import plan, run_campaign
from ked_cli.main import cli as main

from .conftest import QUICK_DYNAMIC

QUICK = """
[campaign]
name = "quick"
step_deg = 30.0
n_modes = 2
[grid]
mechanisms = ["source", "cognate"]
mass_models = ["extender", {name = "tip", payload_kg = 0.5}]
rpm = [60.0]
""" + QUICK_DYNAMIC

# stiffness scaled by 1e-3 at 60 rpm puts the tip-mass scene far above its first resonance: the
# Exudyn Newton iteration diverges during the start-up ramp (a genuine solver failure, no mock)
FAILING = """
[campaign]
name = "with-failure"
solvers = ["quasi_static", "dynamic"]
step_deg = 30.0
n_modes = 2
[grid]
mass_models = [{name = "tip", payload_kg = 0.5}]
rpm = [60.0]
stiffness_scales = [1.0, 1.0e-3, 0.5]
""" + QUICK_DYNAMIC


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("quick") / "quick.h5"
    cfg = parse_config(QUICK)
    summary = run_campaign(cfg, out, workers=2, progress=False)
    return cfg, out, summary


def test_parallel_campaign_stores_every_scene_once_and_valid(quick_run):
    cfg, out, summary = quick_run
    assert summary.total == 4 and summary.ok == 4 and summary.failed == 0 and summary.skipped == 0
    assert store.verify(out) == []
    results = store.read_scenes(out)
    assert sorted(r.key for r in results) == sorted(s.key for s in cfg.scenes())
    for r in results:
        assert r.ok and r.verdict is not None and r.reference == "dynamic"
        assert r.crank_angle.shape == (12,) and r.natural_frequencies.shape == (12, 2)
        assert set(r.dynamic) == {"dx", "dy", "rotation"}
        assert r.stat("dynamic", "steps") > 0 and r.stat("dynamic", "cycles") >= 1 and r.stat("dynamic", "wall_s") > 0
        assert r.verdict.speed_ratio == pytest.approx(2 * np.pi / r.omega1_min)  # 60 rpm = 2 pi rad/s
    # computed in worker processes, not in this (the writing) process
    assert {r.stats.worker.split(":")[1] for r in results}.isdisjoint({str(os.getpid())})
    with h5py.File(out, "r") as f:
        assert "quick" in f.attrs["campaign_config"]


def test_rerun_skips_stored_scenes(quick_run):
    cfg, out, _ = quick_run
    before = {r.key: r.stats.finished_utc for r in store.read_scenes(out)}
    again = run_campaign(cfg, out, workers=2, progress=False)
    assert again.skipped == 4 and again.ok == 0 and again.failed == 0
    assert {r.key: r.stats.finished_utc for r in store.read_scenes(out)} == before
    # a grown grid runs only the new scenes
    bigger = parse_config(QUICK.replace("rpm = [60.0]", "rpm = [60.0, 90.0]"))
    p = plan(bigger.scenes(), store.stored_status(out))
    assert len(p.todo) == 4 and len(p.skipped) == 4
    assert {s.speed.value for s in p.todo} == {90.0}


def test_resume_refuses_scenes_computed_with_other_default_settings(quick_run, tmp_path):
    # content keys hash only the explicit [dynamic] settings; a stored scene whose *resolved* settings differ
    # from what the current DynamicSettings defaults give (here steady_tol, not pinned by QUICK) must not be
    # silently reused: the rerun is refused before anything is written
    import json
    import shutil

    from compare.runner import SettingsMismatchError

    cfg, out, _ = quick_run
    old = tmp_path / "old-defaults.h5"
    shutil.copy(out, old)
    key = cfg.scenes()[0].key
    from compare import tables

    with h5py.File(old, "r+") as f:  # the stored settings of the scene's Exudyn solution, edited
        cols, kinds = tables.read_table(f["solution_table"]), tables.kinds_of(f["solution_table"])
        (i,) = np.flatnonzero((cols["key"] == key) & (cols["solver"] == "dynamic"))
        settings = json.loads(cols["settings_json"][i])
        settings["steady_tol"] = 0.01
        cols["settings_json"][i] = json.dumps(settings, sort_keys=True, separators=(",", ":"))
        tables.write_table(f, "solution_table", cols, kinds=kinds)
    before = old.read_bytes()
    with pytest.raises(SettingsMismatchError, match="steady_tol: stored 0.01"):
        run_campaign(cfg, old, workers=1, progress=False)
    assert old.read_bytes() == before


def test_failing_scene_is_recorded_and_others_complete(tmp_path):
    out = tmp_path / "fail.h5"
    summary = run_campaign(parse_config(FAILING), out, workers=2, progress=False)
    assert summary.ok == 2 and summary.failed == 1
    results = {r.spec.stiffness_scale: r for r in store.read_scenes(out)}
    bad = results[1.0e-3]
    assert bad.status == "failed" and bad.stage == "dynamic" and bad.message
    assert bad.error_type in ("SimulationError", "NoSteadyState")
    assert "dx" in bad.quasi_static  # what was computed before the failure is kept
    assert results[1.0].ok and results[0.5].ok
    assert store.verify(out) == []
    # failed scenes are skipped on resume unless asked to retry
    assert run_campaign(parse_config(FAILING), out, workers=1, progress=False).skipped == 3
    retry = run_campaign(parse_config(FAILING), out, workers=1, progress=False, retry_failed=True)
    assert retry.failed == 1 and retry.skipped == 2
    assert len(store.read_scenes(out)) == 3


def test_cli_run_inspect_plot(tmp_path, quick_run):
    _, out, _ = quick_run
    cfg_file = tmp_path / "quick.toml"
    cfg_file.write_text(QUICK)
    runner = CliRunner()
    res = runner.invoke(main, ["run", str(cfg_file), "--out", str(out), "--no-progress", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "0 ok, 0 failed, 4 skipped" in res.output and "verdict" in res.output

    res = runner.invoke(main, ["inspect", str(out)])
    assert res.exit_code == 0 and "4 scenes: 4 ok" in res.output
    rows = json.loads(runner.invoke(main, ["inspect", str(out), "--json"]).output)["scenes"]
    assert len(rows) == 4 and all(r["status"] == "ok" for r in rows)
    key = rows[0]["key"]
    detail = runner.invoke(main, ["inspect", str(out), key[:8]])
    assert detail.exit_code == 0 and "phase[deg]" in detail.output
    one = json.loads(runner.invoke(main, ["inspect", str(out), key, "--json"]).output)
    assert one["key"] == key and len(one["solutions"]["dynamic"]["deflection"]["dx"]) == 12
    ver = runner.invoke(main, ["inspect", str(out), "--verify"])
    assert ver.exit_code == 0 and "valid, 4 complete scenes" in ver.output

    fig_dir = tmp_path / "figs"
    res = runner.invoke(main, ["plot", str(out), "--out", str(fig_dir)])
    assert res.exit_code == 0, res.output
    pngs = sorted(p.name for p in fig_dir.glob("*.png"))
    assert "amplification.png" in pngs and len(pngs) == 5
    assert all((fig_dir / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


def test_cli_reports_config_errors_and_dry_run(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[grid]\nrpm = [-1.0]\nmechanisms = ['x']\n")
    res = CliRunner().invoke(main, ["run", str(bad)])
    assert res.exit_code == 2
    assert "grid.rpm[0]" in res.output and "grid.mechanisms[0]" in res.output
    good = tmp_path / "q.toml"
    good.write_text(QUICK)
    res = CliRunner().invoke(main, ["run", str(good), "--out", str(tmp_path / "x.h5"), "--dry-run"])
    assert res.exit_code == 0 and "4 scenes, 4 to run" in res.output
    assert not (tmp_path / "x.h5").exists()


def test_worker_killed_mid_campaign_is_recovered(tmp_path):
    """A worker process that dies (as on a segfault inside a solver) breaks the local pool; the scenes
    took down are rerun in a fresh pool (then one by one if it breaks again) and the campaign completes."""
    import multiprocessing
    import os
    import signal

    killed = []

    def kill_a_worker(_result):
        # twice: the first kill breaks the campaign's pool, the second the retry pool, so the last
        # scenes go through the one-by-one isolation path
        victims = [p for p in multiprocessing.active_children() if p.pid not in killed and p.is_alive()]
        if len(killed) < 2 and victims:
            os.kill(victims[0].pid, signal.SIGKILL)
            killed.append(victims[0].pid)

    cfg = parse_config(QUICK.replace("rpm = [60.0]", "rpm = [60.0, 75.0]"))
    out = tmp_path / "crash.h5"
    summary = run_campaign(cfg, out, workers=2, progress=False, on_result=kill_a_worker)
    assert len(killed) == 2
    assert summary.lost == 0 and summary.ok + summary.failed == 8
    results = store.read_scenes(out)
    assert sorted(r.key for r in results) == sorted(s.key for s in cfg.scenes())
    assert all(r.ok for r in results)
    assert store.verify(out) == []


FLAGGED = """
[campaign]
name = "flagged"
step_deg = 30.0
solvers = ["quasi_static", "linear"]
[grid]
mass_models = ["tip", "extender"]
rpm = [300.0]
"""


def test_table_marks_answers_outside_their_model(tmp_path):
    """Case I at 300 rpm deflects P by ~0.37 m quasi-statically (thesis Table I is of that order), far
    beyond 10 % of the 0.254 m crank: the quasi-static error is marked and explained, not printed bare;
    Case III (extender, ~1 mm) is not marked."""
    cfg_file = tmp_path / "flagged.toml"
    cfg_file.write_text(FLAGGED)
    out = tmp_path / "flagged.h5"
    runner = CliRunner()
    res = runner.invoke(main, ["run", str(cfg_file), "--out", str(out), "--no-progress", "--no-figures"])
    assert res.exit_code == 0, res.output
    listed = json.loads(runner.invoke(main, ["inspect", str(out), "--json"]).output)["scenes"]
    rows = {r["mass_model"]: r for r in listed}
    assert "large_deflection" in rows["tip"]["flags_quasi_static"]
    assert "flags_quasi_static" not in rows["extender"]
    lines = {ln.split()[1].split("/")[1]: ln for ln in res.output.splitlines() if "/300rpm/" in ln}
    assert f"{100 * rows['tip']['verdict_error']:.1f}*" in lines["tip"]
    assert "*" not in lines["extender"]
    assert "outside the range where its model holds" in res.output


QS_ONLY = """
[campaign]
name = "twins"
step_deg = {step}
solvers = ["quasi_static"]

[grid]
mechanisms = ["source"]
mass_models = ["tip"]
rpm = [100.0]
"""


def test_run_into_a_file_of_other_settings_says_it_adds_beside_them(tmp_path):
    """A campaign run into a file holding the same physical scene computed with other settings (here the crank-angle
    step; an earlier default campaign's Exudyn start alike) stores its own scene under its own key beside it and says
    so in one line naming the setting; the stored scene is kept."""
    out, a, b = tmp_path / "f.h5", tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text(QS_ONLY.format(step=30.0))
    b.write_text(QS_ONLY.format(step=20.0))
    runner = CliRunner()
    first = runner.invoke(main, ["run", str(a), "--out", str(out), "--no-progress", "--no-figures"])
    assert first.exit_code == 0, first.output
    assert "also holds" not in first.output
    second = runner.invoke(main, ["run", str(b), "--out", str(out), "--no-progress", "--no-figures"])
    assert second.exit_code == 0, second.output
    assert "note: f.h5 also holds 1 of these scenes computed with other settings (step_deg: 30.0 -> 20.0)" in \
        " ".join(second.output.split())
    assert len(store.read_scenes(out)) == 2
