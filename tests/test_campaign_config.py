"""Campaign configuration: parsing, validation (every problem with its TOML path), grid, keys."""

from __future__ import annotations

import math
import re
from pathlib import Path

import h5py
import pytest

from compare import h5layout
from compare.config import ConfigError, default_config_text, load_config, parse_config
from compare.scenes import SceneSpec, SpeedSpec
from ked_quasi import MassModel, rules
from tests.conftest import small_fourbar

EXPLICIT = """
[campaign]
name = "explicit"
[linkage]
crank = 0.1
coupler = 0.3
follower = 0.25
extender = 0.1
coupler_angle_deg = 60.0
ground = 0.3
[linkage.section]
youngs_modulus = 7.0e10
area = 1.0e-4
second_moment = 1.0e-9
density = 2700.0
[grid]
rpm = [100.0]
"""


def problems_of(text: str) -> list[str]:
    with pytest.raises(ConfigError) as info:
        parse_config(text)
    return info.value.problems


# (kind of mistake, TOML, expected TOML path in the message, expected words)
BAD = [
    ("toml syntax", "[campaign\nname = 1", "TOML syntax error", ""),
    ("unknown top-level table", "[campagin]\nname='x'", "campagin", "unknown key"),
    ("unknown key in table", "[campaign]\ntolerence = 0.1", "campaign.tolerence", "unknown key"),
    ("wrong type", "[campaign]\ntolerance = '10%'", "campaign.tolerance", "must be a number"),
    ("out of range", "[campaign]\ntolerance = -0.1", "campaign.tolerance", "must be a number in (0, 10]"),
    ("step not dividing 360", "[campaign]\nstep_deg = 7.0", "campaign.step_deg", "divide 360"),
    ("unknown output", "[campaign]\noutputs = ['dx', 'dz']", "campaign.outputs[1]", "must be one of"),
    ("bad mechanism", "[grid]\nmechanisms = ['source', 'copy']", "grid.mechanisms[1]", "must be one of"),
    ("bad mass model", "[grid]\nmass_models = ['tip', 'bulk']", "grid.mass_models[1].name", "must be one of"),
    ("tip without payload", "[grid]\nmass_models = [{name='tip', payload_kg=0.0}]", "grid.mass_models[0]",
     "payload must be > 0"),
    ("negative rpm", "[grid]\nrpm = [100.0, -5.0]", "grid.rpm[1]", "must be a number in (0, 100000] rev/min"),
    ("empty speed list", "[grid]\nrpm = []", "grid.rpm", "must not be empty"),
    ("not an array", "[grid]\nrpm = 300", "grid.rpm", "must be an array"),
    ("duplicate values", "[grid]\nrpm = [300.0, 300]", "grid.rpm", "duplicate"),
    ("boolean as number", "[grid]\nstiffness_scales = [true]", "grid.stiffness_scales[0]", "must be a number"),
    ("damping too large", "[grid]\ndamping_ratios = [1.5]", "grid.damping_ratios[0]", "in [0, 0.99]"),
    ("bad direction", "[grid]\ndirections = ['clockwise']", "grid.directions[0]", "must be one of"),
    ("unknown preset", "[linkage]\npreset = 'watt'", "linkage.preset", "must be one of"),
    ("explicit linkage incomplete", "[linkage]\ncrank = 0.1", "linkage.coupler", "required"),
    ("zero length", "[linkage]\npreset = 'thesis'\ncrank = 0.0", "linkage.crank", "must be a number in (0, 10] m"),
    ("cannot assemble", "[linkage]\npreset = 'thesis'\nfollower = 0.1", "linkage", "cannot assemble"),
    ("too many lumps", "[grid]\nmass_models = [{name='distributed', lumps=1000}]", "grid.mass_models[0].lumps",
     "in [1, 256]"),
    ("bad section key", "[linkage.sections.crank]\nyoung = 1.0", "linkage.sections.crank.young", "unknown key"),
    ("unknown dynamic setting", "[dynamic]\nsteps = 10", "dynamic.steps", "unknown key"),
    ("dynamic wrong type", "[dynamic]\nsteps_per_cycle = 72.5", "dynamic.steps_per_cycle", "must be an integer"),
    ("dynamic out of range", "[dynamic]\nspectral_radius = 1.5", "dynamic.spectral_radius", "a number in [0, 1]"),
    ("bad element", "[dynamic]\nelement = 'truss'", "dynamic.element", "must be one of"),
    ("damping in the wrong place", "[dynamic]\ndamping_ratio = 0.05", "dynamic.damping_ratio", "grid.damping_ratios"),
    ("inconsistent dynamic settings", "[dynamic]\nmin_cycles = 9\nmax_cycles = 3", "dynamic", "min_cycles"),
    ("table expected", "campaign = 3", "campaign", "must be a table"),
]


