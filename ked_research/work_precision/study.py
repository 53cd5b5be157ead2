"""`ked study work-precision`: error against run time of the three solvers.

Regenerates ``results/studies/work_precision.h5`` from the checked-in configs
``results/studies/work_precision*.toml`` (one file; scenes shared by two configs run once), re-times
the cheap dynamic runs serially, measures the quasi-static solver's time and its lumps convergence and
the linear KED model's time and error, stores the derived tables in ``/study`` of the same file, draws
``results/figures/work_precision*.png`` and writes the ``work-precision`` section of ``results/README.md``
from the stored tables.

Resuming: when the campaign adds no scene, the ``/study`` tables already stored are kept as they are
(their timings included: re-timing would only redo Exudyn runs and add noise) and only the missing tables
are computed; ``--fresh`` recomputes everything.
"""

from __future__ import annotations

import json
import math
import statistics
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path

import h5py
import numpy as np

from compare import store
from compare.metrics import cycle_error
from compare.paths import RESULTS, StudyPaths, remove_outputs
from compare.results import SceneResult
from compare.scenes import SceneSpec, canonical_json
from compare.sections import write_section
from compare.solvers import COMPONENTS
from compare.solvers.dynamic import settings_for as build_settings
from ked_linear import LinearSettings, forget_recalled, solve_linear
from ked_quasi.massmodel import MassModel
from ked_quasi.presets import linkage
from ked_quasi.solver import Scene, solve_quasi_static
from ked_research import study_io
from ked_research.work_precision.analysis import REFERENCE, LumpPoint, WPPoint, disc_of, is_reference

STUDIES = RESULTS / "studies"
CONFIGS = ("work_precision.toml", "work_precision_quasi.toml", "work_precision_refcheck.toml")
OUT = STUDIES / "work_precision.h5"
FIGURES = RESULTS / "figures"
README = RESULTS / "README.md"
SECTION = "work-precision"
LUMPS = (1, 2, 3, 4, 5, 6, 8, 12, 16, 24, 32, 48, 64)
LUMPS_REFERENCE = 256


def family_key(spec: SceneSpec) -> str:
    """The scene without its Exudyn discretization (damping ratio kept): what a reference serves."""
    d = spec.to_dict()
    d["dynamic"] = {"damping_ratio": spec.damping_ratio}
    return canonical_json(d)


def family_label(spec: SceneSpec) -> str:
    """e.g. ``tip r=0.3`` (mass model and speed)."""
    return f"{spec.mass_model.name} {'r=' if spec.speed.kind == 'ratio' else ''}{spec.speed.label().rstrip('w1')}"


def deflection(side: dict[str, np.ndarray]) -> np.ndarray:
    """(n, 3) dx, dy [m], rotation [rad] from a stored side (all three outputs required)."""
    return np.column_stack([side[c] for c in COMPONENTS])


def ked_scene(r: SceneResult):
    """The ked_quasi Scene a stored result was computed on (resolved crank speed)."""
    return r.spec.scene(r.rpm)


def median_time(fn: Callable[[], object], repeats: int) -> float:
    """Median wall time [s] of ``repeats`` calls of ``fn``."""
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls)


def retime(results: Sequence[SceneResult], below_s: float, extra: int) -> dict[str, tuple[float, int, float]]:
    """Key -> (median wall [s], timings, (max - min) / median) for ok runs whose campaign wall time was
    below ``below_s``: ``extra`` more serial runs of the dynamic solver, median together with the
    campaign's timing."""
    from exudyn_models import simulate_steady_state

    out = {}
    for r in results:
        if not r.ok or r.stat("dynamic", "wall_s") >= below_s:
            continue
        scene, settings = ked_scene(r), build_settings(r.spec)
        walls = [r.stat("dynamic", "wall_s")] + [
            median_time(lambda s=scene, c=settings: simulate_steady_state(s, c), 1) for _ in range(extra)]
        med = statistics.median(walls)
        out[r.key] = (med, len(walls), (max(walls) - min(walls)) / med)
    return out


