"""The speed-free frame cache (ked_quasi.framecache): a recombination at another speed equals a fresh build,
and any changed field of the linkage or mass model misses the cache."""

from __future__ import annotations

import numpy as np
import pytest

from ked_quasi import MassModel, natural_frequencies
from ked_quasi.frame import _congruence, _static_modes, assemble, condensed_structure, frame_dofs
from ked_quasi.framecache import CACHE, ContentCache
from ked_quasi.kinematics import loop
from ked_quasi.massmodel import lumps
from ked_quasi.scene import Scene, build_scene
from ked_quasi.solver import inertia_loads, node_masses
from ked_quasi.structure import element_forces, geometry, topology

FIELDS = ("stiffness", "material_stiffness", "mass", "load", "output", "mass_node")


def fresh(scene: Scene, theta: np.ndarray, prestress: bool) -> dict[str, np.ndarray]:
    """The condensation built from scratch at the scene's own speed, without the cache or the speed
    scaling: the loads and axial forces of the scene's rpm, K = K_E + K_G(N), Psi, Psi^T K Psi (the frame
    model's definition, ked_quasi.frame)."""
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    dofs = frame_dofs(topo)
    lp = loop(scene.fourbar, theta)
    geo = geometry(scene.fourbar, topo, theta, lp)
    loads = inertia_loads(scene, topo, lm, theta, geo, lp)
    K_E = assemble(scene.fourbar, topo, dofs, geo)
    K = K_E
    if prestress:
        K = K_E + assemble(scene.fourbar, topo, dofs, geo, element_forces(topo, geo, loads)[..., 0], elastic=False)
    mass = node_masses(topo, lm)
    nodes = np.flatnonzero(mass > 0)
    psi = _static_modes(K, np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel())
    p = topo.p_index
    return {"stiffness": _congruence(psi, K), "material_stiffness": _congruence(psi, K_E),
            "mass": np.repeat(mass[nodes], 2), "load": loads[:, nodes].reshape(theta.size, -1),
            "output": psi[:, [2 * p, 2 * p + 1, dofs.p_rotation]], "mass_node": nodes}


def assert_close(cs, ref: dict[str, np.ndarray], rtol: float = 1e-11) -> None:
    for name in FIELDS:
        got, want = np.asarray(getattr(cs, name)), ref[name]
        assert got.shape == want.shape, name
        scale = np.max(np.abs(want))
        assert np.max(np.abs(got - want)) <= rtol * scale, name


@pytest.mark.parametrize("mass_model", ["tip", "extender", "distributed"])
def test_recombination_at_another_speed_equals_a_fresh_build(thesis, mass_model):
    # the cache is filled at 250 rpm (ccw); at 37 and 580 rpm, cw too, the recombination (reference-speed
    # loads and geometric stiffness times (rpm / 60)^2, cached K_E) must equal the condensation built
    # directly at that speed (loads from the rigid accelerations at that rpm) to round-off: the loads
    # are exactly quadratic in the crank speed (no gravity), the condensation with prestress is not and
    # is redone per speed
    theta = np.arange(48) * (2.0 * np.pi / 48) + 0.01
    CACHE.clear()
    for prestress in (True, False):
        condensed_structure(build_scene(thesis, mass_model=mass_model, rpm=250.0), theta, prestress)
    hits = CACHE.hits
    for rpm, direction in ((37.0, "ccw"), (580.0, "ccw"), (580.0, "cw")):
        scene = build_scene(thesis, mass_model=mass_model, rpm=rpm, direction=direction)
        for prestress in (True, False):
            assert_close(condensed_structure(scene, theta, prestress), fresh(scene, theta, prestress))
    assert CACHE.hits > hits  # the later speeds were recombined from the cache, not rebuilt
    # the geometric stiffness matters at 580 rpm: the prestressed and unstressed condensations differ
    scene = build_scene(thesis, mass_model=mass_model, rpm=580.0)
    a, b = condensed_structure(scene, theta, True).stiffness, condensed_structure(scene, theta, False).stiffness
    assert np.max(np.abs(a - b)) > 1e-6 * np.max(np.abs(b))


def test_a_changed_field_misses_the_cache(thesis):
    # each variant differs from the base in one field the frame depends on; after the base filled the
    # cache the variant's condensation and frequencies must equal its own fresh build (cache emptied) and
    # differ from the base's
    theta = np.arange(36) * (2.0 * np.pi / 36)
    base = build_scene(thesis, mass_model="extender", rpm=200.0, lumps=3, payload=0.5)
    variants = {
        "stiffness scale": build_scene(thesis, mass_model="extender", rpm=200.0, lumps=3, payload=0.5,
                                       stiffness_scale=2.0),
        "lumps": build_scene(thesis, mass_model="extender", rpm=200.0, lumps=4, payload=0.5),
        "payload": build_scene(thesis, mass_model="extender", rpm=200.0, lumps=3, payload=1.5),
        "mechanism": build_scene(thesis, mechanism="cognate", mass_model="extender", rpm=200.0, lumps=3, payload=0.5),
        "mass model": build_scene(thesis, mass_model="distributed", rpm=200.0, lumps=3, payload=0.5),
        "placement": Scene(base.fourbar, MassModel("extender", lumps=3, payload=0.5, placement="end"), 200.0),
    }
    for name, scene in variants.items():
        CACHE.clear()
        own = condensed_structure(scene, theta, True)
        own_f = natural_frequencies(scene, 2, theta)
        CACHE.clear()
        ref = condensed_structure(base, theta, True)
        ref_f = natural_frequencies(base, 2, theta)
        got = condensed_structure(scene, theta, True)
        got_f = natural_frequencies(scene, 2, theta)
        for field in FIELDS:
            assert np.array_equal(getattr(got, field), getattr(own, field)), (name, field)
        assert np.array_equal(got_f, own_f), name
        assert not np.array_equal(got_f, ref_f), name
        assert got.stiffness.shape != ref.stiffness.shape or not np.allclose(got.stiffness, ref.stiffness), name
    # other crank angles are another key too
    CACHE.clear()
    a = natural_frequencies(base, 1, theta)
    assert np.array_equal(natural_frequencies(base, 1, theta + 0.1), natural_frequencies(base, 1, theta + 0.1))
    assert not np.array_equal(natural_frequencies(base, 1, theta + 0.1), a)


def test_the_cache_is_bounded_and_its_arrays_read_only():
    cache = ContentCache(max_entries=3, max_bytes=4000)
    calls = []

    def make(n):
        def compute():
            calls.append(n)
            return np.zeros(n)
        return compute

    for key in "abcd":
        cache.get(key, make(10))
    assert len(cache) == 3 and calls == [10] * 4
    cache.get("a", make(10))  # "a" was the least recently used: dropped, computed again
    assert len(calls) == 5
    cache.get("big", make(400))  # 3200 bytes > a quarter of the budget: computed, not kept
    assert "big" not in cache._items and len(cache) == 3
    assert cache.nbytes <= 4000
    with pytest.raises(ValueError):
        cache.get("a", make(10))[0] = 1.0
    assert cache.get(["unhashable"], make(2)).shape == (2,)  # computed every time
