"""Benchmark of exudyn_models.simulate_steady_state: default settings vs a straightforward recipe.

For one steady-state scene per mass model (thesis source four-bar, 300 rpm, 10 deg grid) it times
  default : DynamicSettings() (half-cycle smooth ramp, cycle-to-cycle steady-state detection with
            extrapolation of the limit cycle)
  recipe  : ramp over 5 cycles, then a fixed 10 cycles at 1000 steps per cycle (last cycle kept)
and reports median wall seconds over --runs runs, steps, seconds per simulated crank cycle, and the
error of the returned cycle against a fine reference (2304 steps per cycle, 4 elements per link,
plain cycles steady to 1e-6, no extrapolation), as max |d - d_ref| over (dx, dy) relative to the
reference peak, and the same for the rotation. Case I (tip) diverges at 300 rpm for damping ratios
<= 0.05 (the massless coupler buckles near resonance), so its row uses --tip-damping (default 0.1)
for all three runs.

Usage: .venv/bin/python benchmarks/bench_exudyn.py [--runs 3] [--mass-models tip,joints,...]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from dataclasses import replace

import numpy as np

from exudyn_models import DynamicSettings, simulate_steady_state
from ked_quasi.massmodel import MASS_MODELS
from ked_quasi.presets import make_scene


def recipe_settings(base: DynamicSettings) -> DynamicSettings:
    return replace(base, ramp_cycles=5.0, steps_per_cycle=1000, min_cycles=10, max_cycles=10, steady_tol=1e-300,
                   extrapolate=False)


def reference_settings(base: DynamicSettings) -> DynamicSettings:
    return replace(base, steps_per_cycle=2304, elements_per_link=4, steady_tol=1e-6, max_cycles=200,
                   extrapolate=False)


def errors(d: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    xy = float(np.abs(d[:, :2] - ref[:, :2]).max() / np.abs(ref[:, :2]).max())
    rot = float(np.abs(d[:, 2] - ref[:, 2]).max() / np.abs(ref[:, 2]).max())
    return xy, rot


def timed(scene, settings: DynamicSettings, runs: int):
    walls, res = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        res = simulate_steady_state(scene, settings)
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls), res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--mass-models", default=",".join(MASS_MODELS))
    ap.add_argument("--tip-damping", type=float, default=0.1)
    ap.add_argument("--rpm", type=float, default=300.0)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    print(f"exudyn_models benchmark: thesis source, {args.rpm:g} rpm, median of {args.runs} runs")
    print(f"{'mass model':<12}{'method':<9}{'wall s':>8}{'steps':>7}{'cycles':>7}{'s/cycle':>9}"
          f"{'err xy %':>9}{'err rot %':>10}{'speed-up':>9}")
    for mm in args.mass_models.split(","):
        scene = make_scene(mass_model=mm, rpm=args.rpm)
        base = DynamicSettings(damping_ratio=args.tip_damping) if mm == "tip" else DynamicSettings()
        ref = simulate_steady_state(scene, reference_settings(base))
        rows = {}
        for name, settings in (("default", base), ("recipe", recipe_settings(base))):
            wall, res = timed(scene, settings, args.runs)
            total_cycles = res.cycles + settings.ramp_cycles
            rows[name] = (wall, res, total_cycles)
        for name, (wall, res, total_cycles) in rows.items():
            exy, erot = errors(res.deflection, ref.deflection)
            speed = rows["recipe"][0] / wall
            print(f"{mm:<12}{name:<9}{wall:8.3f}{res.steps:7d}{res.cycles:7d}{wall / total_cycles:9.4f}"
                  f"{100 * exy:9.3f}{100 * erot:10.3f}{speed:9.2f}")
        print(f"{'':<12}{'ref':<9}{ref.wall_s:8.3f}{ref.steps:7d}{ref.cycles:7d}   ({ref.message})")


if __name__ == "__main__":
    main()
