"""Audit the linear-model solutions stored in results files against today's linear model.

For every stored scene of a campaign results file (``results/studies/*.h5``) with a solution of a solver
whose name starts with ``linear`` (``linear``, ``linear_classic``), the scene is rebuilt from its stored
spec (:meth:`compare.scenes.SceneSpec.from_dict` via :func:`compare.read_scenes`, resolved like a campaign
by :func:`compare.execute.frame`) and the solver runs again, through the registry, with the stored resolved
settings (which are the campaign's: :func:`compare.execute.settings_of` is checked to give the same).  Per
solution it records

* ``change``: max_k |d_new,k - d_stored,k| / max_k |d_stored,k| of the deflection vector d = (dx, dy) of P
  (:func:`compare.metrics.history_error`, the verdict's measure); ``inf`` when only one of the two is a
  steady state (e.g. stored unstable, now stable);
* ``mu_change``: |max|mu|_new - max|mu|_stored| of the Floquet multipliers;
* where the scene has an Exudyn steady state, the linear model's error against it, stored and new
  (what the tiers table and the linear-acceptance table publish).

The atlas (``results/atlas/atlas.h5``) stores no linear histories, only the quasi-static-vs-linear history
error and max |mu| per (family, speed ratio): :func:`audit_atlas` recomputes an evenly spaced sample of its
computed (family, ratio) scenes and compares those two numbers.

Run (writes one new JSON file, refuses to overwrite one; reads the stored files only)::

    nice -n 15 .venv/bin/python benchmarks/audit_stored_linear.py OUT.json results/studies/*.h5 \
        [--atlas results/atlas/atlas.h5 --atlas-sample 200] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import math
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare import metrics, read_scenes
from compare import solvers as registry
from compare.execute import frame, message_of, settings_of
from compare.executor import run_tasks
from compare.scenes import SceneSpec

BEYOND = 1e-3
"""A stored history that moved by more than this fraction of its peak is listed."""


@dataclass(frozen=True)
class Task:
    """One stored linear solution to recompute.  ``stored``: (n, 2) deflection vector [m] or None (the
    stored solution has none: failed); ``dynamic``: (n, 2) Exudyn steady state [m] or None."""

    file: str
    key: str
    label: str
    solver: str
    spec: SceneSpec
    stored_status: str
    stored: np.ndarray | None
    stored_mu: float
    stored_rpm: float
    settings: dict[str, Any]
    dynamic: np.ndarray | None


@dataclass(frozen=True)
class Outcome:
    """The audit of one stored linear solution (errors [1] as fractions of a peak, ``ratio`` r =
    Omega / omega1_min [1], ``rpm`` [rev/min], ``wall_s`` [s])."""

    file: str
    key: str
    label: str
    solver: str
    mass_model: str
    ratio: float
    rpm: float
    stored_status: str
    new_status: str
    change: float
    mu_stored: float
    mu_new: float
    mu_change: float
    error_vs_dynamic_stored: float
    error_vs_dynamic_new: float
    settings_match_campaign: bool
    rpm_change: float
    new_harmonics: int
    new_radau_steps: int
    message: str
    wall_s: float
    feeds: str = ""


def feeds_of(file: str, spec: SceneSpec) -> str:
    """Which published numbers a stored linear solution of ``file`` enters (results/README.md, docs/)."""
    from ked_research.validity import study as validity

    name = Path(file).name
    if name == "linear_acceptance.h5":
        return ("docs/linear_model.md 'Against a fine Exudyn reference' (table, r <= 0.1; paragraph above r = 0.1); "
                "docs/exudyn_models.md uses only its Exudyn runs")
    if name in {Path(c).stem + ".h5" for c in validity.CONFIGS}:
        if spec.damping_ratio == validity.REFERENCE_DAMPING and spec.direction == validity.REFERENCE_DIRECTION:
            return "results/README.md tiers section (limits table, per-mass-model spans, Exudyn-failure |mu| table)"
        return "none (the validity section's damping/direction table is quasi-static vs Exudyn)"
    return "none (refinement scenes: the validity section uses their Exudyn runs only)" \
        if name == validity.REFINE_FILE else "none known"


def _vector(history: dict[str, np.ndarray]) -> np.ndarray | None:
    v = metrics.vector(history)
    return None if v is None or not np.all(np.isfinite(v)) else v


def tasks_of(path: str | Path) -> list[Task]:
    """Every stored linear solution of a campaign results file, in key order."""
    out = []
    for r in read_scenes(path):
        dyn = r.solutions.get("dynamic")
        dynamic = _vector(dyn.deflection) if dyn is not None and dyn.ok else None
        for name, sol in sorted(r.solutions.items()):
            if not name.startswith("linear"):
                continue
            out.append(Task(str(path), r.key, r.spec.label, name, r.spec, sol.status,
                            _vector(sol.deflection) if sol.ok else None,
                            float(sol.stats.get("floquet_max_abs", math.nan)), float(r.rpm), dict(sol.settings),
                            dynamic))
    return out


def _error(a: np.ndarray | None, b: np.ndarray | None) -> float:
    """history error of ``a`` against ``b`` (NaN if either is missing)."""
    return math.nan if a is None or b is None else metrics.history_error(a, b)


def recompute(task: Task) -> tuple[Outcome, registry.Solution | None]:
    """Rebuild the scene, run the solver with the stored settings, compare (never raises for a
    problem of the scene: it is the outcome's ``message``); the new solution beside it (None if the
    scene could not be set up)."""
    t0 = time.perf_counter()
    solver = registry.get(task.solver)
    fields = solver.setting_fields()
    base = dict(file=task.file, key=task.key, label=task.label, solver=task.solver,
                mass_model=task.spec.mass_model.name, stored_status=task.stored_status, mu_stored=task.stored_mu,
                error_vs_dynamic_stored=_error(task.stored, task.dynamic), feeds=feeds_of(task.file, task.spec))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fr = frame(task.spec)
            stored_settings = {k: v for k, v in task.settings.items() if k in fields}
            settings = solver.settings_class()(**stored_settings)
            match = solver.settings_dict(settings_of(solver, task.spec)) == solver.settings_dict(settings)
            sol = solver.run(fr.scene, settings, task.spec.outputs)
    except Exception as exc:  # recorded, the audit goes on
        return Outcome(**base, ratio=math.nan, rpm=task.stored_rpm, new_status="error", change=math.inf,
                       mu_new=math.nan, mu_change=math.nan, error_vs_dynamic_new=math.nan,
                       settings_match_campaign=False, rpm_change=math.nan, new_harmonics=0, new_radau_steps=0,
                       message=f"{type(exc).__name__}: {message_of(exc)}", wall_s=time.perf_counter() - t0), None
    new = _vector(sol.deflection) if sol.ok else None
    if task.stored is None and new is None:
        change = 0.0 if sol.status == task.stored_status else math.inf
    elif task.stored is None or new is None:
        change = math.inf
    else:
        change = metrics.history_error(new, task.stored)
    mu_new = float(sol.stats.get("floquet_max_abs", math.nan))
    return Outcome(**base, ratio=fr.rpm * math.pi / 30.0 / fr.omega1_min, rpm=fr.rpm, new_status=sol.status,
                   change=change, mu_new=mu_new, mu_change=abs(mu_new - task.stored_mu),
                   error_vs_dynamic_new=_error(new, task.dynamic), settings_match_campaign=match,
                   rpm_change=abs(fr.rpm - task.stored_rpm), new_harmonics=int(sol.stats.get("harmonics", 0)),
                   new_radau_steps=int(sol.stats.get("radau_steps", 0)), message=sol.message[:300],
                   wall_s=time.perf_counter() - t0), sol


def _crashed(task: Task, exc: BaseException | None) -> tuple[Outcome, None]:
    return Outcome(task.file, task.key, task.label, task.solver, task.spec.mass_model.name, math.nan,
                   task.stored_rpm, task.stored_status, "crashed", math.inf, task.stored_mu, math.nan, math.nan,
                   math.nan, math.nan, False, math.nan, 0, 0, f"worker lost: {exc}", 0.0,
                   feeds_of(task.file, task.spec)), None


Solutions = dict[tuple[str, str], registry.Solution]
"""(scene key, solver name) -> the solution recomputed with today's code."""


