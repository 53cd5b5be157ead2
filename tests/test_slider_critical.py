"""A slider-crank design check over three speeds or more runs the critical-speed sweep as a four-bar's does
(the Floquet analysis of its linear model) and says what it found; it is not skipped silently."""

from __future__ import annotations

import json

from click.testing import CliRunner

from ked_cli.check import check as command


def test_slider_crank_check_reports_critical_speeds_and_amplification_peaks():
    res = CliRunner().invoke(command, ["--linkage", "simeon", "--rpm-range", "1000:3000:3", "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert "Critical speeds, i.e. of weakest damping" in res.output
    assert "Amplification peaks (forced resonance" in res.output
    res = CliRunner().invoke(command, ["--linkage", "simeon", "--rpm-range", "1000:3000:3", "--workers", "1",
                                       "--json"])
    rows = json.loads(res.output)
    assert all("critical_speeds_rpm" in r and "amplification_peaks_rpm" in r for r in rows)


def test_the_sweep_of_a_slider_crank_is_its_linear_models_floquet_analysis():
    # the sweep's max |mu| at a checked speed agrees with the one of the linear solve of that speed (an
    # independent computation: the periodic solve's own Floquet analysis) within the Floquet error
    from ked_check.check import check, spec_for
    from ked_check.critical import floquet_max_abs
    from ked_cli.quasi import slider_source
    from ked_quasi.massmodel import MassModel

    src = slider_source("simeon")
    mm = MassModel("distributed", lumps=5, payload=0.0)
    (row,) = check(src, "source", mm, [2000.0])
    assert abs(floquet_max_abs(spec_for(src, "source", mm, 2000.0))(2000.0) - row.floquet_max_abs) < 5e-3
