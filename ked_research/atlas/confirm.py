"""The Exudyn-confirmed sample of the atlas: a stratified set of scenes run by all three solvers.

Selection (:func:`select`, pure and seeded): the families whose quasi-static 10 % limit r10 was crossed
on the grid, per mass model (the sample split evenly over the four), sorted by r10 and cut into equal
strata, one family drawn from each stratum; each family at r = f x r10 for f in :data:`FACTORS` (capped
at the top of the atlas's ratio grid, duplicates dropped), so the scenes sit around each family's limits
and reach past them, where the linear model's own limit lies.  Every scene is the atlas's campaign scene
(:func:`ked_research.atlas.compute.spec_of`) run by the registered ``quasi_static``, ``linear`` and
``dynamic`` solvers with default settings (:func:`compare.execute.solve_one`); errors are
:mod:`compare.metrics` vector history errors against Exudyn.  A failed solver is stored with its reason.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare import metrics
from compare import solvers as registry
from compare.execute import frame, solve_one
from compare.tables import columns
from ked_quasi.massmodel import MASS_MODELS
from ked_research.atlas import store as atlas_store
from ked_research.atlas.compute import RATIOS, flag_bits, spec_of, xy
from ked_research.atlas.generate import Linkage
from ked_research.atlas.lumps import ATTR, lumping

FACTORS = (0.6, 1.0, 1.4, 2.0, 3.0)
"""Speed ratios of a confirmed family as multiples of its quasi-static 10 % limit."""


@dataclass(frozen=True)
class ConfirmPoint:
    """One scene to confirm: family, multiple of its r10, speed ratio r, the family's atlas r10."""

    linkage: int
    mechanism: str
    mass_model: str
    factor: float
    r: float
    atlas_r10: float

    @property
    def key(self) -> str:
        return f"{self.linkage}/{self.mechanism}/{self.mass_model}/{self.r:.6g}"


@dataclass(frozen=True)
class ConfirmRecord:
    """A confirmed scene: history / peak errors [1] against Exudyn (nan when a solver failed), the
    quasi-static error against the linear model, Exudyn's wall time [s], the peak Exudyn deflection
    over the shortest link [1], linear flag bits and max |Floquet multiplier| (defaults: not computed)."""

    key: str
    linkage: int
    mechanism: str
    mass_model: str
    factor: float
    r: float
    atlas_r10: float
    status: str
    reason: str
    qs_vs_dyn: float = math.nan
    linear_vs_dyn: float = math.nan
    qs_vs_linear: float = math.nan
    qs_peak_vs_dyn: float = math.nan
    linear_peak_vs_dyn: float = math.nan
    deflection_ratio: float = math.nan
    floquet_max_abs: float = math.nan
    linear_flags: int = 0
    dyn_wall_s: float = math.nan


def _strata_pick(rows: list[int], r10: np.ndarray, k: int, rng: np.random.Generator) -> list[int]:
    order = sorted(rows, key=lambda i: r10[i])
    return [int(rng.choice(chunk)) for chunk in np.array_split(np.array(order), min(k, len(order))) if len(chunk)]


