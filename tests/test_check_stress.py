"""``ked check`` stress and fatigue keys: present beside every existing key, consistent with the stress
modules, and refusals that name the option."""

import json

import pytest
from click.testing import CliRunner

from ked_cli.main import cli

OLD_KEYS = {"speed_ratio", "quasi_static_peak_m", "linear_peak_m", "linear_vs_quasi_static",
            "quasi_static_error_estimate", "floquet_max_abs", "tier", "verdict", "rpm", "flags", "confirmed", "key"}
LINKS = ("crank", "coupler", "extender", "follower")


def _check(*args):
    return CliRunner().invoke(cli, ["check", "--workers", "1", *args])


def test_json_gains_stress_keys_and_keeps_the_old_ones():
    res = _check("--rpm", "100", "--mass-model", "distributed", "--json",
                 "--ultimate-strength", "310e6", "--endurance-limit", "96.5e6")
    assert res.exit_code == 0, res.output
    row = json.loads(res.output)[0]
    assert OLD_KEYS <= set(row)
    s = row["stress"]
    for lk in LINKS:
        assert s[f"quasi_static_peak_pa_{lk}"] > 0 and s[f"linear_peak_pa_{lk}"] > 0
        assert 0 <= s[f"stress_error_{lk}"] < 0.2  # 100 rpm, r = 0.07: a few per cent, as the deflection's 5 %
    # the definition of the overstatement key
    assert s["goodman_overstatement"] == pytest.approx(s["goodman_quasi_static"] / s["goodman_linear"] - 1)
    # Goodman: 1/n = sigma_a/S_e + sigma_m/S_u <= (sigma_a + |sigma_m|)/S_e = max|sigma| at the point / S_e,
    # so each tier's factor is at least S_e / (its largest peak over the links)
    for tier in ("quasi_static", "linear"):
        top = max(s[f"{tier}_peak_pa_{lk}"] for lk in LINKS)
        assert s[f"goodman_{tier}"] >= 96.5e6 / top * (1 - 1e-12)
    # the stress verdict names the worst link's error and grants no tier
    worst = max(LINKS, key=lambda lk: s[f"stress_error_{lk}"])
    assert f"within {s[f'stress_error_{worst}']:.1%}" in row["stress_verdict"] and worst in row["stress_verdict"]
    assert "not calibrated against Exudyn" in row["stress_verdict"]


def test_no_stress_verdict_without_a_material():
    row = json.loads(_check("--rpm", "100", "--json").output)[0]
    assert row["stress"] == {} and row["stress_verdict"] == ""


def test_text_prints_the_fatigue_line():
    res = _check("--rpm", "100", "--mass-model", "distributed", "--ultimate-strength", "310e6",
                 "--endurance-limit", "96.5e6")
    assert res.exit_code == 0, res.output
    assert "Fatigue (Goodman): safety factor" in res.output and "quasi-static factor" in res.output
    assert "Stress: the quasi-static stress is within" in res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize(("args", "name"), [
    (("--ultimate-strength", "100e6", "--endurance-limit", "200e6"), "--endurance-limit"),
    (("--ultimate-strength", "100e6"), "--endurance-limit"),
    (("--ultimate-strength", "-5", "--endurance-limit", "1e6"), "--ultimate-strength"),
])
def test_material_refusals_name_the_option(args, name):
    res = _check("--rpm", "100", *args)
    assert res.exit_code != 0 and name in res.output and "Traceback" not in res.output


def _file(tmp_path, fatigue: str):
    path = tmp_path / "linkage.toml"
    path.write_text(f'[linkage]\npreset = "thesis"\n\n[grid]\nmass_models = ["distributed"]\n\n{fatigue}\n')
    return str(path)


def test_a_linkage_file_carries_its_fatigue_material(tmp_path):
    # Expected: the file's [fatigue] table gives the same stress keys as the options with the same strengths;
    # the options override it
    table = "[fatigue]\nultimate_strength = 310e6\nendurance_limit = 96.5e6"
    from_file = json.loads(_check("--linkage", _file(tmp_path, table), "--rpm", "100", "--json").output)[0]
    from_options = json.loads(_check("--rpm", "100", "--mass-model", "distributed", "--json", "--ultimate-strength",
                                     "310e6", "--endurance-limit", "96.5e6").output)[0]
    assert from_file["stress"] == pytest.approx(from_options["stress"], rel=1e-12)
    stronger = json.loads(_check("--linkage", _file(tmp_path, table), "--rpm", "100", "--json",
                                 "--ultimate-strength", "620e6", "--endurance-limit", "193e6").output)[0]
    assert stronger["stress"]["goodman_linear"] > from_file["stress"]["goodman_linear"]


