"""The registry is the one solver contract: every registered solver, and a solver registered later, meets it.

Checked on each solver of ``compare.solvers.names()`` (no per-solver branches):

* grid and outputs: a solution holds exactly the requested components, each one value per crank angle
  of the scene's grid, finite;
* settings: the rules the solver declares (``setting_rules``) name fields of its settings class and
  accept its defaults; the settings survive the store's representation (a real HDF5 solution dataset
  written and read back) and rebuild equal; the campaign config checks the solver's table with the same
  rules (a value outside a declared range is refused naming the key);
* failures: bad settings or a scene the solver cannot take give a failed :class:`Solution` from
  :func:`compare.execute.solve_one` (what a campaign calls), never an exception;
* content keys: the committed reference campaign's and studies' scenes recompute the keys stored in their
  files (declaring the settings with rules changed no key: nothing committed reruns).

A test solver (``tests/stiff_solver.py``: the quasi-static solution with every Young's modulus times a
factor) registered here joins the physics-check suite and meets the contract.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from compare import h5layout, store
from compare import solvers as registry
from compare.config import ConfigError, load_config, parse_config
from compare.execute import solve_one
from compare.scenes import SceneSpec, SpeedSpec
from compare.solvers import COMPONENTS, STATUS_FAILED
from ked_quasi import MassModel, Scene
from tests import stiff_solver
from tests.test_physics_checks import SCENES, quasi_static, run_physics_checks

ROOT = Path(__file__).resolve().parents[1]


def _settings_fields(solver: registry.Solver) -> set[str]:
    return {f.name for f in dataclasses.fields(solver.settings_class())}


def _scene(thesis) -> Scene:
    # the thesis tip scene on a coarse grid: speed ratio ~0.05, where every model converges quickly
    return Scene(thesis, MassModel("tip", payload=0.12), rpm=30.0, step_deg=30.0)


@pytest.fixture()
def stiff():
    """The test solver, registered for one test only (other tests see the built-in registry)."""
    registry.register(stiff_solver.STIFF)
    yield stiff_solver.STIFF
    registry.REGISTRY.pop(stiff_solver.STIFF.name, None)


# -- settings --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", registry.names())
def test_declared_rules_name_settings_fields_and_accept_the_defaults(name):
    solver = registry.get(name)
    rules_of = solver.setting_rules()
    fields = _settings_fields(solver)
    assert set(rules_of) <= fields, f"{name}: rules for fields its settings do not have"
    defaults = solver.setting_fields()
    for key, rule in rules_of.items():
        if defaults[key] is not None:
            assert rule.check(defaults[key]) == defaults[key]
    # every field with a numeric default is ranged by a rule (nothing validated by hand elsewhere)
    unruled = {k for k, v in defaults.items() if isinstance(v, (int, float)) and k not in rules_of}
    assert not unruled, f"{name}: settings without a declared rule: {sorted(unruled)}"


@pytest.mark.parametrize("name", registry.names())
def test_settings_round_trip_through_the_store(name, tmp_path):
    solver = registry.get(name)
    settings = solver.make_settings({}, 0.05)
    sol = registry.Solution(name, "ok", {c: np.zeros(3) for c in COMPONENTS}, settings=solver.settings_dict(settings),
                            stats={"wall_s": 0.0})
    with h5py.File(tmp_path / "s.h5", "w") as f:  # the store's solution table (schema version 4)
        h5layout.write_tables(f, [], [h5layout.solution_row("k", sol)], [])
    with h5py.File(tmp_path / "s.h5", "r") as f:
        row, = h5layout.table_rows(f, h5layout.SOLUTION_TABLE)
    back = json.loads(h5layout.text(row["settings_json"]))
    assert back == solver.settings_dict(settings)
    assert solver.make_settings(back, 0.05) == settings


@pytest.mark.parametrize("name", [n for n in registry.names() if registry.get(n).setting_rules()])
def test_config_checks_a_solver_table_with_the_declared_rules(name):
    solver = registry.get(name)
    key, rule = next((k, r) for k, r in solver.setting_rules().items()
                     if k != "damping_ratio" and getattr(r, "hi", None) is not None)
    too_big = rule.hi * 2 + 1 if rule.integer else rule.hi * 2 + 1.0
    # the class refuses it ...
    with pytest.raises(ValueError, match=key):
        solver.make_settings({key: too_big}, 0.02)
    # ... and so does the config's table of that solver, naming the key and the declared range
    with pytest.raises(ConfigError) as err:
        parse_config(f'[campaign]\nsolvers = ["quasi_static", "{name}"]\n[{name}]\n{key} = {too_big!r}\n')
    assert f"{name}.{key}: must be {rule.allowed()}" in str(err.value)
    # the damping ratio is a grid axis for every solver alike
    with pytest.raises(ConfigError, match=rf"{name}.damping_ratio: set damping in grid.damping_ratios"):
        parse_config(f"[{name}]\ndamping_ratio = 0.1\n")


def test_one_declaration_for_the_dynamic_settings():
    """The Exudyn settings class and ``[dynamic]`` accept the same ranges (they differed: the class took
    any positive elements_per_link, the config 1..64)."""
    from exudyn_models.settings import DynamicSettings

    with pytest.raises(ValueError, match="elements_per_link"):
        DynamicSettings(elements_per_link=65)
    with pytest.raises(ValueError, match="steps_per_cycle"):
        DynamicSettings(steps_per_cycle=4)
    assert DynamicSettings(elements_per_link=64, steps_per_cycle=8).elements_per_link == 64
    with pytest.raises(ConfigError, match="dynamic.elements_per_link"):
        parse_config("[dynamic]\nelements_per_link = 65\n")


# -- solutions -------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", registry.names())
def test_solution_on_the_grid_with_the_requested_outputs(name, thesis):
    solver = registry.get(name)
    scene = _scene(thesis)
    sol = solver.run(scene, solver.make_settings({}, 0.02), ("dx", "rotation"))
    assert sol.ok, sol.message
    assert sol.solver == name
    assert set(sol.deflection) == {"dx", "rotation"}
    for c, v in sol.deflection.items():
        assert v.shape == scene.crank_angles.shape and np.all(np.isfinite(v)), c
    assert math.isfinite(sol.stats["wall_s"])
    json.dumps(sol.stats)  # JSON-able, as stored


def _spec(thesis, solver: str, overrides: dict) -> SceneSpec:
    items = tuple(sorted(overrides.items()))
    return SceneSpec(linkage=thesis, mechanism="source", mass_model=MassModel("tip", payload=0.12),
                     speed=SpeedSpec("rpm", 30.0), stiffness_scale=1.0, damping_ratio=0.02, direction="ccw",
                     step_deg=30.0, n_modes=1, outputs=COMPONENTS, tolerance=0.1,
                     dynamic=items if solver == "dynamic" else (),
                     extra_settings=() if solver == "dynamic" else ((solver, items),),
                     solvers=("quasi_static", solver) if solver != "quasi_static" else ("quasi_static",))


@pytest.mark.parametrize("name", registry.names())
def test_a_failure_is_a_solution_not_an_exception(name, thesis):
    solver = registry.get(name)
    spec = _spec(thesis, name, {"no_such_setting": 1})
    bad = solve_one(solver, spec, spec.scene(30.0))
    assert bad.status == STATUS_FAILED and bad.failure_class == "input" and "no_such_setting" in bad.message
    spec = _spec(thesis, name, {})
    broken = solve_one(solver, spec, scene=None)  # a scene the solver cannot take: its run raises
    assert broken.status == STATUS_FAILED and broken.solver == name and broken.error_type


# -- a registered test solver joins ---------------------------------------------------------------

def test_a_registered_solver_joins_the_physics_checks_and_the_contract(stiff, thesis, thesis_cognate, tmp_path):
    assert stiff.name in registry.names()
    run_physics_checks(stiff.name, thesis, thesis_cognate)  # the physics-check suite, to its 1e-10
    scene = SCENES["tip-source"](thesis)
    sol = stiff.run(scene, stiff.make_settings({"factor": 4.0}, 0.02), COMPONENTS)
    # deflection is linear in the compliance: exactly the quasi-static one / 4 (to round-off)
    np.testing.assert_allclose(sol.array(), quasi_static(scene) / 4.0, rtol=1e-10, atol=1e-16)
    test_declared_rules_name_settings_fields_and_accept_the_defaults(stiff.name)
    test_settings_round_trip_through_the_store(stiff.name, tmp_path)
    test_config_checks_a_solver_table_with_the_declared_rules(stiff.name)
    test_a_failure_is_a_solution_not_an_exception(stiff.name, thesis)


def test_the_test_solver_is_not_registered_outside_its_test():
    assert stiff_solver.STIFF.name not in registry.names()


# -- content keys ----------------------------------------------------------------------------------

def _committed() -> list[tuple[Path, Path]]:
    """(config, its results file) of the committed campaigns whose file has the config's name."""
    pairs = [(ROOT / "results" / "reference" / "reference.toml", ROOT / "results" / "reference" / "reference.h5")]
    pairs += [(t, t.with_suffix(".h5")) for t in sorted((ROOT / "results" / "studies").glob("*.toml"))
              if t.with_suffix(".h5").exists()]
    return pairs


@pytest.mark.parametrize("config,results", _committed(), ids=lambda p: p.name)
def test_committed_scene_keys_recompute_identical(config, results):
    # regression pin: the keys stored in the committed files (computed by earlier versions)
    if not results.exists():
        pytest.skip(f"{results} not in this checkout")
    stored = set(store.stored_status(results))
    planned = {s.key for s in load_config(config).scenes()}
    assert planned and planned <= stored, f"{len(planned - stored)} of {len(planned)} scenes would rerun"
