"""Numerical failures are reported as such, never as physics; limits known at load are refused at load.

Expected values: the linear model's coordinate cap (ked_linear.result.MAX_COORDINATES = 240: two per moving
lump, so 120 lumps, i.e. 30 per link of the four links of the distributed model), the speed-ratio rules of
ked_quasi.rules (r <= 10, r >= MIN_SPEED_RATIO; r of a speed from the lowest first natural frequency
``ked quasi`` reports), and one line naming the option or file for every refusal (exit 2).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ked_linear.result import MAX_COORDINATES
from ked_quasi import rules
from ked_quasi.presets import make_scene

from .test_refusals import assert_refused, ked, write

HEAVY_SLIDER = """[linkage]
kind = "slider-crank"
crank = 0.15
coupler = 0.30
slider_mass = 10000.0
[linkage.section]
youngs_modulus = 2.0e11
area = 6.4e-5
second_moment = 3.4133333333333335e-10
density = 7870.0
[linkage.sections.crank]
rigid = true
"""
"""An accepted slider-crank (every value within its rule; a 10 t slider on a 0.3 m steel coupler) whose
linear solve fails numerically: its monodromy overflows and the solve meets a non-finite matrix
("Array must not contain infs or NaNs", a regression pin of today's numerics)."""


def test_linear_numerical_failure_is_not_a_physical_verdict(tmp_path):
    path = write(tmp_path, "heavy.toml", HEAVY_SLIDER)
    res = ked("check", "--linkage", str(path), "--rpm", "100", "--json")
    assert res.returncode == 0, res.stderr[-2000:]
    (row,) = json.loads(res.stdout)
    assert row["verdict"].startswith("linear model failed numerically")
    assert "no stable linear steady state" not in row["verdict"]
    assert "linear_failed" in row["flags"] and row["tier"] == "nonlinear"
    lin = ked("linear", "--linkage", str(path), "--rpm", "100")
    assert lin.returncode == 1 and "Traceback" not in lin.stderr
    assert "linear model failed numerically" in lin.stderr.strip().splitlines()[-1]


def test_linear_applies_the_speed_ratio_bound_to_a_slider_crank():
    """Simeon's slider-crank at 100 000 rpm and stiffness x0.1: r = 25.9 (its lowest first frequency 64.2 Hz);
    ked quasi refuses it, so must ked linear."""
    args = ("--linkage", "simeon", "--rpm", "100000", "--stiffness-scale", "0.1")
    assert_refused(ked("quasi", *args), "--rpm", "above 10")
    assert_refused(ked("linear", *args), "--rpm", "above 10")


def test_lumps_beyond_the_linear_models_cap_are_refused_at_load():
    from ked_linear.size import check_size, elastic_size, max_lumps

    scene = make_scene(mass_model="distributed", lumps=30)
    assert elastic_size(scene) == MAX_COORDINATES  # 4 links x 30 lumps x 2 coordinates
    assert max_lumps(make_scene(mass_model="distributed", lumps=256)) == 30
    check_size(scene)
    with pytest.raises(ValueError, match="allowed: 1..30"):
        check_size(make_scene(mass_model="distributed", lumps=31))
    line = assert_refused(ked("check", "--mass-model", "distributed", "--lumps", "256"), "--lumps", "256",
                          "allowed: 1..30")
    assert "lumps" in line
    assert_refused(ked("linear", "--mass-model", "distributed", "--lumps", "31"), "--lumps", "allowed: 1..30")
    assert_refused(ked("check", "--linkage", "simeon", "--lumps", "256"), "--lumps", "allowed: 1..")


@pytest.mark.parametrize("preset, kind", [("simeon", "four-bar"), ("thesis", "slider-crank")])
def test_preset_and_kind_in_conflict_name_the_file_and_keys(tmp_path, preset, kind):
    path = write(tmp_path, "conflict.toml", f'[linkage]\npreset = "{preset}"\nkind = "{kind}"\n')
    for cmd in ("quasi", "check", "linear", "simulate"):
        assert_refused(ked(cmd, "--linkage", str(path)), str(path), "preset", "kind", "conflict")
    cfg = write(tmp_path, "campaign.toml",
                f'[linkage]\npreset = "{preset}"\nkind = "{kind}"\n\n[grid]\nrpm = [100.0]\n')
    assert_refused(ked("run", str(cfg), "--dry-run"), str(cfg), "preset", "kind", "conflict")


def test_simeon_preset_in_a_linkage_file_is_the_slider_crank(tmp_path):
    path = write(tmp_path, "simeon.toml", '[linkage]\npreset = "simeon"\n')
    a = ked("quasi", "--linkage", str(path), "--rpm", "1432.4", "--step-deg", "30", "--json")
    b = ked("quasi", "--linkage", "simeon", "--rpm", "1432.4", "--step-deg", "30", "--json")
    assert a.returncode == 0, a.stderr[-2000:]
    assert json.loads(a.stdout)["dx_m"] == json.loads(b.stdout)["dx_m"]


@pytest.mark.parametrize("rpm", ["1e-100", "1e-12", "0.01"])
def test_speeds_below_the_speed_ratio_floor_are_refused(rpm):
    """Thesis tip model: lowest first frequency 9.02 Hz, so 0.01 rpm is r = 1.85e-5 < 1e-4."""
    assert_refused(ked("quasi", "--rpm", rpm), "--rpm", f"below {rules.MIN_SPEED_RATIO:g}")
    assert_refused(ked("check", "--rpm", "300", "--rpm", rpm), "--rpm", f"below {rules.MIN_SPEED_RATIO:g}")


def test_the_speed_ratio_floor_in_campaigns(tmp_path: Path):
    cfg = write(tmp_path, "slow.toml", '[campaign]\nname = "slow"\n\n[grid]\nrpm = [1e-9, 300.0]\n')
    assert_refused(ked("run", str(cfg), "--dry-run"), "grid.rpm", "below")
    cfg = write(tmp_path, "ratio.toml", '[campaign]\nname = "ratio"\n\n[grid]\nspeed_ratios = [1e-6]\n')
    assert_refused(ked("run", str(cfg), "--dry-run"), "grid.speed_ratios")
    ok = ked("quasi", "--rpm", "1", "--json")  # r ~ 1.8e-3: the harness's slowest scenes stay accepted
    assert ok.returncode == 0, ok.stderr[-2000:]


def test_a_campaign_running_the_linear_model_refuses_lumps_beyond_its_cap(tmp_path: Path):
    text = '[campaign]\nname = "lumps"\n{solvers}\n[grid]\nmass_models = [{{name = "distributed", lumps = 64}}]\n'
    cfg = write(tmp_path, "lumps.toml", text.format(solvers=""))  # the default solvers include the linear model
    assert_refused(ked("run", str(cfg), "--dry-run"), "grid.mass_models[0].lumps", "allowed: 1..30")
    cfg = write(tmp_path, "qs.toml", text.format(solvers='solvers = ["quasi_static"]'))
    assert ked("run", str(cfg), "--dry-run").returncode == 0  # the quasi-static solver takes 64 lumps per link