def run_all(tasks: list[Task], workers: int = 2) -> tuple[list[Outcome], Solutions]:
    """Recompute every task on ``workers`` local processes (:func:`compare.runner.run_tasks`): the
    outcomes, in (file, key, solver) order, and the new solutions."""
    done: list[tuple[Outcome, registry.Solution | None]] = []
    if tasks:
        run_tasks(tasks, recompute, workers=workers, crashed=_crashed,
                  on_result=lambda batch: done.extend(r for _, r in batch))
    outcomes = sorted((o for o, _ in done), key=lambda o: (o.file, o.key, o.solver))
    return outcomes, {(o.key, o.solver): sol for o, sol in done if sol is not None}


def tiers_change(files: list[Path], new: Solutions) -> dict[str, Any]:
    """The tiers study's README section (``ked study tiers``: limits of the linear models against Exudyn,
    error parts, linear max |mu| where Exudyn failed) from the stored files as they are and with the stored
    linear solutions replaced by ``new``; the lines that differ.  Only the validity campaigns' files
    (:data:`ked_research.validity.study.CONFIGS`) among ``files`` enter, as in the study."""
    from dataclasses import replace

    from ked_research.tiers import study as tiers
    from ked_research.validity import study as validity
    from ked_research.validity.data import linkage_json, read_points

    names = {Path(c).stem + ".h5" for c in validity.CONFIGS}
    order = [Path(c).stem + ".h5" for c in validity.CONFIGS]
    chosen = sorted((f for f in files if f.name in names), key=lambda f: order.index(f.name))
    old_pts, new_pts, labels = [], [], {}
    for f in chosen:
        results = {r.key: r for r in read_scenes(f)}
        for p in read_points(f, labels=labels):
            labels.setdefault(linkage_json(p.spec), p.linkage)
            if p.refined or p.damping != 0.02 or p.direction != "ccw" or p.key not in results:
                continue
            r = results[p.key]
            sols = {**r.solutions, **{n: new[(r.key, n)] for n in r.solutions if (r.key, n) in new}}
            old_pts.append(tiers.tier_point(p, r))
            new_pts.append(tiers.tier_point(p, replace(r, solutions=sols)))
    readme = Path("README.md")
    old = tiers.markdown(tiers.analyse(old_pts), None, readme).splitlines()
    now = tiers.markdown(tiers.analyse(new_pts), None, readme).splitlines()
    changed = [(a, b) for a, b in zip(old, now) if a != b]
    return {"files": [f.name for f in chosen], "scenes": len(old_pts), "lines_changed": len(changed),
            "changes": [{"stored": a, "new": b} for a, b in changed], "line_count_stored": len(old),
            "line_count_new": len(now)}


