"""The atlas limits ``ked check`` reads are package data (ked_check/atlas_limits.json): the same numbers as the
committed atlas file, and the same in an installed wheel as in the checkout."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ked_check import published
from ked_quasi.massmodel import MASS_MODELS
from ked_research.atlas import publish
from ked_research.atlas.analysis import default_path

ROOT = Path(__file__).resolve().parents[1]


def _same(a: object, b: object) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, float) or isinstance(b, float):
        return (a is None and math.isnan(b)) or (b is None and math.isnan(a)) or a == b  # type: ignore[arg-type]
    return a == b


def test_published_limits_are_those_of_the_committed_atlas():
    # Expected: the record `ked study atlas` publishes equals the one built afresh from results/atlas/atlas.h5
    # (a stale package file would give ked check other limits than the atlas the README reports).
    if not default_path().exists():
        pytest.skip("no committed atlas in this checkout")
    built = publish.build(default_path())
    # the file holds the slider atlas's entries too: the four-bar record merged into it changes nothing
    assert _same(published.read(), json.loads(json.dumps(published.merge(published.read(), built), allow_nan=False)))
    assert set(built["limits"]) == set(MASS_MODELS) and "10" in built["margins"]


def test_published_slider_limits_are_those_of_the_committed_slider_atlas():
    # Expected: the slider-crank entries equal the record built afresh from results/atlas/slider_atlas.h5.
    slider = default_path().with_name("slider_atlas.h5")
    if not slider.exists():
        pytest.skip("no committed slider atlas in this checkout")
    built = publish.build(slider)
    assert built["kind"] == "slider-crank"
    assert _same(published.read(), json.loads(json.dumps(published.merge(published.read(), built), allow_nan=False)))


def test_check_reads_the_published_limits():
    from ked_check.check import linear_range, verdict_margins

    rec = published.read()
    rng = linear_range("tip")
    assert rng.r10 == rec["limits"]["tip"]["linear_r10"] and rng.source == "atlas"
    # per stratum, never pooled: each stratum the check sees reads its own published record
    for k, m in rec["margins"]["10"].items():
        assert verdict_margins(0.10, k).holds_below == m["holds_below"] > 0
    # no calibration at 5 %, nor for a stratum the atlas has not calibrated: no quasi-static tier from a
    # prediction, and it says so
    for tol, k in ((0.05, "four-bar/tip/source"), (0.10, "slider-crank/distributed/cognate")):
        m = verdict_margins(tol, k)
        assert m.holds_below == 0.0 and not m.calibrated and "not calibrated" in m.source


@pytest.mark.slow
def test_check_from_a_built_wheel_gives_the_checkout_limits(tmp_path):
    # Expected: the wheel carries the same limits; before, ked check outside the checkout read no atlas (NaN).
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "dist"), str(ROOT)],
                   check=True, capture_output=True)
    (wheel,) = (tmp_path / "dist").glob("ked_harness-*.whl")
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target), str(wheel)],
                   check=True, capture_output=True)
    args = ["check", "--rpm", "100", "--json"]

    def run(env_path: str | None, cwd: Path) -> tuple[dict, str]:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        if env_path:
            env["PYTHONPATH"] = env_path
        code = (f"import sys, compare; print(compare.__file__, file=sys.stderr); from ked_cli.main import main; "
                f"sys.argv = ['ked', *{args!r}]; main()")
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, env=env,
                             check=True)
        return json.loads(res.stdout)[0], res.stderr.splitlines()[0]

    (wheel_row, wheel_pkg), (checkout_row, _) = run(str(target), tmp_path), run(None, ROOT)
    assert wheel_pkg.startswith(str(target))  # the installed package answered, not the checkout
    for key in ("linear_limit_speed_ratio", "holds_below_error", "fails_above_error", "margins_source", "tier"):
        assert wheel_row[key] == checkout_row[key], key
    assert math.isfinite(wheel_row["linear_limit_speed_ratio"])
