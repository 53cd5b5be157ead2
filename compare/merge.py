"""Nothing computed is lost: :func:`rescue` saves scenes a commit could not store, :func:`merge` carries the
scenes of one results file that verify into another.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import h5py

from compare.h5file import (
    CommitError,
    _discard,
    _hdf5_errors,
    _tmp_beside,
    check_writable,
    target,
    transaction,
    writer_lock,
)
from compare.reader import StoreError, check_ours, file_info, read_scenes, stored_status
from compare.results import SceneResult
from compare.upgrade import upgrade
from compare.verify import verify, verify_scenes
from compare.writer import _commit, _record_run, commit, record_run


def rescue(results: list[SceneResult], out: str | Path, config_text: str, campaign_name: str) -> Path:
    """Write ``results`` (scenes computed but not committed to ``out``) into a new results file beside
    ``out``, else in the temporary directory, else in the home directory; returns its path.  Raises
    CommitError if no location can take it."""
    import tempfile
    import time

    out = target(out)
    stamp = time.strftime("%Y%m%dT%H%M%S")
    name = f"{out.stem}.rescue-{stamp}-{os.getpid()}.h5"
    reasons = []
    for directory in (out.parent, Path(tempfile.gettempdir()), Path.home() / ".cache" / "ked-harness"):
        if directory != Path.home() / ".cache" / "ked-harness" and not directory.is_dir():
            reasons.append(f"{directory}: no such directory (not made again)")
            continue  # a directory deleted during the run is not re-created
        path = directory / name
        try:
            commit(path, results, record_run(path, config_text, campaign_name, len(results)))
            return path
        except (CommitError, OSError) as exc:
            reasons.append(str(exc))
            try:
                path.unlink()
            except OSError:
                pass
    raise CommitError("the computed scenes could not be saved anywhere: " + "; ".join(reasons))


MERGE_WAIT_S = 60.0
"""How long ``ked merge`` waits for another writer of DEST (a merge or a campaign) to finish [s]."""


@dataclasses.dataclass(frozen=True)
class MergeReport:
    """What ``ked merge`` did: ``added`` scenes carried into DEST, ``kept`` offered scenes DEST already
    held, ``refused``: key -> why a scene of SRC was not carried (it fails the checks of
    ``ked inspect --verify``)."""

    added: int
    kept: int
    refused: dict[str, str]


def merge(src: str | Path, dest: str | Path, wait_s: float = MERGE_WAIT_S) -> MergeReport:
    """Add the scenes of results file ``src`` that ``dest`` lacks (or holds only as failed) to ``dest``
    (created if missing).  Both files must be harness files; ``src`` is not changed.  Every scene of
    ``src`` is checked as ``ked inspect --verify`` checks it (:func:`verify_scenes`); only those that
    verify are carried, the others are returned as refused.  The new ``dest`` is verified before it
    replaces the old one: a merge that would add a problem to ``dest`` raises :class:`StoreError` and
    changes nothing.  Holds ``dest``'s writer lock (waiting up to ``wait_s`` [s] for another writer)
    from reading ``dest`` to its atomic replacement, and writes the run record and the scenes in one
    transaction."""
    check_ours(src)
    check_ours(dest)
    check_writable(dest)
    offered = read_scenes(src)
    damage, checks = verify_scenes(src)
    if damage:  # the file's own tables or records are damaged: none of its scenes is carried
        more = f" and {len(damage) - 1} more problem(s)" if len(damage) > 1 else ""
        raise StoreError(f"{target(src)}: fails `ked inspect --verify` ({damage[0]}{more}); refusing to merge "
                         "from it; nothing was merged")
    refused = {k: p[0] + (f" (and {len(p) - 1} more problem(s))" if len(p) > 1 else "")
               for k, p in sorted(checks.items()) if p}
    carried = [r for r in offered if r.key not in refused]
    config = str(file_info(src).get("campaign_config", ""))
    with writer_lock(dest, wait_s=wait_s):
        check_ours(dest)
        have = stored_status(dest)
        new = [r for r in carried if have.get(r.key) is None or (have.get(r.key) == "failed" and r.ok)]
        if new or not target(dest).exists():
            before = set(verify(dest)) if target(dest).exists() else set()
            upgrade(dest)
            with transaction(dest, repack=True) as f, _hdf5_errors(target(dest)):
                run = _record_run(f, config, f"merge of {target(src).name}", len(new))
                _commit(f, new, run)
                f.flush()
                added = [p for p in _verify_image(f, target(dest)) if p not in before]
                if added:
                    raise StoreError(f"{target(dest)}: refusing to merge {target(src).name}: the result would not "
                                     f"verify ({added[0]}); {target(dest)} is unchanged")
    return MergeReport(len(new), len(carried) - len(new), refused)


def _verify_image(f: h5py.File, path: Path) -> list[str]:
    """:func:`verify` of the open in-memory file ``f`` (written to a private file beside ``path``)."""
    tmp = _tmp_beside(path)
    try:
        tmp.write_bytes(f.id.get_file_image())
        return [p.replace(str(tmp), str(path)) for p in verify(tmp)]
    finally:
        _discard(tmp)
