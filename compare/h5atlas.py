"""The atlas file's layout (schema ``ked-harness/atlas`` version 1, described in :mod:`ked_research.atlas.store`)
and its checks: what ``ked inspect ATLAS --verify`` reports.  Imports no writer, so that
:func:`compare.store.verify` can check an atlas file too."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from compare import tables

SCHEMA = "ked-harness/atlas"
SCHEMA_VERSION = 1

ATTRS = ("schema", "schema_version", "created_utc", "modified_utc", "seed", "ratios", "ranges", "settings")
"""Root attributes every atlas file has (``ratios``, ``ranges``, ``settings`` JSON)."""
TABLES = ("linkages", "families", "confirm", "threshold")
PER_RATIO = ("history_error", "peak_error", "floquet_max_abs", "linear_error_estimate", "one_mode_error", "flags",
             "code")
"""The per-ratio columns of ``/families``: (rows, ratios)."""
CODES = (0, 1, 2, 3)
"""Per-ratio codes of ``/families``: 0 ok, 1 unstable, 2 failed, 3 not computed."""


def verify(path: Path) -> list[str]:
    """Integrity and schema check of an atlas file (the checks of ``ked inspect --verify``): the root
    attributes, every table (columns as long as its rows, with units; per-ratio columns one value per
    ratio), per-ratio codes and statuses known, every family and confirmed scene of a linkage drawn."""
    try:
        with h5py.File(path, "r") as f:
            return _verify(f)
    except Exception as exc:  # HDF5 reports damage as OSError, KeyError, ValueError or RuntimeError
        return [f"{path}: unreadable ({type(exc).__name__}: {str(exc).splitlines()[0][:200] if str(exc) else ''})"]


def _verify(f: h5py.File) -> list[str]:
    p = [f"/: missing file attribute {a!r}" for a in ATTRS if a not in f.attrs]
    version = str(tables.text(f.attrs.get("schema_version", "")))
    if tables.text(f.attrs.get("schema", "")) != SCHEMA or version != str(SCHEMA_VERSION):
        return p + [f"/: not an atlas file of schema {SCHEMA!r} version {SCHEMA_VERSION}"]
    ratios = None
    for name in ("ratios", "ranges", "settings", "verdict_margins"):
        if name in f.attrs:
            try:
                value = json.loads(tables.text(f.attrs[name]))
            except (TypeError, ValueError):
                p.append(f"/: attribute {name} is not JSON")
                continue
            if name == "ratios":
                r = np.asarray(value, dtype=float) if isinstance(value, list) else np.array([])
                if not (r.ndim == 1 and len(r) and np.all(np.isfinite(r)) and np.all(r > 0) and np.all(np.diff(r) > 0)):
                    p.append("/: attribute ratios is not an increasing list of positive speed ratios")
                else:
                    ratios = len(r)
    for name in TABLES:
        if name in f:
            p += tables.verify_table(f[name], f"/{name}", ratios, PER_RATIO if name == "families" else ())
    if "linkages" not in f:
        p.append("/: missing table /linkages")
    return p if p else _verify_rows(f)


def _verify_rows(f: h5py.File) -> list[str]:
    """Row-level checks of tables whose shapes are right."""
    p = []
    links = tables.read_table(f["linkages"])
    index = links.get("index", np.array([]))
    if len(set(index.tolist())) != len(index):
        p.append("/linkages/index: a linkage appears twice")
    drawn = set(np.asarray(index, dtype=float).tolist())
    for name in ("families", "confirm", "threshold"):
        if name not in f:
            continue
        t = tables.read_table(f[name])
        missing = [c for c in ("linkage", "mechanism", "mass_model", "status") if c not in t]
        if missing:
            p.append(f"/{name}: missing column(s) {', '.join(missing)}")
            continue
        orphans = sorted(set(np.asarray(t["linkage"], dtype=float).tolist()) - drawn)
        if orphans:
            p.append(f"/{name}/linkage: {len(orphans)} linkage(s) not in /linkages (first {orphans[0]:g})")
        unknown = sorted(set(t["status"].tolist()) - {"ok", "failed"})
        if unknown:
            p.append(f"/{name}/status: unknown status {unknown[0]!r}")
        if name == "families" and "code" in t and not np.isin(t["code"], CODES).all():
            p.append(f"/families/code: values other than {CODES} (0 ok, 1 unstable, 2 failed, 3 not computed)")
    return p
