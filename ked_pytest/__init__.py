"""pytest plugin of ked-harness: regression tests on agreement tolerances in a user's own test suite.

Registered through the ``pytest11`` entry point (installing ked-harness enables it).  It gives:

- :func:`assert_agreement` (results file or scenes, expectations as keywords): fails naming every scene,
  quantity, value and bound that violates an expectation;
- :func:`assert_matches_baseline` (new results file, baseline file): ``ked diff``'s checks, failing with one line
  per failed check (scene, check, solver/quantity, value, bound);
- fixtures ``ked_campaign`` (runs a campaign config into a results file, resuming, or loads a file),
  ``ked_regen`` (whether ``--ked-regen`` was given) and ``ked_baseline`` (:func:`assert_matches_baseline` with
  ``--ked-regen`` applied);
- the option ``--ked-regen``: write missing baselines and refresh existing ones from the new results instead of
  comparing (as pytest-regressions' ``--force-regen``).  Without it a missing baseline fails the test, saying so.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest

__all__ = ["KedCampaign", "assert_agreement", "assert_matches_baseline"]
MAX_LINES = 30
"""The failure message lists at most this many failed checks (the count of the rest follows)."""


def _tolerances(tolerances: Any) -> Any:
    """None, a :class:`compare.tolerances.Tolerances`, a ``[tolerances]`` mapping, or a TOML file with one."""
    from compare.tolerances import Tolerances, parse_tolerances

    if tolerances is None or isinstance(tolerances, Tolerances):
        return tolerances
    if isinstance(tolerances, (str, Path)):
        try:
            import tomllib
        except ModuleNotFoundError:  # pragma: no cover - Python 3.10
            import tomli as tomllib  # type: ignore[no-redef]

        tolerances = tomllib.loads(Path(tolerances).read_text(encoding="utf-8")).get("tolerances", {})
    tol, problems = parse_tolerances(dict(tolerances))
    if problems:
        raise ValueError("; ".join(problems))
    return tol


def _results(results: Any) -> list:
    from compare import store

    return store.read_scenes(results) if isinstance(results, (str, Path)) else list(results)


def assert_agreement(results: str | Path | Sequence[Any], *, holds_below_speed_ratio: float | None = None,
                     verdict_error_below: Mapping[str, float] | None = None, holds: Iterable[str] = (),
                     fails: Iterable[str] = ()) -> None:
    """Assert the expectations on the agreement of a results file (or of :class:`compare.SceneResult` s): the
    quasi-static answer holds in every scene with r below ``holds_below_speed_ratio``; the verdict error is below
    ``verdict_error_below[mass model]`` (key "all": every scene); the scenes ``holds`` hold and ``fails`` fail
    (labels or key prefixes).  AssertionError naming each violation's scene, quantity, value and bound."""
    from compare.expect import parse_expect
    from ked_quasi.massmodel import MASS_MODELS

    table: dict[str, Any] = {"holds": list(holds), "fails": list(fails)}
    if holds_below_speed_ratio is not None:
        table["holds_below_speed_ratio"] = holds_below_speed_ratio
    if verdict_error_below:
        table["verdict_error_below"] = dict(verdict_error_below)
    exp, problems = parse_expect(table, MASS_MODELS, path="assert_agreement")
    if problems:
        raise ValueError("; ".join(problems))
    from compare.expect import check_expectations

    violations = check_expectations(_results(results), exp)
    if violations:
        lines = [v.message for v in violations]
        raise AssertionError(f"{len(violations)} expectation(s) violated:\n  " + "\n  ".join(lines[:MAX_LINES])
                             + (f"\n  ... and {len(lines) - MAX_LINES} more" if len(lines) > MAX_LINES else ""))


def assert_matches_baseline(new: str | Path, baseline: str | Path, *, tolerances: Any = None,
                            regen: bool = False) -> None:
    """Assert that results file ``new`` agrees with ``baseline`` (``ked diff``'s checks and tolerances:
    ``tolerances`` a :class:`compare.tolerances.Tolerances`, a ``[tolerances]`` mapping or a TOML file; None: the
    documented defaults).  ``regen``: copy ``new`` to ``baseline`` instead (a missing baseline fails unless
    ``regen``); an existing baseline that is not a results file is never overwritten."""
    from compare import store
    from compare.diff import diff_files

    new, baseline = Path(new), Path(baseline)
    if regen:
        if baseline.exists():
            store.file_info(baseline)  # StoreError if it is not a results file: the user's file is left alone
        baseline.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(new, baseline)
        return
    if not baseline.exists():
        raise AssertionError(f"no baseline {baseline}: run pytest with --ked-regen to write it from {new}")
    rep = diff_files(baseline, new, _tolerances(tolerances))
    if rep.passed:
        return
    lines = []
    for s in rep.failed_scenes:
        for c in s.failures:
            v = f"{100 * c.value:.4g} %" if isinstance(c.value, float) else c.value
            b = f"{100 * c.bound:.4g} %" if isinstance(c.bound, float) else c.bound
            lines.append(f"{s.label}: {c.name}: {v} (bound {b}, tier {c.tier or '-'})"
                         + (f" {c.message}" if c.message else ""))
    raise AssertionError(f"{new} differs from baseline {baseline} in {len(rep.failed_scenes)} scene(s) "
                         f"(refresh with --ked-regen if intended):\n  " + "\n  ".join(lines[:MAX_LINES])
                         + (f"\n  ... and {len(lines) - MAX_LINES} more" if len(lines) > MAX_LINES else ""))


class KedCampaign:
    """What the ``ked_campaign`` fixture gives: :meth:`run` a campaign config into a results file (resuming a
    stored one; default file: ``<session tmp dir>/<config stem>.h5``), :meth:`load` a results file's scenes."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp

    def run(self, config: str | Path, out: str | Path | None = None, workers: int = 1) -> Path:
        from compare.config import load_config
        from compare.runner import run_campaign

        config = Path(config)
        out = Path(out) if out is not None else self.tmp / f"{config.stem}.h5"
        summary = run_campaign(load_config(config), out, workers=workers, progress=False)
        return Path(summary.out)

    def load(self, path: str | Path) -> list:
        return _results(path)


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("ked", "ked-harness regression tests")
    group.addoption("--ked-regen", action="store_true", default=False,
                    help="ked-harness: write missing baselines and refresh existing ones from the new results "
                         "instead of comparing with them.")


@pytest.fixture
def ked_regen(request: pytest.FixtureRequest) -> bool:
    """Whether ``--ked-regen`` was given."""
    return bool(request.config.getoption("--ked-regen"))


@pytest.fixture(scope="session")
def ked_campaign(tmp_path_factory: pytest.TempPathFactory) -> KedCampaign:
    """Runs (:meth:`KedCampaign.run`) or loads (:meth:`KedCampaign.load`) a campaign; one temporary directory
    for the session, so a config run by several tests is computed once (the run resumes the stored file)."""
    return KedCampaign(tmp_path_factory.mktemp("ked"))


@pytest.fixture
def ked_baseline(ked_regen: bool) -> Any:
    """``ked_baseline(new, baseline, tolerances=None)``: :func:`assert_matches_baseline` with ``--ked-regen``."""

    def check(new: str | Path, baseline: str | Path, tolerances: Any = None) -> None:
        assert_matches_baseline(new, baseline, tolerances=tolerances, regen=ked_regen)

    return check
