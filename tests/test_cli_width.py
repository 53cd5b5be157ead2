"""Every human-readable line the commands print fits a 100-column terminal by default.

A small real campaign (thesis linkage, source and cognate, tip and extender mass, 60 and 300 rpm, the
three solvers at the cheap pinned Exudyn settings of conftest) covers what makes lines long: answers
outside their model's range (the tip mass at 300 rpm deflects P by tens of mm, the "*" note), a failed
scene (Exudyn finds no steady state there at these settings: the failure reasons) and three solvers'
columns.  The single-scene commands run on the thesis defaults (Case I at 300 rpm: flagged answers and
their warnings).  JSON output is a contract and is not looked at here.
"""

from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner

from ked_cli.main import cli

from .conftest import QUICK_DYNAMIC

WIDTH = 100

CONFIG = """
[campaign]
step_deg = 30.0
n_modes = 2
[grid]
mechanisms = ["source", "cognate"]
mass_models = ["tip", "extender"]
rpm = [60.0, 300.0]
""" + QUICK_DYNAMIC


def _run(*args: str) -> tuple[int, str]:
    res = CliRunner().invoke(cli, list(args))  # output: stdout and stderr (warnings) together
    return res.exit_code, res.output


def _too_wide(text: str) -> list[str]:
    """Lines over :data:`WIDTH` columns; an error stays one line (`Error: ...`, the CLI's rule for errors)."""
    return [ln for ln in text.splitlines() if len(ln) > WIDTH and not ln.startswith("Error: ")]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    d = tmp_path_factory.mktemp("width")
    cfg = d / "width.toml"
    cfg.write_text(CONFIG)
    out = d / "width.h5"
    code, text = _run("run", str(cfg), "--out", str(out), "--no-progress", "--workers", "2")
    assert code == 0, text
    return cfg, out, text


def test_run_output_fits_and_runs_three_solvers(campaign):
    _, _, text = campaign
    assert _too_wide(text) == []
    # a config without [campaign] solvers runs the three tiers: a column per solver besides quasi-static
    assert re.search(r"^ +qs +qs rot +linear *$", text, re.M), text
    joined = text.replace("\n  ", " ")  # continuation lines of wrapped notes
    assert re.search(r"^\* .*quasi-static in \d scenes? \(large_deflection", joined, re.M), text  # names the solver
    assert "failed " in text and "(Exudyn)" in text  # the failure reason names the solver


def test_inspect_outputs_fit_and_list_scenes_in_run_order(campaign):
    cfg, out, run_text = campaign
    code, text = _run("inspect", str(out))
    assert code == 0 and _too_wide(text) == [], _too_wide(text)
    keys = re.compile(r"^([0-9a-f]{8,16})  ", re.M)
    assert keys.findall(text) == keys.findall(run_text) and len(keys.findall(text)) == 8
    for key in keys.findall(text):
        code, detail = _run("inspect", str(out), key)
        assert code == 0 and _too_wide(detail) == [], _too_wide(detail)
    code, js = _run("inspect", str(out), "--json")  # a config without [campaign] solvers: the three tiers
    assert code == 0 and set().union(*(r["solvers"] for r in json.loads(js)["scenes"])) == {
        "quasi_static", "linear", "dynamic"}
    code, text = _run("inspect", str(out), "--verify")
    assert code == 0 and _too_wide(text) == []
    code, wide = _run("inspect", str(out), "--wide")  # the full layout: long titles, whole keys
    assert code == 0 and "quasi-static err %" in wide and "reason (failed scenes)" in wide
    code, text = _run("plot", str(out), "--out", str(out.parent / "figs"), "--workers", "1")
    assert code == 0 and _too_wide(text) == []


def test_dry_run_fits_and_names_the_file_after_the_config(campaign, tmp_path, monkeypatch):
    cfg, _, run_text = campaign
    monkeypatch.chdir(tmp_path)
    code, text = _run("run", str(cfg), "--dry-run")
    assert code == 0 and _too_wide(text) == []
    assert "ked_results/width.h5" in text  # no [campaign] name: the config file's name
    listed = re.findall(r"^  ([0-9a-f]{16})  ", text, re.M)
    table = re.findall(r"^([0-9a-f]{8,16})  ", run_text, re.M)
    assert len(listed) == len(table) == 8 and all(k.startswith(p) for k, p in zip(listed, table))  # one order
    code, text = _run("run", "--dry-run")  # the default campaign keeps its file
    assert code == 0 and _too_wide(text) == [] and "ked_results/thesis-default.h5" in text


@pytest.mark.parametrize("args", [
    ("quasi",), ("quasi", "--summary"), ("quasi", "--step-deg", "0.5"),
    ("linear",), ("linear", "--mass-model", "extender"),
    ("simulate", "--mass-model", "extender", "--rpm", "60", "--elements-per-link", "2", "--steps-per-cycle", "36"),
    ("check", "--rpm", "100"), ("check", "--rpm-range", "50:300:3"),
    ("check", "--mass-model", "extender", "--rpm", "100", "--confirm"),
])
def test_single_scene_commands_fit(args):
    code, text = _run(*args)
    assert code == 0, text
    assert text.strip() and _too_wide(text) == [], _too_wide(text)
