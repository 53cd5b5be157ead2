"""Critical speeds (ked_check.critical): local maxima of max |Floquet multiplier| over a speed range."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from ked_check.critical import amplification_peaks, critical_speeds, local_maxima, near


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


def test_only_an_amplification_peak_is_a_speed_to_avoid():
    # a Floquet maximum is where free vibrations die out slowest (parametric resonance), not where the
    # steady response is largest: a verdict near one alone must not tell the user to keep away from it;
    # a verdict near an amplification peak (forced resonance) must
    from ked_check.check import CheckRow
    from ked_check.critical import CriticalSpeed, mark_near

    def row(rpm: float) -> CheckRow:
        return CheckRow(rpm, 0.1, 1e-3, 1e-3, 0.0, 0.0, 0.2, "linear", "use the linear model")

    crit, amp = (CriticalSpeed(200.0, 0.24),), (300.0,)
    at_floquet, at_amp, between = mark_near([row(201.0), row(298.0), row(250.0)], crit, amp)
    assert "weakest damping" in at_floquet.verdict and "keep the operating" not in at_floquet.verdict
    assert "amplification peak 300 rpm" in at_amp.verdict and "keep the operating" in at_amp.verdict
    assert between.verdict == "use the linear model"


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
    from ked_check.check import spec_for
    from ked_check.critical import PROMINENCE, floquet_max_abs
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
    assert all("weakest damping" in r["verdict"] for r in near_one)


def test_check_names_a_weakly_damped_speed(thesis):
    # the thesis joints model at r = 1 with 2 % damping: max |mu| ~ 0.96 (tests/test_linear.py); the
    # design check must flag it, send it to the nonlinear tier and say why
    from ked_check.check import check
    from ked_quasi import MassModel, Scene, natural_frequencies

    mm = MassModel("joints")
    rpm = 60.0 * float(np.min(natural_frequencies(Scene(thesis, mm, 30.0), 1)[:, 0]))
    (row,) = check(thesis, "source", mm, [rpm])
    assert "weakly_damped" in row.flags and row.tier == "nonlinear"
    assert "weakly damped" in row.verdict and "may never settle" in row.verdict
    assert 0.9 <= row.floquet_max_abs < 1.0


def _curve(r):
    # a max |mu| curve with resonance peaks (Lorentzians: centre, height, half-width) on a rising floor, on
    # the samples 30, 60, ..., 600 rpm: a pair in one interval (150, 158: the second no maximum of a fine
    # grid), one of prominence 0.0099 on the samples and 0.0119 on a fine grid (241) with a smaller one
    # (262, below the threshold) beside it, one tall (330), one within the noise (410, 0.002 high) and one
    # inside the last interval (590: the samples rise to the end of the range)
    peaks = ((150.0, 0.05, 4.0), (158.0, 0.03, 5.0), (241.0, 0.02, 5.0), (262.0, 0.01, 4.0), (330.0, 0.2, 12.0),
             (410.0, 0.002, 5.0), (590.0, 0.1, 10.0))
    return 1e-4 * r + sum(h / (1.0 + ((r - c) / w) ** 2) for c, h, w in peaks)


def _fine_sweep_maxima(f, rpms, fine=4):
    # the independent reference: f on the fine grid of every interval (the samples and fine - 1 speeds
    # between each pair), its local maxima of at least PROMINENCE, each located to 1e-3 rpm on a dense grid
    from ked_check.critical import PROMINENCE, fine_speeds

    grid = np.sort(np.concatenate([rpms, fine_speeds(rpms, fine)]))
    values = [f(r) for r in grid]
    out = []
    for i in local_maxima(grid, values, PROMINENCE):
        dense = np.linspace(grid[i - 1], grid[i + 1], 20001)
        out.append(float(dense[np.argmax([f(r) for r in dense])]))
    return out


def test_the_bracketed_sweep_finds_the_maxima_of_the_fine_sweep_with_fewer_evaluations():
    # against the fine sweep of every interval and a dense location of each peak (independent of the
    # refinement): the same critical speeds within the refinement's 2e-3 of the speed, every evaluation
    # once, fewer than the fine sweep's
    from ked_check.critical import fine_speeds

    rpms = np.linspace(30.0, 600.0, 20)
    expected = _fine_sweep_maxima(_curve, rpms)
    assert len(expected) == 4  # 150, 241, 330, 590: not 158, 262 (prominence), 410 (noise)
    calls = []

    def f(r):
        calls.append(r)
        return _curve(r)

    found = critical_speeds(rpms, [_curve(r) for r in rpms], f)
    assert [c.rpm for c in found] == pytest.approx(expected, rel=2e-3)
    assert all(c.max_abs == _curve(c.rpm) for c in found)
    assert len(calls) == len(set(calls))
    assert len(calls) < fine_speeds(rpms).size  # refinements included; the fine sweep's 57 came before them


def test_approximate_samples_find_the_maxima_and_are_never_used_to_decide():
    # the rows' own max |mu| (here: off by up to 5e-4, within the Floquet tolerance): the same critical
    # speeds and values as with exact samples; the sweep evaluates every speed whose value decides one
    rpms = np.linspace(30.0, 600.0, 20)
    noise = 5e-4 * np.sin(7.0 * rpms)
    calls = []

    def f(r):
        calls.append(r)
        return _curve(r)

    exact = critical_speeds(rpms, [_curve(r) for r in rpms], _curve)
    approx = critical_speeds(rpms, [_curve(r) + e for r, e in zip(rpms, noise)], f, exact=False)
    assert approx == exact
    for c in approx:  # the bracket of each refined peak: values of f
        assert c.rpm in calls
    assert len(calls) == len(set(calls))
    # of the samples, only those next to a listed peak are evaluated (150, 240, 330 and 600 here)
    assert set(calls) & set(rpms.tolist()) == {150.0, 240.0, 330.0, 600.0}


def test_few_speeds_are_filled_to_the_least_number_of_intervals():
    # 5 speeds 50 rpm apart hide the peaks at 150 and 330 (no sample maximum); the sweep divides each
    # interval into 4 (16 intervals: the former fine sweep's grid) and finds them as that fine sweep does
    from ked_check.critical import MIN_INTERVALS, fill_speeds

    rpms = np.linspace(100.0, 500.0, 5)
    assert fill_speeds(rpms).size == 3 * 4 and fill_speeds(np.linspace(0, 1, MIN_INTERVALS + 1)).size == 0
    expected = _fine_sweep_maxima(_curve, rpms)
    found = critical_speeds(rpms, [_curve(r) for r in rpms], _curve)
    assert [c.rpm for c in found] == pytest.approx(expected, rel=2e-3) and len(found) >= 2


@pytest.mark.slow
def test_thesis_distributed_critical_speeds_as_the_fine_sweep(thesis):
    # the thesis distributed model, 30-600 rpm in 20 speeds: the critical speeds the fine sweep of every
    # interval found (213.1, 343.4, 556.2 rpm at 5 lumps per link: regression pin of that former sweep, 92
    # evaluations), to the refinement's accuracy, with at most half its evaluations
    from ked_check.check import spec_for
    from ked_check.critical import floquet_max_abs
    from ked_quasi import MassModel

    f = floquet_max_abs(spec_for(thesis, "source", MassModel("distributed", lumps=5), 300.0))
    rpms = np.linspace(30.0, 600.0, 20)
    calls = []

    def counted(r):
        calls.append(r)
        return f(r)

    found = critical_speeds(rpms, [f(r) for r in rpms], counted)
    assert [c.rpm for c in found] == pytest.approx([213.094, 343.433, 556.244], rel=2e-3)
    assert len(calls) == len(set(calls)) and len(rpms) + len(calls) <= 92 // 2 + 20


def test_peaks_and_prominences_as_scipy_signal():
    # the check's own peak search (scipy.signal costs a check its import) against scipy.signal's
    # find_peaks and peak_prominences on random curves with plateaus and ties (rounded values)
    from scipy.signal import find_peaks, peak_prominences

    from ked_check.critical import peaks, prominences

    rng = np.random.default_rng(7)
    for n in (3, 5, 40, 200):
        for _ in range(50):
            y = np.round(rng.normal(size=n).cumsum(), 1)
            found = peaks(y)
            assert found == find_peaks(y)[0].tolist()
            if found:
                p, left, right = prominences(y, found)
                q, ql, qr = peak_prominences(y, found)
                assert np.array_equal(p, q) and left == ql.tolist() and right == qr.tolist()
                for m in (0.0, 0.5, 1.0):
                    assert local_maxima(range(n), y, m) == find_peaks(y, prominence=m)[0].tolist()


def test_a_row_at_the_sweep_steps_is_the_sweeps_own_value(thesis):
    # the check reuses a row's max |mu| as an exact sample only where its linear solve's Floquet analysis
    # ran the full model at the sweep's 2048 steps (thesis joints at 120 and 240 rpm: the automatic
    # doubling stopped there): the independent Floquet-only evaluation of the sweep gives the same
    # number to the last bit there, and the rows at other counts are flagged approximate
    from ked_check.check import check, spec_for
    from ked_check.critical import SWEEP_STEPS, floquet_max_abs, sweep_exact
    from ked_quasi import MassModel

    mm = MassModel("joints")
    rows = check(thesis, "source", mm, [90.0, 120.0, 240.0])
    assert [r.floquet_steps for r in rows] == [512, SWEEP_STEPS, SWEEP_STEPS]  # regression pin of the doubling
    assert [sweep_exact(r) for r in rows] == [False, True, True]
    f = floquet_max_abs(spec_for(thesis, "source", mm, 120.0))
    assert [f(r.rpm) for r in rows[1:]] == [r.floquet_max_abs for r in rows[1:]]


def test_a_row_of_the_reduced_floquet_analysis_is_the_sweeps_own_value(thesis):
    # where the reduced system's Floquet analysis answered a row's linear solve (thesis distributed model:
    # at 100 rpm beside the collocation's steady state, at 300 rpm beside the co-rotating one), the row
    # says so and is an exact sample: the sweep's independent Floquet-only evaluation (a fresh system, no
    # recalled parts) gives the same number to the last bit; the joints model's full propagator is not it
    from ked_check.check import check, spec_for
    from ked_check.critical import floquet_max_abs, sweep_exact
    from ked_linear.solver import forget_recalled
    from ked_quasi import MassModel

    mm = MassModel("distributed")
    rows = check(thesis, "source", mm, [100.0, 300.0])
    assert [r.floquet_reduced for r in rows] == [True, True]
    assert [sweep_exact(r) for r in rows] == [True, True]
    forget_recalled()
    f = floquet_max_abs(spec_for(thesis, "source", mm, 100.0))
    assert [f(r.rpm) for r in rows] == [r.floquet_max_abs for r in rows]
    assert not check(thesis, "source", MassModel("joints"), [90.0])[0].floquet_reduced


def test_a_sweep_of_one_or_no_finite_sample_finds_nothing():
    assert critical_speeds([100.0], [0.5], _curve) == ()
    assert critical_speeds([100.0, 150.0, 200.0], [float("nan")] * 3, lambda r: float("nan")) == ()
    # two samples: the range filled to 16 intervals, the peak at 150 found between them
    (c,) = critical_speeds([100.0, 200.0], [_curve(100.0), _curve(200.0)], _curve)
    assert c.rpm == pytest.approx(150.28, rel=2e-3)


@pytest.mark.slow
def test_critical_speeds_and_amplification_peaks_against_an_exudyn_sweep(thesis, tmp_path):
    # thesis joints model, 180-236 rpm every 4 rpm (r 0.13-0.18, inside the linear model's range), Exudyn
    # (the independent reference) at every speed: the steady amplification max|d_dyn| / max|d_qs| has its
    # local maxima where the check lists its amplification peaks (within one grid step), and at the
    # check's critical speed (the Floquet maximum near 202 rpm) Exudyn's amplification is no local maximum
    # (measured: 1.57 at 200 rpm between 1.85 at 192 and 2.04 at 212), so the verdict there must not
    # tell the user to keep away from it; near an amplification peak it must
    from compare import read_scenes, run_scenes
    from ked_check.check import spec_for
    from ked_quasi import MassModel

    rpms = np.arange(180.0, 236.0 + 1e-9, 4.0)
    out = subprocess.run([sys.executable, "-m", "ked_cli", "check", "--mass-model", "joints", "--rpm-range",
                          f"180:236:{rpms.size}", "--json"], capture_output=True, text=True, check=True)
    rows = json.loads(out.stdout)
    crit, amp = rows[0]["critical_speeds_rpm"], rows[0]["amplification_peaks_rpm"]
    specs = [spec_for(thesis, "source", MassModel("joints"), float(r), confirm=True) for r in rpms]
    run_scenes(specs, tmp_path / "sweep.h5", name="sweep", workers=1, progress=False)
    scenes = sorted(read_scenes(tmp_path / "sweep.h5"), key=lambda s: s.rpm)
    assert [round(s.rpm, 6) for s in scenes] == list(rpms)

    def peak(s, name):
        return float(np.max(np.hypot(*s.solutions[name].array(("dx", "dy")).T)))

    exudyn = [peak(s, "dynamic") / peak(s, "quasi_static") for s in scenes]
    maxima = [rpms[i] for i in local_maxima(rpms, exudyn)]
    assert amp and len(amp) == len(maxima), (amp, maxima, exudyn)
    assert np.abs(np.array(amp) - np.array(maxima)).max() <= 4.0, (amp, maxima)
    assert crit, "the Floquet maximum near 202 rpm must be listed"
    for c in crit:
        i = int(np.argmin(np.abs(rpms - c)))
        assert exudyn[i] < max(exudyn[max(i - 3, 0):i]) and exudyn[i] < max(exudyn[i + 1:i + 4]), exudyn
    for r in rows:
        if near(r["rpm"], crit) is not None and near(r["rpm"], amp) is None:
            assert "weakest damping" in r["verdict"] and "keep the operating" not in r["verdict"], r["verdict"]
        if near(r["rpm"], amp) is not None:
            assert "keep the operating speed away" in r["verdict"], r["verdict"]
