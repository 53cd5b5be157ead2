"""Link stress histories of the Exudyn tier: one more constant-speed cycle from the steady state reached,
with the beam elements' own section forces (:func:`exudyn_models.sections.element_forces`) read at every
step and splined onto the scene's crank-angle grid.

The cycle starts from the model's current state (the end of the steady cycle the run returned: the last
simulated cycle, or the cycle that confirmed an extrapolated one) at the model's current time, so it is the
steady cycle once more; its first step's state is read before the step (Exudyn's pre-step function sees the
state at the start of the coming step); the section forces are read at every step, or every k-th one for at
least :data:`SAMPLES` per cycle.  Per link (every link built of beam elements; a rigid slider crank
has none) the result is a :class:`ked_quasi.stress.LinkStress` on the link's elements: N at each element's
midpoint, M at both its ends (ANCF: M = EI kappa is linear along the element; a geometrically exact element's
moment is its mean, given to both ends).  The moment's sign is Exudyn's (counterclockwise curvature
positive); the fibre stresses use |M|.  Costs one cycle more than the run; only computed when asked for.
"""

from __future__ import annotations

import math

import exudyn as exu
import numpy as np
from scipy.interpolate import CubicSpline

from ked_quasi.stress import LinkStress, StressHistory

from .cycles import solver_settings
from .sections import element_forces
from .start import set_initial_state
from .tolerance import NewtonTolerances

SAMPLES = 360
"""Section forces are read at least this many times per cycle (every step, or every k-th step of a run with
more steps per cycle: reading them costs as much as a step), then splined onto the scene's grid."""


class _Sampler:
    """Exudyn pre-step function: every link's section forces in the state at the start of each step (Exudyn
    passes the time at the step's end)."""

    def __init__(self, element: str, chains: dict[str, tuple[list[int], float]], step: float, stride: int):
        self.element, self.chains, self.step, self.stride = element, chains, step, stride
        self.calls = 0
        self.times: list[float] = []
        self.axial: dict[str, list[np.ndarray]] = {k: [] for k in chains}
        self.moment: dict[str, list[np.ndarray]] = {k: [] for k in chains}
        self.error: BaseException | None = None

    def __call__(self, mbs, t: float) -> bool:
        self.calls += 1
        if (self.calls - 1) % self.stride:
            return True
        try:
            self.times.append(t - self.step)  # t: the end of the coming step
            for link, (objects, length) in self.chains.items():
                n, m = element_forces(mbs, self.element, objects, length)
                self.axial[link].append(n)
                self.moment[link].append(m)
        except Exception as exc:  # noqa: BLE001 - reported after the solver returned
            self.error = exc
            return False
        return True


def _on_grid(angles: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Periodic cubic spline of ``values`` (first axis: samples at ``angles`` [rad], one cycle) at ``grid``."""
    a = np.mod(angles, 2.0 * math.pi)
    order = np.argsort(a)
    a, v = a[order], values[order]
    spline = CubicSpline(np.append(a, a[0] + 2.0 * math.pi), np.concatenate([v, v[:1]]), bc_type="periodic",
                         axis=0)
    return spline(grid)


def steady_stress(model, scene, linkage, steps_per_cycle: int, settings, tol: NewtonTolerances) -> StressHistory:
    """Stress histories of every beam link of ``model`` over one more cycle from its current state (module
    doc); ``linkage``: the scene's four-bar or slider-crank (section and length of each link);
    ``steps_per_cycle``: the run's; ``settings``: its DynamicSettings; ``tol``: its Newton tolerances.
    Raises RuntimeError if that cycle does not run through."""
    mbs, drive = model.mbs, model.drive
    sd = mbs.systemData
    t0 = float(sd.GetTime())
    set_initial_state(model, np.array(sd.GetODE2Coordinates()), np.array(sd.GetODE2Coordinates_t()),
                      np.array(sd.GetODE2Coordinates_tt()), np.array(sd.GetAECoordinates()))
    n_el = settings.elements_per_link
    chains = {link: (objects, linkage.length(link) / n_el) for link, objects in model.link_elements.items()}
    h = drive.cycle_time / steps_per_cycle
    stride = max(1, steps_per_cycle // SAMPLES)
    sampler = _Sampler(settings.element, chains, h, stride)
    sset = solver_settings(settings, h, t0 + steps_per_cycle * h, tol)
    sset.timeIntegration.startTime = t0
    sset.timeIntegration.numberOfSteps = steps_per_cycle
    mbs.SetPreStepUserFunction(sampler)
    try:
        ok = exu.MainSolverImplicitSecondOrder().SolveSystem(mbs, sset)
    finally:
        mbs.SetPreStepUserFunction(0)
    if sampler.error is not None:
        raise RuntimeError(f"section forces not read: {sampler.error}")
    k = -(-steps_per_cycle // stride)  # the samples of one cycle
    if not ok or len(sampler.times) < k:
        raise RuntimeError("the stress cycle from the steady state did not run through")
    angles = np.array([drive.angle(t) for t in sampler.times[:k]])
    grid = np.asarray(scene.crank_angles, dtype=float)
    links = {}
    for link in chains:
        axial = _on_grid(angles, np.array(sampler.axial[link][:k]), grid)
        moment = _on_grid(angles, np.array(sampler.moment[link][:k]), grid)
        e = np.arange(n_el)
        sec = linkage.section(link)
        links[link] = LinkStress(link=link, s0=e / n_el, s1=(e + 1) / n_el, axial=axial, moment=moment,
                                 area=sec.area, second_moment=sec.second_moment, fibre=sec.extreme_fibre)
    return StressHistory(crank_angle=grid, links=links, tier="exudyn")
