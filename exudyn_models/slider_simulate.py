"""The elastic slider-crank run to periodic steady state: sampling, tolerances, damping reference (Simeon's
benchmark mechanism: ked_bench.exudyn_tier).

The run is the four-bar's (exudyn_models.simulate: refinement ladder, failure classes, DynamicResult) with
the slider-crank's own model (exudyn_models.slider_builder) and sampler; the constant-speed phase is
marched (exudyn_models.march) from the start-up ramp.

Output per crank angle of the scene grid (same meaning as ked_quasi.slider_static.solve_slider_quasi_static):
dx, dy [m]: flexible position of the coupler point P minus its rigid-kinematics position at the same
prescribed crank angle (global frame); rotation [rad]: slope angle of the coupler at P minus the rigid rod
angle; midspan [m]: displacement of the coupler's midspan minus the mean of the displacements of A and B,
along the CCW normal of the rigid chord A->B (for Simeon's mechanism: his q1, the rod's lateral midspan
deflection).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import replace

import numpy as np
from scipy.interpolate import CubicSpline

from ked_quasi.slidercrank import SliderScene, slider_kinematics

from .builder import _shape_matrix
from .cycles import RunRecord
from .march import march
from .settings import DynamicSettings
from .slider_builder import MIDSPAN, SliderModel, build_slider_model
from .tolerance import ABS_FRACTION, REL_FRACTION, ROUNDOFF_TOLERANCE, NewtonTolerances

OUTPUT_COLUMNS = ("dx", "dy", "rotation", "midspan")
"""Columns of a sampled slider-crank cycle (the steady-state test reads the first three)."""


def _slope_matrix(element: str, xi: float, length: float) -> np.ndarray:
    """2 x 8 derivative d r / d s of the ANCF element's cubic Hermite interpolation at xi (s: arc length)."""
    dh = (-6 * xi + 6 * xi**2, length * (1 - 4 * xi + 3 * xi**2), 6 * xi - 6 * xi**2, length * (-2 * xi + 3 * xi**2))
    S = np.zeros((2, 8))
    for k, h in enumerate(dh):
        S[0, 2 * k], S[1, 2 * k + 1] = h / length, h / length
    return S


class SliderSampler:
    """Turns the sensor samples of one constant-speed cycle into (dx, dy, rotation, midspan) on the scene
    grid (module doc).  Cycle k starts at crank angle 0 (the drive's ramp ends there)."""

    def __init__(self, model: SliderModel, scene: SliderScene, steps_per_cycle: int):
        self.model = model
        self.n = steps_per_cycle
        j = np.arange(steps_per_cycle)
        self.angles = np.mod(model.drive.sign * 2.0 * math.pi * j / steps_per_cycle, 2.0 * math.pi)
        self.order = np.argsort(self.angles)
        kin = slider_kinematics(scene.linkage, self.angles, scene.rpm)
        self.rigid_p = kin.P
        self.rigid_angle = kin.rod_angle
        chord = kin.zB - kin.zA
        normal = 1j * chord / np.abs(chord)
        self.normal = np.column_stack([normal.real, normal.imag])
        self.grid = np.asarray(scene.crank_angles, dtype=float)
        nc = model.ncoord
        self.ref = np.concatenate([model.node_reference[n] for n in model.sensor_nodes])
        self.col = {n: i * nc for i, n in enumerate(model.sensor_nodes)}
        self.p_at = model.locate(scene.linkage.coupler_point)
        self.mid_at = model.locate(MIDSPAN)

    def _element(self, q: np.ndarray, at: tuple[int, float]) -> tuple[np.ndarray, np.ndarray]:
        """(position (k, 2), slope angle (k,)) of a coupler point from absolute sensor coordinates q."""
        m, nc = self.model, self.model.ncoord
        j, xi = at
        n0, n1 = m.coupler_nodes[j], m.coupler_nodes[j + 1]
        qe = np.concatenate([q[:, self.col[n0]:self.col[n0] + nc], q[:, self.col[n1]:self.col[n1] + nc]], axis=1)
        element = m.settings.element
        r = qe @ _shape_matrix(element, xi, m.element_length).T
        if element == "ancf":
            t = qe @ _slope_matrix(element, xi, m.element_length).T
            return r, np.arctan2(t[:, 1], t[:, 0])
        return r, (1.0 - xi) * qe[:, 2] + xi * qe[:, 5]

    def __call__(self, coords: np.ndarray) -> np.ndarray:
        """coords: (n_steps, ncols) sensor values at the cycle's steps (crank angle 0 first)."""
        q = np.asarray(coords, dtype=float) + self.ref
        nodes = self.model.coupler_nodes
        a = q[:, self.col[nodes[0]]:self.col[nodes[0]] + 2]
        b = q[:, self.col[nodes[-1]]:self.col[nodes[-1]] + 2]
        rp, phi = self._element(q, self.p_at)
        rm, _ = self._element(q, self.mid_at)
        d = np.empty((q.shape[0], 4))
        d[:, :2] = rp - self.rigid_p
        d[:, 2] = np.mod(phi - self.rigid_angle + math.pi, 2.0 * math.pi) - math.pi
        d[:, 3] = np.sum((rm - 0.5 * (a + b)) * self.normal, axis=1)
        ang, d = self.angles[self.order], d[self.order]
        spline = CubicSpline(np.append(ang, ang[0] + 2.0 * math.pi), np.vstack([d, d[:1]]), bc_type="periodic",
                             axis=0)
        return spline(self.grid)


