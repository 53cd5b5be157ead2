"""The validity atlas: the seeded generator, the limit walk, and a small end-to-end run through a real
Dask LocalCluster (2 worker processes) with the real quasi-static, linear and Exudyn solvers."""

from __future__ import annotations

import math
import os
import platform
import subprocess
import sys

import h5py
import numpy as np
import pytest

from compare import metrics
from compare.limits import validity_limit
from compare.sections import section_of
from ked_linear import LinearSettings, solve_linear
from ked_quasi import Scene, natural_frequencies, solve_quasi_static
from ked_quasi.cognates import mechanism as cognate_of
from ked_quasi.rules import RPM
from ked_research.atlas import analysis, calibration, findings, verdict_margins
from ked_research.atlas import store as atlas_store
from ked_research.atlas.compute import OK, failed_record
from ked_research.atlas.confirm import run_confirm
from ked_research.atlas.generate import RANGES, candidate, generate
from ked_research.atlas.report import FIGURES, write_report
from ked_research.atlas.report import load as report_load
from ked_research.atlas.run import LinkageBuffer, family_tasks, run_atlas
from ked_research.atlas.threshold import run_threshold, select_threshold

SEED = 11
RATIOS = (0.05, 0.1, 0.2)


# -- generator ---------------------------------------------------------------------------------------------------


def test_generator_is_reproducible_and_grows_as_a_prefix():
    a, b, c = generate(12, SEED), generate(12, SEED), generate(20, SEED)
    assert a == b
    assert c.linkages[:12] == a.linkages
    assert generate(12, SEED + 1).linkages != a.linkages


def test_every_linkage_assembles_is_crank_drivable_and_passes_the_rules():
    sample = generate(25, SEED)
    bound = RANGES.min_transmission_deg
    for lk in sample.linkages:
        assert lk.fourbar.failing_angles().size == 0
        assert lk.fourbar.grashof_class.startswith("crank-rocker")
        assert lk.min_transmission_deg >= bound
        assert {m.name for m in lk.mass_models} == {"tip", "joints", "extender", "distributed"}
        assert next(m for m in lk.mass_models if m.name == "tip").payload > 0
        for mech in lk.mechanisms:
            fb = cognate_of(lk.fourbar, mech)
            Scene(fb, lk.mass_models[0], 100.0)  # a crank-driven scene (Scene refuses full_turn=False)
        if "cognate" not in lk.mechanisms:
            assert lk.cognate_reason


def test_rejects_carry_their_reasons():
    sample = generate(25, SEED)
    assert sample.rejects, "the ranges are wide enough that some candidates are rejected"
    assert all(r.reason for r in sample.rejects)
    kinds = {r.reason.split(":")[0].split(" (")[0] for r in sample.rejects}
    assert kinds <= {"not a Grashof crank-rocker with margin 0.02", "near toggle", "not a crank-rocker"} | {
        r.reason for r in sample.rejects}
    indices = sorted([*(x.index for x in sample.linkages), *(x.index for x in sample.rejects)])
    assert indices == list(range(len(indices))), "every candidate drawn is either accepted or recorded"


# -- limits ------------------------------------------------------------------------------------------------------


def test_limit_interpolation_hand_computed():
    # errors 0.02, 0.06, 0.30 at r = 0.05, 0.1, 0.2 (by hand):
    # 5 %: 0.05 + (0.05 - 0.02) / (0.06 - 0.02) * 0.05 = 0.0875, half-bracket 0.025
    # 10 %: 0.1 + (0.10 - 0.06) / (0.30 - 0.06) * 0.1 = 0.11667, half-bracket 0.05
    # (r_record: the value the atlas file stores as r5 / r10)
    ok = [True] * 3
    five = validity_limit(RATIOS, [0.02, 0.06, 0.30], ok, 0.05)
    ten = validity_limit(RATIOS, [0.02, 0.06, 0.30], ok, 0.10)
    assert five.status == ten.status == "crossed"
    assert five.r_record == pytest.approx(0.0875) and five.half_bracket == pytest.approx(0.025)
    assert ten.r_record == pytest.approx(0.1 + 0.04 / 0.24 * 0.1) and ten.half_bracket == pytest.approx(0.05)
    assert validity_limit(RATIOS, [0.01, 0.02, 0.04], ok, 0.05).status == "above_grid"
    assert validity_limit(RATIOS, [0.01, 0.02, 0.04], ok, 0.05).r_record == 0.2
    below = validity_limit(RATIOS, [0.2, 0.3, 0.4], ok, 0.05)
    assert below.status == "below_grid" and below.r_record == 0.05
    assert validity_limit(RATIOS, [0.01, math.nan, 0.4], [True, False, True], 0.05).status == "failure"