@pytest.mark.parametrize("kind,text,path,words", BAD, ids=[b[0] for b in BAD])
def test_bad_config_is_reported_with_its_path(kind, text, path, words):
    probs = problems_of(text)
    assert any(p.startswith(path) or path in p for p in probs), probs
    assert any(words in p for p in probs), probs


def test_all_problems_are_listed_in_one_error():
    text = """
    [campaign]
    tolerance = 0
    outputs = ["dq"]
    colour = "red"
    [grid]
    mechanisms = ["source", 3]
    rpm = ["fast"]
    [dynamic]
    elements_per_link = 0
    """
    with pytest.raises(ConfigError) as info:
        parse_config(text, source="bad.toml")
    msg = str(info.value)
    for path in ("campaign.tolerance", "campaign.outputs[0]", "campaign.colour", "grid.mechanisms[1]",
                 "grid.rpm[0]", "dynamic.elements_per_link"):
        assert path in msg
    assert msg.startswith("bad.toml: 6 problem(s):")
    assert len(info.value.problems) == 6


def test_missing_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="cannot read file"):
        load_config(tmp_path / "nope.toml")


def test_default_campaign_is_valid_and_covers_the_brief():
    cfg = load_config(None)
    g = cfg.grid
    assert cfg.text == default_config_text()
    assert set(g.mechanisms) == {"source", "cognate"}
    assert {m.name for m in g.mass_models} == {"tip", "joints", "extender", "distributed"}
    rpms = [s.value for s in g.speeds if s.kind == "rpm"]
    assert max(rpms) == 300.0 and min(rpms) <= 60.0
    assert len(cfg.scenes()) == len(g.mechanisms) * len(g.mass_models) * len(g.speeds) == g.size()


def test_empty_config_is_one_thesis_scene():
    cfg = parse_config("")
    (scene,) = cfg.scenes()
    assert scene.mechanism == "source" and scene.mass_model.name == "tip"
    assert scene.speed == SpeedSpec("rpm", 300.0)
    assert scene.linkage.crank == pytest.approx(0.254)
    assert scene.tolerance == 0.10


def test_explicit_linkage_and_overrides():
    cfg = parse_config(EXPLICIT)
    lk = cfg.linkage
    assert lk.follower_pivot == (0.3, 0.0) and lk.coupler_angle == pytest.approx(math.radians(60))
    assert all(s.youngs_modulus == 7.0e10 for s in lk.sections)
    cfg2 = parse_config(EXPLICIT + "[linkage.sections.crank]\narea = 2.0e-4\n")
    assert cfg2.linkage.sections[0].area == 2.0e-4 and cfg2.linkage.sections[1].area == 1.0e-4
    thesis = parse_config("[linkage]\npreset = 'thesis'\nextender = 0.3\n").linkage
    assert thesis.extender == 0.3 and thesis.crank == pytest.approx(0.254)


