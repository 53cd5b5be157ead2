"""Any linkage in every command: `--linkage FILE.toml` reads a [linkage] table in the campaign schema,
and `ked quasi --linkage FILE --json` returns exactly what a campaign stores for the same scene (the
same construction, so bit for bit)."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from compare import store
from compare.config import parse_config
from compare.runner import run_campaign
from ked_cli.main import cli

LINKAGE = """
[campaign]
name = "steel"
step_deg = 5.0
n_modes = 1
solvers = ["quasi_static"]
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
mechanisms = ["cognate"]
mass_models = [{name = "distributed", lumps = 3, payload_kg = 0.1}]
rpm = [1500.0]
"""


def test_quasi_with_a_linkage_file_equals_the_campaign_bit_for_bit(tmp_path):
    cfg_file = tmp_path / "steel.toml"
    cfg_file.write_text(LINKAGE)
    out = tmp_path / "steel.h5"
    assert run_campaign(parse_config(LINKAGE), out, workers=1, progress=False).ok == 1
    (r,) = store.read_scenes(out)
    res = CliRunner().invoke(cli, ["quasi", "--linkage", str(cfg_file), "--mechanism", "cognate", "--mass-model",
                                   "distributed", "--lumps", "3", "--payload-kg", "0.1", "--rpm", "1500",
                                   "--step-deg", "5", "--json"])
    assert res.exit_code == 0, res.output
    got = json.loads(res.output)
    stored = r.solutions["quasi_static"].deflection
    for key, comp in (("dx_m", "dx"), ("dy_m", "dy"), ("rotation_rad", "rotation")):
        assert np.array_equal(np.array(got[key]), stored[comp]), key
    assert got["crank_angle_deg"][:3] == [0.0, 5.0, 10.0]  # exact grid values


def test_bad_linkage_file_is_one_line_naming_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[linkage]\ncrank = 0.05\n")
    res = CliRunner().invoke(cli, ["quasi", "--linkage", str(bad)])
    assert res.exit_code == 2 and "bad.toml" in res.output and "linkage.coupler" in res.output
    binary = tmp_path / "x.toml"
    binary.write_bytes(bytes(range(256)))
    res = CliRunner().invoke(cli, ["quasi", "--linkage", str(binary)])
    assert res.exit_code == 2 and "not a text file" in res.output
