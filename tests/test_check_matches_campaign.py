"""One verdict: for a default-campaign scene, `ked check --json --confirm` at the same settings and the
campaign's stored verdict give the same error (relative 1e-12) and the same verdict.

Both are the history error of the deflection vector (dx, dy) of the quasi-static answer against Exudyn
(compare.metrics.VERDICT_METRIC), computed by the same code path on the same deterministic Exudyn run;
the campaign's verdict "holds" is the check's tier "quasi-static" (with --confirm the measured error
decides the tier).  The default suite checks three scenes (one through the real command line); the slow
test checks every scene of the default campaign.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

import pytest

from compare import store
from compare.config import default_config_text, load_config, parse_config
from compare.inspect import summary_row
from compare.runner import run_campaign
from ked_check.check import check
from ked_quasi import thesis_fourbar
from ked_quasi.massmodel import MassModel, default_payload

KED = [sys.executable, "-c", "from ked_cli.main import main; main()"]


def _one_scene_config(mechanism: str, mass_model: str, rpm: float) -> str:
    """The default campaign's TOML with its grid narrowed to one scene (same settings, same key)."""
    text = default_config_text()
    for name, value in (("mechanisms", f'["{mechanism}"]'), ("mass_models", f'["{mass_model}"]'),
                        ("rpm", f"[{rpm!r}]")):
        text, n = re.subn(rf"(?m)^{name} = \[.*\]$", f"{name} = {value}", text)
        assert n == 1, name
    return text


def _default_key(mechanism: str, mass_model: str, rpm: float) -> str:
    return next(s.key for s in load_config(None).scenes()
                if (s.mechanism, s.mass_model.name, s.speed.value) == (mechanism, mass_model, rpm))


def _assert_same(check_row: dict[str, Any], stored: dict[str, Any]) -> None:
    """A check row (its JSON) against the stored scene's summary row (`ked inspect --json`)."""
    label = stored["label"]
    if "dynamic_flagged" in check_row["confirmed"]:  # Exudyn beyond the small-deflection range: no measurement
        assert check_row["decided_by"] == "predicted" and stored.get("flags_dynamic"), label
        return
    assert stored["reference"] == "dynamic" and check_row["decided_by"] == "measured", label
    measured = check_row["confirmed"]["quasi_static_vs_dynamic"]
    assert measured == pytest.approx(stored["verdict_error"], rel=1e-12, abs=0.0), label
    assert (check_row["tier"] == "quasi-static") == stored["holds"], (label, check_row["verdict"])
    # the key is the campaign's, unless the check had to allow the linear solve more harmonics
    assert check_row["key"] == stored["key"] or check_row["linear_harmonics"] > 32, label


@pytest.mark.parametrize("mechanism, mass_model, rpm", [
    ("cognate", "distributed", 150.0),  # 10.0 %: on the threshold, FAILS
    ("source", "joints", 150.0),  # linear solve unresolved at 32 harmonics; measured: linear model
])
def test_check_and_campaign_give_one_verdict(tmp_path, mechanism, mass_model, rpm):
    out = tmp_path / "c.h5"
    run_campaign(parse_config(_one_scene_config(mechanism, mass_model, rpm)), out, workers=1, progress=False)
    (r,) = store.read_scenes(out)
    assert r.key == _default_key(mechanism, mass_model, rpm)  # it is the default campaign's scene
    mm = MassModel(mass_model, payload=default_payload(mass_model))
    (row,) = check(thesis_fourbar(), mechanism, mm, [rpm], confirm=True)
    _assert_same(asdict(row), summary_row(r))


def _ked(*args: str, cwd: Path) -> str:
    res = subprocess.run([*KED, *args], cwd=cwd, capture_output=True, text=True, timeout=1200)
    assert res.returncode == 0, res.stderr[-2000:]
    return res.stdout


def test_cli_check_and_cli_campaign_give_one_verdict(tmp_path):
    """Case III (extender) at 300 rpm, the scene whose verdict the vector measure changed: Exudyn
    measures the quasi-static vector error at ~8 % (holds); the worst of dx, dy and rotation was ~10.3 %."""
    cfg = tmp_path / "one.toml"
    cfg.write_text(_one_scene_config("source", "extender", 300.0))
    _ked("run", str(cfg), "--out", "c.h5", "--no-figures", "--no-progress", "--workers", "1", cwd=tmp_path)
    (stored,) = json.loads(_ked("inspect", "c.h5", "--json", cwd=tmp_path))["scenes"]
    (row,) = json.loads(_ked("check", "--mass-model", "extender", "--rpm", "300", "--confirm", "--json",
                             cwd=tmp_path))
    assert stored["key"] == _default_key("source", "extender", 300.0)
    _assert_same(row, stored)
    assert row["tier"] == "quasi-static" and stored["verdict_error"] < 0.10 <= stored["max_relative_error"]


@pytest.mark.slow
def test_every_default_scene_has_one_verdict(tmp_path):
    """The whole default campaign (`ked run` without a config) against `ked check --confirm --json`
    at each of its scenes' settings."""
    _ked("run", "--out", "default.h5", "--no-figures", "--no-progress", cwd=tmp_path)
    stored = json.loads(_ked("inspect", "default.h5", "--json", cwd=tmp_path))["scenes"]
    cfg = load_config(None)
    assert len(stored) == len(cfg.scenes())
    by_scene = {(s["mechanism"], s["mass_model"], s["rpm"]): s for s in stored}
    rpms = sorted({s.speed.value for s in cfg.scenes()})
    checked = 0
    for mechanism in cfg.grid.mechanisms:
        for mass_model in sorted({s.mass_model.name for s in cfg.scenes()}):
            args = ["check", "--mechanism", mechanism, "--mass-model", mass_model, "--confirm", "--json"]
            for rpm in rpms:
                args += ["--rpm", repr(rpm)]
            for row in json.loads(_ked(*args, cwd=tmp_path)):
                _assert_same(row, by_scene[(mechanism, mass_model, row["rpm"])])
                checked += 1
    assert checked == len(stored)