def test_median_spread_hand_computed():
    # numpy's linear percentile: P10 of 0.1..0.5 sits 0.4 of the way from 0.1 to 0.2 -> 0.14
    med, spread = analysis.median_spread([0.5, 0.1, 0.3, 0.2, 0.4, math.nan])
    assert med == pytest.approx(0.3) and spread == pytest.approx(0.16)


# -- end to end --------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def atlas(tmp_path_factory):
    """Two linkages (source + cognate, four mass models) on a short sweep, one Exudyn scene, the report."""
    root = tmp_path_factory.mktemp("atlas")
    path = root / "atlas" / "atlas.h5"
    first = run_atlas(path, linkages=2, seed=SEED, workers=2, ratios=RATIOS, echo=lambda s: None)
    conf = run_confirm(path, n=1, seed=SEED, workers=2, echo=lambda s: None)
    thr = run_threshold(path, n=1, top_up=1, seed=SEED, workers=2, echo=lambda s: None)
    margins = calibration.store_margins(path)
    report = write_report(path, root / "figures", root / "README.md")
    return {"path": path, "root": root, "first": first, "confirm": conf, "threshold": thr, "margins": margins,
            "report": report}


def test_run_stores_every_family_and_resumes(atlas):
    path = atlas["path"]
    assert atlas["first"].computed == 2
    fam = atlas_store.read(path, "families")
    sample = generate(2, SEED)
    assert len(fam["linkage"]) == sum(len(lk.mechanisms) * 4 for lk in sample.linkages)
    assert fam["history_error"].shape == (len(fam["linkage"]), len(RATIOS))
    assert set(fam["status"]) == {"ok"}
    again = run_atlas(path, linkages=2, seed=SEED, workers=2, ratios=RATIOS, echo=lambda s: None)
    assert again.computed == 0 and again.skipped == 2
    assert run_confirm(path, n=1, seed=SEED, echo=lambda s: None)["computed"] == 0
    assert path.stat().st_size < 1_000_000


def test_family_tasks_cover_every_family_and_linkages_are_committed_whole():
    # one task per family (linkage x mechanism x mass model), the 5-lump distributed model first in each
    # linkage; the buffer releases a linkage's records only when all of them are in, in the stored order
    sample = generate(3, SEED).linkages
    tasks = family_tasks(sample)
    assert sorted((lk.index, mech, mm.name) for lk, mech, mm in tasks) == sorted(
        (lk.index, mech, mm.name) for lk in sample for mech in lk.mechanisms for mm in lk.mass_models)
    assert [lk.index for lk, _, _ in tasks] == sorted(lk.index for lk, _, _ in tasks)
    assert tasks[0][2].name == "distributed"
    buffer = LinkageBuffer(sample)
    records = {(lk.index, mech, mm.name): failed_record(lk.index, mech, mm, "test", len(RATIOS))
               for lk, mech, mm in tasks}
    first, second = sample[0].index, sample[1].index
    arrivals = [k for k in records if k[0] == second][:-1] + [k for k in records if k[0] == first]
    released = buffer.add([records[k] for k in arrivals])
    assert [(r.linkage, r.mechanism, r.mass_model) for r in released] == [
        (first, mech, mm.name) for mech in sample[0].mechanisms for mm in sample[0].mass_models]
    last = [k for k in records if k[0] == second][-1]
    assert len(buffer.add([records[last]])) == len(sample[1].mechanisms) * 4
    assert buffer.held == {}


