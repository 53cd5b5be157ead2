"""The one table format of the harness's HDF5 files: campaign files (``/runs``, ``/scene_table``,
``/solution_table``, ``/metric_table``), the study tables (``/study/<table>``) and the atlas.

A table is a group with one dataset per column (``rows`` attribute = its length), each column
carrying the attributes ``units`` (SI; "1" for every dimensionless number: ratios, counts, flags; "" only
for text) and ``description``.  A table may also hold dimension scales (HDF5 dimension scales naming its
row and inner dimensions, listed in the table's ``dimensions`` attribute): they are not columns.
Encoding: text as UTF-8 strings (written fixed-width, padding compressed away;
variable-length columns of older files are read too), booleans as ``uint8`` 0/1, numbers as float64
(``None`` -> NaN) or, where the writer asks for it, integers as int64; a column of equal-length
sequences is a (rows, k) array.  Columns are gzip-compressed (numbers shuffled first).
Readers get column -> numpy array, text as ``str`` objects.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import h5py
import numpy as np

ROWS = "rows"
UNITS = "units"
DESCRIPTION = "description"
DIMENSIONS = "dimensions"
"""Table attribute: comma-separated names of the table's datasets that are dimension scales, not columns."""
DIMENSIONLESS = "1"
"""The unit of a dimensionless number (ratio, count, flag); text has the unit ""."""

_SUFFIX_UNITS = (("rpm", "rev/min"), ("_rad_s", "rad/s"), ("_kg_m3", "kg/m^3"), ("_hz", "Hz"), ("_Pa", "Pa"),
                 ("_m2", "m^2"), ("_m4", "m^4"), ("_kg", "kg"), ("_deg", "deg"), ("_rad", "rad"), ("_s", "s"),
                 ("_m", "m"))


def units_of_name(name: str) -> str:
    """The unit a column name states by its suffix (``wall_s`` -> s, ``f1_min_hz`` -> Hz, ``peak_m``
    -> m, ``rpm`` -> rev/min), "" if it states none (the naming convention of every table and attribute;
    a number whose name states no unit is dimensionless, :data:`DIMENSIONLESS`)."""
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix) or name.lower().endswith(suffix.lower()):
            return unit
    return ""


def text(v: Any) -> str:
    return v.decode("utf-8") if isinstance(v, (bytes, np.bytes_)) else str(v)


def _is_text(v: Any) -> bool:
    return isinstance(v, (str, bytes, np.str_, np.bytes_))


KINDS = ("text", "flag", "int", "float")
"""Column kinds: UTF-8 text, uint8 0/1 flag, int64, float64."""


def encode(values: Sequence[Any] | np.ndarray, integers: bool = False, kind: str | None = None) -> np.ndarray:
    """One column as the array it is stored as (``kind`` one of :data:`KINDS`, else inferred): text ->
    UTF-8 bytes (fixed width), booleans -> uint8, numbers -> float64 with None -> NaN (``integers``: a
    column of integers stays int64), a column of equal-length sequences -> 2-D."""
    if isinstance(values, np.ndarray) and values.dtype.kind in "fiubS" and (kind != "text" or values.dtype.kind == "S"):
        if kind in ("flag", "int", "float"):
            return values.astype({"flag": np.uint8, "int": np.int64, "float": np.float64}[kind])
        return values.astype(np.uint8) if values.dtype.kind == "b" else values
    if kind == "text":
        values = ["" if v is None else v if _is_text(v) else str(v) for v in values]
    elif kind == "flag":
        return np.array([bool(v) for v in values], dtype=np.uint8)
    elif kind == "int":
        return np.array([int(v) for v in values], dtype=np.int64)
    elif kind == "float":
        return np.array([np.nan if v is None else v for v in values], dtype=np.float64)
    vals = list(values)
    if vals and all(_is_text(v) for v in vals):
        enc = [bytes(v) if isinstance(v, (bytes, np.bytes_)) else str(v).encode("utf-8") for v in vals]
        return np.array(enc, dtype=f"S{max(1, *(len(b) for b in enc))}")
    if vals and all(isinstance(v, (bool, np.bool_)) for v in vals):
        return np.array(vals, dtype=np.uint8)
    if integers and vals and all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
                                 for v in vals):
        return np.array(vals, dtype=np.int64)
    if vals and all(isinstance(v, (tuple, list, np.ndarray)) for v in vals):  # a (rows, k) column, its type kept
        arr = np.array(vals)
        if arr.dtype.kind in "fiub":
            return arr.astype(np.uint8) if arr.dtype.kind == "b" else arr
    return np.array([np.nan if v is None else v for v in vals], dtype=np.float64)


def dimension_names(g: h5py.Group) -> tuple[str, ...]:
    """The datasets of table ``g`` that are dimension scales, not columns (its ``dimensions`` attribute)."""
    return tuple(n for n in text(g.attrs.get(DIMENSIONS, "")).split(",") if n)


