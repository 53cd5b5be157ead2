"""A results file as labelled data: the histories as an xarray Dataset with scene coordinates, the tables as
pandas DataFrames (the optional extra ``ked-harness[xarray]``: xarray, pandas, h5netcdf).

    from compare import open_results
    res = open_results("ked_results/thesis-default.h5")
    res.histories["dy"].sel(solver="dynamic").plot.line(x="crank_angle")

Read with plain h5py from the stored file (schema version 4 or 5); nothing is recomputed.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import h5dims, h5layout, tables
from compare.solvers import COMPONENT_UNITS, COMPONENTS
from ked_quasi.units import rpm_to_rad_s, speed_ratio

EXTRA = "xarray"
"""The optional extra that installs what :func:`open_results` needs."""


def _require(name: str) -> Any:
    try:
        return importlib.import_module(name)
    except ImportError:
        raise ImportError(f"compare.open_results needs {name}: install the extra with "
                          f"pip install 'ked-harness[{EXTRA}]'") from None


@dataclass(frozen=True)
class Results:
    """A results file as labelled data.

    ``histories``: xarray Dataset of the complete scenes, dims ``scene`` (coordinate: the content key), ``solver``,
    ``crank_angle`` [rad], ``xy``, ``mode``, ``link``; variables ``dx``, ``dy`` [m], ``rotation`` [rad]
    (scene, solver, crank_angle), ``coupler_point`` [m] (scene, crank_angle, xy), ``natural_frequencies``
    [Hz] (scene, crank_angle, mode); every column of ``/scene_table`` is a coordinate along ``scene``
    (per-link columns along (scene, link), pivots along (scene, xy)), plus ``speed_ratio`` [1] =
    Omega / omega1_min; with link stresses (schema version 5, the output ``stress``) ``stress`` [Pa] (scene, solver,
    crank_angle, link, fibre): the largest (fibre ``max``) and the smallest (``min``) extreme-fibre normal stress
    over each link.  NaN where a scene has no such sample (a failed solver, another crank grid: the
    coordinate is the union of the scenes' grids).
    ``scenes``, ``solutions``, ``metrics``, ``runs``: DataFrames of ``/scene_table``, ``/solution_table``,
    ``/metric_table``, ``/runs``, one column per stored column (a (rows, k) column as one array per
    cell), units and descriptions in ``DataFrame.attrs["units"]`` / ``["descriptions"]``."""

    histories: Any
    scenes: Any
    solutions: Any
    metrics: Any
    runs: Any


def _frame(pd: Any, g: h5py.Group | None) -> Any:
    if g is None:
        return pd.DataFrame()
    cols = {}
    for name, ds in tables.column_items(g):
        data = tables.read_column(ds)
        cols[name] = list(data) if data.ndim > 1 else data
    df = pd.DataFrame(cols)
    df.attrs["units"] = {n: tables.text(ds.attrs.get(tables.UNITS, "")) for n, ds in tables.column_items(g)}
    df.attrs["descriptions"] = {n: tables.text(ds.attrs.get(tables.DESCRIPTION, ""))
                                for n, ds in tables.column_items(g)}
    return df


def _scene_arrays(f: h5py.File, keys: list[str]) -> dict[str, Any]:
    """key -> (crank_angle, {solver: {component: history}}, coupler_point, natural_frequencies,
    {solver: {link: (n, 2) stress}})."""
    out: dict[str, Any] = {}
    scenes = f.get(h5layout.SCENES)
    for k in keys:
        g = scenes.get(k) if isinstance(scenes, h5py.Group) else None
        if g is None or "crank_angle" not in g:
            continue
        sols: dict[str, dict[str, np.ndarray]] = {}
        for solver, ds in (g[h5layout.SOLUTIONS].items() if h5layout.SOLUTIONS in g else ()):
            comps = [c for c in tables.text(ds.attrs.get("components", "")).split(",") if c]
            data = ds[()]
            sols[solver] = {c: data[:, i] for i, c in enumerate(comps)}
        stress = {solver: h5layout.read_stress(ds) for solver, ds in
                  (g[h5layout.STRESS].items() if h5layout.STRESS in g else ())}
        out[k] = (g["crank_angle"][()], sols, g["coupler_point"][()] if "coupler_point" in g else None,
                  g["natural_frequencies"][()] if "natural_frequencies" in g else None, stress)
    return out


def _stress(keys: list[str], arrays: dict[str, Any], solvers: list[str], grid: np.ndarray) -> np.ndarray | None:
    """(scene, solver, crank_angle, link, fibre) [Pa] of the stored link stresses (None: no scene has any)."""
    if not any(a[4] for a in arrays.values()):
        return None
    out = np.full((len(keys), len(solvers), len(grid), len(h5layout.LINKS), 2), np.nan)
    for i, k in enumerate(keys):
        if k not in arrays:
            continue
        theta, stress = arrays[k][0], arrays[k][4]
        at = np.searchsorted(grid, theta + ANGLE_TOL, side="right") - 1
        for j, s in enumerate(solvers):
            for lk, v in stress.get(s, {}).items():
                if lk in h5layout.LINKS and v.shape == (len(theta), 2):
                    out[i, j, at, h5layout.LINKS.index(lk)] = v
    return out


ANGLE_TOL = 1e-9
"""Crank angles of two scenes closer than this [rad] are one value of the ``crank_angle`` coordinate."""


def _grid(thetas: list[np.ndarray]) -> np.ndarray:
    """The union of the scenes' crank-angle grids [rad], sorted, values closer than ANGLE_TOL merged (the
    first kept)."""
    if not thetas:
        return np.zeros(0)
    every = np.sort(np.concatenate(thetas))
    return every[np.concatenate([[True], np.diff(every) > ANGLE_TOL])]


def _histories(xr: Any, f: h5py.File, scene_cols: dict[str, np.ndarray], scene_attrs: dict[str, dict[str, str]]
               ) -> Any:
    n_rows = len(scene_cols.get("key", []))
    done = np.asarray(scene_cols.get("complete", np.zeros(n_rows)), dtype=bool)  # readers ignore incomplete rows
    scene_cols = {name: data[done] for name, data in scene_cols.items()}
    keys = [str(k) for k in scene_cols.get("key", [])]
    arrays = _scene_arrays(f, keys)
    grid = _grid([a[0] for a in arrays.values()])
    solvers = list(dict.fromkeys(s for a in arrays.values() for s in a[1]))
    n_modes = max((a[3].shape[1] for a in arrays.values() if a[3] is not None and a[3].ndim == 2), default=0)
    n, m = len(keys), len(grid)
    hist = {c: np.full((n, len(solvers), m), np.nan) for c in COMPONENTS}
    cp, nf = np.full((n, m, 2), np.nan), np.full((n, m, n_modes), np.nan)
    for i, k in enumerate(keys):
        if k not in arrays:
            continue
        theta, sols, coupler, freqs, _ = arrays[k]
        at = np.searchsorted(grid, theta + ANGLE_TOL, side="right") - 1
        for j, s in enumerate(solvers):
            for c, h in sols.get(s, {}).items():
                if c in hist and h.shape == theta.shape:
                    hist[c][i, j, at] = h
        if coupler is not None and coupler.shape == (len(theta), 2):
            cp[i, at] = coupler
        if freqs is not None and freqs.ndim == 2 and freqs.shape[0] == len(theta):
            nf[i, at, :freqs.shape[1]] = freqs
    variables = {c: (("scene", "solver", "crank_angle"), hist[c],
                     {"units": COMPONENT_UNITS[c], "description": f"deflection {c} of the coupler point P"})
                 for c in COMPONENTS}
    for name, dims, data in (("coupler_point", ("scene", "crank_angle", "xy"), cp),
                             ("natural_frequencies", ("scene", "crank_angle", "mode"), nf)):
        units, description = h5layout.ARRAYS[name]
        variables[name] = (dims, data, {"units": units, "description": description})
    stress = _stress(keys, arrays, solvers, grid)
    if stress is not None:
        variables["stress"] = (("scene", "solver", "crank_angle", "link", "fibre"), stress,
                               {"units": "Pa", "description": "largest (max) and smallest (min) extreme-fibre normal "
                                                              "stress N/A +- M c/I over the link"})
    coords: dict[str, Any] = {
        "scene": ("scene", np.array(keys, dtype=object), {"description": "content key of the scene"}),
        "solver": ("solver", np.array(solvers, dtype=object)),
        "crank_angle": ("crank_angle", grid, {"units": "rad", "description": h5layout.ARRAYS["crank_angle"][1]}),
        "xy": ("xy", np.array(["x", "y"], dtype=object)),
        "mode": ("mode", np.arange(1, n_modes + 1)),
    }
    if stress is not None:
        coords["link"] = ("link", np.array(h5layout.LINKS, dtype=object))
        coords["fibre"] = ("fibre", np.array(["max", "min"], dtype=object))
    for name, data in scene_cols.items():
        if name == "key":
            continue
        inner = h5dims.INNER_COLUMNS.get(name)
        if data.ndim == 2 and inner == "link" and data.shape[1] == len(h5layout.LINKS):
            coords.setdefault("link", ("link", np.array(h5layout.LINKS, dtype=object)))
            coords[name] = (("scene", "link"), data, scene_attrs[name])
        elif data.ndim == 2 and inner == "xy" and data.shape[1] == 2:
            coords[name] = (("scene", "xy"), data, scene_attrs[name])
        elif data.ndim == 1:
            coords[name] = ("scene", data, scene_attrs[name])
    if "rpm" in scene_cols and "omega1_min_rad_s" in scene_cols:
        ratio = np.array([speed_ratio(rpm_to_rad_s(float(n)), float(w))
                          for n, w in zip(scene_cols["rpm"], scene_cols["omega1_min_rad_s"])])
        coords["speed_ratio"] = ("scene", ratio, {"units": "1", "description": "Omega / omega1_min"})
    return xr.Dataset(variables, coords=coords)


def open_results(path: str | Path) -> Results:
    """The results file ``path`` (schema version 4 or 5) as labelled data (:class:`Results`); needs the extra
    ``ked-harness[xarray]``.  Raises ``compare.store.StoreError`` for a file of an older layout."""
    from compare import reader, store

    pd, xr = _require("pandas"), _require("xarray")
    path = Path(path)
    with reader._open(path) as f:
        _, version = reader._scenes(f, path)
        if version < store.TABLE_LAYOUT:
            raise store.StoreError(f"{path}: schema version {version}; open_results reads versions "
                                   f"{store.TABLE_LAYOUT}-{store.SCHEMA_VERSION} (a copy in today's layout: "
                                   f"`ked merge {path} NEW.h5`)")
        frames = {n: _frame(pd, f.get(n)) for n in h5layout.TABLES}
        st = f.get(h5layout.SCENE_TABLE)
        cols = tables.read_table(st) if st is not None else {}
        attrs = {n: {"units": tables.text(ds.attrs.get(tables.UNITS, "")),
                     "description": tables.text(ds.attrs.get(tables.DESCRIPTION, ""))}
                 for n, ds in (tables.column_items(st) if st is not None else ())}
        histories = _histories(xr, f, cols, attrs)
    return Results(histories=histories, scenes=frames[h5layout.SCENE_TABLE],
                   solutions=frames[h5layout.SOLUTION_TABLE], metrics=frames[h5layout.METRIC_TABLE],
                   runs=frames[h5layout.RUNS])