def test_the_atlas_file_is_refused_for_another_seed_and_a_foreign_file_is_refused(atlas, tmp_path):
    with pytest.raises(atlas_store.AtlasFileError, match="seed"):
        run_atlas(atlas["path"], linkages=2, seed=SEED + 1, ratios=RATIOS, echo=lambda s: None)
    # an atlas made with other settings (as after a change of the atlas's damping): resuming would mix them
    other = tmp_path / "other_settings.h5"
    other.write_bytes(atlas["path"].read_bytes())
    with h5py.File(other, "a") as f:
        f.attrs["settings"] = f.attrs["settings"].replace('"damping_ratio": 0.02', '"damping_ratio": 0.05')
    with pytest.raises(atlas_store.AtlasFileError, match="settings"):
        run_atlas(other, linkages=2, seed=SEED, ratios=RATIOS, echo=lambda s: None)
    foreign = tmp_path / "campaign.h5"
    with h5py.File(foreign, "w") as f:
        f.attrs["schema"] = "ked-harness/campaign"
    before = foreign.read_bytes()
    with pytest.raises(atlas_store.AtlasFileError, match="not an atlas file"):
        run_atlas(foreign, linkages=1, seed=SEED, ratios=RATIOS, echo=lambda s: None)
    assert foreign.read_bytes() == before


def test_stored_error_equals_an_independent_recomputation(atlas):
    """One family recomputed without the harness's campaign path: ked_quasi and ked_linear directly,
    the speed from r * omega1_min, the error by compare.metrics.history_error."""
    fam = atlas_store.read(atlas["path"], "families")
    i = int(np.flatnonzero(np.asarray(fam["mass_model"], dtype=object) == "extender")[0])
    lk = candidate(SEED, int(fam["linkage"][i]))
    mm = next(m for m in lk.mass_models if m.name == "extender")
    fb = cognate_of(lk.fourbar, str(fam["mechanism"][i]))
    w1 = 2 * math.pi * float(np.nanmin(natural_frequencies(Scene(fb, mm, 1.0), n_modes=1)[:, 0]))
    assert fam["omega1_min"][i] == pytest.approx(w1, rel=1e-12)
    for j, r in enumerate(RATIOS):
        if fam["code"][i, j] != OK:
            continue
        scene = Scene(fb, mm, RPM.check(r * w1 * 60 / (2 * math.pi)), 10.0)
        qs = solve_quasi_static(scene).deflection[:, :2]
        lin = solve_linear(scene, LinearSettings(damping_ratio=0.02)).deflection[:, :2]
        assert fam["history_error"][i, j] == pytest.approx(metrics.history_error(qs, lin), rel=1e-9)
        assert fam["peak_error"][i, j] == pytest.approx(metrics.peak_error(qs, lin), rel=1e-9, abs=1e-12)


def test_confirmed_scene_and_tier_limits(atlas):
    conf = atlas_store.read(atlas["path"], "confirm")
    assert len(conf["key"]) == 1 and atlas["confirm"]["computed"] == 1
    assert conf["status"][0] == "ok" or conf["reason"][0]
    t = analysis.limits("tip", atlas["path"])
    fam = atlas_store.read(atlas["path"], "families")
    rows = analysis.crossed(fam, "r10", "tip")
    # first crossings by hand: the last ratio before the first stored error >= 10 %
    first = [RATIOS[int(np.argmax(e >= 0.10)) - 1] for e in fam["history_error"][rows]]
    assert t.quasi_static_r10 == pytest.approx(float(np.median(first)))
    with pytest.raises(FileNotFoundError, match="no atlas file"):
        analysis.limits("tip", atlas["root"] / "missing.h5")


def test_threshold_scene_and_stored_margins(atlas):
    thr = atlas_store.read(atlas["path"], "threshold")
    # one scene of each draw (the second an independent draw of the same design; the two may coincide)
    assert 1 <= atlas["threshold"]["computed"] == len(thr["key"]) <= 2
    assert all(0.75 <= f <= 1.25 for f in thr["factor"])
    assert all(s == "ok" or why for s, why in zip(thr["status"], thr["reason"]))
    m = verdict_margins(0.10, atlas["path"])
    # two scenes cannot bound the unsafe rate by 3 % (that needs >= 122 scenes without an unsafe call):
    # the prediction alone grants no quasi-static tier, pooled or in any stratum
    assert m.holds_below == 0.0 and 0 < m.n_scenes <= 3  # the threshold scenes (+ a confirmed one at r*)
    assert atlas["margins"]["bound_met"] is False
    strata = atlas["margins"]["strata"]
    assert strata and all(rec["holds_below"] == 0.0 and not rec["bound_met"] for rec in strata.values())
    assert set(strata) <= {f"four-bar/{mm}/{mech}" for mm in ("tip", "joints", "extender", "distributed")
                           for mech in ("source", "cognate")}
    assert all(verdict_margins(0.10, atlas["path"], k).holds_below == 0.0 for k in strata)
    for m in (verdict_margins(0.10, atlas["path"], "slider-crank/distributed/source"),
              verdict_margins(0.05, atlas["path"])):  # calibrated at 10 % only
        assert not m.calibrated and m.n_scenes == 0 and "calibrated" in m.source


