"""HDF5 backend of campaign results (layout: ``docs/hdf5_schema.md``).

Crash safety: HDF5 is not journaled, so the results file is never modified in place.  Every change
(:func:`commit`, :func:`record_run`) copies the current file to a temporary file in the same
directory, modifies the copy, closes and fsyncs it and atomically renames it onto the results file
(``os.replace``), then fsyncs the directory.  A SIGKILL at any moment therefore leaves either the old
or the new complete file (plus, at worst, a stale ``*.h5.tmp-*`` file that is ignored and cleaned up
on the next run).  Each scene group additionally gets its ``complete`` attribute last, and readers
ignore groups without it.  Only one process (the campaign's parent) writes.

Everything is plain HDF5 (groups, numeric datasets, string/number attributes, no pickles).

The store is six modules, each with one job, and this one names their public API (the names every caller uses):
:mod:`compare.h5file` (the atomic file layer: transactions, the writer lock, stale temporary files),
:mod:`compare.reader` (whose file, its schema version, its scenes), :mod:`compare.upgrade` (older layouts),
:mod:`compare.writer` (the commit protocol), :mod:`compare.verify` (``ked inspect --verify``) and
:mod:`compare.merge` (rescue and merge).
"""

from __future__ import annotations

from compare.h5file import (  # noqa: F401 (the store's public API)
    COMMIT_HEADROOM,
    LIBVER,
    LOCK_MARK,
    REPACK_SHARE,
    TMP_MARK,
    CommitError,
    LockedError,
    check_writable,
    is_locked,
    remove_stale_temp_files,
    stale_temp_files,
    target,
    transaction,
    writer_lock,
)
from compare.merge import (  # noqa: F401 (the store's public API)
    MERGE_WAIT_S,
    MergeReport,
    merge,
    rescue,
)
from compare.reader import (  # noqa: F401 (the store's public API)
    READABLE_VERSIONS,
    RUNS,
    SCENES,
    SCHEMA,
    SCHEMA_VERSION,
    TABLE_LAYOUT,
    StoreError,
    array_bytes,
    check_ours,
    file_info,
    file_kind,
    layout_contradiction,
    read_scenes,
    run_records,
    schema_version,
    size_ratio,
    stored_solutions,
    stored_status,
)
from compare.results import utc_now  # noqa: F401 (store.utc_now: its users' name)
from compare.upgrade import (  # noqa: F401 (the store's public API)
    upgrade,
)
from compare.verify import (  # noqa: F401 (the store's public API)
    verify,
    verify_scenes,
)
from compare.writer import (  # noqa: F401 (the store's public API)
    commit,
    commit_first,
    git_commit,
    provenance,
    record_run,
    with_kept_solutions,
)

