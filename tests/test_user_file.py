"""A user's linkage file means one scene to every command, every command refuses the same bad file, and the
problems of a file arrive one per line (subprocesses of the installed command, real files, real Exudyn)."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from compare.config import ConfigError, parse_config
from compare.inspect import label_names

STEEL = """
[campaign]
name = "steel"
step_deg = 10.0
[linkage]
crank = 0.05
coupler = 0.15
follower = 0.12
extender = 0.08
coupler_angle_deg = 30.0
ground = 0.14
branch = "open"
[linkage.section]
youngs_modulus = 210.0e9
area = 1.0e-4
second_moment = 8.333333333333333e-10
density = 7850.0
[grid]
mechanisms = ["source"]
mass_models = ["tip"]
rpm = [120.0]
damping_ratios = [0.05]
[dynamic]
elements_per_link = 2
steps_per_cycle = 360
"""
"""A steel crank-rocker with a 2 lb tip mass at one low speed (r ~ 0.02) and cheap Exudyn settings of its own:
every setting differs from what the command line would default to (damping 0.05, [dynamic])."""


def ked(*args: str, cwd: object = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ked_cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=900)


def test_check_confirm_and_run_give_one_key_and_one_verdict_error(tmp_path):
    f = tmp_path / "steel.toml"
    f.write_text(STEEL)
    chk = ked("check", "--linkage", str(f), "--confirm", "--json", "--workers", "1")
    assert chk.returncode == 0, chk.stderr
    (row,) = json.loads(chk.stdout)
    out = tmp_path / "steel.h5"
    run = ked("run", str(f), "--out", str(out), "--no-figures", "--workers", "1")
    assert run.returncode == 0, run.stderr
    ins = ked("inspect", str(out), "--json")
    (scene,) = json.loads(ins.stdout)["scenes"]
    assert row["key"] == scene["key"]  # the same scene: linkage, grid, damping 0.05, [dynamic], step
    assert row["rpm"] == 120.0
    assert row["confirmed"]["quasi_static_vs_dynamic"] == pytest.approx(scene["verdict_error"], rel=1e-12)
    # an option given overrides the file explicitly: another scene, another key
    other = ked("check", "--linkage", str(f), "--damping-ratio", "0.02", "--json")
    assert other.returncode == 0, other.stderr
    assert json.loads(other.stdout)[0]["key"] != row["key"]


def test_a_grid_of_several_values_asks_which(tmp_path):
    f = tmp_path / "two.toml"
    f.write_text(STEEL.replace('mass_models = ["tip"]', 'mass_models = ["tip", "joints"]'))
    for cmd in ("quasi", "linear", "check"):
        res = ked(cmd, "--linkage", str(f))
        assert res.returncode == 2, (cmd, res.stderr)
        assert "grid.mass_models" in res.stderr and "tip, joints" in res.stderr and "--mass-model" in res.stderr
    res = ked("quasi", "--linkage", str(f), "--mass-model", "joints", "--json")
    assert res.returncode == 0, res.stderr


def test_quasi_takes_the_files_scene(tmp_path):
    """No option given: the file's mass model (joints: no tip payload), speed and step; --rpm overrides."""
    f = tmp_path / "joints.toml"
    f.write_text(STEEL.replace('mass_models = ["tip"]', 'mass_models = ["joints"]'))
    res = json.loads(ked("quasi", "--linkage", str(f), "--json").stdout)
    cli = json.loads(ked("quasi", "--linkage", str(f), "--mass-model", "joints", "--rpm", "120", "--json").stdout)
    assert res == cli
    faster = json.loads(ked("quasi", "--linkage", str(f), "--rpm", "240", "--json").stdout)
    # quasi-static inertia loads grow as Omega^2: twice the speed, four times the deflection
    assert max(abs(x) for x in faster["dx_m"]) == pytest.approx(4 * max(abs(x) for x in res["dx_m"]), rel=1e-9)


def test_a_misspelt_table_is_refused_by_every_command(tmp_path):
    f = tmp_path / "typo.toml"
    f.write_text(STEEL.replace("[linkage]\n", "[linkag]\n"))  # [linkage.section] stays: a table of its own
    for args in (("quasi", "--linkage"), ("linear", "--linkage"), ("simulate", "--linkage"),
                 ("check", "--linkage"), ("run",)):
        res = ked(*args, str(f))
        assert res.returncode == 2, (args, res.stdout, res.stderr)
        assert "linkag: unknown key" in res.stderr, (args, res.stderr)
        assert "Traceback" not in res.stderr


@pytest.mark.parametrize("key, value, unit, hint", [("density", "7.85", "kg/m^3", "7850 kg/m^3"),
                                                    ("youngs_modulus", "210e3", "Pa", "2.1e+11 Pa")])
