"""``ked study NAME``: regenerate a study (campaigns, HDF5 files, figures, README section).

One signature for every study: resume by default (stored results are never deleted unless
``--fresh``), the same results directory, workers and report-only options."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from ked_cli.options import cap_workers

_DEFAULT_RESULTS = "<harness>/results"


def common_options(f: Any) -> Any:
    opts = [
        click.option("--results-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
                     help=f"Where to write: studies/ (HDF5), figures/, README.md (a README.md already there must be "
                          "one the harness made: it is never written into otherwise) "
                          f"[default: {_DEFAULT_RESULTS}, "
                          "the committed results of this checkout]."),
        click.option("--workers", type=click.IntRange(min=1), callback=cap_workers, default=2, show_default=True,
                     help="Campaign worker processes."),
        click.option("--fresh", is_flag=True, help="Delete this study's stored HDF5 files first and recompute "
                                                    "everything (default: resume, computing only what is missing)."),
        click.option("--report-only", is_flag=True, help="Compute nothing: figures and README section from the "
                                                          "stored files only."),
        click.option("--progress/--no-progress", default=False, show_default=True, help="Progress bars."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def _run(name: str, results_dir: Path | None, workers: int, fresh: bool, report_only: bool, progress: bool,
         **options: Any) -> None:
    from compare.sections import SectionError, check_markers
    from ked_research import StudyPaths, run

    paths = StudyPaths(results_dir) if results_dir is not None else StudyPaths()
    if fresh and report_only:
        raise click.UsageError("--fresh and --report-only exclude each other")
    try:
        check_markers(paths.readme)  # before the study runs: its section is written at the end
        summary = run(name, paths, workers=workers, fresh=fresh, report_only=report_only, progress=progress,
                      echo=lambda text: click.echo(text, err=True), **options)
    except SectionError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(json.dumps(summary, indent=2, default=str))


RETRY_FAILED = click.option("--retry-failed", is_flag=True,
                            help="Recompute the scenes stored as failed (with today's solvers: the Exudyn refinement "
                                 "ladder); successful stored scenes are kept.")


@click.group("study")
def study() -> None:
    """Regenerate a study: campaigns, HDF5 files, figures and its section of results/README.md."""


@study.command("validity")
@common_options
@click.option("--config", "configs", multiple=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Campaign config(s) [default: the checked-in results/studies/validity_*.toml].")
@click.option("--retry/--no-retry", default=True, show_default=True,
              help="Retry Newton failures through the Exudyn refinement ladder (more Newton iterations, steps per "
                   "cycle x2-x8, elements x2; the dynamic solver runs it itself): base scenes below r = 0.8 stored "
                   "with a Newton failure from a run without the ladder are recomputed with it.")
@click.option("--refine/--no-refine", default=True, show_default=True,
              help="Rerun the scenes bracketing each crossing at a doubled discretization.")
@RETRY_FAILED
def validity(configs: tuple[Path, ...], retry: bool, refine: bool, retry_failed: bool, **common: Any) -> None:
    """Validity map: when does the quasi-static (instantaneous-structure) assumption hold?"""
    _run("validity", configs=configs, retry=retry, refine=refine, retry_failed=retry_failed, **common)


@study.command("work-precision")
@common_options
@click.option("--retime-below", type=click.FloatRange(min=0.0), default=5.0, show_default=True,
              help="Re-time dynamic runs faster than this [s] twice more (median of 3).")
def work_precision(retime_below: float, **common: Any) -> None:
    """Error against run time of the dynamic and quasi-static solvers."""
    _run("work-precision", retime_below_s=retime_below, **common)


@study.command("tiers")
@common_options
def tiers(**common: Any) -> None:
    """Where the quasi-static error comes from (dynamics or nonlinearity); how far each model holds."""
    _run("tiers", **common)


@study.command("stability")
@common_options
@click.option("--ladder/--no-ladder", default=True, show_default=True,
              help="Report the step search of a Newton failure: the attempts of the Exudyn refinement ladder "
                   "(steps per cycle x2-x8, elements x2; a scene run without the ladder is rerun with it).")
@RETRY_FAILED
def stability(ladder: bool, retry_failed: bool, **common: Any) -> None:
    """Numerical stability of the solvers on stiff and extreme scenes."""
    _run("stability", ladder=ladder, retry_failed=retry_failed, **common)


@study.command("atlas")
@common_options
@click.option("--linkages", type=click.IntRange(min=1), default=1000, show_default=True,
              help="Linkages in the atlas (the first N accepted of the seeded sample; more resumes and extends).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the linkage sample.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Dask scheduler address (e.g. tcp://10.0.0.5:8786) [default: --workers local worker processes].")
@click.option("--confirm", type=click.IntRange(min=0), default=200, show_default=True,
              help="Scenes of the stratified sample confirmed with Exudyn (0: none).")
@click.option("--threshold", type=click.IntRange(min=0), default=400, show_default=True,
              help="Scenes confirmed with Exudyn within +-25 % of their family's quasi-static 10 % limit, from which "
                   "the check's margins are chosen per stratum (0: none).")
@click.option("--threshold-top-up", type=click.IntRange(min=0), default=400, show_default=True,
              help="Scenes of a second, independent draw of the same threshold design, so that every stratum (mass "
                   "model x mechanism) has the Exudyn answers its own margins need (0: none).")
@click.option("--slider-linkages", type=click.IntRange(min=0), default=200, show_default=True,
              help="Generated slider-cranks in the slider atlas (results/atlas/slider_atlas.h5: its own families, "
                   "confirmed and threshold samples, margins per slider stratum; more resumes and extends; 0: none).")
def atlas(linkages: int, seed: int, scheduler: str | None, confirm: int, threshold: int, threshold_top_up: int,
          slider_linkages: int, **common: Any) -> None:
    """Validity atlas: the quasi-static and linear models' limits over a sample of four-bars and of
    slider-cranks."""
    from compare.executor import SchedulerError
    from ked_cli.errors import UserError
    from ked_research.atlas.store import AtlasFileError

    try:
        _run("atlas", linkages=linkages, seed=seed, scheduler=scheduler, confirm=confirm, threshold=threshold,
             threshold_top_up=threshold_top_up, slider_linkages=slider_linkages, **common)
    except (AtlasFileError, SchedulerError) as exc:
        raise UserError(str(exc)) from None


@study.command("stress")
@common_options
@click.option("--atlas-linkages", type=click.IntRange(min=0), default=2, show_default=True,
              help="Generated four-bars of the atlas sample (the first N of the atlas's seeded sample), beside the "
                   "thesis linkage and Simeon's slider-crank.")
def stress(atlas_linkages: int, **common: Any) -> None:
    """Link stresses: where the quasi-static stress holds against where the quasi-static deflection holds, and
    the fatigue safety factor of each tier (quasi-static, linear, Exudyn)."""
    _run("stress", atlas_linkages=atlas_linkages, **common)
