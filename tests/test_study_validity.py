"""``ked study validity``: the pipeline on a tiny campaign (quick) and the committed study (slow)."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from compare import store
from compare.limits import Limit, crossing, errors, one_mode_curves, one_mode_errors, validity_limit
from compare.sections import section_of
from ked_cli.main import cli as main
from ked_research.validity.figures import FIGURES, reference
from ked_research.validity.report import render_section
from ked_research.validity.study import CONFIGS, REFINE_FILE, load_study
from ked_research.validity.summary import answer, claims

ROOT = Path(__file__).resolve().parents[1]

TINY = """
[campaign]
name = "validity-tiny"
step_deg = 30.0
n_modes = 1

[linkage]
preset = "thesis"

[grid]
mechanisms = ["source"]
mass_models = ["extender"]
speed_ratios = [0.04, 0.25]
damping_ratios = [0.02]

[dynamic]
element = "ancf"
elements_per_link = 2
steps_per_cycle = 72
spectral_radius = 0.6
ramp_cycles = 1.0
min_cycles = 2
max_cycles = 30
extrapolate = false
sparse = false
"""


def _history_error_from_file(path: Path, ratio: float) -> float:
    """Independent reading (plain h5py) of one scene's history error."""
    with h5py.File(path, "r") as f:
        t = f["scene_table"]  # one row per scene
        for key, kind, r in zip(t["key"][()], t["speed_kind"][()], t["speed_ratio_requested"][()]):
            g = f["scenes"][key.decode()]
            if kind == b"ratio" and math.isclose(r, ratio):
                qs, dyn = (g[f"solutions/{s}"][()][:, :2] for s in ("quasi_static", "dynamic"))  # columns dx, dy
                return float(np.hypot(*(qs - dyn).T).max() / np.hypot(*dyn.T).max())
    raise KeyError(ratio)


def test_limit_and_errors_pure():
    qs = np.array([[1.0, 0.0], [0.0, 1.0]])
    e = errors(qs, 2 * qs)
    assert e.peak == pytest.approx(0.5) and e.history == pytest.approx(0.5) and e.amplification == pytest.approx(2)
    lim = validity_limit([0.1, 0.2, 0.3], [0.01, 0.04, 0.2], [True, True, True], 0.05)
    assert lim.status == "crossed" and (lim.r_pass, lim.r_fail) == (0.2, 0.3)
    assert lim.r_cross == pytest.approx(0.2 + 0.1 * 0.01 / 0.16)
    assert lim.r_limit == 0.2 and lim.step == pytest.approx(0.1)  # the reported limit: first crossing
    assert validity_limit([0.1, 0.2], [0.2, 0.3], [True, True], 0.05).status == "below_grid"
    assert validity_limit([0.1, 0.2], [0.01, math.nan], [True, False], 0.05) == Limit(0.05, "failure", 0.1, 0.2)
    assert validity_limit([0.1, 0.2], [0.01, 0.02], [True, True], 0.05).status == "above_grid"
    assert math.isnan(crossing(0.1, 0.2, 0.2, 0.3, 0.05))


def test_limit_text_states_the_first_crossing_or_the_bound():
    # the table form (tiers study): the last passing grid ratio and the step to the first failing one;
    # a bound otherwise (the walk's inputs make each status, see test_limit_and_errors_pure)
    assert validity_limit([0.1, 0.2, 0.3], [0.01, 0.04, 0.2], [True] * 3, 0.05).text == "0.200 (+0.100)"
    assert validity_limit([0.1, 0.2], [0.01, 0.02], [True, True], 0.05).text == ">= 0.2"
    assert validity_limit([0.1, 0.2], [0.2, 0.3], [True, True], 0.05).text == "< 0.1"
    assert validity_limit([0.1, 0.2], [0.01, math.nan], [True, False], 0.05).text == ">= 0.1 (Exudyn failed at 0.2)"
    assert validity_limit([0.1], [math.nan], [False], 0.05).text == "-"  # failed at the first ratio
    assert validity_limit([], [], [], 0.05).text == "-"


def test_vectorized_one_mode_equals_ked_quasi_estimate():
    th = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    qs = np.stack([np.cos(th) + 0.3 * np.sin(3 * th), 0.5 * np.sin(th) + 0.2 * np.cos(5 * th)], axis=1)
    rs = np.array([0.05, 0.3, 0.45])
    curves = one_mode_curves(qs, rs, 0.02)
    for i, r in enumerate(rs):
        e = one_mode_errors(qs, float(r), 0.02)
        assert curves["peak"][i] == pytest.approx(e.peak, rel=1e-12)
        assert curves["history"][i] == pytest.approx(e.history, rel=1e-12)
        assert curves["amplification"][i] == pytest.approx(e.amplification, rel=1e-12)