def column_items(g: h5py.Group) -> list[tuple[str, h5py.Dataset]]:
    """(name, dataset) of every column of table ``g`` (its dimension scales left out)."""
    skip = dimension_names(g)
    return [(n, ds) for n, ds in g.items() if n not in skip]


def kinds_of(g: h5py.Group) -> dict[str, str]:
    """Column -> kind of a stored table (to rewrite it with the same types)."""
    out = {}
    for name, ds in column_items(g):
        k = ds.dtype.kind
        out[name] = "text" if k in "OS" else "flag" if ds.dtype == np.uint8 else "int" if k in "iu" else "float"
    return out


def _create(g: h5py.Group, name: str, data: np.ndarray, extendable: bool) -> h5py.Dataset:
    """A compressed column dataset holding ``data`` (text as fixed-width UTF-8)."""
    kw: dict[str, Any] = {"compression": "gzip", "compression_opts": 4, "shuffle": data.dtype.kind in "fiu"}
    if extendable:
        kw.update(maxshape=(None, *data.shape[1:]), chunks=True)
    elif len(data):
        kw["chunks"] = data.shape  # one chunk: the smallest index
    else:
        kw = {}
    if data.dtype.kind == "S":
        ds = g.create_dataset(name, shape=data.shape, dtype=h5py.string_dtype("utf-8", data.dtype.itemsize), **kw)
        if len(data):
            ds.id.write(h5py.h5s.ALL, h5py.h5s.ALL, data, mtype=ds.id.get_type())
        return ds
    return g.create_dataset(name, data=data, **kw)


def _describe(ds: h5py.Dataset, name: str, units: Mapping[str, str] | None,
              descriptions: Mapping[str, str] | None) -> None:
    u = (units or {}).get(name)
    u = units_of_name(name) if u is None else u
    ds.attrs[UNITS] = u or ("" if ds.dtype.kind in "OS" else DIMENSIONLESS)
    ds.attrs[DESCRIPTION] = (descriptions or {}).get(name, "")


def write_table(parent: h5py.Group, name: str, columns: Mapping[str, Sequence[Any] | np.ndarray], *,
                units: Mapping[str, str] | None = None, descriptions: Mapping[str, str] | None = None,
                integers: bool = False, kinds: Mapping[str, str] | None = None,
                extendable: bool = False) -> h5py.Group:
    """Write (replacing) table ``name`` under ``parent``: column -> values, equal lengths.  ``units``
    and ``descriptions``: column -> text (units default to what the column name states, see
    :func:`units_of_name`); ``kinds``: column -> kind (else inferred, see :func:`encode`).
    ``extendable``: chunked so that :func:`append_rows` can grow it."""
    if name in parent:
        del parent[name]
    g = parent.create_group(name)
    n = len(next(iter(columns.values()))) if columns else 0
    for col, values in columns.items():
        data = encode(values, integers, (kinds or {}).get(col))
        if len(data) != n:
            raise ValueError(f"table {name}: column {col} has {len(data)} rows, not {n}")
        _describe(_create(g, col, data, extendable), col, units, descriptions)
    g.attrs[ROWS] = n
    return g


def append_rows(parent: h5py.Group, name: str, columns: Mapping[str, Sequence[Any] | np.ndarray], *,
                units: Mapping[str, str] | None = None, descriptions: Mapping[str, str] | None = None) -> None:
    """Append rows (column -> values, equal lengths) to table ``name`` (created if missing); a text
    column whose new values are wider than its stored width is rewritten wider."""
    if name not in parent:
        write_table(parent, name, columns, units=units, descriptions=descriptions, extendable=True)
        return
    g = parent[name]
    n_old = int(g.attrs.get(ROWS, 0))
    n_new = len(next(iter(columns.values()))) if columns else 0
    for col, values in columns.items():
        data = encode(values)
        if col not in g:
            ds = _create(g, col, data, extendable=True)
            _describe(ds, col, units, descriptions)
            continue
        ds = g[col]
        if data.dtype.kind == "S" and ds.dtype.kind == "O":  # a variable-length column of an older file
            data = np.array([b.decode("utf-8") for b in data], dtype=object)
        if ds.maxshape[0] is None and data.dtype.kind != "S":
            ds.resize(n_old + n_new, axis=0)
            ds[n_old:] = data
            continue
        merged = np.concatenate([ds[()], data])  # fixed-width text (maybe wider now) or a fixed-size column
        attrs = dict(ds.attrs)
        del g[col]
        _create(g, col, merged, extendable=True).attrs.update(attrs)
    g.attrs[ROWS] = n_old + n_new


def read_column(ds: h5py.Dataset) -> np.ndarray:
    """One column: numbers as stored, text as an object array of ``str``."""
    data = ds[()]
    if ds.dtype.kind in "OS":
        return np.array([text(x) for x in np.ravel(data)], dtype=object).reshape(np.shape(data))
    return data


