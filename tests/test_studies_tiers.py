"""Tiers study: the findings (limits, their ranges, where the error comes from) on scenes whose errors are
set by construction, so every expected number follows from the definitions in ked_research.tiers.study."""

from __future__ import annotations

import math

import pytest

from ked_research.tiers.study import COARSE_STEP, TierPoint, analyse

R = (0.02, 0.04, 0.06, 0.08, 0.12)


def _point(r: float, linkage: str = "L", mass_model: str = "tip", dyn_ok: bool = True) -> TierPoint:
    # quasi-static error = r, linear = r / 10, classic linear = r / 5; dynamic part r / 2 and nonlinear part
    # r / 10; peak deflection / shortest link = r
    return TierPoint(linkage=linkage, mechanism="source", mass_model=mass_model, r=r, dyn_ok=dyn_ok,
                     dyn_reason="" if dyn_ok else "no_steady_state: no periodic steady state (time=3)",
                     error={"quasi_static": r, "linear": r / 10, "linear_classic": r / 5},
                     dynamic_part=r / 2 if dyn_ok else math.nan, nonlinear_part=r / 10 if dyn_ok else math.nan,
                     deflection_ratio=r, floquet_max_abs=0.5)


def test_limits_are_the_first_crossings_on_the_grid() -> None:
    f = analyse([_point(r) for r in R])
    (fam,) = f.families
    q5, q10 = fam.limits["quasi_static", 0.05], fam.limits["quasi_static", 0.1]
    # error = r: 0.04 passes 5 %, 0.06 does not; 0.08 passes 10 %, 0.12 does not
    assert (q5.status, q5.r_limit, q5.step) == ("crossed", 0.04, pytest.approx(0.02))
    assert (q10.status, q10.r_limit, q10.step) == ("crossed", 0.08, pytest.approx(0.04))
    assert fam.limits["linear", 0.05].status == "above_grid"  # r / 10 <= 0.012 everywhere
    # r / 5 = 0.024 at 0.12: under both tolerances
    assert fam.limits["linear_classic", 0.1].status == "above_grid"
    assert f.spans["tip"]["quasi_static", 0.05] == (0.04, 0.04)
    assert all(math.isnan(x) for x in f.spans["tip"]["linear", 0.1])  # nothing crossed: no range
    assert COARSE_STEP < 0.04 and f.coarse == ("L",)  # the 10 % limit is known only to 0.04


def test_ranges_span_the_linkages_and_parts_are_counted() -> None:
    pts = [_point(r) for r in R] + [_point(r, linkage="M") for r in (0.03, 0.045, 0.07)]
    f = analyse(pts)
    # quasi-static error = r: L passes 5 % up to 0.04, M up to 0.045 (fails at 0.07)
    assert f.spans["tip"]["quasi_static", 0.05] == (0.04, 0.045)
    # every scene has both parts; dynamic part r / 2 > nonlinear part r / 10 at every r
    assert f.parts == 8 and f.low_r == sum(p.r <= 0.1 for p in pts) and f.low_r_dynamic_larger == f.low_r
    assert f.large_deflection == sum(p.r > 0.1 for p in pts) == 1 and f.large_deflection_nonlinear_larger == 0


def test_a_failed_exudyn_run_ends_the_walk_and_is_listed() -> None:
    pts = [_point(0.02), _point(0.04), _point(0.06, dyn_ok=False)]
    f = analyse(pts)
    lim = f.families[0].limits["linear", 0.05]
    assert (lim.status, lim.r_limit) == ("failure", 0.04)
    assert f.failures == (pts[2],) and f.parts == 2