def test_validity_study_quick(tmp_path):
    cfg = tmp_path / "validity_tiny.toml"
    cfg.write_text(TINY, encoding="utf-8")
    readme = tmp_path / "README.md"
    figs = tmp_path / "figures"
    studies = tmp_path / "studies"
    args = ["study", "validity", "--config", str(cfg), "--results-dir", str(tmp_path), "--workers", "2"]
    res = CliRunner().invoke(main, args, catch_exceptions=False)
    assert res.exit_code == 0, res.output
    h5 = studies / "validity_tiny.h5"
    assert store.verify(h5) == []
    assert (studies / REFINE_FILE).exists() and store.verify(studies / REFINE_FILE) == []
    assert (figs / "validity_error.png").stat().st_size > 1000
    section = section_of(readme.read_text(encoding="utf-8"), "validity")
    # the section is exactly what the stored files give
    points, summaries = load_study([h5], studies / REFINE_FILE)
    figures = [figs / n for n in FIGURES if (figs / n).exists()]
    again = render_section(points, summaries, files=[h5], refine_file=studies / REFINE_FILE, figures=figures,
                           readme=readme, configs=[cfg])
    assert section == again.strip("\n")
    # and its headline number follows from the raw datasets
    e_lo, e_hi = _history_error_from_file(h5, 0.04), _history_error_from_file(h5, 0.25)
    r10 = crossing(0.04, e_lo, 0.25, e_hi, 0.10)
    assert math.isfinite(r10)
    # the limit is the first crossing (the last passing grid ratio, the step to the first failing one); the
    # value interpolated between them is kept for reference only
    found = answer([fs for fams in reference(summaries).values() for fs in fams])
    rg = found.ranges["history", 0.10]
    lim = rg.low.limits["history", 0.10]
    assert rg.families == 1 and rg.low is rg.high and rg.low.mass_model == "extender"
    assert (lim.r_limit, lim.step) == (0.04, pytest.approx(0.21)) and lim.r_cross == pytest.approx(r10, rel=1e-9)
    assert found.history10 == {"extender": (0.04, 0.04)}
    # rerun: everything stored, nothing computed, same section
    res = CliRunner().invoke(main, args, catch_exceptions=False)
    assert res.exit_code == 0 and '"computed": 0' in res.output
    assert section_of(readme.read_text(encoding="utf-8"), "validity") == section


@pytest.mark.slow
def test_committed_validity_study_matches_readme():
    studies = ROOT / "results" / "studies"
    files = [studies / (Path(c).stem + ".h5") for c in CONFIGS]
    for f in (*files, studies / REFINE_FILE):
        # a guard against runaway growth, not a physical bound: each scene stores four solvers' histories and
        # the metrics of every solver pair as small HDF5 groups (~1 kB of object header each); the largest
        # file (the thesis linkage, 175 scenes) is 14.3 MB
        assert f.stat().st_size < 16e6, f
        res = CliRunner().invoke(main, ["inspect", str(f), "--verify"])
        assert res.exit_code == 0, res.output
    readme = ROOT / "results" / "README.md"
    section = section_of(readme.read_text(encoding="utf-8"), "validity")
    points, summaries = load_study(files, studies / REFINE_FILE)
    figdir = ROOT / "results" / "figures"
    figures = [figdir / n for n in FIGURES if (figdir / n).exists()]
    assert len(figures) == len(FIGURES)
    again = render_section(points, summaries, files=files, refine_file=studies / REFINE_FILE, figures=figures,
                           readme=readme, configs=[studies / c for c in CONFIGS])
    assert section == again.strip("\n")


@pytest.mark.slow
def test_committed_validity_answer():
    """The answer's findings on the committed files: the refined reruns move a crossing by far less than the
    r grid's step (0.01), so the grid, not the discretization, bounds the limit; then named regression pins
    (the numbers the README's answer states)."""
    studies = ROOT / "results" / "studies"
    files = [studies / (Path(c).stem + ".h5") for c in CONFIGS]
    _, summaries = load_study(files, studies / REFINE_FILE)
    found = answer([fs for fams in reference(summaries).values() for fs in fams])
    # 63 bracketing pairs rerun refined (regression pin of the committed files: slender source joints at 10 %,
    # refined errors 0.063 and 0.100, is the one crossing whose refined pair does not bracket the tolerance)
    assert len(found.shifts) == 63 and max(found.shifts) < 0.1 * 0.01
    # regression pins (committed files)
    assert found.complete and all(rg.families == 16 for rg in found.ranges.values())
    assert found.ranges["history", 0.10].low.limits["history", 0.10].r_limit == pytest.approx(0.07)
    assert found.between_mass_models == pytest.approx(0.035, abs=5e-4)
    assert found.within_mass_model == pytest.approx(0.020, abs=5e-4)
    pins = {"tip": (0.09, 0.11), "joints": (0.07, 0.07), "extender": (0.09, 0.11), "distributed": (0.08, 0.09)}
    assert found.history10.keys() == pins.keys()
    assert all(found.history10[m] == pytest.approx(pins[m]) for m in pins)
    # the thesis's claims: quasi-statically every deflection scales with omega^2, so the 400/300 rpm peak
    # ratio is (4/3)^2 for every family (and r scales with rpm); regression pin: on the committed files each
    # cognate's quasi-static peak differs from its source's by more than 10 %
    c = claims(summaries)
    assert len(c.doubling) >= 8 and len(c.cognate) >= 8
    for _, a, b in c.doubling:
        assert b.qs_peak / a.qs_peak == pytest.approx((4 / 3) ** 2, rel=1e-6)
        assert b.r / a.r == pytest.approx(4 / 3, rel=1e-9)
    assert all(abs(k.qs_peak / s.qs_peak - 1) > 0.1 for _, s, k in c.cognate)
