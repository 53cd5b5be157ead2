"""The slider atlas: generated slider-cranks, their families, threshold scenes and per-stratum margins, through
the four-bar atlas's own machinery (one seam: :mod:`ked_research.atlas.kinds`).  Real solvers, tiny sizes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ked_check import published
from ked_research.atlas import calibration as cal
from ked_research.atlas import publish
from ked_research.atlas import store as atlas_store
from ked_research.atlas.kinds import FOUR_BAR, SLIDER, kind_of
from ked_research.atlas.run import run_atlas
from ked_research.atlas.slider_generate import RANGES, Ranges, generate, slider_crank
from ked_research.atlas.store import AtlasFileError
from ked_research.atlas.threshold import run_threshold

QUIET = dict(echo=lambda _: None)


def test_generated_slider_cranks_are_valid_and_a_prefix():
    # Expected (closed form of the model's docstring): an accepted slider-crank turns fully, crank + offset < rod,
    # and its transmission angle stays >= 20 deg from a toggle, min = 90 deg - asin((crank + offset) / rod);
    # every drawn ratio lies in its range; generate(n) is a prefix of generate(m > n) (own generator per index).
    sample = generate(12, seed=3)
    for lk in sample.linkages:
        sc, d = lk.slider, lk.design
        assert sc.crank + abs(sc.offset) < sc.coupler
        mu = 90.0 - math.degrees(math.asin((sc.crank + abs(sc.offset)) / sc.coupler))
        assert lk.min_transmission_deg == pytest.approx(mu, abs=0.5) and mu >= RANGES.min_transmission_deg
        assert RANGES.crank_rod_ratio[0] <= d.crank_rod_ratio <= RANGES.crank_rod_ratio[1]
        assert sc.crank / sc.coupler == pytest.approx(d.crank_rod_ratio)
        assert 0.0 < sc.coupler_point < 1.0 and sc.rigid[1] is False
        assert [m.name for m in lk.mass_models] == list(SLIDER.mass_models)
        assert lk.mass_models[0].payload > 0  # the tip model carries the payload always
    assert generate(5, seed=3).linkages == sample.linkages[:5]


def test_generator_refuses_a_slider_crank_near_toggle_with_its_reason():
    # Expected: crank/rod >= 0.9 and offset >= 0.05 x rod give (crank + offset) / rod >= 0.95, a minimum
    # transmission angle 90 - asin(0.95) = 18.2 deg or less: below the 20 deg bound (or a crank that cannot turn).
    near = dataclasses.replace(RANGES, crank_rod_ratio=(0.9, 0.99), offset_ratio=(0.05, 0.1))
    sample = generate(0, seed=0, ranges=near, max_candidates=10)
    with pytest.raises(ValueError, match="only 0 of 1 linkages accepted"):
        generate(1, seed=0, ranges=near, max_candidates=10)
    assert sample.linkages == ()
    from ked_research.atlas.slider_generate import candidate

    reasons = [candidate(0, i, near).reason for i in range(10)]
    assert all("transmission" in r or "turn" in r for r in reasons), reasons
    with pytest.raises(ValueError, match="SliderCrank"):
        slider_crank(dataclasses.replace(candidate(0, 0, near).design, crank_rod_ratio=1.2))
    assert isinstance(Ranges(), Ranges)


def test_slider_atlas_resumes_and_keeps_its_kind(tmp_path):
    # Expected: a second run with one more linkage computes only that one and leaves the stored rows as they
    # were; the file names its kind (its generator's ranges) and a four-bar run refuses to write into it.
    path = tmp_path / "slider_atlas.h5"
    first = run_atlas(path, linkages=2, workers=1, kind=SLIDER, **QUIET)
    assert (first.computed, first.families) == (2, 6)
    before = atlas_store.read(path, "families")
    again = run_atlas(path, linkages=3, workers=1, kind=SLIDER, **QUIET)
    assert (again.skipped, again.computed, again.families) == (2, 1, 9)
    after = atlas_store.read(path, "families")
    np.testing.assert_array_equal(after["history_error"][:6], before["history_error"])
    assert set(after["mass_model"]) == {"tip", "joints", "distributed"} and set(after["mechanism"]) == {"source"}
    assert kind_of(path) is SLIDER and kind_of(tmp_path / "none.h5") is FOUR_BAR
    assert "cognate_reason" not in atlas_store.read(path, "linkages")
    with pytest.raises(AtlasFileError, match="ranges"):
        run_atlas(path, linkages=3, workers=1, **QUIET)
    # a family's quasi-static error grows with speed (the inertia loads scale with Omega^2, the linear answer
    # departs from them as r grows): every computed sweep is increasing at its first ratios
    h = after["history_error"]
    assert np.all(np.diff(h[:, :4], axis=1) > 0)


def test_a_slider_stratum_with_few_scenes_grants_nothing_and_says_so(tmp_path):
    # Expected: with n threshold scenes and no unsafe call, the Clopper-Pearson upper 95 % bound of the unsafe
    # rate is 1 - 0.025^(1/n) > 3 % for n < 122; a stratum below MIN_STRATUM = 100 grants no quasi-static tier,
    # its strata are named slider-crank/<mass model>/source, and nothing of them is published.
    path = tmp_path / "slider_atlas.h5"
    run_atlas(path, linkages=2, workers=1, kind=SLIDER, **QUIET)
    run_threshold(path, n=3, top_up=0, workers=1, **QUIET)
    strata = cal.strata_margins(path)
    assert set(strata) <= {f"slider-crank/{m}/source" for m in SLIDER.mass_models} and strata
    for m in strata.values():
        assert m.stats.n < cal.MIN_STRATUM and m.holds_below == 0.0 and not m.bound_met
    assert cal.clopper_pearson(0, 121).high95 > cal.MAX_UNSAFE_UPPER95 >= cal.clopper_pearson(0, 122).high95
    cal.store_margins(path)
    rec = publish.build(path)
    assert rec["kind"] == "slider-crank" and rec["margins"]["10"] == {}
    assert set(rec["limits"]) <= set(SLIDER.mass_models)


def test_slider_rows_are_predicted_and_swept_again_with_the_slider_generator(tmp_path):
    # Expected: a prediction row at a family's sweep ratio has the quasi-static-vs-linear error the family sweep
    # stored there (two code paths: ked_research.atlas.repredict.predict and ked_research.atlas.compute.sweep), which
    # needs the linkage drawn again by the slider generator, not the four-bar one; the families swept again equal the
    # stored ones (the same code made them)
    from ked_research.atlas import lumps, repredict, resweep
    from ked_research.atlas.compute import RATIOS

    path = tmp_path / "slider_atlas.h5"
    run_atlas(path, linkages=1, workers=1, kind=SLIDER, **QUIET)
    fams = atlas_store.read(path, "families")
    n, j = len(fams["linkage"]), 2
    rows = {"key": [f"k{i}" for i in range(n)], "linkage": list(fams["linkage"]),
            "mechanism": list(fams["mechanism"]), "mass_model": list(fams["mass_model"]), "r": [RATIOS[j]] * n,
            "qs_vs_linear": [9.0] * n, "linear_flags": [0] * n, "floquet_max_abs": [9.0] * n}
    atlas_store.write(path, {}, replaces={"threshold": rows})
    assert repredict.repredict(path, ("threshold",), workers=1, **QUIET) == {"threshold": n}
    np.testing.assert_allclose(atlas_store.read(path, "threshold")["qs_vs_linear"], fams["history_error"][:, j],
                               rtol=1e-9)
    atlas_store.write(path, {lumps.ATTR: {}})  # families as if made by an older code
    assert resweep.resweep(path, workers=1, **QUIET) == 1
    np.testing.assert_allclose(atlas_store.read(path, "families")["history_error"], fams["history_error"],
                               rtol=1e-9, equal_nan=True)


def test_publishing_the_slider_atlas_keeps_the_four_bar_entries():
    # Expected: merging a slider record replaces only the slider-crank strata and limits; the four-bar ones,
    # and the file's top-level four-bar limits, stay as they were (and the reverse).
    old = {"source": "atlas atlas.h5", "damping_ratio": 0.02, "limits": {"tip": {"linear_r10": 0.3}},
           "margins": {"10": {"four-bar/tip/source": {"holds_below": 0.9}, "slider-crank/tip/source": {"x": 1}}}}
    new = {"kind": "slider-crank", "source": "atlas slider_atlas.h5", "damping_ratio": 0.02,
           "limits": {"tip": {"linear_r10": 0.5}}, "margins": {"10": {"slider-crank/joints/source": {"y": 2}}}}
    out = published.merge(old, new)
    assert out["limits"] == old["limits"] and out["source"] == old["source"]
    assert out["margins"]["10"] == {"four-bar/tip/source": {"holds_below": 0.9}, "slider-crank/joints/source": {"y": 2}}
    assert published.kind_limits(out, "slider-crank") == {"tip": {"linear_r10": 0.5}}
    assert published.kind_limits(out, "four-bar") == {"tip": {"linear_r10": 0.3}}
    back = published.merge(out, {**old, "kind": "four-bar", "limits": {"tip": {"linear_r10": 0.31}},
                                 "margins": {"10": {}}})
    assert back["margins"]["10"] == {"slider-crank/joints/source": {"y": 2}}
    assert back[published.KIND_LIMITS] == out[published.KIND_LIMITS]


def _simeon_check(rpm: float) -> dict:
    import json

    from click.testing import CliRunner

    from ked_cli.main import cli

    out = CliRunner().invoke(cli, ["check", "--linkage", "simeon", "--rpm", str(rpm), "--json"])
    assert out.exit_code == 0, out.output
    (row,) = json.loads(out.output)
    return row


def test_check_simeon_grants_a_tier_from_its_slider_strata_margins(monkeypatch):
    # Expected: Simeon's rod (omega1 = 1276.7 rad/s, data sheet) at 100 rpm runs at r = 0.0082, where the
    # predicted quasi-static error is some 0.02 % (it scales with r^2: 0.47 % at r = 0.039); with its stratum
    # slider-crank/distributed/source calibrated (holds_below 0.9) and a linear limit far above r, the prediction
    # alone grants the quasi-static tier and names the slider calibration; an uncalibrated stratum grants none.
    rec = {"damping_ratio": 0.02, "limits": {},
           published.KIND_LIMITS: {"slider-crank": {"source": "atlas slider_atlas.h5", "limits": {
               "distributed": {"linear_r10": 0.3, "linear_r10_spread": 0.05, "linear_r5": 0.2,
                               "linear_r5_spread": 0.05}}}},
           "margins": {"10": {"slider-crank/distributed/source": {
               "holds_below": 0.9, "fails_above": 1.1, "n_scenes": 150, "unsafe_rate": 0.0, "unsafe_upper95": 0.024,
               "source": "atlas slider_atlas.h5: stratum slider-crank/distributed/source"}}}}
    monkeypatch.setattr(published, "read", lambda: rec)
    row = _simeon_check(100.0)
    assert row["speed_ratio"] == pytest.approx(100.0 * 2 * math.pi / 60 / 1276.7, rel=0.02)
    assert row["linear_vs_quasi_static"] < 0.01 * 0.10
    assert row["tier"] == row["predicted_tier"] == "quasi-static" and row["decided_by"] == "predicted"
    assert row["linear_limit_speed_ratio"] == pytest.approx(0.25) and "slider_atlas" in row["margins_source"]
    rec["margins"]["10"] = {}
    row = _simeon_check(100.0)
    assert row["tier"] == "borderline" and "not calibrated" in row["margins_source"]


def test_check_simeon_reads_the_published_slider_margins():
    # Expected: where the committed slider atlas calibrated Simeon's stratum, a slow speed (r = 0.0082, predicted
    # error ~0.02 %, far below any margin and the linear limit) is quasi-static from the prediction alone.
    stratum = "slider-crank/distributed/source"
    if stratum not in published.read().get("margins", {}).get("10", {}):
        pytest.skip(f"{stratum} not calibrated in the published limits")
    row = _simeon_check(100.0)
    assert row["tier"] == "quasi-static" and row["decided_by"] == "predicted" and stratum in row["margins_source"]


def test_speed_at_error_inverts_a_power_law_sweep():
    # Expected: on a sweep e = c r^2 (the inertia loads' scaling near rest) the power-law interpolation between
    # grid ratios is exact, r = sqrt(target / c); a sweep that starts above the target or never reaches it: nan.
    from ked_research.atlas.compute import RATIOS
    from ked_research.atlas.threshold import speed_at_error

    r = np.asarray(RATIOS)
    e = 4.0 * r**2
    for target in (0.07, 0.1, 0.105):
        assert speed_at_error(r, e, target) == pytest.approx(math.sqrt(target / 4.0), rel=1e-12)
    assert math.isnan(speed_at_error(r, e, 2.0)) and math.isnan(speed_at_error(r, e + 0.5, 0.1))
