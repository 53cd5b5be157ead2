"""Dimension scales of a campaign file: every dimension of its tables and scene arrays named for netCDF-4
readers (xarray with the h5netcdf engine): a table's rows, its per-link and (x, y) columns, a scene's crank angle,
components, stress columns, points and modes (layout: ``docs/hdf5_schema.md``, "Dimensions").
"""

from __future__ import annotations

from typing import Any

import h5py
import numpy as np

from compare.h5layout import (
    SOLUTIONS,
    STRESS,
    text,
)
from compare.h5schema import (
    METRIC_TABLE,
    RUNS,
    SCENE_TABLE,
    SCENES,
    SOLUTION_TABLE,
)
from ked_quasi.linkage import LINKS

TABLE_DIMENSIONS = {RUNS: "run", SCENE_TABLE: "scene", SOLUTION_TABLE: "solution", METRIC_TABLE: "metric"}
"""Table -> name of its row dimension (the ``run`` column of ``/runs`` is its own scale; the other tables
get a dataset of row numbers)."""


INNER_DIMENSIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "link": (LINKS, "link of a per-link column (four-bar order; a slider-crank's crank and coupler first)"),
    "xy": (("x", "y"), "coordinate of a point (x, y) in the global frame"),
}
"""Dimension -> (labels, description) of the inner dimension of a table's (rows, k) columns."""


INNER_COLUMNS = {"crank_pivot_m": "xy", "follower_pivot_m": "xy", "youngs_modulus_Pa": "link", "area_m2": "link",
                  "second_moment_m4": "link", "density_kg_m3": "link"}


_DIMENSION_ATTRS = ("DIMENSION_LIST", "REFERENCE_LIST")


def _label_scale(g: h5py.Group, name: str, labels: Any, units: str | None = None, description: str = ""
                 ) -> h5py.Dataset:
    """Dataset ``name`` of ``g`` holding ``labels`` (replaced if it holds other values), made a dimension scale
    (one made before is kept: a table or scene group is written anew whenever its content changes); with
    ``units`` and ``description`` attributes unless ``units`` is None (a scene's labels: the schema states
    them, and a scene's bytes count)."""
    data = np.asarray(labels)
    ds = g.get(name)
    if isinstance(ds, h5py.Dataset) and ds.shape == data.shape and "CLASS" in ds.attrs:
        return _detach(ds)
    if not isinstance(ds, h5py.Dataset) or ds.shape != data.shape or (
            data.dtype.kind in "fiu" and not np.array_equal(ds[()], data)) or (
            data.dtype.kind == "U" and [text(x) for x in ds[()]] != list(data)):
        if name in g:
            del g[name]
        if data.dtype.kind == "U":
            ds = g.create_dataset(name, data=list(data), dtype=h5py.string_dtype())
        else:
            ds = g.create_dataset(name, data=data)
    if units is not None:
        ds.attrs["units"], ds.attrs["description"] = units, description
    _scale(ds, name)
    return ds


def _detach(ds: h5py.Dataset) -> h5py.Dataset:
    """``ds`` without scale attachments (an HDF5 copy into another file leaves them dangling)."""
    for a in _DIMENSION_ATTRS:
        if a in ds.attrs:
            del ds.attrs[a]
    return ds


def _scale(ds: h5py.Dataset, name: str) -> None:
    if "CLASS" not in _detach(ds).attrs:
        ds.make_scale(name)


def _table_dimensions(g: h5py.Group, dim: str) -> None:
    from compare import tables

    n = tables.n_rows(g)
    before, own = tables.dimension_names(g), []
    if dim == TABLE_DIMENSIONS[RUNS] and dim in g:  # the runs' column run numbers the rows
        row = g[dim]
        _scale(row, dim)
    else:
        if dim in g and dim not in before:  # a row-number dataset an older writer took for a column
            del g[dim]
        row = _label_scale(g, dim, np.arange(n, dtype=np.int64), "1", "row number of the table")
        own.append(dim)
    cols = [(c, _detach(ds)) for c, ds in tables.column_items(g) if c not in own and c != dim]
    for inner, (labels, description) in INNER_DIMENSIONS.items():
        users = [ds for c, ds in cols if INNER_COLUMNS.get(c) == inner and ds.ndim == 2 and ds.shape[1] == len(labels)]
        if users:  # at the file's root: every dataset of a table is as long as its rows (older readers' rule)
            scale = _label_scale(g.file, inner, labels, "", description)
            for ds in users:
                ds.dims[1].attach_scale(scale)
    g.attrs[tables.DIMENSIONS] = ",".join(own)
    for name in before:
        if name not in own and name in g:
            del g[name]
    for _, ds in cols:
        if ds.ndim and ds.shape[0] == n:
            ds.dims[0].attach_scale(row)


