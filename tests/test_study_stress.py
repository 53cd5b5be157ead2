"""``ked study stress``: one scene through the three tiers, the families' limits from rows with known crossings,
and the report through the command line from a stored file."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from click.testing import CliRunner

from ked_research.stress import report as stress_report
from ked_research.stress import study as stress
from ked_research.study_io import write_tables


def test_one_scene_through_the_three_tiers():
    # thesis linkage, tip mass, r = 0.04: the dynamic part of the response is small (O(r^2) plus the residual
    # vibration), so the linear model is within 1 % of Exudyn in deflection and stress (the two models of the same
    # small-deflection physics, tests/test_exudyn_stress), and every tier's Goodman factor within 5 % of Exudyn's
    row = stress.compute(stress.Case("thesis", "thesis", -1, "source", "tip", 0.04))
    assert row.ok and not row.flags, row.reason
    assert row.deflection_linear < 1e-2 and row.stress_linear < 1e-2
    assert row.stress_qs < stress.TOLERANCE and row.worst_link in ("crank", "coupler", "extender", "follower")
    for factor in (row.goodman_qs, row.goodman_linear):
        assert factor == pytest.approx(row.goodman_exudyn, rel=5e-2)
    assert row.material == "aluminium" and row.rpm > 0


def _row(r: float, deflection: float, stress_error: float, ok: bool = True) -> stress.Row:
    return stress.Row(key=f"x/source/tip/r={r:g}", group="thesis", linkage="x", mechanism="source", mass_model="tip",
                      material="aluminium", r=r, rpm=100 * r, ok=ok, reason="" if ok else "failed", flags="",
                      deflection_ratio=1e-3, deflection_qs=deflection, deflection_linear=0.0, stress_qs=stress_error,
                      stress_linear=0.0, worst_link="crank", goodman_qs=2.2, goodman_linear=2.0, goodman_exudyn=2.0,
                      peak_stress_pa=1e7, wall_s=1.0)


def test_family_limits_are_first_crossings():
    # deflection crosses 10 % between 0.10 and 0.13, stress between 0.06 and 0.08: limits 0.10 and 0.06 (the last
    # grid ratio below the first crossing); at the deflection limit the stress error is 15 %
    rows = [_row(0.04, 0.02, 0.05), _row(0.06, 0.04, 0.09), _row(0.08, 0.06, 0.12), _row(0.10, 0.08, 0.15),
            _row(0.13, 0.12, 0.2)]
    (fam,) = stress_report.families(rows)
    assert fam.deflection.r_limit == 0.10 and fam.stress.r_limit == 0.06
    assert stress_report._below(fam)
    assert stress_report._at_deflection_limit(fam).stress_qs == 0.15
    text = "\n".join(stress_report.by_mass_model([fam]))
    assert "| tip | 1 | 1 | 0.60 | 15.0 %, 15.0 % |" in text
    # a failed Exudyn answer ends the walk: the limit is a lower bound
    (fam,) = stress_report.families([*rows[:2], replace(rows[2], ok=False)])
    assert fam.stress.status == "failure" and fam.stress.r_limit == 0.06
    assert math.isnan(fam.deflection.r_fail) or fam.deflection.r_fail == 0.08


def test_report_only_through_the_cli(tmp_path):
    from ked_cli.main import cli

    rows = [_row(0.04, 0.02, 0.05), _row(0.06, 0.04, 0.09), _row(0.08, 0.12, 0.12)]
    (tmp_path / "studies").mkdir()
    write_tables(tmp_path / "studies" / stress.FILE, {"scenes": rows}, {})
    res = CliRunner().invoke(cli, ["study", "stress", "--report-only", "--results-dir", str(tmp_path)])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "README.md").read_text()
    assert "<!-- BEGIN stress -->" in text and "r* stress (QS)" in text
    assert (tmp_path / "figures" / stress_report.FIGURE).stat().st_size > 10_000
    assert stress.stored(tmp_path / "studies" / stress.FILE) == rows  # the stored rows read back unchanged
