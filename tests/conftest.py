"""Shared fixtures: the thesis linkage, its cognate, random assemblable four-bars."""

from __future__ import annotations

import numpy as np
import pytest

from ked_quasi import FourBar, MassModel, Section, mechanism, thesis_fourbar
from ked_quasi.linkage import THESIS_TIP_MASS_KG

# cheap, pinned Exudyn settings for campaign tests (coarse but converging at low speed)
QUICK_DYNAMIC = """[dynamic]
element = "ancf"
elements_per_link = 2
steps_per_cycle = 36
spectral_radius = 0.6
ramp_cycles = 1.0
max_cycles = 10
sparse = false
"""

def small_fourbar() -> FourBar:
    """A small aluminium crank-rocker (lengths in m, coupler angle 1 rad) for campaign tests."""
    sec = Section(7.0e10, 1.0e-4, 1.0e-9, 2700.0)
    return FourBar(crank=0.1, coupler=0.3, follower=0.25, extender=0.1, coupler_angle=1.0, sections=(sec,) * 4,
                   crank_pivot=(0.0, 0.0), follower_pivot=(0.3, 0.0), branch="open")


MASS_MODEL_CASES = {
    "tip": MassModel("tip", lumps=5, payload=THESIS_TIP_MASS_KG),
    "joints": MassModel("joints", lumps=5),
    "extender": MassModel("extender", lumps=5),  # 5 lumps: these cases test numerics, not the lumping
    "distributed": MassModel("distributed", lumps=4, payload=0.3),
}


@pytest.fixture(scope="session")
def thesis():
    return thesis_fourbar()


@pytest.fixture(scope="session")
def thesis_cognate():
    return mechanism(thesis_fourbar(), "cognate")


def random_fourbars(n: int, seed: int = 7) -> list[FourBar]:
    """Random crank-rockers (open or crossed, random pivots and sections) that assemble fully."""
    rng = np.random.default_rng(seed)
    out: list[FourBar] = []
    while len(out) < n:
        crank = rng.uniform(0.03, 0.15)
        ground, coupler, follower = rng.uniform(0.2, 0.6, 3)
        if not (coupler + follower > ground + crank + 0.02 and abs(coupler - follower) < ground - crank - 0.02):
            continue
        M = rng.uniform(-0.2, 0.2, 2)
        ang = rng.uniform(0, 2 * np.pi)
        Q = M + ground * np.array([np.cos(ang), np.sin(ang)])
        secs = tuple(Section(rng.uniform(50e9, 210e9), rng.uniform(5e-5, 3e-4), rng.uniform(5e-10, 5e-9),
                             rng.uniform(2000, 8000)) for _ in range(4))
        out.append(FourBar(crank=crank, coupler=coupler, follower=follower, extender=rng.uniform(0.05, 0.4),
                           coupler_angle=rng.uniform(-np.pi, np.pi), sections=secs,
                           crank_pivot=tuple(M), follower_pivot=tuple(Q),
                           branch=str(rng.choice(["open", "crossed"])), direction=str(rng.choice(["ccw", "cw"]))))
    return out


def quasi_deflection(scene) -> np.ndarray:
    """The quasi-static deflection history of ``scene`` (n, 3), its validity warnings silenced."""
    import warnings

    from ked_quasi.solver import solve_quasi_static

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return solve_quasi_static(scene).deflection


def rel_error(got: np.ndarray, expected: np.ndarray) -> tuple[float, float]:
    """max |got - expected| relative to the expected peak: (dx, dy together), rotation."""
    xy = np.abs(got[:, :2] - expected[:, :2]).max() / np.abs(expected[:, :2]).max()
    rot = np.abs(got[:, 2] - expected[:, 2]).max() / np.abs(expected[:, 2]).max()
    return float(xy), float(rot)
