"""Config key grid.dynamic_variants (a grid axis over Exudyn settings, used by the studies)."""

from __future__ import annotations

import pytest

from compare.config import ConfigError, parse_config

BASE = "[grid]\nmass_models = ['extender']\n"


def test_no_variants_keeps_scenes_and_keys() -> None:
    plain = parse_config(BASE + "[dynamic]\nsteps_per_cycle = 90\n")
    assert plain.grid.dynamic_variants == ((),)
    same = parse_config(BASE + "dynamic_variants = [{steps_per_cycle = 90}]\n")
    assert [s.key for s in plain.scenes()] == [s.key for s in same.scenes()]


def test_array_values_expand_to_product_merged_on_dynamic() -> None:
    cfg = parse_config(BASE + "dynamic_variants = [{elements_per_link = [1, 2], steps_per_cycle = [90, 180]},"
                       " {element = 'gebeam'}]\n[dynamic]\nspectral_radius = 0.6\n")
    dyn = [dict(s.dynamic) for s in cfg.scenes()]
    assert len(dyn) == 5 and len({s.key for s in cfg.scenes()}) == 5
    assert all(d["spectral_radius"] == 0.6 and d["damping_ratio"] == 0.02 for d in dyn)
    assert dyn[0]["elements_per_link"] == 1 and dyn[0]["steps_per_cycle"] == 90
    assert dyn[4]["element"] == "gebeam"


@pytest.mark.parametrize("text, path, words", [
    ("dynamic_variants = []", "grid.dynamic_variants", "non-empty array"),
    ("dynamic_variants = [1]", "grid.dynamic_variants[0]", "table"),
    ("dynamic_variants = [{steps = 9}]", "grid.dynamic_variants[0].steps", "unknown key"),
    ("dynamic_variants = [{steps_per_cycle = [90, 7.5]}]", "grid.dynamic_variants[0].steps_per_cycle",
     "integer"),
    ("dynamic_variants = [{damping_ratio = 0.1}]", "grid.dynamic_variants[0].damping_ratio", "damping_ratios"),
    ("dynamic_variants = [{elements_per_link = 2}, {elements_per_link = 2}]", "grid.dynamic_variants",
     "duplicate"),
    ("dynamic_variants = [{max_cycles = 1}]\n[dynamic]\nmin_cycles = 3", "grid.dynamic_variants[0]",
     "min_cycles"),
])
def test_bad_variants_are_reported_with_their_path(text: str, path: str, words: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_config(BASE + text)
    assert any(p.startswith(path + ":") and words in p for p in err.value.problems), err.value.problems
