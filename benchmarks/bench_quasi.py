"""Benchmark: quasi-static solve of 3600 crank angles x (source + cognate) x all four mass models.

Run on purpose:  .venv/bin/python benchmarks/bench_quasi.py [--repeats 7]
Reports the median wall time of the vectorized solver and of a plain per-angle Python loop of the
same computation (the solver called one angle at a time), and their ratio.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np

from ked_quasi.massmodel import MASS_MODELS
from ked_quasi.presets import make_scene
from ked_quasi.solver import solve_quasi_static


def scenes(step_deg: float):
    return [make_scene("thesis", mech, mm, 300.0, step_deg) for mech in ("source", "cognate") for mm in MASS_MODELS]


def run_vectorized(sc) -> float:
    t = time.perf_counter()
    for s in sc:
        solve_quasi_static(s)
    return time.perf_counter() - t


def run_loop(sc, n_angles: int) -> float:
    t = time.perf_counter()
    for s in sc:
        for th in s.crank_angles[:n_angles]:
            solve_quasi_static(s, np.array([th]))
    return (time.perf_counter() - t) * (s.crank_angles.size / n_angles)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--loop-angles", type=int, default=360, help="angles timed in the loop (extrapolated)")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    sc = scenes(0.1)  # 3600 angles
    run_vectorized(sc)  # warm-up
    vec = [run_vectorized(sc) for _ in range(a.repeats)]
    per_model = {}
    for s in sc:
        ts = []
        for _ in range(a.repeats):
            t = time.perf_counter()
            solve_quasi_static(s)
            ts.append(time.perf_counter() - t)
        per_model.setdefault(s.mass_model.name, []).append(statistics.median(ts))
    loop = [run_loop(sc, a.loop_angles) for _ in range(max(1, a.repeats // 3))]
    mv, ml = statistics.median(vec), statistics.median(loop)
    print(f"3600 angles x 2 mechanisms x 4 mass models, median of {a.repeats}:")
    print(f"  vectorized: {1e3 * mv:8.1f} ms")
    for k, v in per_model.items():
        print(f"    {k:<11} {1e3 * sum(v):7.1f} ms (source + cognate)")
    print(f"  per-angle Python loop (extrapolated from {a.loop_angles} angles): {1e3 * ml:8.1f} ms")
    print(f"  speed-up: {ml / mv:6.1f}x")


if __name__ == "__main__":
    main()
