"""Run (resume) the atlas: one task per family on the harness's executor, compact records committed in batches.

The tasks (:func:`family_tasks`: a linkage's families, the costliest mass models first) run on
:func:`compare.runner.run_tasks`: ``workers`` local processes, or the Dask cluster at ``scheduler``
(checked first with :func:`compare.runner.probe_scheduler`).  A family is the unit of work, so the
workers stay busy to the end of a run however unequal the linkages are; a linkage is the unit of
storage: its families are committed together once all are computed.  Only this process writes the
atlas file; a linkage whose families are stored is skipped, so rerunning resumes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare import store
from compare.tables import columns
from ked_quasi.massmodel import MASS_MODELS, MassModel
from ked_research.atlas import store as atlas_store
from ked_research.atlas.compute import (
    DAMPING,
    RATIOS,
    STEP_DEG,
    STOP_ERROR,
    TOLERANCES,
    FamilyRecord,
    compute_family,
    failed_record,
    families_of,
)
from ked_research.atlas.generate import Linkage, Reject, Sample
from ked_research.atlas.kinds import FOUR_BAR, AtlasKind

COMMIT_EVERY_S = 10.0
"""Completed linkages are committed together at most this often (each commit copies the file)."""


@dataclass(frozen=True)
class RunSummary:
    """What one run did; ``wall_s`` [s]."""

    linkages: int
    rejects: int
    skipped: int
    computed: int
    families: int
    wall_s: float


def meta(seed: int, ratios: Sequence[float], kind: AtlasKind = FOUR_BAR) -> dict[str, Any]:
    """The file attributes of an atlas run of linkages of ``kind`` (JSON-able)."""
    return {"seed": seed, "ratios": list(ratios), "ranges": kind.ranges(),
            "settings": {"damping_ratio": DAMPING, "step_deg": STEP_DEG, "stop_error": STOP_ERROR,
                         "tolerances": list(TOLERANCES), "direction": "ccw", "solvers": ["quasi_static", "linear"]}}


def linkage_columns(sample: Sample) -> dict[str, list[Any]]:
    """The /linkages table: every candidate drawn, accepted or not, by index."""
    rows = sorted([*sample.linkages, *sample.rejects], key=lambda c: c.index)
    names = ("index", "accepted", "reason", *asdict(rows[0].design)) if rows else ()
    cols: dict[str, list[Any]] = {k: [] for k in names}
    for c in rows:
        ok = not isinstance(c, Reject)
        for k, v in asdict(c.design).items():
            cols[k].append(v)
        cols["accepted"].append(ok)
        cols["reason"].append("" if ok else c.reason)
    text = ("mechanisms", "cognate_reason")
    for name in ("mechanisms", "cognate_reason", "min_transmission_deg", "cognate_min_transmission_deg"):
        if sample.linkages and not hasattr(sample.linkages[0], name):
            continue  # a column of another linkage kind (a slider-crank has no cognate)
        cols[name] = [_linkage_value(c, name) if not isinstance(c, Reject) else ("" if name in text else np.nan)
                      for c in rows]
    return cols


def _linkage_value(c: Any, name: str) -> Any:
    v = getattr(c, name)
    return ",".join(v) if name == "mechanisms" else v


def family_columns(records: Sequence[FamilyRecord]) -> dict[str, list[Any]]:
    """The /families rows of ``records`` (limits flattened to r5_*, r10_*)."""
    rows = []
    for rec in records:
        row = {k: v for k, v in asdict(rec).items() if k not in ("limits", "one_mode_limits")}
        for tol, lim, om in zip(TOLERANCES, rec.limits, rec.one_mode_limits):
            tag = f"r{round(100 * tol)}"
            row.update({f"{tag}_status": lim.status, tag: lim.r_record, f"{tag}_half_bracket": lim.half_bracket,
                        f"one_mode_{tag}": om})
        rows.append(row)
    return columns(rows)


def crashed(linkage: Linkage, reason: str, ratios: Sequence[float]) -> tuple[FamilyRecord, ...]:
    """Records of a linkage whose tasks died (worker killed, ...): every family failed with the reason."""
    return tuple(failed_record(linkage.index, mech, mm, reason, len(ratios)) for mech, mm in families_of(linkage))


FamilyTask = tuple[Linkage, str, MassModel]
"""(linkage, mechanism, mass model): one family to compute."""


def family_tasks(linkages: Sequence[Linkage]) -> list[FamilyTask]:
    """The atlas's tasks: the families of each linkage in turn, within a linkage the costliest mass models
    (most lumps) first, so that a worker's last tasks are short ones."""
    cost = {name: -i for i, name in enumerate(MASS_MODELS)}  # MASS_MODELS: tip, joints, extender, distributed
    return [(lk, mech, mm) for lk in linkages
            for mech, mm in sorted(families_of(lk), key=lambda f: cost.get(f[1].name, 0))]


