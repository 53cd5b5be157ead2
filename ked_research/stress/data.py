"""The stress study's scenes and their computation (``ked study stress``, :mod:`ked_research.stress.study`):
where the quasi-static link stress holds, against where the quasi-static deflection
holds, and how far the quasi-static fatigue safety factor can be trusted.

Every scene is solved by the three tiers: the quasi-static and linear models (the campaign's solvers, through
:func:`compare.execute.solve_one`) and Exudyn with the link stresses of its steady cycle
(``simulate_steady_state(..., stress=True)``, ``DynamicSettings()`` defaults with :data:`ELEMENTS` beam
elements per link: the section moment converges more slowly than the deflection in the element count).
Against Exudyn, per scene:

* the deflection error: the coupler point's vector history error (:func:`compare.metrics.history_error`);
* the stress error of each link: max over the cycle of |sigma - sigma_exudyn| (largest and smallest fibre
  stress) over the Exudyn peak of that link (:func:`ked_quasi.stress.history_error`); a scene's stress error
  is its worst link's;
* the Goodman safety factor of each tier (:mod:`ked_quasi.fatigue`) for the linkage's material
  (:data:`MATERIALS`).

Families (linkage, mechanism, mass model) walk up :data:`RATIOS` (r = Omega / omega1_min); each family's
limits are first crossings of :data:`TOLERANCE` (:func:`compare.limits.validity_limit`).  Scenes: the thesis
linkage (source and cognate, four mass models), Simeon's slider-crank (rod with its own mass; rigid crank) and
the first :data:`ATLAS_LINKAGES` generated four-bars of the atlas (source, four mass models).  Results are
stored in ``studies/stress.h5`` (``/study/scenes``), one row per scene; a run computes only the scenes missing.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ked_quasi import rules

SECTION = "stress"
FILE = "stress.h5"
RATIOS = (0.04, 0.06, 0.08, 0.10, 0.13, 0.16, 0.20, 0.25)
"""Speed ratios of every family."""
TOLERANCE = rules.DEFAULT_TOLERANCE
ELEMENTS = 8
"""Beam elements per link of the Exudyn reference (the default campaign's 4 leave the section moment of a
link with its own mass 2-3 % of the peak from the converged one; 8: 0.3-1 %, docs/stress.md)."""
DAMPING = rules.DEFAULT_DAMPING_RATIO
ATLAS_LINKAGES = 2
MASS_MODELS_FOUR_BAR = ("tip", "joints", "extender", "distributed")


@dataclass(frozen=True)
class Fatigue:
    """Material fatigue data [Pa] and where they come from."""

    ultimate: float
    endurance: float
    source: str


MATERIALS = {
    "aluminium": Fatigue(310e6, 96.5e6, "6061-T6: S_u 310 MPa, fatigue strength 96.5 MPa at 5e8 cycles (ASM)"),
    "steel": Fatigue(380e6, 190e6, "AISI 1020 hot rolled: S_u 380 MPa, S_e' = 0.5 S_u (Shigley, eq. 6-8)"),
}
"""The fatigue data of the study's materials (unmodified: no Marin factors)."""


@dataclass(frozen=True)
class Case:
    """One scene of the study: group ("thesis", "simeon", "atlas"), linkage label, atlas index (-1 if none),
    mechanism, mass model, speed ratio r [1]."""

    group: str
    linkage: str
    index: int
    mechanism: str
    mass_model: str
    r: float

    @property
    def key(self) -> str:
        return f"{self.linkage}/{self.mechanism}/{self.mass_model}/r={self.r:g}"


@dataclass(frozen=True)
class Row:
    """What the study keeps of one scene (errors [1] against Exudyn, nan where a tier has no answer; rpm
    [rev/min]; goodman_* [1]; deflection_ratio: Exudyn's peak deflection over the shortest link [1];
    flags: Exudyn's validity flags, comma-separated; wall_s [s])."""

    key: str
    group: str
    linkage: str
    mechanism: str
    mass_model: str
    material: str
    r: float
    rpm: float
    ok: bool
    reason: str
    flags: str
    deflection_ratio: float
    deflection_qs: float
    deflection_linear: float
    stress_qs: float
    stress_linear: float
    worst_link: str
    goodman_qs: float
    goodman_linear: float
    goodman_exudyn: float
    peak_stress_pa: float
    wall_s: float


def cases(atlas_linkages: int = ATLAS_LINKAGES) -> list[Case]:
    """Every scene of the study, in report order."""
    out = [Case("thesis", "thesis", -1, mech, mm, r) for mech in ("source", "cognate")
           for mm in MASS_MODELS_FOUR_BAR for r in RATIOS]
    out += [Case("simeon", "simeon", -1, "source", "distributed", r) for r in RATIOS]
    from ked_research.atlas.generate import generate

    for lk in generate(atlas_linkages, 0).linkages:
        out += [Case("atlas", f"atlas-{lk.index}", lk.index, "source", mm.name, r)
                for mm in lk.mass_models for r in RATIOS]
    return out


