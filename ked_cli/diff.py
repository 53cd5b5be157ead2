"""``ked diff BASELINE NEW``: regression comparison of two results files (a thin click wrapper of
:mod:`compare.diff`)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from ked_cli.campaign import _regular


def load_tables(path: Path) -> tuple[Any, Any]:
    """(Tolerances or None, Expectations or None) of a TOML file's ``[tolerances]`` and ``[expect]`` tables
    (a campaign config, or a file of only those tables); a bad file is a usage error naming it."""
    from compare.tomlcheck import ConfigError, read_toml

    try:
        doc = read_toml(path)
    except ConfigError as exc:
        raise click.UsageError(f"--tolerances {path}: {'; '.join(exc.problems)}") from None
    if "tolerances" not in doc and "expect" not in doc:
        raise click.UsageError(f"--tolerances {path}: no [tolerances] or [expect] table (tables found: "
                               f"{', '.join(doc) or 'none'})")
    return parse_tables(doc, f"--tolerances {path}")


def parse_tables(doc: dict[str, Any], where: str) -> tuple[Any, Any]:
    """(Tolerances or None, Expectations or None) of a parsed TOML document; a problem is a usage error."""
    from compare.diff import regression_tables

    tol, exp, problems = regression_tables(doc)
    if problems:
        raise click.UsageError(f"{where}: {'; '.join(problems)}")
    return tol, exp


EPILOG = """\b
Exit status: 0 every scene within tolerance and every expectation met; 1 a check failed (a verdict
flip, a drift beyond its tolerance, a status change ok -> failed, a NaN or inf, a scene missing or
added, an expectation violated); 2 bad input (a file that is not a results file, a bad tolerances
file), one line naming it.
"""


@click.command("diff", epilog=EPILOG)
@click.argument("baseline", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("new", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--tolerances", "tol_file", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="TOML file with a [tolerances] table (tiers same/physics, per solver: history, history_abs, "
                   "verdict_error) and/or an [expect] table, e.g. a campaign config [default: the tables of "
                   "the campaign config stored in NEW, else the documented defaults].")
@click.option("--json", "as_json", is_flag=True, help="Print the whole comparison as JSON (every scene and check).")
@click.option("--junit", "junit", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write JUnit XML to this file: one test case per scene and check, for CI systems.")
@click.option("--figures", "figures", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Directory for PNG figures of baseline and new histories overlaid, one per scene that "
                   "drifted beyond its tolerance.")
def diff_cmd(baseline: Path, new: Path, tol_file: Path | None, as_json: bool, junit: Path | None,
             figures: Path | None) -> None:
    """Compare results file NEW with BASELINE, scene by scene, on agreement tolerances.

    Scenes are matched by content key, else by the physical scene (linkage, mechanism, mass model,
    speed, stiffness, damping, direction; the settings that differ are named). Per scene and solver:
    verdict flips, the drift of each verdict error (absolute, in points), each stored history's drift
    (max |new - base| over the baseline's peak, with an absolute floor), status changes, NaN/inf,
    missing and added scenes. Tier `same` (same settings and versions: round-off) or `physics`
    (settings or versions changed: the reference's stated uncertainty); defaults in the README,
    "Regression tests". Prints failing scenes worst first (within 100 columns).
    """
    from compare import store
    from compare.diff import diff_files, format_report, junit_xml, stored_tables

    _regular(baseline, "BASELINE")
    _regular(new, "NEW")
    if tol_file is not None:
        tol, exp = load_tables(tol_file)
    else:
        try:
            tol, exp = parse_tables(stored_tables(new), f"NEW {new}: its stored campaign config")
        except (ValueError, store.StoreError) as exc:
            raise click.UsageError(str(exc)) from None
    try:
        rep = diff_files(baseline, new, tol, exp)
    except store.StoreError as exc:
        raise click.UsageError(str(exc)) from None
    except (KeyError, RuntimeError, OSError) as exc:  # HDF5 reports a damaged file so
        raise click.UsageError(f"{baseline} or {new}: damaged ({type(exc).__name__}: {str(exc)[:200]}); "
                               "`ked inspect FILE --verify` names the damage") from None
    if junit is not None:
        _regular(junit, "--junit")
        junit.write_text(junit_xml(rep), encoding="utf-8")
    if figures is not None:
        from compare.diff_figures import FigureDirError, write_diff_figures

        try:
            write_diff_figures(rep, baseline, new, figures)
        except FigureDirError as exc:
            raise click.ClickException(str(exc)) from None
    if as_json:
        click.echo(json.dumps(rep.to_dict(), indent=2))
    else:
        click.echo(format_report(rep))
    sys.exit(0 if rep.passed else 1)
