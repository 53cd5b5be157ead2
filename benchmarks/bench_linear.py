"""Benchmark of ked_linear.solve_linear beside exudyn_models.simulate_steady_state on the same scenes.

Per mass model and speed (thesis source four-bar, 10 deg grid; 100 and 300 rpm by default) it times
  linear  : solve_linear(scene) with default LinearSettings (prestress on, automatic resolution)
  exudyn  : simulate_steady_state(scene) with default DynamicSettings
and reports the median wall seconds over --runs runs, the speed ratio r, the resolution the linear model
chose (harmonics H, Floquet steps, max |mu|), and the error of each history against a fine Exudyn
reference (8 elements per link, 5760 steps per cycle, plain cycles steady to 1e-6): max |d - d_ref| over
(dx, dy) relative to the reference peak.  The quasi-static error is printed beside them.  Case I (tip)
at 300 rpm uses --tip-damping (default 0.1) for every model: the Exudyn runs diverge there at 2 %
(see bench_exudyn.py).  Then the cost of solve_linear alone versus lumps per link and grid step, the
64-harmonic solve against the default one, the Floquet part alone against the whole solve, the cost
of the coefficients K, C, f per crank angle (direct frame condensation against the interpolated
coefficients the solver uses), and `ked check` end to end in a fresh process.

With ``--floor`` it only times the Radau stage solves of the distributed model's co-rotating passes on their
own (the arithmetic floor of that solve, docs/linear_model.md).

With ``--against DIR`` it only times solve_linear of this checkout against the one in DIR (an older
checkout, e.g. ``git worktree add /tmp/old main``), both in worker processes asked in turn, scene by
scene (same run, same load): median CPU seconds of each, their ratio, default and 64-harmonic settings.

Usage: .venv/bin/python benchmarks/bench_linear.py [--runs 3] [--mass-models tip,joints,...] [--rpm 100,300]
       .venv/bin/python benchmarks/bench_linear.py --against DIR [--runs 5]
       .venv/bin/python benchmarks/bench_linear.py --floor [--rpm 100,300]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from dataclasses import replace

import numpy as np

from exudyn_models import DynamicSettings, simulate_steady_state
from ked_linear import LinearSettings, solve_linear
from ked_quasi import solve_quasi_static
from ked_quasi.massmodel import MASS_MODELS
from ked_quasi.presets import make_scene


def reference_settings(base: DynamicSettings) -> DynamicSettings:
    return replace(base, elements_per_link=8, steps_per_cycle=5760, steady_tol=1e-6, max_cycles=200,
                   extrapolate=False)


def error(d: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(d[:, :2] - ref[:, :2], axis=1).max() / np.linalg.norm(ref[:, :2], axis=1).max())


def forget() -> None:
    """Empty solve_linear's recall of recent systems and multipliers (if this checkout has one): a
    repeated solve of the same scene would otherwise time the recalled part as free."""
    import sys

    solver = sys.modules.get("ked_linear.solver")
    forget_recalled = getattr(solver, "forget_recalled", None)  # older checkouts: clear the map itself
    forget_recalled() if forget_recalled is not None else getattr(solver, "_RECALL", {}).clear()


def timed(fn, runs: int, *fn_args):
    walls, res = [], None
    for _ in range(runs):
        forget()
        t0 = time.perf_counter()
        res = fn(*fn_args)
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls), res


def side_by_side(args) -> None:
    print(f"linear KED vs Exudyn: thesis source, median of {args.runs} runs, errors vs fine Exudyn reference")
    print(f"{'mass model':<12}{'rpm':>5}{'r':>7}{'zeta':>6}{'lin s':>8}{'exu s':>8}{'ratio':>8}{'H':>4}{'steps':>6}"
          f"{'max|mu|':>9}{'lin %':>8}{'exu %':>8}{'qs %':>8}")
    for mm in args.mass_models.split(","):
        for rpm in (float(x) for x in args.rpm.split(",")):
            scene = make_scene(mass_model=mm, rpm=rpm)
            zeta = args.tip_damping if (mm == "tip" and rpm >= 300) else 0.02
            dyn = DynamicSettings(damping_ratio=zeta)
            lin_settings = LinearSettings(damping_ratio=zeta)
            ref = simulate_steady_state(scene, reference_settings(dyn))
            t_lin, lin = timed(solve_linear, args.runs, scene, lin_settings)
            t_exu, exu = timed(simulate_steady_state, args.runs, scene, dyn)
            qs = solve_quasi_static(scene).deflection
            errs = [100 * error(d, ref.deflection) for d in (lin.deflection, exu.deflection, qs)]
            print(f"{mm:<12}{rpm:5.0f}{lin.speed_ratio:7.3f}{zeta:6.2f}{t_lin:8.3f}{t_exu:8.3f}{t_exu / t_lin:8.0f}"
                  f"{lin.harmonics:4d}{lin.floquet_steps:6d}{lin.floquet_max_abs:9.3f}"
                  f"{errs[0]:8.2f}{errs[1]:8.2f}{errs[2]:8.2f}")


def scaling(args) -> None:
    print("\nsolve_linear cost (distributed, 100 rpm): median wall s by lumps per link and grid step")
    print(f"{'lumps':>6}{'coords':>7}{'10 deg':>9}{'2 deg':>9}{'H':>4}")
    for n in (1, 2, 3, 5):
        row = []
        for step in (10.0, 2.0):
            scene = make_scene(mass_model="distributed", rpm=100.0, lumps=n, step_deg=step)
            wall, res = timed(solve_linear, args.runs, scene)
            row.append(wall)
        print(f"{n:6d}{8 * n:7d}{row[0]:9.3f}{row[1]:9.3f}{res.harmonics:4d}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--mass-models", default=",".join(MASS_MODELS))
    ap.add_argument("--rpm", default="100,300")
    ap.add_argument("--tip-damping", type=float, default=0.1)
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--against", default=None, metavar="DIR", help="time against the checkout in DIR only")
    ap.add_argument("--floor", action="store_true", help="only the Radau stage solves' floor (distributed model)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    if args.against:
        against(args)
        return
    if args.floor:
        radau_floor(args)
        return
    side_by_side(args)
    if not args.no_scaling:
        scaling(args)
    harmonics_64(args)
    floquet_cost(args)
    coefficient_cost(args)
    check_timing(args)


def radau_floor(args) -> None:
    """The arithmetic floor of the co-rotating steady state (docs/linear_model.md, Cost): the Radau passes a
    distributed-model solve marches (recorded from the solve itself), each timed as numpy's batched solve of
    its stage systems alone, (steps, 3r, 3r) with 2r + 1 right-hand sides, on random well-conditioned data."""
    from ked_linear import reducedsystem
    from ked_linear.solver import keep_freed_memory

    keep_freed_memory()
    passes: list[tuple[int, int]] = []
    propagate = reducedsystem._Reduced.propagate

    def recording(self, steps, states=False):
        known = self._runs.get(steps)
        if known is None or (states and known.states is None):  # marched (again), as propagate decides
            passes.append((self.r, steps))
        return propagate(self, steps, states)

    print(f"\nRadau stage solves alone (distributed model, numpy batched solve, median of {max(args.runs, 15)})")
    print(f"{'rpm':>5}{'r':>4}{'steps':>7}{'Mflop':>8}{'ms':>8}{'Gflop/s':>9}")
    rng = np.random.default_rng(0)
    for rpm in (float(x) for x in args.rpm.split(",")):
        passes.clear()
        reducedsystem._Reduced.propagate = recording
        try:
            forget()
            solve_linear(make_scene(mass_model="distributed", rpm=rpm))
        finally:
            reducedsystem._Reduced.propagate = propagate
        total = 0.0
        for r, steps in passes:
            n = 3 * r
            L = rng.normal(size=(steps, n, n)) + n * np.eye(n)
            B = rng.normal(size=(steps, n, 2 * r + 1))
            ms = 1e3 * statistics.median(_cpu(np.linalg.solve, L, B) for _ in range(max(args.runs, 15)))
            flop = steps * (2 * n**3 / 3 + 2 * n**2 * (2 * r + 1))
            total += ms
            print(f"{rpm:5.0f}{r:4d}{steps:7d}{flop / 1e6:8.1f}{ms:8.2f}{flop / ms / 1e6:9.2f}")
        print(f"{rpm:5.0f}  all passes: {total:.1f} ms")


def _cpu(fn, *fn_args) -> float:
    t0 = time.process_time()
    fn(*fn_args)
    return time.process_time() - t0


def harmonics_64(args) -> None:
    print("\n64-harmonic solve (max_harmonics=64) against the default (32): median wall s")
    print(f"{'mass model':<12}{'rpm':>5}{'default':>9}{'64':>9}{'ratio':>7}{'H':>4}")
    for mm in args.mass_models.split(","):
        for rpm in (float(x) for x in args.rpm.split(",")):
            scene = make_scene(mass_model=mm, rpm=rpm)
            zeta = args.tip_damping if (mm == "tip" and rpm >= 300) else 0.02
            t_def, _ = timed(solve_linear, args.runs, scene, LinearSettings(damping_ratio=zeta))
            t_64, res = timed(solve_linear, args.runs, scene, LinearSettings(damping_ratio=zeta, max_harmonics=64))
            print(f"{mm:<12}{rpm:5.0f}{t_def:9.3f}{t_64:9.3f}{t_64 / t_def:7.1f}{res.harmonics:4d}")


def floquet_cost(args) -> None:
    """The Floquet part of solve_linear alone (``ked_linear.floquet`` at the default tolerance, automatic
    step levels) against the whole solve: median wall s, the steps per cycle it chose, max |mu| and
    its error estimate."""
    from ked_linear import floquet, linkage_system

    print("\nFloquet multipliers alone against the whole linear solve: median wall s")
    print(f"{'mass model':<12}{'rpm':>5}{'floquet':>9}{'solve':>9}{'share':>7}{'steps':>7}{'max|mu|':>10}{'+-':>9}")
    for mm in args.mass_models.split(","):
        for rpm in (float(x) for x in args.rpm.split(",")):
            scene = make_scene(mass_model=mm, rpm=rpm)
            settings = LinearSettings(damping_ratio=args.tip_damping if (mm == "tip" and rpm >= 300) else 0.02)
            system = linkage_system(scene, settings).system
            system.coefficients(np.zeros(1))  # the sampling of the coefficients belongs to the solve, not here
            t_fl, fl = timed(floquet, args.runs, system, settings.floquet_tolerance)
            t_all, _ = timed(solve_linear, args.runs, scene, settings)
            print(f"{mm:<12}{rpm:5.0f}{t_fl:9.3f}{t_all:9.3f}{t_fl / t_all:7.0%}{fl.steps:7d}{fl.max_abs:10.5f}"
                  f"{fl.error_estimate:9.1e}")


def coefficient_cost(args) -> None:
    """Microseconds per crank angle of K, C, f and the output map at 1024 uniformly spaced angles (the
    Floquet propagator's kind of request), direct and interpolated, at the first --rpm."""
    from ked_linear import linkage_system

    rpm = float(args.rpm.split(",")[0])
    print(f"\ncoefficients per crank angle at {rpm:g} rpm (1024 angles, median us): direct, interpolated, form")
    theta = 0.1 + np.arange(1024) * (2.0 * np.pi / 1024)
    for mm in args.mass_models.split(","):
        co = linkage_system(make_scene(mass_model=mm, rpm=rpm), LinearSettings()).system.coefficients
        t_direct, _ = timed(co.direct, args.runs, theta)
        t_interp, _ = timed(co._evaluate, args.runs, theta)
        print(f"  {mm:12s} {1e6 * t_direct / theta.size:8.1f} {1e6 * t_interp / theta.size:8.1f}  {co.form} "
              f"({co.points} samples)")


def check_timing(args: argparse.Namespace) -> None:
    """``ked check`` end to end in a fresh process (start-up, atlas limits, quasi-static + linear
    solves), one speed per mass model, median of --runs runs; the target is under one second.  Then the
    distributed model over 30-600 rpm in 20 speeds with its critical-speed sweep, in one process and on
    the default worker processes, in turn."""
    import subprocess
    import sys

    print("\nked check --rpm 100 (fresh process, median wall s)")
    for mm in args.mass_models.split(","):
        walls = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "ked_cli", "check", "--mass-model", mm, "--rpm", "100"],
                           check=True, capture_output=True)
            walls.append(time.perf_counter() - t0)
        print(f"  {mm:12s} {statistics.median(walls):6.2f}")
    print("\nked check --mass-model distributed --rpm-range 30:600:20 (fresh process, median wall s): "
          "in one process (--workers 1) and by default (worker processes)")
    for extra in (["--workers", "1"], []):
        walls = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "ked_cli", "check", "--mass-model", "distributed", "--rpm-range",
                            "30:600:20", *extra], check=True, capture_output=True)
            walls.append(time.perf_counter() - t0)
        print(f"  {' '.join(extra) or 'default':12s} {statistics.median(walls):6.2f}")



