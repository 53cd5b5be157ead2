"""The atlas file (``results/atlas/atlas.h5``, schema ``ked-harness/atlas`` version 1).

Plain HDF5, the harness's tables (:mod:`compare.tables`: one dataset per column with ``units`` and
``description`` attributes, text as UTF-8, per-ratio columns as (rows, ratios) arrays), written only
through :func:`compare.store.transaction` (a private copy renamed atomically onto the file), appended
in batches, so a killed run loses only the linkages still being computed.

```
/                 attrs schema, schema_version, created_utc, modified_utc, seed, ratios (json),
                  ranges (json: the generator's), settings (json: damping, step, stop error), provenance
/linkages         one row per candidate drawn: index, accepted (uint8), reason, the drawn design,
                  mechanisms, cognate_reason, min_transmission_deg (source and cognate)
/families         one row per family (linkage, mechanism, mass model): see compute.FamilyRecord;
                  per-ratio columns history_error, peak_error, floquet_max_abs, linear_error_estimate,
                  one_mode_error (float, (rows, ratios)), flags (bits), code (0 ok, 1 unstable, 2 failed,
                  3 not computed); limits r5_status, r5, r5_half_bracket, r10_* (r5, r10 interpolated: a
                  record; the analysis uses first crossings); one_mode_r5, one_mode_r10
/confirm          one row per Exudyn-confirmed scene (ked_research.atlas.confirm.ConfirmRecord)
/threshold        one row per threshold scene (the same columns; ked_research.atlas.threshold)
```

The root attribute ``verdict_margins`` (JSON, tolerance in percent -> record) holds the check's margins
chosen from /threshold (:mod:`ked_research.atlas.calibration`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import store, tables
from compare.h5atlas import CODES, SCHEMA, SCHEMA_VERSION, verify  # noqa: F401 (the atlas file's names)


class AtlasFileError(ValueError):
    """A file that is not an atlas file, or an atlas of another seed or ratio grid."""


def check_atlas(path: Path, meta: dict[str, Any] | None = None) -> None:
    """Refuse a file that is not an atlas (or, given ``meta``, one made with another seed, ratio grid,
    generator ranges or settings: resuming it would mix two atlases)."""
    if not path.exists():
        return
    try:
        with h5py.File(path, "r") as f:
            schema, attrs = f.attrs.get("schema"), dict(f.attrs)
    except OSError as exc:
        raise AtlasFileError(f"{path}: not an HDF5 file ({exc}); refusing to write into it") from None
    if schema != SCHEMA:
        raise AtlasFileError(f"{path}: not an atlas file (schema {schema!r}, expected {SCHEMA!r}); refusing to "
                             "write into it")
    for key, value in (meta or {}).items():
        if key in attrs and json.loads(attrs[key]) != json.loads(json.dumps(value)):
            raise AtlasFileError(f"{path}: an atlas of {key} {attrs[key]}, not {json.dumps(value)}; use --fresh "
                                 "or another results directory")


def append(f: h5py.File, table: str, columns: dict[str, Sequence[Any]]) -> None:
    """Append rows (column -> values, equal lengths; 2D values for per-ratio columns) to ``table``."""
    tables.append_rows(f, table, columns)


def replace(f: h5py.File, table: str, columns: dict[str, Sequence[Any]]) -> None:
    """Replace ``table`` by the given columns."""
    tables.write_table(f, table, columns, extendable=True)


def write(path: Path, meta: dict[str, Any], *, appends: dict[str, dict[str, Sequence[Any]]] | None = None,
          replaces: dict[str, dict[str, Sequence[Any]]] | None = None) -> None:
    """One atomic commit: file attributes, replaced tables, appended rows."""
    with store.transaction(path) as f:
        if "schema" not in f.attrs:
            f.attrs.update({"schema": SCHEMA, "schema_version": SCHEMA_VERSION, "created_utc": store.utc_now()})
        f.attrs["modified_utc"] = store.utc_now()
        for k, v in {**meta, **store.provenance()}.items():
            f.attrs[k] = json.dumps(v) if k in meta else v
        for table, cols in (replaces or {}).items():
            replace(f, table, cols)
        for table, cols in (appends or {}).items():
            if cols and len(next(iter(cols.values()))):
                append(f, table, cols)


def compact(path: Path) -> None:
    """Rewrite the file in one piece (appending in small batches leaves small chunks, and HDF5 does not give
    back the space of replaced tables): a new file is written with :func:`compare.store.transaction`
    next to it and renamed onto it atomically."""
    tables = {t: read(path, t) for t in ("linkages", "families", "confirm", "threshold")}
    with h5py.File(path, "r") as f:
        file_attrs = dict(f.attrs)
    fresh = path.with_name(path.name + ".compact")
    fresh.unlink(missing_ok=True)
    with store.transaction(fresh) as f:
        f.attrs.update(file_attrs)
        for name, cols in tables.items():
            if cols:
                replace(f, name, {k: list(v) if v.ndim == 1 else [tuple(row) for row in v] for k, v in cols.items()})
    os.replace(fresh, path)


def read(path: Path, table: str) -> dict[str, np.ndarray]:
    """One table, column -> array (text as str objects); empty if absent."""
    with h5py.File(path, "r") as f:
        return tables.read_table(f[table]) if table in f else {}


def attrs(path: Path) -> dict[str, Any]:
    """File attributes, JSON ones decoded."""
    with h5py.File(path, "r") as f:
        out = {}
        for k, v in f.attrs.items():
            v = v.decode() if isinstance(v, bytes) else v
            try:
                out[k] = json.loads(v) if isinstance(v, str) else v
            except json.JSONDecodeError:
                out[k] = v
        return out



def summary(path: Path) -> dict[str, Any]:
    """What ``ked inspect`` shows of an atlas file: its attributes, the linkages drawn and accepted, the
    families by status and per-ratio code, the confirmed and threshold scenes."""
    meta = attrs(path)
    out: dict[str, Any] = {"kind": "atlas", **{k: meta.get(k) for k in ("schema", "schema_version", "created_utc",
                                                                        "modified_utc", "seed", "harness_version")}}
    out["ratios"] = meta.get("ratios")
    links = read(path, "linkages")
    out["linkages"] = len(links.get("index", ()))
    out["accepted"] = int(np.sum(links["accepted"])) if "accepted" in links else 0
    fam = read(path, "families")
    out["families"] = len(fam.get("status", ()))
    status = fam.get("status", np.array([], dtype=object))
    out["families_by_status"] = {str(k): int(v) for k, v in zip(*np.unique(status, return_counts=True))}
    codes = np.asarray(fam.get("code", np.zeros((0, 0))))
    out["ratio_points_by_code"] = {name: int(np.sum(codes == c)) for c, name in
                                   zip(CODES, ("ok", "unstable", "failed", "not computed"))}
    for name in ("confirm", "threshold"):
        t = read(path, name)
        out[name] = len(t.get("status", ()))
        out[f"{name}_ok"] = int(np.sum(t["status"] == "ok")) if "status" in t else 0
    margins = meta.get("verdict_margins")
    out["verdict_margin_tolerances_percent"] = sorted(margins) if isinstance(margins, dict) else []
    return out


def describe(s: dict[str, Any]) -> list[str]:
    """The lines of ``ked inspect`` for an atlas :func:`summary`."""
    ratios = s.get("ratios") or []
    codes = ", ".join(f"{n} {k}" for k, n in s["ratio_points_by_code"].items())
    lines = [f"atlas file (schema {s['schema']} version {s['schema_version']}), seed {s['seed']}, created "
             f"{s['created_utc']}, modified {s['modified_utc']}, harness {s.get('harness_version')}",
             f"{s['linkages']} linkages drawn, {s['accepted']} accepted; {s['families']} families ("
             + ", ".join(f"{n} {k}" for k, n in s["families_by_status"].items()) + ")",
             f"{len(ratios)} speed ratios r = Omega/omega1_min"
             + (f" from {min(ratios):g} to {max(ratios):g}" if ratios else "") + f"; ratio points: {codes}",
             f"{s['confirm']} Exudyn-confirmed scenes ({s['confirm_ok']} ok), {s['threshold']} threshold scenes "
             f"({s['threshold_ok']} ok); verdict margins for tolerances "
             + (", ".join(f"{t} %" for t in s["verdict_margin_tolerances_percent"]) or "none")]
    return lines
