"""Store or compare solve_linear on a grid of scenes: two implementations must give the same answers.

Grid: the thesis linkage, source and cognate mechanism x tip, joints, extender, distributed (5 lumps per
link) x 30, 100, 300, 600 rpm and, per mass model, the speed where the speed ratio r = Omega / omega1_min
is 0.5 and 0.9 (near the first resonance), damping 2 % (10 % for tip at 300 rpm and above, where the
thesis Case I needs it), prestressed.  Per scene it stores the history, status, max |Floquet multiplier|,
its error estimate, H and the wall time.  ``compare`` prints, per scene, max |new - old| of the history
as a fraction of the old peak ((dx, dy) as a vector, and the rotation), the change of max |mu| against
its error estimate, and the worst of them.

Usage (old code from a checkout OLD, new code from this one):
    PYTHONPATH=OLD python benchmarks/compare_linear_grid.py store old.npz
    python benchmarks/compare_linear_grid.py compare old.npz
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from ked_linear import LinearSettings, solve_linear
from ked_quasi.massmodel import MASS_MODELS
from ked_quasi.presets import make_scene
from ked_quasi.solver import natural_frequencies

SPEEDS_RPM = (30.0, 100.0, 300.0, 600.0)
SPEED_RATIOS = (0.5, 0.9)


def grid():
    for mech in ("source", "cognate"):
        for mm in MASS_MODELS:
            probe = make_scene(mechanism_name=mech, mass_model=mm, rpm=100.0)
            f1 = float(np.min(natural_frequencies(probe, n_modes=1)[:, 0]))
            rpms = list(SPEEDS_RPM) + [round(r * f1 * 60.0, 1) for r in SPEED_RATIOS]
            for rpm in rpms:
                zeta = 0.1 if (mm == "tip" and rpm >= 300) else 0.02
                yield f"{mech}-{mm}-{rpm:g}rpm", make_scene(mechanism_name=mech, mass_model=mm, rpm=rpm), zeta


def run() -> dict[str, np.ndarray]:
    out = {}
    for key, scene, zeta in grid():
        t0 = time.perf_counter()
        res = solve_linear(scene, LinearSettings(damping_ratio=zeta))
        wall = time.perf_counter() - t0
        out[key + "/deflection"] = res.deflection
        out[key + "/scalars"] = np.array([res.floquet_max_abs, res.floquet_error, res.harmonics,
                                          res.error_estimate, float(res.stable), wall])
        print(f"{key:<36}{res.status:>9}{wall:8.3f} s", flush=True)
    return out


def peak_error(new: np.ndarray, old: np.ndarray) -> float:
    """max over (dx, dy) as a vector and the rotation of max |new - old| / max |old|; both all-NaN
    (no stable steady state) counts as equal, one of them NaN as infinitely different."""
    if np.all(np.isnan(old)) and np.all(np.isnan(new)):
        return 0.0
    if np.any(np.isnan(old)) or np.any(np.isnan(new)):
        return float("inf")
    err = 0.0
    for g in (slice(0, 2), slice(2, 3)):
        peak = np.max(np.linalg.norm(old[:, g], axis=1))
        err = max(err, float(np.max(np.linalg.norm(new[:, g] - old[:, g], axis=1)) / peak))
    return err


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("action", choices=("store", "compare"))
    ap.add_argument("file")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    new = run()
    if args.action == "store":
        np.savez(args.file, **new)
        return
    old = np.load(args.file)
    worst, worst_mu, t_old, t_new = 0.0, 0.0, 0.0, 0.0
    print(f"\n{'scene':<36}{'hist err':>10}{'d|mu|':>10}{'+-old':>9}{'+-new':>9}{'H old/new':>10}{'t old':>8}"
          f"{'t new':>8}")
    for key in sorted(k[:-len("/deflection")] for k in new if k.endswith("/deflection")):
        e = peak_error(new[key + "/deflection"], old[key + "/deflection"])
        so, sn = old[key + "/scalars"], new[key + "/scalars"]
        d_mu = abs(sn[0] - so[0])
        worst, worst_mu = max(worst, e), max(worst_mu, d_mu / max(so[1], sn[1]))
        t_old, t_new = t_old + so[5], t_new + sn[5]
        print(f"{key:<36}{e:10.2e}{d_mu:10.2e}{so[1]:9.1e}{sn[1]:9.1e}{int(so[2]):>5}/{int(sn[2]):<4}"
              f"{so[5]:8.3f}{sn[5]:8.3f}")
    print(f"worst history difference {worst:.3e} of the peak; worst |d max|mu|| / its error estimate "
          f"{worst_mu:.2f}; total wall old {t_old:.2f} s, new {t_new:.2f} s (not the same run)")


if __name__ == "__main__":
    main()
