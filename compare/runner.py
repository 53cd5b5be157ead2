"""The campaign runner, on the one executor of the harness (:mod:`compare.executor`, whose public names it
re-exports for scripts that import them from here).

:func:`run_scenes` runs :func:`compare.execute.run_scene` over scene specs: it plans once, under the
results file's writer lock (one read of the store: skip stored scenes), and commits after every
completion (all results finished by then together, in one atomic file replacement, see
:mod:`compare.store`).  A SIGKILL therefore loses only the scenes still being computed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from compare import solvers, store
from compare.config import CampaignConfig
from compare.execute import run_scene
from compare.executor import (  # noqa: F401  (re-exported: the executor's public names, where they were defined)
    LocalPool,
    SchedulerError,
    WorkerError,
    WorkerStartError,
    crash_reason,
    default_workers,
    exit_if_starting_worker,
    kill_pool,
    probe_scheduler,
    run_tasks,
    worker_init,
)
from compare.results import STATUS_FAILED, STATUS_OK, RunStats, SceneResult
from compare.scenes import SceneSpec, canonical_json
from compare.solvers import Solution

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class Job:
    """A scene to compute, with the stored solutions it keeps (solver name -> solution)."""

    spec: SceneSpec
    reuse: dict[str, Solution]


@dataclass(frozen=True)
class Plan:
    """Scenes of a campaign split into those to compute and those already stored (by key)."""

    jobs: tuple[Job, ...]
    skipped: tuple[SceneSpec, ...]

    @property
    def todo(self) -> tuple[SceneSpec, ...]:
        return tuple(j.spec for j in self.jobs)


@dataclass(frozen=True)
class CampaignSummary:
    """Outcome of one :func:`run_campaign` call.  ``wall_s`` [s] of the whole call."""

    out: Path
    total: int
    skipped: int
    ok: int
    failed: int
    lost: int
    wall_s: float
    keys: tuple[str, ...]


def plan(scenes: Iterable[SceneSpec], stored: dict[str, str], retry_failed: bool = False,
         solutions: dict[str, dict[str, Solution]] | None = None) -> Plan:
    """Pure: which scenes still need computing given ``stored`` (key -> status) and the stored
    ``solutions`` (key -> solver -> solution).  A stored scene is computed again when ``retry_failed``
    and it failed (its successful solutions are kept), or when it lacks a requested solver (all its
    stored solutions are kept); otherwise it is skipped."""
    solutions = solutions or {}
    jobs, skipped = [], []
    for s in scenes:
        status, have = stored.get(s.key), solutions.get(s.key, {})
        mine = {n: sol for n, sol in have.items() if n in s.solvers}
        if status is None:
            jobs.append(Job(s, {}))
        elif retry_failed and status != STATUS_OK:
            jobs.append(Job(s, {n: sol for n, sol in mine.items() if sol.ok}))
        elif have and any(n not in have for n in s.solvers):
            jobs.append(Job(s, mine))
        else:
            skipped.append(s)
    return Plan(tuple(jobs), tuple(skipped))


class SettingsMismatchError(ValueError):
    """Stored scenes were computed with other resolved Exudyn settings than the current ones."""


def resolved_settings(spec: SceneSpec, solver: str) -> dict[str, Any]:
    """The settings the current code would use for ``solver`` on ``spec`` (as stored: JSON values)."""
    import json

    from compare.execute import settings_of

    sv = solvers.get(solver)
    return json.loads(canonical_json(sv.settings_dict(settings_of(sv, spec))))


def settings_diff(old: dict[str, Any], new: dict[str, Any], legacy: dict[str, Any]) -> dict[str, tuple[Any, Any]]:
    """Fields whose stored value differs from the current one; a field the stored settings lack (it
    was added later) counts as its ``legacy`` value, the one that reproduces the older behaviour."""
    old = {**{k: v for k, v in legacy.items() if k in new}, **old}
    return {k: (old.get(k), new.get(k)) for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)}


def check_stored_settings(specs: Iterable[SceneSpec], stored: dict[str, dict[str, Solution]]) -> None:
    """Refuse to resume onto stored solutions computed with other resolved settings than the current
    code would use.  A scene's content key hashes only the settings given explicitly, so a solution
    computed under older defaults would otherwise be silently reused."""
    problems = []
    for spec in specs:
        for name, sol in stored.get(spec.key, {}).items():
            if name not in spec.solvers or not sol.settings:
                continue
            diff = settings_diff(sol.settings, resolved_settings(spec, name), solvers.get(name).legacy_defaults())
            if diff:
                fields = ", ".join(f"{k}: stored {a!r} -> now {b!r}" for k, (a, b) in diff.items())
                problems.append(f"{spec.label} [{spec.key}] {name}: {fields}")
    if problems:
        shown = "\n  ".join(problems[:5]) + (f"\n  ... and {len(problems) - 5} more" if len(problems) > 5 else "")
        raise SettingsMismatchError(
            f"{len(problems)} stored solution(s) were computed with other settings than the current "
            f"defaults would give; resuming would mix them:\n  {shown}\n"
            "Write to a new --out file, or pin these settings in the config (e.g. its [dynamic] table).")


def _rescued(exc: store.CommitError, unsaved: list[SceneResult], out: Path, name: str, text: str) -> Exception:
    """The error to raise after a failed commit, once the scenes computed in this run are saved."""
    if not unsaved:
        return exc
    try:
        path = store.rescue(unsaved, out, text, name)
    except store.CommitError as exc2:
        return store.CommitError(f"{exc}; {exc2}")
    return store.CommitError(
        f"{exc}. The {len(unsaved)} scene(s) computed in this run are kept in {path}; once {out} can be written "
        f"again, `ked merge {path} {out}` adds them, and rerunning the campaign resumes the rest.")


# ------------------------------------------------------------------------------------------------------
# campaigns


def _worker_crashed(spec: SceneSpec, exc: BaseException | None) -> SceneResult:
    if exc is None:
        error_type, message = "WorkerCrashed", "the worker process died while computing this scene"
    else:
        error_type, message = type(exc).__name__, f"worker failed while computing the scene: {exc}"
    return SceneResult(spec=spec, status=STATUS_FAILED, stage="worker", error_type=error_type,
                       message=message[:2000], failure_class="numerical", stats=RunStats(finished_utc=store.utc_now()))


def _args(job: Job) -> tuple[SceneSpec, tuple[solvers.Solver, ...], dict[str, Solution]]:
    """Arguments of :func:`compare.execute.run_scene` for a job (solvers travel by reference)."""
    return job.spec, tuple(solvers.get(n) for n in job.spec.solvers), job.reuse


def stored_plan(scenes: Sequence[SceneSpec], out: str | Path, retry_failed: bool = False) -> Plan:
    """:func:`plan` against the results file ``out``, read once (only the scenes of ``scenes``), after
    refusing to resume onto solutions computed with other settings (:func:`check_stored_settings`).  With
    ``retry_failed`` the scenes that fail ``ked inspect --verify``'s checks count as not stored."""
    stored = {r.key: r for r in store.read_scenes(out, [s.key for s in scenes])} if scenes else {}
    if retry_failed and stored:  # a damaged scene (a history deleted, ...) is computed again, whole
        damaged = {k for k, problems in store.verify_scenes(out)[1].items() if problems}
        stored = {k: r for k, r in stored.items() if k not in damaged}
    solutions = {k: r.solutions for k, r in stored.items()}
    check_stored_settings(scenes, solutions)
    return plan(scenes, {k: r.status for k, r in stored.items()}, retry_failed, solutions)