def _spec(case: Case) -> tuple[Any, str]:
    """(the campaign scene, material name) of a case."""
    from compare.scenes import SceneSpec, SpeedSpec
    from ked_quasi.massmodel import MassModel, default_payload
    from ked_quasi.rules import DEFAULT_LUMPS

    if case.group == "atlas":
        from ked_research.atlas.generate import candidate

        lk = candidate(0, case.index)
        linkage, mm = lk.source, next(m for m in lk.mass_models if m.name == case.mass_model)
        mm = MassModel(mm.name, lumps=DEFAULT_LUMPS, payload=mm.payload)
        material = lk.design.material
    else:
        from ked_quasi import simeon_slider_crank, thesis_fourbar

        linkage = thesis_fourbar() if case.group == "thesis" else simeon_slider_crank()
        mm = MassModel(case.mass_model, lumps=DEFAULT_LUMPS, payload=default_payload(case.mass_model))
        material = "aluminium" if case.group == "thesis" else "steel"
    spec = SceneSpec(linkage=linkage, mechanism=case.mechanism, mass_model=mm, speed=SpeedSpec("ratio", case.r),
                     stiffness_scale=1.0, damping_ratio=DAMPING, direction="ccw", step_deg=10.0, n_modes=1,
                     outputs=("dx", "dy", "rotation"), tolerance=TOLERANCE, dynamic=(("damping_ratio", DAMPING),),
                     solvers=("quasi_static", "linear"))
    return spec, material


def compute(case: Case) -> Row:
    """The three tiers of one case (on a worker); a failure is a row with ok False and its reason."""
    t0 = time.perf_counter()
    nan = math.nan
    material = ""
    try:
        spec, material = _spec(case)
        return _solve(case, spec, material, t0)
    except Exception as exc:  # noqa: BLE001 - a failed scene is data, with its reason
        return Row(case.key, case.group, case.linkage, case.mechanism, case.mass_model, material, case.r, nan,
                   False, f"{type(exc).__name__}: {str(exc)[:300]}", "", nan, nan, nan, nan, nan, "", nan, nan, nan,
                   nan,
                   time.perf_counter() - t0)


def _solve(case: Case, spec: Any, material: str, t0: float) -> Row:
    from compare import metrics
    from compare import solvers as registry
    from compare.execute import frame, solve_one
    from exudyn_models.settings import DynamicSettings
    from exudyn_models.simulate import simulate_steady_state
    from ked_linear.settings import LinearSettings
    from ked_linear.stress import linear_stress
    from ked_quasi.fatigue import Material
    from ked_quasi.kinds import quasi_static_stress
    from ked_quasi.stress import history_error

    nan = math.nan
    fr = frame(spec)
    scene = fr.scene
    qs, lin = (solve_one(registry.get(n), spec, scene) for n in ("quasi_static", "linear"))
    dyn = simulate_steady_state(scene, DynamicSettings(elements_per_link=ELEMENTS, damping_ratio=DAMPING),
                                stress=True)
    d_dyn = dyn.deflection[:, :2]
    ok = dyn.converged and dyn.stress is not None
    s_qs = quasi_static_stress(scene)
    try:
        s_lin = linear_stress(scene, LinearSettings(damping_ratio=DAMPING))
    except ValueError:  # the masses' steady state not resolved well enough for its accelerations
        s_lin = None
    e_qs = history_error(s_qs, dyn.stress) if ok else {}
    e_lin = history_error(s_lin, dyn.stress) if ok and s_lin is not None else {}
    worst = max(e_qs, key=e_qs.get) if e_qs else ""
    fat = MATERIALS[material]
    mat = Material(fat.ultimate, fat.endurance)
    shortest = min(scene.linkage.length(k) for k in dyn.stress.links) if ok else nan
    ratio = metrics.peak(d_dyn) / shortest if ok else nan
    return Row(
        key=case.key, group=case.group, linkage=case.linkage, mechanism=case.mechanism, mass_model=case.mass_model,
        material=material, r=case.r, rpm=fr.rpm, ok=ok, reason="" if ok else dyn.message[:300],
        flags=",".join(dyn.flags), deflection_ratio=ratio,
        deflection_qs=metrics.history_error(metrics.vector(qs.deflection), d_dyn) if ok and qs.ok else nan,
        deflection_linear=metrics.history_error(metrics.vector(lin.deflection), d_dyn) if ok and lin.ok else nan,
        stress_qs=e_qs.get(worst, nan), stress_linear=max(e_lin.values()) if e_lin else nan, worst_link=worst,
        goodman_qs=_goodman(s_qs, mat), goodman_linear=_goodman(s_lin, mat) if s_lin is not None else nan,
        goodman_exudyn=_goodman(dyn.stress, mat) if ok else nan,
        peak_stress_pa=max(dyn.stress.peaks().values()) if ok else nan,
        wall_s=time.perf_counter() - t0,
    )


def _goodman(history: Any, material: Any) -> float:
    from ked_quasi.fatigue import history_fatigue

    factors = [f.safety_factor for f in history_fatigue(history, material).values() if math.isfinite(f.safety_factor)]
    return min(factors) if factors else math.nan


def stored(path: Path) -> list[Row]:
    """The rows stored in ``path`` (none if the file does not exist)."""
    from ked_research.study_io import read_tables, rows

    if not path.exists():
        return []
    tables, _ = read_tables(path)
    return [Row(**r) for r in rows(tables.get("scenes", {}))]