def dynamic_points(results: Sequence[SceneResult], timings: dict[str, tuple[float, int, float]]) -> list[WPPoint]:
    """Every dynamic run of a family that has a reference, with its error against that reference."""
    refs = {family_key(r.spec): r for r in results if r.ok and is_reference(r.dynamic_settings)}
    points = []
    for r in results:
        ref = refs.get(family_key(r.spec))
        if ref is None or not r.dynamic_settings:
            continue
        if r.key != ref.key and r.dynamic_settings.get("steady_tol") == REFERENCE["steady_tol"]:
            continue  # a check of the reference itself (reference_check), not a discretization to rank
        wall, n, spread = timings.get(r.key, (r.stat("dynamic", "wall_s"), 1, 0.0))
        ok = r.ok and bool(r.dynamic)
        err = cycle_error(deflection(r.dynamic), deflection(ref.dynamic)) if ok else math.nan
        points.append(WPPoint(
            family=family_label(r.spec), disc=disc_of(r.dynamic_settings),
            reference=r.key == ref.key, ok=ok, wall_s=float(wall), repeats=n, error=err,
            cycles=r.stat("dynamic", "cycles", -1), newton_iterations=r.stat("dynamic", "newton_iterations", -1),
            message=(r.message or r.stat("dynamic", "dynamic_message", ""))[:300], wall_spread=float(spread)))
    return points


def reference_check(results: Sequence[SceneResult]) -> list[dict]:
    """Finer-than-reference ANCF runs (more elements and steps, same tolerance) against the reference."""
    refs = {family_key(r.spec): r for r in results if r.ok and is_reference(r.dynamic_settings)}
    out = []
    for r in results:
        s, ref = r.dynamic_settings, refs.get(family_key(r.spec))
        if (ref is None or not r.ok or s.get("element") != "ancf" or s.get("steady_tol") != REFERENCE["steady_tol"]
                or s["elements_per_link"] <= REFERENCE["elements_per_link"]):
            continue
        out.append({"family": family_label(r.spec), "elements_per_link": s["elements_per_link"],
                    "steps_per_cycle": s["steps_per_cycle"], "wall_s": r.stat("dynamic", "wall_s"),
                    "error": cycle_error(deflection(ref.dynamic), deflection(r.dynamic))})
    return out


def reference_scenes(results: Sequence[SceneResult]) -> list[SceneResult]:
    """The stored dynamic references (ok, with a verdict): the scenes the fast solvers are measured on."""
    return [r for r in results if r.ok and is_reference(r.dynamic_settings) and r.verdict is not None]


def quasi_points(results: Sequence[SceneResult], repeats: int) -> list[dict]:
    """Quasi-static solver on every reference scene: error [1] against the dynamic reference, median
    solve time [s] over ``repeats`` solves, speed ratio, quasi-static and dynamic peaks [m]."""
    out = []
    for r in reference_scenes(results):
        scene = ked_scene(r)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            wall = median_time(lambda scene=scene: solve_quasi_static(scene), repeats)
        qs, dyn = deflection(r.quasi_static), deflection(r.dynamic)
        out.append({"mass_model": r.spec.mass_model.name, "lumps": r.spec.mass_model.lumps,
                    "speed_ratio": float(r.verdict.speed_ratio), "rpm": float(r.rpm),
                    "error": cycle_error(qs, dyn), "wall_s": wall, "dynamic_wall_s": r.stat("dynamic", "wall_s"),
                    "qs_peak_m": float(np.max(np.abs(qs[:, :2]))), "dyn_peak_m": float(np.max(np.abs(dyn[:, :2])))})
    return sorted(out, key=lambda d: (d["mass_model"], d["speed_ratio"]))