def run_scenes(
    specs: Sequence[SceneSpec],
    out: str | Path,
    *,
    name: str,
    config_text: str = "",
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    on_result: Callable[[SceneResult], None] | None = None,
    on_start: Callable[[Plan], None] | None = None,
) -> CampaignSummary:
    """Run every scene of ``specs`` not yet stored in ``out`` and store the results there (see the
    module docstring); ``name`` and ``config_text`` go into the file's run record.

    ``workers``: local worker processes (default: available CPUs; ignored with ``scheduler``), see
    :func:`run_tasks` (a script calls this under ``if __name__ == "__main__":``).  ``retry_failed``:
    recompute stored failed scenes too.  ``progress``: tqdm bar on stderr.  ``on_result``: called
    with every stored result; ``on_start``: with the plan, once the workers are there.  Raises
    :class:`compare.store.LockedError` if another process is writing ``out`` and scenes are to be
    computed (with nothing to compute, nothing is written: a read-only file system is fine)."""
    exit_if_starting_worker()
    t0 = time.perf_counter()
    specs = tuple(specs)
    out = store.target(out)
    store.check_ours(out)
    with ExitStack() as locked:
        try:
            locked.enter_context(store.writer_lock(out))
            lock_error: Exception | None = None
        except (store.LockedError, store.CommitError) as exc:  # another writer, or no lock file possible
            lock_error = exc
        p = stored_plan(specs, out, retry_failed)  # the one read of the store, under the lock
        counts = {STATUS_OK: 0, STATUS_FAILED: 0}
        lost = 0
        if p.jobs:  # nothing to compute: nothing is written
            store.check_writable(out)
            if lock_error is not None:
                raise lock_error
            counts, lost = _compute(p, out, name, config_text, len(specs), workers=workers, scheduler=scheduler,
                                    progress=progress, on_result=on_result, on_start=on_start)
    return CampaignSummary(out=out, total=len(specs), skipped=len(p.skipped), ok=counts[STATUS_OK],
                           failed=counts[STATUS_FAILED], lost=lost, wall_s=time.perf_counter() - t0,
                           keys=tuple(s.key for s in specs))


