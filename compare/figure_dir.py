"""The figure directory of a results file: scene and amplification figures written there, PNG unless asked
(:data:`FORMATS`), each through a temporary file; drawn by :mod:`compare.plots`.

``index.json`` maps each scene figure to its key, label and a stamp of the stored scene; a figure
whose stamp is unchanged is not drawn again.  Its entry ``"@ked-harness"`` (not a file) is the manifest:
``{"written_by": "ked-harness", "files": [...], "results_file": ..., "results_id": ...}``, every file the
harness wrote in the directory and the results file they were drawn from (one per directory).  A
file of the same name that the manifest does not list (the user's own ``index.json``, ``amplification.png``
or ``scene_*.png``) is never overwritten: :class:`FigureDirError` names it instead.
"""

from __future__ import annotations

import contextlib
import errno
import json
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from compare.plots import amplification_figure, scene_figure
from compare.results import SceneResult

FORMATS = ("png", "svg", "pdf")
"""File formats of the figures (matplotlib's writers); PNG unless asked."""
DPI = 110
"""Resolution of the figures [dots per inch] unless asked (PNG; SVG and PDF are vector drawings)."""


class FigureWriteError(OSError):
    """A figure (or the index) could not be written: its ``filename`` names the file."""


def save_figure(fig: Figure, path: Path, dpi: int = DPI, metadata: dict | None = None) -> Path:
    """Write ``fig`` to ``path`` (format from its suffix) through a temporary file renamed into place:
    ``path`` is either its old self or the whole new figure.  An OS failure (a full disk) removes the
    temporary file and raises :class:`FigureWriteError` naming ``path``."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        fig.savefig(tmp, dpi=dpi, format=path.suffix[1:], metadata=metadata)
        tmp.replace(path)
    except OSError as exc:
        with contextlib.suppress(OSError):  # the failure to report is the write's, not this clean-up's
            tmp.unlink(missing_ok=True)
        raise FigureWriteError(exc.errno, exc.strerror or str(exc), str(path)) from None
    return path


def _write_scene_png(r: SceneResult, path: Path, dpi: int) -> Path:
    return save_figure(scene_figure(r), path, dpi, metadata={"Title": f"{r.spec.label} [{r.key}]"})


def figure_names(results: Sequence[SceneResult], fmt: str = "png") -> dict[str, str]:
    """key -> file name of its scene figure: the label, plus the key where labels repeat."""
    safe = {r.key: "scene_" + "".join(ch if ch.isalnum() or ch in "-." else "_" for ch in r.spec.label)
            for r in results}
    counts = defaultdict(int)
    for name in safe.values():
        counts[name] += 1
    return {k: (f"{n}_{k}" if counts[n] > 1 else n) + f".{fmt}" for k, n in safe.items()}


def _stamp(r: SceneResult, dpi: int = DPI) -> str:
    """What a scene figure depends on: the stored scene (finished time, status, solvers), the resolution
    and this module."""
    return (f"{r.key}|{r.status}|{r.stats.finished_utc}|{','.join(sorted(r.solutions))}|{_FIGURE_VERSION}"
            + ("" if dpi == DPI else f"|dpi{dpi}"))


_FIGURE_VERSION = 4


MANIFEST = "@ked-harness"
"""The entry of ``index.json`` that lists the files the harness wrote in its directory."""
INDEX = "index.json"
AMPLIFICATION = "amplification.png"


def amplification_name(fmt: str = "png") -> str:
    """The file name of the amplification figure in format ``fmt``."""
    return f"amplification.{fmt}"


class FigureDirError(ValueError):
    """The figure directory holds a file of a name the harness would write that the harness did not write,
    or the figures of another results file."""


def _owned(out: Path) -> tuple[dict, set[str], tuple[str, str] | None]:
    """The scene entries of ``out``'s index, the names of the files the harness wrote there and the
    results file they were drawn from (its identity and path; None: not recorded).  Raises :class:`FigureDirError` if
    ``index.json`` exists but is not a figure index of the harness."""
    import json

    index_path = out / INDEX
    if not index_path.exists() and not index_path.is_symlink():
        return {}, set(), None
    try:
        data = json.loads(index_path.read_text()) if index_path.is_file() else None
    except (OSError, ValueError):  # includes undecodable bytes
        data = None
    manifest = data.get(MANIFEST) if isinstance(data, dict) else None
    entries = {k: v for k, v in data.items() if k != MANIFEST} if isinstance(data, dict) else {}
    legacy = bool(entries) and all(isinstance(v, dict) and {"key", "label", "stamp"} <= set(v)
                                   for v in entries.values())
    source = None
    if isinstance(manifest, dict) and manifest.get("written_by") == "ked-harness":
        files = {f for f in manifest.get("files", []) if isinstance(f, str)}
        if isinstance(manifest.get("results_id"), str):
            source = (manifest["results_id"], str(manifest.get("results_file")))
    elif legacy and manifest is None:  # written by a harness version before the manifest
        files = set(entries) | {AMPLIFICATION}
    else:
        raise FigureDirError(f"{index_path}: not a figure index written by ked-harness (a file of yours?); it is "
                             "left as it is: choose another figure directory")
    return entries, files | {INDEX}, source


def _source_id(source: str | Path | None) -> str | None:
    """Which results file figures were drawn from: its file name and creation time (a results file moved
    with its figure directory is still the same one; a copy under another name is not)."""
    if source is None:
        return None
    from compare import store

    try:
        created = str(store.file_info(source).get("created_utc", ""))
    except (store.StoreError, OSError):
        created = ""
    return f"{Path(source).name}|{created}"


def check_figure_dir(out_dir: str | Path, names: Sequence[str] = (), fmt: str = "png",
                     source: str | Path | None = None) -> None:
    """Refuse (:class:`FigureDirError`, naming the file) if writing the figures ``names`` (besides the
    index and the amplification figure in format ``fmt``) into ``out_dir`` would overwrite a file the
    harness did not write, or if the directory holds the figures of a results file other than ``source``
    (one figure directory, one index, per results file)."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FigureDirError(f"{out}: not a directory; the figures need a directory")
    _, files, drawn_from = _owned(out)
    mine = _source_id(source)
    if mine is not None and drawn_from is not None and drawn_from[0] != mine:
        raise FigureDirError(f"{out}: holds the figures of another results file ({drawn_from[1]}); they are "
                             f"left as they are: choose another figure directory for {source}")
    for name in (INDEX, amplification_name(fmt), *names):
        if (out / name).exists() or (out / name).is_symlink():
            if name not in files:
                raise FigureDirError(f"{out / name}: exists and was not written by ked-harness (not in its "
                                     f"{INDEX}); it is left as it is: choose another figure directory")