class LinkageBuffer:
    """Family records held until every family of their linkage is in (then released together, in the
    linkage's family order), so that a stored linkage is always complete."""

    def __init__(self, linkages: Sequence[Linkage]):
        self.expected = {lk.index: families_of(lk) for lk in linkages}
        self.held: dict[int, dict[tuple[str, str], FamilyRecord]] = {}

    def add(self, records: Sequence[FamilyRecord]) -> list[FamilyRecord]:
        """Hold ``records``; returns the records of the linkages now complete."""
        done: list[FamilyRecord] = []
        for rec in records:
            got = self.held.setdefault(rec.linkage, {})
            got[(rec.mechanism, rec.mass_model)] = rec
            order = [(mech, mm.name) for mech, mm in self.expected[rec.linkage]]
            if set(order) <= set(got):
                done += [got[k] for k in order]
                del self.held[rec.linkage]
        return done


def stored_linkages(path: Path) -> set[int]:
    """Indices of the linkages whose families are stored."""
    if not path.exists():
        return set()
    fam = atlas_store.read(path, "families")
    return {int(i) for i in fam.get("linkage", [])}


def run_records(tasks: Sequence[Any], fn: Callable[..., Any], commit: Callable[[list[Any]], None],
                crashed: Callable[[Any, str], Sequence[Any]], *, workers: int, scheduler: str | None,
                args: Callable[[Any], tuple[Any, ...]] = lambda task: (task,), progress: bool = False,
                label: str = "atlas") -> None:
    """``fn(*args(task))`` for every task on :func:`compare.runner.run_tasks`; the records (a task returns one
    or a tuple) are committed at most every :data:`COMMIT_EVERY_S` and at the end; a task that died is
    recorded by ``crashed(task, reason)``."""
    import sys

    from tqdm import tqdm

    from compare.executor import crash_reason, run_tasks

    pending: list[Any] = []
    last = [time.monotonic()]

    def on_result(batch: list[tuple[Any, Any]]) -> None:
        for _, res in batch:
            pending.extend(res if isinstance(res, (tuple, list)) else [res])
        bar.update(len(batch))
        if pending and time.monotonic() - last[0] >= COMMIT_EVERY_S:
            commit(pending[:])
            pending.clear()
            last[0] = time.monotonic()

    with tqdm(total=len(tasks), disable=not progress, file=sys.stderr, desc=label) as bar:
        run_tasks(tasks, fn, args=args, workers=workers, scheduler=scheduler, on_result=on_result,
                  crashed=lambda task, exc: tuple(crashed(task, f"task failed: {crash_reason(exc)}")))
    if pending:
        commit(pending)


def run_atlas(path: Path, *, linkages: int = 1000, seed: int = 0, workers: int = 2, scheduler: str | None = None,
              ratios: Sequence[float] = RATIOS, progress: bool = False,
              echo: Callable[[str], Any] = print, kind: AtlasKind = FOUR_BAR) -> RunSummary:
    """Compute every linkage of ``kind.generate(linkages, seed)`` not yet stored in ``path`` (see module
    docstring)."""
    from compare.executor import exit_if_starting_worker

    exit_if_starting_worker()  # a worker importing a script without a main guard writes nothing
    t0 = time.perf_counter()
    path = store.target(path)
    info = meta(seed, ratios, kind)
    atlas_store.check_atlas(path, info)
    if scheduler:  # an unreachable cluster is reported before anything is written
        from compare.executor import probe_scheduler

        probe_scheduler(scheduler)
    done = stored_linkages(path)
    sample = kind.generate(max(linkages, len(done)), seed)  # a prefix of the same draws: keeps every stored linkage
    todo = [lk for lk in sample.linkages[:linkages] if lk.index not in done]
    store.check_writable(path)
    with store.writer_lock(path):
        from ked_research.atlas.lumps import ATTR, lumping

        made = {} if done else {ATTR: {"families": lumping()}}  # a new atlas: its sweeps use today's lumping
        atlas_store.write(path, {**info, **made}, replaces={"linkages": linkage_columns(sample)})
        if todo:
            _compute(path, todo, info, workers=workers, scheduler=scheduler, ratios=tuple(ratios),
                     progress=progress, echo=echo)
            atlas_store.compact(path)
    n_fam = len(atlas_store.read(path, "families").get("linkage", []))
    return RunSummary(len(sample.linkages), len(sample.rejects), len(sample.linkages) - len(todo), len(todo), n_fam,
                      time.perf_counter() - t0)


def _compute(path: Path, todo: list[Linkage], info: dict[str, Any], *, workers: int, scheduler: str | None,
             ratios: tuple[float, ...], progress: bool, echo: Callable[[str], Any]) -> None:
    where = f"the scheduler {scheduler}" if scheduler else f"{workers} local workers"
    echo(f"atlas: {len(todo)} linkage(s) to compute on {where}")
    t0 = time.perf_counter()
    buffer = LinkageBuffer(todo)

    def commit(recs: list[FamilyRecord]) -> None:
        complete = buffer.add(recs)
        if complete:
            atlas_store.write(path, info, appends={"families": family_columns(complete)})

    def lost(task: FamilyTask, reason: str) -> tuple[FamilyRecord, ...]:
        lk, mech, mm = task
        return (failed_record(lk.index, mech, mm, reason, len(ratios)),)

    run_records(family_tasks(todo), compute_family, commit, lost, args=lambda task: (*task, ratios),
                workers=workers, scheduler=scheduler, progress=progress)
    echo(f"atlas: computed {len(todo)} linkage(s) in {time.perf_counter() - t0:.0f} s")