def linear_points(results: Sequence[SceneResult], repeats: int = 5, slow_s: float = 1.0) -> list[dict]:
    """Linear KED model (``ked_linear.solve_linear``, damped like the scene, default resolution) on every
    reference scene: error [1] against the dynamic reference (as :func:`quasi_points`), median solve time
    [s] over ``repeats`` solves (at most 3 when the first takes over ``slow_s``), each with solve_linear's
    recall emptied (:func:`ked_linear.forget_recalled`: none reuses another's system or multipliers), and
    their spread (max - min) / median [1], its harmonics, own error estimate [1], largest |Floquet
    multiplier| and stability, peak [m]."""
    out = []
    for r in reference_scenes(results):
        scene, settings = ked_scene(r), LinearSettings(damping_ratio=r.spec.damping_ratio)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            forget_recalled()  # every timed solve computes the scene's system and multipliers afresh
            t0 = time.perf_counter()
            res = solve_linear(scene, settings)
            walls = [time.perf_counter() - t0]
            n = repeats if walls[0] <= slow_s else min(repeats, 3)
            for _ in range(n - 1):
                forget_recalled()
                walls.append(median_time(lambda s=scene, c=settings: solve_linear(s, c), 1))
        lin, dyn = np.asarray(res.deflection, dtype=float), deflection(r.dynamic)
        out.append({"mass_model": r.spec.mass_model.name, "lumps": r.spec.mass_model.lumps,
                    "speed_ratio": float(r.verdict.speed_ratio), "rpm": float(r.rpm),
                    "damping_ratio": float(r.spec.damping_ratio), "error": cycle_error(lin, dyn),
                    "wall_s": statistics.median(walls), "repeats": len(walls),
                    "wall_spread": (max(walls) - min(walls)) / statistics.median(walls),
                    "dynamic_wall_s": r.stat("dynamic", "wall_s"), "stable": bool(res.stable),
                    "harmonics": int(res.harmonics), "error_estimate": float(res.error_estimate),
                    "floquet_max_abs": float(res.floquet_max_abs),
                    "peak_m": float(np.max(np.abs(lin[:, :2]))) if res.stable else math.nan})
    return sorted(out, key=lambda d: (d["mass_model"], d["speed_ratio"]))


def lump_convergence(models: Sequence[str] = ("extender", "distributed"),
                     placements: Sequence[str] = ("midpoint", "end"), lumps: Sequence[int] = LUMPS,
                     reference: int = LUMPS_REFERENCE, repeats: int = 15) -> list[LumpPoint]:
    """Quasi-static deflection with n lumps per link against n = ``reference`` (thesis source linkage,
    300 rpm; the relative error does not depend on the speed since all loads scale with omega^2)."""
    fb = linkage("thesis")
    out = []
    for model in models:
        for placement in placements:
            def solve(n: int, model: str = model, placement: str = placement):
                return solve_quasi_static(Scene(fb, MassModel(model, lumps=n, placement=placement), 300.0, 10.0))

            ref = solve(reference).deflection
            for n in lumps:
                d = solve(n).deflection
                out.append(LumpPoint(model, placement, n, reference, cycle_error(d, ref),
                                     median_time(lambda n=n: solve(n), repeats)))
    return out


def stored_study(out: Path, scenes: int) -> tuple[dict[str, list[dict]], dict]:
    """The ``/study`` tables (name -> rows) and attrs stored in ``out`` by a run of the same configs over
    ``scenes`` scenes, as :func:`study_io.write_tables` takes them back; ({}, {}) if there are none."""
    if not out.exists():
        return {}, {}
    with h5py.File(out, "r") as f:
        if study_io.STUDY not in f:
            return {}, {}
    tables, attrs = study_io.read_tables(out)
    attrs = {k: v.item() if isinstance(v, np.generic) else v for k, v in attrs.items()}
    configs = json.loads(attrs["configs"]) if isinstance(attrs.get("configs"), str) else attrs.get("configs")
    if configs != [f"results/studies/{c}" for c in CONFIGS] or attrs.get("scenes") != scenes:
        return {}, {}
    # booleans are stored as uint8: give them back as booleans so that a rewrite keeps the column types
    return ({name: study_io.rows({c: v.astype(bool) if v.dtype == np.uint8 else v for c, v in t.items()})
             for name, t in tables.items()}, attrs)