def test_grid_expansion_and_speed_kinds():
    cfg = parse_config("""
    [grid]
    mechanisms = ["source", "cognate"]
    mass_models = ["tip", {name = "distributed", lumps = 3, payload_kg = 0.2}]
    rpm = [100.0, 300.0]
    speed_ratios = [0.1]
    stiffness_scales = [1.0, 0.5]
    directions = ["ccw", "cw"]
    [dynamic]
    steps_per_cycle = 72
    """)
    scenes = cfg.scenes()
    assert len(scenes) == 2 * 2 * 3 * 2 * 2
    assert len({s.key for s in scenes}) == len(scenes)
    assert {s.speed.kind for s in scenes} == {"rpm", "ratio"}
    assert scenes[0].mass_model == MassModel("tip", rules.DEFAULT_LUMPS, 0.90718474, 0.5, "midpoint")  # thesis 2 lb
    assert dict(scenes[0].dynamic) == {"steps_per_cycle": 72, "damping_ratio": 0.02}


def _spec(**changes) -> SceneSpec:
    base = dict(
        linkage=small_fourbar(),
        mechanism="source",
        mass_model=MassModel("tip", lumps=5, payload=1.0),
        speed=SpeedSpec("rpm", 300.0),
        stiffness_scale=1.0,
        damping_ratio=0.02,
        direction="ccw",
        step_deg=10.0,
        n_modes=3,
        outputs=("dx", "dy", "rotation"),
        tolerance=0.1,
        dynamic=(("damping_ratio", 0.02), ("steps_per_cycle", 72)),
    )
    base.update(changes)
    return SceneSpec(**base)


def test_scene_key_is_stable_and_content_based():
    s = _spec()
    # pinned: the key must not change between runs, processes or releases of the same parameters
    assert s.key == _spec().key
    assert s.key == SceneSpec.from_dict(s.to_dict()).key
    assert len(s.key) == 16 and int(s.key, 16) >= 0
    assert s.key == "86679f2939fe35aa" or pytest.fail(f"content key changed: {s.key}")
    assert _spec(stiffness_scale=0.5).key != s.key
    assert _spec(dynamic=(("damping_ratio", 0.02), ("steps_per_cycle", 73))).key != s.key
    with pytest.raises(AttributeError):
        s.mechanism = "cognate"  # immutable


def test_output_order_does_not_change_keys():
    a = parse_config("[campaign]\noutputs = ['dy', 'dx']\n").scenes()[0]
    b = parse_config("[campaign]\noutputs = ['dx', 'dy']\n").scenes()[0]
    assert a.outputs == ("dx", "dy") and a.key == b.key


COMMITTED_CONFIGS = sorted(str(p) for p in Path("results").rglob("*.toml"))


@pytest.mark.parametrize("path", [None, *COMMITTED_CONFIGS])
def test_committed_configs_keep_their_scenes_with_linkage_arrays(path):
    """Every committed config (and the embedded default) gives the same scenes and content keys whether its
    [linkage] is a table or a one-element [[linkage]] array (the array form only adds linkages); where its
    results file is committed, its scenes' keys are stored there (written before linkage arrays existed)."""
    text = default_config_text() if path is None else Path(path).read_text(encoding="utf-8")
    as_array = re.sub(r"^\[linkage\]", "[[linkage]]", text, flags=re.M)
    assert as_array != text or "[linkage]" not in text
    try:
        keys = [s.key for s in parse_config(text).scenes()]
    except ConfigError as exc:  # the stability study's deliberately bad configs: refused alike in both forms
        with pytest.raises(ConfigError) as again:
            parse_config(as_array)
        assert again.value.problems == exc.problems
        return
    assert [s.key for s in parse_config(as_array).scenes()] == keys
    h5 = None if path is None else Path(path).with_suffix(".h5")
    if h5 is not None and h5.is_file():
        with h5py.File(h5, "r") as f:
            stored = {h5layout.text(row["key"]) for row in h5layout.table_rows(f, h5layout.SCENE_TABLE)}
        assert set(keys) <= stored