def test_repredict_reproduces_the_predictions_stored_by_the_same_code(atlas, tmp_path):
    # regression pin of the re-prediction path: on rows that today's code computed, predicting them again
    # (quasi-static and linear alone, ked_research.atlas.repredict) must give the stored prediction columns, and
    # the file then records which code made them
    import shutil

    from ked_research.atlas import repredict

    path = tmp_path / "atlas.h5"
    shutil.copy(atlas["path"], path)
    before = atlas_store.read(path, "threshold")
    assert repredict.stale_tables(path) == ["threshold", "confirm"]  # no record yet of the code behind them
    assert repredict.repredict(path, ("threshold",), seed=SEED, workers=1, echo=lambda s: None) == {
        "threshold": len(before["key"])}
    after = atlas_store.read(path, "threshold")
    for c in ("qs_vs_linear", "floquet_max_abs", "linear_flags"):
        np.testing.assert_allclose(after[c], before[c], rtol=1e-9, atol=1e-12, equal_nan=True)
    assert list(after["key"]) == list(before["key"]) and list(after["qs_vs_dyn"]) == list(before["qs_vs_dyn"])
    assert repredict.stale_tables(path) == ["confirm"]
    assert "threshold" in atlas_store.attrs(path)[repredict.ATTR]


def test_reconfirm_redoes_rows_of_an_older_lumping_and_resumes(atlas, tmp_path):
    # a threshold row of the distributed model stored without a record of its lumping counts as made with the
    # former 5 lumps: `reconfirm` runs it again (all three solvers) and replaces it in place with what today's
    # code computes (the same code made the row here, so the recomputed columns equal the originals: a second
    # implementation path, ked_research.atlas.confirm.confirm_scene, run once more); rows of other mass models and
    # of tables with today's record stay; the record is written, and a second call computes nothing
    import shutil

    from ked_research.atlas import confirm, lumps, reconfirm

    path = tmp_path / "atlas.h5"
    shutil.copy(atlas["path"], path)
    linkage = int(atlas_store.read(path, "families")["linkage"][0])
    point = confirm.ConfirmPoint(linkage, "source", "distributed", 0.2, 0.02, 0.1)
    table = "threshold"
    confirm.confirm_points(path, [point], table, SEED, workers=1, scheduler=None, progress=False,
                           echo=lambda s: None)
    made = atlas_store.read(path, table)
    meta = atlas_store.attrs(path)
    assert meta[lumps.ATTR][table] == lumps.lumping()
    assert reconfirm.reconfirm(path, seed=SEED, workers=1, echo=lambda s: None) == {"threshold": 0, "confirm": 0}
    lumps_by = {k: v for k, v in meta[lumps.ATTR].items() if k != table}  # as written by an older harness
    tampered = {c: list(v) for c, v in made.items()}
    row = list(made["key"]).index(point.key)
    tampered["qs_vs_dyn"][row] = 9.0
    atlas_store.write(path, {lumps.ATTR: lumps_by}, replaces={table: tampered})
    lumped = [i for i, m in enumerate(made["mass_model"]) if m in ("extender", "distributed")]
    assert [p.key for p in reconfirm.stale_points(path, table)] == [made["key"][i] for i in lumped]
    assert reconfirm.reconfirm(path, seed=SEED, workers=1, echo=lambda s: None)[table] == len(lumped)
    after = atlas_store.read(path, table)
    for c in ("qs_vs_dyn", "qs_vs_linear", "linear_vs_dyn"):
        np.testing.assert_allclose(after[c], made[c], rtol=1e-9, equal_nan=True)
    assert atlas_store.attrs(path)[lumps.ATTR][table] == lumps.lumping()
    assert reconfirm.reconfirm(path, seed=SEED, workers=1, echo=lambda s: None)[table] == 0


