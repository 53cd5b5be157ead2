"""``ked run``, ``ked inspect`` and ``ked plot``: the campaign commands (thin click wrappers)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from ked_cli.options import cap_workers

DEFAULT_DIR = Path("ked_results")
LARGE_GRID = 1000
"""A grid this large gets a warning with its estimated run time before anything runs."""
FIGURE_FORMATS = ("png", "svg", "pdf")
"""The figure formats offered (compare.figure_dir.FORMATS; not imported here: matplotlib costs start-up time)."""
SECONDS_PER_SCENE = 2.5
"""Rough cost of one scene with the Exudyn model on one core (the default campaign's median)."""


WIDE_HELP = ("Print the summary table with every column and whole scene labels and keys (lines may be "
             "wider than 100 columns); default: a compact table of at most 100 columns.")


def wrap(text: str) -> str:
    """One message in lines of at most 100 columns (continuation lines indented)."""
    import textwrap

    return textwrap.fill(text, width=100, subsequent_indent="  ", break_on_hyphens=False, break_long_words=False)


def default_out(cfg: Any, config: Path | None) -> Path:
    """The results file when --out is not given: ``ked_results/<campaign name>.h5``, where a config
    without ``[campaign] name`` takes its file's name (``my_grid.toml`` -> ``my_grid``)."""
    name = cfg.name
    if config is not None and not _names_itself(cfg.text):
        name = config.stem
    return DEFAULT_DIR / f"{_safe_name(name)}.h5"


def _names_itself(text: str) -> bool:
    """Whether a config's TOML text sets ``[campaign] name``."""
    import tomllib

    try:
        return "name" in tomllib.loads(text).get("campaign", {})
    except (tomllib.TOMLDecodeError, AttributeError):
        return True


def _figures_dir(out: Path) -> Path:
    return out.with_name(f"{out.stem}_figures")


def _safe_name(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name) or "campaign"


def _regular(path: Path, what: str) -> None:
    """Refuse (exit 2) a path that exists but is not a regular file, or cannot be followed (a symbolic
    link loop): a FIFO would block the command forever."""
    import stat

    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return  # absent (or a dangling link): the command says what it needs
    except OSError as exc:
        raise click.UsageError(f"{what} {path}: {exc.strerror or exc}; give a results file (.h5)") from None
    if not stat.S_ISREG(mode):
        raise click.UsageError(f"{what} {path}: not a regular file (a FIFO, socket, device or directory); "
                               "give a results file (.h5)")


def _load(config: Path | None) -> Any:
    from compare.config import ConfigError, load_config
    from ked_cli.errors import ProblemsError

    try:
        return load_config(config)
    except ConfigError as exc:
        raise ProblemsError(exc.source, exc.problems) from None


def _results(file: Path) -> list:
    from compare import store
    from compare.inspect import sort_key

    try:
        return sorted(store.read_scenes(file), key=sort_key)
    except store.StoreError as exc:
        raise click.ClickException(str(exc)) from None


@click.command("run")
@click.argument("config", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "out", type=click.Path(dir_okay=False, path_type=Path),
              help="Results file [default: ked_results/<campaign name>.h5; for a config without a "
                   "[campaign] name: ked_results/<config file name>.h5].")
@click.option("--workers", type=click.IntRange(min=1), callback=cap_workers, default=None,
              help="Local worker processes [default: available CPUs].")
@click.option("--scheduler", metavar="ADDRESS", default=None,
              help="Run the scenes on a Dask distributed cluster at this scheduler address.")
@click.option("--figures", "figures", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Directory for the figures [default: <out stem>_figures next to the file].")
@click.option("--no-figures", is_flag=True, help="Do not draw figures.")
@click.option("--figure-format", "fmt", type=click.Choice(FIGURE_FORMATS), default="png", show_default=True,
              help="File format of the figures (svg, pdf: vector drawings for reports and papers).")
@click.option("--dpi", type=click.IntRange(min=20, max=1200), default=110, show_default=True,
              help="Resolution of the figures [dots per inch].")
@click.option("--retry-failed", is_flag=True, help="Recompute scenes stored as failed.")
@click.option("--dry-run", is_flag=True, help="Validate the config, list the scenes and what would run; stop.")
@click.option("--progress/--no-progress", default=True, help="Show the progress bar.")
@click.option("--wide", is_flag=True, help=WIDE_HELP)
def run_cmd(config: Path | None, out: Path | None, workers: int | None, scheduler: str | None,
            figures: Path | None, no_figures: bool, fmt: str, dpi: int, retry_failed: bool, dry_run: bool,
            progress: bool, wide: bool) -> None:
    """Run a comparison campaign (CONFIG: TOML file; none = the embedded default campaign).

    Scenes already stored in the results file are skipped, so rerunning resumes an interrupted
    campaign (a stored scene missing one of the campaign's solvers gets just that solver).  Prints a
    summary table and writes figures at the end.
    """
    cfg = _load(config)
    out = out or default_out(cfg, config)
    _regular(out, "--out")
    n = cfg.grid.size()
    if n > LARGE_GRID:
        hours = n * SECONDS_PER_SCENE / (workers or 2) / 3600 if "dynamic" in cfg.solvers else 0.0
        click.echo(f"warning: {n} scenes" + (f", roughly {hours:.1f} h with the Exudyn model on "
                                             f"{workers or 2} workers" if hours else ""), err=True)
    if dry_run:
        _dry_run(cfg, out, retry_failed)
        return
    fig_dir = (figures or _figures_dir(out)).absolute()  # still right if the working directory goes away
    if not no_figures:
        _check_figure_dir(fig_dir, fmt, out)  # before computing: a directory of the user's own files is refused now
    from compare import store
    from compare.executor import SchedulerError, WorkerError, WorkerStartError, default_workers
    from compare.inspect import format_counts, format_table, summary_row
    from compare.runner import SettingsMismatchError, run_campaign

    note = _other_settings_note(cfg, out)

    def started(p: Any) -> None:
        click.echo(_start_line(cfg, n, p, out), err=True)
        if note:
            click.echo(wrap(note), err=True)

    try:
        summary = run_campaign(cfg, out, workers=workers, scheduler=scheduler, retry_failed=retry_failed,
                               progress=progress, on_start=started)
    except (store.LockedError, SettingsMismatchError, store.StoreError, store.CommitError, SchedulerError,
            WorkerStartError, WorkerError) as exc:
        raise click.ClickException(str(exc)) from None
    from compare.inspect import sort_key

    order = set(summary.keys)
    # the resolved path: a relative --out must still name the file if the working directory went away;
    # the order of `ked inspect` (compare.inspect.sort_key)
    results = sorted((r for r in store.read_scenes(summary.out) if r.key in order), key=sort_key)
    click.echo(format_table([summary_row(r) for r in results], wide=wide))
    click.echo(format_counts(results))
    click.echo(wrap(f"this run: {summary.ok} ok, {summary.failed} failed, {summary.skipped} skipped (already stored)"
                    + (f", {summary.lost} lost to a crashed worker (rerun to retry)" if summary.lost else "")
                    + f" in {summary.wall_s:.1f} s; results: {out}"))
    if not no_figures:
        paths = _write_figures(results, fig_dir, workers=1 if scheduler else (workers or default_workers()),
                               fmt=fmt, dpi=dpi, source=out, progress=progress)
        click.echo(wrap(f"figures: {len(paths)} {fmt.upper()} files (re)drawn in {fig_dir} (index.json: file -> "
                        "scene)"))
    if cfg.expect:
        _report_expectations(results, cfg.expect)


def _report_expectations(results: list, expect: Any) -> None:
    """Print every violated expectation (one line each: scene, quantity, value, bound) and exit 1 if any."""
    from compare.expect import check_expectations

    violations = check_expectations(results, expect)
    for v in violations:
        click.echo(wrap(f"EXPECT {v.message}"))
    click.echo(wrap(f"expectations: {len(violations)} violated" if violations else "expectations: all met"))
    if violations:
        sys.exit(1)


def _other_settings_note(cfg: Any, out: Path) -> str:
    """One line when ``out`` already holds some of the campaign's physical scenes computed with other settings
    (e.g. a file of an earlier default campaign): the run adds its own beside them ("" otherwise, or when the file
    cannot be read: the run itself then says why)."""
    from compare import store
    from compare.physical import other_settings

    if not out.is_file():
        return ""
    scenes = cfg.scenes()
    try:
        others = set(store.stored_status(out)) - {s.key for s in scenes}  # only these can be other settings
        count, differ = other_settings(scenes, [r.spec for r in store.read_scenes(out, sorted(others))]
                                       if others else [])
    except (store.StoreError, OSError, ValueError):
        return ""
    if not count:
        return ""
    shown = "; ".join(differ[:3]) + (f"; ... {len(differ) - 3} more" if len(differ) > 3 else "")
    return (f"note: {out.name} also holds {count} of these scenes computed with other settings ({shown}); this "
            "run stores its own beside them under their own keys and reports only its own (ked inspect lists both)")


def _start_line(cfg: Any, n: int, p: Any, out: Path) -> str:
    """The one line that starts a run, in at most 100 columns where it can: without the solvers (the
    table has a column for each) and then with the results file's name alone (the last line of the run
    names the whole path) where the whole line would be longer."""
    head = f"campaign {cfg.name!r}: {n} scenes ({len(p.jobs)} to run, {len(p.skipped)} stored)"
    solvers = f", solvers {'+'.join(cfg.solvers)}"
    lines = [f"{head}{solvers} -> {out}", f"{head} -> {out}", f"{head}{solvers} -> {out.name}", f"{head} -> {out.name}"]
    return next((ln for ln in lines if len(ln) <= 100), lines[-1])


def _dry_run(cfg: Any, out: Path, retry_failed: bool) -> None:
    from compare import store
    from compare.runner import plan

    scenes = cfg.scenes()
    try:
        p = plan(scenes, store.stored_status(out), retry_failed, store.stored_solutions(out))
    except store.StoreError as exc:
        raise click.ClickException(str(exc)) from None
    todo = {s.key for s in p.todo}
    click.echo(wrap(f"campaign {cfg.name!r}: {len(scenes)} scenes, {len(p.todo)} to run, "
                    f"{len(p.skipped)} already in {out}; solvers {', '.join(cfg.solvers)}"))
    from compare.inspect import spec_sort_key

    for s in sorted(scenes, key=spec_sort_key):  # the order of the summary table
        click.echo(f"  {s.key}  {'run ' if s.key in todo else 'skip'}  {s.label}")


@click.command("inspect")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("scene", required=False)
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON output.")
@click.option("--verify", is_flag=True, help="Check the file's integrity and schema; exit 1 on problems.")
@click.option("--wide", is_flag=True, help=WIDE_HELP)
@click.option("--expect", "expect", is_flag=True,
              help="Check the [expect] table of the campaign config stored in FILE (what the verdicts must be); "
                   "print each violation (scene, quantity, value, bound) and exit 1 if any.")
def inspect_cmd(file: Path, scene: str | None, as_json: bool, verify: bool, wide: bool, expect: bool) -> None:
    """Show a results FILE: summary table of its scenes, or one SCENE (key prefix or label) in detail."""
    _regular(file, "FILE")
    if verify:
        _verify(file, as_json)
        return
    if expect:
        _inspect_expect(file, as_json)
        return
    from compare import store

    if store.file_kind(file) == "atlas":
        _inspect_atlas(file, scene, as_json)
        return
    from compare.inspect import find_scene, format_counts, format_detail, format_table, scene_detail, summary_row
    from ked_cli.options import json_text

    results = _results(file)
    if scene:
        try:
            r = find_scene(results, scene)
        except ValueError as exc:
            raise click.ClickException(str(exc)) from None
        click.echo(json_text(scene_detail(r), indent=2, default=str) if as_json else format_detail(r))
        return
    rows = [summary_row(r) for r in results]
    try:
        info = store.file_info(file)
    except store.StoreError as exc:
        raise click.ClickException(str(exc)) from None
    if as_json:
        click.echo(json_text({"file": str(file), "attributes": info, "scenes": rows}, indent=2, default=str))
        return
    click.echo(wrap(f"{file}: campaign {info.get('campaign_name')!r}, created {info.get('created_utc')}, "
                    f"harness {info.get('harness_version')} ({info.get('git_commit', '')[:10] or 'no git'}), "
                    f"exudyn {info.get('exudyn_version')}, schema version {info.get('schema_version')}"))
    click.echo(format_table(rows, wide=wide))
    click.echo(format_counts(results))


def _inspect_expect(file: Path, as_json: bool) -> None:
    from compare import store
    from compare.diff import regression_tables, stored_tables
    from compare.expect import check_expectations

    try:
        _, exp, problems = regression_tables(stored_tables(file))
    except (ValueError, store.StoreError) as exc:
        raise click.UsageError(str(exc)) from None
    if problems:
        raise click.UsageError(f"{file}: its stored campaign config: {'; '.join(problems)}")
    if not exp:
        raise click.UsageError(f"{file}: its stored campaign config has no [expect] table (nothing to check)")
    if not as_json:
        _report_expectations(_results(file), exp)
        return
    violations = check_expectations(_results(file), exp)
    click.echo(json.dumps({"file": str(file), "expect": exp.to_dict(), "met": not violations,
                           "violations": [v.to_dict() for v in violations]}, indent=2))
    sys.exit(1 if violations else 0)


def _inspect_atlas(file: Path, scene: str | None, as_json: bool) -> None:
    """An atlas file: its summary (it has no scenes to show one by one)."""
    from ked_cli.options import json_text
    from ked_research.atlas import store as atlas_store

    if scene:
        raise click.ClickException(f"{file}: an atlas file has tables, not scenes; SCENE {scene!r} cannot be shown "
                                   "(leave it out for the atlas's summary)")
    try:
        summary = atlas_store.summary(file)
    except Exception as exc:  # damage: HDF5 reports it as OSError, KeyError, ValueError or RuntimeError
        raise click.ClickException(f"{file}: the atlas tables are unreadable ({type(exc).__name__}: "
                                   f"{str(exc).splitlines()[0][:200] if str(exc) else ''}); check it with "
                                   "`ked inspect FILE --verify`") from None
    if as_json:
        click.echo(json_text({"file": str(file), **summary}, indent=2, default=str))
        return
    click.echo(wrap(f"{file}:"))
    for line in atlas_store.describe(summary):
        click.echo(wrap(line))


def _verify(file: Path, as_json: bool) -> None:
    from compare import store

    problems = store.verify(file)
    # a writer running now (it holds the lock) owns its temporary file: not stale
    stale = [] if store.is_locked(file) else store.stale_temp_files(file)
    atlas = store.file_kind(file) == "atlas"
    try:
        n = 0 if atlas else len(store.stored_status(file))
    except store.StoreError:
        n = 0
    what = "atlas file" if atlas else f"{n} complete scenes"
    if as_json:
        click.echo(json.dumps({"file": str(file), "kind": "atlas" if atlas else "campaign", "valid": not problems,
                               "scenes": n, "problems": problems, "stale_temp_files": [str(p) for p in stale]},
                              indent=2))
    else:
        for p in problems:  # one line per problem, like an error (greppable): not wrapped
            click.echo(f"PROBLEM {p}")
        for p in stale:
            click.echo(f"note: stale temporary file (ignored, removed by the next run): {p}")
        click.echo(wrap(f"{file}: {'INVALID' if problems else 'valid'}, {what}"
                        + (f", {len(problems)} problem(s)" if problems else "")))
    sys.exit(1 if problems else 0)


@click.command("merge")
@click.argument("src", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("dest", type=click.Path(dir_okay=False, path_type=Path))
def merge_cmd(src: Path, dest: Path) -> None:
    """Add the scenes of results file SRC (e.g. a rescue file) that DEST lacks to DEST (SRC unchanged).

    Every scene of SRC is checked as `ked inspect SRC --verify` checks it; only the scenes that verify
    are carried.  Each refused scene gets one line on stderr (its key and why), and the command then
    exits with status 1 (the scenes that verified are merged).  A SRC whose tables are damaged, or a
    merge that would make DEST fail `ked inspect DEST --verify`, changes nothing and exits 1."""
    from compare import store

    _regular(src, "SRC")
    _regular(dest, "DEST")
    try:
        report = store.merge(src, dest)
    except (store.StoreError, store.CommitError, store.LockedError) as exc:
        raise click.ClickException(str(exc)) from None
    for key, why in report.refused.items():  # one line each, like an error (greppable): not wrapped
        click.echo(f"ked: refused scene {key} of {src}: {why}", err=True)
    click.echo(wrap(f"{report.added} scene(s) added to {dest}; {report.kept} already there (kept)"
                    + (f"; {len(report.refused)} refused (they fail `ked inspect {src} --verify`)"
                       if report.refused else "")))
    if report.refused:
        sys.exit(1)


@click.command("plot")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output directory [default: <file stem>_figures next to the file].")
@click.option("--workers", type=click.IntRange(min=1), callback=cap_workers, default=None,
              help="Processes drawing the figures [default: available CPUs].")
@click.option("--format", "fmt", type=click.Choice(FIGURE_FORMATS), default="png", show_default=True,
              help="File format of the figures (svg, pdf: vector drawings for reports and papers).")
@click.option("--dpi", type=click.IntRange(min=20, max=1200), default=110, show_default=True,
              help="Resolution of the figures [dots per inch].")
@click.option("--progress/--no-progress", default=True, help="Show the progress bar (on a terminal).")
def plot_cmd(file: Path, out_dir: Path | None, workers: int | None, fmt: str, dpi: int, progress: bool) -> None:
    """Draw figures of a results FILE: per-scene histories and coupler curves, amplification vs speed.

    A figure directory holds the figures of one results file (its index.json names it); figures of
    another results file there are refused, never overwritten.
    """
    from compare import store
    from compare.executor import default_workers

    _regular(file, "FILE")
    results = _results(file)
    damaged = {k: v for k, v in store.verify_scenes(file)[1].items() if v}
    for key, problems in sorted(damaged.items()):  # a damaged scene is not drawn (its arrays do not fit)
        click.echo(f"ked: {file}: scene {key} is damaged ({problems[0][:200]}); not drawn (`ked inspect "
                   f"{file.name} --verify` lists the damage)", err=True)
    results = [r for r in results if r.key not in damaged]
    target = out_dir or _figures_dir(file)
    paths = _write_figures(results, target, workers=workers or default_workers(), fmt=fmt, dpi=dpi, source=file,
                           progress=progress)
    click.echo(wrap(f"{len(paths)} {fmt.upper()} files (re)drawn in {target} ({len(results)} scenes; index.json: "
                    "file -> scene)"))
    if damaged:
        sys.exit(1)



def _check_figure_dir(fig_dir: Path, fmt: str = "png", source: Path | None = None) -> None:
    from compare.figure_dir import FigureDirError, check_figure_dir

    try:
        check_figure_dir(fig_dir, fmt=fmt, source=source)
    except FigureDirError as exc:
        raise click.ClickException(str(exc)) from None


def _write_figures(results: list, fig_dir: Path, workers: int, fmt: str = "png", dpi: int = 110,
                   source: Path | None = None, progress: bool = True) -> list[Path]:
    """The figures of ``results`` in ``fig_dir`` under a progress bar; a file there the harness did not
    write, or the figures of another results file, is refused; an OS failure names the file."""
    from compare.figure_dir import FigureDirError, figure_count, write_figures
    from compare.progress import progress_bar

    try:
        with progress_bar(figure_count(results), "figures", unit="figure", enabled=progress) as bar:
            return write_figures(results, fig_dir, workers=workers, fmt=fmt, dpi=dpi, source=source,
                                 on_each=lambda p: bar.update(1))
    except FigureDirError as exc:
        raise click.ClickException(str(exc)) from None