def read_raw(g: h5py.Group) -> dict[str, np.ndarray]:
    """Table -> column -> array as stored (fixed-width text as UTF-8 ``bytes``, variable-length text as
    an object array): for rewriting a table without decoding it."""
    out = {}
    for name, ds in column_items(g):
        data = ds[()]
        if ds.dtype.kind == "O":
            data = np.array([x if isinstance(x, bytes) else str(x).encode("utf-8") for x in np.ravel(data)],
                            dtype=bytes).reshape(np.shape(data))
        out[name] = data
    return out


def decode(data: np.ndarray) -> np.ndarray:
    """A raw text column (UTF-8 bytes) as an object array of ``str``; other columns unchanged."""
    if data.dtype.kind in "OS":
        return np.array([text(x) for x in np.ravel(data)], dtype=object).reshape(np.shape(data))
    return data


def _fill(like: np.ndarray, n: int) -> np.ndarray:
    """``n`` rows of a column's missing value: "" text, NaN numbers, 0 integers and flags."""
    if like.dtype.kind == "S":
        return np.zeros(n, dtype="S1")
    if like.dtype.kind == "f":
        return np.full((n, *like.shape[1:]), np.nan)
    return np.zeros((n, *like.shape[1:]), dtype=like.dtype)


def concat(old: Mapping[str, np.ndarray], new: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Two tables of encoded columns one after the other (a column one of them lacks filled, see
    :func:`_fill`)."""
    n_old = len(next(iter(old.values()))) if old else 0
    n_new = len(next(iter(new.values()))) if new else 0
    out = {}
    for name in dict.fromkeys([*old, *new]):
        a, b = old.get(name), new.get(name)
        a = _fill(b, n_old) if a is None else a
        b = _fill(a, n_new) if b is None else b
        if a.dtype.kind == "S" or b.dtype.kind == "S":
            a, b = (x if x.dtype.kind == "S" else x.astype(str).astype(bytes) for x in (a, b))
        out[name] = np.concatenate([a, b]) if n_old and n_new else (a if n_old else b)
    return out


def read_table(g: h5py.Group) -> dict[str, np.ndarray]:
    """Table -> column -> array (see :func:`read_column`)."""
    return {name: read_column(ds) for name, ds in column_items(g) if isinstance(ds, h5py.Dataset)}


def verify_table(g: object, where: str, ratios: int | None = None, per_ratio: Sequence[str] = (),
                 units: bool = True) -> list[str]:
    """Problems of one stored table (``where``: its path for the messages): a group with a ``rows``
    attribute, every column a dataset of that many rows (with a ``units`` attribute, if ``units``);
    the columns ``per_ratio`` (when ``ratios`` is given) of shape (rows, ratios)."""
    if not isinstance(g, h5py.Group) or ROWS not in g.attrs:
        return [f"{where}: not a table (a group with a rows attribute)"]
    n, p = int(g.attrs[ROWS]), []
    for col, ds in column_items(g):
        if not isinstance(ds, h5py.Dataset) or len(ds) != n:
            p.append(f"{where}/{col}: {getattr(ds, 'shape', 'not a column')} rows, the table has {n}")
        elif units and UNITS not in ds.attrs:
            p.append(f"{where}/{col}: no units attribute")
        elif ratios is not None and col in per_ratio and ds.shape != (n, ratios):
            p.append(f"{where}/{col}: shape {ds.shape}, not (rows, ratios) = ({n}, {ratios})")
    return p


def n_rows(g: h5py.Group) -> int:
    return int(g.attrs.get(ROWS, 0))


def rows(table: Mapping[str, np.ndarray]) -> list[dict[str, Any]]:
    """Column table -> list of row dicts (numpy scalars turned into Python ones)."""
    if not table:
        return []
    n = len(next(iter(table.values())))
    return [{k: (v[i].item() if isinstance(v[i], np.generic) else v[i]) for k, v in table.items()} for i in range(n)]


def columns(row_dicts: Sequence[Mapping[str, Any]], fill: Mapping[str, Any] | None = None) -> dict[str, list[Any]]:
    """Row dicts -> column -> values, the columns in first-seen order; a row lacking a column gets
    ``fill[column]`` or, by the column's kind, "" (text), NaN (numbers), NaN-filled arrays."""
    names: dict[str, None] = {}
    for r in row_dicts:
        names.update(dict.fromkeys(r))
    out: dict[str, list[Any]] = {}
    for name in names:
        present = [r[name] for r in row_dicts if name in r]
        if fill and name in fill:
            default: Any = fill[name]
        elif all(_is_text(v) for v in present):
            default = ""
        elif np.ndim(present[0]):
            default = np.full(np.shape(present[0]), np.nan)
        else:
            default = None
        out[name] = [r.get(name, default) for r in row_dicts]
    return out
