"""PNG figures of a regression comparison (``ked diff --figures DIR``): for every scene whose histories drifted
beyond tolerance, the baseline's and the new histories of each drifted solver overlaid against the crank angle.

Files are ``diff_<new key>.png``; ``diff_index.json`` lists them (file -> scene label, keys, drifted checks).  A
file of the directory that the index does not list is never overwritten (:class:`FigureDirError`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from compare.diff import DiffReport, SceneDiff
from compare.figure_dir import FigureDirError
from compare.metrics import is_stress
from compare.results import SceneResult
from compare.solvers import COMPONENT_UNITS

INDEX = "diff_index.json"
__all__ = ["INDEX", "FigureDirError", "diff_figure", "write_diff_figures"]


def diff_figure(s: SceneDiff, base: SceneResult, new: SceneResult) -> Figure:
    """One row of axes per drifted (solver, component): baseline solid, new dashed, in mm (or mrad; a link's
    stress ``stress_<link>`` in MPa, its largest and smallest fibre)."""
    drifted = [(c.solver, c.quantity, c) for c in s.drifted]
    fig = Figure(figsize=(8, 2.4 * len(drifted) + 0.6))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(drifted), 1, squeeze=False)[:, 0]
    for ax, (solver, comp, c) in zip(axes, drifted):
        scale, shown = (1e-6, "MPa") if is_stress(comp) else (1e3, "mm" if COMPONENT_UNITS.get(comp) == "m" else
                                                                    "mrad")
        for r, name, style in ((base, "baseline", "-"), (new, "new", "--")):
            s_ = r.solutions.get(solver)
            h = s_.histories.get(comp) if s_ is not None else None
            if h is not None and r.crank_angle is not None:
                lines = ax.plot(np.degrees(r.crank_angle), scale * np.asarray(h), style)
                lines[0].set_label(name)
        ax.set_ylabel(f"{solver} {comp} [{shown}]")
        ax.set_title(f"drift {100 * c.value:.3g} % of the peak (bound {100 * c.bound:.3g} %)", fontsize=9)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("crank angle [deg]")
    fig.suptitle(s.label, fontsize=10)
    fig.tight_layout()
    return fig


def write_diff_figures(rep: DiffReport, baseline: str | Path, new: str | Path, out_dir: str | Path,
                       dpi: int = 100) -> list[Path]:
    """The figures of every drifted scene of ``rep`` into ``out_dir`` (reading only those scenes of the two
    files); returns the paths written."""
    from compare import store

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FigureDirError(f"{out}: not a directory; the figures need a directory")
    index_path = out / INDEX
    index: dict = {}
    if index_path.exists():
        try:
            index = json.loads(index_path.read_text(encoding="utf-8"))
        except (ValueError, OSError):
            raise FigureDirError(f"{index_path}: exists and is not a figure index of ked diff; choose another "
                                 "figure directory") from None
        if not isinstance(index, dict):
            raise FigureDirError(f"{index_path}: not a figure index of ked diff; choose another figure directory")
    scenes = [s for s in rep.scenes if s.drifted]
    names = {s.new_key: f"diff_{s.new_key}.png" for s in scenes}
    for name in names.values():
        if (out / name).exists() and name not in index:
            raise FigureDirError(f"{out / name}: exists and was not written by ked diff (not in its {INDEX}); it is "
                                 "left as it is: choose another figure directory")
    if not scenes:
        return []
    out.mkdir(parents=True, exist_ok=True)
    base = {r.key: r for r in store.read_scenes(baseline, [s.base_key for s in scenes])}
    newr = {r.key: r for r in store.read_scenes(new, [s.new_key for s in scenes])}
    paths = []
    for s in scenes:
        fig = diff_figure(s, base[s.base_key], newr[s.new_key])
        path = out / names[s.new_key]
        fig.savefig(path, dpi=dpi)
        paths.append(path)
        index[names[s.new_key]] = {"label": s.label, "baseline_key": s.base_key, "new_key": s.new_key,
                                   "drifted": [c.name for c in s.drifted]}
    index_path.write_text(json.dumps(index, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return paths