def _scene_dimensions(g: h5py.Group) -> None:
    """A scene group's crank angle as the scale of its arrays' and histories' first dimension, with the
    point coordinates (xy), modes and components as the second."""
    theta = g.get("crank_angle")
    if not isinstance(theta, h5py.Dataset) or theta.ndim != 1:
        return
    _scale(theta, "crank_angle")
    n = theta.shape[0]
    cp, nf = g.get("coupler_point"), g.get("natural_frequencies")
    for ds, dim, labels in ((cp, "xy", ("x", "y")), (nf, "mode", None)):
        if isinstance(ds, h5py.Dataset) and ds.ndim == 2 and ds.shape[0] == n:
            _detach(ds).dims[0].attach_scale(theta)
            labels = np.arange(1, ds.shape[1] + 1, dtype=np.int64) if labels is None else labels
            if len(labels) == ds.shape[1]:
                ds.dims[1].attach_scale(_label_scale(g, dim, labels))
    for sub, attr, dim in ((SOLUTIONS, "components", "component"), (STRESS, "columns", "stress_column")):
        _columns_dimension(g, g.get(sub), theta, attr, dim)


def _columns_dimension(g: h5py.Group, sg: Any, theta: h5py.Dataset, attr: str, dim: str) -> None:
    """The datasets of ``sg`` (the solvers' histories or stresses): the crank angle as their first dimension and
    the column names of attribute ``attr`` as a label scale ``dim`` in the scene group, where all agree."""
    if not isinstance(sg, h5py.Group):
        return
    n = theta.shape[0]
    sols = [ds for ds in sg.values() if isinstance(ds, h5py.Dataset) and ds.ndim == 2 and ds.shape[0] == n]
    if not sols:
        return
    comps = {text(ds.attrs.get(attr, "")) for ds in sols}
    scale = None
    if len(comps) == 1:
        labels = [c for c in comps.pop().split(",") if c]
        if labels and all(ds.shape[1] == len(labels) for ds in sols):
            scale = _label_scale(g, dim, np.array(labels))
    for ds in sols:
        _detach(ds).dims[0].attach_scale(theta)
        if scale is not None:
            ds.dims[1].attach_scale(scale)


def _dimensioned(f: h5py.File) -> list[h5py.Dataset]:
    """Every dataset :func:`attach_dimensions` attaches a scale to or makes one."""
    out = [ds for n in TABLE_DIMENSIONS if isinstance(f.get(n), h5py.Group) for ds in f[n].values()]
    out += [f[n] for n in INNER_DIMENSIONS if isinstance(f.get(n), h5py.Dataset)]
    scenes = f.get(SCENES)
    for g in (scenes.values() if isinstance(scenes, h5py.Group) else ()):
        if isinstance(g, h5py.Group):
            out += [ds for ds in g.values() if isinstance(ds, h5py.Dataset)]
            for sg in (g.get(SOLUTIONS), g.get(STRESS)):
                out += [ds for ds in sg.values() if isinstance(ds, h5py.Dataset)] if isinstance(sg, h5py.Group) else []
    return [ds for ds in out if isinstance(ds, h5py.Dataset)]


def detach_dimensions(f: h5py.File) -> None:
    """Drop every scale attachment of a campaign file (before an HDF5 copy into another file, which would
    leave them dangling and their stale data in the copy)."""
    for ds in _dimensioned(f):
        _detach(ds)


def attach_dimensions(f: h5py.File) -> None:
    """Name every dimension of a version-4 file's tables and scene arrays with HDF5 dimension scales
    (netCDF-4 and xarray read them as named dimensions with coordinates): a table's rows (``scene``,
    ``solution``, ``metric``, ``run``) and its per-link / (x, y) columns (``link``, ``xy``: datasets at the
    file's root); a scene's
    ``crank_angle`` [rad], ``component`` (of ``solutions/<solver>``), ``xy`` and ``mode`` (scales in the
    scene's group: ``solutions/`` holds only the solvers' datasets).  Stale
    attachments (an HDF5 copy into another file leaves them dangling) are dropped and made anew."""
    groups = [f[n] for n in TABLE_DIMENSIONS if isinstance(f.get(n), h5py.Group) and "rows" in f[n].attrs]
    scenes = f.get(SCENES)
    for g in groups:
        _table_dimensions(g, TABLE_DIMENSIONS[g.name.lstrip("/")])
    for g in (scenes.values() if isinstance(scenes, h5py.Group) else ()):
        if isinstance(g, h5py.Group):
            _scene_dimensions(g)
