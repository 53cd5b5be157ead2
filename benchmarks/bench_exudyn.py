"""Benchmark of exudyn_models.simulate_steady_state: today's algorithm vs the new start and periodic solve.

For one steady-state scene per mass model (thesis source four-bar, 300 rpm, 10 deg grid, 2 % damping,
the default discretization ANCF 4 el/link, 720 steps/cycle for every method) it runs
  legacy      : LEGACY_DEFAULTS (ramp, marching with extrapolation) but refine=True, so that Case I,
                which fails at the requested settings, is still compared (it then runs on a ladder rung)
  qs-start    : start="quasi_static", marching
  anderson    : start="ramp", periodic="anderson" (the default)
  qs+anderson : start="quasi_static", periodic="anderson"
  legacy-tight: the legacy march to steady_tol 1e-5 without extrapolation (the transient error the
                periodic solve reaches; how many cycles marching needs for it)
and reports the median wall seconds over --runs, steps, constant-speed cycles, the settings that produced
the result, and the error against a fine reference (ANCF 8 el/link, 2880 steps/cycle, periodic solve
to steady_tol 1e-6): max |d - d_ref| of (dx, dy) over the reference peak, and the same for the rotation.

With --starts it compares the two starts of the constant-speed phase instead, on the default campaign's scenes
and [dynamic] settings (lumps, grid, damping; ANCF 6 el/link, 1080 steps/cycle) per mass model and crank speed
(--rpms, default 30-300): "ramp" (from rest through the start-up ramp) and "linear" (on the linear model's
periodic orbit, the ramp where the linear answer is outside its range): median wall seconds, constant-speed
cycles, the history difference of the two starts' answers and each one's error against the fine run (ANCF 8
el/link, 2880 steps/cycle, to steady_tol 1e-6), all (dx, dy) over the fine run's peak.

Usage: .venv/bin/python benchmarks/bench_exudyn.py [--runs 3] [--mass-models tip,joints,...]
       .venv/bin/python benchmarks/bench_exudyn.py --starts [--runs 3] [--mechanism source|cognate] [--rpms 30,300]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from dataclasses import replace

import numpy as np

from exudyn_models import LEGACY_DEFAULTS, DynamicSettings, simulate_steady_state
from ked_quasi.massmodel import MASS_MODELS
from ked_quasi.presets import make_scene

LEGACY = replace(DynamicSettings(**LEGACY_DEFAULTS), refine=True)
METHODS = {
    "legacy": LEGACY,
    "qs-start": replace(LEGACY, start="quasi_static"),
    "anderson": DynamicSettings(),
    "qs+anderson": DynamicSettings(start="quasi_static"),
    "legacy-tight": replace(LEGACY, steady_tol=1e-5, extrapolate=False, max_cycles=200),
}


def reference_settings() -> DynamicSettings:
    return DynamicSettings(steps_per_cycle=2880, elements_per_link=8, steady_tol=1e-6, max_cycles=200)


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


def campaign_scenes(mechanism: str, mass_model: str, rpms: list[float]) -> list:
    """The default campaign's scenes (compare/default_campaign.toml: its lumps, grid and damping) of one mechanism
    and mass model at the crank speeds ``rpms``, with its [dynamic] settings except the start."""
    from compare.config import load_config
    from compare.solvers.dynamic import settings_for

    specs = {s.speed.value: s for s in load_config(None).scenes()
             if s.mechanism == mechanism and s.mass_model.name == mass_model}
    return [(specs[rpm].scene(rpm), settings_for(specs[rpm])) for rpm in rpms]


def starts(args: argparse.Namespace) -> None:
    """The --starts comparison (module doc)."""
    print(f"starts: the default campaign's thesis {args.mechanism} scenes and [dynamic] settings, median of "
          f"{args.runs} runs; errors against the fine run, (dx, dy) over its peak")
    print(f"{'mass model':<12}{'rpm':>5}  {'ramp s':>7}{'cyc':>4}{'err %':>8}  {'linear s':>8}{'cyc':>4}{'err %':>8}"
          f"{'diff %':>8}  linear start")
    for mm in args.mass_models.split(","):
        rpms = [float(r) for r in args.rpms.split(",")]
        for rpm, (scene, settings) in zip(rpms, campaign_scenes(args.mechanism, mm, rpms)):
            ref = simulate_steady_state(scene, reference_settings()).deflection
            row, answers = f"{mm:<12}{rpm:5.0f}", []
            for start in ("ramp", "linear"):
                wall, res = timed(scene, replace(settings, start=start), args.runs)
                answers.append(res)
                row += f"  {wall:7.2f}{res.cycles:4d}{100 * errors(res.deflection, ref)[0]:8.3f}"
            diff = errors(answers[1].deflection, answers[0].deflection)[0]
            print(f"{row}{100 * diff:8.3f}  {answers[1].start[:70]}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--mass-models", default=",".join(MASS_MODELS))
    ap.add_argument("--rpm", type=float, default=300.0)
    ap.add_argument("--starts", action="store_true", help="compare the ramp and linear starts (module doc)")
    ap.add_argument("--rpms", default="30,75,150,225,300", help="crank speeds of --starts [rpm] (default campaign's)")
    ap.add_argument("--mechanism", default="source", choices=("source", "cognate"), help="mechanism of --starts")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    if args.starts:
        starts(args)
        return
    print(f"exudyn_models benchmark: thesis source, {args.rpm:g} rpm, 2 % damping, median of {args.runs} runs")
    print(f"{'mass model':<12}{'method':<13}{'wall s':>8}{'steps':>7}{'cycles':>7}{'err xy %':>10}{'err rot %':>10}"
          "  solved with")
    for mm in args.mass_models.split(","):
        scene = make_scene(mass_model=mm, rpm=args.rpm)
        ref = simulate_steady_state(scene, reference_settings())
        for name, settings in METHODS.items():
            wall, res = timed(scene, settings, args.runs)
            exy, erot = errors(res.deflection, ref.deflection)
            s = res.solved_settings
            how = f"{s.elements_per_link} el, {s.steps_per_cycle} st" + (f" ({res.attempts[-1].rung})"
                                                                        if s != res.settings else "")
            print(f"{mm:<12}{name:<13}{wall:8.2f}{res.steps:7d}{res.cycles:7d}{100 * exy:10.3f}{100 * erot:10.3f}"
                  f"  {how}{'' if res.converged else ' NOT STEADY'}")
        print(f"{'':<12}{'ref':<13}{ref.wall_s:8.2f}{ref.steps:7d}{ref.cycles:7d}   ({ref.message[:60]})", flush=True)


if __name__ == "__main__":
    main()
