"""The slider-crank through the harness: scene specs and keys, campaigns, ked simulate / check / run / merge.

The four-bar's content keys are a contract (stored campaigns resume by them): they are checked against a
stored results file and against the default campaign's keys before the slider-crank existed.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import replace

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from compare import h5layout
from compare.config import ConfigError, load_config, load_linkage, parse_config
from compare.execute import run_scene
from compare.scenes import SceneSpec
from compare.solvers import get
from exudyn_models import DynamicSettings
from exudyn_models.simulate import simulate_steady_state
from ked_check.check import spec_for
from ked_cli.main import cli
from ked_quasi.massmodel import MassModel
from ked_quasi.slider_static import solve_slider_quasi_static
from ked_quasi.slidercrank import SliderScene, simeon_slider_crank

DEFAULT_CAMPAIGN_KEYS_SHA256 = "665bfdb9b319dbbe667980db4172ca1da1f8efe4571b3dd65b8b6cbeb429d51a"
"""SHA-256 of the default campaign's 40 scene keys at 5 lumps per link, comma-joined in grid order (regression pin
of a contract: four-bar keys change only with the scenes; the slider-crank's entry into the scene specs left them
unchanged). Changed on purpose once since: the default campaign's [dynamic] table gained start = "linear" (was
d4ad256c158f5ba449a4e0b7acd871fc9d3f717f683cd80ad015087c1d854962)."""
DEFAULT_CAMPAIGN_KEYS_SHA256_20_LUMPS = "97007ab721b2021a8f22a776fe725d1df74dba7cfadf591ad885733002b8246b"
"""The same at today's default of 20 lumps per link (regression pin; before start = "linear":
bf2372bd39b02dc955d556bde0ed1c9b489e447eb1e59e0abecd2b1d333bc9c2)."""

SLIDER_CAMPAIGN = """
[campaign]
name = "slider"
step_deg = 30.0
solvers = ["quasi_static", "dynamic"]

[linkage]
preset = "simeon"

[grid]
mass_models = ["distributed"]
rpm = [238.7]

[dynamic]
elements_per_link = 4
steps_per_cycle = 360
"""


def test_default_campaign_keys_unchanged():
    scenes = load_config(None).scenes()
    keys = [s.key for s in scenes]
    assert len(keys) == 40
    assert hashlib.sha256(",".join(keys).encode()).hexdigest() == DEFAULT_CAMPAIGN_KEYS_SHA256_20_LUMPS
    old = [replace(s, mass_model=replace(s.mass_model, lumps=5)).key for s in scenes]
    assert hashlib.sha256(",".join(old).encode()).hexdigest() == DEFAULT_CAMPAIGN_KEYS_SHA256


def test_stored_reference_keys_unchanged():
    """The committed reference results file (written by an earlier harness) holds exactly the keys its
    config gives today, and every stored scene's parameters read back to its own key."""
    cfg = load_config("results/reference/reference.toml")
    with h5py.File("results/reference/reference.h5", "r") as f:
        rows = h5layout.table_rows(f, h5layout.SCENE_TABLE)
    stored = {h5layout.text(r["key"]) for r in rows}
    for r in rows:
        spec = SceneSpec.from_dict(json.loads(h5layout.text(r["json"])))
        assert spec.key == h5layout.text(r["key"]) and spec.kind == "four-bar"
    assert {s.key for s in cfg.scenes()} == stored


def test_slider_spec_kind_key_and_round_trip():
    mm = MassModel("distributed", lumps=5, payload=0.0)
    spec = spec_for(simeon_slider_crank(), "source", mm, 1432.4)
    assert spec.kind == "slider-crank"
    assert spec.key_dict()["linkage"]["kind"] == "slider-crank"
    back = SceneSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert back.key == spec.key and back.kind == "slider-crank"
    assert isinstance(spec.scene(1432.4), SliderScene)
    with pytest.raises(ValueError, match="cognate"):
        spec_for(simeon_slider_crank(), "cognate", mm, 1432.4).scene(1432.4)


