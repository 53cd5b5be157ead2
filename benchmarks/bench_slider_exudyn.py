"""Exudyn's slider-crank against Simeon's reference model: the midspan deflection's periodic steady state.

For each crank speed Omega (rad/s): the history error max |q1_exudyn - q1_ref| / max |q1_ref| of the rod's
midspan transverse deflection against ked_bench.simeon's damped model marched to its steady state, with
the published model (linear stiffness, the data sheet's default) and with the model's own option
"nonlinear stiffness term" as published (Ex_crank.f IPAR(1) = 1, ked_bench.simeon stiffness
"published_nonlinear": its truncated axial strain energy softens the rod spuriously, docs/exudyn_models.md)
and in its consistent, locking-free form ("geometric": the rod's geometric stiffening by its axial force,
which Exudyn's geometrically nonlinear beams contain), and, to size the axial force's share, both models
without the slider mass (its inertia is the main axial load).  Also the quasi-static answer's
error (80 lumps on the rod) against the reference.  Exudyn runs
ked_bench.exudyn_tier.slider_midspan_history (6 ANCF elements, 1080 steps per cycle, Simeon's damping ratio at
the rod's first bending frequency).

    .venv/bin/python benchmarks/bench_slider_exudyn.py [--omega 25 50 ...] [--json FILE]

Each reference run marches up to 80 cycles at rtol 1e-10 (about a minute per speed and model).
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace

import numpy as np

from exudyn_models import DynamicSettings
from exudyn_models.simulate import simulate_steady_state
from ked_bench.exudyn_tier import simeon_damping, simeon_scene, slider_midspan_history
from ked_bench.simeon import SimeonModel, SimeonParameters, integrate
from ked_quasi.slider_static import solve_slider_quasi_static
from ked_quasi.slidercrank import build_slider_scene, simeon_slider_crank


def reference(omega: float, *, stiffness: str = "linear", consistent_axial_mass: bool = False,
              slider_mass: float | None = None, samples: int = 72, tolerance: float = 1e-8,
              max_cycles: int = 80) -> np.ndarray:
    """Midspan q1 (samples,) [m] of the damped reference at steady state (as ked_bench.simeon.steady_state)."""
    par = SimeonParameters(omega=omega, damped=True, stiffness=stiffness, consistent_axial_mass=consistent_axial_mass)
    if slider_mass is not None:
        par = replace(par, m3=slider_mass)
    model = SimeonModel(par)
    period = 2.0 * math.pi / omega
    y, last = model.rigid_start(), None
    for _ in range(max_cycles):
        sol = integrate(model, y, period, rtol=1e-10, atol=1e-14, t_eval=np.linspace(0.0, period, samples + 1))
        hist, y = sol.y[3, :-1].copy(), sol.y[:, -1].copy()
        y[0] -= 2.0 * math.pi
        if last is not None and np.max(np.abs(hist - last)) < tolerance * np.max(np.abs(hist)):
            return hist
        last = hist
    raise RuntimeError(f"reference at {omega} rad/s did not settle")


def error(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(a - ref)) / np.max(np.abs(ref)))


def row(omega: float) -> dict[str, float]:
    zeta, f_ref = simeon_damping()
    _, mid, res = slider_midspan_history(omega)
    free = replace(simeon_slider_crank(), slider_mass=0.0)
    no_slider = simulate_steady_state(replace(simeon_scene(omega), linkage=free),
                                      DynamicSettings(elements_per_link=6, steps_per_cycle=1080, damping_ratio=zeta,
                                                      damping_reference_hz=f_ref))
    qs = solve_slider_quasi_static(build_slider_scene(simeon_slider_crank(), "distributed",
                                                      omega * 60.0 / (2.0 * math.pi), 5.0, lumps=80)).midspan
    lin, nl = reference(omega), reference(omega, stiffness="published_nonlinear")
    geo = reference(omega, stiffness="geometric")
    lin0 = reference(omega, slider_mass=1e-9)
    return {"omega_rad_s": omega, "speed_ratio": omega / (2.0 * math.pi * f_ref),
            "reference_peak_m": float(np.max(np.abs(lin))), "exudyn_peak_m": float(np.max(np.abs(mid))),
            "exudyn_vs_linear_stiffness": error(mid, lin),
            "exudyn_vs_nonlinear_stiffness": error(mid, nl),
            "exudyn_vs_geometric_stiffness": error(mid, geo), "nonlinear_vs_linear_stiffness": error(nl, lin),
            "exudyn_vs_linear_stiffness_no_slider": error(no_slider.midspan, lin0),
            "quasi_static_vs_linear_stiffness": error(qs, lin), "exudyn_converged": bool(res.converged and
                                                                                         no_slider.converged)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--omega", type=float, nargs="+", default=[25.0 * k for k in range(1, 13)])
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = ap.parse_args()
    rows = []
    print(f"{'Omega':>6} {'r':>6} {'ref peak mm':>11} {'Exu/lin':>8} {'Exu/nonlin':>10} {'Exu/geo':>8} "
          f"{'nonlin/lin':>10} "
          f"{'Exu/lin m3=0':>12} {'qs/lin':>7}")
    for omega in args.omega:
        r = row(omega)
        rows.append(r)
        pct = {k: 100.0 * v for k, v in r.items() if isinstance(v, float)}
        print(f"{omega:6.0f} {r['speed_ratio']:6.3f} {1e3 * r['reference_peak_m']:11.4f} "
              f"{pct['exudyn_vs_linear_stiffness']:7.2f}% {pct['exudyn_vs_nonlinear_stiffness']:9.2f}% "
              f"{pct['exudyn_vs_geometric_stiffness']:7.2f}% "
              f"{pct['nonlinear_vs_linear_stiffness']:9.2f}% {pct['exudyn_vs_linear_stiffness_no_slider']:11.2f}% "
              f"{pct['quasi_static_vs_linear_stiffness']:6.2f}%" + ("" if r["exudyn_converged"] else "  NOT STEADY"),
              flush=True)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
