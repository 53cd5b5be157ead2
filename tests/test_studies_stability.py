"""Stability study: the solvers' behaviour on extreme scenes, pinned on cheap scenes
with the real solvers (no mocks), plus the study's pure helpers and checked-in configs."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from compare.config import ConfigError, load_config, parse_config
from compare.execute import run_scene
from ked_research.stability.analysis import check, quasi_report
from ked_research.stability.study import CONFIG_DIR, case_of_keys
from ked_research.study_io import refused_configs

STIFF = """
[campaign]
step_deg = 30.0
n_modes = 1
[grid]
mass_models = ["extender"]
rpm = [300.0]
stiffness_scales = [1000.0]
[dynamic]
elements_per_link = 1
"""


def _scene(text: str):
    (spec,) = parse_config(text).scenes()
    return spec


def test_stiff_case_converges_at_the_default_step() -> None:
    """E x 1e3: the default 720 steps per cycle are stable and the result is the quasi-static one."""
    from exudyn_models import DynamicSettings

    r = run_scene(_scene(STIFF))
    assert r.ok, r.message
    assert r.dynamic_settings["steps_per_cycle"] == DynamicSettings().steps_per_cycle
    assert r.stat("dynamic", "converged") and r.stat("dynamic", "cycles") <= 6
    assert r.verdict.speed_ratio < 0.01
    for c in ("dx", "dy"):
        dyn, qs = r.dynamic[c], r.quasi_static[c]
        assert np.all(np.isfinite(dyn))
        assert np.max(np.abs(dyn - qs)) < 0.05 * np.max(np.abs(qs))


def test_newton_failure_raises_simulation_error_and_is_recorded() -> None:
    """Massless links (tip model) at 90 steps per cycle: Newton fails; simulate_steady_state raises
    SimulationError with time and crank angle, and a campaign records it (stage dynamic)."""
    from compare.solvers.dynamic import settings_for as build_settings
    from exudyn_models import SimulationError, simulate_steady_state
    from ked_research.work_precision.study import ked_scene

    spec = _scene("[campaign]\nstep_deg = 30.0\nn_modes = 1\n[grid]\nmass_models = ['tip']\n"
                  "speed_ratios = [0.3]\n[dynamic]\nelements_per_link = 1\nsteps_per_cycle = 90\nrefine = false\n")
    r = run_scene(spec)
    assert (r.status, r.stage, r.error_type) == ("failed", "dynamic", "SimulationError")
    assert "Newton" in r.message and "crank angle" in r.message
    with pytest.raises(SimulationError) as err:
        simulate_steady_state(ked_scene(r), build_settings(spec))
    assert 0.0 <= err.value.crank_angle < 2 * math.pi and err.value.time > 0.0


def test_campaign_keeps_the_refinement_ladder_record() -> None:
    """The same scene with the ladder on (the default): solved, and the stored stats say by which
    settings and after which attempts; the content key is that of the requested settings."""
    text = ("[campaign]\nstep_deg = 30.0\nn_modes = 1\n[grid]\nmass_models = ['tip']\n"
            "speed_ratios = [0.3]\n[dynamic]\nelements_per_link = 1\nsteps_per_cycle = 90\n")
    spec = _scene(text)
    r = run_scene(spec)
    assert r.status == "ok" and r.key == spec.key
    assert r.stat("dynamic", "n_attempts") >= 2 and r.stat("dynamic", "attempts").startswith("requested")
    solved = (r.stat("dynamic", "solved_steps_per_cycle"), r.stat("dynamic", "solved_newton_max_iterations"))
    assert solved != (90, 12)


def test_no_steady_state_is_recorded_as_failed() -> None:
    r = run_scene(_scene("[campaign]\nstep_deg = 30.0\nn_modes = 1\n[grid]\nmass_models = ['extender']\n"
                         "rpm = [300.0]\n[dynamic]\nelements_per_link = 1\nsteps_per_cycle = 90\nmax_cycles = 2\n"
                         "steady_tol = 1.0e-9\nextrapolate = false\n"))
    assert (r.status, r.stage, r.error_type) == ("failed", "dynamic", "NoSteadyState")
    assert "no periodic steady state" in r.message and r.stat("dynamic", "cycles") == 2
    assert not r.stat("dynamic", "converged")


def test_linkage_past_the_grashof_limit_fails_at_setup_with_value_error() -> None:
    import dataclasses

    from ked_quasi.linkage import thesis_fourbar

    with pytest.raises(ValueError, match="cannot assemble"):
        dataclasses.replace(thesis_fourbar(), coupler=0.635, follower=0.3809)
    # refused when the campaign is loaded (before anything runs), with the Grashof class in the message
    with pytest.raises(ConfigError, match="Grashof"):
        load_config(CONFIG_DIR / "07_cannot_assemble.toml")
    refused = refused_configs([CONFIG_DIR / "07_cannot_assemble.toml", CONFIG_DIR / "01_baseline.toml"])
    assert list(refused) == ["07_cannot_assemble.toml"] and "cannot assemble" in refused["07_cannot_assemble.toml"]


def test_near_toggle_is_flagged_by_the_quasi_static_solver() -> None:
    import dataclasses

    from ked_quasi.linkage import thesis_fourbar
    from ked_quasi.massmodel import MassModel
    from ked_quasi.solver import Scene, ToggleWarning, solve_quasi_static

    fb = dataclasses.replace(thesis_fourbar(), coupler=0.635, follower=0.38103, check_toggle=False)
    with pytest.warns(ToggleWarning):
        q = solve_quasi_static(Scene(fb, MassModel("extender"), 300.0, 10.0))
    rep = quasi_report(q.deflection, q.condition, q.flagged, q.transmission_angle, q.crank_angle)
    assert rep.flagged_deg == (180.0,) and rep.toggle_distance_deg < 1.0 and rep.condition_max > 50
    assert rep.nonfinite == 0 and rep.peak_unflagged_m < rep.peak_m


def test_change_point_linkage_is_singular_but_finite_flagged() -> None:
    import dataclasses

    from ked_quasi.linkage import thesis_fourbar
    from ked_quasi.massmodel import MassModel
    from ked_quasi.solver import Scene, solve_quasi_static

    fb = dataclasses.replace(thesis_fourbar(), coupler=0.635, follower=0.381, check_toggle=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        q = solve_quasi_static(Scene(fb, MassModel("extender"), 300.0, 10.0))
    assert q.flagged.any() and np.nanmax(q.condition) > 1e6


def test_check_verdicts() -> None:
    assert check(True, True, True, 0.1, 1.01, 0.001) == "pass"
    assert check(False, False, False, 0.1, math.nan, None) == "-"
    assert check(True, False, True, 0.1, 1.0, None).startswith("fail: non-finite")
    assert check(True, True, False, 0.1, 1.0, None) == "fail: not steady"
    assert "amplification" in check(True, True, True, 0.1, 5.0, None)
    assert check(True, True, True, 2.0, 5.0, None) == "pass"  # supercritical: no amplification band
    assert "default-settings" in check(True, True, True, 0.1, 1.0, 0.2)
    assert check(True, True, True, 0.1, 0.1, None, near_toggle=True) == "pass"  # no QS yardstick at a toggle
    assert "default-settings" in check(True, True, True, 0.1, 0.1, 0.2, near_toggle=True)


def test_stability_configs_cover_the_required_cases() -> None:
    configs = sorted(Path(CONFIG_DIR).glob("*.toml"))
    cases = case_of_keys(configs)
    assert len(cases) >= 10
    names = {c for c, _ in cases.values()}
    for required in ("stiff", "flexible", "supercritical", "slender", "massless", "heavy-tip",
                     "small-step", "large-step", "spectral-radius"):
        assert required in names
    refused = refused_configs(configs)
    # refused at load: the linkage that cannot assemble, and the near-toggle and change-point linkages
    # (minimum transmission angle below the rules' bound; the solvers' behaviour there is pinned above)
    assert set(refused) == {"05_near_toggle.toml", "06_change_point.toml", "07_cannot_assemble.toml"}
    assert all("transmission angle" in refused[c] for c in ("05_near_toggle.toml", "06_change_point.toml"))
    scales = {s.stiffness_scale for c in configs if c.name not in refused for s in load_config(c).scenes()}
    assert {1000.0, 0.01} <= scales


def _row(case: str, status: str, verdict: str) -> dict:
    return {"case": case, "status": status, "check": verdict}


def test_findings_count_the_rows() -> None:
    """Counts by construction: 4 scenes in 2 cases, 3 converged (2 pass), 1 failed."""
    from ked_research.stability.analysis import analyse

    cases = [_row("a", "ok", "pass"), _row("a", "ok", "fail: not steady"), _row("b", "ok", "pass"),
             _row("b", "failed", "-")]
    attrs = {"created_utc": "t", "defaults": '{"element": "ancf"}', "campaign_wall_s": 10.0, "study_wall_s": 12.0,
             "workers": 2, "lost": 1}
    f = analyse(cases, attrs)
    assert (f.scenes, f.cases, f.converged, f.passed, f.failed, f.lost) == (4, 2, 3, 2, 1, 1)
    assert f.defaults == {"element": "ancf"} and f.failures == (cases[3],)


def test_findings_of_the_committed_study() -> None:
    """Regression pin on the committed results/studies/stability.h5 (the numbers its README section states):
    29 scenes in 14 cases, 23 converged, 21 of them pass the check, 6 failed, none lost; every converged
    scene has a verdict, every failed one none (an independent count over the stored status column)."""
    from ked_research import study_io
    from ked_research.stability import study as stability
    from ked_research.stability.analysis import analyse

    if not stability.OUT.exists():
        pytest.skip("study results not generated")
    tables, attrs = study_io.read_tables(stability.OUT)
    f = analyse(study_io.rows(tables["cases"]), attrs)
    assert (f.scenes, f.cases, f.converged, f.passed, f.failed, f.lost) == (29, 14, 23, 21, 6, 0)
    status = [str(s) for s in tables["cases"]["status"]]
    assert f.converged == status.count("ok") and len(f.failures) == len(status) - status.count("ok")
    assert all(r["check"] == "-" for r in f.failures)
    assert f.defaults["element"] in ("ancf", "ge") and f.workers == 2


def test_step_search_of_a_newton_failure_is_the_refinement_ladder() -> None:
    """``ked study stability --ladder``: a Newton failure from a run without the ladder is rerun with it.
    The independent reference is a campaign of the same scene with the ladder on (the default): the steps
    per cycle found and the rungs tried (with their outcomes) must be those it stores."""
    import re

    from ked_research.stability.study import ladder_search

    text = ("[campaign]\nstep_deg = 30.0\nn_modes = 1\n[grid]\nmass_models = ['tip']\n"
            "speed_ratios = [0.3]\n[dynamic]\nelements_per_link = 1\nsteps_per_cycle = 90\n")
    failed = run_scene(_scene(text + "refine = false\n"))
    assert failed.error_type == "SimulationError"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        steps, log = ladder_search(failed)
    reference = run_scene(_scene(text))
    assert reference.ok and steps == reference.stat("dynamic", "solved_steps_per_cycle")

    def rungs(attempts: str) -> str:  # wall times differ from run to run
        return re.sub(r", \d+\.\d s", "", attempts)

    assert rungs(log) == rungs(reference.stat("dynamic", "attempts")) and log.startswith("requested")
