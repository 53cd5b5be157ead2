"""ked check: the design check runs the campaign's own code path, so for the default campaign's scenes it
reproduces the numbers a campaign stores; its tier rule grants a tier only inside the range of the model
it is judged against, has a borderline band, and yields to the errors measured with --confirm."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from compare import metrics, store
from compare.config import load_config
from compare.runner import run_scenes
from ked_check.check import (
    LinearRange,
    VerdictMargins,
    check,
    check_row,
    measured_tier,
    spec_for,
    tier,
    verdict_margins,
)
from ked_cli.main import cli
from ked_quasi import MassModel, thesis_fourbar
from ked_quasi.massmodel import default_payload


def _default_scene(mass_model: str, rpm: float):
    return next(s for s in load_config(None).scenes()
                if s.mechanism == "source" and s.mass_model.name == mass_model and s.speed.value == rpm)


@pytest.mark.parametrize("mm, rpm", [("tip", 75.0), ("extender", 300.0)])
def test_a_check_is_the_default_campaigns_scene(mm, rpm):
    # same content key: the same linkage, mass model, grid, tolerance and pinned Exudyn settings
    spec = spec_for(thesis_fourbar(), "source", MassModel(mm, payload=default_payload(mm)), rpm)
    assert spec.key == _default_scene(mm, rpm).key


def test_check_reproduces_the_stored_quasi_static_and_linear_numbers(tmp_path):
    scenes = [_default_scene("tip", 75.0), _default_scene("extender", 150.0)]
    scenes = [replace(s, solvers=("quasi_static", "linear")) for s in scenes]
    out = tmp_path / "c.h5"
    run_scenes(scenes, out, name="check", workers=1, progress=False)
    stored = {r.key: r for r in store.read_scenes(out)}
    for s in scenes:
        (row,) = check(thesis_fourbar(), "source", s.mass_model, [s.speed.value])
        r = stored[row.key]
        xy = {n: np.column_stack([r.history(n)["dx"], r.history(n)["dy"]]) for n in ("quasi_static", "linear")}
        assert row.quasi_static_peak_m == metrics.peak(xy["quasi_static"])  # exactly: one code path
        assert row.linear_peak_m == metrics.peak(xy["linear"])
        assert row.linear_vs_quasi_static == metrics.history_error(xy["quasi_static"], xy["linear"])
        assert row.speed_ratio == r.verdict.speed_ratio


def test_tiers_follow_the_predicted_errors():
    rows = check(thesis_fourbar(), "source", MassModel("extender"), [30.0, 600.0])
    slow, fast = rows
    # at r ~ 0.01 the dynamic part is far below 10 %: quasi-static; at 600 rpm it is not
    assert slow.tier == "quasi-static" and slow.linear_vs_quasi_static < slow.holds_below_error
    assert slow.speed_ratio < slow.linear_limit_speed_ratio and slow.decided_by == "predicted"
    assert fast.tier in ("linear", "nonlinear") and fast.speed_ratio > slow.speed_ratio


def _extender_300():
    """Case III at 300 rpm (r = 0.11), quasi-static and linear only: the quasi-static answer is ~9 % off
    the linear model (the default campaign measures 8.1 % against Exudyn): near a 10 % threshold."""
    from compare.execute import run_scene
    from compare.solvers import get

    r = run_scene(spec_for(thesis_fourbar(), "source", MassModel("extender", payload=default_payload("extender")),
                           300.0), [get("quasi_static"), get("linear")])
    xy = {n: metrics.vector(r.solutions[n].deflection) for n in ("quasi_static", "linear")}
    return r, metrics.history_error(xy["quasi_static"], xy["linear"]), r.verdict.speed_ratio


def test_tier_bands_follow_the_rule():
    """Expected tiers from the rule itself (module docstring of ked_check.check) applied to the predicted
    error e and speed ratio r of one scene, with tolerances and limits placed around them."""
    r, e, ratio = _extender_300()
    assert 0.07 < e < 0.12 and 0.10 < ratio < 0.12
    wide = LinearRange(r5=0.5, r5_spread=0.1, r10=0.5, r10_spread=0.1, source="test")  # lower band 0.4 > r
    m = VerdictMargins(holds_below=0.6, fails_above=1.4)
    assert wide.lower_limit(0.10) == pytest.approx(0.4) and wide.lower_limit(0.05) == pytest.approx(0.4)
    t_hold, t_border, t_fail = 1.01 * e / m.holds_below, e, 0.99 * e / m.fails_above
    assert tier(r, wide, t_hold, m)[0] == "quasi-static"  # e < holds_below x tolerance, r inside
    name, text = tier(r, wide, t_border, m)  # holds_below x t < e < fails_above x t
    assert name == "borderline" and "--confirm" in text
    assert tier(r, wide, t_fail, m)[0] == "linear"  # e > fails_above x tolerance, r inside
    # r beyond the linear model's lower band: the linear model cannot judge, so no quasi-static/linear tier
    narrow = LinearRange(r5=0.9 * ratio, r5_spread=0.0, r10=0.9 * ratio, r10_spread=0.0, source="test")
    assert tier(r, narrow, t_hold, m)[0] == "borderline"
    assert tier(r, narrow, t_fail, m)[0] == "nonlinear"
    # lower band, not the median: the median above r, median - spread below it
    banded = LinearRange(r10=1.1 * ratio, r10_spread=0.2 * ratio, r5=1.1 * ratio, r5_spread=0.2 * ratio)
    assert tier(r, banded, t_hold, m)[0] == "borderline"
    # without an atlas the linear model's range is unknown: never quasi-static or linear from a prediction
    assert tier(r, LinearRange(), t_hold, m)[0] == "borderline"
    assert tier(r, LinearRange(), t_fail, m)[0] == "nonlinear"
    # a stratum without calibration against Exudyn: never quasi-static from the prediction, and it says so
    name, text = tier(r, wide, t_hold, VerdictMargins(source="four-bar/tip/source: not calibrated"))
    assert name == "borderline" and "not calibrated" in text and "--confirm" in text
    assert tier(r, wide, t_fail, VerdictMargins())[0] == "linear"  # far above the tolerance: still linear
    # narrower margins move the band: with holds_below 0.99 an error of 0.95 x tolerance holds
    assert tier(r, wide, e / 0.95, VerdictMargins(holds_below=0.99, fails_above=1.01))[0] == "quasi-static"
    row = check_row(r, wide, 0.10, m)  # the JSON states the numbers the rule used
    assert row.linear_limit_speed_ratio == pytest.approx(0.4)
    assert row.holds_below_error == pytest.approx(0.10 * m.holds_below)
    assert row.fails_above_error == pytest.approx(0.10 * m.fails_above)
    assert row.margins_source == m.source and row.predicted_tier == row.tier


def test_verdict_margins_are_validated_and_default_conservative():
    d = VerdictMargins()  # a stratum without calibration: the prediction never grants the quasi-static tier
    assert (d.holds_below, d.fails_above, d.calibrated) == (0.0, 1.4, False)
    for bad in ((-0.1, 1.4), (1.2, 1.4), (0.6, 0.9), (0.6, math.inf)):
        with pytest.raises(ValueError, match="verdict margins"):
            VerdictMargins(*bad)
    m = verdict_margins(0.10, "four-bar/tip/source")  # calibrated by the atlas where it offers them
    assert 0 <= m.holds_below <= 1 <= m.fails_above


def test_measured_errors_decide():
    # the rule: quasi-static if its measured error < tolerance, else linear if the linear one is, else nonlinear
    assert measured_tier({}, 0.1) is None
    name, text = measured_tier({"quasi_static_vs_dynamic": 0.081, "linear_vs_dynamic": 0.01}, 0.1)
    assert name == "quasi-static" and text.startswith("measured: quasi-static 8.1% vs Exudyn")
    name, text = measured_tier({"quasi_static_vs_dynamic": 0.226, "linear_vs_dynamic": 0.054}, 0.1)
    assert name == "linear" and "measured" in text and "5.4%" in text and "nonlinear" not in text
    assert measured_tier({"quasi_static_vs_dynamic": 0.3, "linear_vs_dynamic": 0.12}, 0.1)[0] == "nonlinear"
    assert measured_tier({"quasi_static_vs_dynamic": 0.1, "linear_vs_dynamic": 0.1}, 0.1)[0] == "nonlinear"


def test_cli_json_keys_and_confirm():
    res = CliRunner().invoke(cli, ["check", "--mass-model", "extender", "--rpm", "75", "--json", "--confirm"])
    assert res.exit_code == 0, res.output
    (row,) = json.loads(res.output)
    for key in ("speed_ratio", "quasi_static_peak_m", "linear_peak_m", "quasi_static_error_estimate",
                "floquet_max_abs", "tier", "verdict", "linear_limit_speed_ratio", "holds_below_error",
                "fails_above_error", "margins_source", "decided_by", "predicted_tier"):
        assert key in row
    assert row["decided_by"] == "measured" and row["verdict"].startswith("measured:")
    c = row["confirmed"]
    # at r = 0.02 all three models agree to the Exudyn discretization (the default campaign's floor, ~1 %)
    assert c["quasi_static_vs_dynamic"] < 0.05 and c["linear_vs_dynamic"] < 0.05
    assert math.isfinite(row["floquet_max_abs"]) and row["floquet_max_abs"] < 1


def test_unconverged_linear_solve_is_retried_with_more_harmonics():
    """Source linkage, joints, 150 rpm (r = 0.11): at the default 32 harmonics the linear periodic solve
    is flagged unresolved (the campaign stores it so); the check solves it again with up to 64 and
    recommends the linear model, and Exudyn confirms that model within 5 % (the default campaign
    measured 1.8 %)."""
    from compare.execute import run_scene
    from compare.solvers import get

    mm = MassModel("joints")
    stored = run_scene(spec_for(thesis_fourbar(), "source", mm, 150.0), [get("quasi_static"), get("linear")])
    assert stored.solutions["linear"].flags == ("unresolved",)
    default = check(thesis_fourbar(), "source", mm, [150.0])[0]
    assert default.linear_harmonics > 32 and "did not converge" in default.verdict
    (row,) = check(thesis_fourbar(), "source", mm, [150.0], confirm=True)
    assert row.tier == "linear" and "unresolved" not in row.flags
    assert row.confirmed["linear_vs_dynamic"] < 0.05 < 0.10 < row.confirmed["quasi_static_vs_dynamic"]
    assert row.decided_by == "measured" and "use the linear model" in row.verdict


def test_atlas_limit_at_another_damping_is_called_a_guide():
    """The atlas measured the linear model's limits at 2 % damping (ked_research.atlas.compute.DAMPING); a
    check at 5 % that leans on them says so, one at 2 % does not."""
    other, same = (check(thesis_fourbar(), "source", MassModel("joints"), [225.0], damping_ratio=z)[0]
                   for z in (0.05, 0.02))
    assert other.tier == same.tier == "linear"  # r = 0.17: quasi-static ~50 % off, far below the atlas limit
    assert "measured at 0.02 damping" in other.verdict and "measured at" not in same.verdict


def test_confirmed_check_reproduces_the_stored_exudyn_numbers(tmp_path):
    """With --confirm a check is the default campaign's scene with all three solvers: the errors it
    reports equal those computed from the histories a campaign stores for that scene (same code path;
    the Exudyn run is deterministic, so the agreement is to rounding)."""
    scene = _default_scene("extender", 75.0)
    out = tmp_path / "c.h5"
    run_scenes([scene], out, name="check", workers=1, progress=False)
    (r,) = store.read_scenes(out)
    xy = {n: np.column_stack([r.history(n)["dx"], r.history(n)["dy"]]) for n in ("quasi_static", "linear", "dynamic")}
    (row,) = check(thesis_fourbar(), "source", scene.mass_model, [75.0], confirm=True)
    assert row.key == r.key
    for name in ("quasi_static", "linear"):
        expected = metrics.history_error(xy[name], xy["dynamic"])
        assert row.confirmed[f"{name}_vs_dynamic"] == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_the_check_is_one_call_whose_report_the_command_renders():
    # ked_check.run is the design check of a script: the rows and the critical speeds the command prints come from
    # it (a second path: `ked check --json` through the command line gives the same numbers)
    import ked_check

    mm = MassModel("tip", payload=default_payload("tip"))
    report = ked_check.run(thesis_fourbar(), "source", mm, [100.0, 250.0, 400.0])
    assert [r.rpm for r in report.rows] == [100.0, 250.0, 400.0]
    res = CliRunner().invoke(cli, ["check", "--mass-model", "tip", "--rpm", "100", "--rpm", "250", "--rpm", "400",
                                   "--json", "--workers", "1"])
    assert res.exit_code == 0, res.output
    printed = json.loads(res.output)
    assert [p["tier"] for p in printed] == [r.tier for r in report.rows]
    assert [p["linear_peak_m"] for p in printed] == [r.linear_peak_m for r in report.rows]
    assert printed[0]["critical_speeds_rpm"] == [c.rpm for c in report.critical_speeds]
    assert printed[0]["amplification_peaks_rpm"] == list(report.amplification_peaks_rpm)
