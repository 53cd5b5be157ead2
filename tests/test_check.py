"""ked check: the design check runs the campaign's own code path, so for the default campaign's scenes it
reproduces the numbers a campaign stores; its tier rule follows the measured errors."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from compare import metrics, store
from compare.check import check, spec_for
from compare.config import load_config
from compare.runner import run_campaign
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
    from compare.config import CampaignConfig
    from compare.studies.validity import ExplicitCampaign

    scenes = [_default_scene("tip", 75.0), _default_scene("extender", 150.0)]
    scenes = [replace(s, solvers=("quasi_static", "linear")) for s in scenes]
    base = load_config(None)
    cfg = ExplicitCampaign(**{f: getattr(base, f) for f in CampaignConfig.__dataclass_fields__}, explicit=tuple(scenes))
    out = tmp_path / "c.h5"
    run_campaign(cfg, out, workers=1, progress=False)
    stored = {r.key: r for r in store.read_scenes(out)}
    for s in scenes:
        (row,) = check(thesis_fourbar(), "source", s.mass_model, [s.speed.value])
        r = stored[row.key]
        xy = {n: np.column_stack([r.history(n)["dx"], r.history(n)["dy"]]) for n in ("quasi_static", "linear")}
        assert row.quasi_static_peak_m == metrics.peak(xy["quasi_static"])  # exactly: one code path
        assert row.linear_peak_m == metrics.peak(xy["linear"])
        assert row.linear_vs_quasi_static == metrics.history_error(xy["quasi_static"], xy["linear"])
        assert row.speed_ratio == r.verdict.speed_ratio


def test_tiers_follow_the_measured_errors():
    rows = check(thesis_fourbar(), "source", MassModel("extender"), [30.0, 600.0])
    slow, fast = rows
    # at r ~ 0.01 the dynamic part is far below 10 %: quasi-static; at 600 rpm it is not
    assert slow.tier == "quasi-static" and slow.linear_vs_quasi_static < 0.10
    assert fast.tier in ("linear", "nonlinear") and fast.speed_ratio > slow.speed_ratio


def test_cli_json_keys_and_confirm():
    res = CliRunner().invoke(cli, ["check", "--mass-model", "extender", "--rpm", "75", "--json", "--confirm"])
    assert res.exit_code == 0, res.output
    (row,) = json.loads(res.output)
    for key in ("speed_ratio", "quasi_static_peak_m", "linear_peak_m", "quasi_static_error_estimate",
                "floquet_max_abs", "tier", "verdict"):
        assert key in row
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


def test_atlas_limit_at_another_damping_is_called_a_guide():
    """The atlas measured the linear model's limits at 2 % damping (compare.atlas.compute.DAMPING); a
    check at 5 % that leans on them says so, one at 2 % does not."""
    other, same = (check(thesis_fourbar(), "source", MassModel("joints"), [225.0], damping_ratio=z)[0]
                   for z in (0.05, 0.02))
    assert other.tier == same.tier == "linear"  # r = 0.17: quasi-static ~50 % off, far below the atlas limit
    assert "measured at 0.02 damping" in other.verdict and "measured at" not in same.verdict


def test_confirmed_check_reproduces_the_stored_exudyn_numbers(tmp_path):
    """With --confirm a check is the default campaign's scene with all three solvers: the errors it
    reports equal those computed from the histories a campaign stores for that scene (same code path;
    the Exudyn run is deterministic, so the agreement is to rounding)."""
    from compare.config import CampaignConfig
    from compare.studies.validity import ExplicitCampaign

    scene = _default_scene("extender", 75.0)
    base = load_config(None)
    cfg = ExplicitCampaign(**{f: getattr(base, f) for f in CampaignConfig.__dataclass_fields__}, explicit=(scene,))
    out = tmp_path / "c.h5"
    run_campaign(cfg, out, workers=1, progress=False)
    (r,) = store.read_scenes(out)
    xy = {n: np.column_stack([r.history(n)["dx"], r.history(n)["dy"]]) for n in ("quasi_static", "linear", "dynamic")}
    (row,) = check(thesis_fourbar(), "source", scene.mass_model, [75.0], confirm=True)
    assert row.key == r.key
    for name in ("quasi_static", "linear"):
        expected = metrics.history_error(xy[name], xy["dynamic"])
        assert row.confirmed[f"{name}_vs_dynamic"] == pytest.approx(expected, rel=1e-9, abs=1e-12)
