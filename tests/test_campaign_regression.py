"""Regression on agreement tolerances: rerun the committed reference campaign (results/reference/) and
compare every metric with the stored value.

Tolerance (compare.reference.TOLERANCES): each of max_abs_error, rms_error, relative_error and
amplification within 2 % of the stored value (absolute floors 1e-7 m|rad for the errors, 2e-3 for the
ratios), phase shift within 1 deg, speed ratio within 1e-6 relative; every verdict (scene and component)
unchanged; every scene's status unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from compare import store
from compare.config import load_config
from compare.reference import compare_to_reference, expected_metrics
from compare.runner import run_campaign

REFERENCE = Path(__file__).resolve().parents[1] / "results" / "reference"


@pytest.fixture(scope="module")
def expected():
    return json.loads((REFERENCE / "expected_metrics.json").read_text())


def test_committed_reference_file_is_valid_and_matches_its_metrics(expected):
    h5 = REFERENCE / "reference.h5"
    assert store.verify(h5) == []
    results = store.read_scenes(h5)
    assert compare_to_reference(results, expected) == []
    assert expected_metrics(results)["scenes"] == expected["scenes"]
    assert {r["status"] for r in expected["scenes"].values()} == {"ok"}
    verdicts = {r["holds"] for r in expected["scenes"].values()}
    assert verdicts == {True, False}, "the reference should contain both verdicts"


def test_rerun_reproduces_reference_metrics(tmp_path, expected):
    cfg = load_config(REFERENCE / "reference.toml")
    assert {s.key for s in cfg.scenes()} == set(expected["scenes"]), "reference.toml and expected keys differ"
    out = tmp_path / "rerun.h5"
    summary = run_campaign(cfg, out, workers=2, progress=False)
    assert summary.ok + summary.failed == len(expected["scenes"])
    problems = compare_to_reference(store.read_scenes(out), expected)
    assert problems == [], "\n".join(problems)


def test_regression_check_detects_a_changed_metric(expected):
    results = store.read_scenes(REFERENCE / "reference.h5")
    tampered = json.loads(json.dumps(expected))
    key = next(iter(tampered["scenes"]))
    comp = tampered["scenes"][key]["components"]["dx"]
    comp["amplification"] *= 1.05
    comp["holds"] = not comp["holds"]
    problems = compare_to_reference(results, tampered)
    assert any("amplification" in p for p in problems)
    assert any("verdict changed" in p for p in problems)
