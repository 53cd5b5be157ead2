"""Critical speeds (compare.critical): local maxima of max |Floquet multiplier| over a speed range."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from compare.critical import amplification_peaks, critical_speeds, local_maxima, near


def test_local_maxima_of_a_known_curve():
    # y = cos(x) on [0, 4 pi] sampled finely: interior maxima at 2 pi only (the ends are excluded)
    x = np.linspace(0.0, 4 * np.pi, 81)
    y = np.cos(x)
    assert [x[i] for i in local_maxima(x, y)] == pytest.approx([2 * np.pi])
    assert local_maxima([1, 2, 3], [0.1, float("nan"), 0.2]) == []
    # prominence: a bump of 0.005 on a rising curve is dropped at 0.01, kept at 0
    bump = [0.1, 0.2, 0.3, 0.305, 0.3, 0.4, 0.5]
    assert local_maxima(range(7), bump) == [3] and local_maxima(range(7), bump, 0.01) == []
    assert amplification_peaks([3.0, 1.0, 2.0], [1.0, 1.0, 2.0]) == (2.0,)
    assert near(102.0, [100.0, 300.0]) == 100.0 and near(110.0, [100.0]) is None


def test_refinement_finds_peaks_between_the_samples():
    # two Lorentzian resonance peaks at 137.3 and 262.9 rpm; the coarse samples (every 50 rpm) do not
    # contain either; the fine sweep and the golden-section search must find both within 2e-3 of the speed
    def mu(r):
        return 0.3 + 0.5 / (1 + ((r - 137.3) / 6.0) ** 2) + 0.4 / (1 + ((r - 262.9) / 9.0) ** 2)

    rpms = np.linspace(50.0, 350.0, 7)
    found = critical_speeds(rpms, [mu(r) for r in rpms], mu, fine=4)
    assert [c.rpm for c in found] == pytest.approx([137.3, 262.9], rel=2e-3)
    assert found[0].max_abs == mu(found[0].rpm) and mu(137.3) - found[0].max_abs < 1e-4


@pytest.mark.slow
def test_ked_check_rpm_range_lists_the_maxima_of_a_fine_sweep(thesis):
    # `ked check --rpm-range` on the thesis joints model against an independent fine sweep of max |mu|
    # (every 2.5 rpm, 4096 propagator steps: a different step count than the check's): every local
    # maximum of the fine sweep (prominence 0.01, as the check) is listed within one sweep spacing, and
    # nothing else
    from compare.check import spec_for
    from compare.critical import PROMINENCE, floquet_max_abs
    from ked_quasi import MassModel

    out = subprocess.run([sys.executable, "-m", "ked_cli", "check", "--mass-model", "joints", "--rpm-range",
                          "150:350:5", "--json"], capture_output=True, text=True, check=True)
    rows = json.loads(out.stdout)
    listed = rows[0]["critical_speeds_rpm"]
    assert all(r["critical_speeds_rpm"] == listed for r in rows)
    f = floquet_max_abs(spec_for(thesis, "source", MassModel("joints"), 200.0), steps=4096)
    grid = np.arange(150.0, 350.0 + 1e-9, 2.5)
    sweep = [f(r) for r in grid]
    maxima = [grid[i] for i in local_maxima(grid, sweep, PROMINENCE)]
    assert len(listed) == len(maxima), (listed, maxima)
    assert np.abs(np.array(listed) - np.array(maxima)).max() <= 2.5, (listed, maxima)
    near_one = [r for r in rows if any(abs(r["rpm"] - c) <= 0.05 * c for c in listed)]
    assert all("critical speed" in r["verdict"] for r in near_one)


def test_check_names_a_weakly_damped_speed(thesis):
    # the thesis joints model at r = 1 with 2 % damping: max |mu| ~ 0.96 (tests/test_linear.py); the
    # design check must flag it, send it to the nonlinear tier and say why
    from compare.check import check
    from ked_quasi import MassModel, Scene, natural_frequencies

    mm = MassModel("joints")
    rpm = 60.0 * float(np.min(natural_frequencies(Scene(thesis, mm, 30.0), 1)[:, 0]))
    (row,) = check(thesis, "source", mm, [rpm])
    assert "weakly_damped" in row.flags and row.tier == "nonlinear"
    assert "weakly damped" in row.verdict and "may never settle" in row.verdict
    assert 0.9 <= row.floquet_max_abs < 1.0
