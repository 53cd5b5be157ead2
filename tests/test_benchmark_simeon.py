"""The harness's tiers against Simeon's reference model (ked_bench.tiers, ``ked benchmark simeon --speeds``):
the rod's midspan deflection in the damped periodic steady state, per crank speed."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from ked_bench.simeon import steady_state
from ked_bench.tiers import (
    SPEEDS,
    compare_speed,
    reference_damping_ratio,
    reference_first_bending_hz,
)

GALERKIN = 1536.0 / (5.0 * math.pi**5) - 1.0
"""The reference's two-mode static midspan deflection under the rod's mean inertia load exceeds the exact
beam's by 0.387 % (4 / pi^5 against 5 / 384; tests/test_slider_crank.py): a model difference of the
reference, not an error of the harness."""

LUMPING = 0.003
"""16 midpoint lumps of the rod's mass against the continuous rod (the linear tier of the benchmark): the
midspan deflection's second-order lumping error, ~0.15 % of the peak (quasi-static: 0.42 % error at 16 lumps,
0.56 % at 128 against the reference at 25 rad/s, both including GALERKIN); bounded by twice that."""


def test_reference_damping_is_the_published_first_mode_ratio():
    # Data sheet: DQ11 / (2 sqrt(KQ11 MQ11)) = 2.59 %, the rod's first bending frequency 1276.7 rad/s.
    assert reference_damping_ratio() == pytest.approx(0.0259, abs=5e-5)
    assert 2 * math.pi * reference_first_bending_hz() == pytest.approx(1276.7, abs=0.05)


@pytest.mark.parametrize("omega", [25.0, 50.0])
def test_linear_tier_matches_the_reference_at_low_speed(omega):
    # Issue's expectation: linear within 2 % of the reference's peak up to r = 0.15.  Like for like (the
    # reference's damping ratio at its first bending frequency, no geometric stiffness) the remaining
    # differences are the reference's two-mode discretization and the harness's lumping: bound
    # GALERKIN + LUMPING (+ the loose reference tolerance 1e-4).  The quasi-static tier misses the dynamic
    # part, ~ (k r)^2 + 2 zeta k r: the linear tier must be closer.  The reference is marched at loose
    # tolerances here (~8 s per speed); the slow sweep uses its defaults.
    ref = steady_state(omega, samples=36, tolerance=1e-4, rtol=1e-8)
    geo = steady_state(omega, samples=36, tolerance=1e-4, rtol=1e-8, stiffness="geometric") if omega == 25 else None
    row = compare_speed(omega, ref, dynamic=omega == 25.0, geometric=geo)  # Exudyn at the lowest speed only
    assert row.linear_status == "ok"
    assert row.linear_error < GALERKIN + LUMPING + 1e-4
    assert row.linear_error < 0.02
    assert row.linear_error < row.quasi_static_error
    # the harness's default (prestressed) linear tier adds the rod's geometric stiffening, which the
    # reference lacks: its error is larger, by ~ N/P_cr ~ r^2 (slider's inertia over the Euler load)
    assert row.linear_prestressed_error > row.linear_error
    if omega == 25.0:
        # Issue's expectation: Exudyn within 2 % of the reference's peak where both are valid.  At r = 0.02
        # the differences are the reference's two lateral modes (GALERKIN) and its lack of geometric
        # stiffness (~ N / P_cr ~ 0.2 % here); measured 0.54 % (docs/exudyn_models.md).
        assert row.dynamic_error is not None and row.dynamic_error < GALERKIN + 0.005
        # against the reference with geometric stiffness (like for like) only the two-mode difference
        # remains (GALERKIN) plus Exudyn's discretization (< 1e-5) and the loose tolerance
        assert row.dynamic_error_geometric < GALERKIN + 0.002
        assert row.linear_prestressed_error_geometric < GALERKIN + LUMPING + 1e-4
    else:
        assert row.dynamic_error is None and any("dynamic: not run" in n for n in row.notes)
    assert row.speed_ratio == pytest.approx(omega / 1276.7, rel=1e-4)


def test_cli_speeds_option_refuses_bad_ranges_in_one_line():
    # 1e-9 rad/s: a period of 6e9 s the reference would march without bound (it takes 75 s at 1 rad/s)
    for bad in ("0:100:25", "25:300:0", "a,b", "-50", "1e-9", "1e-9:10:1", "1"):
        res = subprocess.run([sys.executable, "-m", "ked_cli", "benchmark", "simeon", "--speeds", bad],
                             capture_output=True, text=True)
        assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, (bad, res.stderr)
        assert "--speeds" in res.stderr and "Traceback" not in res.stderr


def test_text_output_fits_100_columns(capsys):
    from ked_cli.benchmark import _speeds_table

    res = subprocess.run([sys.executable, "-m", "ked_cli", "benchmark", "simeon", "--speeds", "none"],
                         capture_output=True, text=True, check=True)
    row = {"omega_rad_s": 300.0, "speed_ratio": 0.235, "reference_peak_m": 7.8e-3, "quasi_static_error": 0.266,
           "linear_error": 0.0028, "linear_prestressed_error": 1.5311, "dynamic_error": 0.4847,
           "dynamic_error_geometric": 0.05, "notes": ["dynamic: the Exudyn model did not settle to a periodic "
                                                       "steady state at 300 rad/s"]}
    _speeds_table([row])
    for text in (res.stdout, capsys.readouterr().out):
        assert max(len(line) for line in text.splitlines()) <= 100


@pytest.mark.slow
def test_full_sweep_json_contract_and_linear_within_2_percent_up_to_r_0_15():
    # The benchmark: 25..300 rad/s step 25 (default --speeds), each reference marched to its
    # steady state at its default tolerances (~20 s per speed on an idle machine).
    out = subprocess.run([sys.executable, "-m", "ked_cli", "benchmark", "simeon", "--json"], capture_output=True,
                         text=True, check=True).stdout
    data = json.loads(out)
    assert data["max_relative_error"] < 1e-6
    rows = data["speeds"]
    assert [r["omega_rad_s"] for r in rows] == list(SPEEDS)
    for r in rows:
        assert {"omega_rad_s", "speed_ratio", "quasi_static_error", "linear_error", "dynamic_error"} <= set(r)
        assert r["dynamic_error"] is not None and r["dynamic_error_geometric"] is not None
        if r["speed_ratio"] <= 0.06:  # measured 1.98 % at r = 0.059 (docs/exudyn_models.md)
            assert r["dynamic_error"] < 0.02, r
        if r["speed_ratio"] <= 0.18:  # like for like (geometric stiffness): the 2 % target; measured
            assert r["dynamic_error_geometric"] < 0.02, r  # 0.4-0.6 % to r = 0.157, 1.46 % at r = 0.176
        if r["speed_ratio"] <= 0.15:
            assert r["linear_error"] < 0.02, r
    # the quasi-static error grows with the speed (the dynamic part it misses, ~ r^2) below the first
    # harmonic resonances k r = 1 of the rod's first mode (k <= 6 carry the load: r < 1/6); near r = 0.2
    # (k = 5) it need not (measured: 24.3 % at r = 0.196, 24.1 % at 0.215)
    qs = [r["quasi_static_error"] for r in rows if r["speed_ratio"] < 1 / 6]
    assert len(qs) == 8 and all(b > a for a, b in zip(qs, qs[1:]))


@pytest.mark.slow
@pytest.mark.parametrize("omega", [100.0, 150.0])
def test_exudyn_matches_the_reference_with_geometric_stiffness(omega):
    # The model difference named and measured: Exudyn's beams are geometrically nonlinear, the published
    # reference (linear stiffness) is not.  Against the reference with the consistent geometric stiffness
    # (ked_bench.simeon, "geometric") the target bound, 2 % of the reference's peak, must hold where the
    # linear-stiffness reference misses it (measured 3.3 % and 7.0 %, docs/exudyn_models.md); the
    # published "nonlinear stiffness" option as written softens the rod spuriously and moves the
    # reference away (measured +21 % at 150 rad/s).
    ref = steady_state(omega, tolerance=1e-6, rtol=1e-9)
    geo = steady_state(omega, tolerance=1e-6, rtol=1e-9, stiffness="geometric")
    row = compare_speed(omega, ref, geometric=geo)
    assert row.dynamic_error > 0.02
    assert row.dynamic_error_geometric < 0.02
    assert row.linear_prestressed_error_geometric < 0.02


def test_figure_option_refuses_to_overwrite_and_needs_the_sweep(tmp_path):
    existing = tmp_path / "old.png"
    existing.write_bytes(b"stored")
    for args in (["--figure", str(existing)], ["--speeds", "none", "--figure", str(tmp_path / "new.png")]):
        res = subprocess.run([sys.executable, "-m", "ked_cli", "benchmark", "simeon", *args], capture_output=True,
                             text=True)
        assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, (args, res.stderr)
        assert "--figure" in res.stderr and "Traceback" not in res.stderr
    assert existing.read_bytes() == b"stored"


def test_validity_figure_is_a_png_of_the_rows(tmp_path):
    from ked_bench.figure import write_validity_figure

    rows = [{"speed_ratio": r, "quasi_static_error": 0.3 * r, "linear_error": 0.002, "dynamic_error": None,
             "dynamic_error_geometric": 0.004, "linear_prestressed_error_geometric": 0.002} for r in (0.02, 0.1)]
    out = write_validity_figure(rows, tmp_path / "v.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
