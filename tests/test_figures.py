"""The campaign figures show what is valid (real campaign, real matplotlib figure objects, Agg).

Case I (2 lb at P) at 300 rpm deflects P by tens of mm quasi-statically, beyond 10 % of the 0.254 m
crank (thesis Table I is of that order): its quasi-static answer carries the large_deflection flag and
must be drawn as not valid; Case III (extender mass, about 1 mm) is valid.  The campaign runs the
quasi-static and linear solvers only (no Exudyn: quick).
"""

from __future__ import annotations

import io
import warnings

import matplotlib.colors as mcolors
import numpy as np
import pytest

from compare import store
from compare.config import parse_config
from compare.inspect import rpm_text
from compare.plots import INVALID_COLOR, amplification_figure, scene_figure
from compare.runner import run_campaign

CONFIG = """
[campaign]
name = "figures"
step_deg = 30.0
solvers = ["quasi_static", "linear"]
[grid]
mass_models = ["tip", "extender"]
rpm = [150.0, 300.0]
"""


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    out = tmp_path_factory.mktemp("figures") / "figures.h5"
    run_campaign(parse_config(CONFIG), out, workers=1, progress=False)
    return {(r.spec.mass_model.name, r.rpm): r for r in store.read_scenes(out)}


def _grey(line) -> bool:
    return mcolors.same_color(line.get_color(), INVALID_COLOR)


def test_flagged_answer_is_grey_dashed_and_says_why(scenes):
    r = scenes[("tip", 300.0)]
    assert "large_deflection" in r.solutions["quasi_static"].flags  # the premise (see module docstring)
    fig = scene_figure(r)
    history = fig.axes[0]
    lines = {ln.get_label(): ln for ln in history.get_lines()}
    qs = next(ln for lb, ln in lines.items() if lb.startswith("quasi-static"))
    assert _grey(qs) and qs.get_linestyle() == "--" and qs.get_markerfacecolor() == "none"
    assert "NOT VALID" in qs.get_label() and "large_deflection" in qs.get_label()
    legend = [t.get_text() for t in history.get_legend().get_texts()]
    assert any("large_deflection" in t for t in legend)


def test_valid_answers_keep_colour_and_vibrating_solvers_are_markers(scenes):
    r = scenes[("extender", 150.0)]
    assert all(not s.flags for s in r.solutions.values())  # Case III at 150 rpm: within range
    history = scene_figure(r).axes[0]
    for ln in history.get_lines():
        assert not _grey(ln) and "NOT VALID" not in ln.get_label()
        if not ln.get_label().startswith("quasi-static"):
            # sampled every 30 deg: markers only, no line between samples that would alias vibration
            assert ln.get_linestyle() == "None" and ln.get_marker() not in (None, "None", "")
    assert "stored every 30 deg" in history.figure.axes[-2].get_xlabel()  # the last history axis


def test_invalid_answer_leaves_the_scale_to_valid_ones(scenes):
    """Where a valid and a flagged answer share an axis, the y-limits come from the valid one."""
    for r in scenes.values():
        flagged = [n for n, s in r.solutions.items() if s.flags]
        valid = [n for n, s in r.solutions.items() if s.ok and not s.flags]
        if flagged and valid:
            fig = scene_figure(r)
            with warnings.catch_warnings():  # drawn without matplotlib's complaints (e.g. fixed limits vs aspect)
                warnings.simplefilter("error")
                fig.savefig(io.BytesIO(), format="png", dpi=40)
            ax = fig.axes[0]  # dx [mm]
            lo, hi = ax.get_ylim()
            dx = np.concatenate([1e3 * r.solutions[n].deflection["dx"] for n in valid])
            span = dx.max() - dx.min()
            assert dx.min() - 0.1 * span <= lo <= dx.min() and dx.max() <= hi <= dx.max() + 0.1 * span
            far = max(abs(1e3 * r.solutions[n].deflection["dx"]).max() for n in flagged)
            assert far > hi  # the flagged answer reaches beyond: it would have set the scale
            return
    pytest.skip("no scene with a valid and a flagged answer side by side in this grid")


def test_amplification_figure_legend_rpm_and_invalid_points(scenes):
    fig = amplification_figure(list(scenes.values()))
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("tip mass model, damping ratio 2 %" in t for t in texts)  # not "z0.02"
    assert not any("z0.02" in t for t in texts)
    invalid = [t for t in texts if t.startswith("not valid")]
    assert invalid and "large_deflection" in invalid[0].replace("\n", " ")
    # two families of different omega1_min: the rpm of r = 0.1 in each entry, from the stored rpm and r
    tip = scenes[("tip", 300.0)]
    expected = 0.1 * tip.rpm / tip.speed_ratio
    assert any(t.startswith("source, tip") and f"r = 0.1 at {rpm_text(expected)} rpm" in t for t in texts)
    for ax in fig.axes[:2]:
        assert ax.get_xlabel().startswith("speed ratio r")


def test_amplification_figure_has_an_rpm_axis_for_one_family(scenes):
    tip = [r for (mm, _), r in scenes.items() if mm == "tip"]
    fig = amplification_figure(tip)
    tops = [c for ax in fig.axes[:2] for c in ax.child_axes]
    assert len(tops) == 2 and all(t.get_xlabel() == "crank speed [rpm]" for t in tops)
    r = tip[0]
    to_rpm = tops[0]._functions[0]  # r -> rpm of the secondary axis
    assert to_rpm(r.speed_ratio) == pytest.approx(r.rpm, rel=1e-6)  # rpm = r omega1_min 60 / (2 pi)