def _finite(values: list[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def summarize(outcomes: list[Outcome], wall_s: float) -> dict[str, Any]:
    """Per-file figures: scenes, solutions, max and median change (finite ones; the count of those that
    changed status separately), max |mu| change, the solutions beyond :data:`BEYOND`."""
    changes = [o.change for o in outcomes]
    fin = _finite(changes)
    mus = _finite([o.mu_change for o in outcomes])
    beyond = [o for o in outcomes if not o.change <= BEYOND]
    return {
        "scenes": len({o.key for o in outcomes}), "solutions": len(outcomes),
        "max_change": max(fin) if fin else math.nan, "median_change": float(np.median(fin)) if fin else math.nan,
        "status_changed": sum(o.stored_status != o.new_status for o in outcomes),
        "max_mu_change": max(mus) if mus else math.nan,
        "settings_differ_from_campaign": sum(not o.settings_match_campaign for o in outcomes),
        "max_rpm_change": max(_finite([o.rpm_change for o in outcomes]), default=math.nan),
        "beyond": [asdict(o) for o in sorted(beyond, key=lambda o: -o.change if math.isfinite(o.change) else -1e300)],
        "wall_s": wall_s,
    }


# -- the work-precision study ------------------------------------------------------------------------

WP_COLUMNS = ("error", "floquet_max_abs", "harmonics", "error_estimate", "stable", "peak_m")
"""The columns of the work-precision study's ``/study/linear`` table that the linear model's answer sets
(its timing columns are left as stored: the audit is about answers)."""


def audit_work_precision(path: str | Path) -> dict[str, Any]:
    """The work-precision study stores no linear solution per scene but a derived table, ``/study/linear``
    (:func:`ked_research.work_precision.study.linear_points`: per reference scene the linear model's error
    against the dynamic reference, its peak, max |mu|, harmonics, estimate).  Recompute that table with
    today's code (one solve per scene, in this process), compare it row by row (rows match by mass model and
    speed ratio, rpm checked) and render the README section (:func:`ked_research.work_precision.report.markdown`) from
    the stored tables and from the stored tables with those columns replaced: the lines that differ."""
    from ked_research import study_io
    from ked_research.work_precision import report as wp_report
    from ked_research.work_precision import study as work_precision

    t0 = time.perf_counter()
    path = Path(path)
    tables, attrs = study_io.read_tables(path)
    stored = study_io.rows(tables["linear"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fresh = work_precision.linear_points(read_scenes(path), repeats=1)
    if [(r["mass_model"], round(r["speed_ratio"], 9), round(r["rpm"], 6)) for r in stored] != \
            [(r["mass_model"], round(r["speed_ratio"], 9), round(r["rpm"], 6)) for r in fresh]:
        raise ValueError(f"{path}: the reference scenes no longer match the stored /study/linear rows")
    rows = []
    for a, b in zip(stored, fresh):
        pa, pb = float(a["peak_m"]), float(b["peak_m"])
        rows.append({"mass_model": a["mass_model"], "speed_ratio": float(a["speed_ratio"]),
                     "error_stored": float(a["error"]), "error_new": float(b["error"]),
                     "peak_change": abs(pb - pa) / pa if pa else math.nan,
                     "mu_stored": float(a["floquet_max_abs"]), "mu_new": float(b["floquet_max_abs"]),
                     "harmonics_stored": int(a["harmonics"]), "harmonics_new": int(b["harmonics"]),
                     "estimate_stored": float(a["error_estimate"]), "estimate_new": float(b["error_estimate"])})
    new_tables = dict(tables)
    new_tables["linear"] = {**tables["linear"], **{c: np.asarray([r[c] for r in fresh]) for c in WP_COLUMNS}}
    figs = [path.parent / "work_precision.png", path.parent / "work_precision_lumps.png"]
    old = wp_report.markdown(tables, attrs, figs, path.parent).splitlines()
    now = wp_report.markdown(new_tables, attrs, figs, path.parent).splitlines()
    errs = [abs(r["error_new"] - r["error_stored"]) for r in rows]
    return {"scenes": len(rows), "max_error_change": max(errs, default=math.nan),
            "max_peak_change": max(_finite([r["peak_change"] for r in rows]), default=math.nan),
            "max_mu_change": max((abs(r["mu_new"] - r["mu_stored"]) for r in rows), default=math.nan),
            "rows": rows, "lines_changed": sum(a != b for a, b in zip(old, now)),
            "changes": [{"stored": a, "new": b} for a, b in zip(old, now) if a != b],
            "wall_s": time.perf_counter() - t0}


# -- the atlas --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AtlasTask:
    """One computed (family, ratio) of the atlas: its row, the linkage index, mechanism, mass model name,
    the ratio's index, the stored quasi-static-vs-linear history error [1] and max |mu|."""

    row: int
    linkage: int
    mechanism: str
    mass_model: str
    ratio_index: int
    history_error: float
    mu: float


def atlas_tasks(path: str | Path, sample: int) -> tuple[list[AtlasTask], int]:
    """``sample`` evenly spaced (family, ratio) scenes among the atlas's computed ones (status code ok or
    unstable), and how many there are."""
    from ked_research.atlas import store as atlas_store
    from ked_research.atlas.compute import OK, UNSTABLE

    fam = atlas_store.read(Path(path), "families")
    code = np.asarray(fam["code"])
    rows, cols = np.nonzero((code == OK) | (code == UNSTABLE))
    pick = np.unique(np.linspace(0, rows.size - 1, min(sample, rows.size)).round().astype(int))
    return [AtlasTask(int(rows[i]), int(fam["linkage"][rows[i]]), str(fam["mechanism"][rows[i]]),
                      str(fam["mass_model"][rows[i]]), int(cols[i]), float(fam["history_error"][rows[i], cols[i]]),
                      float(fam["floquet_max_abs"][rows[i], cols[i]])) for i in pick], int(rows.size)


def recompute_atlas(task: AtlasTask, seed: int = 0) -> dict[str, Any]:
    """One atlas scene again with today's code: |history error change| and |max|mu| change|."""
    from ked_research.atlas.compute import RATIOS, spec_of, sweep
    from ked_research.atlas.generate import candidate

    t0 = time.perf_counter()
    link = candidate(seed, task.linkage)
    mm = next(m for m in link.mass_models if m.name == task.mass_model)
    r = RATIOS[task.ratio_index]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fr = frame(spec_of(link, task.mechanism, mm, r))
        s = sweep(link, task.mechanism, mm, fr.omega1_min, (r,), fr.scene)
    e, mu = float(s.hist[0]), float(s.mu[0])
    return {**asdict(task), "ratio": r, "history_error_new": e, "mu_new": mu,
            "history_error_change": abs(e - task.history_error) if math.isfinite(task.history_error) else
            (0.0 if not math.isfinite(e) else math.inf),
            "mu_change": abs(mu - task.mu), "wall_s": time.perf_counter() - t0}


def audit_atlas(path: str | Path, sample: int = 200, workers: int = 2) -> dict[str, Any]:
    """The atlas's sample recomputed (see :func:`atlas_tasks`), with per-file figures."""
    t0 = time.perf_counter()
    tasks, n = atlas_tasks(path, sample)
    done: list[dict[str, Any]] = []
    run_tasks(tasks, recompute_atlas, workers=workers,
              crashed=lambda t, exc: {**asdict(t), "history_error_change": math.inf, "mu_change": math.nan,
                                      "message": f"worker lost: {exc}"},
              on_result=lambda batch: done.extend(o for _, o in batch))
    ch = _finite([d["history_error_change"] for d in done])
    mus = _finite([d["mu_change"] for d in done])
    return {"computed_scenes": n, "sampled": len(tasks), "max_history_error_change": max(ch, default=math.nan),
            "median_history_error_change": float(np.median(ch)) if ch else math.nan,
            "max_mu_change": max(mus, default=math.nan),
            "beyond": sorted((d for d in done if not d["history_error_change"] <= BEYOND),
                             key=lambda d: -d["history_error_change"]),
            "wall_s": time.perf_counter() - t0, "all": sorted(done, key=lambda d: (d["row"], d["ratio_index"]))}


def _json_default(x: Any) -> Any:
    if isinstance(x, (np.integer, np.floating)):
        return x.item()
    raise TypeError(type(x).__name__)


def _clean(x: Any) -> Any:
    """Non-finite floats as strings (strict JSON)."""
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    return x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path, help="new JSON file (refused if it exists)")
    ap.add_argument("files", nargs="*", type=Path, help="campaign results files (results/studies/*.h5)")
    ap.add_argument("--atlas", type=Path, default=None)
    ap.add_argument("--atlas-sample", type=int, default=200)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    if args.out.exists():
        raise SystemExit(f"{args.out}: exists; the audit writes only a new file")
    report: dict[str, Any] = {"beyond_fraction_of_peak": BEYOND, "files": {}}
    solutions: Solutions = {}
    for path in args.files:
        if path.name == "work_precision.h5":
            w = audit_work_precision(path)
            report["work_precision"] = w
            print(f"{path}: /study/linear, {w['scenes']} scenes: linear error change max {w['max_error_change']:.2e}, "
                  f"peak change max {w['max_peak_change']:.2e}, max |mu| change {w['max_mu_change']:.2e}; "
                  f"{w['lines_changed']} README lines change; {w['wall_s']:.0f} s", flush=True)
            for c in w["changes"]:
                print(f"  stored: {c['stored']}\n  new:    {c['new']}", flush=True)
        t0 = time.perf_counter()
        outcomes, new = run_all(tasks_of(path), args.workers)
        solutions.update(new)
        s = summarize(outcomes, time.perf_counter() - t0)
        s["all"] = [asdict(o) for o in outcomes]
        report["files"][str(path)] = s
        print(f"{path}: {s['scenes']} scenes, {s['solutions']} linear solutions; change max {s['max_change']:.2e}, "
              f"median {s['median_change']:.2e}; status changed {s['status_changed']}; max |mu| change "
              f"{s['max_mu_change']:.2e}; beyond {BEYOND:g}: {len(s['beyond'])}; {s['wall_s']:.0f} s", flush=True)
        for b in s["beyond"]:
            print(f"    {b['label']:<45} {b['solver']:<15} r={b['ratio']:.3f} change {b['change']:.2e} "
                  f"{b['stored_status']}->{b['new_status']} vs dyn {b['error_vs_dynamic_stored']:.4f}->"
                  f"{b['error_vs_dynamic_new']:.4f}; feeds: {b['feeds']}", flush=True)
    if any(f.name != "work_precision.h5" for f in args.files):
        t = tiers_change(list(args.files), solutions)
        report["tiers"] = t
        print(f"tiers section ({t['scenes']} scenes of {len(t['files'])} files): {t['lines_changed']} lines change",
              flush=True)
        for c in t["changes"]:
            print(f"  stored: {c['stored']}\n  new:    {c['new']}", flush=True)
    if args.atlas is not None:
        a = audit_atlas(args.atlas, args.atlas_sample, args.workers)
        report["atlas"] = {str(args.atlas): a}
        print(f"{args.atlas}: {a['sampled']} of {a['computed_scenes']} computed scenes; qs-vs-linear error change max "
              f"{a['max_history_error_change']:.2e}, median {a['median_history_error_change']:.2e}; max |mu| change "
              f"{a['max_mu_change']:.2e}; beyond {BEYOND:g}: {len(a['beyond'])}; {a['wall_s']:.0f} s", flush=True)
    with open(args.out, "x") as fh:
        json.dump(_clean(report), fh, indent=1, default=_json_default)


if __name__ == "__main__":
    main()