def test_resweep_recomputes_families_of_an_older_lumping_and_resumes(atlas, tmp_path):
    # a families table stored without a record of its lumping counts as made by the older code: `resweep`
    # computes every family again and replaces its row (the same code made the rows here, so the recomputed
    # rows equal the originals); a linkage listed as already redone by an interrupted run is skipped (its
    # tampered row stays), the record is written, and a second call computes nothing
    import shutil

    from ked_research.atlas import lumps, resweep

    path = tmp_path / "atlas.h5"
    shutil.copy(atlas["path"], path)
    made = atlas_store.read(path, "families")
    meta = atlas_store.attrs(path)
    assert meta[lumps.ATTR]["families"] == lumps.lumping() and not resweep.stale(path)
    assert resweep.resweep(path, seed=SEED, workers=1, echo=lambda s: None) == 0
    linkages = sorted(set(int(k) for k in made["linkage"]))
    tampered = {c: list(v) if v.ndim == 1 else [tuple(x) for x in v] for c, v in made.items()}
    rows = [[i for i, k in enumerate(made["linkage"]) if k == lk][0] for lk in linkages]
    for i in rows:
        tampered["history_error"][i] = (9.0,) * len(RATIOS)
    older = {k: v for k, v in meta[lumps.ATTR].items() if k != "families"}
    atlas_store.write(path, {lumps.ATTR: older, resweep.DONE_ATTR: linkages[:1]}, replaces={"families": tampered})
    assert resweep.stale(path)
    assert resweep.resweep(path, seed=SEED, workers=1, echo=lambda s: None) == len(linkages) - 1
    after = atlas_store.read(path, "families")
    assert np.all(after["history_error"][rows[0]] == 9.0)  # listed as done: not computed again
    keep = np.asarray(made["linkage"]) != linkages[0]
    for c in ("history_error", "peak_error", "floquet_max_abs", "one_mode_error", "r10", "r5"):
        np.testing.assert_allclose(after[c][keep], made[c][keep], rtol=1e-9, equal_nan=True)
    assert list(after["code"][keep].ravel()) == list(made["code"][keep].ravel())
    meta = atlas_store.attrs(path)
    assert meta[lumps.ATTR]["families"] == lumps.lumping() and not meta[resweep.DONE_ATTR]
    assert resweep.resweep(path, seed=SEED, workers=1, echo=lambda s: None) == 0
    assert atlas_store.verify(path) == []


def test_an_exudyn_answer_beyond_the_small_deflection_range_is_no_reference(atlas, tmp_path):
    # the harness's own rule (ked_quasi.limits): a deflection above MAX_DEFLECTION_FRACTION of the shortest link
    # is outside the range of the small-deflection comparison, so the calibration leaves that scene out
    import shutil

    from ked_quasi.limits import MAX_DEFLECTION_FRACTION

    path = tmp_path / "atlas.h5"
    shutil.copy(atlas["path"], path)
    cols = {c: list(v) for c, v in atlas_store.read(path, "threshold").items()}
    assert np.isfinite(calibration.threshold_data(path).measured[0])
    cols["deflection_ratio"][0] = 2.0 * MAX_DEFLECTION_FRACTION
    atlas_store.write(path, {}, replaces={"threshold": cols})
    assert np.isnan(calibration.threshold_data(path).measured[0])


def test_tolerance_bound_covers_the_quantile_as_stated():
    # independent check by simulation: for uniform(0, 1) samples of 100 the bound must lie above the 0.95
    # quantile (0.95) in at least 95 % of the draws (the chosen order statistic k = 99 covers it with probability
    # P(Binom(100, 0.95) <= 98) = 0.963); of 59 values the largest, since 1 - 0.95^59 > 0.95 > 1 - 0.95^58
    rng = np.random.default_rng(7)
    hits = [calibration.tolerance_bound(rng.uniform(size=100)) >= 0.95 for _ in range(4000)]
    assert 0.95 <= np.mean(hits) <= 0.975
    x = rng.uniform(size=59)
    assert calibration.tolerance_bound(x) == x.max() and calibration.tolerance_bound(x[:10]) == x[:10].max()