def _draw_in_pool(jobs: list[tuple[SceneResult, Path]], dpi: int, workers: int, written: list[Path],
                  on_each: Callable[[Path], Any] | None) -> None:
    """Scene figures on ``workers`` local processes of the one executor (:func:`compare.executor.run_tasks`:
    spawned workers that die with this one, crash isolation, stopped at once on an interrupt); each figure
    written is appended to ``written`` as it completes.  A figure that cannot be written stops the drawing
    and raises its :class:`FigureWriteError`, naming the file."""
    from compare.executor import run_tasks

    failed: list[tuple[int, str, str]] = []

    def commit(batch: list[tuple[tuple[SceneResult, Path, int], _Drawn]]) -> bool:
        for _, (path, error) in batch:  # every figure of the batch that was drawn is recorded
            if error is not None:
                failed.append(error)
                continue
            written.append(path)
            if on_each is not None:
                on_each(path)
        return bool(failed)  # the figures not started are not drawn

    def crashed(job: tuple[SceneResult, Path, int], exc: BaseException | None) -> _Drawn:
        why = "its drawing process died" if exc is None else f"{type(exc).__name__}: {exc}"
        return None, (errno.EIO, f"not drawn ({why})", str(job[1]))

    run_tasks([(r, p, dpi) for r, p in jobs], _draw_task, workers=workers, on_result=commit, crashed=crashed)
    if failed:
        raise FigureWriteError(*failed[0])


_Drawn = tuple[Path | None, tuple[int, str, str] | None]
"""A drawing task's answer: the figure written, or None and its failure (errno, reason, file)."""


def _draw_task(job: tuple[SceneResult, Path, int]) -> _Drawn:
    """One scene figure, on a worker; its write failure is data (the executor's tasks keep their own)."""
    try:
        return _write_scene_png(*job), None
    except FigureWriteError as exc:
        return None, (exc.errno or errno.EIO, exc.strerror or str(exc), str(exc.filename))


def figure_count(results: Sequence[SceneResult]) -> int:
    """How many figures :func:`write_figures` draws at most for ``results`` (a progress bar's total)."""
    return len(results) + 1