def _compute(p: Plan, out: Path, name: str, text: str, n_scenes: int, *, workers: int | None,
             scheduler: str | None, progress: bool, on_result: Callable[[SceneResult], None] | None,
             on_start: Callable[[Plan], None] | None) -> tuple[dict[str, int], int]:
    """The plan's jobs through :func:`run_tasks`, each finished batch committed; returns the counts of
    ok / failed scenes and the jobs lost.  A failed commit stops the run: the scenes computed meanwhile
    go to a rescue file (:func:`compare.store.rescue`) named in the :class:`~compare.store.CommitError`."""
    from compare.progress import progress_bar

    counts = {STATUS_OK: 0, STATUS_FAILED: 0}
    unsaved: list[SceneResult] = []
    failure: list[store.CommitError] = []
    run: list[int] = []
    bars: list[Any] = []

    def ready() -> None:  # the workers are there (the run's record is written with its first scenes)
        store.remove_stale_temp_files(out)
        if on_start is not None:
            on_start(p)
        bars.append(progress_bar(len(p.jobs), name, unit="scene", enabled=progress, smoothing=0.1))
        bars[0].set_postfix(ok=0, failed=0, skipped=len(p.skipped), refresh=False)

    def commit(done: list[tuple[Job, SceneResult]]) -> bool:
        batch = [r for _, r in done]
        if not failure:
            try:
                if run:
                    store.commit(out, batch, run[0])
                else:
                    run.append(store.commit_first(out, batch, text, name, n_scenes))
            except store.CommitError as exc:  # keep what is computed; stop starting new scenes
                failure.append(exc)
        if failure:
            unsaved.extend(batch)
        for r in batch:
            counts[STATUS_OK if r.status == STATUS_OK else STATUS_FAILED] += 1
            if on_result is not None:
                on_result(r)
        bars[0].set_postfix(ok=counts[STATUS_OK], failed=counts[STATUS_FAILED], skipped=len(p.skipped),
                            refresh=False)
        bars[0].update(len(batch))
        return bool(failure)

    try:
        lost = run_tasks(p.jobs, run_scene, args=_args, workers=workers, scheduler=scheduler, on_result=commit,
                         crashed=lambda job, exc: _worker_crashed(job.spec, exc), on_ready=ready)
    finally:
        for bar in bars:
            bar.close()
    if failure:
        raise _rescued(failure[0], unsaved, out, name, text)
    return counts, lost


def run_campaign(
    config: CampaignConfig,
    out: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    on_result: Callable[[SceneResult], None] | None = None,
    on_start: Callable[[Plan], None] | None = None,
) -> CampaignSummary:
    """Run every scene of ``config`` not yet stored in ``out`` and store the results there: :func:`run_scenes`
    on the config's scenes (its name and text recorded in the file).

    ``workers``: local worker processes (default: available CPUs; ignored with ``scheduler``).  They are
    spawned and import the caller's main module, so a script must call this under
    ``if __name__ == "__main__":``; otherwise :class:`WorkerStartError` is raised and nothing is stored.
    ``retry_failed``: recompute stored failed scenes too.  ``progress``: tqdm bar on stderr.
    Raises :class:`compare.store.LockedError` if another campaign is writing ``out``.
    """
    exit_if_starting_worker()
    return run_scenes(config.scenes(), out, name=config.name, config_text=config.text, workers=workers,
                      scheduler=scheduler, retry_failed=retry_failed, progress=progress, on_result=on_result,
                      on_start=on_start)