def test_report_section_and_figures(atlas):
    root = atlas["root"]
    assert section_of((root / "README.md").read_text(), "atlas")  # the section's content: test_atlas_findings.py
    _, fam, _, conf = report_load(atlas["path"])
    c = findings.confirm(conf)
    assert (c.scenes, c.families) == (1, 1) and c.exudyn_ok == int(conf["status"][0] == "ok")  # one scene confirmed
    assert findings.distribution(fam)[-1].r10.size == int(analysis.crossed(fam, "r10").sum())
    for name in FIGURES:
        assert (root / "figures" / name).stat().st_size > 1000


@pytest.mark.slow
def test_study_through_the_cli(tmp_path):
    from click.testing import CliRunner

    from ked_cli.main import cli

    args = ["study", "atlas", "--results-dir", str(tmp_path), "--linkages", "4", "--confirm", "8", "--threshold", "8",
            "--seed", "3", "--slider-linkages", "2"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(cli, args + ["--report-only"])
    assert res.exit_code == 0, res.output
    text = section_of((tmp_path / "README.md").read_text(), "atlas")
    assert text and "### Slider-crank strata" in text and "slider-crank/tip/source" in text
    assert (tmp_path / "atlas" / "slider_atlas.h5").exists()


def test_run_on_a_running_scheduler(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=40) as cluster:
        path = tmp_path / "atlas.h5"
        summary = run_atlas(path, linkages=1, seed=SEED, scheduler=cluster.scheduler_address, ratios=(0.1,),
                            echo=lambda s: None)
    assert summary.computed == 1
    assert set(atlas_store.read(path, "families")["status"]) == {"ok"}


_FAULTS = """
import resource, sys
import numpy as np
from ked_linear.solver import keep_freed_memory
if sys.argv[1] == "keep":
    keep_freed_memory()
np.ones(2**17).sum()  # numpy's own first-use allocations
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(100):
    np.ones(2**17).sum()  # 1 MiB allocated, written and freed
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="glibc's allocator")
def test_a_worker_keeps_freed_memory_under_the_dask_nanny_environment():
    # A Dask nanny starts its workers with MALLOC_TRIM_THRESHOLD_=65536: glibc then maps every 1 MiB block
    # afresh, and writing it faults in all its 256 pages of 4 KiB (about 25600 faults for 100 blocks);
    # after keep_freed_memory() (which an atlas task and solve_linear call first) the block freed is
    # reused, no fresh pages (a handful of faults).
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    faults = {mode: int(subprocess.run([sys.executable, "-c", _FAULTS, mode], env=env, capture_output=True, text=True,
                                       check=True).stdout) for mode in ("nanny", "keep")}
    assert faults["nanny"] > 100 * 256 // 2
    assert faults["keep"] < 100 * 256 // 20


# -- calibration at the threshold (pure) -------------------------------------------------------------------------


def _binomial_upper95(k: int, n: int) -> float:
    """Upper end of the two-sided 95 % exact interval, from the binomial distribution itself:
    the p with P(X <= k | n, p) = 0.025 (an independent route to the beta quantile)."""
    from scipy.optimize import brentq
    from scipy.stats import binom

    return brentq(lambda p: binom.cdf(k, n, p) - 0.025, 1e-12, 1 - 1e-12, xtol=1e-14)


def test_clopper_pearson_closed_forms():
    for n in (10, 122, 400):
        assert calibration.clopper_pearson(0, n).high95 == pytest.approx(1 - 0.025 ** (1 / n), rel=1e-9)
        assert calibration.clopper_pearson(n, n).low95 == pytest.approx(0.025 ** (1 / n), rel=1e-9)
        assert calibration.clopper_pearson(3, n).high95 == pytest.approx(_binomial_upper95(3, n), rel=1e-7)


def _perfect(n: int) -> tuple[np.ndarray, ...]:
    """n scenes whose prediction equals the measurement, spread over 5-15 %, inside the linear range."""
    e = np.linspace(0.05, 0.15, n)
    return e, e.copy(), np.full(n, 0.1), np.full(n, 1.0), np.ones(n, bool)


def test_margin_rule_needs_122_scenes_without_an_unsafe_call():
    # zero unsafe calls in n scenes: upper 95 % bound 1 - 0.025^(1/n), <= 3 % iff n >= ln 0.025 / ln 0.97 = 121.1
    mg = calibration.choose_margins(*_perfect(122))
    assert mg.bound_met and mg.holds_below == 1.0 and mg.fails_above == 1.0
    assert mg.stats.unsafe.k == 0 and mg.stats.unsafe.high95 == pytest.approx(1 - 0.025 ** (1 / 122))
    assert mg.stats.unsafe.high95 <= 0.03
    mg = calibration.choose_margins(*_perfect(121))
    assert not mg.bound_met and mg.holds_below == 0.0 and mg.stats.quasi_static == 0


def test_margin_rule_with_planted_unsafe_scenes():
    # 300 scenes: 295 perfectly predicted, 5 predicted at 9.05 % but measured 11 % (unsafe if called quasi-static).
    # Five unsafe in 300: upper bound > 3 % (binomial), so the margin must fall to at most 0.90 x 10 %, where none
    # is called quasi-static and the bound is the zero-count one.
    e, m, r, r_lin, ok = _perfect(295)
    e, m = np.r_[e, [0.0905] * 5], np.r_[m, [0.11] * 5]
    r, r_lin, ok = np.r_[r, [0.1] * 5], np.r_[r_lin, [1.0] * 5], np.r_[ok, [True] * 5]
    assert _binomial_upper95(5, 300) > 0.03
    mg = calibration.choose_margins(e, m, r, r_lin, ok)
    # the rate criterion alone gives 0.90; the scatter criterion is more cautious: 5 of the 122 scenes predicted
    # near the tolerance have measured / predicted = 0.11 / 0.0905 = 1.2155, and the 95 % / 95 % upper tolerance
    # bound of 122 values is their 121st (P(Binom(122, 0.95) <= 120) >= 0.95), one of the five: 1 / 1.2155 -> 0.82
    assert mg.holds_below_rate == 0.90 and mg.bound_met
    assert mg.ratio_q95 == pytest.approx(0.11 / 0.0905) and mg.holds_below_scatter == 0.82 == mg.holds_below
    assert mg.stats.unsafe.k == 0 and mg.stats.unsafe.high95 == pytest.approx(1 - 0.025 ** (1 / 300))
    above = calibration.call_stats(calibration.calls(e, r, r_lin, ok, 0.10, 0.91, 1.0), m, 0.10)
    assert above.unsafe.k == 5 and above.unsafe.high95 == pytest.approx(_binomial_upper95(5, 300), rel=1e-7)
    assert mg.plain.unsafe.k == 5  # the plain rule (e < 10 %) makes them
    # the five are in the borderline band now: not unsafe, counted apart, all measured above the tolerance
    assert mg.stats.borderline >= 5 and mg.stats.borderline_measured_fail == 5


def test_the_check_rule_withholds_quasi_static_outside_the_linear_range():
    c = calibration.calls(np.array([0.02, 0.02, 0.02, 0.095, 0.2]), np.array([0.1, 0.3, 0.1, 0.1, 0.1]),
                          np.array([0.25, 0.25, math.nan, 0.25, 0.25]), np.array([True, True, True, True, True]),
                          0.10, 0.9, 1.2)
    assert c.tolist() == [calibration.QUASI_STATIC, calibration.NOT_QUASI_STATIC, calibration.NOT_QUASI_STATIC,
                          calibration.BORDERLINE, calibration.NOT_QUASI_STATIC]
    assert calibration.calls(np.array([0.02]), np.array([0.1]), np.array([0.25]), np.array([False]), 0.1, 0.9,
                             1.2).tolist() == [calibration.NOT_QUASI_STATIC]


def test_verdict_margins_without_an_atlas_file_does_not_raise(tmp_path):
    m = verdict_margins(0.10, tmp_path / "missing.h5")
    assert not m.calibrated and m.holds_below == 0.0 and m.n_scenes == 0
    assert "missing.h5" in m.source
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    assert verdict_margins(0.10, junk).n_scenes == 0


def test_the_committed_margins_meet_the_bound():
    """The committed atlas's calibration (what `ked check` reads): >= 300 threshold scenes, unsafe-call upper
    95 % bound <= 3 % (regression pin of the committed data, not of a computation)."""
    if not analysis.default_path().exists():
        pytest.skip("no committed atlas file (not a checkout)")
    m = verdict_margins()
    assert m.n_scenes >= 300 and m.unsafe_upper95 <= 0.03 and 0 < m.holds_below <= 1 <= m.fails_above
    # every four-bar stratum: at least MIN_STRATUM scenes of its own, its own unsafe bound <= 3 %
    strata = [f"four-bar/{mm}/{mech}" for mm in ("tip", "joints", "extender", "distributed")
              for mech in ("source", "cognate")]
    for k in strata:
        s = verdict_margins(0.10, None, k)
        assert s.n_scenes >= calibration.MIN_STRATUM and s.unsafe_upper95 <= 0.03, (k, s)
        assert 0 < s.holds_below <= 1 <= s.fails_above, (k, s)


def test_threshold_sample_is_stratified_and_inside_the_band():
    rng = np.random.default_rng(0)
    n_fam = 64
    fam = {"r10": rng.uniform(0.05, 0.3, n_fam), "r10_status": np.array(["crossed"] * n_fam, dtype=object),
           "mass_model": np.array(["tip", "joints", "extender", "distributed"] * (n_fam // 4), dtype=object),
           "mechanism": np.array((["source"] * 4 + ["cognate"] * 4) * (n_fam // 8), dtype=object),
           "linkage": np.arange(n_fam) // 2}
    pts = select_threshold(fam, 16, seed=1)
    assert len(pts) == 16 and len({p.key for p in pts}) == 16
    assert all(0.75 <= p.r / p.atlas_r10 <= 1.25 for p in pts)
    assert {(p.mass_model, p.mechanism) for p in pts} == {(m, k) for m in ("tip", "joints", "extender",
                                                                            "distributed") for k in ("source",
                                                                                                     "cognate")}
    assert select_threshold(fam, 16, seed=1) == pts


# -- first crossings --------------------------------------------------------------------------------------------


def _resonant(r: np.ndarray) -> np.ndarray:
    """A smooth error rising from 7.6 % at r = 0.25 to 12.3 % at 0.30 plus a resonance peak at 0.277
    (2 % damping width), like the thesis source tip linear model."""
    r = np.asarray(r, float)
    return 0.076 + 0.94 * (r - 0.25) + 0.15 / (1 + ((r - 0.277) / (2 * 0.02 * 0.277)) ** 2) - 0.15 / (
        1 + ((0.25 - 0.277) / (2 * 0.02 * 0.277)) ** 2) * (r <= 0.25)


def test_first_crossing_is_not_interpolated_across_a_resonance():
    from scipy.optimize import brentq

    # the true first crossing of 10 %, found on the function itself
    true = brentq(lambda x: float(_resonant(np.array([x]))[0]) - 0.10, 0.2501, 0.277)
    coarse = np.array([0.2, 0.25, 0.3])
    lim = validity_limit(coarse, _resonant(coarse), [True] * 3, 0.10)
    assert lim.status == "crossed" and lim.r_cross > true + 0.005  # interpolation over the peak overstates it
    assert lim.r_limit == 0.25 <= true and lim.step == pytest.approx(0.05)
    fine = np.round(np.arange(0.2, 0.3001, 0.001), 6)
    lim = validity_limit(fine, _resonant(fine), [True] * fine.size, 0.10)
    assert lim.r_limit <= true < lim.r_limit + lim.step + 1e-12 and lim.step == pytest.approx(0.001)


def test_atlas_first_crossings_from_the_stored_errors():
    ratios = (0.1, 0.2, 0.3, 0.4)
    fam = {"history_error": np.array([[0.01, 0.12, 0.03, 0.3], [0.01, 0.02, 0.04, 0.06], [0.2, 0.3, np.nan, np.nan]]),
           "code": np.array([[OK] * 4, [OK] * 4, [OK, OK, 3, 3]]), "r10": np.array([0.19, 0.4, 0.1]),
           "r5": np.array([0.15, 0.35, 0.1])}
    out = analysis.first_crossings(fam, ratios)
    # row 0 crosses 10 % between 0.1 and 0.2 (the dip back to 3 % at 0.3 does not matter: first crossing)
    assert out["r10"][0] == 0.1 and out["r10_step"][0] == pytest.approx(0.1)
    assert out["r10"][1] == 0.4 and math.isnan(out["r10_step"][1])  # never reached: the largest ratio
    assert math.isnan(out["r10"][2])  # already above at the smallest ratio
    assert out["r5"][1] == 0.3 and out["r10_interpolated"][0] == 0.19
