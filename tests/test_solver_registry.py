"""The solver registry: adding a solver is one module plus one registration.

A tiny extra solver, the quasi-static answer at half the crank speed (defined and registered here,
in a test module the workers import by reference), runs through a real campaign, `ked inspect` and
`ked plot` without any edit of the store, inspect or plot code.  Expected values: inertia loads
scale with Omega^2, so its history is exactly 1/4 of the quasi-static one (history error 3/4).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from typing import Any

import h5py
import pytest
from click.testing import CliRunner

from compare import solvers, store
from compare.config import parse_config
from compare.runner import run_campaign
from compare.solvers import Solver, register
from compare.solvers import quasi_static as qs_solver
from ked_cli.main import cli


@dataclass(frozen=True)
class HalfSpeedSettings:
    """Settings of the test solver: the factor on the crank speed."""

    factor: float = 0.5


def half_speed_settings() -> type:
    return HalfSpeedSettings


def make_half_speed(overrides: dict[str, Any], damping_ratio: float) -> HalfSpeedSettings:
    return HalfSpeedSettings(**overrides)


def run_half_speed(scene: Any, settings: HalfSpeedSettings, outputs: tuple[str, ...]) -> Any:
    slow = replace(scene, rpm=scene.rpm * settings.factor)
    return replace(qs_solver.run(slow, qs_solver.QuasiStaticSettings(), outputs), solver="half_speed")


HALF_SPEED = Solver(name="half_speed", label="quasi-static at half speed", fidelity=1,
                    settings_class=half_speed_settings, make_settings=make_half_speed, run=run_half_speed)

CONFIG = """
[campaign]
name = "registry"
step_deg = 30.0
n_modes = 1
solvers = ["quasi_static", "half_speed"]
[grid]
mass_models = ["tip", "extender"]
rpm = [100.0]
"""


@pytest.fixture()
def registered():
    register(HALF_SPEED)
    yield HALF_SPEED
    solvers.REGISTRY.pop("half_speed", None)


def test_a_registered_solver_runs_through_campaign_inspect_and_plot(tmp_path, registered):
    cfg = parse_config(CONFIG)
    assert cfg.solvers == ("quasi_static", "half_speed")
    out = tmp_path / "r.h5"
    summary = run_campaign(cfg, out, workers=2, progress=False)
    assert summary.ok == 2 and summary.failed == 0
    assert store.verify(out) == []
    for r in store.read_scenes(out):
        assert set(r.solutions) == {"quasi_static", "half_speed"} and r.reference == "half_speed"
        m = r.verdict  # quasi-static measured against the higher-fidelity test solver
        assert m.component("vector").history_error == pytest.approx(3.0, rel=1e-12)  # |qs - qs/4| / |qs/4|
        assert m.component("vector").amplification == pytest.approx(0.25, rel=1e-12)
    with h5py.File(out) as f:
        g = next(iter(f["scenes"].values()))
        assert "half_speed" in g["solutions"] and b"half_speed" in set(f["metric_table/reference"][()])
        solvers = list(f["solution_table/solver"][()])
        assert json.loads(f["solution_table/settings_json"][solvers.index(b"half_speed")]) == {"factor": 0.5}
    runner = CliRunner()
    res = runner.invoke(cli, ["inspect", str(out)])
    assert res.exit_code == 0 and "2 scenes: 2 ok" in res.output, res.output
    key = store.read_scenes(out)[0].key
    detail = runner.invoke(cli, ["inspect", str(out), key])
    assert "quasi-static at half speed" in detail.output
    res = runner.invoke(cli, ["plot", str(out), "--out", str(tmp_path / "figs"), "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert len(list((tmp_path / "figs").glob("scene_*.png"))) == 2


def test_resuming_with_an_added_solver_computes_only_that_solver(tmp_path, registered):
    out = tmp_path / "r.h5"
    first = parse_config(CONFIG.replace('solvers = ["quasi_static", "half_speed"]', 'solvers = ["quasi_static"]'))
    run_campaign(first, out, workers=1, progress=False)
    before = {r.key: r.solutions["quasi_static"].deflection["dx"] for r in store.read_scenes(out)}
    assert all(set(r.solutions) == {"quasi_static"} for r in store.read_scenes(out))
    again = run_campaign(parse_config(CONFIG), out, workers=1, progress=False)
    assert again.ok == 2 and again.skipped == 0
    for r in store.read_scenes(out):
        assert set(r.solutions) == {"quasi_static", "half_speed"}
        assert (r.solutions["quasi_static"].deflection["dx"] == before[r.key]).all()  # kept, not recomputed
    assert run_campaign(parse_config(CONFIG), out, workers=1, progress=False).skipped == 2


def test_unknown_solver_in_a_config_is_refused():
    from compare.config import ConfigError

    with pytest.raises(ConfigError, match="campaign.solvers"):
        parse_config('[campaign]\nsolvers = ["quasi_static", "nonsense"]\n')
    assert math.isfinite(solvers.fidelity("dynamic"))