@pytest.mark.parametrize(("table", "named"), [
    ("[fatigue]\nultimate_strength = 310\nendurance_limit = 96.5", "fatigue.ultimate_strength"),  # MPa
    ("[fatigue]\nultimate_strength = 310e6", "fatigue.endurance_limit"),  # required
    ("[fatigue]\nultimate_strength = 310e6\nendurance_limt = 96.5e6", "fatigue.endurance_limt"),  # misspelt
    ("[fatigue]\nultimate_strength = 100e6\nendurance_limit = 200e6", "fatigue.endurance_limit"),  # S_e > S_u
    ("[fatigue]\nultimate_strength = 310e6\nendurance_limit = 96.5e6\ncriterion = \"soderberg\"", "fatigue.criterion"),
    ("[fatigue]\nultimate_strength = 310e6\nsn_curve = [[1e6, 1.4e8], [1e3, 2.4e8]]\ndesign_cycles = 1e5",
     "fatigue.sn_curve"),  # cycles decreasing
    ("[fatigue]\nultimate_strength = 310e6\nsn_curve = [1e6, 1.4e8]\ndesign_cycles = 1e5", "fatigue.sn_curve"),
    ("[fatigue]\nultimate_strength = 310e6\nsn_curve = [[1e3, 2.4e8], [1e6, 1.4e8]]\ndesign_cycles = 1e8",
     "fatigue.design_cycles"),  # beyond the curve
])
def test_a_bad_fatigue_table_is_refused_by_every_command(tmp_path, table, named):
    from compare.config import ConfigError, load_config

    res = _check("--linkage", _file(tmp_path, table), "--rpm", "100")
    assert res.exit_code != 0 and named in res.output and "Traceback" not in res.output
    with pytest.raises(ConfigError, match=named.replace(".", r"\.")):  # ked run reads the file alike
        load_config(tmp_path / "linkage.toml")


ALUMINIUM = """[fatigue]
ultimate_strength = 310e6
yield_strength = 276e6
criterion = "gerber"
sn_curve = [[1e3, 6.0e7], [1e6, 2.0e7], [1e9, 8.0e6]]
design_cycles = 1e8
"""
"""A metal without an endurance limit: its S-N curve scaled to the thesis linkage's stresses at 150 rpm (a few
tens of MPa), so that the lives fall on the curve."""


def test_a_fatigue_curve_gives_each_tiers_life_and_the_criterion_its_factor(tmp_path):
    # Expected: the safety_factor keys follow the criterion (Gerber's parabola lies outside Goodman's line, so
    # n_gerber >= n_goodman: Shigley fig. 6-27); the life keys' ratio is their definition; a shorter life goes
    # with a larger stress, so the tier whose factor is the smaller has the shorter life
    row = json.loads(_check("--linkage", _file(tmp_path, ALUMINIUM), "--rpm", "150", "--json").output)[0]
    s = row["stress"]
    assert row["fatigue_criterion"] == "gerber"
    for tier in ("quasi_static", "linear"):
        assert s[f"safety_factor_{tier}"] >= s[f"goodman_{tier}"]
        assert 1e3 < s[f"life_cycles_{tier}"] < 1e9 and s[f"life_unbounded_{tier}"] == 0.0
    assert s["life_overstatement"] == pytest.approx(s["life_cycles_quasi_static"] / s["life_cycles_linear"])
    assert (s["life_overstatement"] > 1) == (s["safety_factor_overstatement"] > 0)
    goodman = json.loads(_check("--linkage", _file(tmp_path, ALUMINIUM), "--rpm", "150", "--json",
                                "--fatigue-criterion", "goodman").output)[0]["stress"]
    assert goodman["safety_factor_quasi_static"] == pytest.approx(goodman["goodman_quasi_static"], rel=1e-12)
    text = _check("--linkage", _file(tmp_path, ALUMINIUM), "--rpm", "150").output
    assert "Fatigue (Gerber)" in text and "cycles" in text and "quasi-static life is" in text


def test_the_criterion_option_needs_a_material():
    res = _check("--rpm", "100", "--fatigue-criterion", "gerber")
    assert res.exit_code != 0 and "--fatigue-criterion" in res.output and "Traceback" not in res.output


def test_confirm_measures_the_stress_against_exudyn():
    # Expected: at 5 rpm (r = 0.004) the dynamic part of the stress is O(r^2); the linear model and Exudyn model
    # the same small-deflection physics, so their stresses agree within 0.1 % of the peak (measured 5e-5), and the
    # quasi-static one within 0.5 % (measured 7e-4); the verdict is then the measurement's, naming no prediction
    res = _check("--mass-model", "tip", "--rpm", "5", "--confirm", "--json", "--ultimate-strength", "310e6",
                 "--endurance-limit", "96.5e6")
    assert res.exit_code == 0, res.output
    row = json.loads(res.output)[0]
    s = row["stress"]
    for lk in LINKS:
        assert s[f"exudyn_peak_pa_{lk}"] > 0
        assert s[f"linear_stress_error_exudyn_{lk}"] < 1e-3 and s[f"stress_error_exudyn_{lk}"] < 5e-3
    assert row["stress_verdict"].startswith("Stress (measured against Exudyn)")
    assert "not calibrated" not in row["stress_verdict"]
