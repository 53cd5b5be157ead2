"""The family sweeps of an atlas made by an older code, computed again by today's, in place.

``/families`` holds each family's quasi-static-vs-linear sweep up the ratio grid (:mod:`ked_research.atlas.compute`).
The file attribute :data:`~ked_research.atlas.lumps.ATTR` records the lumping its rows were made with; a table without
an entry was made before the lumping was raised (:data:`~ked_research.atlas.lumps.LEGACY`), by a linear model older
than today's.  When the record differs from today's (:func:`~ked_research.atlas.lumps.lumping`), :func:`resweep`
computes every family again (every mass model: the linear model of the rigid-lump ones changed with it) and
replaces its row; the linkages already redone are listed in :data:`DONE_ATTR`, so an interrupted run resumes.
The Exudyn-confirmed tables are not touched (:mod:`ked_research.atlas.reconfirm` keeps them current).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ked_research.atlas import store as atlas_store
from ked_research.atlas.compute import FamilyRecord, compute_family, failed_record
from ked_research.atlas.kinds import kind_of
from ked_research.atlas.lumps import ATTR, LEGACY, lumping

DONE_ATTR = "reswept"
"""Atlas file attribute (JSON list): indices of the linkages whose families an unfinished run has redone."""
TABLE = "families"


def stale(path: Path) -> bool:
    """Whether the family sweeps of the atlas at ``path`` were made with another lumping than today's."""
    meta = atlas_store.attrs(path)
    return bool(atlas_store.read(path, TABLE)) and _dict(meta.get(ATTR)).get(TABLE, LEGACY) != lumping()


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def resweep(path: Path, *, seed: int = 0, workers: int = 2, scheduler: str | None = None,
            progress: bool = False, echo: Callable[[str], Any] = print) -> int:
    """Compute again the families of a stale atlas (see the module docstring); returns the linkages redone."""
    from compare import store
    from ked_research.atlas.run import LinkageBuffer, family_tasks, run_records

    if not path.exists() or not stale(path):
        return 0
    meta = atlas_store.attrs(path)
    ratios = tuple(float(r) for r in meta["ratios"])
    done = {int(i) for i in meta.get(DONE_ATTR) or []}
    stored = sorted({int(i) for i in atlas_store.read(path, TABLE)["linkage"]})
    kind = kind_of(path)
    sample = kind.generate(len(stored), seed)  # the same draws as the stored linkages (a prefix of the sample)
    todo = [lk for lk in sample.linkages if lk.index in set(stored) - done]
    if todo:
        echo(f"atlas: {len(todo)} linkage(s) to sweep again with today's lumping {lumping()}")
        buffer = LinkageBuffer(todo)

        def commit(recs: list[FamilyRecord]) -> None:
            complete = buffer.add(recs)
            if complete:
                _commit(path, complete)

        def lost(task: Any, reason: str) -> tuple[FamilyRecord, ...]:
            lk, mech, mm = task
            return (failed_record(lk.index, mech, mm, reason, len(ratios)),)

        with store.writer_lock(path):
            run_records(family_tasks(todo), compute_family, commit, lost, args=lambda task: (*task, ratios),
                        workers=workers, scheduler=scheduler, progress=progress, label="families again")
    _finish(path)
    atlas_store.compact(path)  # replaced rows leave the old ones' space behind
    return len(todo)


def _commit(path: Path, records: list[FamilyRecord]) -> None:
    """Replace the rows of ``records`` (by linkage, mechanism, mass model) and note their linkages as done, in
    one commit."""
    from ked_research.atlas.run import family_columns

    cols = atlas_store.read(path, TABLE)
    at = {(int(k), str(m), str(mm)): i
          for i, (k, m, mm) in enumerate(zip(cols["linkage"], cols["mechanism"], cols["mass_model"]))}
    new = family_columns(records)
    for j, rec in enumerate(records):
        i = at[(rec.linkage, rec.mechanism, rec.mass_model)]
        for c in cols:
            cols[c][i] = new[c][j]
    meta = atlas_store.attrs(path)
    done = sorted({int(i) for i in meta.get(DONE_ATTR) or []} | {r.linkage for r in records})
    _write(path, meta, {DONE_ATTR: done}, cols)


def _finish(path: Path) -> None:
    """Record that the families are made with today's lumps and drop the list of done linkages."""
    meta = atlas_store.attrs(path)
    _write(path, meta, {ATTR: {**_dict(meta.get(ATTR)), TABLE: lumping()}, DONE_ATTR: []}, None)


def _write(path: Path, meta: dict[str, Any], extra: dict[str, Any], families: dict[str, np.ndarray] | None) -> None:
    keep = {k: meta[k] for k in ("seed", "ratios", "ranges", "settings") if k in meta}
    whole = {TABLE: {c: (list(v) if np.ndim(v) == 1 else [tuple(x) for x in v]) for c, v in families.items()}} \
        if families is not None else {}
    atlas_store.write(path, keep | extra, replaces=whole)

