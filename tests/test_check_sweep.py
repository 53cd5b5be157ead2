"""ked check's critical-speed sweep: the values it takes from the check's own linear solves, its progress bar."""

from __future__ import annotations

import pytest

from ked_quasi import MassModel
from ked_quasi.massmodel import default_payload


@pytest.mark.parametrize("mass_model, rpm", [("tip", 120.0), ("joints", 240.0)])
def test_a_rows_floquet_value_is_the_sweeps_at_its_step_count(thesis, mass_model, rpm):
    # the sweep takes a row's max |mu| instead of computing it when the row's Floquet refinement ended at
    # the sweep's step count: that is sound only if the check's linear system and the sweep's are the same
    # (scene, settings, damping reference), so the sweep's function at the row's step count must give the
    # row's value exactly
    from compare.check import check, spec_for
    from compare.critical import floquet_max_abs

    mm = MassModel(mass_model, payload=default_payload(mass_model))
    (row,) = check(thesis, "source", mm, [rpm])
    assert row.floquet_steps >= 64
    f = floquet_max_abs(spec_for(thesis, "source", mm, rpm), steps=row.floquet_steps)
    assert f(rpm) == row.floquet_max_abs


def test_the_progress_bar_covers_the_critical_speed_sweep(monkeypatch):
    # `ked check --rpm-range` on a terminal: one bar over the speeds and then the sweep's Floquet
    # evaluations (here shown at once: delay 0), which it names; it ends complete (n = total)
    import sys

    from compare import check as chk
    from ked_cli.check import check as command

    class Terminal:
        def __init__(self):
            self.parts = []

        def isatty(self):
            return True

        def write(self, text):
            self.parts.append(text)
            return len(text)

        def flush(self):
            return None

    bars = []
    original = chk.progress

    def recording(total):
        bar = original(total)
        bars.append(bar)
        return bar

    err = Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(chk, "PROGRESS_DELAY_S", 0.0)
    monkeypatch.setattr(chk, "progress", recording)
    command.main(["--mass-model", "tip", "--rpm-range", "100:200:3"], standalone_mode=False)
    text = "".join(err.parts)
    assert "critical speeds" in text and "ked check" in text
    (bar,) = bars
    assert bar.n == bar.total >= 3 + 2 * 3  # the speeds, then at least the fine sweep's evaluations