def slider_tolerances(settings: DynamicSettings, scene: SliderScene) -> NewtonTolerances:
    """The Newton tolerances of a slider-crank run: the four-bar's rule (exudyn_models.tolerance) with the
    slider-crank's quasi-static peak deflection and largest d'Alembert load."""
    from ked_quasi.slider_static import solve_slider_quasi_static

    sc = scene.linkage
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            qs = solve_slider_quasi_static(scene)
        d_qs = float(np.nanmax(np.hypot(qs.deflection[:, 0], qs.deflection[:, 1])))
        f_qs = float(np.nanmax(np.hypot(qs.loads[..., 0], qs.loads[..., 1])))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        d_qs = f_qs = math.nan
    rel, abs_n = settings.newton_rel_tol, settings.newton_abs_tol
    if math.isfinite(d_qs) and d_qs > 0.0:
        rel = min(rel, REL_FRACTION * d_qs / max(sc.crank, sc.coupler))
    if math.isfinite(f_qs) and f_qs > 0.0:
        abs_n = min(abs_n, ABS_FRACTION * f_qs)
    floor = ROUNDOFF_TOLERANCE * max(s.youngs_modulus * s.area for s in sc.sections)
    return NewtonTolerances(abs_n=max(abs_n, floor), rel=rel, d_qs=d_qs, f_qs=f_qs)


def slider_reference_frequency(scene: SliderScene, settings: DynamicSettings) -> float:
    """Damping reference frequency [Hz]: settings.damping_reference_hz, or if None the first natural
    frequency of the frozen slider-crank (ked_quasi.slider_static.slider_natural_frequencies) averaged over
    the scene's crank-angle grid."""
    if settings.damping_reference_hz is not None:
        return float(settings.damping_reference_hz)
    from ked_quasi.slider_static import slider_natural_frequencies

    return float(np.nanmean(slider_natural_frequencies(scene, n_modes=1)[:, 0]))


def run_slider(scene: SliderScene, settings: DynamicSettings, damping_beta: float, stress: bool = False) -> RunRecord:
    """One run at fixed settings: build, ramp (also for start = "linear", said in the start note), march to steady
    state (RunRecord.deflection: (n, 4), the columns of OUTPUT_COLUMNS); with ``stress``, the link stresses of one
    more cycle (exudyn_models.stress_cycle)."""
    from .stress_cycle import steady_stress

    note = "ramp (the slider-crank model has no linear start)" if settings.start == "linear" else "ramp"
    settings = replace(settings, start="ramp")
    model = build_slider_model(scene, settings, damping_beta)
    tol = slider_tolerances(settings, scene)
    record = march(scene, settings, model, note, sampler=SliderSampler(model, scene, settings.steps_per_cycle),
                   tolerances=tol)
    if stress:
        t0 = time.perf_counter()
        record.stress = steady_stress(model, scene, scene.linkage, settings.steps_per_cycle, settings, tol)
        record.stress_wall_s = time.perf_counter() - t0
    return record
