"""The prediction columns of the Exudyn-confirmed tables recomputed by today's code.

A row of ``/threshold`` or ``/confirm`` holds the measured errors (quasi-static and linear against Exudyn)
and the prediction the check makes from the quasi-static and linear models alone (``qs_vs_linear``,
``linear_flags``, ``floquet_max_abs``).  The check's margins are calibrated on the pair, so the prediction
must be the one today's linear model makes: after the linear model changes, :func:`repredict` solves every
row's scene again with the ``quasi_static`` and ``linear`` solvers (no Exudyn: the measured columns are kept)
and replaces those three columns.  The file attribute :data:`ATTR` records, per table, the harness version
and commit that made its prediction columns; a table without an entry predates it and is re-predicted.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare import metrics
from compare import solvers as registry
from compare.execute import frame, solve_one
from ked_research.atlas import store as atlas_store
from ked_research.atlas.compute import flag_bits, spec_of, xy
from ked_research.atlas.generate import Linkage
from ked_research.atlas.kinds import kind_of

ATTR = "predicted_by"
"""Atlas file attribute (JSON: table -> {"harness_version", "git_commit"}) of the code behind each table's
prediction columns."""
COLUMNS = ("qs_vs_linear", "linear_flags", "floquet_max_abs")


@dataclass(frozen=True)
class Prediction:
    """The check's prediction at one stored scene: quasi-static vs linear history error [1] (nan when a
    solver failed), linear flag bits, max |Floquet multiplier| [1]."""

    key: str
    qs_vs_linear: float
    linear_flags: int
    floquet_max_abs: float


def predict(linkage: Linkage, key: str, mechanism: str, mass_model: str, r: float) -> Prediction:
    """Quasi-static and linear solve of one stored scene (on a worker)."""
    mm = next(m for m in linkage.mass_models if m.name == mass_model)
    spec = spec_of(linkage, mechanism, mm, r)
    try:
        fr = frame(spec)
    except Exception:  # noqa: BLE001 - a scene that cannot be set up has no prediction
        return Prediction(key, math.nan, 0, math.nan)
    qs, lin = (solve_one(registry.get(n), spec, fr.scene) for n in ("quasi_static", "linear"))
    e = metrics.history_error(xy(qs), xy(lin)) if qs.ok and lin.ok else math.nan
    return Prediction(key, e, flag_bits(lin.flags), float(lin.stats.get("floquet_max_abs", math.nan)))


def stale_tables(path: Path, tables: tuple[str, ...] = ("threshold", "confirm")) -> list[str]:
    """The tables of the atlas file whose prediction columns no record says were made by a known code."""
    done = atlas_store.attrs(path).get(ATTR, {})
    done = done if isinstance(done, dict) else {}
    return [t for t in tables if t not in done and atlas_store.read(path, t)]


def repredict(path: Path, tables: tuple[str, ...] | None = None, *, seed: int = 0, workers: int = 2,
              scheduler: str | None = None, progress: bool = False,
              echo: Callable[[str], Any] = print) -> dict[str, int]:
    """Recompute the prediction columns of ``tables`` (default: the stale ones), one commit per table;
    returns the rows recomputed per table."""
    out: dict[str, int] = {}
    for table in stale_tables(path) if tables is None else tables:
        cols = atlas_store.read(path, table)
        if len(cols.get("key", [])):
            echo(f"atlas: {len(cols['key'])} {table} scene(s) to predict again with today's linear model")
            new = _predictions(cols, kind_of(path).candidate, seed, workers=workers, scheduler=scheduler,
                               progress=progress,
                               label=f"{table} prediction")
            _commit(path, table, cols, new)
            out[table] = len(cols["key"])
    return out


def _predictions(cols: dict[str, np.ndarray], candidate: Callable[[int, int], Any], seed: int,
                 **run: Any) -> dict[str, list[Any]]:
    """The prediction columns of a table's rows, in row order (``candidate(seed, index)``: the atlas kind's
    linkage drawn at an index)."""
    from ked_research.atlas.run import run_records

    keys = [str(k) for k in cols["key"]]
    links = {int(i): candidate(seed, int(i)) for i in set(np.asarray(cols["linkage"], float).astype(int))}
    rows = [(k, int(cols["linkage"][i]), str(cols["mechanism"][i]), str(cols["mass_model"][i]), float(cols["r"][i]))
            for i, k in enumerate(keys)]
    found: dict[str, Prediction] = {}
    run_records(rows, predict, lambda recs: found.update({p.key: p for p in recs}),
                lambda row, reason: [Prediction(row[0], math.nan, 0, math.nan)],
                args=lambda row: (links[row[1]], row[0], *row[2:]), **run)
    return {c: [getattr(found[k], c) for k in keys] for c in COLUMNS}


def _commit(path: Path, table: str, cols: dict[str, np.ndarray], new: dict[str, list[Any]]) -> None:
    """Replace ``table`` with its new prediction columns and record the code that made them."""
    from compare import store

    with store.writer_lock(path):
        meta = atlas_store.attrs(path)
        record = {**(meta.get(ATTR) if isinstance(meta.get(ATTR), dict) else {}),
                  table: {k: store.provenance().get(k) for k in ("harness_version", "git_commit")}}
        whole = {c: (list(v) if np.ndim(v) == 1 else [tuple(x) for x in v]) for c, v in cols.items()}
        atlas_store.write(path, {k: meta[k] for k in ("seed", "ratios", "ranges", "settings")} | {ATTR: record},
                          replaces={table: {**whole, **new}})
