"""Print the acceptance table of the linear KED model (docs/linear_model.md) from the stored campaign
results/studies/linear_acceptance.h5: per scene with r <= 0.1, the vector history error of the coupler
point (compare.metrics.history_error on dx, dy) of the quasi-static and the linear model against the fine
Exudyn steady state, the bound it must meet and whether it does.  Bound: 2 % of the peak; for the
distributed mass model (lumps against Exudyn's consistent beam mass) the lumping floor, i.e. the
quasi-static error of the same mechanism at 30 rpm (r ~ 0.02, where the dynamic part is ~r^2 < 0.1 %),
plus 1 %.

    .venv/bin/python results/studies/linear_acceptance_table.py
"""

from __future__ import annotations

from pathlib import Path

from compare import metrics, store
from compare.inspect import speed_ratio

FILE = Path(__file__).with_name("linear_acceptance.h5")
R_MAX = 0.1


def main() -> None:
    scenes = [r for r in store.read_scenes(FILE) if r.ok]
    vec = metrics.vector
    err = {(r.spec.mechanism, r.spec.mass_model.name, r.rpm): {
        n: metrics.history_error(vec(r.history(n)), vec(r.history("dynamic"))) for n in ("quasi_static", "linear")}
        for r in scenes}
    print("| mechanism | mass model | rpm | r | quasi-static | linear KED | bound | linear within bound |")
    print("|---|---|---|---|---|---|---|---|")
    for r in sorted(scenes, key=lambda r: (r.spec.mechanism != "source", r.spec.mass_model.name, r.rpm)):
        ratio = speed_ratio(r)
        if ratio > R_MAX:
            continue
        key = (r.spec.mechanism, r.spec.mass_model.name)
        e = err[(*key, r.rpm)]
        bound = 0.02 if key[1] != "distributed" else err[(*key, 30.0)]["quasi_static"] + 0.01
        print(f"| {key[0]} | {key[1]} | {r.rpm:g} | {ratio:.3f} | {100 * e['quasi_static']:.2f} % "
              f"| {100 * e['linear']:.2f} % | {100 * bound:.2f} % | {'yes' if e['linear'] < bound else 'NO'} |")


if __name__ == "__main__":
    main()