def run_study(out: Path = OUT, *, workers: int | None = 2, fresh: bool = True, figures: Path = FIGURES,
              readme: Path = README, retime_below_s: float = 5.0, progress: bool = True) -> dict:
    """The whole study (see module docstring); returns a small summary dict.  Not ``fresh`` and no scene
    added by the campaign: the stored ``/study`` tables and attrs are kept, only missing tables computed."""
    t0 = time.perf_counter()
    summaries = study_io.run_configs([STUDIES / c for c in CONFIGS], out, workers=workers, fresh=fresh,
                                     progress=progress)
    t_campaign = time.perf_counter() - t0
    scenes = sum(s.total for s in summaries)
    added = sum(s.ok + s.failed + s.lost for s in summaries)
    kept, kept_attrs = ({}, {}) if fresh or added else stored_study(out, scenes)
    results = store.read_scenes(out)

    def dynamic() -> list[WPPoint]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return dynamic_points(results, retime(results, retime_below_s, extra=2))

    builders: dict[str, Callable[[], Sequence]] = {
        "dynamic": dynamic, "refcheck": lambda: reference_check(results),
        "quasi_static": lambda: quasi_points(results, repeats=21), "lumps": lump_convergence,
        "linear": lambda: linear_points(results, repeats=5)}
    missing = [name for name in builders if name not in kept]
    tables = {name: kept[name] if name in kept else build() for name, build in builders.items()}
    wall = time.perf_counter() - t0
    if kept:
        attrs = dict(kept_attrs)
        if missing:
            attrs.update({"updated_utc": store.utc_now(), "updated_tables": missing, "updated_wall_s": wall,
                          "updated_git_commit": store.git_commit()})
            if "dynamic" in missing:
                attrs["retime_below_s"] = retime_below_s
    else:
        from exudyn_models import DynamicSettings

        attrs = {"name": SECTION, "created_utc": store.utc_now(), "reference": REFERENCE,
                 "defaults": asdict(DynamicSettings()), "campaign_wall_s": t_campaign, "study_wall_s": wall,
                 "workers": workers or 0, "retime_below_s": retime_below_s,
                 "configs": [f"results/studies/{c}" for c in CONFIGS],
                 "scenes": scenes, "git_commit": store.git_commit()}
    if missing:
        study_io.write_tables(out, tables, attrs)
    paths = report(out, figures, readme)
    return {"out": str(out), "wall_s": wall, "computed": missing, "figures": [str(p) for p in paths]}


def report(out: Path = OUT, figures: Path = FIGURES, readme: Path = README) -> list[Path]:
    """Figures and README section from the stored ``/study`` tables of ``out`` (no computation)."""
    from ked_research.work_precision import report as wp_report

    tables, attrs = study_io.read_tables(out)
    paths = wp_report.write_figures(tables, attrs, figures)
    write_section(readme, SECTION, wp_report.markdown(tables, attrs, paths, readme.parent))
    return paths


def run(paths: StudyPaths, *, workers: int = 2, fresh: bool = False, report_only: bool = False,
        progress: bool = False, echo: Callable[[str], object] = print, retime_below_s: float = 5.0) -> dict:
    """The study with the common signature (see :func:`ked_research.run`)."""
    out = paths.studies / OUT.name
    if report_only:
        return {"out": str(out), "figures": [str(p) for p in report(out, paths.figures, paths.readme)]}
    if fresh:
        remove_outputs([out], echo)
    return run_study(out, workers=workers, fresh=False, figures=paths.figures, readme=paths.readme,
                     retime_below_s=retime_below_s, progress=progress)
