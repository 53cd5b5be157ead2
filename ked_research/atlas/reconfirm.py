"""Exudyn-confirmed rows whose quasi-static answer an older mass lumping made, confirmed again by today's.

The columns of a ``/threshold`` or ``/confirm`` row (quasi-static and linear against Exudyn and each other)
depend on the lumps per link of the quasi-static answer and on the linear model's dynamic lumps for the mass
models that lump a link's mass (extender, distributed).  The file attribute :data:`ATTR` records, per table,
the lumping its rows were made with; a table without an entry was made with :data:`LEGACY`.  When that differs
from today's (:func:`lumping`), :func:`reconfirm` runs those rows again (all three solvers,
:func:`ked_research.atlas.confirm.confirm_scene`) and replaces them in place; rows already done are listed in
:data:`DONE_ATTR`, so an interrupted run resumes.  The other mass models' rows do not depend on the lumps.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from ked_linear.lumping import LUMPED
from ked_research.atlas import store as atlas_store
from ked_research.atlas.confirm import ConfirmPoint, confirm_scene, failed_confirm
from ked_research.atlas.kinds import kind_of
from ked_research.atlas.lumps import ATTR, LEGACY, lumping

DONE_ATTR = "reconfirmed"
"""Atlas file attribute (JSON: table -> keys of the rows confirmed again so far by an unfinished run)."""
TABLES = ("threshold", "confirm")


def stale_points(path: Path, table: str) -> list[ConfirmPoint]:
    """The rows of ``table`` that today's lumping would answer differently and no run has redone yet."""
    meta = atlas_store.attrs(path)
    if _dict(meta.get(ATTR)).get(table, LEGACY) == lumping():
        return []
    cols = atlas_store.read(path, table)
    done = set(_dict(meta.get(DONE_ATTR)).get(table, []))
    return [_point(cols, i) for i, k in enumerate(cols.get("key", []))
            if str(cols["mass_model"][i]) in LUMPED and str(k) not in done]


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _point(cols: dict[str, np.ndarray], i: int) -> ConfirmPoint:
    return ConfirmPoint(int(cols["linkage"][i]), str(cols["mechanism"][i]), str(cols["mass_model"][i]),
                        float(cols["factor"][i]), float(cols["r"][i]), float(cols["atlas_r10"][i]))


def reconfirm(path: Path, *, seed: int = 0, workers: int = 2, scheduler: str | None = None,
              progress: bool = False, echo: Callable[[str], Any] = print) -> dict[str, int]:
    """Confirm again the stale rows of every table (see the module docstring); returns the rows per table."""
    from compare import store
    from ked_research.atlas.run import run_records

    out: dict[str, int] = {}
    for table in TABLES:
        if not atlas_store.read(path, table):
            continue
        todo = stale_points(path, table)
        if todo:
            echo(f"atlas: {len(todo)} {table} scene(s) to confirm again with today's lumping {lumping()}")
            links = {p.linkage: kind_of(path).candidate(seed, p.linkage) for p in todo}
            with store.writer_lock(path):
                run_records(todo, confirm_scene, lambda recs, t=table: _commit(path, t, recs),
                            lambda p, reason: [failed_confirm(p, reason)], args=lambda p, lk=links: (lk[p.linkage], p),
                            workers=workers, scheduler=scheduler, progress=progress, label=f"{table} again")
        _finish(path, table)
        out[table] = len(todo)
    if any(out.values()):
        atlas_store.compact(path)  # replaced rows leave the old ones' space behind
    return out


def _commit(path: Path, table: str, records: list[Any]) -> None:
    """Replace the rows of ``records`` (by key) in ``table`` and note their keys as done, in one commit."""
    cols = atlas_store.read(path, table)
    at = {str(k): i for i, k in enumerate(cols["key"])}
    for rec in records:
        for c, v in asdict(rec).items():
            cols[c][at[rec.key]] = v
    meta = atlas_store.attrs(path)
    done = _dict(meta.get(DONE_ATTR))
    done[table] = sorted(set(done.get(table, [])) | {r.key for r in records})
    _write(path, meta, {DONE_ATTR: done}, {table: cols})


def _finish(path: Path, table: str) -> None:
    """Record that ``table`` is made with today's lumps and drop its list of done rows."""
    meta = atlas_store.attrs(path)
    if _dict(meta.get(ATTR)).get(table) == lumping():
        return
    from compare import store
    from ked_research.atlas.repredict import ATTR as PREDICTED_BY

    done = {k: v for k, v in _dict(meta.get(DONE_ATTR)).items() if k != table}
    made = {k: store.provenance().get(k) for k in ("harness_version", "git_commit")}
    _write(path, meta, {ATTR: {**_dict(meta.get(ATTR)), table: lumping()}, DONE_ATTR: done,
                        PREDICTED_BY: {**_dict(meta.get(PREDICTED_BY)), table: made}}, {})


def _write(path: Path, meta: dict[str, Any], extra: dict[str, Any], replaces: dict[str, dict[str, Any]]) -> None:
    keep = {k: meta[k] for k in ("seed", "ratios", "ranges", "settings") if k in meta}
    whole = {t: {c: (list(v) if np.ndim(v) == 1 else [tuple(x) for x in v]) for c, v in cols.items()}
             for t, cols in replaces.items()}
    atlas_store.write(path, keep | extra, replaces=whole)
