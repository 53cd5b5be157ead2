"""The atlas report's findings (ked_research.atlas.findings) on hand-built tables: every expected number is
worked out by hand in the comments (numpy's linear percentile where a percentile is stated)."""

from __future__ import annotations

import numpy as np
import pytest

from ked_research.atlas import calibration as cal
from ked_research.atlas import findings as fd


def test_confirm_findings_hand_computed():
    # two families; the joints family's second scene failed in Exudyn
    conf = {"key": np.array(["1/source/tip/0.1", "1/source/tip/0.2", "2/cognate/joints/0.1", "2/cognate/joints/0.3"]),
            "linkage": np.array([1, 1, 2, 2]), "mechanism": np.array(["source", "source", "cognate", "cognate"]),
            "mass_model": np.array(["tip", "tip", "joints", "joints"]), "r": np.array([0.1, 0.2, 0.1, 0.3]),
            "status": np.array(["ok", "ok", "ok", "failed"]),
            "reason": np.array(["", "", "", "ExudynError: solver diverged"]),
            "qs_vs_dyn": np.array([0.05, 0.15, 0.02, np.nan]), "qs_vs_linear": np.array([0.06, 0.08, 0.03, np.nan]),
            "linear_vs_dyn": np.array([0.01, 0.07, 0.2, np.nan]), "dyn_wall_s": np.array([1.0, 3.0, 2.0, np.nan]),
            "factor": np.array([1.0, 2.0, 0.6, 3.0])}
    c = fd.confirm(conf)
    assert (c.scenes, c.families, c.exudyn_ok) == (4, 2, 3)
    assert c.wall_median_s == 2.0  # median of 1, 3, 2 s
    # the 10 % calls agree on scenes 0 (both < 10 %) and 2 (both < 10 %), not on 1 (0.08 vs 0.15)
    assert (c.agree, c.agree_at, c.at) == (2, 1, 1)
    # |0.06-0.05|, |0.08-0.15|, |0.03-0.02| = 0.01, 0.07, 0.01: median 0.01, P90 0.01 + 0.8 * 0.06 = 0.058
    assert c.diff_median == pytest.approx(0.01) and c.diff_p90 == pytest.approx(0.058)
    assert c.linear_within == pytest.approx({0.05: 1 / 3, 0.10: 2 / 3}) and c.factor_max == 3.0
    # tip: 0.01, 0.07 never reach 10 % (above_grid); joints: 0.2 at its smallest ratio (below_grid)
    assert c.linear_status["above_grid"] == 1 and c.linear_status["below_grid"] == 1
    assert c.linear_status["crossed"] == 0
    assert c.failures == (("ExudynError:  solver diverged", 1),)
    assert fd.confirm({}) is None


def test_headline_findings_hand_computed():
    mms = ["tip", "tip", "joints", "joints", "extender", "extender", "distributed", "distributed", "tip"]
    r10 = np.array([0.1, 0.2, 0.15, 0.25, 0.3, 0.32, 0.05, 0.08, 0.5])
    status = np.array(["crossed"] * 8 + ["above_grid"])  # the last family never crossed: left out
    fam = {"mass_model": np.array(mms), "r10": r10, "r5": r10 / 2, "r10_status": status, "r5_status": status,
           "r10_step": np.array([0.01] * 8 + [np.nan]), "one_mode_r10": r10 * np.array([1.2, 1.3] * 4 + [1.0]),
           "one_mode_r5": r10 / 2, "k_sig_1": np.full(9, 2.0)}
    feats = {"weak": np.array([3, 1, 4, 1.5, 9, 2.6, 5, 3.5, 8]), "falling": -r10, "rising": r10}
    h = fd.headline(fd.distribution(fam), fd.correlations(fam, feats), fd.predictions(fam),
                    fd.quantile(fam["r10_step"], 50))
    assert h.families == 8
    # sorted crossed r10: 0.05 0.08 0.1 0.15 0.2 0.25 0.3 0.32 -> median (0.15 + 0.2) / 2
    assert h.r10_median == pytest.approx(0.175) and h.r5_median == pytest.approx(0.0875)
    assert h.r10_step_median == pytest.approx(0.01)
    # mass-model medians 0.15, 0.2, 0.31, 0.065: spread 0.245; widest 10-90 % width 0.8 x 0.1 (tip, joints)
    assert h.mass_model_spread == pytest.approx(0.245) and h.widest == pytest.approx(0.08)
    # rank correlations +1 and -1 first (in either order), the weaker one last
    assert [k for k, _ in h.correlations][2] == "weak"
    rho = dict(h.correlations)
    assert rho["rising"] == pytest.approx(1.0) and rho["falling"] == pytest.approx(-1.0) and abs(rho["weak"]) < 1
    assert h.one_mode_within == 0.5  # x1.2 within +-25 %, x1.3 not


