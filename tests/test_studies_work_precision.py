"""Work-precision study: pure helpers, README sections, checked-in configs; the full
study runs are slow tests."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from compare.config import load_config
from compare.metrics import cycle_error
from compare.sections import markers, replace_section
from ked_research.work_precision.analysis import (
    Choice,
    Discretization,
    WPPoint,
    choose,
    coarsest_failures,
    is_reference,
    observed_order,
    pareto_mask,
)
from ked_research.work_precision.study import CONFIGS, STUDIES, family_key, lump_convergence


def test_replace_section_appends_replaces_and_leaves_others_alone() -> None:
    text = "# t\n\n<!-- BEGIN other -->\nkeep me\n<!-- END other -->\n"
    once = replace_section(text, "mine", "first")
    assert "keep me" in once and once.count(markers("mine")[0]) == 1
    twice = replace_section(once, "mine", "second\n")
    assert "first" not in twice and "second" in twice and twice.startswith(text.rstrip("\n"))
    assert replace_section(twice, "mine", "second") == twice
    assert replace_section("", "mine", "x").startswith("# ked-harness results")
    with pytest.raises(ValueError):
        replace_section("<!-- END mine -->\n<!-- BEGIN mine -->", "mine", "x")


def test_cycle_error_and_pareto_front() -> None:
    ref = np.zeros((4, 3))
    ref[:, 0], ref[:, 2] = [1.0, -2.0, 0.5, 0.0], [0.1, 0.0, -0.1, 0.0]
    d = ref.copy()
    d[1, 0] += 0.02  # 1 % of the xy peak
    d[0, 2] += 0.005  # 5 % of the rotation peak
    assert cycle_error(d, ref) == pytest.approx(0.05)
    assert cycle_error(np.full((4, 3), np.nan), ref) == math.inf
    mask = pareto_mask([1, 2, 3, 4, 2], [0.5, 0.1, 0.2, 0.01, math.nan])
    assert mask.tolist() == [True, True, False, True, False]


def _pt(fam: str, disc: Discretization, wall: float, err: float, ok: bool = True) -> WPPoint:
    return WPPoint(fam, disc, False, ok, wall, 1, err, 4, 100, "")


def test_choose_cheapest_within_budget_on_every_scene() -> None:
    a, b, c = (Discretization("ancf", n, 90 * n, 0.9) for n in (1, 2, 4))
    pts = [_pt("x", a, 0.1, 0.02), _pt("y", a, 0.1, 0.001),
           _pt("x", b, 0.3, 0.004), _pt("y", b, 0.3, 0.002),
           _pt("x", c, 1.0, 0.001), _pt("y", c, 1.0, 0.0005, ok=True)]
    ch = choose(pts, 0.01, 2)
    assert isinstance(ch, Choice) and ch.disc == b and ch.total_wall_s == pytest.approx(0.6)
    assert choose(pts, 0.001, 2).disc == c
    assert choose(pts, 1e-6, 2).disc is None


def test_observed_order() -> None:
    n = np.array([1, 2, 4, 8, 16])
    assert observed_order(n, 3.0 / n**2) == pytest.approx(2.0)


def test_lump_convergence_midpoint_is_second_order() -> None:
    pts = lump_convergence(models=("extender",), placements=("midpoint", "end"), lumps=(4, 8, 16), reference=64,
                           repeats=1)
    mid = [p.error for p in pts if p.placement == "midpoint"]
    end = [p.error for p in pts if p.placement == "end"]
    assert observed_order([4, 8, 16], mid) > 1.8 and 0.8 < observed_order([4, 8, 16], end) < 1.3
    assert all(m < e for m, e in zip(mid, end))


def test_configs_share_the_reference_scenes() -> None:
    wp, qs = (load_config(STUDIES / c) for c in CONFIGS[:2])
    refs_wp = {s.key for s in wp.scenes() if is_reference(dict(s.dynamic))}
    refs_qs = {s.key for s in qs.scenes() if is_reference(dict(s.dynamic))}
    assert len(refs_wp) == 3 and refs_wp <= refs_qs and len(refs_qs) == len(qs.scenes())
    assert len({family_key(s) for s in wp.scenes()}) == 3


@pytest.mark.slow
def test_work_precision_study_regenerates(tmp_path: Path) -> None:
    from ked_research import study_io
    from ked_research.work_precision.study import run_study

    out, readme = tmp_path / "wp.h5", tmp_path / "README.md"
    run_study(out, figures=tmp_path, readme=readme, progress=False)
    tables, _ = study_io.read_tables(out)
    # size: a guard against runaway growth; the linear solver and its pair metrics took a regenerated file
    # from under 5 MB to 5.5 MB (HDF5 object headers of the per-pair metric groups)
    assert len(tables["dynamic"]["error"]) > 100 and out.stat().st_size < 8e6
    assert "<!-- BEGIN work-precision -->" in readme.read_text()
    assert (tmp_path / "work_precision.png").exists()


@pytest.mark.slow
def test_stability_study_regenerates(tmp_path: Path) -> None:
    from ked_research import study_io
    from ked_research.stability.study import run_study

    out, readme = tmp_path / "stab.h5", tmp_path / "README.md"
    run_study(out, readme=readme, progress=False)
    tables, attrs = study_io.read_tables(out)
    assert len(tables["cases"]["case"]) >= 10 and attrs["lost"] == 0
    assert "<!-- BEGIN stability -->" in readme.read_text()


def test_choose_lists_timing_ties() -> None:
    a, b = Discretization("ancf", 4, 720, 0.6), Discretization("ancf", 4, 720, 0.9)
    ch = choose([_pt("x", a, 1.00, 0.005), _pt("x", b, 1.10, 0.003)], 0.01, 1)
    assert ch.disc == a and ch.tied == (b,)  # 10 % slower: within the timing noise
    assert choose([_pt("x", a, 1.00, 0.005), _pt("x", b, 1.30, 0.003)], 0.01, 1).tied == ()
    assert coarsest_failures([_pt("x", a, 1.0, math.nan, ok=False)]) == {("ancf", 4, 0.6): 720}


def _section(name: str) -> str:
    from compare.sections import markers

    text = (Path(__file__).resolve().parents[1] / "results" / "README.md").read_text(encoding="utf-8")
    begin, end = markers(name)
    return text[text.index(begin) + len(begin):text.index(end)].strip()


def test_committed_readme_sections_are_generated_from_the_committed_results() -> None:
    """Every number in the two README sections comes from the stored /study tables."""
    from ked_research import study_io
    from ked_research.stability import report as stability_report
    from ked_research.stability import study as stability
    from ked_research.work_precision import report as wp_report
    from ked_research.work_precision import study as work_precision

    if not (work_precision.OUT.exists() and stability.OUT.exists()):
        pytest.skip("study results not generated")
    tables, attrs = study_io.read_tables(work_precision.OUT)
    figs = [work_precision.FIGURES / "work_precision.png", work_precision.FIGURES / "work_precision_lumps.png"]
    assert wp_report.markdown(tables, attrs, figs, work_precision.README.parent).strip() == _section("work-precision")
    tables, attrs = study_io.read_tables(stability.OUT)
    assert stability_report.markdown(tables, attrs).strip() == _section("stability")
    assert work_precision.OUT.stat().st_size < 5e6 and stability.OUT.stat().st_size < 5e6


def _stored_references():
    from compare import store
    from ked_research.work_precision.study import OUT, reference_scenes

    if not OUT.exists():
        pytest.skip("study results not generated")
    return reference_scenes(store.read_scenes(OUT))


def test_linear_points_use_the_quasi_static_error_against_the_same_reference() -> None:
    import warnings

    from ked_linear import LinearSettings, solve_linear
    from ked_research.work_precision.study import deflection, ked_scene, linear_points

    r = next(r for r in _stored_references() if r.spec.mass_model.name == "tip" and r.verdict.speed_ratio < 0.1)
    (row,) = linear_points([r], repeats=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lin = solve_linear(ked_scene(r), LinearSettings(damping_ratio=r.spec.damping_ratio))
    assert row["error"] == pytest.approx(cycle_error(lin.deflection, deflection(r.dynamic)))
    assert row["stable"] and row["repeats"] == 1 and row["wall_s"] > 0
    assert row["error"] < cycle_error(deflection(r.quasi_static), deflection(r.dynamic))


def test_resume_keeps_the_stored_tables_and_adds_the_missing_one(tmp_path: Path, monkeypatch) -> None:
    """A resume that adds no scene computes only the missing /study table (no Exudyn run, no re-timing)."""
    import shutil

    from ked_research import study_io
    from ked_research.work_precision import analysis as wp_analysis
    from ked_research.work_precision import report as wp_report
    from ked_research.work_precision import study as work_precision

    _stored_references()
    out = tmp_path / "wp.h5"
    shutil.copy(work_precision.OUT, out)
    before, attrs = study_io.read_tables(out)
    old = {k: v for k, v in before.items() if k != "linear"}
    figs = [tmp_path / "a.png", tmp_path / "b.png"]
    assert wp_analysis.analyse(old, attrs).linear is None  # older files still report, without the linear part
    assert wp_report.markdown(old, attrs, figs, tmp_path)
    kept, kept_attrs = work_precision.stored_study(out, int(attrs["scenes"]))
    study_io.write_tables(out, {k: v for k, v in kept.items() if k != "linear"}, kept_attrs)
    row = {"mass_model": "tip", "lumps": 5, "speed_ratio": 0.05, "rpm": 1.0, "damping_ratio": 0.02, "error": 0.01,
           "wall_s": 0.1, "repeats": 5, "wall_spread": 0.1, "dynamic_wall_s": 10.0, "stable": True, "harmonics": 8,
           "error_estimate": 1e-4, "floquet_max_abs": 0.1, "peak_m": 1e-3}
    monkeypatch.setattr(work_precision, "linear_points", lambda results, repeats: [row])
    monkeypatch.setattr(work_precision, "retime", lambda *a, **k: pytest.fail("re-timed"))
    summary = work_precision.run_study(out, workers=1, fresh=False, figures=tmp_path,
                                       readme=tmp_path / "README.md", retime_below_s=0.0, progress=False)
    assert summary["computed"] == ["linear"]
    after, new_attrs = study_io.read_tables(out)
    for name, table in old.items():
        for col, v in table.items():
            assert after[name][col].dtype == v.dtype
            assert (np.array_equal(after[name][col], v) if v.dtype.kind == "O"
                    else np.array_equal(after[name][col], v, equal_nan=True))
    assert new_attrs["campaign_wall_s"] == attrs["campaign_wall_s"] and "updated_utc" in new_attrs
    assert wp_analysis.analyse(after, new_attrs).linear.scenes == 1  # the one linear row added above


def test_findings_of_the_committed_study() -> None:
    """The findings of the committed work_precision.h5: expectations from numerics and physics, then named
    regression pins (the numbers its README section states)."""
    from ked_research import study_io
    from ked_research.work_precision import study as work_precision
    from ked_research.work_precision.analysis import Discretization, analyse

    if not work_precision.OUT.exists():
        pytest.skip("study results not generated")
    f = analyse(*study_io.read_tables(work_precision.OUT))
    # lumps: masses at segment midpoints are the midpoint rule (second order), at segment ends a one-sided
    # rule (first order); both converge
    for (model, placement), order in f.lumps.orders.items():
        assert order == pytest.approx(2.0 if placement == "midpoint" else 1.0, abs=0.2), (model, placement)
    # the quasi-static (instantaneous-structure) error grows with the speed ratio for every mass model
    by_model: dict[str, list[tuple[float, float]]] = {}
    for q in f.quasi:
        by_model.setdefault(q["mass_model"], []).append((q["speed_ratio"], q["error"]))
    for model, pts in by_model.items():
        errors = [e for _, e in sorted(pts)]
        assert errors == sorted(errors), model
    # a Pareto front is cheaper and less accurate from one point to the next
    for fr in f.fronts.values():
        assert all(a.wall_s <= b.wall_s and a.error > b.error for a, b in zip(fr, fr[1:]))
    # regression pins (committed file): default ANCF 4 el, 720 steps, rho 0.9, 2.31 s and 0.343 % over the
    # 3 scenes, the cheapest within the 1 % budget, tied with rho 0.6 and 1; 18 failed runs (the configs run
    # without the refinement ladder: each point is the discretization it names); the coarsest failing steps
    # per spectral radius; the linear model beats the quasi-static solver on 12 of 12 scenes
    dflt = Discretization("ancf", 4, 720, 0.9)
    assert f.default.default == dflt and f.default.cost == pytest.approx((2.312, 0.00343), rel=1e-3)
    assert f.default.choice.disc == dflt and Discretization("ancf", 4, 720, 0.6) in f.default.choice.tied
    assert len(f.default.on_front) == 2 and len(f.failed) == 18
    assert f.default.failed_steps == {0.6: 90, 0.9: 180, 1.0: 360}
    assert (f.linear.scenes, f.linear.pairs, f.linear.better) == (12, 12, 12) and not f.linear.unstable
    assert f.lumps.needed["distributed", "midpoint"] == {0.01: 5, 0.001: 16}
