"""I/O edge shared by the studies.

* running several campaign configs into one results file (:func:`run_configs`);
* derived study tables stored next to the scenes in ``/study/<table>`` of the same HDF5 file, tables
  of :mod:`compare.tables` (one dataset per column, numbers as float64, flags as uint8, text as UTF-8;
  units from the column names), written atomically with :func:`compare.store.transaction`;
  ``ked inspect --verify`` checks the scenes and the shapes of these tables.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import store
from compare import tables as table_io
from compare.config import ConfigError, load_config
from compare.runner import CampaignSummary, run_campaign

STUDY = "study"


def refused_configs(configs: Sequence[Path]) -> dict[str, str]:
    """Config file name -> why it is refused at load (a case of a study may be exactly that)."""
    out = {}
    for c in configs:
        try:
            load_config(c)
        except ConfigError as exc:
            out[c.name] = "; ".join(exc.problems)
    return out


def run_configs(configs: Sequence[Path], out: Path, *, workers: int | None, fresh: bool,
                progress: bool = True, retry_failed: bool = False) -> list[CampaignSummary]:
    """Run each campaign config into ``out`` (scenes already stored are skipped, so scenes shared by
    two configs run once; configs refused at load are left out, see :func:`refused_configs`).
    ``fresh``: delete ``out`` first (the study regenerates it); ``retry_failed``: recompute the scenes
    stored as failed (with today's solvers, e.g. the Exudyn refinement ladder)."""
    if fresh and out.exists():
        out.unlink()
    refused = refused_configs(configs)
    return [run_campaign(load_config(c), out, workers=workers, progress=progress, retry_failed=retry_failed)
            for c in configs if c.name not in refused]


def _flatten(row: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in (dataclasses.asdict(row) if dataclasses.is_dataclass(row) else dict(row)).items():
        if isinstance(v, dict):
            out.update({f"{k}_{kk}": vv for kk, vv in v.items()})
        else:
            out[k] = v
    return out


def write_tables(path: Path, tables: dict[str, Sequence[Any]], attrs: dict[str, Any]) -> None:
    """Replace ``/study`` of ``path`` by ``tables`` (name -> rows: dataclasses or dicts with scalar
    fields; nested dataclasses become ``<field>_<sub>`` columns) and the ``attrs`` (JSON-able)."""
    with store.transaction(path) as f:
        if STUDY in f:
            del f[STUDY]
        g = f.create_group(STUDY)
        for k, v in attrs.items():
            g.attrs[k] = v if isinstance(v, (int, float, str)) else json.dumps(v)
        for name, table_rows in tables.items():
            flat = [_flatten(r) for r in table_rows]
            table_io.write_table(g, name, table_io.columns(flat))


def read_tables(path: Path) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, Any]]:
    """``/study`` of ``path``: (table -> column -> array, attrs)."""
    with h5py.File(path, "r") as f:
        g = f[STUDY]
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in g.attrs.items()}
        tables = {name: table_io.read_table(tg) for name, tg in g.items()}
    return tables, attrs


rows = table_io.rows


def save_figures(figures: dict[str, Any], out_dir: Path, dpi: int) -> list[Path]:
    """Write each figure (name -> matplotlib figure, None: left out) into ``out_dir`` and close it;
    returns the paths written, in order."""
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    for name, fig in figures.items():
        if fig is not None:
            fig.savefig(out_dir / name, dpi=dpi)
            plt.close(fig)
    return [out_dir / name for name, fig in figures.items() if fig is not None]
