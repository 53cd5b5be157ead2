"""Cycles and wall time of the Exudyn start "ramp" against "linear" (docs/exudyn_models.md, "Start").

Thesis source four-bar, 6 ANCF elements per link, 1080 steps per cycle; per mass model and crank speed: cycles
and wall time of each start, and the largest difference of the two answers (fraction of the peak).
Run: ``.venv/bin/python benchmarks/bench_start.py tip,joints,extender,distributed 30,150,300`` (about 3 min).
"""
import sys
import time
import warnings

import numpy as np

from exudyn_models import DynamicSettings, simulate_steady_state
from ked_quasi import MassModel, Scene, mechanism
from ked_quasi.linkage import THESIS_TIP_MASS_KG, thesis_fourbar


def main() -> None:
    warnings.simplefilter("ignore")
    mms = sys.argv[1].split(",") if len(sys.argv) > 1 else ["tip", "joints", "extender", "distributed"]
    rpms = [float(x) for x in sys.argv[2].split(",")] if len(sys.argv) > 2 else [30.0, 150.0, 300.0]
    for mm in mms:
        for rpm in rpms:
            model = MassModel(mm, payload=THESIS_TIP_MASS_KG if mm == "tip" else 0.0)
            sc = Scene(mechanism(thesis_fourbar(), "source"), model, rpm)
            row: list[object] = [mm, rpm]
            res = {}
            for start in ("ramp", "linear"):
                t = time.perf_counter()
                r = simulate_steady_state(sc, DynamicSettings(elements_per_link=6, steps_per_cycle=1080, start=start))
                res[start] = r
                row += [start, r.cycles, round(time.perf_counter() - t, 2)]
            a, b = res["ramp"].deflection[:, :2], res["linear"].deflection[:, :2]
            row.append(round(float(np.max(np.linalg.norm(a - b, axis=1)) / np.max(np.linalg.norm(a, axis=1))), 5))
            print(*row, flush=True)


if __name__ == "__main__":
    main()