def select(families: dict[str, np.ndarray], n: int, seed: int = 0, r_max: float = RATIOS[-1],
           mass_models: Sequence[str] = MASS_MODELS) -> list[ConfirmPoint]:
    """The stratified sample of about ``n`` scenes over ``mass_models`` (the atlas kind's; see the module
    docstring)."""
    rng = np.random.default_rng([seed, 1])
    r10 = np.asarray(families.get("r10", []), float)
    crossed = [i for i, s in enumerate(families.get("r10_status", [])) if s == "crossed" and np.isfinite(r10[i])]
    points: list[ConfirmPoint] = []
    per_mm = [n // len(mass_models) + (j < n % len(mass_models)) for j in range(len(mass_models))]
    for mm, quota in zip(mass_models, per_mm):
        rows = [i for i in crossed if families["mass_model"][i] == mm]
        picked = _strata_pick(rows, r10, math.ceil(quota / len(FACTORS)), rng) if rows and quota else []
        mine = [p for i in picked for p in _family_points(families, i, r_max)]
        points += mine[:quota]
    return points


def _family_points(families: dict[str, np.ndarray], i: int, r_max: float) -> list[ConfirmPoint]:
    r10 = float(families["r10"][i])
    rs = dict.fromkeys(round(min(f * r10, r_max), 6) for f in FACTORS)
    return [ConfirmPoint(int(families["linkage"][i]), str(families["mechanism"][i]), str(families["mass_model"][i]),
                         round(r / r10, 4), r, r10) for r in rs]


def confirm_scene(linkage: Linkage, point: ConfirmPoint) -> ConfirmRecord:
    """Quasi-static, linear and Exudyn on one scene (on a worker)."""
    mm = next(m for m in linkage.mass_models if m.name == point.mass_model)
    spec = spec_of(linkage, point.mechanism, mm, point.r)
    base = dict(key=point.key, **asdict(point))
    try:
        fr = frame(spec)
    except Exception as exc:  # cannot be set up
        return failed_confirm(point, f"setup: {exc}")
    sol = {name: solve_one(registry.get(name), spec, fr.scene) for name in ("quasi_static", "linear", "dynamic")}
    return _record(base, sol, fr.scene.linkage)


def _record(base: dict[str, Any], sol: dict[str, registry.Solution], fb: Any) -> ConfirmRecord:
    nan = math.nan
    h = {k: xy(s) if s.ok else None for k, s in sol.items()}
    dyn, qs, lin = h["dynamic"], h["quasi_static"], h["linear"]
    failed = [f"{k}: {s.message}" for k, s in sol.items() if not s.ok]
    shortest = shortest_link(fb)

    def err(fn: Callable[[np.ndarray, np.ndarray], float], a: np.ndarray | None, b: np.ndarray | None) -> float:
        return fn(a, b) if a is not None and b is not None else nan

    return ConfirmRecord(
        **base, status="ok" if dyn is not None else "failed", reason="; ".join(failed)[:500],
        qs_vs_dyn=err(metrics.history_error, qs, dyn), linear_vs_dyn=err(metrics.history_error, lin, dyn),
        qs_vs_linear=err(metrics.history_error, qs, lin), qs_peak_vs_dyn=err(metrics.peak_error, qs, dyn),
        linear_peak_vs_dyn=err(metrics.peak_error, lin, dyn),
        deflection_ratio=metrics.peak(dyn) / shortest if dyn is not None else nan,
        floquet_max_abs=float(sol["linear"].stats.get("floquet_max_abs", nan)),
        linear_flags=flag_bits(sol["linear"].flags), dyn_wall_s=float(sol["dynamic"].stats.get("wall_s", nan)),
    )


def shortest_link(linkage: Any) -> float:
    """The shortest link of an analysed linkage [m] (a four-bar's five lengths, a slider-crank's two)."""
    if hasattr(linkage, "shortest_link"):
        return float(linkage.shortest_link)
    return min(linkage.crank, linkage.coupler, linkage.follower, linkage.extender, linkage.ground)


def confirm_columns(records: Sequence[ConfirmRecord]) -> dict[str, list[Any]]:
    return columns([asdict(rec) for rec in records])


def run_confirm(path: Path, *, n: int = 200, seed: int = 0, workers: int = 2, scheduler: str | None = None,
                progress: bool = False, echo: Callable[[str], Any] = print) -> dict[str, int]:
    """Confirm the sample's scenes not yet stored in the atlas file (resumable)."""
    from ked_research.atlas.kinds import kind_of

    atlas_store.check_atlas(path, {"seed": seed})  # the sample's linkages are regenerated from the seed
    mms = kind_of(path).mass_models
    return confirm_points(path, select(atlas_store.read(path, "families"), n, seed, mass_models=mms), "confirm", seed,
                          workers=workers, scheduler=scheduler, progress=progress, echo=echo)


def confirm_points(path: Path, points: Sequence[ConfirmPoint], table: str, seed: int, *, workers: int,
                   scheduler: str | None, progress: bool, echo: Callable[[str], Any]) -> dict[str, int]:
    """Run :func:`confirm_scene` on the ``points`` not yet stored in ``table`` of the atlas file (whose
    linkages are regenerated from ``seed``) and append their records there; returns the counts."""
    from compare import store
    from ked_research.atlas.run import run_records

    done = set(atlas_store.read(path, table).get("key", []))
    todo = [p for p in points if p.key not in done]
    what = "scene(s)" if table == "confirm" else f"{table} scene(s)"
    if todo:
        echo(f"atlas: {len(todo)} {what} to confirm with Exudyn")
        t0 = time.perf_counter()
        from ked_research.atlas.kinds import kind_of

        candidate = kind_of(path).candidate
        links = {p.linkage: candidate(seed, p.linkage) for p in todo}
        with store.writer_lock(path):
            info = atlas_store.attrs(path)
            meta = {k: info[k] for k in ("seed", "ratios", "ranges", "settings")}
            if not done:  # a new table: its rows are made with today's lumping
                made = info.get(ATTR) if isinstance(info.get(ATTR), dict) else {}
                meta[ATTR] = {**made, table: lumping()}
            run_records(todo, confirm_scene,
                        lambda recs: atlas_store.write(path, meta, appends={table: confirm_columns(recs)}),
                        lambda p, reason: [failed_confirm(p, reason)], args=lambda p: (links[p.linkage], p),
                        workers=workers, scheduler=scheduler, progress=progress, label=table)
            atlas_store.compact(path)
        echo(f"atlas: confirmed {len(todo)} {what} in {time.perf_counter() - t0:.0f} s")
    return {"sample": len(points), "computed": len(todo), "skipped": len(points) - len(todo)}


def failed_confirm(p: ConfirmPoint, reason: str) -> ConfirmRecord:
    """The record of a scene that could not be confirmed at all."""
    return ConfirmRecord(key=p.key, **asdict(p), status="failed", reason=reason[:500])
