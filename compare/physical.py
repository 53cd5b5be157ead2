"""The physical scene of a scene description apart from its settings: what ``ked diff`` matches scenes by when
their content keys differ, and what ``ked run`` names when its file holds some of its physical scenes under other
settings."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from typing import Any

from compare.scenes import SceneSpec

PHYSICAL = ("linkage", "mechanism", "mass_model", "speed", "stiffness_scale", "damping_ratio", "direction")
"""The fields of a scene's description that make the physical scene (the rest are settings)."""
SCENE_SETTINGS = ("step_deg", "n_modes", "outputs", "tolerance")
"""Settings of the scene that concern every solver: a change puts every solver in the ``physics`` tier."""


def spec_physical_key(spec: SceneSpec) -> str:
    """Hash of a scene description's physical scene (:data:`PHYSICAL`), whatever its settings."""
    d = spec.key_dict()
    text = json.dumps({k: d[k] for k in PHYSICAL}, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def spec_settings(spec: SceneSpec) -> dict[str, Any]:
    """name -> value of every setting a scene description gives: the scene's own and each solver's explicit ones
    (``dynamic.start``, ...)."""
    d = spec.key_dict()
    out = {k: d[k] for k in SCENE_SETTINGS if k in d}
    for k, v in d.items():
        if k not in PHYSICAL and k not in SCENE_SETTINGS and isinstance(v, dict):
            out.update({f"{k}.{n}": x for n, x in v.items()})
    return out


def other_settings(scenes: Sequence[SceneSpec], stored: Sequence[SceneSpec]) -> tuple[int, list[str]]:
    """Stored scenes outside ``scenes`` (by content key) that are one of their physical scenes under other
    settings: (how many, the differing settings "name: stored -> now", sorted, each once). A campaign run into a
    file made with other settings adds its scenes beside them (new keys); this says so."""
    keys = {s.key for s in scenes}
    now = {spec_physical_key(s): s for s in scenes}
    count, differ = 0, set()
    for old in stored:
        new = now.get(spec_physical_key(old)) if old.key not in keys else None
        if new is None:
            continue
        count += 1
        a, b = spec_settings(old), spec_settings(new)
        differ.update(f"{k}: {a.get(k, '-')} -> {b.get(k, '-')}" for k in set(a) | set(b) if a.get(k) != b.get(k))
    return count, sorted(differ)