def test_threshold_findings_by_construction():
    # six tip scenes, three per mechanism; the last a confirmed scene in the band, the third failed in Exudyn
    d = cal.ThresholdData(
        e=np.array([0.05, 0.09, 0.12, 0.11, 0.085, 0.10]), measured=np.array([0.06, 0.11, np.nan, 0.09, 0.07, 0.12]),
        r=np.full(6, 0.1), r_linear=np.ones(6), linear_ok=np.ones(6, bool), mass_model=np.array(["tip"] * 6),
        mechanism=np.array(["source"] * 3 + ["cognate"] * 3), factor=np.array([0.8, 0.9, 1.1, 0.85, 1.2, 1.0]),
        sample=np.array(["threshold"] * 5 + ["confirm"]), linkage=np.array([1, 1, 1, 2, 2, 2]))
    mg = cal.choose_margins(d.e, d.measured, d.r, d.r_linear, d.linear_ok, 0.10)
    fam = {"linkage": np.array([1, 2]), "mechanism": np.array(["source", "cognate"]),
           "mass_model": np.array(["tip"] * 2), "r10": np.array([0.1, 0.05])}
    t = fd.threshold(d, mg, fam)
    assert (t.scenes, t.exudyn_ok, t.threshold_scenes, t.joined) == (6, 5, 5, 1)
    assert (t.strata_min, t.strata_max) == (2, 3) and (t.factor_min, t.factor_max) == (0.8, 1.2)
    assert t.measured_fail == 2  # 0.11 and 0.12
    # measured / predicted: 1.2, 1.222, 0.818, 0.824, 1.2 -> median 1.2; predicted within 8-12 %: 4 scenes
    assert t.ratio_median == pytest.approx(1.2) and t.near == 4
    rows = {(x.mass_model, x.mechanism): x for x in t.strata}
    assert (rows["tip", "source"].scenes, rows["tip", "source"].exudyn_ok, rows["tip", "source"].measured_fail) \
        == (3, 2, 1)
    assert (rows["tip", "cognate"].scenes, rows["tip", "cognate"].measured_fail) == (3, 1)
    assert sum(x.scenes for x in t.strata) == 6
    assert sum(x.unsafe + x.borderline + x.overcautious for x in t.strata) <= t.exudyn_ok
    # below their family's interpolated r*: scenes 0, 1, 3; scene 3 (e = 0.11) already >= 10 %, at
    # r = 0.1 above its family's first-crossing limit 0.05: between the two, not unseen
    assert t.early == (3, 1, 1, 0)
    assert fd.threshold(None, None) is None


def test_the_committed_atlas_section_is_the_markdown_of_its_findings():
    # regression pin: results/README.md's atlas section, regenerated from the committed atlas file's findings
    # (figures not redrawn: only their paths enter the text)
    from compare.paths import ATLAS_FILE, RESULTS
    from compare.sections import markers
    from ked_research.atlas import report

    info, fam, links, conf = report.load(ATLAS_FILE)
    thr, margins = report.threshold_of(ATLAS_FILE)
    feats = report.features(fam, links)
    found = fd.analyse(info, fam, links, conf, thr, margins, feats, np.asarray(info["ratios"]))
    readme = RESULTS / "README.md"
    figs = dict(zip(("limits", "features", "prediction", "map", "confirm", "coupler_curves", "threshold"),
                    (RESULTS / "figures" / name for name in report.FIGURES)))
    text = readme.read_text(encoding="utf-8")
    begin, end = markers(report.SECTION)
    slider = ATLAS_FILE.with_name("slider_atlas.h5")  # the slider-crank strata's table, when committed
    assert report.markdown(found, ATLAS_FILE, readme, figs, slider if slider.exists() else None).strip() == \
        text[text.index(begin) + len(begin):text.index(end)].strip()


def test_spearman_ranks_ties_at_their_average():
    """Spearman's rho is Pearson's r of the ranks, tied values sharing their average rank (the definition):
    x = (1, 2, 2, 3) has ranks (1, 2.5, 2.5, 4); against y ranks (1, 2, 3, 4) that is r = 4.5 / sqrt(4.5 * 5)
    = 0.9487. A constant variable has no rank correlation (nan), not an arbitrary one."""
    import math

    from ked_research.atlas.analysis import spearman

    assert spearman([1, 2, 2, 3], [10, 20, 30, 40]) == pytest.approx(4.5 / math.sqrt(4.5 * 5.0), rel=1e-12)
    assert math.isnan(spearman([5, 5, 5, 5], [1, 2, 3, 4]))


def test_report_says_when_the_exudyn_samples_come_from_a_prefix_of_the_atlas(tmp_path):
    """Samples drawn before the atlas was extended name the prefix they came from (by construction: families of
    linkages 0..3, samples from linkages 0 and 1 -> the first 2 of 4); samples reaching the last linkage say
    nothing."""
    import h5py

    from ked_research.atlas.report import drawn_from

    path = tmp_path / "atlas.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("families/linkage", data=np.repeat(np.arange(4), 8))
        f.create_dataset("confirm/linkage", data=np.array([0, 1]))
        f.create_dataset("threshold/linkage", data=np.array([1]))
    assert "first 2 of the 4 linkages" in drawn_from(path)
    with h5py.File(path, "a") as f:
        del f["threshold/linkage"]
        f.create_dataset("threshold/linkage", data=np.array([3]))
    assert drawn_from(path) == ""
