"""The validity atlas: the seeded generator, the limit walk, and a small end-to-end run through a real
Dask LocalCluster (2 worker processes) with the real quasi-static, linear and Exudyn solvers."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from compare import metrics
from compare.atlas import analysis
from compare.atlas import store as atlas_store
from compare.atlas.compute import OK, limit_of
from compare.atlas.confirm import run_confirm
from compare.atlas.generate import RANGES, candidate, generate
from compare.atlas.report import FIGURES, write_report
from compare.atlas.run import run_atlas
from compare.studies.sections import section_of
from ked_linear import LinearSettings, solve_linear
from ked_quasi import Scene, natural_frequencies, solve_quasi_static
from ked_quasi.cognates import mechanism as cognate_of
from ked_quasi.rules import RPM

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
    ok = [True] * 3
    five = limit_of(RATIOS, [0.02, 0.06, 0.30], ok, 0.05)
    ten = limit_of(RATIOS, [0.02, 0.06, 0.30], ok, 0.10)
    assert five.status == ten.status == "crossed"
    assert five.r == pytest.approx(0.0875) and five.half_bracket == pytest.approx(0.025)
    assert ten.r == pytest.approx(0.1 + 0.04 / 0.24 * 0.1) and ten.half_bracket == pytest.approx(0.05)
    assert limit_of(RATIOS, [0.01, 0.02, 0.04], ok, 0.05).status == "above_grid"
    assert limit_of(RATIOS, [0.01, 0.02, 0.04], ok, 0.05).r == 0.2
    below = limit_of(RATIOS, [0.2, 0.3, 0.4], ok, 0.05)
    assert below.status == "below_grid" and below.r == 0.05
    assert limit_of(RATIOS, [0.01, math.nan, 0.4], [True, False, True], 0.05).status == "failure"


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
    report = write_report(path, root / "figures", root / "README.md")
    return {"path": path, "root": root, "first": first, "confirm": conf, "report": report}


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
    r10 = fam["r10"][analysis.crossed(fam, "r10", "tip")]
    assert t.quasi_static_r10 == pytest.approx(float(np.median(r10)))
    with pytest.raises(FileNotFoundError, match="no atlas file"):
        analysis.limits("tip", atlas["root"] / "missing.h5")


def test_report_section_and_figures(atlas):
    root = atlas["root"]
    text = section_of((root / "README.md").read_text(), "atlas")
    assert "## Atlas" in text and "Tier limits" in text and "Exudyn-confirmed sample" in text
    for name in FIGURES:
        assert (root / "figures" / name).stat().st_size > 1000


@pytest.mark.slow
def test_study_through_the_cli(tmp_path):
    from click.testing import CliRunner

    from ked_cli.main import cli

    args = ["study", "atlas", "--results-dir", str(tmp_path), "--linkages", "4", "--confirm", "8", "--seed", "3"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(cli, args + ["--report-only"])
    assert res.exit_code == 0, res.output
    assert section_of((tmp_path / "README.md").read_text(), "atlas")


def test_run_on_a_running_scheduler(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=40) as cluster:
        path = tmp_path / "atlas.h5"
        summary = run_atlas(path, linkages=1, seed=SEED, scheduler=cluster.scheduler_address, ratios=(0.1,),
                            echo=lambda s: None)
    assert summary.computed == 1
    assert set(atlas_store.read(path, "families")["status"]) == {"ok"}