def test_campaign_config_slider():
    cfg = parse_config(SLIDER_CAMPAIGN)
    (spec,) = cfg.scenes()
    assert spec.kind == "slider-crank" and spec.linkage == simeon_slider_crank()
    table = SLIDER_CAMPAIGN.replace('preset = "simeon"', 'kind = "slider-crank"\ncrank = 0.05\ncoupler = 0.2\n'
                                    'offset = 0.02\nslider_mass = 0.1\n[linkage.section]\nyoungs_modulus = 2e11\n'
                                    'area = 6.4e-5\nsecond_moment = 3.4e-10\ndensity = 7870.0')
    (spec,) = parse_config(table).scenes()
    assert spec.linkage.offset == 0.02
    with pytest.raises(ConfigError, match="extender: not a mass model of a slider-crank"):
        parse_config(SLIDER_CAMPAIGN.replace('mass_models = ["distributed"]', 'mass_models = ["extender"]'))
    with pytest.raises(ConfigError, match="no Roberts cognate"):
        parse_config(SLIDER_CAMPAIGN.replace("[grid]", '[grid]\nmechanisms = ["source", "cognate"]'))
    with pytest.raises(ConfigError, match="linkage.kind"):
        parse_config(SLIDER_CAMPAIGN.replace('preset = "simeon"', 'kind = "six-bar"'))


def test_campaign_scene_is_the_solvers_answer():
    """One campaign scene of the slider-crank runs the quasi-static and Exudyn solvers on the same scene:
    their stored histories are the direct calls' (same code path), the verdict compares them."""
    (spec,) = parse_config(SLIDER_CAMPAIGN).scenes()
    r = run_scene(spec)
    assert r.ok, r.message
    scene = spec.scene(r.rpm)
    qs = solve_slider_quasi_static(scene)
    assert np.allclose(r.solutions["quasi_static"].deflection["dx"], qs.deflection[:, 0], rtol=0, atol=1e-15)
    dyn = simulate_steady_state(scene, get("dynamic").make_settings(spec.settings_for("dynamic"), 0.02))
    assert np.allclose(r.solutions["dynamic"].deflection["dy"], dyn.deflection[:, 1], rtol=0, atol=1e-12)
    assert math.isfinite(r.metrics["quasi_static_vs_dynamic"].verdict_error)
    assert np.allclose(r.coupler_point[0], [0.3, 0.0])  # P at the rod's midspan at crank angle 0


def test_linear_solver_runs_a_slider_scene_through_the_registry():
    """The registry's linear solver on a slider-crank scene (ked_linear.slider) stores an answer with the
    slider-crank's validity flags; at r = 0.04 it is within 2 % of the quasi-static answer (the dynamic part
    is ~r^2 of it, a few harmonics amplified: measured 1 % by the reference model at 50 rad/s)."""
    spec = spec_for(simeon_slider_crank(), "source", MassModel("distributed", lumps=5, payload=0.0), 477.5)
    r = run_scene(spec, [get("quasi_static"), get("linear")])
    assert r.ok, r.message
    assert r.metrics["quasi_static_vs_linear"].verdict_error < 0.02


def test_cli_simulate_simeon():
    out = CliRunner().invoke(cli, ["simulate", "--linkage", "simeon", "--rpm", "477.5", "--step-deg", "30",
                                   "--elements-per-link", "4", "--steps-per-cycle", "360", "--json"])
    assert out.exit_code == 0, out.output
    d = json.loads(out.output)
    assert d["converged"] and len(d["midspan_m"]) == 12
    scene = SliderScene(simeon_slider_crank(), MassModel("distributed", payload=0.0), 477.5, 30.0)  # default lumps
    res = simulate_steady_state(scene, DynamicSettings(elements_per_link=4, steps_per_cycle=360))
    assert np.allclose(d["midspan_m"], res.midspan, rtol=0, atol=1e-12)
    text = CliRunner().invoke(cli, ["simulate", "--linkage", "simeon", "--rpm", "477.5", "--step-deg", "30",
                                    "--elements-per-link", "4", "--steps-per-cycle", "360"])
    assert text.exit_code == 0 and "mass model distributed" in text.output and "mid mm" in text.output
    bad = CliRunner().invoke(cli, ["simulate", "--linkage", "simeon", "--mechanism", "cognate"])
    assert bad.exit_code == 2 and "cognate" in bad.output and "Traceback" not in bad.output


