"""The lumping bias of the quasi-static error prediction on distributed four-bars (docs/linear_model.md, "Lumps").

On ten distributed scenes of the atlas's threshold sample (the ten whose Exudyn-measured quasi-static error
exceeded the prediction most in the atlas of 2026-11-24), at one crank speed per scene (the speed of ratio r on
5 lumps per link), the quasi-static and linear answers on 5, 10 and 20 lumps per link (the linear model on the
same lumps throughout, ``dynamic_lumps=None``, and on 20 with the default 5 dynamic lumps) against Exudyn
(atlas settings).  Prints per scene: each answer's history error against Exudyn and the prediction (quasi-static
vs linear) on each lumping.  Run: ``.venv/bin/python benchmarks/bench_lumping.py`` (about a minute).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace

from compare import metrics
from compare import solvers as registry
from compare.atlas.compute import spec_of, xy
from compare.atlas.generate import candidate
from compare.execute import frame, solve_one

KEYS = ("590/source/0.076193", "1690/source/0.134258", "420/cognate/0.067676", "1494/source/0.097951",
        "1205/cognate/0.130044", "488/cognate/0.156507", "364/cognate/0.096993", "1054/source/0.05909",
        "663/source/0.100849", "1138/cognate/0.111037")
"""(linkage index of seed 0 / mechanism / speed ratio) of the ten scenes."""
LUMPS = (5, 10, 20)


def scene_errors(key: str) -> dict[str, float]:
    linkage, mechanism, r = key.split("/")
    lk = candidate(0, int(linkage))
    mm = next(m for m in lk.mass_models if m.name == "distributed")
    spec = {n: replace(spec_of(lk, mechanism, replace(mm, lumps=n), float(r)),
                       solvers=("quasi_static", "linear", "dynamic")) for n in LUMPS}
    fr = frame(spec[5])
    x = {"exudyn": xy(solve_one(registry.get("dynamic"), spec[5], fr.scene))}
    for n in LUMPS:
        scene = spec[n].scene(fr.rpm)
        x[f"qs{n}"] = xy(solve_one(registry.get("quasi_static"), spec[n], scene))
        x[f"lin{n}"] = xy(registry.get("linear").run(scene, _settings(spec[n], dynamic_lumps=None)))
    x["lin20_on5"] = xy(registry.get("linear").run(spec[20].scene(fr.rpm), _settings(spec[20])))
    out = {"r": float(r), "rpm": fr.rpm}
    for n in LUMPS:
        out[f"qs{n}_vs_exudyn"] = metrics.history_error(x[f"qs{n}"], x["exudyn"])
        out[f"lin{n}_vs_exudyn"] = metrics.history_error(x[f"lin{n}"], x["exudyn"])
        out[f"predicted{n}"] = metrics.history_error(x[f"qs{n}"], x[f"lin{n}"])
    out["lin20_on5_vs_exudyn"] = metrics.history_error(x["lin20_on5"], x["exudyn"])
    out["predicted20_on5"] = metrics.history_error(x["qs20"], x["lin20_on5"])
    return out


def _settings(spec: object, **over: object) -> object:
    from ked_linear.settings import LinearSettings

    return LinearSettings(damping_ratio=spec.damping_ratio, **over)  # type: ignore[attr-defined]


def main() -> None:
    warnings.simplefilter("ignore")
    for key in KEYS:
        e = scene_errors(key)
        print(json.dumps({"scene": key} | {k: round(v, 4) for k, v in e.items()}), flush=True)


if __name__ == "__main__":
    main()
