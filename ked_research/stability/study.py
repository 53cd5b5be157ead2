"""`ked study stability`: numerical stability on stiff and extreme scenes.

Runs every campaign config in ``results/studies/stability/`` (one extreme case each, named by its
``campaign.name``) into ``results/studies/stability.h5``. A scene's failure never stops the campaign:
it is stored with status "failed", its stage, exception type and message. Then, per scene, it records
what the quasi-static solver reports (peak, condition number, flagged near-toggle angles, distance of
the transmission angle from a toggle) and what the dynamic one did (converged?, cycles, Newton
iterations, steps, wall time, error), checks every converged result, and for a Newton failure
(SimulationError) reports the step search of the Exudyn refinement ladder (``exudyn_models.refine``:
more Newton iterations, steps per cycle x2-x8, elements x2; the attempts the campaign's run made, or a
rerun with the ladder on if the scene ran without it). The table goes to ``/study/cases`` and to the
``stability`` section of ``results/README.md``.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from compare import store
from compare.config import load_config
from compare.paths import RESULTS, StudyPaths, remove_outputs
from compare.results import SceneResult
from compare.sections import write_section
from compare.solvers import COMPONENTS
from compare.solvers.dynamic import legacy_defaults
from compare.solvers.dynamic import settings_for as build_settings
from ked_quasi.solver import solve_quasi_static
from ked_research import study_io
from ked_research.stability import report as stability_report
from ked_research.stability.analysis import check, deviation, peak, quasi_report
from ked_research.work_precision.study import family_key, ked_scene

CONFIG_DIR = RESULTS / "studies" / "stability"
OUT = RESULTS / "studies" / "stability.h5"
README = RESULTS / "README.md"
SECTION = "stability"


@dataclass(frozen=True)
class CaseRow:
    """One scene of the stability campaign (see module docstring). Peaks [m], wall [s], angles [deg]; the
    defaults: not computed."""

    case: str
    config: str
    key: str
    label: str
    variant: str
    speed_ratio: float
    rpm: float
    status: str
    stage: str
    error_type: str
    message: str
    qs_peak_m: float = math.nan
    qs_peak_unflagged_m: float = math.nan
    qs_condition_max: float = math.nan
    qs_flagged_deg: str = ""
    qs_toggle_distance_deg: float = math.nan
    qs_nonfinite: int = -1
    qs_warning: str = ""
    dyn_converged: bool = False
    dyn_cycles: int = -1
    dyn_newton_iterations: int = -1
    dyn_steps: int = -1
    dyn_wall_s: float = 0.0
    dyn_peak_m: float = math.nan
    amplification: float = math.nan
    deviation_from_default: float = math.nan
    check: str = "-"
    stable_steps_per_cycle: int = -1
    ladder: str = ""


def case_of_keys(configs: Sequence[Path]) -> dict[str, tuple[str, str]]:
    """Scene key -> (case name = campaign.name, config file name); configs refused at load have no scenes."""
    out: dict[str, tuple[str, str]] = {}
    refused = study_io.refused_configs(configs)
    for cfg, c in ((load_config(c), c) for c in configs if c.name not in refused):
        for s in cfg.scenes():
            out.setdefault(s.key, (cfg.name, c.name))
    return out


def variant_text(r: SceneResult) -> str:
    """What sets the scene apart: speed, stiffness scale, payload, explicit Exudyn settings."""
    s = r.spec
    parts = [s.mass_model.name, f"{s.speed.value:g} rpm" if s.speed.kind == "rpm" else f"r={s.speed.value:g}"]
    if s.stiffness_scale != 1.0:
        parts.append(f"E x{s.stiffness_scale:g}")
    if s.mass_model.name != "tip" and s.mass_model.payload > 0:
        parts.append(f"payload {s.mass_model.payload:g} kg")
    parts += [f"{k}={v}" for k, v in s.dynamic if k != "damping_ratio"]
    return ", ".join(parts)


def _dyn(r: SceneResult) -> np.ndarray | None:
    return np.column_stack([r.dynamic[c] for c in COMPONENTS]) if r.dynamic else None


def is_default(r: SceneResult) -> bool:
    """Resolved Exudyn settings equal to the defaults (damping ratio aside; a field the stored settings
    lack counts as its legacy value, see ``compare.solvers.dynamic.legacy_defaults``)."""
    from exudyn_models import DynamicSettings

    stored = {**legacy_defaults(), **r.dynamic_settings}
    d = asdict(DynamicSettings())
    return all(stored.get(k) == v for k, v in d.items() if k != "damping_ratio")


def ladder_search(r: SceneResult) -> tuple[int, str]:
    """For a Newton failure: the refinement ladder's search for settings that run through.  A scene
    whose run used the ladder failed on every rung: (-1, what was tried, from the stored message); one
    that ran without it is rerun with the ladder on.  Returns (steps per cycle of the first attempt that
    ran through, or -1; the attempts, one line)."""
    from compare.solvers.dynamic import attempts_text
    from exudyn_models import SimulationError, simulate_steady_state

    if r.dynamic_settings.get("refine") is True:
        return -1, r.message.split("Tried: ", 1)[1] if "Tried: " in r.message else ""
    try:
        res = simulate_steady_state(ked_scene(r), replace(build_settings(r.spec), refine=True))
    except SimulationError as exc:
        return -1, attempts_text(exc.attempts)
    return int((res.solved_settings or res.settings).steps_per_cycle), attempts_text(res.attempts)


def refused_row(config: str, message: str) -> CaseRow:
    """The row of a case whose config is refused at load (nothing runs; the reason is the result)."""
    return CaseRow(case=config.split("_", 1)[-1].removesuffix(".toml").replace("_", "-"), config=config, key="",
                   label="", variant="", speed_ratio=math.nan, rpm=math.nan, status="refused", stage="load",
                   error_type="ConfigError", message=message[:400])


def case_rows(results: Sequence[SceneResult], cases: dict[str, tuple[str, str]], ladder: bool = True) -> list[CaseRow]:
    """One row per stored scene of the stability campaign (in config order)."""
    by_key = {r.key: r for r in results}
    defaults = {family_key(r.spec): r for r in results if r.ok and is_default(r)}
    rows = []
    for key, (case, config) in cases.items():
        r = by_key.get(key)
        if r is None:
            continue
        qs, warn = None, ""
        if r.crank_angle is not None and math.isfinite(r.rpm):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                q = solve_quasi_static(ked_scene(r))
            warn = "; ".join(sorted({type(w.message).__name__ for w in caught}))
            qs = quasi_report(q.deflection, q.condition, q.flagged, q.transmission_angle, q.crank_angle)
        d = _dyn(r)
        dyn_peak = peak(d) if d is not None else math.nan
        amp = dyn_peak / qs.peak_unflagged_m if (qs is not None and qs.peak_unflagged_m > 0) else math.nan
        base = defaults.get(family_key(r.spec))
        dev = deviation(d, _dyn(base)) if (d is not None and base is not None and base.key != r.key) else None
        ratio = r.speed_ratio
        finite = d is not None and bool(np.all(np.isfinite(d)))
        verdict = check(r.ok, finite, bool(r.stat("dynamic", "converged", False)), ratio, amp, dev,
                        near_toggle=bool(qs is not None and qs.flagged_deg))
        stable, log = -1, ""
        if ladder and r.error_type == "SimulationError":
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                stable, log = ladder_search(r)
        elif r.stat("dynamic", "cycles", -1) >= 0 and r.error_type != "SimulationError":
            stable = int(r.dynamic_settings.get("steps_per_cycle", -1))
        rows.append(CaseRow(
            case=case, config=config, key=key, label=r.spec.label, variant=variant_text(r), speed_ratio=ratio,
            rpm=r.rpm, status=r.status, stage=r.stage, error_type=r.error_type, message=r.message[:400],
            **(dict(qs_peak_m=qs.peak_m, qs_peak_unflagged_m=qs.peak_unflagged_m, qs_condition_max=qs.condition_max,
                    qs_flagged_deg=",".join(f"{x:g}" for x in qs.flagged_deg),
                    qs_toggle_distance_deg=qs.toggle_distance_deg, qs_nonfinite=qs.nonfinite) if qs else {}),
            qs_warning=warn,
            dyn_converged=bool(r.stat("dynamic", "converged", False)), dyn_cycles=r.stat("dynamic", "cycles", -1),
            dyn_newton_iterations=r.stat("dynamic", "newton_iterations", -1), dyn_steps=r.stat("dynamic", "steps", -1),
            dyn_wall_s=r.stat("dynamic", "wall_s", 0.0), dyn_peak_m=dyn_peak, amplification=amp,
            deviation_from_default=math.nan if dev is None else dev, check=verdict,
            stable_steps_per_cycle=stable, ladder=log))
    return rows


def run_study(out: Path = OUT, *, workers: int | None = 2, fresh: bool = True, readme: Path = README,
              ladder: bool = True, progress: bool = True, retry_failed: bool = False) -> dict:
    """The whole study (see module docstring); returns a small summary dict."""
    t0 = time.perf_counter()
    configs = sorted(CONFIG_DIR.glob("*.toml"))
    summaries = study_io.run_configs(configs, out, workers=workers, fresh=fresh, progress=progress,
                                     retry_failed=retry_failed)
    t_campaign = time.perf_counter() - t0
    results = store.read_scenes(out)
    rows = case_rows(results, case_of_keys(configs), ladder=ladder)
    rows += [refused_row(c, m) for c, m in study_io.refused_configs(configs).items()]
    from exudyn_models import DynamicSettings

    attrs = {"name": SECTION, "created_utc": store.utc_now(), "defaults": asdict(DynamicSettings()),
             "campaign_wall_s": t_campaign, "study_wall_s": time.perf_counter() - t0, "workers": workers or 0,
             "configs": [f"results/studies/stability/{c.name}" for c in configs],
             "scenes": sum(s.total for s in summaries), "lost": sum(s.lost for s in summaries),
             "git_commit": store.git_commit()}
    study_io.write_tables(out, {"cases": rows}, attrs)
    report(out, readme)
    return {"out": str(out), "wall_s": attrs["study_wall_s"], "scenes": len(rows)}


def report(out: Path = OUT, readme: Path = README) -> Path:
    """The README section from the stored ``/study/cases`` table of ``out`` (no computation)."""
    tables, attrs = study_io.read_tables(out)
    return write_section(readme, SECTION, stability_report.markdown(tables, attrs))


def run(paths: StudyPaths, *, workers: int = 2, fresh: bool = False, report_only: bool = False,
        progress: bool = False, echo: Callable[[str], object] = print, ladder: bool = True,
        retry_failed: bool = False) -> dict:
    """The study with the common signature (see :func:`ked_research.run`); ``retry_failed``:
    recompute the scenes stored as failed."""
    out = paths.studies / OUT.name
    if report_only:
        return {"out": str(out), "readme": str(report(out, paths.readme))}
    if fresh:
        remove_outputs([out], echo)
    return run_study(out, workers=workers, fresh=False, readme=paths.readme, ladder=ladder, progress=progress,
                     retry_failed=retry_failed)