WORKER = """
import sys, time, warnings
warnings.simplefilter("ignore")
from ked_linear import LinearSettings, solve_linear
from ked_quasi.presets import make_scene
for line in sys.stdin:
    mm, rpm, zeta, max_h = line.split()
    scene = make_scene(mass_model=mm, rpm=float(rpm))
    settings = LinearSettings(damping_ratio=float(zeta), max_harmonics=int(max_h))
    forget = getattr(sys.modules.get("ked_linear.solver"), "forget_recalled", None)
    if forget is not None:  # time every solve from scratch
        forget()
    else:  # a checkout older than forget_recalled
        getattr(sys.modules.get("ked_linear.solver"), "_RECALL", {}).clear()
    t0, c0 = time.perf_counter(), time.process_time()
    solve_linear(scene, settings)
    print(time.perf_counter() - t0, time.process_time() - c0, flush=True)
"""


def against(args: argparse.Namespace) -> None:
    """solve_linear here against the checkout ``args.against``: median CPU s per scene, in turn."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    here = str(Path(__file__).resolve().parents[1])
    workers = {}
    for name, root in (("new", here), ("old", str(Path(args.against).resolve()))):
        env = dict(os.environ, PYTHONPATH=root)
        workers[name] = subprocess.Popen([sys.executable, "-c", WORKER], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, text=True, env=env, cwd=root)
    print(f"solve_linear wall and CPU ms (all threads), median of {args.runs}, each asked in turn: this checkout "
          f"(new) vs {args.against} (old)")
    print(f"{'mass model':<12}{'rpm':>5}{'H max':>6}{'new wall':>9}{'old wall':>9}{'ratio':>7}{'new cpu':>9}"
          f"{'old cpu':>9}{'ratio':>7}")
    try:
        for max_h in (32, 64):
            for mm in args.mass_models.split(","):
                for rpm in (float(x) for x in args.rpm.split(",")):
                    zeta = args.tip_damping if (mm == "tip" and rpm >= 300) else 0.02
                    walls: dict[str, list[list[float]]] = {"new": [], "old": []}
                    for _ in range(args.runs + 1):  # the first run of each warms up (imports, caches)
                        for name, w in workers.items():
                            w.stdin.write(f"{mm} {rpm} {zeta} {max_h}\n")
                            w.stdin.flush()
                            walls[name].append([float(x) for x in w.stdout.readline().split()])
                    row = f"{mm:<12}{rpm:5.0f}{max_h:6d}"
                    for i in (0, 1):
                        new, old = (1e3 * statistics.median(t[i] for t in walls[k][1:]) for k in ("new", "old"))
                        row += f"{new:9.1f}{old:9.1f}{old / new:7.2f}"
                    print(row, flush=True)
    finally:
        for w in workers.values():
            w.stdin.close()
            w.wait()


if __name__ == "__main__":
    main()