def test_material_in_the_wrong_unit_is_refused_naming_the_unit(tmp_path, key, value, unit, hint):
    """7.85 g/cm^3 and 210e3 MPa, steel's constants in the wrong units: refused by the loader and the command
    line, the message naming the SI unit (the expected values: steel's density and modulus in SI)."""
    line = {"density": "density = 7850.0", "youngs_modulus": "youngs_modulus = 210.0e9"}[key]
    text = STEEL.replace(line, f"{key} = {value}")
    with pytest.raises(ConfigError, match=re.escape(f"linkage.section.{key} = {float(value):g} {unit}:")):
        parse_config(text)
    f = tmp_path / "units.toml"
    f.write_text(text)
    res = ked("quasi", "--linkage", str(f))
    assert res.returncode == 2 and unit in res.stderr and hint in res.stderr, res.stderr
    slider = ('[linkage]\nkind = "slider-crank"\ncrank = 0.15\ncoupler = 0.3\n[linkage.section]\n'
              'youngs_modulus = 2e11\narea = 6.4e-5\nsecond_moment = 3.4e-10\ndensity = 7870.0\n')
    bad = slider.replace("density = 7870.0", f"density = {value}") if key == "density" else \
        slider.replace("youngs_modulus = 2e11", f"youngs_modulus = {value}")
    with pytest.raises(ConfigError, match=re.escape(hint)):
        parse_config(bad + "[grid]\nmass_models = [\"distributed\"]\n")


def test_thirteen_problems_print_thirteen_lines(tmp_path):
    """Twelve misspelt or out-of-range entries plus one bad shared section value (read for each of the four
    links, reported once): 13 problems, 13 lines, each naming the file."""
    bad = STEEL.replace("density = 7850.0", "density = -1.0").replace("[dynamic]", "[dynamic]\nfoo = 1")
    bad = bad.replace("[campaign]\n", "[campaign]\ncolour = 1\ntolerance = -1.0\nn_modes = 0\n")
    bad = bad.replace("[grid]\n", "[grid]\nspeeds = 1\nstiffness_scales = [-1.0]\ndirections = ['up']\n")
    bad = bad.replace("branch = \"open\"", "branch = \"shut\"\ncolor = 2\nrigid = true")
    bad += "[extra]\nx = 1\n[more]\ny = 2\n"
    f = tmp_path / "bad.toml"
    f.write_text(bad)
    with pytest.raises(ConfigError) as err:
        parse_config(bad)
    assert len(err.value.problems) == 13, err.value.problems
    for args in (("run",), ("quasi", "--linkage")):
        res = ked(*args, str(f))
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 2 and len(lines) == 13, res.stderr
        assert all(line.startswith("ked: ") and "bad.toml" in line for line in lines)
        assert len(set(lines)) == 13


def test_inspect_accepts_the_labels_its_table_prints(tmp_path):
    f = tmp_path / "two.toml"
    # long stiffness and damping labels: the table's lines outgrow 100 columns, so it prints short labels
    f.write_text(STEEL.replace("rpm = [120.0]", "rpm = [60.0, 120.0]").replace(
        "damping_ratios = [0.05]", "damping_ratios = [0.0512345]\nstiffness_scales = [1.23456]"))
    out = tmp_path / "two.h5"
    assert ked("run", str(f), "--out", str(out), "--no-figures", "--workers", "1").returncode == 0
    keys = [s["key"] for s in json.loads(ked("inspect", str(out), "--json").stdout)["scenes"]]
    table = ked("inspect", str(out)).stdout.splitlines()
    printed = {}
    for key in keys:  # the label column of each scene's row as the table prints it
        (row,) = [line for line in table if line.split() and len(line.split()[0]) >= 8
                  and key.startswith(line.split()[0])]
        printed[key] = row.split()[1]
    assert any(lb.count("/") < 5 for lb in printed.values())  # the table printed short labels
    for key, label in printed.items():
        res = ked("inspect", str(out), label, "--json")
        assert res.returncode == 0, (label, res.stderr)
        assert json.loads(res.stdout)["key"] == key
    for short, rpm in (("60rpm", 60.0), ("tip/120rpm", 120.0), ("source/60rpm", 60.0),
                       ("source/tip/120rpm/k1.23456/z0.0512345/ccw", 120.0)):
        res = ked("inspect", str(out), short, "--json")
        assert res.returncode == 0 and json.loads(res.stdout)["rpm"] == rpm, (short, res.stderr)
    res = ked("inspect", str(out), "source/tip")  # names both scenes: ambiguous, says so in one line
    assert res.returncode != 0 and "ambiguous" in res.stderr and len(res.stderr.splitlines()) == 1


def test_label_names():
    label = "source/tip/5000rpm/k1/z0.02/ccw"
    assert label_names("source/5000rpm", label) and label_names("5000rpm/ccw", label)
    assert label_names("source/tip/50...", label)
    assert not label_names("cognate/5000rpm", label) and not label_names("source/500rpm", label)
    assert not label_names("5000rpm/source", label)  # segments in the label's order only


def test_simulate_runs_the_files_dynamic_settings(tmp_path):
    """The file's [dynamic] table and damping ratio, not DynamicSettings' defaults (4 elements, 720 steps, 0.02);
    an option given overrides one of them."""
    f = tmp_path / "steel.toml"
    f.write_text(STEEL)
    res = ked("simulate", "--linkage", str(f), "--json")
    assert res.returncode == 0, res.stderr
    solved = json.loads(res.stdout)["solved_settings"]
    assert (solved["elements_per_link"], solved["steps_per_cycle"], solved["damping_ratio"]) == (2, 360, 0.05)
    res = ked("simulate", "--linkage", str(f), "--steps-per-cycle", "720", "--json")
    solved = json.loads(res.stdout)["solved_settings"]
    assert (solved["elements_per_link"], solved["steps_per_cycle"], solved["damping_ratio"]) == (2, 720, 0.05)
