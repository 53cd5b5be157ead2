"""Store or compare the linear model's answers on the 40 scenes of the default campaign.

Used to check that a faster implementation gives the same answers as an older one: run ``store`` with
the old code (e.g. from another checkout: ``cd OLD && python /path/to/compare_linear.py store FILE``),
then ``compare`` with the new code.  Per scene (source and cognate mechanism x tip, joints, extender,
distributed x 30, 75, 150, 225, 300 rpm, damping 2 %, prestressed and classical) it stores the history,
max |Floquet multiplier|, H, the error estimate and the wall time; ``compare`` prints the largest
difference of the histories as a fraction of the peak (per output group) and of the multipliers, and the
wall-time ratio (old / new, same machine, not the same run).

Usage: python benchmarks/compare_linear.py store|compare FILE.npz [--prestress-only]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from compare_linear_grid import peak_error  # the grid comparison's error (sibling script)

from compare.config import load_config
from ked_linear import LinearSettings, solve_linear


def scenes():
    for spec in load_config().scenes():
        yield f"{spec.mechanism}-{spec.mass_model.name}-{spec.speed.value:g}rpm", spec


def run(prestress_only: bool):
    out = {}
    for label, spec in scenes():
        scene = spec.scene(spec.speed.value)
        for prestress in ((True,) if prestress_only else (True, False)):
            settings = LinearSettings(damping_ratio=spec.damping_ratio, prestress=prestress)
            t0 = time.perf_counter()
            res = solve_linear(scene, settings)
            wall = time.perf_counter() - t0
            key = f"{label}-{'pre' if prestress else 'classic'}"
            out[key + "/deflection"] = res.deflection
            out[key + "/scalars"] = np.array([res.floquet_max_abs, res.harmonics, res.error_estimate,
                                              float(res.stable), wall, res.floquet_steps])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("action", choices=("store", "compare"))
    ap.add_argument("file")
    ap.add_argument("--prestress-only", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    new = run(args.prestress_only)
    if args.action == "store":
        np.savez(args.file, **new)
        return
    old = np.load(args.file)
    worst, t_old, t_new = 0.0, 0.0, 0.0
    print(f"{'scene':<40}{'hist err':>10}{'d|mu|':>10}{'H old/new':>10}{'t old':>8}{'t new':>8}")
    for key in sorted(k[:-len("/deflection")] for k in new if k.endswith("/deflection")):
        e = peak_error(new[key + "/deflection"], old[key + "/deflection"])
        so, sn = old[key + "/scalars"], new[key + "/scalars"]
        worst = max(worst, e)
        t_old, t_new = t_old + so[4], t_new + sn[4]
        print(f"{key:<40}{e:10.2e}{abs(sn[0] - so[0]):10.2e}{int(so[1]):>5}/{int(sn[1]):<4}{so[4]:8.3f}{sn[4]:8.3f}")
    print(f"worst history difference {worst:.3e} of the peak; total wall old {t_old:.2f} s, new {t_new:.2f} s")


if __name__ == "__main__":
    main()
