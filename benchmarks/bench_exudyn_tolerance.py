"""Benchmark of the deflection-scaled Newton tolerances (exudyn_models.tolerance) on the default campaign.

For every scene of the embedded default campaign (`ked run` without CONFIG) it runs the Exudyn model
twice in the same process, with the fixed tolerances of the settings (the old interpretation: the
scaling fractions set to infinity) and with the scaled ones, and, where the tolerances differ, a fine run
(8 elements per link, 5760 steps per cycle, scaled tolerances). One JSON line per scene: the tolerances
used, wall seconds, cycles and Newton iterations of both, the difference of the two histories and each
one's error against the fine run (max |d - d_fine| over the fine peak, dx/dy together and rotation, the
larger). --fine-all also runs the fine run where nothing changed.

Usage: .venv/bin/python benchmarks/bench_exudyn_tolerance.py [--rpm 30 75] [--fine-all]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace

import numpy as np

import exudyn_models.tolerance as tolerance
from compare import solvers
from compare.config import load_config
from compare.execute import frame, settings_of
from exudyn_models import simulate_steady_state

SCALED = (tolerance.REL_FRACTION, tolerance.ABS_FRACTION)


def _run(scene, settings, fixed: bool):
    tolerance.REL_FRACTION, tolerance.ABS_FRACTION = (math.inf, math.inf) if fixed else SCALED
    t0 = time.perf_counter()
    res = simulate_steady_state(scene, settings)
    return res, time.perf_counter() - t0


def _error(a: np.ndarray, b: np.ndarray) -> float:
    xy = np.abs(a[:, :2] - b[:, :2]).max() / np.abs(b[:, :2]).max()
    rot = np.abs(a[:, 2] - b[:, 2]).max() / np.abs(b[:, 2]).max()
    return float(max(xy, rot))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rpm", type=float, nargs="*", default=None)
    ap.add_argument("--fine-all", action="store_true")
    args = ap.parse_args()
    for spec in load_config(None).scenes():
        if args.rpm and not any(math.isclose(spec.speed.value, r) for r in args.rpm):
            continue
        scene = frame(spec).scene
        st = settings_of(solvers.get("dynamic"), spec)
        tol = tolerance.newton_tolerances(st, scene)
        changed = tol.rel < st.newton_rel_tol or tol.abs_n < st.newton_abs_tol
        old, w_old = _run(scene, st, True)
        new, w_new = _run(scene, st, False)
        rec = {"label": spec.label, "rel": tol.rel, "abs_n": tol.abs_n, "changed": changed,
               "wall_old_s": round(w_old, 2), "wall_new_s": round(w_new, 2), "cycles": [old.cycles, new.cycles],
               "newton": [old.newton_iterations, new.newton_iterations], "converged": [old.converged, new.converged],
               "new_vs_old": _error(new.deflection, old.deflection)}
        if changed or args.fine_all:
            fine, w_fine = _run(scene, replace(st, elements_per_link=8, steps_per_cycle=5760), False)
            rec.update(err_old=_error(old.deflection, fine.deflection), err_new=_error(new.deflection, fine.deflection),
                       wall_fine_s=round(w_fine, 1))
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