def test_cli_check_simeon_confirm():
    """`ked check --linkage simeon --rpm 1432.4 --confirm` (150 rad/s) runs every tier it has: the measured
    quasi-static error decides; the prediction names why it could not (no linear model / no atlas)."""
    out = CliRunner().invoke(cli, ["check", "--linkage", "simeon", "--rpm", "1432.4", "--confirm", "--json"])
    assert out.exit_code == 0, out.output
    (row,) = json.loads(out.output)
    assert row["decided_by"] == "measured" and row["verdict"].startswith("measured:")
    assert abs(row["speed_ratio"] - 150.0 / 1276.7) < 0.005  # omega1 of the frozen rod: data sheet
    q = row["confirmed"]["quasi_static_vs_dynamic"]
    assert 0.0 < q < 1.0
    if not math.isfinite(row["confirmed"].get("linear_vs_dynamic") or math.nan):  # no linear slider model yet
        assert row["tier"] == ("quasi-static" if q < 0.10 else "nonlinear")
    text = CliRunner().invoke(cli, ["check", "--linkage", "simeon", "--rpm", "1432.4"])
    assert text.exit_code == 0 and "mass model distributed" in text.output


@pytest.mark.slow
def test_campaign_files_of_both_kinds_merge(tmp_path):
    """A slider-crank campaign and a four-bar campaign, each in its own file, join in one results file by
    ked merge (content keys never collide: the slider-crank's carry its kind); the file verifies."""
    slider, fourbar = tmp_path / "slider.toml", tmp_path / "fourbar.toml"
    slider.write_text(SLIDER_CAMPAIGN)
    fourbar.write_text(SLIDER_CAMPAIGN.replace('preset = "simeon"', 'preset = "thesis"').replace(
        '"distributed"', '"tip"').replace('"quasi_static", "dynamic"', '"quasi_static"').replace("238.7", "30.0"))
    runner = CliRunner()
    for cfg in (slider, fourbar):
        out = runner.invoke(cli, ["run", str(cfg), "--out", str(cfg.with_suffix(".h5")), "--workers", "1",
                                  "--no-figures", "--no-progress"])
        assert out.exit_code == 0, out.output
    out = runner.invoke(cli, ["merge", str(slider.with_suffix(".h5")), str(fourbar.with_suffix(".h5"))])
    assert out.exit_code == 0, out.output
    out = runner.invoke(cli, ["inspect", str(fourbar.with_suffix(".h5")), "--json"])
    assert out.exit_code == 0, out.output
    verify = runner.invoke(cli, ["inspect", str(fourbar.with_suffix(".h5")), "--verify"])
    assert verify.exit_code == 0 and "2 complete scenes" in verify.output
    with h5py.File(fourbar.with_suffix(".h5"), "r") as f:
        kinds = sorted(row["kind"] or "four-bar" for row in h5layout.table_rows(f, h5layout.SCENE_TABLE))
    assert kinds == ["four-bar", "slider-crank"]


MIXED_CAMPAIGN = """
[campaign]
name = "mixed"
step_deg = 30.0
solvers = ["quasi_static", "linear", "dynamic"]

[[linkage]]
preset = "thesis"

[[linkage]]
preset = "simeon"

[grid]
mass_models = ["distributed"]
speed_ratios = [0.05]

"""


def test_mixed_campaign_is_the_union_of_its_single_kind_campaigns():
    """A [[linkage]] grid holds both kinds; its scenes (and content keys) are exactly those of the two
    single-[linkage] campaigns (so a mixed file resumes and merges with files of either kind)."""
    mixed = parse_config(MIXED_CAMPAIGN)
    singles = [parse_config(MIXED_CAMPAIGN.replace("[[linkage]]\npreset = \"simeon\"\n", "").replace(
        "[[linkage]]", "[linkage]")), parse_config(MIXED_CAMPAIGN.replace("[[linkage]]\npreset = \"thesis\"\n", "")
                                                   .replace("[[linkage]]", "[linkage]"))]
    assert [s.kind for s in mixed.scenes()] == ["four-bar", "slider-crank"]
    assert [s.label for s in mixed.scenes()] == ["source/distributed/0.05w1/k1/z0.02/ccw",
                                                 "slider-crank/distributed/0.05w1/k1/z0.02/ccw"]
    assert [s.key for s in mixed.scenes()] == [s.key for c in singles for s in c.scenes()]
    tables = '[[linkage]]\npreset = "thesis"\n\n[[linkage]]\npreset = "simeon"\n'
    inline = parse_config(MIXED_CAMPAIGN.replace(tables, "").replace(
        "[campaign]", 'linkage = ["thesis", "simeon"]\n[campaign]'))
    assert [s.key for s in inline.scenes()] == [s.key for s in mixed.scenes()]
    assert mixed.grid.size() == 2 and mixed.linkages == (singles[0].linkage, singles[1].linkage)