def write_figures(results: Sequence[SceneResult], out_dir: str | Path, dpi: int = DPI,
                  workers: int = 1, fmt: str = "png", source: str | Path | None = None,
                  on_each: Callable[[Path], Any] | None = None) -> list[Path]:
    """Write the campaign figures (format ``fmt``, one of :data:`FORMATS`) into ``out_dir`` (scene
    figures in ``workers`` processes), skipping scene figures whose stored scene did not change; returns
    the paths written.  Only files the harness wrote there for the results file ``source`` are replaced
    (see :class:`FigureDirError`).  Each figure goes through a temporary file renamed into place; then
    the index, the same way, lists only the figures there.  An OS failure (a full disk) raises
    :class:`FigureWriteError` naming the file, after the index is brought up to date where it can be.
    ``on_each``: called with each path written (progress)."""
    if fmt not in FORMATS:
        raise ValueError(f"figure format {fmt!r}: allowed {', '.join(FORMATS)}")
    out = Path(out_dir)
    names = figure_names(results, fmt)
    amp_name = amplification_name(fmt)
    check_figure_dir(out, sorted(names.values()), fmt, source)
    out.mkdir(parents=True, exist_ok=True)
    old, files, _ = _owned(out)
    index = {names[r.key]: {"key": r.key, "label": r.spec.label, "stamp": _stamp(r, dpi)} for r in results}
    jobs = [(r, out / names[r.key]) for r in results
            if old.get(names[r.key], {}).get("stamp") != _stamp(r, dpi) or not (out / names[r.key]).exists()]
    head = {"written_by": "ked-harness"} | ({"results_file": str(Path(source).resolve()),
                                             "results_id": _source_id(source)} if source is not None else {})
    # the claim first (the files about to be written are the harness's, should it be stopped mid-way);
    # the scene entries only for figures that are there
    claimed = (files | set(index) | {amp_name}) - {INDEX}
    kept = {k: v for k, v in old.items() if (out / k).exists()}
    if jobs or not (out / INDEX).exists() or claimed != files - {INDEX}:
        _write_index(out / INDEX, {**kept, MANIFEST: head | {"files": sorted(claimed)}})
    written: list[Path] = []
    try:
        if workers > 1 and len(jobs) > 2 * workers:
            _draw_in_pool(jobs, dpi, workers, written, on_each)
        else:
            for r, p in jobs:
                written.append(_write_scene_png(r, p, dpi))
                if on_each is not None:
                    on_each(written[-1])
        p = out / amp_name
        if jobs or not p.exists() or set(old) != set(index):
            written.append(save_figure(amplification_figure(results), p, dpi))
            if on_each is not None:
                on_each(p)
    except BaseException:  # the index lists what is there; the first failure is the one reported
        with contextlib.suppress(OSError):
            _final_index(out, kept, index, written, claimed, head)
        raise
    _final_index(out, kept, index, written, claimed, head)
    return written


def _final_index(out: Path, kept: dict, index: dict, written: list[Path], claimed: set[str], head: dict) -> None:
    """The index after drawing: the scene entries of the figures there (a figure not redrawn keeps its
    old entry: its old content is there), the manifest listing the harness's files that exist."""
    done = {p.name for p in written}
    entries = kept | {k: v for k, v in index.items() if k in done}
    final = {**entries, MANIFEST: head | {"files": sorted(f for f in claimed if (out / f).exists())}}
    try:
        current = json.loads((out / INDEX).read_text())
    except (OSError, ValueError):
        current = None
    if _moved_only(current, final):  # the same results file by another path (moved, a bind mount): record it
        with contextlib.suppress(OSError):  # where it can be: nothing else changed (a read-only copy stays valid)
            _write_index(out / INDEX, final)
    elif current != final:
        _write_index(out / INDEX, final)


def _moved_only(current: object, final: dict) -> bool:
    """Whether the index on disk differs from ``final`` only in the results file's path (same results id)."""
    if not isinstance(current, dict) or not isinstance(current.get(MANIFEST), dict):
        return False
    path = final[MANIFEST].get("results_file")
    return current != final and {**current, MANIFEST: {**current[MANIFEST], "results_file": path}} == final


def _write_index(index_path: Path, index: dict) -> None:
    tmp = index_path.with_name(index_path.name + ".tmp")
    try:
        tmp.write_text(json.dumps(index, indent=1, sort_keys=True))
        tmp.replace(index_path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise FigureWriteError(exc.errno, exc.strerror or str(exc), str(index_path)) from None
