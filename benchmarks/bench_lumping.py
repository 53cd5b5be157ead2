"""The lumping bias of the quasi-static error prediction on distributed four-bars (docs/linear_model.md, "Lumps").

On ten distributed scenes of the atlas's threshold sample (the ten whose Exudyn-measured quasi-static error
exceeded the prediction most in the atlas of 2026-11-24), at one crank speed per scene (the speed of ratio r on
5 lumps per link), the quasi-static and linear answers on 5, 10 and 20 lumps per link (the linear model on the
same lumps throughout, ``dynamic_lumps=None``, and on 20 with the default 10 dynamic lumps) against Exudyn
(atlas settings).  Prints per scene: each answer's history error against Exudyn and the prediction (quasi-static
vs linear) on each lumping.  Then five extender scenes of the same sample (the five whose measured error
exceeded the prediction most once the quasi-static answer had 20 lumps), on the scene's 20 lumps with the linear
model's dynamics on 5, 10 (the default) and all 20 lumps.  Run: ``.venv/bin/python benchmarks/bench_lumping.py``
(about a minute and a half).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace

from compare import metrics
from compare import solvers as registry
from compare.execute import frame, solve_one
from ked_research.atlas.compute import spec_of, xy
from ked_research.atlas.generate import candidate

KEYS = ("590/source/0.076193", "1690/source/0.134258", "420/cognate/0.067676", "1494/source/0.097951",
        "1205/cognate/0.130044", "488/cognate/0.156507", "364/cognate/0.096993", "1054/source/0.05909",
        "663/source/0.100849", "1138/cognate/0.111037")
"""(linkage index of seed 0 / mechanism / speed ratio) of the ten scenes."""
EXTENDER_KEYS = ("1606/cognate/0.085", "245/source/0.196327", "1721/source/0.2377", "1307/source/0.08553",
                 "450/cognate/0.124318")
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
    x["lin20_default"] = xy(registry.get("linear").run(spec[20].scene(fr.rpm), _settings(spec[20])))
    out = {"r": float(r), "rpm": fr.rpm}
    for n in LUMPS:
        out[f"qs{n}_vs_exudyn"] = metrics.history_error(x[f"qs{n}"], x["exudyn"])
        out[f"lin{n}_vs_exudyn"] = metrics.history_error(x[f"lin{n}"], x["exudyn"])
        out[f"predicted{n}"] = metrics.history_error(x[f"qs{n}"], x[f"lin{n}"])
    out["lin20_default_vs_exudyn"] = metrics.history_error(x["lin20_default"], x["exudyn"])
    out["predicted20_default"] = metrics.history_error(x["qs20"], x["lin20_default"])
    return out


def extender_errors(key: str) -> dict[str, float]:
    """The extender scene on today's default lumps: measured (quasi-static vs Exudyn), and the prediction and the
    linear model's error with its dynamics on 5, 10 and all lumps."""
    linkage, mechanism, r = key.split("/")
    lk = candidate(0, int(linkage))
    mm = next(m for m in lk.mass_models if m.name == "extender")
    spec = spec_of(lk, mechanism, mm, float(r))
    fr = frame(spec)
    qs = xy(solve_one(registry.get("quasi_static"), spec, fr.scene))
    exu = xy(solve_one(registry.get("dynamic"), spec, fr.scene))
    out = {"r": float(r), "measured": metrics.history_error(qs, exu)}
    for dyn in (5, 10, None):
        lin = xy(registry.get("linear").run(fr.scene, _settings(spec, dynamic_lumps=dyn)))
        out[f"predicted_dyn{dyn}"] = metrics.history_error(qs, lin)
        out[f"lin_dyn{dyn}_vs_exudyn"] = metrics.history_error(lin, exu)
    return out


def _settings(spec: object, **over: object) -> object:
    from ked_linear.settings import LinearSettings

    return LinearSettings(damping_ratio=spec.damping_ratio, **over)  # type: ignore[attr-defined]


def main() -> None:
    warnings.simplefilter("ignore")
    for key in KEYS:
        e = scene_errors(key)
        print(json.dumps({"scene": key} | {k: round(v, 4) for k, v in e.items()}), flush=True)
    for key in EXTENDER_KEYS:
        e = extender_errors(key)
        print(json.dumps({"extender": key} | {k: round(v, 4) for k, v in e.items()}), flush=True)


if __name__ == "__main__":
    main()