@pytest.mark.parametrize("grid_line, path, words", [
    ('mechanisms = ["source", "cognate"]', "grid.mechanisms", "linkage[1] is a slider-crank, which has no Roberts"),
    ('mass_models = ["distributed", "extender"]', "grid.mass_models", "extender: not a mass model of a slider-crank"),
])
def test_mixed_campaign_refuses_axes_a_kind_lacks(grid_line, path, words):
    """A grid point that does not apply to one of the linkages is refused at load (one line naming the grid
    parameter and the linkage), never skipped: every requested point is computed or the config is refused."""
    text = MIXED_CAMPAIGN.replace('mass_models = ["distributed"]', grid_line if "mass" in grid_line else
                                  'mass_models = ["distributed"]\n' + grid_line)
    with pytest.raises(ConfigError) as exc:
        parse_config(text)
    assert len(exc.value.problems) == 1 and exc.value.problems[0].startswith(f"{path}: ")
    assert words in exc.value.problems[0] and "ked merge" in exc.value.problems[0]


def test_mixed_campaign_names_the_linkage_of_a_problem(tmp_path):
    with pytest.raises(ConfigError) as exc:
        parse_config('linkage = ["thesis", 3, "foo", "thesis"]\n')
    assert exc.value.problems == [
        "linkage[1]: must be a linkage table or a preset name ('thesis', 'simeon'), got integer",
        "linkage[2].preset: must be one of 'thesis', 'simeon', got 'foo'",
        "linkage[3]: the same linkage as linkage[0] (each linkage once)"]
    p = tmp_path / "two.toml"
    p.write_text('linkage = ["thesis", "simeon"]\n')
    with pytest.raises(ConfigError, match="a linkage file holds one"):
        load_linkage(p)


def test_mixed_campaign_runs_stores_both_kinds_and_each_scene_is_the_direct_call(tmp_path):
    """`ked run` on a grid of both kinds (low speed, the cheap pinned Exudyn settings of conftest): both kinds
    stored, the file verifies, and every stored history is the direct solver call's on the same scene."""
    from compare.store import stored_solutions
    from tests.conftest import QUICK_DYNAMIC

    cfg_path = tmp_path / "mixed.toml"
    cfg_path.write_text(MIXED_CAMPAIGN + QUICK_DYNAMIC)
    out_h5 = tmp_path / "mixed.h5"
    runner = CliRunner()
    res = runner.invoke(cli, ["run", str(cfg_path), "--out", str(out_h5), "--workers", "1", "--no-figures",
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    verify = runner.invoke(cli, ["inspect", str(out_h5), "--verify"])
    assert verify.exit_code == 0 and "2 complete scenes" in verify.output, verify.output
    with h5py.File(out_h5, "r") as f:
        kinds = sorted(row["kind"] or "four-bar" for row in h5layout.table_rows(f, h5layout.SCENE_TABLE))
    assert kinds == ["four-bar", "slider-crank"]
    stored = stored_solutions(out_h5)
    for spec in load_config(cfg_path).scenes():
        direct = run_scene(spec)  # resolves the speed ratio to rpm as the campaign does
        assert direct.ok, direct.message
        for name in ("quasi_static", "linear", "dynamic"):
            solver = get(name)
            settings = solver.make_settings({**spec.shared_settings(), **spec.settings_for(name)},
                                            spec.damping_ratio)
            sol = solver.run(spec.scene(direct.rpm), settings, spec.outputs)
            for comp in spec.outputs:
                assert np.allclose(stored[spec.key][name].deflection[comp], sol.deflection[comp],
                                   rtol=0, atol=1e-12), (spec.kind, name, comp)
